//! The GPU half of vwss without the crate feature `gpu`: a warper that cannot be made.
use crate::error::Result;
use crate::gpu::multiview::Lighting;
use crate::raster::frustum::LightFrustum;

pub enum Warper {}

impl Warper {
    pub fn new(_points: impl ExactSizeIterator<Item = glam::Vec3>) -> Result<Self> {
        Err(crate::gpu::unavailable())
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
