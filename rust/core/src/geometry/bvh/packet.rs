//! Coherent shadow-ray packets: segments from many origins to one common target.
//!
//! When every receiver uses the same light samples, the rays of neighbouring receivers to one
//! sample `y` converge at `y`: read backwards they share their origin, so their frustum (apex
//! `y`, through the bounding box of the origins) is narrow, the classic coherent packet of
//! Wald et al., "Interactive Rendering with Coherent Ray Tracing" (2001), used for soft shadows
//! by Benthin and Wald, "Efficient Ray Traced Soft Shadows using Multi-Frusta Tracing" (2009).
//! One traversal serves a packet of up to [`LANES`] rays:
//!
//! - inner nodes are culled with the [`RayFrustum`] of the packet (conservative, see
//!   `bvh/frustum.rs`: it bounds the very same segments, read from `y`), so the inner-node work
//!   is shared by all lanes (about one node test per ray instead of nine);
//! - each child also gets the lanes that may reach it, by the central projection from `y`
//!   ([`Slopes`]: a box's slope rectangle against each lane's slopes): penumbra rays graze
//!   different small leaves, and lanes leave the packet when blocked, so the lines of the
//!   active lanes are far thinner than the frustum and whole subtrees are skipped once no
//!   active lane can reach them;
//! - at a leaf, the lanes still active when it is popped are box-tested with the exact
//!   arithmetic of the single-ray slab test (`Node4::hit`), and the survivors run the
//!   watertight test of `bvh/triangle.rs`: triangle by triangle, many lanes at once (the
//!   vertices permuted once when the lanes share their shear axes, as nearly parallel rays
//!   do), or lane by lane, four triangles at once, for a chunk bringing only a few lanes;
//! - a blocked lane leaves the packet, and the traversal stops when no lane is left;
//! - a node reached by at most [`SINGLE_RAY_LANES`] active lanes is left to single-ray
//!   traversals of its subtree, one per lane (`Bvh::any_hit` from that node, on the lane's own
//!   fields, [`LaneView`]): the hybrid of Benthin, Wald, Woop, Ernst and Mark, "Combining Single and
//!   Packet-Ray Tracing for Arbitrary Ray Distributions on the Intel MIC Architecture" (IEEE
//!   TVCG 18(9), 2012). A packet's node visit (frustum, four slope rectangles, lane masks per
//!   stack entry) costs several single-ray node tests, so below a few lanes the lanes' own
//!   traversals are cheaper; incoherent packets (small images, whose tiles of receivers cover
//!   more of the scene) lose most of their lanes a few levels down.
//!
//! Lane data is transposed into [`Chunk`]s of [`W`] lanes and every per-lane test is a plain
//! loop over a chunk, which LLVM vectorizes to the registers of the instruction set it is
//! compiled for. The traversal is compiled once per instruction set ([`Isa`]: SSE2 everywhere,
//! AVX2 and AVX-512 where the CPU has them, chosen at run time), all from the same body. A
//! tile's origins are transposed once for all its light samples
//! ([`Bvh::occluded_converging_lanes`]), and the same lanes serve the candidate test of the
//! per-receiver frustum pass (one origin, many targets: [`Bvh::occluded_by_blocks`]).
//!
//! The same traversal serves the mirror image: the segments from one origin to many targets
//! ([`Bvh::occluded_diverging`]), whose frustum has its apex at the origin. Every point of a
//! lane's segment has the lane's slopes from the origin as well, so the projection test, the
//! frustum and the lanes' own `RayData` are those of the converging packets with the apex
//! moved.
//!
//! Exactness: every lane does the IEEE operations, in the same order, of the `RayData` that
//! [`Bvh::occluded`] builds for the same segment and of its slab and watertight tests (LLVM
//! never fuses or reorders float operations, whatever the vector width; lanes tested one by
//! one run `hit4` itself on their own fields (the values of that `RayData`, [`LaneView`]), and
//! lanes handed to single-ray traversals run `Bvh::any_hit` itself, whose answer for a subtree
//! is that of [`Bvh::occluded`] restricted to it); a leaf is skipped for a lane only when the
//! frustum or the projection test (both conservative, with margins far above float rounding)
//! or that lane's own slab test (identical to the single ray's, which never culls a leaf
//! holding a watertight hit) rejects it. An opaque hit anywhere in the open
//! segment answers either way, so each lane's answer equals [`Bvh::occluded`] bit for bit,
//! whatever the packet it travels in and whatever the instruction set.

use super::frustum::{bounds, FrontPlane, RayFrustum};
use super::triangle::{Ray, RayData};
use super::{Bvh, LeafRef, Node4, Tri4, LEAF, ROBUST, STACK};
use crate::geometry::mesh::Scene;
use crate::isa::{isa_dispatch, movemask, top_bit, Isa};
use glam::{Vec3, Vec4};
use std::cell::RefCell;

thread_local! {
    /// Per-thread packet buffer (about 11 KiB, rewritten lane by lane, never zeroed again).
    static PACKET: RefCell<Box<Packet>> = RefCell::new(Box::new(Packet::empty()));
}

/// Most rays of one packet (one bit each in the lane masks).
pub(super) const LANES: usize = 64;
/// Lanes of one [`Chunk`]: one AVX-512 register of `f32` (two AVX2 or four SSE registers).
const W: usize = 16;
/// Chunks of one packet.
const CHUNKS: usize = LANES / W;
/// The lanes of one chunk, as a mask.
const CHUNK_MASK: u64 = (1 << W) - 1;
/// Most lanes of a chunk tested against a leaf one by one (see [`Chunk::blocked_lanes`]).
/// One lane's `hit4` (four triangles) costs about one triangle's test of a whole chunk in
/// AVX-512, and a leaf holds 3.5 triangles on average: the break-even is near 3 lanes. In
/// the bunny's packets 57% of the chunks that reach a leaf bring at most 3 lanes (28% one).
/// At 128x128 receivers (measured as [`SINGLE_RAY_LANES`]), 2 and 5 lanes took 1.00-1.01x the
/// CPU time of 3.
const SPARSE_LANES: u32 = 3;

/// Most active lanes at a node for which the packet hands each lane its own single-ray
/// traversal of the node's subtree (see the module doc). On the bunny (bench/shadow_rays.py,
/// 64 shared samples, three runs alternating with and without the hand-off) it takes 0.75-0.80x
/// the CPU time of no hand-off at 128x128 receivers, 0.94-0.96x at 256x256 and 0.95-0.98x at
/// 512x512, with the same answers bit for bit. At 128x128, 2 lanes took 1.06-1.07x the CPU time
/// of 4, and 8 the same as 4 within the noise (three alternating runs each).
///
/// Since the tiles of few hard receivers go by receiver and the tangent-plane cut, 8 lanes pay
/// (2026-12-07): by cachegrind, one 128x128 call runs 8% fewer instructions than with 4 (229M
/// against 249M, one thread, the difference of 9 calls and 1 call in one process each, which
/// cancels the start-up's variation of about 30M); timed on one thread, the threshold switched
/// call by call in one process (same bits), 0.96x and 0.975x the fastest CPU time of 4 at
/// 128x128 (80 rounds each; median 0.94x, 0.945x) and 0.975x and 0.96x at 256x256 (30 and 40
/// rounds). 12 and 16 lanes took 0.98-1.01x the fastest time of 4, no better than 8: a
/// hand-off's single ray waits on its loads (below).
///
/// At 128x128, with packets by sample only (before `ray_traced` sent the tiles of few receivers to
/// [`Bvh::occluded_diverging`]), 44% of the packets' live lanes are handed off, each about three
/// times per sample, and a hand-off tests 1.4 nodes and 0.7 leaves on average (one call: 127k nodes
/// handing off 299k lanes, against 108k node visits of the 6k packets themselves). Timed by the
/// time-stamp counter, the hand-offs take about 40% of the call's CPU time and the packets' own
/// node visits about 30%. Running each hand-off a second time right after the first, its nodes and
/// leaves now in cache, adds about half the hand-offs' time (1.18-1.21x the whole call): half of a
/// hand-off is its instructions and branches, the rest at most is waiting on its loads. Hiding that
/// wait did not pay: a software ray stream (Wald, Woop, Benthin, Johnson and Ernst, "Embree: A
/// Kernel Framework for Efficient CPU Ray Tracing", 2014; the latency hiding of Aila and Laine,
/// "Understanding the Efficiency of Ray Traversal on GPUs", 2009) that runs a node's handed-off
/// lanes round-robin, one node or leaf step of each in turn on its own stack, took 1.00-1.04x the
/// CPU time of this code (its bookkeeping, run one lane at a time, 1.09-1.11x); queueing the
/// hand-offs of several nodes and running 4 or 8 of a queue of 8 round-robin took 1.15-1.18x, as
/// the lanes waiting in the queue stay active in the packet. Nor did a cheaper set-up: building
/// each lane's `RayData` once per packet rather than once per hand-off took 0.98-1.01x (builds of
/// the `quick` profile, alternating processes, one thread, fastest CPU time of 20 calls, three
/// rounds each, same bits). What did not make it cheaper before (one thread, each variant against
/// this code in interleaved rounds of one process, fastest CPU time, same bits): testing first the
/// block that last blocked the lane, an occluder cache per receiver after Haines and Greenberg,
/// "The light buffer: a shadow-testing accelerator" (1986), found the segment blocked for 0.9% of
/// the hand-offs with a remembered block (1.3% at 256x256) and took 1.05x the CPU time (1.03x),
/// since a receiver's Poisson samples spread over the light and its consecutive rays rarely meet
/// the same block; tracing a node's handed-off lanes together on one stack, each node slab-tested
/// for all of them, took 1.58x; 3 lanes took 1.03x and 6 lanes 0.99x the time of 4.
const SINGLE_RAY_LANES: u32 = 8;

