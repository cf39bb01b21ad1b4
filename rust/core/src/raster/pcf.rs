//! Percentage-closer filtering (Reeves et al. 1987) and the slope-scaled depth bias: the shadow
//! test every depth-map method shares (`shadow_map`, `mvr`, `vwss`, `pcss`).
//!
//! A tap compares the receiver's linear depth, less the bias, with the depth stored in one texel
//! and counts as lit when `receiver_depth − bias <= stored` (texels outside the map hold `+inf`,
//! so they count as lit).
//!
//! **Slope-scaled bias.** Maps store linear depth (along the frustum's `forward`), so on the
//! receiver's tangent plane the stored depth changes across texels by the plane's screen-space
//! depth gradient: with `v` the receiver's view-space position (depth `z = v.z`) and `n_v` its
//! view-space normal, `|∂z/∂sx| = z² |n_v.x| / (k_x |n_v · v|)` (and likewise for `sy`), with
//! `k_x = width / (2 tan_half_x)` texels per unit of `x/z`. A tap `r` texels from the receiver's
//! own texel can then hold the receiver's own surface at a depth up to
//! `(r + 0.5) (|∂z/∂sx| + |∂z/∂sy|)` nearer, so [`slope_bias`] is
//! `1.5 · (r + 1) · min(|∂z/∂sx| + |∂z/∂sy|, 20 · texel_world_size(z)) + 1e-4 · z`; the factor 1.5
//! covers curved receivers and the relative term float round-off of the receiver positions. On
//! the frustum's axis this is the textbook `texel · tan θ`; off axis, where the direction to the
//! eye and `forward` differ, the gradient is not small even for a receiver that faces the eye.
//! Like every bias it lets light leak over that distance at contact points ("peter panning").

use crate::error::{Error, Result};
use crate::raster::depth::{DepthMap, LightFrustum};
use glam::Vec3;

/// The largest square PCF kernel side accepted.
pub const MAX_PCF_SIDE: usize = 63;

/// The slope-scaled depth bias (world units of linear depth) for a receiver at `p` with unit
/// normal `n` at linear depth `depth` in `frustum`, read by taps up to `radius` texels from its
/// own texel (see the module documentation).
pub fn slope_bias(frustum: &LightFrustum, p: Vec3, n: Vec3, depth: f32, radius: f32) -> f32 {
    let v = frustum.to_view(p);
    let n_v = Vec3::new(n.dot(frustum.right), n.dot(frustum.up), n.dot(frustum.forward));
    let texel = frustum.texel_world_size(depth);
    let per_x = 2.0 * frustum.tan_half_x / frustum.width as f32;
    let per_y = 2.0 * frustum.tan_half_y / frustum.height as f32;
    let rise = depth * depth * (n_v.x.abs() * per_x + n_v.y.abs() * per_y);
    let facing = n_v.dot(v).abs();
    let gradient = if rise < 20.0 * texel * facing { rise / facing } else { 20.0 * texel };
    1.5 * (radius + 1.0) * gradient + 1e-4 * depth
}

/// A PCF kernel: texel offsets around the texel that contains the receiver's projection.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PcfKernel {
    offsets: Vec<(i64, i64)>,
    radius: i64,
}

impl PcfKernel {
    /// `side × side` taps (odd side, at most [`MAX_PCF_SIDE`]); `side = 1` is a single tap.
    pub fn square(side: usize) -> Result<Self> {
        if side & 1 == 0 || side > MAX_PCF_SIDE {
            return Err(Error::invalid("pcf", format!("must be odd and in 1..={MAX_PCF_SIDE} (taps per side), got {side}")));
        }
        let r = (side / 2) as i64;
        let offsets = (-r..=r).flat_map(|dy| (-r..=r).map(move |dx| (dx, dy))).collect();
        Ok(Self { offsets, radius: r })
    }

    /// A kernel of `taps` taps in all: 1 (the texel itself), 5 (the texel and its four edge
    /// neighbours: the 5-sample filter of seed 004's Tables 1–2) or the square of an odd side
    /// (9 = 3 × 3, 25 = 5 × 5, ...).
    pub fn with_taps(taps: usize) -> Result<Self> {
        if taps == 5 {
            return Ok(Self { offsets: vec![(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)], radius: 1 });
        }
        let side = (taps as f64).sqrt().round() as usize;
        if side * side != taps || side & 1 == 0 || side > MAX_PCF_SIDE {
            return Err(Error::invalid(
                "pcf",
                format!("must be 1, 5 (a cross) or the square of an odd side up to {MAX_PCF_SIDE} (9, 25, ...) taps, got {taps}"),
            ));
        }
        Self::square(side)
    }

    /// The number of taps.
    pub fn taps(&self) -> usize {
        self.offsets.len()
    }

    /// The largest offset along either axis, in texels.
    pub fn radius(&self) -> i64 {
        self.radius
    }

    /// The fraction of taps around the texel containing `(sx, sy)` whose stored depth is
    /// `>= depth` (`depth`: the receiver's linear depth with the bias already subtracted).
    #[inline]
    pub fn lit_fraction(&self, map: &DepthMap, sx: f32, sy: f32, depth: f32) -> f32 {
        let (cx, cy) = (sx.floor() as i64, sy.floor() as i64);
        let lit = self.offsets.iter().filter(|(dx, dy)| depth <= map.get(cx + dx, cy + dy)).count();
        lit as f32 / self.offsets.len() as f32
    }

    /// Hard-shadow visibility of a receiver at `p` (unit normal `n`) through `map` rendered from
    /// `frustum`: 0 when the receiver faces away from the eye (`n · (eye − p) <= 0`, as in the
    /// ray-traced definition), 1 when it lies nearer than the near plane or projects outside the
    /// map (the map says nothing about it), else the lit fraction with `bias` (`None`:
    /// [`slope_bias`] for this kernel's radius).
    pub fn visibility(&self, map: &DepthMap, frustum: &LightFrustum, p: Vec3, n: Vec3, bias: Option<f32>) -> f32 {
        if n.dot(frustum.eye - p) <= 0.0 {
            return 0.0;
        }
        let Some(s) = frustum.project(p) else { return 1.0 };
        if !(s.x >= 0.0 && s.y >= 0.0 && s.x < map.width as f32 && s.y < map.height as f32) {
            return 1.0;
        }
        let bias = bias.unwrap_or_else(|| slope_bias(frustum, p, n, s.z, self.radius as f32));
        self.lit_fraction(map, s.x, s.y, s.z - bias)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tap_counts() {
        assert_eq!(PcfKernel::with_taps(1).unwrap().taps(), 1);
        assert_eq!(PcfKernel::with_taps(5).unwrap().radius(), 1);
        assert_eq!(PcfKernel::with_taps(25).unwrap(), PcfKernel::square(5).unwrap());
        for bad in [0, 2, 4, 16, 3] {
            assert!(PcfKernel::with_taps(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn cross_counts_lit_neighbours() {
        let mut map = DepthMap::empty(3, 3).unwrap();
        map.depth[1] = 0.5; // the texel above the center
        let k = PcfKernel::with_taps(5).unwrap();
        assert_eq!(k.lit_fraction(&map, 1.5, 1.5, 1.0), 0.8);
        assert_eq!(k.lit_fraction(&map, 1.5, 1.5, 0.25), 1.0);
    }
}
