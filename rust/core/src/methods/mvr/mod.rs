//! `mvr`: multi-view rasterization, the reference family of Marrs et al. 2018,
//! View-warped Multi-view Soft Shadows (section 2.1; Herf and
//! Heckbert 1996). One perspective depth map per light sample, every triangle rasterized into
//! each (standard rasterization, perforated meshes alpha-tested), then per receiver the PCF shadow
//! test on every map and their weighted average ([`crate::raster::multiview`]). With 512 views it
//! is the paper's "ultra-high quality" reference; with the samples of `vwss` it is the peer whose
//! depth maps `vwss` warps instead of rasterizing.
//!
//! Views are rendered and lit one at a time, so memory stays at one map whatever the view count.

#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(not(feature = "gpu"))]
#[path = "no_gpu.rs"]
pub mod gpu;

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::gpu::multiview::Lighting;
use crate::interrupt;
use crate::light::lights::Light;
use crate::light::sampling::SampleSet;
use crate::limits::{Peak, Work};
use crate::raster::cube;
use crate::raster::depth::{raster_peak, rasterize_depth, RasterOptions};
use crate::raster::frustum::check_resolution;
use crate::raster::multiview::{accumulate, resolve, ViewSet};
use crate::raster::pcf::{DepthBias, PcfKernel};
use crate::stats::Stats;
use glam::Vec3;
use gpu::GpuRasterizer;
use rayon::prelude::*;

/// Options shared by [`mvr`] and `vwss`'s lighting stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiViewOptions {
    /// Side of every light-sample depth map in texels (default 1024, Marrs et al. 2018, section 4).
    pub resolution: usize,
    /// PCF taps per depth map: 1, 5 (the paper's, default) or an odd square (9, 25, ...).
    pub pcf: usize,
    /// Constant depth bias in world units, or `None` for the receiver plane per tap (default).
    pub bias: Option<f32>,
    /// Where the depth maps are made and lit: the CPU, or the GPU (`methods/mvr/mvr.wgsl` rasterizes,
    /// `methods/vwss/vwss.wgsl` warps, `gpu/multiview.wgsl` lights), with maps equal texel for texel.
    pub backend: Backend,
}

impl Default for MultiViewOptions {
    fn default() -> Self {
        Self {
            resolution: 1024,
            pcf: 5,
            bias: None,
            backend: Backend::Cpu,
        }
    }
}

impl MultiViewOptions {
    /// The work of lighting `receivers` from `views` maps: each map cleared, and each receiver's
    /// PCF taps in each.
    pub fn lighting_work(&self, views: usize, receivers: usize) -> Work {
        let side = self.resolution as u64;
        Work::default()
            .loop_of(&[views as u64, side, side])
            .loop_of(&[views as u64, receivers as u64, (self.pcf as u64).pow(2)])
    }

    /// Checks the options and returns the PCF kernel and the depth bias (see
    /// [`crate::raster::pcf`]).
    pub fn shadow_test(&self) -> Result<(PcfKernel, DepthBias)> {
        check_resolution("resolution", self.resolution)?;
        Ok((PcfKernel::with_taps(self.pcf)?, DepthBias::new(self.bias)?))
    }
}

/// The light samples every receiver shares, which multi-view methods turn into views.
pub fn shared_eyes(samples: &SampleSet) -> Result<&[glam::Vec3]> {
    if !samples.is_shared() {
        return Err(Error::invalid(
            "views",
            "multi-view methods render one depth map per light sample shared by every receiver: \
             per-receiver rotation and interleaving do not apply",
        ));
    }
    Ok(samples.pattern_for(0, 0))
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "depth_maps_seconds",
    "lighting_seconds",
    "fragments",
    "views",
    "resolution",
    "light_faces",
];

