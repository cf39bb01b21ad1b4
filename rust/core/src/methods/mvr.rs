//! `mvr`: multi-view rasterization, the reference family of Marrs et al. 2018,
//! View-warped Multi-view Soft Shadows (section 2.1; Herf and
//! Heckbert 1996). One perspective depth map per light sample, every triangle rasterized into
//! each (standard rasterization, perforated meshes alpha-tested), then per receiver the PCF shadow
//! test on every map and their weighted average ([`crate::raster::multiview`]). With 512 views it
//! is the paper's "ultra-high quality" reference; with the samples of `vwss` it is the peer whose
//! depth maps `vwss` warps instead of rasterizing.
//!
//! Views are rendered and lit one at a time, so memory stays at one map whatever the view count.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::gpu::multiview::Lighting;
use crate::gpu::mvr::Rasterizer;
use crate::gpu::Backend;
use crate::interrupt;
use crate::light::lights::Light;
use crate::light::sampling::SampleSet;
use crate::limits::{Peak, Work};
use crate::raster::depth::{raster_peak, rasterize_depth, RasterOptions};
use crate::raster::multiview::{accumulate, resolve, ViewSet};
use crate::raster::pcf::{DepthBias, PcfKernel};
use crate::stats::Stats;

/// Options shared by [`mvr`] and `vwss`'s lighting stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiViewOptions {
    /// Side of every light-sample depth map in texels (default 1024, Marrs et al. 2018, section 4).
    pub resolution: usize,
    /// PCF taps per depth map: 1, 5 (the paper's, default) or an odd square (9, 25, ...).
    pub pcf: usize,
    /// Constant depth bias in world units, or `None` for the receiver plane per tap (default).
    pub bias: Option<f32>,
    /// Where the depth maps are made and lit: the CPU, or the GPU (`gpu/mvr.wgsl` rasterizes,
    /// `gpu/vwss.wgsl` warps, `gpu/multiview.wgsl` lights), with maps equal texel for texel.
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
        if !(1..=crate::raster::depth::MAX_RESOLUTION).contains(&self.resolution) {
            return Err(Error::invalid(
                "resolution",
                format!(
                    "must be in 1..={}, got {}",
                    crate::raster::depth::MAX_RESOLUTION,
                    self.resolution
                ),
            ));
        }
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

/// Soft-shadow visibility of every receiver by multi-view rasterization.
///
/// Returns the visibility (receivers' order) and stats: `depth_maps_seconds`,
/// `lighting_seconds`, `views`, `resolution`, `fragments` (rasterized over all views).
///
/// Errors: invalid options; rotated or interleaved samples; a sample inside the receivers'
/// bounds; `TooLarge` past the memory limit.
pub fn mvr(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &MultiViewOptions,
) -> Result<(Vec<f32>, Stats)> {
    let (kernel, bias) = opts.shadow_test()?;
    let eyes = shared_eyes(samples)?;
    let mut stats = Stats::default();
    for name in ["depth_maps_seconds", "lighting_seconds", "fragments"] {
        stats.set(name, 0.0);
    }
    stats.set("views", eyes.len() as f64);
    stats.set("resolution", opts.resolution as f64);
    let Some(bounds) = receivers.bounds() else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    let views = ViewSet::fit(light, eyes, bounds, opts.resolution)?;
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
        let rasterizer = stats.time_add("depth_maps", || Rasterizer::new(scene))?;
        let lighting = stats.time_add("lighting", || Lighting::new(receivers, &kernel, bias))?;
        let (draw, light, fragments) =
            rasterizer.draw_and_light(&views.views, &views.weights, &lighting)?;
        stats.add("depth_maps_seconds", draw);
        stats.add("lighting_seconds", light);
        stats.set("fragments", fragments as f64);
        let sums = stats.time_add("lighting", || lighting.sums())?;
        return Ok((resolve(&sums, &views, receivers), stats));
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
    Ok((resolve(&sums, &views, receivers), stats))
}