/// The per-lane data of [`W`] rays of a packet, one array entry per lane: the fields of the
/// lane's single-ray `RayData` (see `bvh/triangle.rs`) and its slopes.
#[derive(Debug, Clone, Copy)]
struct Chunk {
    /// The lanes' ray origins, per axis.
    origin: [[f32; W]; 3],
    /// Slab test: the origin for the entry and for the exit planes and the safe reciprocal
    /// direction (whose sign picks the entry plane), per axis.
    org_near: [[f32; W]; 3],
    org_far: [[f32; W]; 3],
    inv: [[f32; W]; 3],
    /// Watertight test: the shear permutation `[kx, ky, kz]`, the origin in those axes and the
    /// shear constants.
    k: [[u32; W]; 3],
    ok: [[f32; W]; 3],
    s: [[f32; W]; 3],
    /// The footprint slopes (see [`Slopes`]).
    sa: [f32; W],
    sb: [f32; W],
    /// The shear permutation of every lane the last aim set, when they all have the same
    /// (the rule in a packet: its rays are nearly parallel).
    shared_k: Option<[u32; 3]>,
}

/// Lane `l` of a chunk as a single ray ([`Ray`]), each field broadcast where a test reads it.
///
/// The packets hand about 300k lanes to single-ray traversals in a call on the bunny at 128x128
/// (see [`SINGLE_RAY_LANES`]); each hand-off built a `RayData` of the lane first, fifteen
/// broadcasts and stores, most of them read once or twice. Read in place instead, one 128x128
/// call runs 2.9% fewer instructions (218M against 224M by cachegrind, one thread, the
/// difference of 11 calls and 1 call in one process each), the same bits; timed in alternating
/// processes on a machine loaded by others (one thread, fastest CPU time), 1.00x and 0.99x at
/// 128x128 (10 and 20 rounds) and 0.89x and 0.94x at 256x256 (6 and 10 rounds).
struct LaneView<'a> {
    chunk: &'a Chunk,
    l: usize,
    near: [bool; 3],
    k: [usize; 3],
}

impl Ray for LaneView<'_> {
    #[inline(always)]
    fn org_near(&self, a: usize) -> Vec4 {
        Vec4::splat(self.chunk.org_near[a][self.l])
    }
    #[inline(always)]
    fn org_far(&self, a: usize) -> Vec4 {
        Vec4::splat(self.chunk.org_far[a][self.l])
    }
    #[inline(always)]
    fn inv(&self, a: usize) -> Vec4 {
        Vec4::splat(self.chunk.inv[a][self.l])
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
        Vec4::splat(self.chunk.ok[a][self.l])
    }
    #[inline(always)]
    fn s(&self, a: usize) -> Vec4 {
        Vec4::splat(self.chunk.s[a][self.l])
    }
}

/// The rays of one packet, transposed [`W`] lanes per [`Chunk`].
pub(super) struct Packet {
    chunks: [Chunk; CHUNKS],
    /// The bounding box `[min, max]` of the lanes' origins and their largest coordinate
    /// magnitude.
    origin_bounds: [Vec3; 2],
    origin_scale: f32,
    slopes: Slopes,
    /// The lanes that may reach each node on the traversal stack, and for a leaf its parent
    /// node and slot (`4 parent + slot`).
    lane_stack: [u64; STACK],
    slot_stack: [usize; STACK],
    /// The stack of the single-ray traversals that the packet hands its sparse lanes.
    ray_stack: [u32; STACK],
}

/// The slot of a leaf with no parent node (the root of a tree of at most four triangles).
const NO_SLOT: usize = usize::MAX;

/// Central projection from the common target `y` along the frustum's dominant axis `k`
/// (`d_k = (p_k - y_k) sign > 0` on the whole packet): a point `p` maps to the slopes
/// `(d_i / d_k, d_j / d_k)` of its offset from `y`. Every point of a lane's segment maps to
/// the lane's own slopes (they all lie on one line through `y`), so a segment can only meet a
/// box whose slope rectangle holds the lane's slopes: four comparisons per lane reject most
/// lanes (a per-ray refinement of the frustum test of Benthin and Wald 2009).
#[derive(Debug, Clone, Copy)]
struct Slopes {
    y: Vec3,
    k: usize,
    sign: f32,
    /// Absolute rounding scale of the slopes: the largest coordinate magnitude of the target
    /// and the origins.
    scale: f32,
}

