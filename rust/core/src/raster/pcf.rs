//! Percentage-closer filtering (Reeves et al. 1987) and the receiver-plane depth bias: the shadow
//! test every depth-map method shares (`shadow_map`, `mvr`, `vwss`, `pcss`).
//!
//! A tap compares a receiver depth with the depth stored in one texel and counts as lit when
//! `receiver_depth <= stored` (texels outside the map hold `+inf`, so they count as lit).
//!
//! **Receiver depth per tap.** With a constant `bias`, every tap uses the receiver's linear depth
//! less `bias`. By default ([`ReceiverDepth`]) each tap uses the depth of the receiver's tangent
//! plane at the tap's texel center (receiver plane depth bias; Schüler 2005, Isidoro 2006), so a
//! planar receiver never shadows itself however far the tap or however steep the plane, and the
//! bias left over is a small slack for curvature. Maps store linear depth (along the frustum's
//! `forward`), and on a plane `1/z` is an affine function of the texel coordinates: with `v` the
//! receiver's view-space position, `n_v` its view-space normal and `k = width / (2 tan_half_x)`
//! texels per unit of `x/z`, `∂(1/z)/∂sx = n_v.x / (k_x (n_v · v))` and
//! `∂(1/z)/∂sy = −n_v.y / (k_y (n_v · v))`. The slack is [`SLACK`] texels of the plane's depth gradient
//! `g = z² (|∂(1/z)/∂sx| + |∂(1/z)/∂sy|)`, capped at 10 texels of world size, plus
//! `1e-4 · z` for the round-off of the receiver positions; the predicted depth is kept within
//! `20 · (r + 1)` texels of world size of the receiver's own depth (`r` the tap's distance in
//! texels), where a plane seen nearly edge-on stops being a useful prediction. The plane lets
//! light leak only where an occluder lies within the slack of the receiver's plane; a single
//! worst-case slope bias for the whole kernel (`(r + 1)` texels of gradient) leaked far more on
//! curved, self-shadowing receivers (the bunny's ears and flanks).

use crate::error::{Error, Result};
use crate::raster::depth::DepthMap;
use crate::raster::frustum::LightFrustum;
use glam::{Vec2, Vec3};

/// The largest square PCF kernel side accepted.
pub const MAX_PCF_SIDE: usize = 63;

/// Slack of the receiver plane, in texels of the plane's depth gradient, one for every depth-map
/// method so that their errors differ by method and not by bias. A rasterized map stores the
/// surface's depth at the texel center, leaving the slack to curvature; a map of warped points
/// (`vwss`) keeps the nearest point anywhere in the texel, up to half a texel of gradient nearer,
/// and self-shadows the occluders more at the same slack, as Marrs et al. 2018 (section 5.1)
/// observe.
pub const SLACK: f32 = 0.5;

/// How shadow tests offset the receiver's depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DepthBias {
    /// A constant offset in world units of linear depth.
    Constant(f32),
    /// The receiver's tangent plane per tap, less `slack` texels of its depth gradient.
    ReceiverPlane { slack: f32 },
}

impl DepthBias {
    /// `Some(b)`: a constant bias `b >= 0`; `None`: the receiver plane with [`SLACK`].
    pub fn new(bias: Option<f32>) -> Result<Self> {
        match bias {
            None => Ok(DepthBias::ReceiverPlane { slack: SLACK }),
            Some(b) if b.is_finite() && b >= 0.0 => Ok(DepthBias::Constant(b)),
            Some(b) => Err(Error::invalid(
                "bias",
                format!("must be finite and >= 0 (or None for auto), got {b}"),
            )),
        }
    }
}

