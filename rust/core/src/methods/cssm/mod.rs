//! `cssm`: convolution soft shadow maps (Annen, Dong, Mertens, Bekaert, Seidel and Kautz 2008,
//! Real-time, All-Frequency Shadows in Dynamic Scenes), built on convolution shadow maps (Annen et
//! al. 2007).
//!
//! One depth map is rendered from the light's center. Its linear depths are normalized to
//! `ẑ ∈ [0, 1]` over the depth range of the map's occluders and the receivers (empty texels read as
//! `ẑ = 1`, the far end), and so is each receiver's depth `d̂`.
//!
//! **CSM** (section 3.1, eq. 1–3). The shadow test `f(d̂, ẑ) = 1` if `d̂ <= ẑ` (lit), else 0, is the
//! square wave `f ≈ 1/2 + 2 Σ_{k=1..M} sin(c_k (ẑ − d̂)) / c_k`, `c_k = π (2k − 1)` (the
//! appendix's eq. 10), a separable series:
//! `sin(c_k (ẑ − d̂)) = cos(c_k d̂) sin(c_k ẑ) − sin(c_k d̂) cos(c_k ẑ)`. The basis images
//! `cos(c_k ẑ)`, `sin(c_k ẑ)` are prefiltered, so a box filter `w` of any size applied to the
//! shadow test costs one lookup per basis image: `(w ∗ f)(d̂) = 1/2 + 2 Σ (cos(c_k d̂) (w ∗ sin c_k ẑ)
//! − sin(c_k d̂) (w ∗ cos c_k ẑ)) / c_k`.
//!
//! **CSM-Z** (section 3.2, eq. 4–8, appendix eq. 11). The average depth of the blockers inside a
//! filter is `z_avg = (w ∗ (ẑ f̄)) / (w ∗ f̄)` with the complementary test `f̄ = 1 − f`, and
//! `ẑ f̄ ≈ ẑ/2 − 2 Σ (cos(c_k d̂) ẑ sin(c_k ẑ) − sin(c_k d̂) ẑ cos(c_k ẑ)) / c_k` needs the basis
//! images `ẑ cos(c_k ẑ)`, `ẑ sin(c_k ẑ)` and the plain `ẑ` image. So `4M + 1` images in all.
//!
//! **Prefiltering** by a summed-area table (f64; exact box means of any size and aspect, see
//! [`SummedAreaTable`]) or a mipmap (trilinear, box footprints; a rectangle is covered by
//! square lookups along its long side, as anisotropic texture filtering does).
//!
//! **Filter sizes** (Figure 2). The initial filter is the light's footprint through the search
//! plane `z_n` ([`LightFootprint`]): the paper intersects the cone from the receiver to the light
//! with "the near plane"; by default `z_n` is the nearest depth stored in the map (no occluder
//! lies nearer, and a plane nearer still only widens the filter), or `near`. CSM-Z over it gives
//! `z_avg`; the final filter is the footprint through `z_avg` (the parallel-planes penumbra,
//! `f_w = D (d − z_avg) / z_avg` mapped to the map). Rectangular lights get rectangular
//! (anisotropic) filters.
//!
//! **Ringing suppression** (section 3.3, Figure 3: shift, scale, clamp). The truncated series
//! `S_M(t) = 1/2 + 2 Σ sin(c_k t) / c_k` of the step at `t = ẑ − d̂` is 1/2 at the receiver's own
//! depth (`t = 0`), rises over a width of about `1/M` and rings around 0 and 1 (Gibbs: up to 1.09
//! and down to −0.09). The test is evaluated at `d̂ − offset` (shifted towards the light), the
//! filtered value scaled about 1/2 by `scale`, then clamped to `[0, 1]`. The default shift is
//! [`first_lit_offset`]: the `t₁` where `S_M` first reaches 1 (`0.29/M` to `0.31/M`: 0.0763 at
//! `M = 4`, 0.0192 at `M = 16`). There a receiver's own surface tests exactly 1: lit texels count
//! 1 in every filter, so a filter half over lit texels and half over blockers (far ahead, ≈ 0)
//! reads 1/2, the parallel-planes penumbra of the paper's exact case. The former default, the
//! step's half width `0.5/M`, put the receiver's own depth on the overshoot (`S_M ≈ 1.09`): every
//! partly covered filter read too bright, and the clamp cut the penumbra's lit end, about 18%
//! narrower on parallel plates. `scale` (any value > 0, default 1) trades the other way: above 1
//! it lifts the lit side's troughs (`S_M ≥ 0.95` past `t₁`) towards 1 and narrows the penumbra by
//! the same factor, below 1 it compensates an overshooting shift. The shift also ignores
//! occluders within `offset` of the receiver (contact and self shadows leak by that much).
//!
//! **Sharpening** (eq. 9, Figure 4): `V ← V^p`, `p = 1 + A · exp(−B (d̂ − ẑ_avg))`, meant to darken
//! contact shadows where the low-order series leaks. It is off by default. Measured against 1024
//! ray-traced samples at 128² (order 4, the default shift), `A = 30` raised the RMSE of the
//! columns from 0.031 to 0.047 / 0.034 / 0.032 at `B = 10 / 20 / 80`, of the torus knot from
//! 0.072 to 0.249 / 0.216 / 0.205 and of the bunny from 0.119 to 0.216 / 0.171 / 0.140. Reading
//! `d̂ − ẑ_avg` in world units instead (`B` times the depth span) changes little (torus knot
//! 0.214 at `B = 10`), so it is not our normalization: wherever the average blocker lies near
//! the receiver `p` approaches `1 + A`, and on closed curved meshes that is every self-shadowed
//! pixel near its terminator, not only contacts. Contacts under the columns do get darker, as
//! the paper's Figures 4 and 9 show.
//!
//! A receiver facing away from the light's center gets 0, as in `shadow_map`; one whose initial
//! filter finds no blocker (`w ∗ f̄` below 1e-4) is lit.

