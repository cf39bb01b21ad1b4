//! The GPU half of pcss without the crate feature `gpu`: refuses.
use super::GpuLookup;
use crate::error::Result;
use crate::geometry::receivers::Receivers;

pub fn pcss(_lookup: &GpuLookup<'_>, _rx: &Receivers) -> Result<(Vec<f32>, f64)> {
    Err(crate::gpu::unavailable())
}