/// `_mm_min_ps(a, b)` lane by lane (glam's `Vec4::min`): `b` unless `a < b`.
#[inline(always)]
fn min_ps(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `_mm_max_ps(a, b)` lane by lane (glam's `Vec4::max`): `b` unless `a > b`.
#[inline(always)]
fn max_ps(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// Component `k` (0, 1 or 2) of `v`, without a bounds check (a select LLVM vectorizes).
#[inline(always)]
fn pick(v: [f32; 3], k: u32) -> f32 {
    if k == 0 {
        v[0]
    } else if k == 1 {
        v[1]
    } else {
        v[2]
    }
}

/// The point `p` in the permuted axes `[kx, ky, kz]`.
#[inline(always)]
fn permuted(p: [f32; 3], [kx, ky, kz]: [u32; 3]) -> [f32; 3] {
    [pick(p, kx), pick(p, ky), pick(p, kz)]
}

/// The points `p` (at most [`W`]) per axis, one lane each; lanes past `p` get 0.
#[inline(always)]
fn transposed(p: &[Vec3]) -> [[f32; W]; 3] {
    let mut out = [[0f32; W]; 3];
    for (l, p) in p.iter().take(W).enumerate() {
        (out[0][l], out[1][l], out[2][l]) = (p.x, p.y, p.z);
    }
    out
}

/// One lane's `RayData` fields for the direction `dir` from `org`, when no component of `dir`
/// is zero or non-finite: the same IEEE operations as `RayData::new` (the safe reciprocal and
/// the shear axes and constants).
struct LaneRay {
    inv: [f32; 3],
    k: [u32; 3],
    ok: [f32; 3],
    s: [f32; 3],
}

#[inline(always)]
fn regular_ray(org: [f32; 3], dir: [f32; 3]) -> LaneRay {
    let tiny = 1e-30f32;
    let safe = |d: f32| 1.0 / if d.abs() < tiny { tiny.copysign(d) } else { d };
    let (ax, ay, az) = (dir[0].abs(), dir[1].abs(), dir[2].abs());
    let kz: u32 = if (ax >= ay) & (ax >= az) {
        0
    } else if ay >= az {
        1
    } else {
        2
    };
    let dz = pick(dir, kz);
    let (kx, ky) = if dz < 0.0 {
        ((kz + 2) % 3, (kz + 1) % 3)
    } else {
        ((kz + 1) % 3, (kz + 2) % 3)
    };
    LaneRay {
        inv: [safe(dir[0]), safe(dir[1]), safe(dir[2])],
        k: [kx, ky, kz],
        ok: [pick(org, kx), pick(org, ky), pick(org, kz)],
        s: [pick(dir, kx) / dz, pick(dir, ky) / dz, 1.0 / dz],
    }
}

// Lane loops index by lane on purpose: plain index loops are what LLVM vectorizes reliably
// (see `top_bit`).
#[allow(clippy::needless_range_loop)]
impl Chunk {
    const EMPTY: Chunk = Chunk {
        origin: [[0.0; W]; 3],
        org_near: [[0.0; W]; 3],
        org_far: [[0.0; W]; 3],
        inv: [[1.0; W]; 3],
        k: [[0; W]; 3],
        ok: [[0.0; W]; 3],
        s: [[0.0; W]; 3],
        sa: [0.0; W],
        sb: [0.0; W],
        shared_k: None,
    };

    /// Sets the origins of the lanes (at most [`W`]); lanes past `origins` get the origin 0
    /// and no mask selects them.
    #[inline(always)]
    fn set_origins(&mut self, origins: &[Vec3]) {
        self.origin = transposed(origins);
    }

    /// Sets the lanes `lanes` (a chunk mask) to the segments from their origins to `target`
    /// and their slopes from it; returns the mask of those with a non-empty segment. The other
    /// lanes get data no mask selects.
    #[inline(always)]
    fn aim(&mut self, target: Vec3, lanes: u64, slopes: &Slopes) -> u64 {
        let live = self.aim_lanes(&[[target.x; W], [target.y; W], [target.z; W]], lanes);
        self.aim_slopes(slopes);
        self.shared_k = self.common_k(live);
        live
    }

    /// Sets the lanes to the segments from `origin` to `targets` (at most [`W`], no slopes);
    /// returns the mask of those with a non-empty segment.
    #[inline(always)]
    fn set_rays(&mut self, origin: Vec3, targets: &[Vec3]) -> u64 {
        self.origin = [[origin.x; W], [origin.y; W], [origin.z; W]];
        let live = self.aim_lanes(&transposed(targets), CHUNK_MASK >> (W - targets.len()));
        self.shared_k = self.common_k(live);
        live
    }

    /// The shear permutation of the lanes `lanes` if they all have the same.
    #[inline(always)]
    fn common_k(&self, lanes: u64) -> Option<[u32; 3]> {
        let first = (lanes != 0).then(|| lanes.trailing_zeros() as usize)?;
        let k = [self.k[0][first], self.k[1][first], self.k[2][first]];
        let mut differs = [0u8; W];
        for l in 0..W {
            differs[l] =
                top_bit((self.k[0][l] != k[0]) | (self.k[1][l] != k[1]) | (self.k[2][l] != k[2]));
        }
        (movemask(differs) & lanes == 0).then_some(k)
    }

    /// Sets the lanes `lanes` to the segments from their origins to `targets[axis][lane]`;
    /// returns the mask of those with a non-empty segment.
    #[inline(always)]
    fn aim_lanes(&mut self, targets: &[[f32; W]; 3], lanes: u64) -> u64 {
        let regular = self.aim_regular(targets) & lanes;
        let mut live = regular;
        let mut special = lanes & !regular;
        while special != 0 {
            let l = special.trailing_zeros() as usize;
            special &= special - 1;
            let o = Vec3::new(self.origin[0][l], self.origin[1][l], self.origin[2][l]);
            let y = Vec3::new(targets[0][l], targets[1][l], targets[2][l]);
            if let Some(r) = RayData::new(o, y - o) {
                self.set_lane(l, &r);
                live |= 1 << l;
            }
        }
        live
    }

    /// Sets every lane as `RayData::new(o, target - o)` would (see [`regular_ray`]); returns
    /// the mask of the lanes where that is right: no direction component zero or non-finite.
    /// The others go through `RayData::new` itself, which handles those cases.
    #[inline(always)]
    fn aim_regular(&mut self, targets: &[[f32; W]; 3]) -> u64 {
        let o = self.origin;
        let (mut inv, mut k, mut ok, mut s) = (
            [[0f32; W]; 3],
            [[0u32; W]; 3],
            [[0f32; W]; 3],
            [[0f32; W]; 3],
        );
        let mut bytes = [0u8; W];
        for l in 0..W {
            let org = [o[0][l], o[1][l], o[2][l]];
            let dir = [
                targets[0][l] - org[0],
                targets[1][l] - org[1],
                targets[2][l] - org[2],
            ];
            let ray = regular_ray(org, dir);
            for a in 0..3 {
                (inv[a][l], k[a][l], ok[a][l], s[a][l]) =
                    (ray.inv[a], ray.k[a], ray.ok[a], ray.s[a]);
            }
            let regular = |x: f32| (x != 0.0) & x.is_finite();
            bytes[l] = top_bit(regular(dir[0]) & regular(dir[1]) & regular(dir[2]));
        }
        (self.inv, self.k, self.ok, self.s) = (inv, k, ok, s);
        (self.org_near, self.org_far) = (o, o);
        movemask(bytes)
    }

    /// Copies the single-ray data `r` into lane `l`.
    #[inline(always)]
    fn set_lane(&mut self, l: usize, r: &RayData) {
        for a in 0..3 {
            self.org_near[a][l] = r.org_near[a].x;
            self.org_far[a][l] = r.org_far[a].x;
            self.inv[a][l] = r.inv[a].x;
            self.k[a][l] = r.k[a] as u32;
            self.ok[a][l] = r.ok[a].x;
            self.s[a][l] = r.s[a].x;
        }
    }

    /// The lanes' slopes from the common target. `org_far` is the origin up to one ulp on axes
    /// of zero direction: far below the tolerance of the slope test.
    #[inline(always)]
    fn aim_slopes(&mut self, slopes: &Slopes) {
        let o = self.org_far;
        self.set_slopes(&o, slopes);
    }

    /// Sets the lanes' slopes to those of the points `p[axis][lane]` from the apex `slopes.y`:
    /// for each lane a point of its segment's line other than the apex (the origin of a
    /// converging lane, the target of a diverging one), so every point of the segment has those
    /// slopes up to rounding.
    #[inline(always)]
    fn set_slopes(&mut self, p: &[[f32; W]; 3], &Slopes { y, k, sign, .. }: &Slopes) {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let (mut sa, mut sb) = ([0f32; W], [0f32; W]);
        for l in 0..W {
            let dk = (p[k][l] - y[k]) * sign;
            sa[l] = (p[i][l] - y[i]) / dk;
            sb[l] = (p[j][l] - y[j]) / dk;
        }
        (self.sa, self.sb) = (sa, sb);
    }

    /// The lanes whose slopes lie in the rectangle `[a min, a max, b min, b max]`.
    #[inline(always)]
    fn rect_lanes(&self, [amin, amax, bmin, bmax]: [f32; 4]) -> u64 {
        let mut bytes = [0u8; W];
        for l in 0..W {
            let (a, b) = (self.sa[l], self.sb[l]);
            bytes[l] = top_bit((a >= amin) & (a <= amax) & (b >= bmin) & (b <= bmax));
        }
        movemask(bytes)
    }

    /// The lanes whose slab test accepts the box `lo..hi` over t in (0, 1): per lane the same
    /// IEEE operations, in the same order, as `Node4::hit` for that lane's single ray.
    #[inline(always)]
    fn box_lanes(&self, lo: [f32; 3], hi: [f32; 3]) -> u64 {
        let mut bytes = [0u8; W];
        for l in 0..W {
            bytes[l] = top_bit(self.slab_accepts(l, &lo, &hi));
        }
        movemask(bytes)
    }

    /// Whether lane `l`'s slab test accepts the box `lo..hi` (see [`Chunk::box_lanes`]).
    #[inline(always)]
    fn slab_accepts(&self, l: usize, lo: &[f32; 3], hi: &[f32; 3]) -> bool {
        let x = self.slab_distances(l, 0, lo, hi);
        let y = self.slab_distances(l, 1, lo, hi);
        let z = self.slab_distances(l, 2, lo, hi);
        let tnear = max_ps(max_ps(x.0, y.0), max_ps(z.0, 0.0));
        let tfar = min_ps(min_ps(x.1, y.1), min_ps(z.1, 1.0)) * ROBUST;
        tnear <= tfar
    }

    /// Lane `l`'s entry and exit distances of the slab `lo[a]..hi[a]` of axis `a`.
    #[inline(always)]
    fn slab_distances(&self, l: usize, a: usize, lo: &[f32; 3], hi: &[f32; 3]) -> (f32, f32) {
        // Whether the box maximum is the entry plane (`RayData::near`).
        let near = self.inv[a][l] < 0.0;
        let (bn, bf) = (
            if near { hi[a] } else { lo[a] },
            if near { lo[a] } else { hi[a] },
        );
        (
            (bn - self.org_near[a][l]) * self.inv[a][l],
            (bf - self.org_far[a][l]) * self.inv[a][l],
        )
    }

    /// The lanes of `lanes` that hit triangle `v` (`v[vertex][axis]`) by the watertight test
    /// over t in (0, 1): per lane the IEEE operations of `hit4` for that lane's single ray, in
    /// the same order. The lanes with an edge function of exactly zero are redone one by one
    /// with the double-precision edge functions (a cold path, so that the common one keeps
    /// everything in registers).
    ///
    /// When the lanes share their shear permutation, the vertices are permuted once for all.
    #[inline(always)]
    fn triangle_lanes(&self, v: &[[f32; 3]; 3], lanes: u64) -> u64 {
        let (hits, zero) = match self.shared_k {
            Some(k) => self.edge_tests::<true>(v, &v.map(|p| permuted(p, k))),
            None => self.edge_tests::<false>(v, v),
        };
        let zero = zero & lanes;
        if zero == 0 {
            return hits & lanes;
        }
        self.refined_lanes(v, hits & lanes & !zero, zero)
    }

    /// The lanes that hit triangle `v` by the watertight test with single-precision edge
    /// functions, and those with an edge function of exactly zero. `SHARED`: every lane has
    /// the shear permutation that `vk` holds `v` permuted by.
    #[inline(always)]
    fn edge_tests<const SHARED: bool>(&self, v: &[[f32; 3]; 3], vk: &[[f32; 3]; 3]) -> (u64, u64) {
        let (mut hits, mut zero) = ([0u8; W], [0u8; W]);
        for l in 0..W {
            let e = if SHARED {
                self.sheared_permuted(l, vk)
            } else {
                self.sheared(l, v)
            };
            let uvw = edge_functions(&e);
            hits[l] = top_bit(self.accepts(l, &e, uvw));
            zero[l] = top_bit((uvw[0] == 0.0) | (uvw[1] == 0.0) | (uvw[2] == 0.0));
        }
        (movemask(hits), movemask(zero))
    }

    /// The lanes of `lanes` that block `b` holds an opaque hit for: triangle by triangle,
    /// all the lanes at once, or for at most [`SPARSE_LANES`] lanes lane by lane, the four
    /// triangles at once (`hit4` itself, on each lane's fields, [`LaneView`]).
    #[inline(always)]
    fn blocked_lanes(&self, scene: &Scene, b: &Tri4, lanes: u64) -> u64 {
        if lanes.count_ones() <= SPARSE_LANES {
            return self.blocked_lanes_one_by_one(scene, b, lanes);
        }
        let mut blocked = 0u64;
        for t in 0..4 {
            // Short leaves repeat their last face: test each face once.
            if t > 0 && b.ids[t] == b.ids[t - 1] {
                continue;
            }
            let mut v = [[0f32; 3]; 3];
            for (vert, p) in v.iter_mut().enumerate() {
                *p = [b.v[vert][0][t], b.v[vert][1][t], b.v[vert][2][t]];
            }
            let hits = self.triangle_lanes(&v, lanes & !blocked);
            blocked |= if b.alpha >> t & 1 != 0 {
                opaque_lanes(scene, b.ids[t], self, &v, hits)
            } else {
                hits
            };
            if blocked == lanes {
                break;
            }
        }
        blocked
    }

    /// [`Chunk::blocked_lanes`] lane by lane.
    #[inline(always)]
    fn blocked_lanes_one_by_one(&self, scene: &Scene, b: &Tri4, lanes: u64) -> u64 {
        let mut blocked = 0u64;
        let mut m = lanes;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            blocked |= u64::from(Bvh::block_occludes(scene, b, &self.lane(l), 1.0)) << l;
        }
        blocked
    }

    /// Lane `l` as a single ray (see [`LaneView`]).
    #[inline(always)]
    fn lane(&self, l: usize) -> LaneView<'_> {
        LaneView {
            chunk: self,
            l,
            near: [0, 1, 2].map(|a| self.inv[a][l] < 0.0),
            k: [0, 1, 2].map(|a| self.k[a][l] as usize),
        }
    }

    /// [`Chunk::triangle_lanes`] for lanes `zero` with double-precision edge functions, added
    /// to the hits `hits` of the other lanes.
    #[cold]
    #[inline(never)]
    fn refined_lanes(&self, v: &[[f32; 3]; 3], mut hits: u64, zero: u64) -> u64 {
        let mut m = zero;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            let e = self.sheared(l, v);
            hits |= u64::from(self.accepts(l, &e, edge_functions_f64(&e))) << l;
        }
        hits
    }

    /// The barycentric weights `(b1, b2)` of the hit of lane `l` (one that hit `v`), divided
    /// as in `Lanes::get`.
    fn barycentrics(&self, l: usize, v: &[[f32; 3]; 3]) -> (f32, f32) {
        let e = self.sheared(l, v);
        let mut uvw = edge_functions(&e);
        if uvw.contains(&0.0) {
            uvw = edge_functions_f64(&e);
        }
        let det = uvw[0] + uvw[1] + uvw[2];
        (uvw[1] / det, uvw[2] / det)
    }

    /// The vertices of `v` relative to lane `l`'s origin in its permuted axes, sheared:
    /// `[ax, ay, bx, by, cx, cy, az, bz, cz]`, as in `hit4`.
    #[inline(always)]
    fn sheared(&self, l: usize, v: &[[f32; 3]; 3]) -> [f32; 9] {
        let k = [self.k[0][l], self.k[1][l], self.k[2][l]];
        self.sheared_permuted(l, &v.map(|p| permuted(p, k)))
    }

    /// [`Chunk::sheared`] given the vertices already in lane `l`'s permuted axes
    /// (`vk[vertex] = [x, y, z]` there).
    #[inline(always)]
    fn sheared_permuted(&self, l: usize, vk: &[[f32; 3]; 3]) -> [f32; 9] {
        let [ox, oy, oz] = [self.ok[0][l], self.ok[1][l], self.ok[2][l]];
        let [sx, sy] = [self.s[0][l], self.s[1][l]];
        let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = *vk;
        let (az, bz, cz) = (az - oz, bz - oz, cz - oz);
        let ax = (ax - ox) - sx * az;
        let ay = (ay - oy) - sy * az;
        let bx = (bx - ox) - sx * bz;
        let by = (by - oy) - sy * bz;
        let cx = (cx - ox) - sx * cz;
        let cy = (cy - oy) - sy * cz;
        [ax, ay, bx, by, cx, cy, az, bz, cz]
    }

    /// Whether lane `l` hits the triangle of sheared vertices `e` and edge functions `uvw`
    /// within t in (0, 1), as in `hit4`.
    #[inline(always)]
    fn accepts(&self, l: usize, e: &[f32; 9], [u, v, w]: [f32; 3]) -> bool {
        let neg = (u < 0.0) | (v < 0.0) | (w < 0.0);
        let pos = (u > 0.0) | (v > 0.0) | (w > 0.0);
        let det = u + v + w;
        let sz = self.s[2][l];
        let t = u * (sz * e[6]) + v * (sz * e[7]) + w * (sz * e[8]);
        // T / det against the interval without dividing (sign folded in, as in `hit4`).
        let ts = t * 1f32.copysign(det);
        let limit = det.abs() * 1.0;
        !(neg & pos) & (det != 0.0) & (ts > 0.0) & (ts < limit)
    }
}

