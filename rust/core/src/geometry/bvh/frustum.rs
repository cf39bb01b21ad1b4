//! Shared-origin culling for the shadow rays of one receiver.
//!
//! All shadow rays of a receiver leave the same point `o` for targets on the light. Before
//! tracing them one by one, one traversal collects the leaves whose boxes meet the *frustum*
//! of these segments: the pyramid with apex `o` bounded by four planes through `o` (the extreme
//! slopes of the directions over their dominant axis), cut by the bounding box of `o` and the
//! targets. When that traversal finds no leaf, every ray is unblocked; when it finds a few, each
//! ray is tested against those leaves only, with the same watertight test as the BVH traversal;
//! when it finds more than [`MAX_CANDIDATES`] it gives up and the rays traverse the BVH one by one.
//!
//! Conservativeness (answers must equal the per-ray traversal): the slopes are widened by
//! `1e-4` of their magnitude, the plane test accepts a box whose maximal signed distance is
//! above `-1e-5` times the magnitude of its terms, and the box is widened by `1e-5` of its
//! extent, all far above the float rounding (~6e-8 relative) of the slopes, of the plane
//! distances and of the watertight test. A leaf holding a triangle that any ray hits is
//! therefore always collected; extra leaves cost time only.

use super::{LeafRef, Node4, Root, LEAF, STACK};
use glam::{Vec3, Vec4};

/// Most leaves collected before falling back to per-ray traversal.
///
/// On the bunny with 64 shared samples (`bench/shadow_rays.py`'s rays, one thread, alternating
/// processes, same bits), 48 took 0.95-0.98x the CPU time of 24 at 128x128 receivers, where
/// the packets of the receivers left over are least coherent, but 0.98-1.00x at
/// 256x256 and 1.02-1.08x at 512x512; 16 took 0.99-1.03x at 128x128. Sending every receiver
/// through its frustum pass (not skipping those whose neighbours went to the packets) took
/// 1.05-1.10x at 128x128 with 48 to 128 candidates.
pub(super) const MAX_CANDIDATES: usize = 24;

/// One bounding plane `n . (p - o) >= 0` with `n` non-zero on axes `a` and `k` only.
#[derive(Debug, Clone, Copy)]
struct Plane {
    a: usize,
    na: Vec4,
    /// Which bound (0 min, 1 max) maximizes `n_a (p_a - o_a)`.
    sel_a: usize,
    nk: Vec4,
    sel_k: usize,
}

/// A plane that every segment of a frustum lies strictly in front of:
/// `normal . (x - point) > 0` at every point `x` of every segment.
///
/// The tangent plane of a receiver is one: its rays start at `point + epsilon normal` and go
/// only to the samples in front of it (`docs/design.md` section 3), so every point of them lies
/// in front. A leaf wholly behind it holds no hit, though its box meets the frustum whenever it
/// touches the apex: on a curved receiver the neighbouring triangles of the surface lie just
/// behind the plane, in boxes around the ray origin that the frustum and every lane's slope
/// test accept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrontPlane {
    pub point: Vec3,
    pub normal: Vec3,
}

/// A [`FrontPlane`] as seen from the apex `o`: `n . (x - o) > -d`, `d >= 0`, with the bound of
/// each axis (0 min, 1 max) that maximizes `n_a (x_a - o_a)` over a box.
#[derive(Debug, Clone, Copy)]
struct HalfSpace {
    n: [Vec4; 3],
    sel: [usize; 3],
    d: Vec4,
}

/// The frustum of a set of segments sharing their origin.
#[derive(Debug, Clone, Copy)]
pub(super) struct RayFrustum {
    o: [Vec4; 3],
    k: usize,
    /// +1 or -1: the direction of the targets from the apex along axis `k`.
    sign: f32,
    planes: [Plane; 4],
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    /// The half-space every segment lies in, when the caller knows one.
    front: Option<HalfSpace>,
}

/// The bounding box `[min, max]` of `points`; `None` when there are none.
pub(super) fn bounds(points: &[Vec3]) -> Option<[Vec3; 2]> {
    let first = *points.first()?;
    Some(
        points
            .iter()
            .fold([first, first], |[lo, hi], &p| [lo.min(p), hi.max(p)]),
    )
}