#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(not(feature = "gpu"))]
#[path = "no_gpu.rs"]
pub mod gpu;

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::interrupt;
use crate::light::lights::Light;
use crate::limits::{self, Peak};
use crate::raster::cube::{self, by_light_face};
use crate::raster::depth::{raster_peak, raster_work, rasterize_depth, DepthMap, RasterOptions};
use crate::raster::footprint::LightFootprint;
use crate::raster::frustum::{check_resolution, LightFrustum};
use crate::raster::pyramid::{MipMap, SummedAreaTable};
use crate::stats::Stats;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// The largest Fourier order accepted.
pub const MAX_ORDER: usize = 64;

/// How the basis images are prefiltered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Prefilter {
    /// Summed-area table: exact box means of any size.
    #[default]
    Sat,
    /// Mipmap with trilinear lookups.
    Mipmap,
}

/// Options of [`cssm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CssmOptions {
    /// Depth-map side in texels (default 512).
    pub resolution: usize,
    /// Fourier order `M` (default 4; the paper uses 4 and 16).
    pub order: usize,
    pub prefilter: Prefilter,
    /// Plane of the initial filter (linear depth from the light's center); `None`: the nearest
    /// depth in the map.
    pub near: Option<f32>,
    /// Depth shift of the shadow test towards the light, in normalized depth; `None`:
    /// [`first_lit_offset`], where the series at the receiver's own depth first reaches 1.
    pub offset: Option<f32>,
    /// Scale of the filtered test about 1/2 before clamping (> 0; default 1: clamping only).
    pub scale: f32,
    /// Sharpening strength `A` of eq. 9 (default 0: off; the paper's Figure 4 uses 30).
    pub sharpen_a: f32,
    /// Sharpening falloff `B` of eq. 9, per unit of normalized depth (default 10, Figure 4).
    pub sharpen_b: f32,
    /// Where the basis images, their table and the lookups run (the shadow map is the CPU's):
    /// the CPU, or the GPU (`methods/cssm/cssm.wgsl`; summed-area tables only, f32 trigonometry).
    pub backend: Backend,
}

impl Default for CssmOptions {
    fn default() -> Self {
        Self {
            resolution: 512,
            order: 4,
            prefilter: Prefilter::Sat,
            near: None,
            offset: None,
            scale: 1.0,
            sharpen_a: 0.0,
            sharpen_b: 10.0,
            backend: Backend::Cpu,
        }
    }
}

