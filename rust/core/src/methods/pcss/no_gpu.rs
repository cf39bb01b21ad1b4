//! The GPU half of pcss without the crate feature `gpu`: refuses.
use super::{GpuLookup, Outcome};
use crate::error::Result;
use crate::geometry::receivers::Receivers;

pub(super) fn pcss(_lookup: &GpuLookup<'_>, _rx: &Receivers) -> Result<Vec<Option<Outcome>>> {
    Err(crate::gpu::unavailable())
}