/// The edge functions `U, V, W` of the sheared vertices `e` (see [`Chunk::sheared`]), each
/// from its own edge's two vertices only, as in `hit4`.
#[inline(always)]
fn edge_functions(e: &[f32; 9]) -> [f32; 3] {
    let [ax, ay, bx, by, cx, cy, ..] = *e;
    [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax]
}

/// [`edge_functions`] in double precision (the products of two floats are exact there), as
/// `refine` in `bvh/triangle.rs` does for rays through edges and vertices.
fn edge_functions_f64(e: &[f32; 9]) -> [f32; 3] {
    let [ax, ay, bx, by, cx, cy] = [0, 1, 2, 3, 4, 5].map(|q| f64::from(e[q]));
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}

impl Packet {
    /// A packet with no lanes.
    fn empty() -> Packet {
        Packet {
            chunks: [Chunk::EMPTY; CHUNKS],
            origin_bounds: [Vec3::ZERO; 2],
            origin_scale: 0.0,
            slopes: Slopes {
                y: Vec3::ZERO,
                k: 0,
                sign: 1.0,
                scale: 0.0,
            },
            lane_stack: [0; STACK],
            slot_stack: [NO_SLOT; STACK],
            ray_stack: [0; STACK],
        }
    }

    /// Sets the lanes' origins (at most [`LANES`], one lane each, in order), shared by the
    /// segments to every target of [`Packet::aim`].
    fn set_origins(&mut self, origins: &[Vec3]) {
        let origins = &origins[..origins.len().min(LANES)];
        for (c, chunk) in origins.chunks(W).enumerate() {
            self.chunks[c].set_origins(chunk);
        }
        let first = origins.first().copied().unwrap_or(Vec3::ZERO);
        self.origin_bounds = origins
            .iter()
            .fold([first, first], |[lo, hi], &o| [lo.min(o), hi.max(o)]);
        self.origin_scale = origins
            .iter()
            .fold(0f32, |m, o| m.max(o.abs().max_element()));
    }

    /// Sets the lanes to the segments from `origin` to `targets` (at most [`LANES`], one lane
    /// each, in order) for the leaf test alone (no slopes); returns the mask of those with a
    /// non-empty segment.
    #[inline(always)]
    fn set_rays(&mut self, origin: Vec3, targets: &[Vec3]) -> u64 {
        let mut live = 0u64;
        for (c, chunk) in targets[..targets.len().min(LANES)].chunks(W).enumerate() {
            live |= self.chunks[c].set_rays(origin, chunk) << (W * c);
        }
        live
    }

    /// Sets the lanes `lanes` to the segments from their origins to `target` (t in (0, 1)
    /// along `target - origin`) for the frustum axis `(k, sign)`; returns the mask of those with
    /// a non-empty segment. Only the chunks of those lanes are written; the others keep stale
    /// data that the lane masks never read.
    #[inline(always)]
    fn aim(&mut self, target: Vec3, lanes: u64, (k, sign): (usize, f32)) -> u64 {
        let slopes = self.project_from(
            target,
            (k, sign),
            self.origin_scale.max(target.abs().max_element()),
        );
        let mut live = 0u64;
        for (c, chunk) in self.chunks.iter_mut().enumerate() {
            let mine = chunk_lanes(lanes, c);
            if mine != 0 {
                live |= chunk.aim(target, mine, &slopes) << (W * c);
            }
        }
        live
    }

    /// Sets the projection of the lanes' slopes: from the apex `y` along the frustum axis
    /// `(k, sign)`, with the rounding scale `scale` of every point it projects; returns it.
    #[inline(always)]
    fn project_from(&mut self, y: Vec3, (k, sign): (usize, f32), scale: f32) -> Slopes {
        self.slopes = Slopes { y, k, sign, scale };
        self.slopes
    }

    /// Sets the lanes to the segments from `origin` to `targets` (at most [`LANES`], one lane
    /// each, in order) with their slopes from the apex `origin`, for the frustum axis
    /// `(k, sign)`; returns the mask of those with a non-empty segment.
    #[inline(always)]
    fn aim_diverging(&mut self, origin: Vec3, targets: &[Vec3], (k, sign): (usize, f32)) -> u64 {
        let targets = &targets[..targets.len().min(LANES)];
        let scale = targets.iter().fold(origin.abs().max_element(), |m, y| {
            m.max(y.abs().max_element())
        });
        let slopes = self.project_from(origin, (k, sign), scale);
        let mut live = 0u64;
        for (c, chunk) in targets.chunks(W).enumerate() {
            live |= self.chunks[c].set_rays(origin, chunk) << (W * c);
            self.chunks[c].set_slopes(&transposed(chunk), &slopes);
        }
        live
    }