/// The receiver depth each tap of a shadow test compares with (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub struct ReceiverDepth {
    /// Texel coordinates and linear depth of the receiver.
    s: Vec3,
    /// `1 / s.z`, which every prediction starts from.
    inv_z: f32,
    /// `∂(1/z)/∂sx`, `∂(1/z)/∂sy` of the receiver's tangent plane (0 with a constant bias).
    grad: Vec2,
    /// Subtracted from every predicted depth.
    slack: f32,
    /// The largest distance of a prediction from `s.z`, per texel of tap distance plus one.
    reach: f32,
}

impl ReceiverDepth {
    /// The receiver at `p` (unit normal `n`) whose projection into `frustum` is `s = (sx, sy, z)`.
    pub fn new(frustum: &LightFrustum, p: Vec3, n: Vec3, s: Vec3, bias: DepthBias) -> Self {
        let slack_texels = match bias {
            DepthBias::Constant(b) => {
                return Self {
                    s,
                    inv_z: 1.0 / s.z,
                    grad: Vec2::ZERO,
                    slack: b,
                    reach: 0.0,
                }
            }
            DepthBias::ReceiverPlane { slack } => slack,
        };
        let v = frustum.to_view(p);
        let n_v = Vec3::new(
            n.dot(frustum.right),
            n.dot(frustum.up),
            n.dot(frustum.forward),
        );
        let facing = n_v.dot(v);
        let k = Vec2::new(
            frustum.width as f32 / (2.0 * frustum.tan_half_x),
            frustum.height as f32 / (2.0 * frustum.tan_half_y),
        );
        let grad = if facing != 0.0 {
            Vec2::new(n_v.x / k.x, -n_v.y / k.y) / facing
        } else {
            Vec2::ZERO
        };
        let texel = frustum.texel_world_size(s.z);
        let gradient = s.z * s.z * (grad.x.abs() + grad.y.abs());
        let slack = slack_texels * gradient.min(10.0 * texel) + 1e-4 * s.z;
        let grad = if grad.is_finite() { grad } else { Vec2::ZERO };
        Self {
            s,
            inv_z: 1.0 / s.z,
            grad,
            slack,
            reach: 20.0 * texel,
        }
    }

    /// The receiver's linear depth.
    pub fn depth(&self) -> f32 {
        self.s.z
    }

    /// The receiver's texel coordinates.
    pub fn texel_coords(&self) -> Vec2 {
        Vec2::new(self.s.x, self.s.y)
    }

