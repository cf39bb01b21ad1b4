//! `shadow_map`: hard shadows from one point by a classic depth map (Williams 1978), with depth
//! bias and percentage-closer filtering (Reeves et al. 1987): the aliasing baseline of seeds 000
//! and 004.
//!
//! The shadow-casting point is the frustum's eye: a point light's position, or the center of an
//! area or sphere light (so an area light gets the hard shadow of its center). Unless an explicit
//! frustum is given, a square frustum of `resolution²` texels is fitted from that point to the
//! valid receivers' bounds ([`LightFrustum::fit`]). Every triangle is rasterized (standard mode,
//! perforated meshes alpha-tested) into a map of linear depth; each receiver is then projected and
//! compared with `pcf × pcf` texels around its own:
//!
//! - a receiver facing away from the eye (`n · (eye − p) <= 0`) gets 0, as for a point light in
//!   the ray-traced definition (DESIGN.md section 3); an invalid receiver (no hit) gets 0;
//! - a receiver nearer than the near plane, or projecting outside the map (possible only with an
//!   explicit frustum), gets 1 (lit): the map says nothing about it;
//! - otherwise the fraction of taps with `receiver_depth − bias <= stored_depth` (taps outside the
//!   map hold `+inf` and count as lit).
//!
//! **Bias.** `bias = Some(b)` subtracts a constant `b` world units of linear depth. `None` (the
//! default) uses [`auto_bias`], a slope-scaled bias that removes self-shadowing acne on flat and
//! curved receivers for every PCF size: the depth of the receiver's own surface can differ from the
//! value stored at a tap `k` texels away by at most about `(k + 0.71) texels × tan θ` (θ between
//! the receiver's normal and the direction to the eye), so the auto bias is
//! `1.5 · (r + 1) · texel_world_size(depth) · min(tan θ, 20) + 1e-4 · depth` with `r = (pcf − 1)/2`
//! the PCF radius; the relative term absorbs float round-off of the receiver positions. Like every
//! bias it lets light leak over that distance at contact points ("peter panning").

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::light::lights::Light;
use crate::raster::depth::{rasterize_depth, DepthMap, LightFrustum, RasterOptions};
use crate::stats::Stats;
use glam::Vec3;
use rayon::prelude::*;

/// Options of [`shadow_map`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowMapOptions {
    /// Map side in texels when the frustum is fitted (default 1024); ignored with `frustum`.
    pub resolution: usize,
    /// Constant depth bias in world units (>= 0), or `None` for [`auto_bias`] (default).
    pub bias: Option<f32>,
    /// PCF taps per side, odd: 1 = a single tap (pure hard shadow, default), 3 = 3 × 3, 5 = 5 × 5.
    pub pcf: usize,
    /// An explicit light frustum; its eye is the shadow-casting point. `None`: fitted.
    pub frustum: Option<LightFrustum>,
}

impl Default for ShadowMapOptions {
    fn default() -> Self {
        Self { resolution: 1024, bias: None, pcf: 1, frustum: None }
    }
}

/// The largest PCF kernel side accepted.
pub const MAX_PCF: usize = 63;

impl ShadowMapOptions {
    /// Checks every option (the frustum too).
    pub fn validate(&self) -> Result<()> {
        if !(1..=crate::raster::depth::MAX_RESOLUTION).contains(&self.resolution) {
            return Err(Error::invalid(
                "resolution",
                format!("must be in 1..={}, got {}", crate::raster::depth::MAX_RESOLUTION, self.resolution),
            ));
        }
        if let Some(b) = self.bias {
            if !(b.is_finite() && b >= 0.0) {
                return Err(Error::invalid("bias", format!("must be finite and >= 0 (or None for auto), got {b}")));
            }
        }
        if self.pcf & 1 == 0 || self.pcf > MAX_PCF {
            return Err(Error::invalid("pcf", format!("must be odd and in 1..={MAX_PCF} (taps per side), got {}", self.pcf)));
        }
        match &self.frustum {
            Some(f) => f.validate(),
            None => Ok(()),
        }
    }
}