    /// The slope rectangles `[a min, a max, b min, b max]` of the four children of `node`
    /// (one lane per child), widened by `1e-4` of the slopes' magnitude and of their absolute
    /// rounding scale: over a thousand times the float error of either side, so a lane whose
    /// segment meets a box is never rejected. A box reaching the target's side of the
    /// projection plane (or an empty slot) gets the whole plane.
    #[inline(always)]
    fn child_rects(&self, node: &Node4) -> [Vec4; 4] {
        let Slopes { y, k, sign, scale } = self.slopes;
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let [lo, hi] = &node.bounds;
        let sign = Vec4::splat(sign);
        let (k0, k1) = (
            (lo[k] - Vec4::splat(y[k])) * sign,
            (hi[k] - Vec4::splat(y[k])) * sign,
        );
        let kmin = k0.min(k1);
        let ahead = kmin.cmpgt(Vec4::ZERO);
        // Reciprocals: their extra rounding (one ulp) is far below the tolerance.
        let (r0, r1) = (Vec4::ONE / k0, Vec4::ONE / k1);
        let range = |a: usize| {
            let (d0, d1) = (lo[a] - Vec4::splat(y[a]), hi[a] - Vec4::splat(y[a]));
            let (q0, q1, q2, q3) = (d0 * r0, d0 * r1, d1 * r0, d1 * r1);
            let (qmin, qmax) = (q0.min(q1).min(q2.min(q3)), q0.max(q1).max(q2.max(q3)));
            let magnitude = lo[a].abs().max(hi[a].abs()).max(Vec4::splat(scale));
            let tol = (qmin.abs().max(qmax.abs()) + magnitude / kmin) * 1e-4;
            (
                Vec4::select(ahead, qmin - tol, Vec4::NEG_INFINITY),
                Vec4::select(ahead, qmax + tol, Vec4::INFINITY),
            )
        };
        let ((amin, amax), (bmin, bmax)) = (range(i), range(j));
        [amin, amax, bmin, bmax]
    }

    /// For each child `c` of `node`, the lanes of `lanes` whose slopes lie in its rectangle of
    /// `rects` (see [`Packet::child_rects`]); none for a child not in `children`.
    ///
    /// Chunk by chunk, so that a chunk's data is loaded once per node, and only for chunks
    /// with lanes (LLVM hoists the loads of every chunk a loop body touches to the loop's
    /// entry). All four rectangles are tested, met or not: the children met are unpredictable,
    /// and a mispredicted branch costs more than a rectangle test.
    #[inline(always)]
    fn child_lanes(&self, rects: &[Vec4; 4], children: u32, lanes: u64) -> [u64; 4] {
        let met = [0, 1, 2, 3].map(|child| 0u64.wrapping_sub(u64::from(children >> child & 1)));
        let mut out = [0u64; 4];
        for (c, chunk) in self.chunks.iter().enumerate() {
            let mine = chunk_lanes(lanes, c);
            if mine == 0 {
                continue;
            }
            for child in 0..4 {
                let rect = [
                    rects[0][child],
                    rects[1][child],
                    rects[2][child],
                    rects[3][child],
                ];
                out[child] |= (chunk.rect_lanes(rect) & mine & met[child]) << (W * c);
            }
        }
        out
    }

    /// The lanes of `lanes` whose slab test accepts the box `lo..hi`, chunk by chunk.
    #[inline(always)]
    fn box_lanes(&self, lo: [f32; 3], hi: [f32; 3], lanes: u64) -> u64 {
        let mut out = 0u64;
        for (c, chunk) in self.chunks.iter().enumerate() {
            let mine = chunk_lanes(lanes, c);
            if mine != 0 {
                out |= (chunk.box_lanes(lo, hi) & mine) << (W * c);
            }
        }
        out
    }

    /// The lanes of `lanes` that block `b` holds an opaque hit for: chunk by chunk (see
    /// [`Packet::child_lanes`]) and triangle by triangle, the watertight test of the chunk's
    /// lanes at once; hits on perforated faces go through the texture.
    #[inline(always)]
    fn blocked_lanes(&self, scene: &Scene, b: &Tri4, lanes: u64) -> u64 {
        let mut blocked = 0u64;
        for (c, chunk) in self.chunks.iter().enumerate() {
            let mine = chunk_lanes(lanes, c);
            if mine != 0 {
                blocked |= chunk.blocked_lanes(scene, b, mine) << (W * c);
            }
        }
        blocked
    }
}

/// The lanes of `lanes` in chunk `c`, as a chunk mask.
#[inline(always)]
fn chunk_lanes(lanes: u64, c: usize) -> u64 {
    lanes >> (W * c) & CHUNK_MASK
}

/// The lanes of `hits` (which hit the perforated face `id` of vertices `v`) that are opaque at
/// their hit point.
#[cold]
#[inline(never)]
fn opaque_lanes(scene: &Scene, id: u32, chunk: &Chunk, v: &[[f32; 3]; 3], hits: u64) -> u64 {
    let mut out = 0u64;
    let mut m = hits;
    while m != 0 {
        let l = m.trailing_zeros() as usize;
        m &= m - 1;
        let (b1, b2) = chunk.barycentrics(l, v);
        if scene.is_opaque_at(id, b1, b2) {
            out |= 1 << l;
        }
    }
    out
}

impl Bvh {
    /// Most origins of one call of [`Bvh::occluded_converging_lanes`].
    pub const PACKET_LANES: usize = LANES;

    /// For each origin, whether the open segment from it to `target` is blocked (t in (0, 1)
    /// with `dir = target - origin`): the shadow rays of many receivers to one light sample.
    /// Clears and fills `out`.
    ///
    /// Same answers as [`Bvh::occluded`] per origin; faster for nearby origins, whose segments
    /// form a narrow frustum with apex `target` traced as coherent packets (see `bvh/packet.rs`).
    pub fn occluded_converging(
        &self,
        scene: &Scene,
        origins: &[Vec3],
        target: Vec3,
        out: &mut Vec<bool>,
    ) {
        out.clear();
        for chunk in origins.chunks(LANES) {
            let mut blocked = [0u64];
            self.occluded_converging_lanes(scene, chunk, &[target], &[u64::MAX], &mut blocked);
            out.extend((0..chunk.len()).map(|lane| blocked[0] >> lane & 1 != 0));
        }
    }

    /// The shadow rays of up to [`Bvh::PACKET_LANES`] receivers (`origins`, lane `i` for
    /// `origins[i]`; any further origins are ignored) to many light samples: for each target
    /// `targets[s]`, sets `blocked[s]` to the mask of the lanes of `lanes[s]` whose open segment
    /// `origin -> targets[s]` (t in (0, 1)) is blocked. Stops at the shortest of `targets`,
    /// `lanes` and `blocked`.
    ///
    /// Same answers as [`Bvh::occluded`] per segment: the rays of each target are one packet
    /// of [`Bvh::occluded_converging`], with the origins transposed once for all targets.
    pub fn occluded_converging_lanes(
        &self,
        scene: &Scene,
        origins: &[Vec3],
        targets: &[Vec3],
        lanes: &[u64],
        blocked: &mut [u64],
    ) {
        self.occluded_converging_lanes_with(Isa::detect(), scene, origins, targets, lanes, blocked);
    }

    /// [`Bvh::occluded_converging_lanes`] with the traversal compiled for `isa`.
    pub(super) fn occluded_converging_lanes_with(
        &self,
        isa: Isa,
        scene: &Scene,
        origins: &[Vec3],
        targets: &[Vec3],
        lanes: &[u64],
        blocked: &mut [u64],
    ) {
        let origins = &origins[..origins.len().min(LANES)];
        let present = u64::MAX
            .checked_shr((LANES - origins.len()) as u32)
            .unwrap_or(0);
        PACKET.with(|p| {
            // Only busy if `is_opaque_at` re-entered the BVH on this thread.
            let mut packet = p.try_borrow_mut().ok();
            if let Some(packet) = packet.as_mut() {
                packet.set_origins(origins);
            }
            let mut trace = |stack: &mut [u32; STACK]| {
                for ((&y, &m), out) in targets.iter().zip(lanes).zip(blocked.iter_mut()) {
                    let m = m & present;
                    *out = match packet.as_mut() {
                        _ if m == 0 => 0,
                        // The frustum of all the origins bounds the segments of any lanes.
                        Some(packet) => match RayFrustum::around(y, packet.origin_bounds) {
                            Some(f) => self.packet_trace(isa, scene, packet, y, m, &f, stack),
                            // No pyramid with apex `y` bounds the origins: the rays go one by one.
                            None => self.one_by_one(scene, origins, y, m),
                        },
                        None => self.one_by_one(scene, origins, y, m),
                    };
                }
            };
            super::ANY_STACK.with(|s| match s.try_borrow_mut() {
                Ok(mut stack) => trace(&mut stack),
                Err(_) => trace(&mut [0; STACK]),
            });
        });
    }

