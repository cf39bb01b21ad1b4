//! `shadow_map`: hard shadows from one point by a classic depth map (Williams 1978), with depth
//! bias and percentage-closer filtering (Reeves et al. 1987): the aliasing baseline of Sintorn et
//! al. 2008 (Sample Based Visibility for Soft Shadows) and Marrs et al. 2018 (View-warped
//! Multi-view Soft Shadows).
//!
//! The shadow-casting point is the frustum's eye: a point light's position, or the center of an
//! area or sphere light (so an area light gets the hard shadow of its center). Unless an explicit
//! frustum is given, a square frustum of `resolution²` texels is fitted from that point to the
//! valid receivers' bounds ([`LightFrustum::fit`]), or, for a light among the receivers, one per
//! face of a cube around it ([`crate::raster::cube`]). Every triangle is rasterized (standard mode,
//! perforated meshes alpha-tested) into a map of linear depth; each receiver is then projected and
//! compared with `pcf × pcf` texels around its own:
//!
//! - a receiver facing away from the eye (`n · (eye − p) <= 0`) gets 0, as for a point light in
//!   the ray-traced definition (`docs/design.md` section 3); an invalid receiver (no hit) gets 0;
//! - a receiver nearer than the near plane, or projecting outside the map (possible only with an
//!   explicit frustum), gets 1 (lit): the map says nothing about it;
//! - otherwise the fraction of taps with `receiver_depth − bias <= stored_depth` (taps outside the
//!   map hold `+inf` and count as lit).
//!
//! **Bias.** `bias = Some(b)` subtracts a constant `b` world units of linear depth. `None` (the
//! default) compares each tap with the receiver's tangent plane
//! ([`ReceiverDepth`](crate::raster::pcf::ReceiverDepth)), which removes
//! self-shadowing acne on flat and curved receivers for every PCF size.

use crate::backend::Backend;
use crate::error::Result;
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::gpu;
use crate::gpu::multiview::Lighting;
use crate::interrupt;
use crate::light::lights::Light;
use crate::limits::Peak;
use crate::raster::cube::{self, by_light_face};
use crate::raster::depth::{raster_peak, raster_work, rasterize_depth, DepthMap, RasterOptions};
use crate::raster::frustum::check_resolution;
use crate::raster::frustum::LightFrustum;
use crate::raster::pcf::{DepthBias, PcfKernel};
use crate::stats::Stats;

/// Options of [`shadow_map`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowMapOptions {
    /// Map side in texels when the frustum is fitted (default 1024); ignored with `frustum`.
    pub resolution: usize,
    /// Constant depth bias in world units (>= 0), or `None` for the receiver's tangent plane per tap (default).
    pub bias: Option<f32>,
    /// PCF taps per side, odd: 1 = a single tap (pure hard shadow, default), 3 = 3 × 3, 5 = 5 × 5.
    pub pcf: usize,
    /// An explicit light frustum; its eye is the shadow-casting point. `None`: fitted.
    pub frustum: Option<LightFrustum>,
    /// Where the lookups run (the map is rasterized on the CPU either way): the CPU, or the GPU
    /// (`gpu/multiview.wgsl`, the lighting pass `mvr` and `vwss` share, with one view).
    pub backend: Backend,
}

impl Default for ShadowMapOptions {
    fn default() -> Self {
        Self {
            resolution: 1024,
            bias: None,
            pcf: 1,
            frustum: None,
            backend: Backend::Cpu,
        }
    }
}

impl ShadowMapOptions {
    /// Checks every option (the frustum too).
    pub fn validate(&self) -> Result<()> {
        check_resolution("resolution", self.resolution)?;
        DepthBias::new(self.bias)?;
        PcfKernel::square(self.pcf)?;
        match &self.frustum {
            Some(f) => f.validate(),
            None => Ok(()),
        }
    }
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "render_seconds",
    "lookup_seconds",
    "resolution",
    "texels_drawn",
    "fragments",
    "light_faces",
];

/// Hard-shadow visibility of every receiver from the light's center by a shadow map.
///
/// Returns the visibility (one value in [0, 1] per receiver, receivers' order) and stats:
/// `render_seconds`, `lookup_seconds`, `resolution` (map width), `texels_drawn` (texels holding
/// a depth), `fragments` (fragments rasterized).
///
/// A light among the receivers (no frustum holds their bounds) gets a map per face of a cube
/// around its center ([`crate::raster::cube`]), each receiver looked up in its own face's, with
/// the stat `light_faces` (1 for one fitted frustum).
///
/// Errors: invalid options; `TooLarge` past the memory limit.
pub fn shadow_map(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    opts: &ShadowMapOptions,
) -> Result<(Vec<f32>, Stats)> {
    super::refuse_textured(light, "shadow_map")?;
    opts.validate()?;
    if let Some(frustum) = opts.frustum {
        return through(scene, receivers, &frustum, opts);
    }
    by_light_face(light, receivers, |part, face| {
        let frustum = match (face, part.bounds()) {
            (Some(face), _) => {
                cube::face_frustum(light.center(), face, part.valid_points(), opts.resolution)?
            }
            (None, Some(bounds)) => LightFrustum::for_light(light, bounds, opts.resolution)?,
            (None, None) => {
                return Ok((vec![0.0; part.len()], Stats::declared(STATS)));
            }
        };
        through(scene, part, &frustum, opts)
    })
}

/// [`shadow_map`] through one frustum.
fn through(
    scene: &Scene,
    receivers: &Receivers,
    frustum: &LightFrustum,
    opts: &ShadowMapOptions,
) -> Result<(Vec<f32>, Stats)> {
    let mut stats = Stats::declared(STATS);
    Peak::default()
        .buffer(&[receivers.len() as u64, 4])
        .and(raster_peak(scene, frustum.width, frustum.height))
        .check("shadow_map", &mut stats)?;
    raster_work(scene, frustum.width, frustum.height)
        .loop_of(&[receivers.len() as u64, (opts.pcf as u64).pow(2)])
        .check("shadow_map", &mut stats)?;
    let map = stats.time("render", || {
        rasterize_depth(scene, frustum, &RasterOptions::default())
    })?;
    let vis = match opts.backend {
        Backend::Gpu => gpu::timed_stage(&mut stats, "lookup", || {
            lookup_all(&map, frustum, receivers, opts)
        })?,
        Backend::Cpu => stats.time("lookup", || lookup_all(&map, frustum, receivers, opts))?,
    };
    stats.set("resolution", frustum.width as f64);
    stats.set("texels_drawn", map.drawn_texels() as f64);
    stats.set("fragments", map.fragments as f64);
    Ok((vis, stats))
}

fn lookup_all(
    map: &DepthMap,
    frustum: &LightFrustum,
    rx: &Receivers,
    opts: &ShadowMapOptions,
) -> Result<Vec<f32>> {
    let kernel = PcfKernel::square(opts.pcf)?;
    let bias = DepthBias::new(opts.bias)?;
    if opts.backend == Backend::Gpu {
        // The lighting pass with one view of weight 1: sums are the lit fractions themselves.
        let lighting = Lighting::new(rx, &kernel, bias)?;
        lighting.accumulate_maps(&[map], std::slice::from_ref(frustum), &[1.0])?;
        return lighting.sums();
    }
    let taps = (opts.pcf as u64).pow(2);
    interrupt::par_map(rx.len(), taps, |i| {
        if rx.valid[i] {
            kernel.visibility(map, frustum, rx.points[i], rx.normals[i], bias)
        } else {
            0.0
        }
    })
}
