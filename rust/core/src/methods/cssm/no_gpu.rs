//! The GPU half of cssm without the crate feature `gpu`: refuses.
use super::{Shared, Start};
use crate::error::Result;
use crate::raster::depth::DepthMap;

pub fn cssm(_map: &DepthMap, _shared: &Shared, _starts: &[Start]) -> Result<(Vec<f32>, [f64; 3])> {
    Err(crate::gpu::unavailable())
}
