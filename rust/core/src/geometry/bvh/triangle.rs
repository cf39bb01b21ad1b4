//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013, evaluated for four triangles at once.
//!
//! Why this test: the oracle must never let a shadow ray slip between two triangles that share
//! an edge or a vertex. The test shears the ray onto the +z axis (dimension `kz` is the largest
//! of the direction, `kx`/`ky` follow it cyclically and are swapped when `dir[kz] < 0`, so the
//! winding is kept) and evaluates the three 2D edge functions `U`, `V`, `W` of the sheared
//! vertices. Each edge function is computed from the two vertices of its edge alone, as
//! `a*b - c*d` with no fused multiply-add, so two triangles sharing an edge get exactly opposite
//! values on it and a ray can only land on one side or exactly on it (edges and vertices count
//! as inside). When a value is exactly zero it is recomputed in double precision (section 3.3
//! of the paper) so that the sign is right for rays passing exactly through vertices.
//!
//! Four triangles are tested together with `Vec4` lanes; every lane does the very same IEEE
//! operations as a scalar evaluation would, so [`intersect_triangle`] (one triangle broadcast to
//! all lanes) gives bit-identical results to the BVH.

use super::Tri4;
use glam::{BVec4A, Vec3, Vec4};

/// Per-ray data shared by every box and triangle test of one traversal.
#[derive(Debug, Clone, Copy)]
pub(super) struct RayData {
    /// Ray origin per axis for the entry planes, broadcast (box test). It equals the origin
    /// except on axes where the direction is exactly zero: there it is nudged one ulp inwards
    /// (see [`RayData::new`]).
    pub org_near: [Vec4; 3],
    /// Ray origin per axis for the exit planes, broadcast (box test).
    pub org_far: [Vec4; 3],
    /// Safe reciprocal direction, broadcast per axis (box test).
    pub inv: [Vec4; 3],
    /// For each axis, whether the box's max plane is the entry plane (negative direction). As
    /// `usize::from(bool)` indices they need no bounds checks in the node test.
    pub near: [bool; 3],
    /// The shear permutation `[kx, ky, kz]`.
    pub k: [usize; 3],
    /// Origin components `org[kx], org[ky], org[kz]`, broadcast.
    pub ok: [Vec4; 3],
    /// Shear constants `Sx, Sy, Sz`, broadcast.
    pub s: [Vec4; 3],
}

impl RayData {
    /// Precomputes the ray; `None` when `dir` is zero (an empty segment hits nothing) or `org`
    /// or `dir` is not finite.
    #[inline(always)]
    pub fn new(org: Vec3, dir: Vec3) -> Option<Self> {
        // Why: a non-finite origin or direction (e.g. `p + epsilon n` or `y - p` overflowing
        // for coordinates near f32::MAX) makes slab distances NaN, and NaN lanes pass the
        // min/max box test, so traversal descended into empty child slots and indexed past the
        // blocks (found by fuzzing). Such a segment cannot be tested in f32: it hits nothing.
        if !(org.is_finite() && dir.is_finite()) {
            return None;
        }
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let dz = dir[kz];
        // `!(dz != 0)` also refuses NaN directions.
        if dz == 0.0 || dz.is_nan() {
            return None;
        }
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if dz < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s3 = [dir[kx] / dz, dir[ky] / dz, 1.0 / dz];
        // Embree-style safe reciprocal: a tiny component becomes +-1e-30 and a zero one +1e-30,
        // so slab distances are finite or infinite but never NaN (0 * inf), and the sign picks
        // the entry plane. A ray with a zero component never leaves its slab, but one lying
        // exactly on a box face would get an exit distance of 0 there and miss the box (and the
        // triangles the watertight test finds in it). So on such axes the origin is moved one
        // ulp inside the slab for each plane: `(min - next_up(o)) * 1e30 < 0` and
        // `(max - next_down(o)) * 1e30 > 0` whenever `min <= o <= max`; outside, the test may
        // only accept more boxes, which keeps it conservative.
        let safe = |d: f32| match d {
            0.0 => 1e30,
            _ if d.abs() < 1e-30 => 1.0 / (1e-30f32).copysign(d),
            _ => 1.0 / d,
        };
        let inv3 = [safe(dir.x), safe(dir.y), safe(dir.z)];
        let near = inv3.map(|i| i < 0.0);
        let o3 = org.to_array();
        // Why `.min(MAX)` / `.max(MIN)`: one ulp beyond ±f32::MAX is ±inf, and `-inf - -inf` in
        // an empty child slot's test is NaN, which passes it (found by fuzzing: an eye at
        // y = f32::MIN looking along x indexed past the blocks). The origin stays put there.
        let nudge = |a: usize, up: bool| match (dir[a] == 0.0, up) {
            (false, _) => Vec4::splat(o3[a]),
            (true, true) => Vec4::splat(o3[a].next_up().min(f32::MAX)),
            (true, false) => Vec4::splat(o3[a].next_down().max(f32::MIN)),
        };
        Some(Self {
            org_near: [nudge(0, true), nudge(1, true), nudge(2, true)],
            org_far: [nudge(0, false), nudge(1, false), nudge(2, false)],
            inv: inv3.map(Vec4::splat),
            near,
            k: [kx, ky, kz],
            ok: [
                Vec4::splat(org[kx]),
                Vec4::splat(org[ky]),
                Vec4::splat(org[kz]),
            ],
            s: s3.map(Vec4::splat),
        })
    }
}

