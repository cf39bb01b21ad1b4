//! `pcss`: percentage-closer soft shadows (Fernando 2005), the fast single-view baseline of Marrs,
//! Watson and Healey 2018, "View-warped Multi-view Soft Shadows for Local Area Lights" (section 4:
//! "a 64-sample blocker search and 96-sample PCF filter").
//!
//! One depth map is rendered from the light's center (as [`shadow_map`](crate::methods::shadow_map)
//! does). For a receiver at linear depth `z_r` whose projection is `(sx, sy)`:
//!
//! 1. **Blocker search.** Occluders that can hide part of the light from the receiver lie in the
//!    cone from the receiver to the light; between the depths `z_n` and `z_r` that cone projects
//!    into the map as the light's footprint through depth `z_n`
//!    ([`LightFootprint`]), Fernando's
//!    `LIGHT_SIZE_UV · (z_r − NEAR) / z_r` written for a perspective map. `z_n` is the search's near
//!    plane: `near`, or by default the nearest depth stored in the map (no occluder lies nearer).
//!    `blocker_samples` Poisson-disk taps over that region average the depths of the texels
//!    nearer than the receiver: `z_avg`. No blocker found: the receiver is lit.
//! 2. **Penumbra estimate** by parallel planes: the penumbra seen from the receiver spans the
//!    light's footprint through a blocker at `z_avg`.
//! 3. **Filtering**: `filter_samples` Poisson-disk taps over that region, the fraction lit.
//!
//! Both tap patterns are Poisson disks (the platform's pattern in the unit disk, seeded by `seed`)
//! shared by every receiver, as in Fernando's implementation. Each tap compares with the depth of
//! the receiver's tangent plane at that tap ([`ReceiverDepth`]), unless a constant `bias` is given. A receiver facing away from the light's center gets 0,
//! as in `shadow_map`.
//!
//! Its known failures, which Marrs et al. 2018, View-warped Multi-view Soft Shadows shows in
//! Figure 10, are reproduced on purpose: thin
//! occluders that fall between the search taps are missed, and a single average blocker depth
//! cannot represent occluders at very different depths (occluder fusion).

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
use crate::light::sampling::{unit_disk_pattern, Pattern};
use crate::limits::Peak;
use crate::raster::cube::{self, by_light_face};
use crate::raster::depth::{raster_peak, raster_work, rasterize_depth, DepthMap, RasterOptions};
use crate::raster::footprint::LightFootprint;
use crate::raster::frustum::{check_resolution, LightFrustum};
use crate::raster::pcf::{DepthBias, ReceiverDepth};
use crate::stats::Stats;
use glam::{Vec2, Vec3};

/// The largest tap count accepted for either stage.
pub const MAX_TAPS: usize = 4096;

/// Options of [`pcss`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcssOptions {
    /// Depth-map side in texels (default 1024, Marrs et al. 2018, section 4).
    pub resolution: usize,
    /// Poisson taps of the blocker search (default 64).
    pub blocker_samples: usize,
    /// Poisson taps of the PCF filter (default 96).
    pub filter_samples: usize,
    /// Constant depth bias in world units, or `None` for the receiver plane per tap (default).
    pub bias: Option<f32>,
    /// Near plane of the blocker search (linear depth from the light's center, world units), or
    /// `None` for the nearest depth in the map (default).
    pub near: Option<f32>,
    /// Seed of the two Poisson-disk tap patterns.
    pub seed: u64,
    /// Where the blocker search and filter run (the map is rasterized on the CPU either way):
    /// the CPU, or the GPU (`methods/pcss/pcss.wgsl`), with equal results.
    pub backend: Backend,
}

impl Default for PcssOptions {
    fn default() -> Self {
        Self {
            resolution: 1024,
            blocker_samples: 64,
            filter_samples: 96,
            bias: None,
            near: None,
            seed: 0,
            backend: Backend::Cpu,
        }
    }
}

impl PcssOptions {
    fn validate(&self) -> Result<()> {
        check_resolution("resolution", self.resolution)?;
        for (arg, n) in [
            ("blocker_samples", self.blocker_samples),
            ("filter_samples", self.filter_samples),
        ] {
            if !(1..=MAX_TAPS).contains(&n) {
                return Err(Error::invalid(
                    arg,
                    format!("must be in 1..={MAX_TAPS}, got {n}"),
                ));
            }
        }
        DepthBias::new(self.bias)?;
        if let Some(z) = self.near {
            if !(z.is_finite() && z > 0.0) {
                return Err(Error::invalid(
                    "near",
                    format!("must be finite and > 0 (or None), got {z}"),
                ));
            }
        }
        Ok(())
    }
}