    /// The depth to compare with the depth stored in texel `(x, y)`.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> f32 {
        self.predict(x as f32 + 0.5 - self.s.x, y as f32 + 0.5 - self.s.y)
    }

    /// [`ReceiverDepth::at`] of the texels `(x0 + k, y)` for `k` in `0..out.len()`, into `out`:
    /// the same bits, in a loop without branches that the compiler vectorizes. Texel coordinates
    /// are below [`crate::raster::frustum::MAX_RESOLUTION`], so exact as `i32` and as `f32`.
    pub fn at_row(&self, x0: i32, y: i32, out: &mut [f32]) {
        let dy = y as f32 + 0.5 - self.s.y;
        for (x, o) in (x0..).zip(out.iter_mut()) {
            *o = self.predict(x as f32 + 0.5 - self.s.x, dy);
        }
    }

    /// The predicted depth `dx`, `dy` texels away from the receiver's projection.
    #[inline]
    fn predict(&self, dx: f32, dy: f32) -> f32 {
        let inv = self.inv_z + self.grad.x * dx + self.grad.y * dy;
        let limit = self.reach * (dx.abs().max(dy.abs()) + 1.0);
        let (lo, hi) = (self.s.z - limit, self.s.z + limit);
        let plane = if inv > 0.0 {
            // `(1 / inv).clamp(lo, hi)`, less its check of `lo <= hi` (`limit >= 0`), which
            // keeps the loop of `at_row` from vectorizing.
            let v = 1.0 / inv;
            if v < lo {
                lo
            } else if v > hi {
                hi
            } else {
                v
            }
        } else {
            hi
        };
        plane - self.slack
    }
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
            return Err(Error::invalid(
                "pcf",
                format!("must be odd and in 1..={MAX_PCF_SIDE} (taps per side), got {side}"),
            ));
        }
        let r = (side / 2) as i64;
        let offsets = (-r..=r)
            .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
            .collect();
        Ok(Self { offsets, radius: r })
    }

    /// A kernel of `taps` taps in all: 1 (the texel itself), 5 (the texel and its four edge
    /// neighbours: the 5-sample filter of Marrs et al. 2018, Tables 1–2) or the square of an odd side
    /// (9 = 3 × 3, 25 = 5 × 5, ...).
    pub fn with_taps(taps: usize) -> Result<Self> {
        if taps == 5 {
            return Ok(Self {
                offsets: vec![(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)],
                radius: 1,
            });
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

    /// The taps' texel offsets from the receiver's texel.
    pub fn offsets(&self) -> &[(i64, i64)] {
        &self.offsets
    }

    /// The number of taps.
    pub fn taps(&self) -> usize {
        self.offsets.len()
    }

    /// The largest offset along either axis, in texels.
    pub fn radius(&self) -> i64 {
        self.radius
    }

    /// The fraction of taps around the receiver's texel whose stored depth is at least the
    /// receiver depth for that tap.
    #[inline]
    pub fn lit_fraction(&self, map: &DepthMap, receiver: &ReceiverDepth) -> f32 {
        let s = receiver.texel_coords();
        let (cx, cy) = (s.x.floor() as i64, s.y.floor() as i64);
        let lit = self
            .offsets
            .iter()
            .filter(|(dx, dy)| receiver.at(cx + dx, cy + dy) <= map.get(cx + dx, cy + dy))
            .count();
        lit as f32 / self.offsets.len() as f32
    }

    /// Hard-shadow visibility of a receiver at `p` (unit normal `n`) through `map` rendered from
    /// `frustum`: 0 when the receiver faces away from the eye (`n · (eye − p) <= 0`, as in the
    /// ray-traced definition), 1 when it lies nearer than the near plane or projects outside the
    /// map (the map says nothing about it), else the lit fraction with `bias`.
    pub fn visibility(
        &self,
        map: &DepthMap,
        frustum: &LightFrustum,
        p: Vec3,
        n: Vec3,
        bias: DepthBias,
    ) -> f32 {
        if n.dot(frustum.eye - p) <= 0.0 {
            return 0.0;
        }
        let Some(s) = frustum.project(p) else {
            return 1.0;
        };
        if !(s.x >= 0.0 && s.y >= 0.0 && s.x < map.width as f32 && s.y < map.height as f32) {
            return 1.0;
        }
        self.lit_fraction(map, &ReceiverDepth::new(frustum, p, n, s, bias))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tap_counts() {
        assert_eq!(PcfKernel::with_taps(1).unwrap().taps(), 1);
        assert_eq!(PcfKernel::with_taps(5).unwrap().radius(), 1);
        assert_eq!(
            PcfKernel::with_taps(25).unwrap(),
            PcfKernel::square(5).unwrap()
        );
        for bad in [0, 2, 4, 16, 3] {
            assert!(PcfKernel::with_taps(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn cross_counts_lit_neighbours() {
        let mut map = DepthMap::empty(3, 3).unwrap();
        map.depth[1] = 0.5; // the texel above the center
        let k = PcfKernel::with_taps(5).unwrap();
        let frustum =
            LightFrustum::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 90.0, 1.0, 0.1, 10.0, 3, 3).unwrap();
        let at = |depth: f32| {
            ReceiverDepth::new(
                &frustum,
                Vec3::ZERO,
                Vec3::Z,
                Vec3::new(1.5, 1.5, depth),
                DepthBias::Constant(0.0),
            )
        };
        assert_eq!(k.lit_fraction(&map, &at(1.0)), 0.8);
        assert_eq!(k.lit_fraction(&map, &at(0.25)), 1.0);
    }
}
