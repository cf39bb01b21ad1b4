//! Receivers: the points whose visibility a method computes (the papers' view samples).

use crate::error::{Error, Result};
use glam::Vec3;

/// `width * height` receivers in row-major order, each a point, a unit normal and a validity flag
/// (false for a G-buffer pixel that hit nothing; such receivers get visibility 0).
/// Explicit point sets use `height = 1`. The pixel grid drives interleaved sampling.
#[derive(Debug, Clone)]
pub struct Receivers {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub valid: Vec<bool>,
    pub width: usize,
    pub height: usize,
}

impl Receivers {
    /// Validates lengths and values; normals are normalized here.
    pub fn new(
        points: Vec<Vec3>,
        normals: Vec<Vec3>,
        valid: Vec<bool>,
        width: usize,
        height: usize,
    ) -> Result<Self> {
        let n = width * height;
        if points.len() != n || normals.len() != n || valid.len() != n {
            return Err(Error::invalid(
                "receivers",
                format!(
                    "expected {n} points, normals and flags, got {}, {}, {}",
                    points.len(),
                    normals.len(),
                    valid.len()
                ),
            ));
        }
        let mut normals = normals;
        for (i, (p, nrm)) in points.iter().zip(normals.iter_mut()).enumerate() {
            if !valid[i] {
                continue;
            }
            if !p.is_finite() {
                return Err(Error::invalid(
                    "points",
                    format!("receiver {i} is not finite: {p}"),
                ));
            }
            let len = nrm.length();
            if !len.is_finite() || len == 0.0 {
                return Err(Error::invalid(
                    "normals",
                    format!("receiver {i} has a zero or non-finite normal {nrm}"),
                ));
            }
            *nrm /= len;
        }
        Ok(Self {
            points,
            normals,
            valid,
            width,
            height,
        })
    }

    /// Number of receivers.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no receivers.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Pixel coordinates `(x, y)` of receiver `i`.
    #[inline]
    pub fn pixel(&self, i: usize) -> (usize, usize) {
        (i % self.width.max(1), i / self.width.max(1))
    }

    /// The points of the valid receivers, in order.
    pub fn valid_points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.points
            .iter()
            .zip(&self.valid)
            .filter(|(_, &v)| v)
            .map(|(&p, _)| p)
    }

    /// Bounds of the valid receivers, `None` when there are none.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.valid_points().fold(None, |acc, p| match acc {
            None => Some((p, p)),
            Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
        })
    }
}