/// The slope-scaled depth bias (world units of linear depth) for a receiver at `p` with unit
/// normal `n`, at linear depth `depth`, read with a PCF kernel of `pcf` taps per side (see the
/// module documentation).
pub fn auto_bias(frustum: &LightFrustum, p: Vec3, n: Vec3, depth: f32, pcf: usize) -> f32 {
    let to_eye = (frustum.eye - p).normalize_or_zero();
    let cos = n.dot(to_eye).abs().max(1e-6);
    let tan = ((1.0 - cos * cos).max(0.0).sqrt() / cos).min(20.0);
    let radius = (pcf.saturating_sub(1) / 2) as f32;
    1.5 * (radius + 1.0) * frustum.texel_world_size(depth) * tan + 1e-4 * depth
}

/// Percentage-closer filtering: the fraction of the `pcf × pcf` texels centered on the texel that
/// contains `(sx, sy)` whose stored depth is `>= depth` (taps outside the map are lit). `depth` is
/// the receiver's linear depth with the bias already subtracted.
pub fn pcf_lookup(map: &DepthMap, sx: f32, sy: f32, depth: f32, pcf: usize) -> f32 {
    let r = (pcf / 2) as i64;
    let (cx, cy) = (sx.floor() as i64, sy.floor() as i64);
    let mut lit = 0u32;
    for dy in -r..=r {
        for dx in -r..=r {
            lit += u32::from(depth <= map.get(cx + dx, cy + dy));
        }
    }
    lit as f32 / ((2 * r + 1) * (2 * r + 1)) as f32
}

/// Hard-shadow visibility of every receiver from the light's center by a shadow map.
///
/// Returns the visibility (one value in [0, 1] per receiver, receivers' order) and stats:
/// `render_seconds`, `lookup_seconds`, `resolution` (map width), `texels_drawn` (texels holding
/// a depth), `fragments` (fragments rasterized).
///
/// Errors: invalid options; no fitting frustum (light inside the receivers' bounds: pass
/// `frustum`); `TooLarge` past the memory limit.
pub fn shadow_map(scene: &Scene, light: &Light, receivers: &Receivers, opts: &ShadowMapOptions) -> Result<(Vec<f32>, Stats)> {
    opts.validate()?;
    let mut stats = Stats::default();
    let frustum = match (opts.frustum, receivers.bounds()) {
        (Some(f), _) => f,
        (None, Some(bounds)) => LightFrustum::for_light(light, bounds, opts.resolution)?,
        (None, None) => {
            for name in ["render_seconds", "lookup_seconds", "resolution", "texels_drawn", "fragments"] {
                stats.set(name, 0.0);
            }
            return Ok((vec![0.0; receivers.len()], stats));
        }
    };
    let map = stats.time("render", || rasterize_depth(scene, &frustum, &RasterOptions::default()))?;
    let vis = stats.time("lookup", || lookup_all(&map, &frustum, receivers, opts));
    stats.set("resolution", frustum.width as f64);
    stats.set("texels_drawn", map.drawn_texels() as f64);
    stats.set("fragments", map.fragments as f64);
    Ok((vis, stats))
}

fn lookup_all(map: &DepthMap, frustum: &LightFrustum, rx: &Receivers, opts: &ShadowMapOptions) -> Vec<f32> {
    (0..rx.len())
        .into_par_iter()
        .map(|i| if rx.valid[i] { lookup(map, frustum, rx.points[i], rx.normals[i], opts) } else { 0.0 })
        .collect()
}

/// Visibility of one valid receiver (see the module documentation for the rules).
fn lookup(map: &DepthMap, frustum: &LightFrustum, p: Vec3, n: Vec3, opts: &ShadowMapOptions) -> f32 {
    if n.dot(frustum.eye - p) <= 0.0 {
        return 0.0;
    }
    let Some(s) = frustum.project(p) else { return 1.0 };
    if !(s.x >= 0.0 && s.y >= 0.0 && s.x < map.width as f32 && s.y < map.height as f32) {
        return 1.0;
    }
    let bias = opts.bias.unwrap_or_else(|| auto_bias(frustum, p, n, s.z, opts.pcf));
    pcf_lookup(map, s.x, s.y, s.z - bias, opts.pcf)
}