/// What the slab test of a node (`Node4::hit`) and the watertight test ([`hit4`]) read of a
/// ray: the fields of [`RayData`] of the same names, each broadcast to the four lanes of a node
/// or block. A [`RayData`] holds them; a lane of a packet is read in place (`LaneView` in
/// `bvh/packet.rs`), so that the packets hand a lane to a single-ray traversal without copying
/// it into a `RayData` first.
pub(super) trait Ray {
    fn org_near(&self, a: usize) -> Vec4;
    fn org_far(&self, a: usize) -> Vec4;
    fn inv(&self, a: usize) -> Vec4;
    fn near(&self) -> [bool; 3];
    fn k(&self) -> [usize; 3];
    fn ok(&self, a: usize) -> Vec4;
    fn s(&self, a: usize) -> Vec4;
}

impl Ray for RayData {
    #[inline(always)]
    fn org_near(&self, a: usize) -> Vec4 {
        self.org_near[a]
    }
    #[inline(always)]
    fn org_far(&self, a: usize) -> Vec4 {
        self.org_far[a]
    }
    #[inline(always)]
    fn inv(&self, a: usize) -> Vec4 {
        self.inv[a]
    }
    #[inline(always)]
    fn near(&self) -> [bool; 3] {
        self.near
    }
    #[inline(always)]
    fn k(&self) -> [usize; 3] {
        self.k
    }
    #[inline(always)]
    fn ok(&self, a: usize) -> Vec4 {
        self.ok[a]
    }
    #[inline(always)]
    fn s(&self, a: usize) -> Vec4 {
        self.s[a]
    }
}

/// The lanes of a [`Tri4`] that a ray hits, with the unnormalized quantities of the test.
#[derive(Debug, Clone, Copy)]
pub(super) struct Lanes {
    /// Bit `i` set when lane `i` is hit within the open interval (0, t_max).
    pub mask: u32,
    /// Scaled barycentric of vertex 1 (`V`) and vertex 2 (`W`), the determinant and `T`.
    pub v: Vec4,
    pub w: Vec4,
    pub det: Vec4,
    pub t: Vec4,
}

impl Lanes {
    /// `(t, b1, b2)` of lane `i` (one of the set bits of `mask`).
    #[inline]
    pub fn get(&self, i: usize) -> (f32, f32, f32) {
        let det = self.det[i];
        // Divisions (not a shared reciprocal) so that `t` equals the lane of `distances`.
        (self.t[i] / det, self.v[i] / det, self.w[i] / det)
    }

    /// The distances of all four lanes (meaningful in the set lanes only).
    #[inline]
    pub fn distances(&self) -> Vec4 {
        self.t / self.det
    }
}