impl CssmOptions {
    /// The depth shift in normalized depth.
    pub fn offset(&self) -> f32 {
        self.offset
            .unwrap_or_else(|| first_lit_offset(self.order) as f32)
    }

    fn validate(&self) -> Result<()> {
        check_resolution("resolution", self.resolution)?;
        if !(1..=MAX_ORDER).contains(&self.order) {
            return Err(Error::invalid(
                "order",
                format!("must be in 1..={MAX_ORDER}, got {}", self.order),
            ));
        }
        if self.backend == Backend::Gpu && self.prefilter != Prefilter::Sat {
            return Err(Error::unsupported(
                "prefilter",
                "the GPU prefilters by summed-area tables: use prefilter='sat' with backend='gpu'",
            ));
        }
        if let Some(z) = self.near {
            if !(z.is_finite() && z > 0.0) {
                return Err(Error::invalid(
                    "near",
                    format!("must be finite and > 0 (or None), got {z}"),
                ));
            }
        }
        let checks = [
            (
                "offset",
                self.offset(),
                self.offset().is_finite() && (0.0..0.5).contains(&self.offset()),
            ),
            (
                "scale",
                self.scale,
                self.scale.is_finite() && self.scale > 0.0,
            ),
            (
                "sharpen_a",
                self.sharpen_a,
                self.sharpen_a.is_finite() && self.sharpen_a >= 0.0,
            ),
            (
                "sharpen_b",
                self.sharpen_b,
                self.sharpen_b.is_finite() && self.sharpen_b >= 0.0,
            ),
        ];
        for (arg, value, ok) in checks {
            if !ok {
                let rule = match arg {
                    "offset" => "in [0, 0.5)",
                    "scale" => "> 0",
                    _ => ">= 0",
                };
                return Err(Error::invalid(
                    arg,
                    format!("must be finite and {rule}, got {value}"),
                ));
            }
        }
        Ok(())
    }
}

/// Linear depth ↔ normalized depth `ẑ ∈ [0, 1]`.
#[derive(Debug, Clone, Copy)]
struct DepthRange {
    lo: f32,
    span: f32,
}