    /// The mask of the lanes of `lanes` whose segment `origins[lane] -> target` is blocked,
    /// ray by ray.
    fn one_by_one(&self, scene: &Scene, origins: &[Vec3], target: Vec3, lanes: u64) -> u64 {
        (0..origins.len())
            .filter(|&lane| lanes >> lane & 1 != 0)
            .filter(|&lane| self.occluded(scene, origins[lane], target - origins[lane], 1.0))
            .fold(0, |m, lane| m | 1 << lane)
    }

    /// The mask of the segments `origin -> targets[lane]` (t in (0, 1); at most
    /// [`Bvh::PACKET_LANES`] targets, any further ones ignored) that are blocked: the shadow
    /// rays of one receiver to many light samples, traced as one packet diverging from
    /// `origin`. With `front`, a plane every segment lies in front of (a receiver's tangent
    /// plane, [`FrontPlane`]), the subtrees wholly behind it are skipped.
    ///
    /// Same answers as [`Bvh::occluded`] per segment (see `bvh/packet.rs`).
    pub fn occluded_diverging(
        &self,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
        front: Option<FrontPlane>,
    ) -> u64 {
        self.occluded_diverging_with(Isa::detect(), scene, origin, targets, front)
    }

    /// [`Bvh::occluded_diverging`] with the traversal compiled for `isa`.
    pub(super) fn occluded_diverging_with(
        &self,
        isa: Isa,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
        front: Option<FrontPlane>,
    ) -> u64 {
        let targets = &targets[..targets.len().min(LANES)];
        let one_by_one = || {
            (0..targets.len())
                .filter(|&l| self.occluded(scene, origin, targets[l] - origin, 1.0))
                .fold(0, |m, l| m | 1 << l)
        };
        // No pyramid with apex `origin` bounding the targets: the rays go one by one.
        let Some(f) = bounds(targets).and_then(|b| RayFrustum::around(origin, b)) else {
            return one_by_one();
        };
        let f = f.in_front_of(front);
        PACKET.with(|p| match p.try_borrow_mut() {
            Ok(mut packet) => super::ANY_STACK.with(|s| match s.try_borrow_mut() {
                Ok(mut stack) => {
                    self.diverging_trace(isa, scene, &mut packet, origin, targets, &f, &mut stack)
                }
                Err(_) => self.diverging_trace(
                    isa,
                    scene,
                    &mut packet,
                    origin,
                    targets,
                    &f,
                    &mut [0; STACK],
                ),
            }),
            // Only busy if `is_opaque_at` re-entered the BVH on this thread.
            Err(_) => one_by_one(),
        })
    }

    isa_dispatch! {
        /// Aims the packet's lanes from `origin` at `targets` and traverses it; returns the
        /// mask of blocked lanes.
        fn diverging_trace(&Bvh) => diverging_trace_body(
            scene: &Scene,
            p: &mut Packet,
            origin: Vec3,
            targets: &[Vec3],
            f: &RayFrustum,
            stack: &mut [u32; STACK],
        ) -> u64
    }

    #[inline(always)]
    fn diverging_trace_body(
        &self,
        scene: &Scene,
        p: &mut Packet,
        origin: Vec3,
        targets: &[Vec3],
        f: &RayFrustum,
        stack: &mut [u32; STACK],
    ) -> u64 {
        let live = p.aim_diverging(origin, targets, f.axis());
        let mut active = live;
        self.packet_traverse(scene, p, f, &mut active, stack);
        live & !active
    }

    isa_dispatch! {
        /// Aims the lanes `lanes` of the packet at `target` and traverses it; returns the mask
        /// of blocked lanes.
        fn packet_trace(&Bvh) => packet_trace_body(
            scene: &Scene,
            p: &mut Packet,
            target: Vec3,
            lanes: u64,
            f: &RayFrustum,
            stack: &mut [u32; STACK],
        ) -> u64
    }

    #[inline(always)]
    fn packet_trace_body(
        &self,
        scene: &Scene,
        p: &mut Packet,
        target: Vec3,
        lanes: u64,
        f: &RayFrustum,
        stack: &mut [u32; STACK],
    ) -> u64 {
        let live = p.aim(target, lanes, f.axis());
        let mut active = live;
        self.packet_traverse(scene, p, f, &mut active, stack);
        live & !active
    }

    /// For each target, whether the open segment from `origin` to it (t in (0, 1)) hits one of
    /// the blocks `cand`: the candidate test of [`Bvh::occluded_by_candidates`], compiled for
    /// `isa`. Appends to `out`.
    ///
    /// The segments are lanes of the packet buffer, [`LANES`] at a time, each candidate block
    /// tested for all the lanes not yet blocked at once (the same per-lane test as
    /// [`Bvh::block_occludes`], see [`Packet::blocked_lanes`]).
    pub(super) fn occluded_by_blocks(
        &self,
        isa: Isa,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
        cand: &[LeafRef],
        out: &mut Vec<bool>,
    ) {
        PACKET.with(|p| match p.try_borrow_mut() {
            Ok(mut packet) => {
                for chunk in targets.chunks(LANES) {
                    let blocked = self.blocks_trace(isa, scene, &mut packet, origin, chunk, cand);
                    out.extend((0..chunk.len()).map(|lane| blocked >> lane & 1 != 0));
                }
            }
            // Only busy if `is_opaque_at` re-entered the BVH on this thread: ray by ray.
            Err(_) => out.extend(targets.iter().map(|&y| {
                let hits = |r: &RayData| {
                    cand.iter().any(|c| {
                        Self::block_occludes(scene, &self.blocks[c.block as usize], r, 1.0)
                    })
                };
                RayData::new(origin, y - origin).is_some_and(|r| hits(&r))
            })),
        });
    }

    isa_dispatch! {
        /// The mask of the segments `origin -> targets` (at most [`LANES`]) that hit one of the
        /// blocks `cand`.
        fn blocks_trace(&Bvh) => blocks_trace_body(
            scene: &Scene,
            p: &mut Packet,
            origin: Vec3,
            targets: &[Vec3],
            cand: &[LeafRef],
        ) -> u64
    }

    #[inline(always)]
    fn blocks_trace_body(
        &self,
        scene: &Scene,
        p: &mut Packet,
        origin: Vec3,
        targets: &[Vec3],
        cand: &[LeafRef],
    ) -> u64 {
        let live = p.set_rays(origin, targets);
        let mut blocked = 0u64;
        for c in cand {
            if blocked == live {
                break;
            }
            // The lanes' own slab tests first, as in the traversal (see `Packet::child_lanes`).
            let lanes = p.box_lanes(c.lo, c.hi, live & !blocked);
            if lanes != 0 {
                blocked |= p.blocked_lanes(scene, &self.blocks[c.block as usize], lanes);
            }
        }
        blocked
    }

    /// Traverses the tree with the packet's frustum, clearing from `active` every lane found
    /// blocked; stops as soon as no lane is active. Each stacked node or leaf carries the lanes
    /// that may reach it by the projection test, so a subtree is left as soon as none of the
    /// lanes still active can reach it (the frustum of all lanes stays as wide as at the
    /// start). A leaf also carries its box (its parent and slot): the lanes still active when
    /// it is popped run their slab tests, and those accepted the triangle tests.
    ///
    /// One loop, no inner one (see [`Packet::child_lanes`]): leaves are stacked like nodes,
    /// after the inner children of their parent, so they are tested first. A node popped with
    /// at most [`SINGLE_RAY_LANES`] active lanes goes to [`Bvh::single_ray_lanes`].
    ///
    /// A node visit is a chain of dependent work: the node's rectangles, the lanes of its
    /// children, the pushes, the next pop. At 128x128 (timed as [`SINGLE_RAY_LANES`])
    /// prefetching the nodes and leaves pushed on the stack took 0.97-1.03x the CPU time and
    /// pushing the children without a branch per child 0.99-1.01x; computing the rectangles
    /// and the children's lanes twice more per visit took 1.18-1.20x, which puts that part near
    /// a tenth of the call.
    #[inline(always)]
    fn packet_traverse(
        &self,
        scene: &Scene,
        p: &mut Packet,
        f: &RayFrustum,
        active: &mut u64,
        stack: &mut [u32; STACK],
    ) {
        let mut sp = 0usize;
        // A single-leaf tree has no node box: every lane tests the leaf.
        let (mut cur, mut lanes, mut slot) = (self.root, *active, NO_SLOT);
        loop {
            lanes &= *active;
            if lanes != 0 && cur & LEAF != 0 {
                if slot != NO_SLOT {
                    let leaf = self.nodes[slot / 4].leaf_ref(slot % 4);
                    lanes = p.box_lanes(leaf.lo, leaf.hi, lanes);
                }
                if lanes != 0 {
                    *active &= !p.blocked_lanes(scene, &self.blocks[(cur & !LEAF) as usize], lanes);
                }
            } else if lanes != 0 && lanes.count_ones() <= SINGLE_RAY_LANES {
                *active &= !self.single_ray_lanes(scene, p, cur, lanes);
            } else if lanes != 0 {
                let node = &self.nodes[cur as usize];
                let children = f.overlaps(node);
                if children != 0 {
                    let sub = p.child_lanes(&p.child_rects(node), children, lanes);
                    for leaves in [false, true] {
                        for (c, &sub) in sub.iter().enumerate() {
                            if sub != 0 && (node.child[c] & LEAF != 0) == leaves {
                                // At most 4 pushes per level and 3 * depth + 1 <= STACK (see
                                // `build`): each level leaves at most 3 siblings behind, the
                                // deepest adds 4.
                                stack[sp] = node.child[c];
                                p.lane_stack[sp] = sub;
                                p.slot_stack[sp] = cur as usize * 4 + c;
                                sp += 1;
                            }
                        }
                    }
                }
            }
            if sp == 0 || *active == 0 {
                return;
            }
            sp -= 1;
            (cur, lanes, slot) = (stack[sp], p.lane_stack[sp], p.slot_stack[sp]);
        }
    }