/// What every receiver's GPU lookup shares ([`gpu::pcss`]).
pub struct GpuLookup<'a> {
    pub map: &'a DepthMap,
    pub frustum: &'a LightFrustum,
    /// [`LightFootprint::texels`].
    pub footprint: Vec2,
    pub near: f32,
    pub blocker_taps: &'a [Vec2],
    pub filter_taps: &'a [Vec2],
    pub bias: DepthBias,
}

/// What every receiver's lookup shares.
struct PcssLookup<'a> {
    map: &'a DepthMap,
    frustum: &'a LightFrustum,
    footprint: LightFootprint,
    near: f32,
    blocker_taps: Vec<Vec2>,
    filter_taps: Vec<Vec2>,
    bias: DepthBias,
}

/// The outcome of one receiver's lookup (coded 1 to 4 by `lookup` in `pcss.wgsl`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    /// Outside the map or nearer than the search's near plane: lit, no tap read.
    Unsearched,
    /// Facing away from the light's center: unlit, no tap read.
    FacingAway,
    /// The blocker search found no blocker: lit without filtering.
    NoBlocker,
    /// Searched and filtered, with the fraction of the filter's taps lit.
    Filtered(f32),
}

impl Outcome {
    fn visibility(self) -> f32 {
        match self {
            Outcome::FacingAway => 0.0,
            Outcome::Unsearched | Outcome::NoBlocker => 1.0,
            Outcome::Filtered(v) => v,
        }
    }
}

impl PcssLookup<'_> {
    /// Visits the stored depth and the receiver depth to compare it with at every tap of `taps`
    /// scaled by `region` around the receiver.
    fn taps<'t>(
        &'t self,
        taps: &'t [Vec2],
        region: Vec2,
        receiver: &'t ReceiverDepth,
    ) -> impl Iterator<Item = (f32, f32)> + 't {
        let s = receiver.texel_coords();
        taps.iter().map(move |q| {
            let t = s + *q * region;
            let (x, y) = (t.x.floor() as i64, t.y.floor() as i64);
            (self.map.get(x, y), receiver.at(x, y))
        })
    }

    fn receiver(&self, p: Vec3, n: Vec3) -> Outcome {
        if n.dot(self.frustum.eye - p) <= 0.0 {
            return Outcome::FacingAway;
        }
        let Some(s) = self.frustum.project(p) else {
            return Outcome::Unsearched;
        };
        if !(s.x >= 0.0
            && s.y >= 0.0
            && s.x < self.map.width as f32
            && s.y < self.map.height as f32)
            || s.z <= self.near
        {
            return Outcome::Unsearched;
        }
        let receiver = ReceiverDepth::new(self.frustum, p, n, s, self.bias);
        let search = self.footprint.through(s.z, self.near);
        let (sum, count) = self
            .taps(&self.blocker_taps, search, &receiver)
            .filter(|(stored, depth)| stored < depth)
            .fold((0.0f64, 0u32), |(sum, count), (stored, _)| {
                (sum + f64::from(stored), count + 1)
            });
        if count == 0 {
            return Outcome::NoBlocker;
        }
        let z_avg = ((sum / f64::from(count)) as f32).max(self.near);
        let filter = self.footprint.through(s.z, z_avg);
        let lit = self
            .taps(&self.filter_taps, filter, &receiver)
            .filter(|(stored, depth)| depth <= stored)
            .count();
        Outcome::Filtered(lit as f32 / self.filter_taps.len() as f32)
    }
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "depth_map_seconds",
    "lighting_seconds",
    "search_near",
    "no_blocker",
    "search_taps",
    "filter_taps",
    "resolution",
    "light_faces",
];

/// Soft-shadow visibility of every receiver by percentage-closer soft shadows.
///
/// Returns the visibility (receivers' order) and stats: `depth_map_seconds`, `lighting_seconds`
/// (blocker search and filtering), `resolution`, `search_near` (`z_n`), `no_blocker` (the fraction
/// of valid receivers lit without filtering: no blocker found, or no search), `search_taps` and
/// `filter_taps` (depth-map taps read by the blocker searches and the filters).
///
/// A light among the receivers gets a map per face of a cube around its center
/// ([`crate::raster::cube`]), each receiver searched and filtered in its own face's map, the
/// light's footprint taken along that face's axes; stat `light_faces`.
///
/// Errors: invalid options; `TooLarge`.
pub fn pcss(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    opts: &PcssOptions,
) -> Result<(Vec<f32>, Stats)> {
    super::refuse_textured(light, "pcss")?;
    opts.validate()?;
    by_light_face(light, receivers, |part, face| {
        pcss_view(scene, light, part, face, opts)
    })
}

