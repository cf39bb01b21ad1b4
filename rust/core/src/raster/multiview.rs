//! Multi-view shadow mapping: one perspective depth map per light sample, and the per-receiver
//! weighted average of their PCF shadow tests (Herf and Heckbert 1996; the lighting stage of
//! `mvr` and `vwss`, Marrs et al. 2018, View-warped Multi-view Soft Shadows).
//!
//! Every view of a [`ViewSet`] has its eye at one light sample and shares one orientation,
//! field of view, depth range and resolution (Marrs et al. 2018, section 3.1: "the eye's fields of view
//! match the respective fields of view of the target light sample's depth-map views"). The
//! orientation is the one [`LightFrustum::fit`] picks from the light's center for the receivers'
//! bounds; the square field of view is the smallest that holds the receivers' bounding box from
//! every sample (with the margin [`FOV_MARGIN`]), so no receiver falls outside any view.
//!
//! Visibility is `V(p) = Σ_s w_s · PCF_s(p) / Σ_s w_s` with `w_s` the light's emission weight at
//! sample `s` (1 without a texture). A view whose eye lies behind the receiver's tangent plane
//! contributes 0, as in the ray-traced definition (`docs/design.md` section 3).

use crate::error::{Error, Result};
use crate::geometry::receivers::Receivers;
use crate::light::lights::Light;
use crate::light::sampling::lit_fraction;
use crate::raster::depth::DepthMap;
use crate::raster::frustum::{LightFrustum, FOV_MARGIN, MAX_FIT_TAN, NEAR_FRACTION};
use crate::raster::pcf::{DepthBias, PcfKernel};
use glam::Vec3;
use rayon::prelude::*;

/// One depth-map view per light sample, sharing orientation, field of view and resolution.
#[derive(Debug, Clone)]
pub struct ViewSet {
    /// One frustum per light sample (its eye), in sample order.
    pub views: Vec<LightFrustum>,
    /// The light's emission weight at each sample.
    pub weights: Vec<f32>,
}

impl ViewSet {
    /// Views from every light sample in `eyes` to the receivers' `bounds = (min, max)`, each
    /// `resolution²` texels (see the module documentation for the shared shape).
    ///
    /// `None` when the light lies among the receivers: its center or a sample inside (or level
    /// with) the receivers' bounds, so no perspective view from it contains them.
    ///
    /// Errors: no samples.
    pub fn fit(
        light: &Light,
        eyes: &[Vec3],
        bounds: (Vec3, Vec3),
        resolution: usize,
    ) -> Result<Option<Self>> {
        if eyes.is_empty() {
            return Err(Error::invalid("views", "needs at least one light sample"));
        }
        let Ok(base) = LightFrustum::fit(light.center(), bounds.0, bounds.1, resolution) else {
            return Ok(None);
        };
        let (lo, hi) = bounds;
        let corners: [Vec3; 8] = std::array::from_fn(|i| {
            Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo)
        });
        let (mut tan, mut z_min, mut z_max) = (0.0f32, f32::INFINITY, 0.0f32);
        for eye in eyes {
            for c in &corners {
                let d = *c - *eye;
                let z = d.dot(base.forward);
                let t = d.dot(base.right).abs().max(d.dot(base.up).abs()) / z;
                if !(z > 0.0 && t <= MAX_FIT_TAN) {
                    return Ok(None);
                }
                tan = tan.max(t);
                z_min = z_min.min(z);
                z_max = z_max.max(z);
            }
        }
        let tan = (tan * FOV_MARGIN).max(1e-4);
        let (near, far) = (NEAR_FRACTION * z_min, z_max * 1.001);
        let views = eyes
            .iter()
            .map(|&eye| LightFrustum {
                eye,
                near,
                far,
                tan_half_x: tan,
                tan_half_y: tan,
                ..base
            })
            .collect();
        Ok(Some(Self {
            views,
            weights: eyes.iter().map(|&y| light.weight(y)).collect(),
        }))
    }

    /// The number of views.
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// Whether there are no views.
    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// The sum of the weights.
    pub fn total_weight(&self) -> f64 {
        self.weights.iter().map(|&w| f64::from(w)).sum()
    }
}

/// Adds `w_s · PCF_s(p)` to `sums[i]` for every valid receiver `i` and every `(view index s,
/// depth map)` in `maps`, in the order given (so the sums do not depend on the thread count).
pub fn accumulate(
    sums: &mut [f32],
    views: &ViewSet,
    maps: &[(usize, &DepthMap)],
    rx: &Receivers,
    kernel: &PcfKernel,
    bias: DepthBias,
) {
    sums.par_iter_mut().enumerate().for_each(|(i, sum)| {
        if rx.valid[i] {
            for (s, map) in maps {
                let v = kernel.visibility(map, &views.views[*s], rx.points[i], rx.normals[i], bias);
                *sum += views.weights[*s] * v;
            }
        }
    });
}

/// The visibility from the accumulated sums: `sums[i] / total` in [0, 1], `total` the sum of
/// the samples' weights ([`ViewSet::total_weight`]); 0 for invalid receivers and when the
/// total weight is 0.
pub fn resolve(sums: &[f32], total: f64, rx: &Receivers) -> Vec<f32> {
    sums.iter()
        .zip(&rx.valid)
        .map(|(&s, &valid)| {
            if valid {
                lit_fraction(f64::from(s), total)
            } else {
                0.0
            }
        })
        .collect()
}