/// Tests the four triangles of `b` against the ray over the open interval (0, `t_max`).
#[inline(always)]
pub(super) fn hit4<R: Ray>(b: &Tri4, r: &R, t_max: f32) -> Lanes {
    let [kx, ky, kz] = r.k();
    let (ok, s) = ([r.ok(0), r.ok(1), r.ok(2)], [r.s(0), r.s(1), r.s(2)]);
    // Vertices relative to the origin, in the permuted axes.
    let (az, bz, cz) = (b.v[0][kz] - ok[2], b.v[1][kz] - ok[2], b.v[2][kz] - ok[2]);
    // Shear: x' = x - Sx z, y' = y - Sy z.
    let ax = (b.v[0][kx] - ok[0]) - s[0] * az;
    let ay = (b.v[0][ky] - ok[1]) - s[1] * az;
    let bx = (b.v[1][kx] - ok[0]) - s[0] * bz;
    let by = (b.v[1][ky] - ok[1]) - s[1] * bz;
    let cx = (b.v[2][kx] - ok[0]) - s[0] * cz;
    let cy = (b.v[2][ky] - ok[1]) - s[1] * cz;
    // Edge functions, each from its own edge's two vertices only.
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    let zero = u.cmpeq(Vec4::ZERO) | v.cmpeq(Vec4::ZERO) | w.cmpeq(Vec4::ZERO);
    if zero.any() {
        refine(zero, [ax, ay, bx, by, cx, cy], [&mut u, &mut v, &mut w]);
    }
    let neg = u.cmplt(Vec4::ZERO) | v.cmplt(Vec4::ZERO) | w.cmplt(Vec4::ZERO);
    let pos = u.cmpgt(Vec4::ZERO) | v.cmpgt(Vec4::ZERO) | w.cmpgt(Vec4::ZERO);
    let det = u + v + w;
    let t = u * (s[2] * az) + v * (s[2] * bz) + w * (s[2] * cz);
    // Compare T / det against the interval without dividing (sign folded in, as in the paper).
    let sign = Vec4::ONE.copysign(det);
    let ts = t * sign;
    let limit = det.abs() * Vec4::splat(t_max);
    let ok: BVec4A = !(neg & pos) & det.cmpne(Vec4::ZERO) & ts.cmpgt(Vec4::ZERO) & ts.cmplt(limit);
    Lanes {
        mask: ok.bitmask(),
        v,
        w,
        det,
        t,
    }
}

/// Recomputes the edge functions of the lanes in `zero` in double precision (the products of
/// two floats are exact there), as the paper does for rays through edges and vertices.
#[cold]
#[inline(never)]
fn refine(zero: BVec4A, p: [Vec4; 6], out: [&mut Vec4; 3]) {
    let [ax, ay, bx, by, cx, cy] = p.map(|x| x.to_array().map(f64::from));
    let [u, v, w] = out;
    let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
    for i in (0..4).filter(|&i| zero.test(i)) {
        ua[i] = (cx[i] * by[i] - cy[i] * bx[i]) as f32;
        va[i] = (ax[i] * cy[i] - ay[i] * cx[i]) as f32;
        wa[i] = (bx[i] * ay[i] - by[i] * ax[i]) as f32;
    }
    *u = Vec4::from_array(ua);
    *v = Vec4::from_array(va);
    *w = Vec4::from_array(wa);
}

/// The watertight test for one triangle `tri` (vertices 0, 1, 2) against the ray
/// `origin + t dir`, t in the open interval (0, `t_max`): `(t, b1, b2)` with `b1`, `b2` the
/// barycentric weights of vertices 1 and 2. Bit-identical to what [`super::Bvh`] computes.
pub fn intersect_triangle(
    origin: Vec3,
    dir: Vec3,
    tri: [Vec3; 3],
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let r = RayData::new(origin, dir)?;
    let block = Tri4::splat(tri, 0, false);
    let lanes = hit4(&block, &r, t_max);
    (lanes.mask & 1 != 0).then(|| lanes.get(0))
}
