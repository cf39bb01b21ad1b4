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
    let n = pts.len();
    for pass in 0..2 {
        let start = hull.len();
        // The lower chain left to right, then the upper one right to left.
        for i in 0..n {
            let p = pts[if pass == 0 { i } else { n - 1 - i }];
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

/// Sutherland–Hodgman: the part of `poly` to the left of the directed line `a → b`, written to
/// `out` (cleared first, so that a caller clipping many polygons reuses one buffer).
pub fn clip_half_plane(poly: &[DVec2], a: DVec2, b: DVec2, out: &mut Vec<DVec2>) {
    let sides: Vec<f64> = poly.iter().map(|&p| side_of(a, b, p)).collect();
    clip_to_vec(poly, &sides, out);
}

/// Sutherland–Hodgman: the part of `poly` where the affine function `side` is >= 0.
pub fn clip_affine(poly: &[DVec2], side: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let sides: Vec<f64> = poly.iter().map(|&p| side(p)).collect();
    let mut out = Vec::with_capacity(poly.len() + 1);
    clip_to_vec(poly, &sides, &mut out);
    out
}

/// The clip of `poly` by its vertices' sides, written to `out` (cleared first).
fn clip_to_vec(poly: &[DVec2], sides: &[f64], out: &mut Vec<DVec2>) {
    out.clear();
    clip_by_sides(poly, sides, |v| {
        out.push(v);
        Some(())
    });
}

/// Where `p` lies relative to the directed line `a → b`: positive on its left.
#[inline]
fn side_of(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    (b - a).perp_dot(p - a)
}

/// The index of the vertex after `i` of a polygon of `n` vertices.
#[inline]
fn after(i: usize, n: usize) -> usize {
    if i + 1 == n {
        0
    } else {
        i + 1
    }
}

/// [`clip_half_plane`] with the vertices' sides (of [`side_of`]) given, each vertex of the result
/// handed to `push`; stops at the first `None` it returns.
#[inline]
fn clip_by_sides(
    poly: &[DVec2],
    sides: &[f64],
    mut push: impl FnMut(DVec2) -> Option<()>,
) -> Option<()> {
    let n = poly.len().min(sides.len());
    for i in 0..n {
        let j = after(i, n);
        let (p, q, sp, sq) = (poly[i], poly[j], sides[i], sides[j]);
        if sp >= 0.0 {
            push(p)?;
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            push(p + (q - p) * (sp / (sp - sq)))?;
        }
    }
    Some(())
}

/// A convex polygon (counter-clockwise, around the origin) that measures the part of other
/// polygons inside it: Sutherland–Hodgman against each of its edges in turn, then the shoelace
/// area, on fixed buffers.
///
/// Three shortcuts leave every bit of the result as the full clip gives it:
/// - an edge that has every vertex on its inner side leaves the polygon as it is (the clip keeps
///   each vertex, in order, and adds none), so it is skipped;
/// - a polygon inside the window's inscribed disk or inscribed square about the origin, both
///   shrunk by a relative `1e-9`, is inside every edge, so it is its own clip;
/// - a polygon whose vertices all lie outside one edge by `1e-9` of the edge's length times
///   `1 + M` (`M` the largest coordinate of the polygon and the window) clips to nothing: each
///   clip by an earlier edge adds vertices on the segments between the ones it had, off them by
///   a few units of round-off times `M`, so after at most a few hundred clips they still lie
///   outside that edge, where the clip drops them all. (A polygon with a vertex that is not
///   finite takes the full clip.)
///
/// The margins of `1e-9` exceed those round-offs (some `1e-16` times `M` per operation) by
/// orders of magnitude.
#[derive(Debug, Clone)]
pub struct ConvexWindow {
    edges: Vec<WindowEdge>,
    /// The squared radius of the shrunk inscribed disk (0 when the origin lies outside).
    disk_squared: f64,
    /// The half side of the shrunk inscribed square (0 when the origin lies outside).
    square: f64,
    /// The largest coordinate of the outline.
    extent: f64,
}

/// An edge `a → b` of a [`ConvexWindow`], with `b − a` and its length.
#[derive(Debug, Clone, Copy)]
struct WindowEdge {
    a: DVec2,
    b: DVec2,
    dir: DVec2,
    length: f64,
}

/// The margins of [`ConvexWindow`]'s shortcuts, relative.
const MARGIN: f64 = 1e-9;

/// The most vertices [`ClipBuffers`] holds; a clip that would exceed it starts again on the
/// heap with [`clip_half_plane`].
const CLIP_CAPACITY: usize = 32;

/// The scratch of [`ConvexWindow::clipped_area`]: the polygon, its clipped successor and the
/// vertices' sides of the edge at hand.
#[derive(Debug, Clone)]
pub struct ClipBuffers {
    poly: [DVec2; CLIP_CAPACITY],
    next: [DVec2; CLIP_CAPACITY],
    sides: [f64; CLIP_CAPACITY],
}

impl Default for ClipBuffers {
    fn default() -> Self {
        Self {
            poly: [DVec2::ZERO; CLIP_CAPACITY],
            next: [DVec2::ZERO; CLIP_CAPACITY],
            sides: [0.0; CLIP_CAPACITY],
        }
    }
}

impl ConvexWindow {
    /// The window whose outline is `outline`, counter-clockwise.
    pub fn new(outline: &[DVec2]) -> Self {
        let n = outline.len();
        let edges: Vec<WindowEdge> = (0..n)
            .map(|i| {
                let (a, b) = (outline[i], outline[after(i, n)]);
                WindowEdge {
                    a,
                    b,
                    dir: b - a,
                    length: (b - a).length(),
                }
            })
            .collect();
        // Per edge, the origin's distance `h` to it and its unit normal `u`: the disk of radius
        // `h` and the square of half side `h / (|u.x| + |u.y|)` lie on its inner side.
        let (disk, square) = edges
            .iter()
            .map(|e| {
                let (h, u) = (
                    side_of(e.a, e.b, DVec2::ZERO) / e.length,
                    e.dir.perp() / e.length,
                );
                (h, h / (u.x.abs() + u.y.abs()))
            })
            .fold((f64::INFINITY, f64::INFINITY), |(d, s), (h, q)| {
                (d.min(h), s.min(q))
            });
        let shrink = |r: f64| r.max(0.0) * (1.0 - MARGIN);
        Self {
            edges,
            disk_squared: shrink(disk).powi(2),
            square: shrink(square),
            extent: outline
                .iter()
                .map(|v| v.abs().max_element())
                .fold(0.0, f64::max),
        }
    }

    /// Whether the polygon of bounding box `(lo, hi)` lies inside every edge, by the second
    /// shortcut of the type's documentation.
    #[inline]
    fn surely_inside(&self, poly: &[DVec2], (lo, hi): (DVec2, DVec2)) -> bool {
        lo.abs().max(hi.abs()).max_element() < self.square
            || poly.iter().all(|v| v.length_squared() < self.disk_squared)
    }

    /// Whether the polygon of bounding box `(lo, hi)` clips to nothing, by the third shortcut of
    /// the type's documentation: an edge's side is linear, so over the box it is largest at the
    /// corner its inner normal points to, and that corner must lie outside by the margin.
    #[inline]
    fn surely_outside(&self, (lo, hi): (DVec2, DVec2)) -> bool {
        let m = lo.abs().max(hi.abs()).max_element().max(self.extent);
        self.edges.iter().any(|e| {
            let corner = DVec2::new(
                if e.dir.y < 0.0 { hi.x } else { lo.x },
                if e.dir.x > 0.0 { hi.y } else { lo.y },
            );
            e.dir.perp_dot(corner - e.a) < -MARGIN * e.length * (1.0 + m)
        })
    }

    /// The unsigned area of the part of `poly` inside the window: the same bits as clipping
    /// `poly` by [`clip_half_plane`] against each edge in order and taking [`signed_area`]'s
    /// magnitude.
    #[inline]
    pub fn clipped_area(&self, poly: &[DVec2], buffers: &mut ClipBuffers) -> f64 {
        if let Some(bounds) = finite_bounds(poly) {
            if self.surely_inside(poly, bounds) {
                return signed_area(poly).abs();
            }
            if self.surely_outside(bounds) {
                return 0.0;
            }
        }
        self.clip(poly, buffers)
    }

    /// [`ConvexWindow::clipped_area`] of a polygon that no shortcut settles, clipped edge by edge.
    fn clip(&self, poly: &[DVec2], buffers: &mut ClipBuffers) -> f64 {
        if poly.len() > CLIP_CAPACITY {
            return self.clipped_area_on_heap(poly);
        }
        let (mut current, mut next) = (&mut buffers.poly, &mut buffers.next);
        let sides = &mut buffers.sides;
        current[..poly.len()].copy_from_slice(poly);
        let mut n = poly.len();
        for e in &self.edges {
            // `side_of(e.a, e.b, p)` with `e.b − e.a` computed once.
            let mut inside = true;
            for i in 0..n {
                sides[i] = e.dir.perp_dot(current[i] - e.a);
                inside &= sides[i] >= 0.0;
            }
            if inside {
                continue;
            }
            let Some(m) = clip_into(&current[..n], &sides[..n], next) else {
                return self.clipped_area_on_heap(poly);
            };
            std::mem::swap(&mut current, &mut next);
            n = m;
            if n == 0 {
                return 0.0;
            }
        }
        signed_area(&current[..n]).abs()
    }

    /// [`ConvexWindow::clipped_area`] by the plain chain of [`clip_half_plane`].
    fn clipped_area_on_heap(&self, poly: &[DVec2]) -> f64 {
        let (mut current, mut next) = (poly.to_vec(), Vec::new());
        for e in &self.edges {
            clip_half_plane(&current, e.a, e.b, &mut next);
            std::mem::swap(&mut current, &mut next);
            if current.is_empty() {
                return 0.0;
            }
        }
        signed_area(&current).abs()
    }
}

/// The bounding box `(min, max)` of `poly`, `None` when it is empty or a vertex is not finite.
#[inline]
fn finite_bounds(poly: &[DVec2]) -> Option<(DVec2, DVec2)> {
    let first = *poly.first()?;
    let mut bounds = (first, first);
    for &v in poly {
        if !v.is_finite() {
            return None;
        }
        bounds = (bounds.0.min(v), bounds.1.max(v));
    }
    Some(bounds)
}

/// [`clip_by_sides`] into a fixed buffer: the vertices written, or `None` when they do not fit.
fn clip_into(poly: &[DVec2], sides: &[f64], out: &mut [DVec2; CLIP_CAPACITY]) -> Option<usize> {
    let mut m = 0;
    clip_by_sides(poly, sides, |v| {
        *out.get_mut(m)? = v;
        m += 1;
        Some(())
    })?;
    Some(m)
}

/// The signed area of the polygon `poly` (positive counter-clockwise; shoelace formula).
#[inline]
pub fn signed_area(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    0.5 * (0..n)
        .map(|i| poly[i].perp_dot(poly[after(i, n)]))
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
        let mut half = Vec::new();
        clip_half_plane(
            &square,
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 2.0),
            &mut half,
        );
        assert_eq!(signed_area(&half), 2.0);
    }

    /// The clip chain [`ConvexWindow::clipped_area`] must match bit for bit: each edge's
    /// half-plane in turn on the heap, nothing once empty, the area's magnitude.
    fn chain_area(poly: &[DVec2], outline: &[DVec2]) -> f64 {
        let mut current = poly.to_vec();
        for i in 0..outline.len() {
            let mut next = Vec::new();
            clip_half_plane(
                &current,
                outline[i],
                outline[after(i, outline.len())],
                &mut next,
            );
            current = next;
            if current.is_empty() {
                return 0.0;
            }
        }
        signed_area(&current).abs()
    }

    #[test]
    fn a_window_measures_the_same_bits_as_the_clip_chain() {
        let square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(DVec2::from);
        let gon: Vec<DVec2> = (0..64)
            .map(|i| DVec2::from_angle(std::f64::consts::TAU * i as f64 / 64.0) * 1.0013)
            .collect();
        let mut rng = crate::light::sampling::Rng::new(7);
        let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * f64::from(rng.next_f32());
        let mut buffers = ClipBuffers::default();
        let mut seen = [0usize; 3];
        for outline in [&square[..], &gon[..]] {
            let window = ConvexWindow::new(outline);
            for k in 0..40_000 {
                // Quads (projected micro-occluders), degenerate ones, and stars of up to 60
                // vertices (more than the fixed buffers hold), from far inside to far outside.
                let n = match k % 10 {
                    0 => 3 + (k / 10) % 58,
                    _ => 4,
                };
                let (center, radius) = (
                    DVec2::new(uniform(-3.0, 3.0), uniform(-3.0, 3.0)),
                    10f64.powf(uniform(-6.0, 1.0)),
                );
                let mut poly: Vec<DVec2> = (0..n)
                    .map(|_| center + DVec2::new(uniform(-1.0, 1.0), uniform(-1.0, 1.0)) * radius)
                    .collect();
                if k % 7 == 1 {
                    // Collinear vertices along a line through the window's edge.
                    let dir = DVec2::new(uniform(-1.0, 1.0), uniform(-1.0, 1.0));
                    poly = (0..n)
                        .map(|i| DVec2::new(1.0, 0.5) + dir * (i as f64 - 1.5))
                        .collect();
                }
                let mut same_bits = |poly: &[DVec2]| {
                    let (fast, chain) = (
                        window.clipped_area(poly, &mut buffers),
                        chain_area(poly, outline),
                    );
                    assert_eq!(
                        fast.to_bits(),
                        chain.to_bits(),
                        "{poly:?}: {fast} against {chain}"
                    );
                    chain
                };
                if k % 11 == 5 {
                    // A vertex that is not finite, which no shortcut may settle.
                    let mut broken = poly.clone();
                    broken[k % n].x = [f64::INFINITY, f64::NEG_INFINITY, f64::NAN][k % 3];
                    same_bits(&broken);
                }
                let chain = same_bits(&poly);
                seen[if chain == 0.0 {
                    0
                } else if chain == signed_area(&poly).abs() {
                    1
                } else {
                    2
                }] += 1;
            }
        }
        assert!(
            seen.iter().all(|&n| n > 5000),
            "outside, inside, straddling: {seen:?}"
        );
    }

    #[test]
    fn a_triangle_clipped_by_a_plane_through_it_gains_a_vertex() {
        let tri = ClippedPolygon::triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        let clipped = tri.clip(|p| 0.5 - p.x);
        assert_eq!(clipped.vertices().len(), 4);
        assert!(clipped.vertices().iter().all(|p| p.x <= 0.5));
    }
}
