//! The GPU half of mvr without the crate feature `gpu`: a rasterizer that cannot be made.
use crate::error::Result;
use crate::geometry::mesh::Scene;
use crate::gpu::multiview::Lighting;
use crate::raster::frustum::LightFrustum;

pub enum GpuRasterizer {}

impl GpuRasterizer {
    pub fn new(_scene: &Scene) -> Result<Self> {
        Err(crate::gpu::unavailable())
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
