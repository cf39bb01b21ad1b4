//! The wgpu backend: the methods that the papers ran on graphics hardware, as compute pipelines.
//!
//! One device and queue are created lazily on first use and reused by every call ([`context`]),
//! one per process: a forked child makes its own ([`after_fork_in_child`]);
//! each method has one `.rs` + `.wgsl` pair here, the WGSL embedded in the binary. Methods pick
//! the backend per call ([`Backend`]); the CPU path is unchanged. Large inputs are split into
//! dispatches within the adapter's limits ([`DispatchLimits`]: workgroup counts and storage
//! binding sizes), which tests can force lower ([`force_limits`]).
//!
//! Built without the crate feature `gpu`, [`context`] answers [`Error::Unavailable`].

use crate::error::{Error, Result};
use std::sync::Mutex;

#[cfg(feature = "gpu")]
pub mod alias_free;
#[cfg(feature = "gpu")]
mod context;
#[cfg(feature = "gpu")]
pub mod cssm;
#[cfg(feature = "gpu")]
pub mod multiview;
#[cfg(feature = "gpu")]
pub mod mvr;
#[cfg(feature = "gpu")]
pub mod pcss;
#[cfg(feature = "gpu")]
pub mod vwss;
#[cfg(not(feature = "gpu"))]
pub mod alias_free {
    //! Without the `gpu` feature: refuses.
    use crate::error::Result;
    use crate::methods::alias_free::Setup;
    use crate::stats::Stats;

    pub(crate) fn masks(_setup: &Setup<'_>, _stats: &mut Stats) -> Result<Vec<u64>> {
        Err(super::unavailable())
    }
}
#[cfg(not(feature = "gpu"))]
pub mod cssm {
    //! Without the `gpu` feature: refuses.
    use crate::error::Result;
    use crate::methods::cssm::{Shared, Start};
    use crate::raster::depth::DepthMap;

    pub fn cssm(
        _map: &DepthMap,
        _shared: &Shared,
        _starts: &[Start],
    ) -> Result<(Vec<f32>, [f64; 3])> {
        Err(super::unavailable())
    }
}
#[cfg(not(feature = "gpu"))]
pub mod multiview {
    //! Without the `gpu` feature: lighting that cannot be set up.
    use crate::error::Result;
    use crate::geometry::receivers::Receivers;
    use crate::raster::depth::{DepthMap, LightFrustum};
    use crate::raster::pcf::{DepthBias, PcfKernel};

    pub enum Lighting {}

    impl Lighting {
        pub fn new(_rx: &Receivers, _kernel: &PcfKernel, _bias: DepthBias) -> Result<Self> {
            Err(super::unavailable())
        }

        pub fn accumulate_maps(
            &self,
            _maps: &[&DepthMap],
            _views: &[LightFrustum],
            _weights: &[f32],
        ) -> Result<()> {
            match *self {}
        }

        pub fn sums(&self) -> Result<Vec<f32>> {
            match *self {}
        }
    }
}
#[cfg(not(feature = "gpu"))]
pub mod mvr {
    //! Without the `gpu` feature: a rasterizer that cannot be made.
    use super::multiview::Lighting;
    use crate::error::Result;
    use crate::geometry::mesh::Scene;
    use crate::raster::depth::LightFrustum;

    pub enum Rasterizer {}

    impl Rasterizer {
        pub fn new(_scene: &Scene) -> Result<Self> {
            Err(super::unavailable())
        }

        pub fn draw_and_light(
            &self,
            _views: &[LightFrustum],
            _weights: &[f32],
            _lighting: &Lighting,
        ) -> Result<(f64, f64, u64)> {
            match *self {}
        }
    }
}
#[cfg(not(feature = "gpu"))]
pub mod pcss {
    //! Without the `gpu` feature: refuses.
    use crate::error::Result;
    use crate::geometry::receivers::Receivers;
    use crate::methods::pcss::GpuLookup;

    pub fn pcss(_lookup: &GpuLookup<'_>, _rx: &Receivers) -> Result<(Vec<f32>, f64)> {
        Err(super::unavailable())
    }
}
#[cfg(not(feature = "gpu"))]
pub mod vwss {
    //! Without the `gpu` feature: a warper that cannot be made.
    use super::multiview::Lighting;
    use crate::error::Result;
    use crate::raster::depth::LightFrustum;

    pub enum Warper {}

    impl Warper {
        pub fn new(_points: impl ExactSizeIterator<Item = glam::Vec3>) -> Result<Self> {
            Err(super::unavailable())
        }

        pub fn warp_and_light(
            &self,
            _views: &[LightFrustum],
            _weights: &[f32],
            _lighting: &Lighting,
        ) -> Result<(f64, f64)> {
            match *self {}
        }
    }
}