/// Soft-shadow visibility of every receiver by multi-view rasterization.
///
/// Returns the visibility (receivers' order) and stats: `depth_maps_seconds`,
/// `lighting_seconds`, `views`, `resolution`, `fragments` (rasterized over all views).
///
/// A light among the receivers (its center or a sample inside or level with their bounds) gets
/// a cube of depth maps around every sample instead (see `around_every_sample`), on the CPU.
///
/// Errors: invalid options; rotated or interleaved samples; the GPU backend for a light among
/// the receivers; `TooLarge` past the memory limit.
pub fn mvr(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &MultiViewOptions,
) -> Result<(Vec<f32>, Stats)> {
    let (kernel, bias) = opts.shadow_test()?;
    let eyes = shared_eyes(samples)?;
    let mut stats = Stats::declared(STATS);
    stats.set("views", eyes.len() as f64);
    stats.set("resolution", opts.resolution as f64);
    let Some(bounds) = receivers.bounds() else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    let Some(views) = ViewSet::fit(light, eyes, bounds, opts.resolution)? else {
        let vis = around_every_sample(scene, light, receivers, eyes, opts, &mut stats)?;
        return Ok((vis, stats));
    };
    stats.set("light_faces", 1.0);
    // The sums, the visibility and one view's map at a time.
    Peak::default()
        .buffer(&[receivers.len() as u64, 4 + 4])
        .and(raster_peak(scene, opts.resolution, opts.resolution))
        .check("mvr", &mut stats)?;
    opts.lighting_work(views.views.len(), receivers.len())
        .loop_of(&[
            views.views.len() as u64,
            scene.num_faces() as u64,
            Work::TRIANGLE,
        ])
        .check("mvr", &mut stats)?;
    if opts.backend == Backend::Gpu {
        let rasterizer = stats.time_add("depth_maps", || GpuRasterizer::new(scene))?;
        let lighting = stats.time_add("lighting", || Lighting::new(receivers, &kernel, bias))?;
        let (draw, light, fragments) =
            rasterizer.draw_and_light(&views.views, &views.weights, &lighting)?;
        stats.add("depth_maps_seconds", draw);
        stats.add("lighting_seconds", light);
        stats.set("fragments", fragments as f64);
        let sums = stats.time_add("lighting", || lighting.sums())?;
        return Ok((resolve(&sums, views.total_weight(), receivers), stats));
    }
    let mut sums = vec![0.0f32; receivers.len()];
    for (s, view) in views.views.iter().enumerate() {
        interrupt::check()?;
        let map = stats.time_add("depth_maps", || {
            rasterize_depth(scene, view, &RasterOptions::default())
        })?;
        stats.add("fragments", map.fragments as f64);
        stats.time_add("lighting", || {
            accumulate(&mut sums, &views, &[(s, &map)], receivers, &kernel, bias)
        });
    }
    Ok((resolve(&sums, views.total_weight(), receivers), stats))
}

/// [`mvr`] for a light among the receivers: a cube of depth maps around every light sample
/// ([`crate::raster::cube`]), each receiver tested in the face its direction from that sample
/// falls in (a receiver near the light can lie on different sides of different samples). The
/// faces of one sample are rendered and lit together, then dropped. Stat `light_faces`: the
/// most faces one sample needed.
fn around_every_sample(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    eyes: &[Vec3],
    opts: &MultiViewOptions,
    stats: &mut Stats,
) -> Result<Vec<f32>> {
    if opts.backend == Backend::Gpu {
        return Err(Error::unsupported(
            "backend",
            "mvr's GPU passes light every receiver from one view per light sample, and this light lies \
             among the receivers (a cube of views around each sample): pass backend='cpu'",
        ));
    }
    let (kernel, bias) = opts.shadow_test()?;
    let faces = cube::FACES.len();
    // The sums, the visibility and the faces, and one sample's maps: the one being rasterized
    // and the others kept for the lighting.
    let side = opts.resolution as u64;
    Peak::default()
        .buffer(&[receivers.len() as u64, 4 + 4 + 1])
        .buffer(&[faces as u64 - 1, side, side, 4])
        .and(raster_peak(scene, opts.resolution, opts.resolution))
        .check("mvr", stats)?;
    opts.lighting_work(eyes.len() * faces, receivers.len())
        .loop_of(&[
            (eyes.len() * faces) as u64,
            scene.num_faces() as u64,
            Work::TRIANGLE,
        ])
        .check("mvr", stats)?;
    let weights: Vec<f32> = eyes.iter().map(|&y| light.weight(y)).collect();
    let mut sums = vec![0.0f32; receivers.len()];
    let mut most_faces = 0;
    for (&eye, &weight) in eyes.iter().zip(&weights) {
        interrupt::check()?;
        let face_of = cube::points_faces(eye, receivers);
        let mut maps = Vec::with_capacity(faces);
        for face in 0..faces {
            let mut points = (0..receivers.len())
                .filter(|&i| receivers.valid[i] && usize::from(face_of[i]) == face)
                .map(|i| receivers.points[i])
                .peekable();
            if points.peek().is_none() {
                maps.push(None);
                continue;
            }
            let frustum = cube::face_frustum(eye, face, points, opts.resolution)?;
            let map = stats.time_add("depth_maps", || {
                rasterize_depth(scene, &frustum, &RasterOptions::default())
            })?;
            stats.add("fragments", map.fragments as f64);
            maps.push(Some((frustum, map)));
        }
        most_faces = most_faces.max(maps.iter().flatten().count());
        stats.time_add("lighting", || {
            sums.par_iter_mut().enumerate().for_each(|(i, sum)| {
                if let (true, Some((frustum, map))) =
                    (receivers.valid[i], &maps[usize::from(face_of[i])])
                {
                    let (p, n) = (receivers.points[i], receivers.normals[i]);
                    *sum += weight * kernel.visibility(map, frustum, p, n, bias);
                }
            });
        });
    }
    stats.set("light_faces", most_faces as f64);
    let total = weights.iter().map(|&w| f64::from(w)).sum();
    Ok(resolve(&sums, total, receivers))
}