/// Relative widening of the slope bounds.
const SLOPE_MARGIN: f32 = 1e-4;
/// Relative tolerance of the plane test.
const PLANE_TOL: f32 = 1e-5;

impl RayFrustum {
    /// The frustum of the segments from `origin` to targets within the box `[tlo, thi]`;
    /// `None` when the box's corners do not all lie strictly ahead of `origin` along the
    /// dominant axis (then no pyramid with apex `origin` bounds them).
    ///
    /// The slopes are bounded through the 8 corners of the targets' bounding box rather than
    /// through every target: a slope `d_i / d_k` is a linear-fractional function, so over a box
    /// where `d_k > 0` its extrema lie at corners. That costs one pass of min/max over the
    /// targets and 16 divisions, and loses nothing for axis-aligned lights.
    ///
    /// `[tlo, thi]` may be any box holding the targets (e.g. the bounds of a superset of them):
    /// a looser frustum changes only the speed.
    pub fn around(origin: Vec3, targets: [Vec3; 2]) -> Option<RayFrustum> {
        Self::pyramid(
            origin,
            &[targets],
            targets,
            [targets[0].min(origin), targets[1].max(origin)],
        )
    }

    /// The frustum with apex `apex` through the corners of every box of `boxes` (`[min, max]`
    /// each), cut by their bounding box: it holds every point of the boxes, so (being convex)
    /// every segment between two such points, and nothing outside their bounding box. `None`
    /// under the condition of [`RayFrustum::around`], for the corners of all the boxes and the
    /// dominant axis of the center of their bounding box, or without boxes.
    pub fn around_boxes(apex: Vec3, boxes: &[[Vec3; 2]]) -> Option<RayFrustum> {
        let [first, ..] = boxes else { return None };
        let bounds = boxes
            .iter()
            .fold(*first, |[lo, hi], b| [lo.min(b[0]), hi.max(b[1])]);
        Self::pyramid(apex, boxes, bounds, bounds)
    }

    /// The pyramid with apex `origin` through the corners of `boxes`, whose bounding box is
    /// `[tlo, thi]`, cut by the box `[lo, hi]` (see [`RayFrustum::around`] and
    /// [`RayFrustum::around_boxes`]).
    fn pyramid(
        origin: Vec3,
        boxes: &[[Vec3; 2]],
        [tlo, thi]: [Vec3; 2],
        [lo, hi]: [Vec3; 2],
    ) -> Option<RayFrustum> {
        let center = (tlo + thi) * 0.5 - origin;
        let s = center.abs();
        let k = if s.x >= s.y && s.x >= s.z {
            0
        } else if s.y >= s.z {
            1
        } else {
            2
        };
        let sign = if center[k] < 0.0 { -1.0 } else { 1.0 };
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let (mut amin, mut amax, mut bmin, mut bmax) = (
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
        );
        for &[blo, bhi] in boxes {
            for corner in 0..8 {
                let q = Vec3::select(
                    glam::BVec3::new(corner & 1 != 0, corner & 2 != 0, corner & 4 != 0),
                    bhi,
                    blo,
                );
                let d = q - origin;
                let dk = d[k] * sign;
                if dk.is_nan() || dk <= 0.0 {
                    return None;
                }
                let (a, b) = (d[i] / dk, d[j] / dk);
                (amin, amax, bmin, bmax) = (amin.min(a), amax.max(a), bmin.min(b), bmax.max(b));
            }
        }
        if !(amin.is_finite() && amax.is_finite() && bmin.is_finite() && bmax.is_finite()) {
            return None;
        }
        let wa = SLOPE_MARGIN * (amin.abs().max(amax.abs()) + 1e-30);
        let wb = SLOPE_MARGIN * (bmin.abs().max(bmax.abs()) + 1e-30);
        let plane = |a: usize, na: f32, nk: f32| Plane {
            a,
            na: Vec4::splat(na),
            sel_a: usize::from(na > 0.0),
            nk: Vec4::splat(nk),
            sel_k: usize::from(nk > 0.0),
        };
        let planes = [
            plane(i, 1.0, -(amin - wa) * sign),
            plane(i, -1.0, (amax + wa) * sign),
            plane(j, 1.0, -(bmin - wb) * sign),
            plane(j, -1.0, (bmax + wb) * sign),
        ];
        let pad = (hi - lo) * 1e-5 + (lo.abs().max(hi.abs())) * 1e-6 + Vec3::splat(1e-30);
        let (lo, hi) = (lo - pad, hi + pad);
        let splat3 = |v: Vec3| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Some(RayFrustum {
            o: splat3(origin),
            k,
            sign,
            planes,
            lo: splat3(lo),
            hi: splat3(hi),
            front: None,
        })
    }

