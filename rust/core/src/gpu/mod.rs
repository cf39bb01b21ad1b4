//! What the wgpu backend's methods share: the device, the dispatch limits, and the lighting pass
//! of the multi-view methods.
//!
//! One device and queue are created lazily on first use and reused by every call ([`context()`]),
//! one per process: a forked child makes its own ([`after_fork_in_child`]). Each method's GPU
//! half lives beside its CPU half (`methods/<name>/gpu.rs` and its `.wgsl`, embedded in the
//! binary, with a `no_gpu.rs` that refuses when the crate feature is off); here are only the
//! shared parts: the context, the limits, the multi-view lighting pass ([`multiview`], used by
//! `shadow_map`, `mvr` and `vwss`) and the frustum and f64 vector shaders the others include.
//! Methods pick the backend per call ([`crate::backend::Backend`]). Large inputs are split into
//! dispatches within the adapter's limits ([`DispatchLimits`]: workgroup counts and storage
//! binding sizes), which tests can force lower ([`force_limits`]).
//!
//! Built without the crate feature `gpu`, [`context()`] answers [`Error::Unavailable`].

use crate::error::{Error, Result};
use std::sync::Mutex;

#[cfg(feature = "gpu")]
pub(crate) mod context;
#[cfg(feature = "gpu")]
pub mod multiview;
#[cfg(not(feature = "gpu"))]
pub mod multiview {
    //! Without the `gpu` feature: lighting that cannot be set up.
    use crate::error::Result;
    use crate::geometry::receivers::Receivers;
    use crate::raster::depth::DepthMap;
    use crate::raster::frustum::LightFrustum;
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