impl DepthRange {
    fn normalize(&self, z: f32) -> f64 {
        if z.is_finite() {
            (f64::from((z - self.lo) / self.span)).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// The `4M + 1` basis images of CSM and CSM-Z, interleaved per texel: `cos(c_k ẑ)`, `sin(c_k ẑ)`
/// for each k, then `ẑ cos(c_k ẑ)`, `ẑ sin(c_k ẑ)` for each k, then `ẑ`.
fn basis_images(map: &DepthMap, range: DepthRange, order: usize) -> Result<Vec<f32>> {
    let channels = 4 * order + 1;
    limits::check_memory(
        "cssm basis images",
        limits::bytes(&[map.depth.len() as u64, channels as u64, 4 + 8]),
    )?;
    let mut data = vec![0.0f32; map.depth.len() * channels];
    data.par_chunks_mut(channels)
        .zip(&map.depth)
        .for_each(|(out, &z)| {
            let zn = range.normalize(z);
            for k in 0..order {
                let (s, c) = (coefficient(k) * zn).sin_cos();
                out[2 * k] = c as f32;
                out[2 * k + 1] = s as f32;
                out[2 * order + 2 * k] = (zn * c) as f32;
                out[2 * order + 2 * k + 1] = (zn * s) as f32;
            }
            out[4 * order] = zn as f32;
        });
    Ok(data)
}

/// `c_k = π (2k − 1)` for k = index + 1.
fn coefficient(index: usize) -> f64 {
    PI * (2 * index + 1) as f64
}

/// The truncated series of the lit step, `S_M(t) = 1/2 + 2 Σ_{k=1..M} sin(c_k t) / c_k`, at
/// `t = ẑ − d̂`.
pub fn step_series(order: usize, t: f64) -> f64 {
    0.5 + 2.0
        * (0..order)
            .map(|k| (coefficient(k) * t).sin() / coefficient(k))
            .sum::<f64>()
}

/// The smallest `t > 0` with `S_M(t) = 1`: the default ringing-suppression shift, at which a
/// receiver's own surface tests exactly lit. `S_M` rises monotonically on `(0, 1/(2M))` (its
/// derivative is `sin(2πMt) / sin(πt) > 0` there) to its Gibbs peak above 1 at `1/(2M)`, so
/// bisection on that interval finds it.
pub fn first_lit_offset(order: usize) -> f64 {
    let (mut lo, mut hi) = (0.0, 0.5 / order.max(1) as f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if step_series(order, mid) < 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The prefiltered basis images.
enum Filtered {
    Sat(SummedAreaTable),
    Mipmap(MipMap),
}

impl Filtered {
    /// Box means of every basis image over `center ± half` (texel units) into `out`. A filter
    /// narrower than a texel reads the texel containing `center`, so a point light gives exactly
    /// the (CSM-reconstructed) hard shadow test of that texel. Returns the taps read (a box of
    /// the summed-area table, or a trilinear lookup of the mipmap, each over every basis image).
    fn box_mean(&self, center: Vec2, half: Vec2, out: &mut [f64], scratch: &mut [f32]) -> usize {
        let (mut c, h) = (
            center.as_dvec2(),
            half.as_dvec2().max(glam::DVec2::splat(0.5)),
        );
        if half.max_element() < 0.5 {
            c = c.floor() + 0.5;
        }
        match self {
            Filtered::Sat(sat) => {
                sat.box_mean_into(c.x - h.x, c.y - h.y, c.x + h.x, c.y + h.y, out);
                1
            }
            Filtered::Mipmap(mip) => {
                // Square trilinear lookups of the short side, spread along the long side.
                let short = h.x.min(h.y);
                let steps = ((h.x.max(h.y) / short).ceil() as usize).max(1);
                out.iter_mut().for_each(|o| *o = 0.0);
                for i in 0..steps {
                    let t = (i as f64 + 0.5) / steps as f64 * 2.0 - 1.0;
                    let along = if h.x >= h.y {
                        glam::DVec2::new(t * (h.x - short), 0.0)
                    } else {
                        glam::DVec2::new(0.0, t * (h.y - short))
                    };
                    let p = c + along;
                    mip.trilinear_into(p.x, p.y, 2.0 * short, scratch);
                    out.iter_mut()
                        .zip(scratch.iter())
                        .for_each(|(o, s)| *o += f64::from(*s) / steps as f64);
                }
                steps
            }
        }
    }
}

/// The filtered shadow test `w ∗ f` and the filtered `w ∗ (ẑ f̄)` at normalized receiver depth
/// `d` from the box means `b` of the basis images.
fn reconstruct(b: &[f64], order: usize, d: f64) -> (f64, f64) {
    let (mut test, mut z_part) = (0.5, 0.5 * b[4 * order]);
    for k in 0..order {
        let ck = coefficient(k);
        let (s, c) = (ck * d).sin_cos();
        test += 2.0 * (c * b[2 * k + 1] - s * b[2 * k]) / ck;
        z_part -= 2.0 * (c * b[2 * order + 2 * k + 1] - s * b[2 * order + 2 * k]) / ck;
    }
    (test, z_part)
}

/// What every receiver's lookup shares, as `Params` in `cssm.wgsl` needs it.
#[derive(Debug, Clone, Copy)]
pub struct Shared {
    pub order: usize,
    pub depth_lo: f32,
    pub depth_span: f32,
    pub near: f32,
    pub scale: f32,
    pub sharpen_a: f32,
    pub sharpen_b: f32,
    /// [`crate::raster::footprint::LightFootprint`]'s half extents per unit `(z_r − z) / (z_r z)`.
    pub footprint: Vec2,
}

/// A receiver's lookup start: done (its visibility), or the filters' center and initial half
/// extents (texels), its linear depth and its normalized test depth.
#[derive(Debug, Clone, Copy)]
pub enum Start {
    Done(f32),
    Look {
        center: Vec2,
        half: Vec2,
        depth: f32,
        d: f64,
    },
}

/// What every receiver's lookup shares but the filtered maps.
struct Projection<'a> {
    frustum: &'a LightFrustum,
    range: DepthRange,
    footprint: LightFootprint,
    near: f32,
    /// The ringing-suppression shift, found once per call (a bisection over the series).
    offset: f32,
    opts: &'a CssmOptions,
}

impl Projection<'_> {
    /// The receiver's visibility when no filter is needed (facing away from the light's center:
    /// 0; outside the map or nearer than the search plane: 1), else where the filters read.
    fn start(&self, p: Vec3, n: Vec3) -> Start {
        if n.dot(self.frustum.eye - p) <= 0.0 {
            return Start::Done(0.0);
        }
        let Some(s) = self.frustum.project(p) else {
            return Start::Done(1.0);
        };
        let map = Vec2::new(self.frustum.width as f32, self.frustum.height as f32);
        if !(s.x >= 0.0 && s.y >= 0.0 && s.x < map.x && s.y < map.y) || s.z <= self.near {
            return Start::Done(1.0);
        }
        let d = (self.range.normalize(s.z) - f64::from(self.offset)).max(0.0);
        Start::Look {
            center: Vec2::new(s.x, s.y),
            half: self.footprint.through(s.z, self.near),
            depth: s.z,
            d,
        }
    }

    /// `Params` of the GPU lookup.
    fn shared(&self) -> Shared {
        Shared {
            order: self.opts.order,
            depth_lo: self.range.lo,
            depth_span: self.range.span,
            near: self.near,
            scale: self.opts.scale,
            sharpen_a: self.opts.sharpen_a,
            sharpen_b: self.opts.sharpen_b,
            footprint: self.footprint.texels(),
        }
    }
}

/// What every receiver's CPU lookup shares.
struct CssmLookup<'a> {
    filtered: &'a Filtered,
    projection: Projection<'a>,
}

impl CssmLookup<'_> {
    /// The receiver's visibility and the taps its filters read.
    fn receiver(&self, p: Vec3, n: Vec3) -> (f32, usize) {
        let (center, half, depth, d) = match self.projection.start(p, n) {
            Start::Done(v) => return (v, 0),
            Start::Look {
                center,
                half,
                depth,
                d,
            } => (center, half, depth, d),
        };
        let Projection {
            range,
            footprint,
            near,
            opts,
            ..
        } = &self.projection;
        let channels = 4 * opts.order + 1;
        let (mut means, mut scratch) = (vec![0.0f64; channels], vec![0.0f32; channels]);
        // Stage 1: the blockers' average depth over the initial filter (Figure 2a-b).
        let mut taps = self
            .filtered
            .box_mean(center, half, &mut means, &mut scratch);
        let (test, z_part) = reconstruct(&means, opts.order, d);
        let blocked = 1.0 - test;
        if blocked < 1e-4 {
            return (1.0, taps);
        }
        let z_avg_n = (z_part / blocked).clamp(0.0, d);
        let z_avg = (range.lo as f64 + z_avg_n * range.span as f64).max(f64::from(*near)) as f32;
        // Stage 2: the filtered shadow test over the penumbra (Figure 2c-d).
        taps += self.filtered.box_mean(
            center,
            footprint.through(depth, z_avg),
            &mut means,
            &mut scratch,
        );
        let (test, _) = reconstruct(&means, opts.order, d);
        let v = (f64::from(opts.scale) * (test - 0.5) + 0.5).clamp(0.0, 1.0);
        let p = 1.0
            + f64::from(opts.sharpen_a)
                * (-f64::from(opts.sharpen_b) * (d - z_avg_n).max(0.0)).exp();
        (v.powf(p) as f32, taps)
    }
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "shadow_map_seconds",
    "basis_seconds",
    "prefilter_seconds",
    "lookup_seconds",
    "search_near",
    "resolution",
    "basis_images",
    "taps",
    "depth_min",
    "depth_span",
    "light_faces",
];

/// Soft-shadow visibility of every receiver by convolution soft shadow maps.
///
/// Returns the visibility (receivers' order) and stats: `shadow_map_seconds`, `basis_seconds`,
/// `prefilter_seconds`, `lookup_seconds`, `resolution`, `basis_images` (`4M + 1`), `search_near`,
/// the normalization `depth_min`, `depth_span` (`ẑ = (z − depth_min) / depth_span`), and `taps`
/// (filtered lookups of all the basis images, two per receiver in penumbra: Figure 2; counted on
/// the CPU backend only, NaN on the GPU).
///
/// A light among the receivers gets a map per face of a cube around its center
/// ([`crate::raster::cube`]), each with its own basis images and normalization, every receiver
/// filtered in its own face's; stat `light_faces`.
///
/// Errors: invalid options; `TooLarge`.
pub fn cssm(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    opts: &CssmOptions,
) -> Result<(Vec<f32>, Stats)> {
    super::refuse_textured(light, "cssm")?;
    opts.validate()?;
    by_light_face(light, receivers, |part, face| {
        cssm_view(scene, light, part, face, opts)
    })
}

/// [`cssm`] on the receivers one light frustum serves: fitted, or cube face `face`'s.
fn cssm_view(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    face: Option<usize>,
    opts: &CssmOptions,
) -> Result<(Vec<f32>, Stats)> {
    let mut stats = Stats::declared(STATS);
    stats.set("resolution", opts.resolution as f64);
    stats.set("basis_images", (4 * opts.order + 1) as f64);
    let Some(bounds) = receivers.bounds() else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    let frustum = cube::footprint_frustum(light, receivers, face, bounds, opts.resolution)?;
    Peak::default()
        .buffer(&[receivers.len() as u64, 4])
        .and(cssm_peak(scene, frustum.width, frustum.height, opts))
        .check("cssm", &mut stats)?;
    // The basis images and their prefilter per channel; each receiver's search and lookups
    // (a few tens of prefiltered fetches of every channel).
    let channel_count = (4 * opts.order + 1) as u64;
    raster_work(scene, frustum.width, frustum.height)
        .loop_of(&[
            frustum.width as u64,
            frustum.height as u64,
            channel_count,
            4,
        ])
        .loop_of(&[receivers.len() as u64, channel_count, 32])
        .check("cssm", &mut stats)?;
    let map = stats.time("shadow_map", || {
        rasterize_depth(scene, &frustum, &RasterOptions::default())
    })?;
    let range = depth_range(&map, &frustum, receivers);
    let near = opts.near.unwrap_or(range.lo).max(frustum.near);
    stats.set("search_near", f64::from(near));
    stats.set("depth_min", f64::from(range.lo));
    stats.set("depth_span", f64::from(range.span));
    let projection = Projection {
        frustum: &frustum,
        range,
        footprint: LightFootprint::new(&frustum, light),
        near,
        offset: opts.offset(),
        opts,
    };
    if opts.backend == Backend::Gpu {
        let starts: Vec<Start> = (0..receivers.len())
            .into_par_iter()
            .map(|i| {
                if receivers.valid[i] {
                    projection.start(receivers.points[i], receivers.normals[i])
                } else {
                    Start::Done(0.0)
                }
            })
            .collect();
        let (vis, [basis, prefilter, lookup]) = gpu::cssm(&map, &projection.shared(), &starts)?;
        for (name, seconds) in [
            ("basis_seconds", basis),
            ("prefilter_seconds", prefilter),
            ("lookup_seconds", lookup),
        ] {
            stats.set(name, seconds);
        }
        // The shader does not count its taps: NaN says "not counted", where 0 would lie.
        stats.set("taps", f64::NAN);
        return Ok((vis, stats));
    }
    let basis = stats.time("basis", || basis_images(&map, range, opts.order))?;
    let channels = 4 * opts.order + 1;
    let filtered = stats.time("prefilter", || -> Result<Filtered> {
        Ok(match opts.prefilter {
            Prefilter::Sat => Filtered::Sat(SummedAreaTable::new(
                map.width, map.height, channels, &basis,
            )?),
            Prefilter::Mipmap => {
                Filtered::Mipmap(MipMap::new(map.width, map.height, channels, &basis)?)
            }
        })
    })?;
    drop(basis);
    let lookup = CssmLookup {
        filtered: &filtered,
        projection,
    };
    let looked_up = stats.time("lookup", || {
        interrupt::par_map(receivers.len(), channel_count * 32, |i| {
            if receivers.valid[i] {
                lookup.receiver(receivers.points[i], receivers.normals[i])
            } else {
                (0.0, 0)
            }
        })
    })?;
    stats.add("taps", looked_up.iter().map(|(_, t)| *t as f64).sum());
    Ok((looked_up.into_iter().map(|(v, _)| v).collect(), stats))
}

/// The memory of the maps of [`cssm`] at `width × height`: the shadow map, then its basis images
/// and their prefiltered form, all held together while the prefilter is built.
fn cssm_peak(scene: &Scene, width: usize, height: usize, opts: &CssmOptions) -> Peak {
    let channels = 4 * opts.order + 1;
    let filtered = match opts.prefilter {
        Prefilter::Sat => SummedAreaTable::peak(width, height, channels),
        Prefilter::Mipmap => MipMap::peak(width, height, channels),
    };
    raster_peak(scene, width, height)
        .buffer(&[width as u64, height as u64, channels as u64, 4])
        .and(filtered)
}

/// The normalization range: from the nearest stored depth to the farthest of the stored depths
/// and the receivers' depths (a hair beyond, so receivers stay inside).
fn depth_range(map: &DepthMap, frustum: &LightFrustum, rx: &Receivers) -> DepthRange {
    let finite = map.depth.iter().copied().filter(|z| z.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, 0.0f32), |(lo, hi), z| {
        (lo.min(z), hi.max(z))
    });
    let far = rx
        .points
        .iter()
        .zip(&rx.valid)
        .filter(|(_, &v)| v)
        .map(|(p, _)| frustum.to_view(*p).z)
        .fold(hi, f32::max);
    let lo = if lo.is_finite() { lo } else { frustum.near };
    DepthRange {
        lo,
        span: ((far - lo) * 1.001).max(f32::MIN_POSITIVE.sqrt()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::Rng;

    #[test]
    fn sat_and_mipmap_agree_on_boxes_aligned_to_mip_levels() {
        let (w, order) = (64usize, 3usize);
        let mut rng = Rng::new(9);
        let map = DepthMap {
            width: w,
            height: w,
            depth: (0..w * w)
                .map(|i| {
                    if i % 7 == 0 {
                        f32::INFINITY
                    } else {
                        1.0 + rng.next_f32()
                    }
                })
                .collect(),
            fragments: 0,
        };
        let basis = basis_images(&map, DepthRange { lo: 1.0, span: 1.0 }, order).unwrap();
        let channels = 4 * order + 1;
        let sat = Filtered::Sat(SummedAreaTable::new(w, w, channels, &basis).unwrap());
        let mip = Filtered::Mipmap(MipMap::new(w, w, channels, &basis).unwrap());
        let (mut a, mut b, mut scratch) = (
            vec![0.0; channels],
            vec![0.0; channels],
            vec![0.0f32; channels],
        );
        for level in 0..5u32 {
            let size = (1u32 << level) as f32;
            for (i, j) in [(0u32, 0u32), (1, 2), (3, 1)] {
                let center = Vec2::new((i as f32 + 0.5) * size, (j as f32 + 0.5) * size);
                sat.box_mean(center, Vec2::splat(size / 2.0), &mut a, &mut scratch);
                mip.box_mean(center, Vec2::splat(size / 2.0), &mut b, &mut scratch);
                for (x, y) in a.iter().zip(&b) {
                    assert!(
                        (x - y).abs() < 1e-5,
                        "level {level} box ({i}, {j}): {x} vs {y}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_series_reconstructs_the_step_away_from_the_edge() {
        let order = 32;
        for (z, d, lit) in [(0.8, 0.3, 1.0), (0.2, 0.6, 0.0), (0.55, 0.45, 1.0)] {
            let zn: f64 = z;
            let mut b = vec![0.0; 4 * order + 1];
            for k in 0..order {
                let (s, c) = (coefficient(k) * zn).sin_cos();
                b[2 * k] = c;
                b[2 * k + 1] = s;
                b[2 * order + 2 * k] = zn * c;
                b[2 * order + 2 * k + 1] = zn * s;
            }
            b[4 * order] = zn;
            let (test, z_part) = reconstruct(&b, order, d);
            assert!((test - lit).abs() < 0.05, "f({d}, {z}) = {test}");
            assert!((z_part - z * (1.0 - lit)).abs() < 0.05, "z f̄ = {z_part}");
        }
    }

    #[test]
    fn the_default_shift_is_where_the_series_first_reaches_one() {
        for order in [1, 2, 4, 16, 64] {
            let t1 = first_lit_offset(order);
            assert!(
                (step_series(order, t1) - 1.0).abs() < 1e-9,
                "M = {order}: S({t1}) = {}",
                step_series(order, t1)
            );
            assert!(
                (1..100).all(|i| step_series(order, t1 * i as f64 / 100.0) < 1.0),
                "M = {order}: S reaches 1 before {t1}"
            );
            assert!(
                (0.28..0.31).contains(&(t1 * order as f64)),
                "M = {order}: t1 M = {}",
                t1 * order as f64
            );
        }
        assert_eq!(CssmOptions::default().offset(), first_lit_offset(4) as f32);
    }

    /// CSM-Z (eq. 8, appendix eq. 11) against the brute-force mean of the blocker depths over
    /// the same boxes. The only error is the series' truncation: with `ε` the largest
    /// `|S_M(t) − step(t)|` over the box's texels (`t = ẑ − d̂`), the filtered blocked fraction
    /// is within `ε` of the true one and `w ∗ (ẑ f̄)` within `ε` of its true value (`ẑ <= 1`), so
    /// `z_avg` is within `2ε / (blocked − ε)`; and the error shrinks as the order grows.
    #[test]
    fn csm_z_average_blocker_depth_matches_the_brute_force_average() {
        let (w, d) = (64usize, 0.8f64);
        let mut rng = Rng::new(3);
        let depth: Vec<f32> = (0..w * w)
            .map(|i| {
                if (i % w / 8 + i / w / 8) % 3 == 0 {
                    1.25 + 0.4 * rng.next_f32()
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let range = DepthRange { lo: 1.0, span: 1.0 };
        let map = DepthMap {
            width: w,
            height: w,
            depth,
            fragments: 0,
        };
        let mut worst = Vec::new();
        for order in [16usize, 64] {
            let channels = 4 * order + 1;
            let sat = Filtered::Sat(
                SummedAreaTable::new(w, w, channels, &basis_images(&map, range, order).unwrap())
                    .unwrap(),
            );
            let (mut means, mut scratch) = (vec![0.0; channels], vec![0.0f32; channels]);
            let mut errors = 0.0f64;
            for (x0, y0, x1, y1) in [
                (0, 0, 16, 16),
                (5, 3, 37, 20),
                (10, 30, 64, 64),
                (20, 20, 28, 44),
            ] {
                let center = Vec2::new((x0 + x1) as f32 / 2.0, (y0 + y1) as f32 / 2.0);
                sat.box_mean(
                    center,
                    Vec2::new((x1 - x0) as f32 / 2.0, (y1 - y0) as f32 / 2.0),
                    &mut means,
                    &mut scratch,
                );
                let (test, z_part) = reconstruct(&means, order, d);
                let depths: Vec<f64> = (y0..y1)
                    .flat_map(|y| (x0..x1).map(move |x| y * w + x))
                    .map(|k| range.normalize(map.depth[k]))
                    .collect();
                let blockers: Vec<f64> = depths.iter().copied().filter(|&z| z < d).collect();
                let eps = depths
                    .iter()
                    .map(|&z| (step_series(order, z - d) - if z >= d { 1.0 } else { 0.0 }).abs())
                    .fold(0.0, f64::max);
                let fraction = blockers.len() as f64 / depths.len() as f64;
                let brute = blockers.iter().sum::<f64>() / blockers.len() as f64;
                let z_avg = z_part / (1.0 - test);
                assert!(
                    ((1.0 - test) - fraction).abs() <= eps,
                    "M = {order}: blocked {} vs {fraction} (ε = {eps})",
                    1.0 - test
                );
                assert!(
                    (z_avg - brute).abs() <= 2.0 * eps / (fraction - eps),
                    "M = {order}: z_avg {z_avg} vs brute force {brute} (ε = {eps})"
                );
                errors = errors.max((z_avg - brute).abs());
            }
            worst.push(errors);
        }
        assert!(
            worst[1] < 0.5 * worst[0],
            "the error does not shrink with the order: {worst:?}"
        );
    }
}