    /// The lanes of `lanes` blocked within the subtree of node `node`, each found by its own
    /// single-ray traversal (inlined: compiled for the packet's instruction set).
    #[inline(always)]
    fn single_ray_lanes(&self, scene: &Scene, p: &mut Packet, node: u32, lanes: u64) -> u64 {
        let mut blocked = 0u64;
        let mut m = lanes;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            let r = p.chunks[l / W].lane(l % W);
            if self
                .any_hit_inline(scene, &r, 1.0, node, None, &mut p.ray_stack)
                .is_some()
            {
                blocked |= 1 << l;
            }
        }
        blocked
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;
    use crate::geometry::mesh::{AlphaTexture, Mesh};
    use crate::light::sampling::Rng;
    use glam::Vec2;

    /// Random small triangles over `[0, 4]^3` (opaque), the same shifted and perforated by a
    /// random binary texture, and a ground quad at y = -0.5.
    fn scene(n: usize, seed: u64) -> Scene {
        let mut rng = Rng::new(seed);
        let mut r3 = |s: f32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * s;
        let mut pos = Vec::new();
        for _ in 0..n {
            let c = r3(4.0);
            pos.extend([c + r3(0.5) - 0.25, c + r3(0.5) - 0.25, c + r3(0.5) - 0.25]);
        }
        let faces: Vec<[u32; 3]> = (0..n as u32)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect();
        let opaque = Mesh::new(pos.clone(), faces.clone(), None, None, false).unwrap();
        let uvs: Vec<Vec2> = pos
            .iter()
            .map(|p| Vec2::new(p.x * 3.1, p.z * 2.7 + p.y))
            .collect();
        let alpha: Vec<f32> = (0..16 * 16)
            .map(|k| ((k * 7919 + 13) % 5 < 2) as u8 as f32)
            .collect();
        let shifted: Vec<Vec3> = pos
            .iter()
            .map(|p| *p + Vec3::new(0.17, -0.11, 0.23))
            .collect();
        let tex = AlphaTexture::new(16, 16, &alpha).unwrap();
        let perforated = Mesh::new(shifted, faces, Some(uvs), Some(tex), false).unwrap();
        let g = [(-1.0, -1.0), (5.0, -1.0), (5.0, 5.0), (-1.0, 5.0)]
            .map(|(x, z)| Vec3::new(x, -0.5, z));
        let ground = Mesh::new(g.to_vec(), vec![[0, 1, 2], [0, 2, 3]], None, None, false).unwrap();
        Scene::new(vec![opaque, perforated, ground]).unwrap()
    }

    /// The instruction sets of this CPU: every packet test runs on each.
    fn isas() -> Vec<Isa> {
        Isa::all_on_this_cpu()
    }

    /// Checks every lane of `occluded_converging` against `occluded`, and the traversal of
    /// every instruction set against it; returns (blocked, lit).
    fn check(bvh: &Bvh, scene: &Scene, origins: &[Vec3], target: Vec3) -> (usize, usize) {
        let mut out = vec![true; 3];
        bvh.occluded_converging(scene, origins, target, &mut out);
        assert_eq!(out.len(), origins.len());
        for (&o, &blocked) in origins.iter().zip(&out) {
            assert_eq!(
                blocked,
                bvh.occluded(scene, o, target - o, 1.0),
                "origin {o} target {target}"
            );
        }
        for isa in isas() {
            for (c, chunk) in origins.chunks(LANES).enumerate() {
                let mut blocked = [0u64];
                bvh.occluded_converging_lanes_with(
                    isa,
                    scene,
                    chunk,
                    &[target],
                    &[u64::MAX],
                    &mut blocked,
                );
                let expected = (0..chunk.len())
                    .filter(|&i| out[LANES * c + i])
                    .fold(0u64, |m, i| m | 1 << i);
                assert_eq!(blocked[0], expected, "{isa:?} target {target}");
            }
        }
        let blocked = out.iter().filter(|&&b| b).count();
        (blocked, out.len() - blocked)
    }

    /// A random point on the ground of [`scene`] or inside its soup of triangles.
    fn point_in_soup(rng: &mut Rng) -> Vec3 {
        Vec3::new(
            rng.next_f32() * 4.0,
            rng.next_f32() * 4.5 - 0.49,
            rng.next_f32() * 4.0,
        )
    }

    #[test]
    fn converging_packets_equal_single_rays() {
        let scene = scene(600, 7);
        let bvh = Bvh::build(&scene).unwrap();
        let mut rng = Rng::new(11);
        let (mut blocked, mut lit) = (0, 0);
        for _ in 0..60 {
            // A tile of origins on the ground or inside the soup (9 x 9: two packets), and
            // targets above: lit, penumbra and umbra lanes, perforated hits included.
            let corner = point_in_soup(&mut rng);
            let step = 0.002 + rng.next_f32() * 0.05;
            let origins: Vec<Vec3> = (0..81)
                .map(|k| corner + Vec3::new((k % 9) as f32 * step, 0.0, (k / 9) as f32 * step))
                .collect();
            for _ in 0..8 {
                let target = Vec3::new(
                    rng.next_f32() * 6.0 - 1.0,
                    6.0 + rng.next_f32(),
                    rng.next_f32() * 6.0 - 1.0,
                );
                let (b, l) = check(&bvh, &scene, &origins, target);
                (blocked, lit) = (blocked + b, lit + l);
            }
        }
        assert!(blocked > 2000 && lit > 2000, "blocked {blocked}, lit {lit}");
    }

    #[test]
    fn converging_packets_with_mixed_shear_axes() {
        let scene = scene(600, 7);
        let bvh = Bvh::build(&scene).unwrap();
        let target = Vec3::new(2.0, 3.0, 2.0);
        let (mut blocked, mut lit) = (0, 0);
        for row in 0..12 {
            // Directions (d, 1.5, dz) with d across 1.5: every chunk of 16 lanes holds rays
            // whose dominant axis is x and rays whose dominant axis is y (two shear
            // permutations), so the per-lane path of `Chunk::triangle_lanes` runs.
            let z = 1.75 + 0.04 * row as f32;
            let d = |k: usize| 1.2 + 0.04 * (k % 16) as f32 + 0.01 * (k / 16) as f32;
            let origins: Vec<Vec3> = (0..64).map(|k| Vec3::new(2.0 - d(k), 1.5, z)).collect();
            for chunk in origins.chunks(W) {
                let axes: Vec<usize> = chunk
                    .iter()
                    .map(|&o| RayData::new(o, target - o).unwrap().k[2])
                    .collect();
                assert!(
                    axes.contains(&0) && axes.contains(&1),
                    "row {row}: dominant axes {axes:?}"
                );
            }
            let (b, l) = check(&bvh, &scene, &origins, target);
            (blocked, lit) = (blocked + b, lit + l);
        }
        assert!(blocked > 50 && lit > 50, "blocked {blocked}, lit {lit}");
    }

    #[test]
    fn converging_packets_handle_degenerate_rays() {
        let scene = scene(300, 3);
        let bvh = Bvh::build(&scene).unwrap();
        let target = Vec3::new(2.0, 6.0, 2.0);
        // Directions with exactly zero components (origins straight below or level with the
        // target) and an empty segment (origin at the target).
        let mut origins: Vec<Vec3> = (0..20)
            .map(|k| Vec3::new(2.0, -0.5 + 0.3 * k as f32, 2.0))
            .collect();
        origins.extend((0..20).map(|k| Vec3::new(0.2 * k as f32, -0.4, 2.0)));
        origins.push(target);
        check(&bvh, &scene, &origins, target);
        // Origins on both sides of the target: no frustum, the rays go one by one.
        let around: Vec<Vec3> = (0..16)
            .map(|k| Vec3::new(0.3 * k as f32 - 0.5, 2.0, 2.0))
            .collect();
        check(&bvh, &scene, &around, Vec3::new(2.0, 2.0, 2.1));
        // No origins at all.
        check(&bvh, &scene, &[], target);
    }

    /// Asserts that every target's converging lanes (`lanes[t]` of `origins`, past the first
    /// [`LANES`] ignored) get the answers of single rays on every instruction set; returns the
    /// blocked and lit lanes counted over all of them.
    fn converging_lanes_against_single_rays(
        bvh: &Bvh,
        scene: &Scene,
        origins: &[Vec3],
        targets: &[Vec3],
        lanes: &[u64],
    ) -> (u32, u32) {
        let (mut blocked, mut lit) = (0, 0);
        for isa in isas() {
            let mut out = vec![u64::MAX; targets.len()];
            bvh.occluded_converging_lanes_with(isa, scene, origins, targets, lanes, &mut out);
            for ((&y, &m), &got) in targets.iter().zip(lanes).zip(&out) {
                let expected = (0..LANES)
                    .filter(|&i| {
                        m >> i & 1 != 0 && bvh.occluded(scene, origins[i], y - origins[i], 1.0)
                    })
                    .fold(0u64, |acc, i| acc | 1 << i);
                assert_eq!(got, expected, "{isa:?} target {y} lanes {m:#x}");
                (blocked, lit) = (blocked + got.count_ones(), lit + (m & !got).count_ones());
            }
        }
        (blocked, lit)
    }