    /// This frustum cut by `plane`, which every segment lies in front of: a box wholly behind
    /// it is culled. `normal . (x - point) > 0` reads `n . (x - o) > -d` from the apex `o`, with
    /// `d = normal . (o - point)`, `epsilon |normal|^2` for a receiver's moved origin; a `d`
    /// below 0 (an apex behind the plane, which no caller passes) is taken as 0, which only
    /// culls less. No plane, or one that is not finite, leaves the frustum as it is.
    pub fn in_front_of(self, plane: Option<FrontPlane>) -> RayFrustum {
        let Some(plane) = plane else {
            return self;
        };
        let o = Vec3::new(self.o[0].x, self.o[1].x, self.o[2].x);
        let n = plane.normal;
        let d = (n * (o - plane.point)).element_sum().max(0.0);
        if !(n.is_finite() && d.is_finite()) {
            return self;
        }
        let front = HalfSpace {
            n: [Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z)],
            sel: [0, 1, 2].map(|a| usize::from(n[a] > 0.0)),
            d: Vec4::splat(d),
        };
        RayFrustum {
            front: Some(front),
            ..self
        }
    }

    /// The dominant axis `k` and the sign of the targets' offsets from the apex along it: every
    /// target `y` has `(y[k] - apex[k]) * sign > 0`.
    pub(super) fn axis(&self) -> (usize, f32) {
        (self.k, self.sign)
    }

    /// The bitmask of the children of `node` whose boxes may meet the frustum.
    #[inline(always)]
    pub(super) fn overlaps(&self, node: &Node4) -> u32 {
        let [lo, hi] = &node.bounds;
        let mut m = lo[0].cmple(self.hi[0]) & lo[1].cmple(self.hi[1]) & lo[2].cmple(self.hi[2]);
        m &= hi[0].cmpge(self.lo[0]) & hi[1].cmpge(self.lo[1]) & hi[2].cmpge(self.lo[2]);
        for p in &self.planes {
            let t1 = p.na * (node.bounds[p.sel_a][p.a] - self.o[p.a]);
            let t2 = p.nk * (node.bounds[p.sel_k][self.k] - self.o[self.k]);
            m &= (t1 + t2).cmpge(-(t1.abs() + t2.abs()) * PLANE_TOL);
        }
        if let Some(h) = &self.front {
            // The box's farthest point in front, with the tolerance of the planes above.
            let t = [0, 1, 2].map(|a| h.n[a] * (node.bounds[h.sel[a]][a] - self.o[a]));
            let magnitude = t[0].abs() + t[1].abs() + t[2].abs() + h.d;
            m &= (t[0] + t[1] + t[2]).cmpge(-(h.d + magnitude * PLANE_TOL));
        }
        m.bitmask()
    }

    /// Collects into `out` the leaves, with their boxes, of the tree under `root` that may meet
    /// the frustum; `None` when there are more than `out` holds.
    pub fn collect(
        &self,
        nodes: &[Node4],
        root: Root,
        stack: &mut [u32; STACK],
        out: &mut [LeafRef],
    ) -> Option<usize> {
        let mut cur = match root {
            Root::Node(node) => node,
            Root::Leaf(leaf) => {
                *out.first_mut()? = leaf;
                return Some(1);
            }
        };
        let (mut sp, mut n) = (0usize, 0usize);
        loop {
            let node = &nodes[cur as usize];
            let mut mask = self.overlaps(node);
            while mask != 0 {
                let c = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if node.child[c] & LEAF != 0 {
                    *out.get_mut(n)? = node.leaf_ref(c);
                    n += 1;
                } else {
                    // Each level leaves at most 3 siblings behind, the deepest adds 4:
                    // at most 3 * depth + 1 <= STACK entries (see `build`).
                    stack[sp] = node.child[c];
                    sp += 1;
                }
            }
            if sp == 0 {
                return Some(n);
            }
            sp -= 1;
            cur = stack[sp];
        }
    }
}