#[cfg(feature = "gpu")]
pub use context::{context, Gpu, PerContext};

/// Makes a forked child build its own GPU context on its next GPU call, as the parent's waits on
/// driver threads that do not exist in the child. Call it in the child right after `fork`; a
/// child that does not still gets its own context, by its new process id, unless that id was
/// the one of the process that made the context.
pub fn after_fork_in_child() {
    #[cfg(feature = "gpu")]
    context::forget_after_fork();
}

/// Where a method runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    #[default]
    Cpu,
    Gpu,
}

/// The limits that split a method's work into dispatches: workgroups per dispatch dimension and
/// bytes per storage-buffer binding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DispatchLimits {
    pub workgroups: u32,
    pub binding_bytes: u64,
}

impl DispatchLimits {
    /// The smaller of each limit.
    pub fn min(self, other: DispatchLimits) -> DispatchLimits {
        DispatchLimits {
            workgroups: self.workgroups.min(other.workgroups),
            binding_bytes: self.binding_bytes.min(other.binding_bytes),
        }
    }
}

// A poisoned lock only means a test panicked while holding it; the limits inside stay valid.
static FORCED: Mutex<Option<DispatchLimits>> = Mutex::new(None);

/// Lowers the dispatch limits below the adapter's (for tests of the splitting); `None` restores
/// the adapter's own.
pub fn force_limits(limits: Option<DispatchLimits>) -> Result<()> {
    if let Some(l) = limits {
        if l.workgroups == 0 || l.binding_bytes < 256 {
            return Err(Error::invalid(
                "limits",
                format!("need >= 1 workgroup and >= 256 binding bytes, got {l:?}"),
            ));
        }
    }
    *FORCED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner()) = limits;
    Ok(())
}

/// The forced limits, if any.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
fn forced_limits() -> Option<DispatchLimits> {
    *FORCED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Runs GPU `work` and adds its stage time to `{stage}_seconds` in `stats`: the GPU's execution
/// time of its compute passes by timestamp queries where the adapter has them, else the wall
/// clock ([`Gpu::timed`]).
pub fn timed_stage<T>(
    stats: &mut crate::stats::Stats,
    stage: &str,
    work: impl FnOnce() -> Result<T>,
) -> Result<T> {
    #[cfg(feature = "gpu")]
    {
        let mut seconds = 0.0;
        let out = context()?.timed(&mut seconds, work);
        stats.add(&format!("{stage}_seconds"), seconds);
        out
    }
    #[cfg(not(feature = "gpu"))]
    {
        let _ = (stats, stage, work);
        Err(unavailable())
    }
}

/// The adapter the GPU backend uses, as `(name, value)` pairs: name, backend, device type,
/// driver, and the limits that split the work.
pub fn info() -> Result<Vec<(String, String)>> {
    #[cfg(feature = "gpu")]
    {
        Ok(context()?.describe())
    }
    #[cfg(not(feature = "gpu"))]
    {
        Err(unavailable())
    }
}

/// The error of a GPU request that cannot be served.
#[cfg(not(feature = "gpu"))]
pub(crate) fn unavailable() -> Error {
    Error::Unavailable(
        "softshadows was built without the `gpu` feature: rebuild with it for backend=\"gpu\""
            .into(),
    )
}

#[cfg(test)]
mod shader_tests {
    /// Every embedded shader parses and validates with naga, so a broken shader fails `cargo test`
    /// on machines without a GPU.
    #[test]
    fn every_shader_parses_and_validates() {
        use naga::valid::Capabilities;
        let frustum = include_str!("frustum.wgsl");
        let vector64 = include_str!("vector64.wgsl");
        for (name, source, capabilities) in [
            (
                "vwss.wgsl",
                format!("{frustum}\n{}", include_str!("vwss.wgsl")),
                Capabilities::empty(),
            ),
            (
                "multiview.wgsl",
                format!("{frustum}\n{}", include_str!("multiview.wgsl")),
                Capabilities::empty(),
            ),
            (
                "pcss.wgsl",
                format!("{frustum}\n{}", include_str!("pcss.wgsl")),
                Capabilities::FLOAT64,
            ),
            (
                "mvr.wgsl",
                format!("{frustum}\n{vector64}\n{}", include_str!("mvr.wgsl")),
                Capabilities::FLOAT64,
            ),
            (
                "cssm.wgsl",
                include_str!("cssm.wgsl").to_string(),
                Capabilities::FLOAT64,
            ),
            (
                "alias_free.wgsl",
                format!("{frustum}\n{vector64}\n{}", include_str!("alias_free.wgsl")),
                Capabilities::FLOAT64,
            ),
        ] {
            let source = source.as_str();
            let module = naga::front::wgsl::parse_str(source)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
    }
}