    /// Many targets with their own lane masks per call: each target's answers are those of
    /// single rays for its lanes alone (and 0 for the others), on every instruction set.
    #[test]
    fn converging_lanes_equal_single_rays() {
        let scene = scene(600, 5);
        let bvh = Bvh::build(&scene).unwrap();
        let mut rng = Rng::new(3);
        let origins: Vec<Vec3> = (0..LANES + 5)
            .map(|k| {
                Vec3::new(
                    1.0 + (k % 8) as f32 * 0.03,
                    -0.49 + rng.next_f32() * 2.0,
                    1.0 + (k / 8) as f32 * 0.03,
                )
            })
            .collect();
        let targets: Vec<Vec3> = (0..24)
            .map(|_| {
                Vec3::new(
                    rng.next_f32() * 6.0 - 1.0,
                    6.0 + rng.next_f32(),
                    rng.next_f32() * 6.0 - 1.0,
                )
            })
            .collect();
        let lanes: Vec<u64> = (0..targets.len())
            .map(|_| rng.next_u64() | rng.next_u64())
            .collect();
        let (blocked, lit) =
            converging_lanes_against_single_rays(&bvh, &scene, &origins, &targets, &lanes);
        assert!(blocked > 100 && lit > 100, "blocked {blocked}, lit {lit}");
    }

    /// Asserts that the packet diverging from `origin` to `targets` (past the first [`LANES`]
    /// ignored) gets the answers of single rays on every instruction set; returns the blocked
    /// and lit lanes.
    fn diverging_against_single_rays(
        bvh: &Bvh,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
    ) -> (u32, u32) {
        let n = targets.len().min(LANES);
        let expected = (0..n)
            .filter(|&l| bvh.occluded(scene, origin, targets[l] - origin, 1.0))
            .fold(0u64, |m, l| m | 1 << l);
        for isa in isas() {
            let got = bvh.occluded_diverging_with(isa, scene, origin, targets, None);
            assert_eq!(got, expected, "{isa:?} origin {origin}");
        }
        (expected.count_ones(), n as u32 - expected.count_ones())
    }

    /// The shadow rays of one origin to many targets as one diverging packet: the answers of
    /// single rays, lane for lane, on every instruction set, from origins on the ground and
    /// inside the soup (opaque and perforated hits), with more targets than lanes.
    #[test]
    fn diverging_packets_equal_single_rays() -> Result<()> {
        let scene = scene(600, 17);
        let bvh = Bvh::build(&scene)?;
        let mut rng = Rng::new(29);
        let (mut blocked, mut lit) = (0, 0);
        for _ in 0..60 {
            let origin = point_in_soup(&mut rng);
            // A light 1 to 3 units wide above the soup.
            let (corner, size) = (
                Vec3::new(rng.next_f32() * 4.0 - 1.0, 6.0, rng.next_f32() * 4.0 - 1.0),
                1.0 + rng.next_f32() * 2.0,
            );
            let targets: Vec<Vec3> = (0..LANES + 9)
                .map(|_| corner + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * size)
                .collect();
            let (b, l) = diverging_against_single_rays(&bvh, &scene, origin, &targets);
            (blocked, lit) = (blocked + b, lit + l);
        }
        assert!(blocked > 1000 && lit > 1000, "blocked {blocked}, lit {lit}");
        Ok(())
    }

    /// Diverging packets with empty segments (targets at the origin), directions with exactly
    /// zero components, targets on both sides of the origin (no frustum: ray by ray) and no
    /// targets at all.
    #[test]
    fn diverging_packets_handle_degenerate_rays() -> Result<()> {
        let scene = scene(300, 3);
        let bvh = Bvh::build(&scene)?;
        let origin = Vec3::new(2.0, -0.4, 2.0);
        let mut targets: Vec<Vec3> = (0..20)
            .map(|k| Vec3::new(2.0, 0.5 + 0.3 * k as f32, 2.0))
            .collect();
        targets.extend((0..20).map(|k| Vec3::new(0.2 * k as f32, 6.0, 2.0)));
        targets.push(origin);
        diverging_against_single_rays(&bvh, &scene, origin, &targets);
        let around: Vec<Vec3> = (0..16)
            .map(|k| Vec3::new(0.3 * k as f32 - 0.5, 2.0, 2.1))
            .collect();
        diverging_against_single_rays(&bvh, &scene, Vec3::new(2.0, 2.0, 2.0), &around);
        diverging_against_single_rays(&bvh, &scene, origin, &[]);
        Ok(())
    }

    /// Packets of a few lanes (at most [`SINGLE_RAY_LANES`] + 1 per target, so that some go
    /// to single-ray traversals from the root and some from a node further down): the answers
    /// of single rays, lane for lane, on every instruction set.
    #[test]
    fn sparse_lanes_equal_single_rays() {
        let scene = scene(600, 13);
        let bvh = Bvh::build(&scene).unwrap();
        let mut rng = Rng::new(21);
        let origins: Vec<Vec3> = (0..LANES)
            .map(|_| {
                Vec3::new(
                    rng.next_f32() * 4.0,
                    -0.49 + rng.next_f32() * 4.0,
                    rng.next_f32() * 4.0,
                )
            })
            .collect();
        let targets: Vec<Vec3> = (0..200)
            .map(|_| {
                Vec3::new(
                    rng.next_f32() * 6.0 - 1.0,
                    6.0 + rng.next_f32(),
                    rng.next_f32() * 6.0 - 1.0,
                )
            })
            .collect();
        let lanes: Vec<u64> = (0..targets.len())
            .map(|t| {
                let count = 1 + t % (SINGLE_RAY_LANES as usize + 1);
                (0..count).fold(0u64, |m, _| m | 1 << rng.below(LANES))
            })
            .collect();
        let (blocked, lit) =
            converging_lanes_against_single_rays(&bvh, &scene, &origins, &targets, &lanes);
        assert!(blocked > 50 && lit > 50, "blocked {blocked}, lit {lit}");
    }

    /// Segments through the shared vertices and edges of a grid of unit triangles (integer
    /// coordinates: edge functions of exactly zero, redone in double precision): the packets
    /// of every instruction set agree with single rays, which never slip through.
    #[test]
    fn converging_packets_through_vertices_and_edges() {
        let k = 8u32;
        let pos: Vec<Vec3> = (0..=k)
            .flat_map(|z| (0..=k).map(move |x| Vec3::new(x as f32, 0.0, z as f32)))
            .collect();
        let faces = (0..k)
            .flat_map(|z| (0..k).map(move |x| z * (k + 1) + x))
            .flat_map(|a| [[a, a + 1, a + k + 2], [a, a + k + 2, a + k + 1]])
            .collect();
        let scene = Scene::new(vec![Mesh::new(pos, faces, None, None, false).unwrap()]).unwrap();
        let bvh = Bvh::build(&scene).unwrap();
        let origins: Vec<Vec3> = (0..49)
            .map(|i| Vec3::new((i % 7) as f32, -1.0, (i / 7) as f32))
            .collect();
        let mut blocked = 0;
        for target in [
            Vec3::new(2.0, 1.0, 4.0),
            Vec3::new(3.0, 3.0, 1.0),
            Vec3::new(6.0, 1.0, 6.0),
        ] {
            blocked += check(&bvh, &scene, &origins, target).0;
        }
        assert_eq!(blocked, 3 * 49);
    }

    /// The candidate test of the frustum pass (shared origin, many targets) on every
    /// instruction set: with every block as a candidate, the answers of single rays.
    #[test]
    fn candidate_blocks_equal_single_rays() {
        let scene = scene(600, 9);
        let bvh = Bvh::build(&scene).unwrap();
        let all = bvh.leaf_refs();
        assert_eq!(all.len(), bvh.leaf_count());
        let mut rng = Rng::new(5);
        let (mut blocked, mut lit) = (0, 0);
        for _ in 0..20 {
            let origin = Vec3::new(
                rng.next_f32() * 4.0,
                rng.next_f32() * 4.5 - 0.49,
                rng.next_f32() * 4.0,
            );
            let targets: Vec<Vec3> = (0..LANES + 13)
                .map(|_| {
                    Vec3::new(
                        rng.next_f32() * 6.0 - 1.0,
                        6.0 + rng.next_f32(),
                        rng.next_f32() * 6.0 - 1.0,
                    )
                })
                .collect();
            let expected: Vec<bool> = targets
                .iter()
                .map(|&y| bvh.occluded(&scene, origin, y - origin, 1.0))
                .collect();
            for isa in isas() {
                let mut out = Vec::new();
                bvh.occluded_by_blocks(isa, &scene, origin, &targets, &all, &mut out);
                assert_eq!(out, expected, "{isa:?} origin {origin}");
            }
            blocked += expected.iter().filter(|&&b| b).count();
            lit += expected.iter().filter(|&&b| !b).count();
        }
        assert!(blocked > 200 && lit > 200, "blocked {blocked}, lit {lit}");
    }
}
