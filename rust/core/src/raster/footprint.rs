//! The light's footprint in a depth map rendered from its center: the region of the map through
//! which a receiver sees the light. Blocker searches and filter kernels of the single-view soft
//! shadow methods (`pcss`, `cssm`) are sized by it.
//!
//! Seen from a receiver at linear depth `z_r`, the light (half extent `h` along a map axis, in its
//! plane at depth 0 around the eye) projects through the plane at depth `z` onto a region of half
//! extent `k · h · (z_r − z) / (z_r · z)` texels around the receiver's own texel, with
//! `k = width / (2 tan_half_x)` texels per unit of `x/z` (likewise for `y`). This is Fernando's
//! `LIGHT_SIZE_UV · (z_r − NEAR) / z_r` written for a perspective map, and at a blocker depth `z` it
//! is the parallel-planes penumbra estimate mapped into the map (Annen et al.
//! 2008, All-Frequency Shadows in Dynamic Scenes, Figure 2).

use crate::light::lights::Light;
use crate::raster::frustum::LightFrustum;
use glam::Vec2;

/// `k · h` per map axis for one light and frustum (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightFootprint {
    texels: Vec2,
    map: Vec2,
}

impl LightFootprint {
    /// The footprint of `light` in a map rendered through `frustum` (whose eye is the light's
    /// center); anisotropic for lights longer along one map axis than the other.
    pub fn new(frustum: &LightFrustum, light: &Light) -> Self {
        let k = Vec2::new(
            frustum.width as f32 / (2.0 * frustum.tan_half_x),
            frustum.height as f32 / (2.0 * frustum.tan_half_y),
        );
        let h = Vec2::new(
            light.half_extent_along(frustum.right),
            light.half_extent_along(frustum.up),
        );
        Self {
            texels: k * h,
            map: Vec2::new(frustum.width as f32, frustum.height as f32),
        }
    }

    /// Half extents in texels per unit `(z_r − z) / (z_r z)`, before capping.
    pub fn texels(&self) -> Vec2 {
        self.texels
    }

    /// Half extents in texels, per axis, of the light's projection through depth `z` seen from
    /// receiver depth `z_r` (capped at the map's size).
    pub fn through(&self, z_r: f32, z: f32) -> Vec2 {
        (self.texels * ((z_r - z) / (z_r * z))).clamp(Vec2::ZERO, self.map)
    }
}