/// [`pcss`] on the receivers one light frustum serves: fitted, or cube face `face`'s.
fn pcss_view(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    face: Option<usize>,
    opts: &PcssOptions,
) -> Result<(Vec<f32>, Stats)> {
    let mut stats = Stats::declared(STATS);
    stats.set("resolution", opts.resolution as f64);
    let Some(bounds) = receivers.bounds() else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    let frustum = cube::footprint_frustum(light, receivers, face, bounds, opts.resolution)?;
    // The visibility and each receiver's outcome.
    Peak::default()
        .buffer(&[receivers.len() as u64, 4 + 8])
        .and(raster_peak(scene, frustum.width, frustum.height))
        .check("pcss", &mut stats)?;
    raster_work(scene, frustum.width, frustum.height)
        .loop_of(&[
            receivers.len() as u64,
            (opts.blocker_samples + opts.filter_samples) as u64,
        ])
        .check("pcss", &mut stats)?;
    let map = stats.time("depth_map", || {
        rasterize_depth(scene, &frustum, &RasterOptions::default())
    })?;
    let nearest_stored = map.depth.iter().copied().fold(f32::INFINITY, f32::min);
    let near = opts.near.unwrap_or(nearest_stored).max(frustum.near);
    stats.set("search_near", f64::from(near));
    let lookup = PcssLookup {
        map: &map,
        frustum: &frustum,
        footprint: LightFootprint::new(&frustum, light),
        near,
        blocker_taps: unit_disk_pattern(Pattern::Poisson, opts.blocker_samples, opts.seed),
        filter_taps: unit_disk_pattern(
            Pattern::Poisson,
            opts.filter_samples,
            opts.seed ^ 0x5EED_F117,
        ),
        bias: DepthBias::new(opts.bias)?,
    };
    if opts.backend == Backend::Gpu {
        let gpu_lookup = GpuLookup {
            map: &map,
            frustum: &frustum,
            footprint: lookup.footprint.texels(),
            near,
            blocker_taps: &lookup.blocker_taps,
            filter_taps: &lookup.filter_taps,
            bias: lookup.bias,
        };
        let outcomes =
            crate::gpu::timed_stage(&mut stats, "lighting", || gpu::pcss(&gpu_lookup, receivers))?;
        return Ok((record_outcomes(&outcomes, opts, &mut stats), stats));
    }
    let taps = (opts.blocker_samples + opts.filter_samples) as u64;
    let outcomes: Vec<Option<Outcome>> = stats.time("lighting", || {
        interrupt::par_map(receivers.len(), taps, |i| {
            receivers.valid[i].then(|| lookup.receiver(receivers.points[i], receivers.normals[i]))
        })
    })?;
    let vis = record_outcomes(&outcomes, opts, &mut stats);
    Ok((vis, stats))
}

/// The visibility of the receivers' outcomes (0 for an invalid one), recording the stats
/// `no_blocker`, `search_taps` and `filter_taps`.
fn record_outcomes(
    outcomes: &[Option<Outcome>],
    opts: &PcssOptions,
    stats: &mut Stats,
) -> Vec<f32> {
    let count = |pred: fn(&Outcome) -> bool| outcomes.iter().flatten().filter(|o| pred(o)).count();
    let valid = count(|_| true);
    let free = count(|o| matches!(o, Outcome::Unsearched | Outcome::NoBlocker));
    let filtered = count(|o| matches!(o, Outcome::Filtered(_)));
    let searched = filtered + count(|o| *o == Outcome::NoBlocker);
    stats.set(
        "no_blocker",
        if valid > 0 {
            free as f64 / valid as f64
        } else {
            0.0
        },
    );
    stats.add("search_taps", (searched * opts.blocker_samples) as f64);
    stats.add("filter_taps", (filtered * opts.filter_samples) as f64);
    outcomes
        .iter()
        .map(|o| o.map_or(0.0, Outcome::visibility))
        .collect()
}
