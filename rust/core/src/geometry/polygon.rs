//! Convex polygon geometry shared by the methods: hulls, clipping, areas, and the polygons that
//! bound a circle.

use crate::light::lights::tangent_frame;
use glam::{DVec2, DVec3};

/// The convex hull of `points` in counter-clockwise order (Andrew's monotone chain; collinear
/// points dropped). Fewer than three distinct points give them back as they are.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let mut pts: Vec<DVec2> = points.iter().copied().filter(|p| p.is_finite()).collect();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Sutherland–Hodgman: the part of `poly` to the left of the directed line `a → b`.
pub fn clip_half_plane(poly: &[DVec2], a: DVec2, b: DVec2) -> Vec<DVec2> {
    clip_affine(poly, |p| (b - a).perp_dot(p - a))
}

/// Sutherland–Hodgman: the part of `poly` where the affine function `side` is >= 0.
pub fn clip_affine(poly: &[DVec2], side: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            out.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    out
}

/// The signed area of the polygon `poly` (positive counter-clockwise; shoelace formula).
pub fn signed_area(poly: &[DVec2]) -> f64 {
    0.5 * (0..poly.len())
        .map(|i| poly[i].perp_dot(poly[(i + 1) % poly.len()]))
        .sum::<f64>()
}

/// The part of the polytope `points` strictly on the side `sigma` of the plane `n · (x − v0) = 0`
/// and on it: the points on that side and the plane's crossings of every pair of points.
pub fn clip_to_side(points: &[DVec3], n: DVec3, v0: DVec3, sigma: f64) -> Vec<DVec3> {
    let d: Vec<f64> = points.iter().map(|q| sigma * n.dot(*q - v0)).collect();
    let mut out: Vec<DVec3> = points
        .iter()
        .zip(&d)
        .filter(|(_, &d)| d > 0.0)
        .map(|(q, _)| *q)
        .collect();
    if out.is_empty() {
        return out;
    }
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            if d[i] * d[j] < 0.0 {
                out.push(points[i] + (points[j] - points[i]) * (d[i] / (d[i] - d[j])));
            }
        }
    }
    out
}

/// The `degree`-gon circumscribing the circle of radius `r` about `c` in the plane normal to `n`.
pub fn circumscribed_polygon(c: DVec3, n: DVec3, r: f64, degree: usize) -> Vec<DVec3> {
    let (t, b) = tangent_frame(n.as_vec3());
    let (t, b) = (t.as_dvec3(), b.as_dvec3());
    let r = r / (std::f64::consts::PI / degree as f64).cos();
    (0..degree)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / degree as f64;
            c + (t * a.cos() + b * a.sin()) * r
        })
        .collect()
}

/// Vertices of a triangle clipped against five planes (one more per plane at most).
pub const MAX_CLIPPED: usize = 8;

/// A convex polygon of at most [`MAX_CLIPPED`] vertices, kept on the stack: a triangle clipped
/// by up to five planes (the rasterizer's near plane and guard band).
#[derive(Debug, Clone, Copy)]
pub struct ClippedPolygon {
    v: [DVec3; MAX_CLIPPED],
    n: usize,
}

impl ClippedPolygon {
    /// The triangle `v`, unclipped.
    pub fn triangle(v: [DVec3; 3]) -> Self {
        let mut poly = Self {
            v: [DVec3::ZERO; MAX_CLIPPED],
            n: 3,
        };
        poly.v[..3].copy_from_slice(&v);
        poly
    }

    /// The vertices, in order.
    pub fn vertices(&self) -> &[DVec3] {
        &self.v[..self.n]
    }

    /// The part where the signed distance `dist` to a plane is `>= 0` (Sutherland–Hodgman).
    pub fn clip(&self, dist: impl Fn(DVec3) -> f64) -> Self {
        let mut out = Self {
            v: [DVec3::ZERO; MAX_CLIPPED],
            n: 0,
        };
        for i in 0..self.n {
            let (a, b) = (self.v[i], self.v[(i + 1) % self.n]);
            let (da, db) = (dist(a), dist(b));
            // A convex polygon clipped by one plane gains at most one vertex, and at most five
            // planes clip a triangle, so `out.n < MAX_CLIPPED` holds at every push.
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                // From the inside vertex to the outside one: identical for both triangles of an edge.
                let (i_v, o_v, di, dout) = if da >= 0.0 {
                    (a, b, da, db)
                } else {
                    (b, a, db, da)
                };
                out.push(i_v + (o_v - i_v) * (di / (di - dout)));
            }
        }
        out
    }

    #[inline]
    fn push(&mut self, v: DVec3) {
        if self.n < MAX_CLIPPED {
            self.v[self.n] = v;
            self.n += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_inner_points() {
        let pts = [
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
        ];
        let hull = convex_hull(&pts);
        assert_eq!(hull.len(), 4);
        assert!(!hull.contains(&DVec2::new(1.0, 1.0)));
    }

    #[test]
    fn a_square_clipped_by_its_diagonal_keeps_half_its_area() {
        let square = [
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
        ];
        assert_eq!(signed_area(&square), 4.0);
        let half = clip_half_plane(&square, DVec2::new(0.0, 0.0), DVec2::new(2.0, 2.0));
        assert_eq!(signed_area(&half), 2.0);
    }

    #[test]
    fn a_triangle_clipped_by_a_plane_through_it_gains_a_vertex() {
        let tri = ClippedPolygon::triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        let clipped = tri.clip(|p| 0.5 - p.x);
        assert_eq!(clipped.vertices().len(), 4);
        assert!(clipped.vertices().iter().all(|p| p.x <= 0.5));
    }
}
