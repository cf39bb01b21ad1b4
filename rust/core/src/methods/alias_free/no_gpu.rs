//! The GPU half of alias_free without the crate feature `gpu`: refuses.
use super::TexelTests;
use crate::error::Result;
use crate::stats::Stats;

pub(crate) fn masks(_setup: &TexelTests<'_>, _stats: &mut Stats) -> Result<Vec<u64>> {
    Err(crate::gpu::unavailable())
}
