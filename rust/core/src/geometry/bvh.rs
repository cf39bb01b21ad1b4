//! The bounding volume hierarchy of all scene triangles, used by the ray-traced oracle and the
//! G-buffer.
//!
//! Layout: a 4-wide BVH (each node holds the boxes of its up to four children as `Vec4` lanes,
//! one 64-byte-aligned node per visit) built by binned SAH over a binary tree and collapsed (see
//! `bvh/build.rs`). Leaves hold at most four triangles, stored as one `Tri4` block of
//! precomputed vertex coordinates in structure-of-arrays form, so a leaf is one SIMD
//! watertight test (`bvh/triangle.rs`, after Woop, Benthin and Wald 2013) and no index or
//! vertex buffer is touched during traversal.
//!
//! Queries cover the *open* interval t in (0, `t_max`) of `origin + t dir` (`dir` need not be
//! unit; `t` is in units of `dir`). Faces of perforated meshes are alpha-tested: a hit counts only
//! where the texture is opaque, transparent hits are skipped and the traversal goes on. Each block
//! carries a bitmask of its perforated lanes, so opaque meshes never pay for the texture path.
//!
//! Box tests are conservative: the exit distance is scaled by `1 + 4 eps` (Ize, "Robust BVH Ray
//! Traversal", JCGT 2013, needs `1 + 2 gamma_3`), so a triangle hit by the watertight test is
//! never culled by a box rounding the other way, and the any-hit answer does not depend on the
//! traversal order. Results are deterministic: the build is, and traversal is sequential per ray.
//!
//! Shadow rays: [`Bvh::occluded`] answers one segment; [`Bvh::occluded_many`] answers the
//! shadow rays of one receiver together, culling with the frustum of their shared origin
//! (`bvh/frustum.rs`: no triangle test at all for a fully lit receiver) and remembering the
//! leaf and subtree that blocked the previous ray ([`ShadowCache`]); [`Bvh::occluded_converging`]
//! answers the rays of many receivers to one light sample as coherent packets (`bvh/packet.rs`).
//! Traversal stacks are per-thread arrays sized by the depth bound of the build, so queries
//! allocate nothing.

mod build;
mod frustum;
mod packet;
mod triangle;

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::isa::Isa;
pub use frustum::FrontPlane;
use frustum::{RayFrustum, MAX_CANDIDATES};
use glam::{Vec3, Vec4};
use std::cell::RefCell;
use std::sync::OnceLock;
pub use triangle::intersect_triangle;
use triangle::{hit4, Lanes, Ray, RayData};

/// Traversal stack entries; `build` guarantees `3 * depth + 1 <= STACK`.
const STACK: usize = 256;
/// Child reference flag: the low 31 bits index `blocks`, not `nodes`.
const LEAF: u32 = 1 << 31;
/// An unused child slot (its box is empty and never hit).
const EMPTY: u32 = u32::MAX;
/// Conservative scale of box exit distances (>= 1 + 2 gamma_3 of Ize 2013).
const ROBUST: f32 = 1.0 + 4.0 * f32::EPSILON;

thread_local! {
    /// Per-thread traversal stacks, so that no query zeroes a fresh kilobyte-sized stack.
    static ANY_STACK: RefCell<[u32; STACK]> = const { RefCell::new([0; STACK]) };
    static CLOSEST_STACK: RefCell<[(u32, f32); STACK]> = const { RefCell::new([(0, 0.0); STACK]) };
}

/// The leaves one frustum pass found ([`Bvh::frustum_candidates`]): at most
/// [`FrustumCandidates::MAX`].
#[derive(Debug, Clone, Copy)]
pub struct FrustumCandidates {
    leaves: [LeafRef; MAX_CANDIDATES],
    len: usize,
}

/// A leaf and the box its parent node stores for it (for the root leaf of a tree of at most
/// four triangles, the bounds of the whole tree).
#[derive(Debug, Clone, Copy, Default)]
struct LeafRef {
    block: u32,
    lo: [f32; 3],
    hi: [f32; 3],
}

/// Where a traversal starts: the root node, or the only leaf of a tree of at most four
/// triangles.
#[derive(Debug, Clone, Copy)]
enum Root {
    Node(u32),
    Leaf(LeafRef),
}

impl FrustumCandidates {
    /// Most leaves of one frustum pass.
    pub const MAX: usize = MAX_CANDIDATES;

    /// Whether the frustum met no leaf: all its segments are unblocked.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A closest hit: distance `t` in units of the ray direction, the global face id and the
/// barycentric weights `b1`, `b2` of the face's vertices 1 and 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub face: u32,
    pub b1: f32,
    pub b2: f32,
}

/// Remembers where the last shadow ray of a receiver was blocked: the leaf, tested first, and
/// the subtree a few levels above it, searched before the whole tree. Neighbouring shadow rays
/// of one receiver are usually blocked by the same or nearby triangles, so most umbra rays are
/// answered by one leaf test or a small subtree. It only changes speed, never answers (any
/// opaque hit in the open segment is an answer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShadowCache {
    block: u32,
    /// An ancestor node of `block` ([`SUBTREE_LEVELS`] up), searched before the whole tree.
    subtree: u32,
}

impl Default for ShadowCache {
    fn default() -> Self {
        Self {
            block: EMPTY,
            subtree: EMPTY,
        }
    }
}

/// How many levels above the last blocking leaf the cached subtree starts.
const SUBTREE_LEVELS: usize = 3;

/// One inner node: the bounds of four children (`bounds[0]` minima, `bounds[1]` maxima, each
/// `[x, y, z]` with one lane per child) and their references.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct Node4 {
    bounds: [[Vec4; 3]; 2],
    child: [u32; 4],
}

impl Node4 {
    /// Child `c`, a leaf, with its box.
    fn leaf_ref(&self, c: usize) -> LeafRef {
        let [lo, hi] = &self.bounds;
        LeafRef {
            block: self.child[c] & !LEAF,
            lo: [lo[0][c], lo[1][c], lo[2][c]],
            hi: [hi[0][c], hi[1][c], hi[2][c]],
        }
    }

    const EMPTY_NODE: Node4 = Node4 {
        bounds: [[Vec4::INFINITY; 3], [Vec4::NEG_INFINITY; 3]],
        child: [EMPTY; 4],
    };

    /// Slab test of the four child boxes: the bitmask of those overlapping (0, `t_max`) and
    /// their entry distances.
    #[inline(always)]
    fn hit<R: Ray>(&self, r: &R, t_max: f32) -> (u32, Vec4) {
        let n = r.near().map(usize::from);
        let f = r.near().map(|b| usize::from(!b));
        let x0 = (self.bounds[n[0]][0] - r.org_near(0)) * r.inv(0);
        let y0 = (self.bounds[n[1]][1] - r.org_near(1)) * r.inv(1);
        let z0 = (self.bounds[n[2]][2] - r.org_near(2)) * r.inv(2);
        let x1 = (self.bounds[f[0]][0] - r.org_far(0)) * r.inv(0);
        let y1 = (self.bounds[f[1]][1] - r.org_far(1)) * r.inv(1);
        let z1 = (self.bounds[f[2]][2] - r.org_far(2)) * r.inv(2);
        let tnear = x0.max(y0).max(z0.max(Vec4::ZERO));
        let tfar = x1.min(y1).min(z1.min(Vec4::splat(t_max))) * ROBUST;
        (tnear.cmple(tfar).bitmask(), tnear)
    }
}

/// Up to four triangles: `v[vertex][axis]` with one lane per triangle (short leaves repeat their
/// last triangle), the global face ids and the bitmask of lanes from perforated meshes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
struct Tri4 {
    v: [[Vec4; 3]; 3],
    ids: [u32; 4],
    alpha: u32,
}

impl Tri4 {
    /// One triangle in all four lanes.
    fn splat(tri: [Vec3; 3], id: u32, perforated: bool) -> Tri4 {
        let v = tri.map(|p| [Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z)]);
        Tri4 {
            v,
            ids: [id; 4],
            alpha: if perforated { 0xF } else { 0 },
        }
    }

    /// The block of global faces `faces` (1 to 4 of them).
    fn from_faces(faces: &[u32], tris: &[[Vec3; 3]], perforated: &[bool]) -> Tri4 {
        let mut v = [[[0f32; 4]; 3]; 3];
        let (mut ids, mut alpha) = ([0u32; 4], 0u32);
        for lane in 0..4 {
            let id = faces[lane.min(faces.len() - 1)];
            ids[lane] = id;
            alpha |= u32::from(perforated[id as usize]) << lane;
            for (vert, p) in tris[id as usize].iter().enumerate() {
                for axis in 0..3 {
                    v[vert][axis][lane] = p[axis];
                }
            }
        }
        Tri4 {
            v: v.map(|vert| vert.map(Vec4::from_array)),
            ids,
            alpha,
        }
    }
}

/// The BVH over all triangles of one scene (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    nodes: Vec<Node4>,
    blocks: Vec<Tri4>,
    /// Parent node of each node (`EMPTY` for the root) and of each block.
    parents: Vec<u32>,
    block_parents: Vec<u32>,
    /// A node index, or `LEAF | block` for scenes of at most four triangles.
    root: u32,
    depth: u32,
    bounds: (Vec3, Vec3),
    num_faces: usize,
}

/// Where a method that traces only now and then gets the BVH of its scene: one built already, or
/// one kept with the scene and built on first use (by whichever method needs it first), so that
/// no call builds a BVH of its own.
#[derive(Clone, Copy)]
pub enum SceneBvh<'a> {
    Built(&'a Bvh),
    Cached(&'a OnceLock<Bvh>),
}

impl<'a> SceneBvh<'a> {
    /// The BVH of `scene`, built into the cache if it holds none yet. Errors: those of
    /// [`Bvh::build`], and a BVH built for another scene ([`Bvh::check_scene`]).
    pub fn get(self, scene: &Scene) -> Result<&'a Bvh> {
        let bvh = match self {
            SceneBvh::Built(bvh) => bvh,
            SceneBvh::Cached(cache) => match cache.get() {
                Some(bvh) => bvh,
                None => {
                    let built = Bvh::build(scene)?;
                    cache.get_or_init(|| built)
                }
            },
        };
        bvh.check_scene(scene)?;
        Ok(bvh)
    }
}

impl Bvh {
    /// Builds the BVH of `scene` by binned SAH. Deterministic whatever the rayon thread count.
    /// Refuses with [`Error::TooLarge`] before allocating when the build would exceed the
    /// memory limit.
    pub fn build(scene: &Scene) -> Result<Bvh> {
        build::build(scene)
    }

    /// Number of triangles (the scene this BVH was built for has as many faces).
    pub fn num_faces(&self) -> usize {
        self.num_faces
    }

    /// Refuses a scene other than the one this BVH was built for (by face count).
    pub fn check_scene(&self, scene: &Scene) -> Result<()> {
        if scene.num_faces() != self.num_faces {
            return Err(Error::invalid(
                "bvh",
                format!(
                    "built for {} faces, the scene has {}",
                    self.num_faces,
                    scene.num_faces()
                ),
            ));
        }
        Ok(())
    }

    /// Bounds `(min, max)` of all triangles.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Number of inner (4-wide) nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of leaves (four-triangle blocks).
    pub fn leaf_count(&self) -> usize {
        self.blocks.len()
    }

    /// Depth of the 4-wide tree (a single leaf has depth 1).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Bytes held by the nodes and blocks.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node4>()
            + self.blocks.len() * std::mem::size_of::<Tri4>()
    }

    /// Whether any opaque surface hits the open segment t in (0, `t_max`) of `origin + t dir`.
    /// `scene` must be the scene the BVH was built from. A zero `dir` or `t_max <= 0` (or NaN)
    /// hits nothing.
    pub fn occluded(&self, scene: &Scene, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.occluded_cached(scene, origin, dir, t_max, &mut ShadowCache::default())
    }

    /// [`Bvh::occluded`] that first tests the leaf remembered in `cache` and remembers the
    /// blocking leaf. Use one cache per receiver for its shadow rays.
    #[inline]
    pub fn occluded_cached(
        &self,
        scene: &Scene,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        cache: &mut ShadowCache,
    ) -> bool {
        let Some(r) = segment(origin, dir, t_max) else {
            return false;
        };
        if let Some(b) = self.blocks.get(cache.block as usize) {
            if Self::block_occludes(scene, b, &r, t_max) {
                return true;
            }
        }
        let search = |start: u32| {
            ANY_STACK.with(|s| match s.try_borrow_mut() {
                Ok(mut stack) => self.any_hit(scene, &r, t_max, start, None, &mut stack),
                // Only reachable if `is_opaque_at` re-entered the BVH on this thread.
                Err(_) => self.any_hit(scene, &r, t_max, start, None, &mut [0; STACK]),
            })
        };
        // The subtree first (unless it is the whole tree): a hit there is as good as any.
        let found = match cache.subtree {
            sub if sub == EMPTY || sub == self.root => None,
            sub => search(sub),
        };
        match found.or_else(|| search(self.root)) {
            Some(block) => {
                cache.block = block;
                cache.subtree = self.ancestor(block);
                true
            }
            None => false,
        }
    }

    /// [`Bvh::occluded`] counting only the faces for which `casts(face id)` holds (one traversal,
    /// no leaf cache): the oracle of culled casters, `ray_traced(caster_faces="backfacing")`.
    pub fn occluded_by_faces(
        &self,
        scene: &Scene,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        casts: &dyn Fn(u32) -> bool,
    ) -> bool {
        let Some(r) = segment(origin, dir, t_max) else {
            return false;
        };
        ANY_STACK
            .with(|s| match s.try_borrow_mut() {
                Ok(mut stack) => self.any_hit(scene, &r, t_max, self.root, Some(casts), &mut stack),
                Err(_) => self.any_hit(scene, &r, t_max, self.root, Some(casts), &mut [0; STACK]),
            })
            .is_some()
    }

    /// For each target, whether the open segment from `origin` to it is blocked: the shadow
    /// rays of one receiver (t in (0, 1) with `dir = target - origin`). With `front`, a plane
    /// they all lie in front of ([`FrontPlane`]: the receiver's tangent plane), the frustum pass
    /// leaves out the leaves wholly behind it. Clears and fills `out`.
    ///
    /// Same answers as [`Bvh::occluded`] per target, faster: one traversal with the frustum of
    /// all the segments first collects the few leaves they may hit (none for a fully lit
    /// receiver), and the rays are tested against those alone; with many candidate leaves the
    /// rays traverse one by one, sharing a [`ShadowCache`] (see `bvh/frustum.rs`).
    pub fn occluded_many(
        &self,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
        front: Option<FrontPlane>,
        out: &mut Vec<bool>,
    ) {
        let candidates = frustum::bounds(targets)
            .filter(|_| targets.len() >= Self::FRUSTUM_MIN_RAYS)
            .and_then(|bounds| self.frustum_candidates(origin, bounds, front));
        if let Some(cand) = candidates {
            self.occluded_by_candidates(scene, origin, targets, &cand, out);
            return;
        }
        let mut cache = ShadowCache::default();
        out.clear();
        out.extend(
            targets
                .iter()
                .map(|&y| self.occluded_cached(scene, origin, y - origin, 1.0, &mut cache)),
        );
    }

    /// The root node, or the only leaf with the tree's bounds.
    fn root_ref(&self) -> Root {
        if self.root & LEAF == 0 {
            return Root::Node(self.root);
        }
        let (lo, hi) = self.bounds;
        Root::Leaf(LeafRef {
            block: self.root & !LEAF,
            lo: lo.to_array(),
            hi: hi.to_array(),
        })
    }

    /// Every leaf with the box its parent stores for it.
    #[cfg(test)]
    fn leaf_refs(&self) -> Vec<LeafRef> {
        match self.root_ref() {
            Root::Leaf(leaf) => vec![leaf],
            Root::Node(_) => self
                .nodes
                .iter()
                .flat_map(|node| {
                    (0..4)
                        .filter(|&c| node.child[c] != EMPTY && node.child[c] & LEAF != 0)
                        .map(|c| node.leaf_ref(c))
                })
                .collect(),
        }
    }

    /// Whether no leaf may meet a segment from a point of the box `a` to a point of the box
    /// `b` (`[min, max]` each): then every such segment is unblocked. False also when the test
    /// does not apply (`b` not larger than `a`, or overlapping it).
    ///
    /// One traversal with the frustum through the corners of both boxes from an apex behind
    /// `a`, on the line from the center of `b` through that of `a`: it holds the boxes, so
    /// their convex hull and every such segment (see [`RayFrustum::around_boxes`]). The apex is
    /// placed (a quarter further than) where the cone tangent to both boxes' bounding spheres
    /// has its tip, which makes the frustum about as thin as the hull: the shaft of Haines and
    /// Wallace (1994) with a pyramid's planes.
    pub fn shaft_is_empty(&self, a: [Vec3; 2], b: [Vec3; 2]) -> bool {
        let (ca, cb) = ((a[0] + a[1]) * 0.5, (b[0] + b[1]) * 0.5);
        let (ra, rb) = ((a[1] - a[0]).length() * 0.5, (b[1] - b[0]).length() * 0.5);
        let axis = ca - cb;
        let len = axis.length();
        // `!(x > y)` also refuses NaN.
        if !(rb > ra && len > 0.0) {
            return false;
        }
        let behind = (1.25 * ra / (rb - ra)).max(1e-3) * len;
        let Some(f) = RayFrustum::around_boxes(ca + axis * (behind / len), &[a, b]) else {
            return false;
        };
        ANY_STACK.with(|s| match s.try_borrow_mut() {
            Ok(mut stack) => f.collect(&self.nodes, self.root_ref(), &mut stack, &mut []),
            Err(_) => f.collect(&self.nodes, self.root_ref(), &mut [0; STACK], &mut []),
        }) == Some(0)
    }

    /// Fewest shadow rays of one receiver for which the frustum pass pays off.
    pub const FRUSTUM_MIN_RAYS: usize = 4;

    /// The first half of the frustum pass: the leaves that the frustum of the segments from
    /// `origin` to any point of the box `bounds` meets, or `None` when it meets more than
    /// [`FrustumCandidates::MAX`] (or no pyramid with apex `origin` bounds the box). No
    /// candidate means that every such segment is unblocked. With `front`, a plane those
    /// segments all lie in front of ([`FrontPlane`]), the leaves wholly behind it are left out.
    pub fn frustum_candidates(
        &self,
        origin: Vec3,
        bounds: [Vec3; 2],
        front: Option<FrontPlane>,
    ) -> Option<FrustumCandidates> {
        let f = RayFrustum::around(origin, bounds)?.in_front_of(front);
        let mut cand = FrustumCandidates {
            leaves: [LeafRef::default(); MAX_CANDIDATES],
            len: 0,
        };
        let root = self.root_ref();
        cand.len = ANY_STACK.with(|s| match s.try_borrow_mut() {
            Ok(mut stack) => f.collect(&self.nodes, root, &mut stack, &mut cand.leaves),
            Err(_) => f.collect(&self.nodes, root, &mut [0; STACK], &mut cand.leaves),
        })?;
        Some(cand)
    }

    /// The second half of the frustum pass: for each target (within the box `cand` was found
    /// for), whether the open segment from `origin` to it is blocked, by the candidate leaves
    /// alone. Clears and fills `out`.
    pub fn occluded_by_candidates(
        &self,
        scene: &Scene,
        origin: Vec3,
        targets: &[Vec3],
        cand: &FrustumCandidates,
        out: &mut Vec<bool>,
    ) {
        out.clear();
        if cand.is_empty() {
            out.resize(targets.len(), false);
        } else {
            self.occluded_by_blocks(
                Isa::detect(),
                scene,
                origin,
                targets,
                &cand.leaves[..cand.len],
                out,
            );
        }
    }

    /// How many faces the open segment t in (0, `t_max`) of `origin + t dir` meets, among those
    /// for which `counts(face id)` holds (its depth complexity; no alpha test). A zero `dir` or
    /// `t_max <= 0` meets none.
    pub fn count_hits(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        counts: impl Fn(u32) -> bool,
    ) -> u32 {
        let Some(r) = segment(origin, dir, t_max) else {
            return 0;
        };
        let mut total = 0u32;
        self.leaves_along(&r, t_max, |b| {
            let hits = hit4(b, &r, t_max).mask;
            total += distinct_lanes(b)
                .filter(|&i| hits >> i & 1 != 0 && counts(b.ids[i]))
                .count() as u32;
            false
        });
        total
    }

    /// Whether `hit(face id)` holds for some face in a leaf whose box the segment t in
    /// (0, `t_max`) of `origin + t dir` meets: every face the segment may meet is offered, for
    /// a test of the caller's own (e.g. in f64). A zero `dir` or `t_max <= 0` offers none.
    pub fn any_face_along(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        hit: impl Fn(u32) -> bool,
    ) -> bool {
        let Some(r) = segment(origin, dir, t_max) else {
            return false;
        };
        self.leaves_along(&r, t_max, |b| distinct_lanes(b).any(|i| hit(b.ids[i])))
    }

    /// Visits every leaf whose box the ray meets in (0, `t_max`) until `visit` returns true;
    /// returns whether it did.
    fn leaves_along(&self, r: &RayData, t_max: f32, mut visit: impl FnMut(&Tri4) -> bool) -> bool {
        let mut stack = [0u32; STACK];
        let (mut sp, mut cur) = (0usize, self.root);
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let (mut mask, _) = node.hit(r, t_max);
                while mask != 0 {
                    // At most 4 pushes per level and 3 * depth + 1 <= STACK (see `build`).
                    stack[sp] = node.child[mask.trailing_zeros() as usize];
                    sp += 1;
                    mask &= mask - 1;
                }
            } else if visit(&self.blocks[(cur & !LEAF) as usize]) {
                return true;
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }

    /// The closest opaque hit in the open interval (0, `t_max`), alpha-testing perforated faces.
    pub fn intersect(&self, scene: &Scene, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        if t_max.is_nan() || t_max <= 0.0 {
            return None;
        }
        let r = RayData::new(origin, dir)?;
        CLOSEST_STACK.with(|s| match s.try_borrow_mut() {
            Ok(mut stack) => self.closest_hit(scene, &r, t_max, &mut stack),
            Err(_) => self.closest_hit(scene, &r, t_max, &mut [(0, 0.0); STACK]),
        })
    }

    /// The node [`SUBTREE_LEVELS`] above block `b` (`EMPTY` when that is above the root).
    fn ancestor(&self, b: u32) -> u32 {
        let mut n = self.block_parents.get(b as usize).copied().unwrap_or(EMPTY);
        for _ in 1..SUBTREE_LEVELS {
            n = self.parents.get(n as usize).copied().unwrap_or(EMPTY);
        }
        n
    }

    /// Any-hit traversal of the subtree `start` (a child reference); returns the block that
    /// holds an opaque hit, among the faces `casts` keeps (all without it).
    fn any_hit(
        &self,
        scene: &Scene,
        r: &RayData,
        t_max: f32,
        start: u32,
        casts: Option<&dyn Fn(u32) -> bool>,
        stack: &mut [u32; STACK],
    ) -> Option<u32> {
        self.any_hit_inline(scene, r, t_max, start, casts, stack)
    }

    /// [`Bvh::any_hit`] inlined into its caller: the packet traversal hands its sparse lanes
    /// to it (`bvh/packet.rs`), compiled there for each instruction set and without a call's
    /// set-up per lane.
    ///
    /// The entry and exit planes are picked by the direction's signs once per ray
    /// (`RayData::near`). On the bunny's 128x128 receivers (see `SINGLE_RAY_LANES` in
    /// `bvh/packet.rs` for how it was timed) neither prefetching the children pushed on the
    /// stack (0.995x the CPU time) nor pushing every child without a branch per child (1.01x)
    /// paid.
    #[inline(always)]
    fn any_hit_inline<R: Ray>(
        &self,
        scene: &Scene,
        r: &R,
        t_max: f32,
        start: u32,
        casts: Option<&dyn Fn(u32) -> bool>,
        stack: &mut [u32; STACK],
    ) -> Option<u32> {
        let mut sp = 0usize;
        let mut cur = start;
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let (mut mask, _) = node.hit(r, t_max);
                if mask != 0 {
                    cur = node.child[mask.trailing_zeros() as usize];
                    mask &= mask - 1;
                    while mask != 0 {
                        // At most 3 pushes per level and 3 * depth + 1 <= STACK (see `build`).
                        stack[sp] = node.child[mask.trailing_zeros() as usize];
                        sp += 1;
                        mask &= mask - 1;
                    }
                    continue;
                }
            } else {
                let b = cur & !LEAF;
                let block = &self.blocks[b as usize];
                let mut lanes = hit4(block, r, t_max);
                if let Some(casts) = casts {
                    lanes.mask &= kept_lanes(block, casts);
                }
                if Self::lanes_occlude(scene, block, &lanes) {
                    return Some(b);
                }
            }
            if sp == 0 {
                return None;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }

    /// Closest-hit traversal, nearest child first, skipping subtrees beyond the best hit.
    fn closest_hit(
        &self,
        scene: &Scene,
        r: &RayData,
        t_max: f32,
        stack: &mut [(u32, f32); STACK],
    ) -> Option<Hit> {
        let mut sp = 0usize;
        let mut cur = self.root;
        let (mut t_max, mut best) = (t_max, None);
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, tnear) = node.hit(r, t_max);
                if mask != 0 {
                    cur = push_far_children(node, mask, tnear, stack, &mut sp);
                    continue;
                }
            } else if let Some(h) =
                block_closest(scene, &self.blocks[(cur & !LEAF) as usize], r, t_max)
            {
                t_max = h.t;
                best = Some(h);
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, d) = stack[sp];
                if d <= t_max * ROBUST {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Whether block `b` holds an opaque hit: opaque-mesh lanes answer at once, perforated lanes
    /// go through the texture.
    #[inline(always)]
    fn block_occludes<R: Ray>(scene: &Scene, b: &Tri4, r: &R, t_max: f32) -> bool {
        Self::lanes_occlude(scene, b, &hit4(b, r, t_max))
    }

    /// Whether the hit `lanes` of block `b` hold an opaque hit.
    #[inline(always)]
    fn lanes_occlude(scene: &Scene, b: &Tri4, lanes: &Lanes) -> bool {
        if lanes.mask & !b.alpha != 0 {
            return true;
        }
        lanes.mask != 0 && alpha_occludes(scene, b, lanes)
    }
}

/// The ray of the open segment t in (0, `t_max`) of `origin + t dir`; `None` when it is empty
/// (`t_max <= 0` or NaN, a zero `dir`) or not finite. Inlined, so that the ray is built where
/// it is used rather than returned by copy (`RayData` is about 300 bytes, copied once per ray).
#[inline(always)]
fn segment(origin: Vec3, dir: Vec3, t_max: f32) -> Option<RayData> {
    if t_max.is_nan() || t_max <= 0.0 {
        return None;
    }
    RayData::new(origin, dir)
}

/// The lanes of block `b` that hold distinct faces: short leaves repeat their last face.
fn distinct_lanes(b: &Tri4) -> impl Iterator<Item = usize> + '_ {
    (0..4).filter(|&i| i == 0 || b.ids[i] != b.ids[i - 1])
}

/// The lanes of block `b` whose faces `casts` keeps.
fn kept_lanes(b: &Tri4, casts: &dyn Fn(u32) -> bool) -> u32 {
    (0..4).fold(0, |m, i| m | u32::from(casts(b.ids[i])) << i)
}

/// Whether any hit lane of a perforated block is opaque at its hit point.
#[cold]
#[inline(never)]
fn alpha_occludes(scene: &Scene, b: &Tri4, lanes: &Lanes) -> bool {
    (0..4)
        .filter(|&i| lanes.mask >> i & 1 != 0)
        .any(|i| lane_opaque(scene, b, lanes, i))
}

/// Whether lane `i` (hit) is opaque at its hit point.
#[inline]
fn lane_opaque(scene: &Scene, b: &Tri4, lanes: &Lanes, i: usize) -> bool {
    if b.alpha >> i & 1 == 0 {
        return true;
    }
    let (_, b1, b2) = lanes.get(i);
    scene.is_opaque_at(b.ids[i], b1, b2)
}

/// The closest opaque hit of block `b` (ties go to the lower lane).
#[inline]
fn block_closest(scene: &Scene, b: &Tri4, r: &RayData, t_max: f32) -> Option<Hit> {
    let lanes = hit4(b, r, t_max);
    let mut mask = lanes.mask;
    if mask == 0 {
        return None;
    }
    let t = lanes.distances().to_array();
    while mask != 0 {
        let lane = (0..4).filter(|&i| mask >> i & 1 != 0).fold(4, |best, i| {
            if best == 4 || t[i] < t[best] {
                i
            } else {
                best
            }
        });
        if lane_opaque(scene, b, &lanes, lane) {
            let (t, b1, b2) = lanes.get(lane);
            return Some(Hit {
                t,
                face: b.ids[lane],
                b1,
                b2,
            });
        }
        mask &= !(1 << lane);
    }
    None
}

/// Pushes the hit children of `node` farthest first with their entry distances and returns the
/// nearest, to be visited next.
#[inline(always)]
fn push_far_children(
    node: &Node4,
    mask: u32,
    tnear: Vec4,
    stack: &mut [(u32, f32); STACK],
    sp: &mut usize,
) -> u32 {
    if mask & (mask - 1) == 0 {
        return node.child[mask.trailing_zeros() as usize];
    }
    let d = tnear.to_array();
    let mut items = [(0f32, 0u32); 4];
    let mut n = 0;
    for lane in (0..4).filter(|&i| mask >> i & 1 != 0) {
        // Insertion into descending order of distance (stable: equal distances keep lane order).
        let mut j = n;
        while j > 0 && items[j - 1].0 < d[lane] {
            items[j] = items[j - 1];
            j -= 1;
        }
        items[j] = (d[lane], node.child[lane]);
        n += 1;
    }
    for &(dist, child) in &items[..n - 1] {
        // At most 3 pushes per level and 3 * depth + 1 <= STACK (see `build`).
        stack[*sp] = (child, dist);
        *sp += 1;
    }
    items[n - 1].1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::Mesh;
    use crate::light::sampling::Rng;

    /// A scene of `n` unit triangles side by side.
    fn strip(n: u32) -> Result<Scene> {
        let vertices = (0..n)
            .flat_map(|i| {
                let x = i as f32;
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 1.0, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                ]
            })
            .collect();
        let faces = (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        Scene::new(vec![Mesh::new(vertices, faces, None, None, false)?])
    }

    #[test]
    fn a_cached_bvh_is_built_once_and_kept_for_its_scene_only() -> Result<()> {
        let (scene, other) = (strip(5)?, strip(7)?);
        let cache = OnceLock::new();
        let first = SceneBvh::Cached(&cache).get(&scene)?;
        assert_eq!(first.num_faces(), 5);
        assert!(std::ptr::eq(first, SceneBvh::Cached(&cache).get(&scene)?));
        assert!(SceneBvh::Cached(&cache).get(&other).is_err());
        assert!(SceneBvh::Built(first).get(&other).is_err());
        assert!(std::ptr::eq(first, SceneBvh::Built(first).get(&scene)?));
        Ok(())
    }

    /// The shaft test is conservative: no segment between points of two boxes whose shaft is
    /// empty is blocked (random points and corners, against single rays), and it finds shafts
    /// both empty and not, the latter with blocked segments.
    #[test]
    fn empty_shafts_hold_no_blocked_segment() {
        let mut rng = Rng::new(17);
        let mut point = |lo: Vec3, size: Vec3| {
            lo + size * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
        };
        // Small random triangles over [0, 4]^3 and a ground quad at y = -0.5.
        let (mut positions, mut faces) = (Vec::new(), Vec::new());
        for t in 0..120u32 {
            let a = point(Vec3::ZERO, Vec3::splat(4.0));
            positions.extend([
                a,
                a + point(Vec3::splat(-0.3), Vec3::splat(0.6)),
                a + point(Vec3::splat(-0.3), Vec3::splat(0.6)),
            ]);
            faces.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let ground = [(-1.0, -1.0), (5.0, -1.0), (5.0, 5.0), (-1.0, 5.0)]
            .map(|(x, z)| Vec3::new(x, -0.5, z));
        let meshes = vec![
            Mesh::new(positions, faces, None, None, false).unwrap(),
            Mesh::new(
                ground.to_vec(),
                vec![[0, 1, 2], [0, 2, 3]],
                None,
                None,
                false,
            )
            .unwrap(),
        ];
        let scene = Scene::new(meshes).unwrap();
        let bvh = Bvh::build(&scene).unwrap();
        let (mut empty, mut blocked_in_full) = (0, 0);
        for _ in 0..3000 {
            // A tile of origins just above the ground or among the triangles, a light above.
            let a0 = point(Vec3::new(-0.5, -0.49, -0.5), Vec3::new(5.0, 4.0, 5.0));
            let a = [a0, a0 + point(Vec3::ZERO, Vec3::new(0.15, 0.02, 0.15))];
            let b0 = point(Vec3::new(-1.0, 6.0, -1.0), Vec3::new(6.0, 1.0, 6.0));
            let b = [b0, b0 + Vec3::new(0.8, 0.05, 0.8)];
            let is_empty = bvh.shaft_is_empty(a, b);
            let corner = |[lo, hi]: [Vec3; 2], c: usize| {
                Vec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), hi, lo)
            };
            let mut blocked = 0;
            for s in 0..64 {
                let (p, q) = if s < 8 {
                    (corner(a, s), corner(b, 7 - s))
                } else {
                    (point(a[0], a[1] - a[0]), point(b[0], b[1] - b[0]))
                };
                blocked += usize::from(bvh.occluded(&scene, p, q - p, 1.0));
            }
            if is_empty {
                assert_eq!(blocked, 0, "empty shaft {a:?} -> {b:?}");
                empty += 1;
            } else {
                blocked_in_full += blocked;
            }
        }
        assert!(
            empty > 300 && blocked_in_full > 10000,
            "empty {empty}, blocked {blocked_in_full}"
        );
        // Boxes the test does not apply to: the same box, and a larger box of origins.
        let box_a = [Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.2, 0.1, 1.2)];
        assert!(!bvh.shaft_is_empty(box_a, box_a));
        assert!(!bvh.shaft_is_empty(
            [Vec3::new(-1.0, -0.4, -1.0), Vec3::new(5.0, -0.3, 5.0)],
            [Vec3::splat(9.0), Vec3::splat(9.1)]
        ));
    }

    /// A receiver's tangent plane ([`FrontPlane`]) leaves leaves out of its frustum pass, never
    /// one that holds a hit: receivers at the face centres of a tessellated sphere (a convex
    /// mesh: every other face lies behind a face's plane), under a small quad that shadows some
    /// of them, each traced to the samples in front of it. Every receiver's candidates with
    /// the plane are among those without, and give each ray the answer of its single ray, as
    /// does [`Bvh::occluded_many`] given the plane; some receivers lose candidates, and some
    /// rays are blocked.
    #[test]
    fn tangent_planes_cut_candidates_but_no_hit() -> Result<()> {
        let quad =
            [(0.0, -0.2), (0.3, -0.2), (0.3, 0.1), (0.0, 0.1)].map(|(x, z)| Vec3::new(x, 2.0, z));
        let scene = Scene::new(vec![
            Mesh::uv_sphere(Vec3::new(0.2, 1.0, -0.1), 0.5, 16, 8, true)?,
            Mesh::new(quad.to_vec(), vec![[0, 2, 1], [0, 3, 2]], None, None, false)?,
        ])?;
        let bvh = Bvh::build(&scene)?;
        let mut rng = Rng::new(3);
        let samples: Vec<Vec3> = (0..32)
            .map(|_| {
                Vec3::new(
                    -0.3 + 0.8 * rng.next_f32(),
                    3.0,
                    -0.4 + 0.8 * rng.next_f32(),
                )
            })
            .collect();
        let bounds = frustum::bounds(&samples).ok_or(Error::invalid("samples", "none"))?;
        let (mut cut, mut receivers, mut blocked, mut traced) = (0, 0, 0, 0);
        for (_, [a, b, c]) in scene.triangles().take(scene.meshes[0].faces.len()) {
            let point = (a + b + c) / 3.0;
            let normal = (b - a).cross(c - a).normalize();
            // Outwards, away from the centre.
            let normal = normal * normal.dot(point - Vec3::new(0.2, 1.0, -0.1)).signum();
            let origin = point + normal * 1e-4;
            let targets: Vec<Vec3> = samples
                .iter()
                .copied()
                .filter(|&y| (y - point).dot(normal) > 0.0)
                .collect();
            if targets.is_empty() {
                continue;
            }
            let plane = FrontPlane { point, normal };
            let (Some(all), Some(front)) = (
                bvh.frustum_candidates(origin, bounds, None),
                bvh.frustum_candidates(origin, bounds, Some(plane)),
            ) else {
                let why = format!("more than {MAX_CANDIDATES} candidates at {point}");
                return Err(Error::invalid("receiver", why));
            };
            let blocks = |c: &FrustumCandidates| -> Vec<u32> {
                c.leaves[..c.len].iter().map(|l| l.block).collect()
            };
            assert!(blocks(&front).iter().all(|b| blocks(&all).contains(b)));
            cut += usize::from(front.len < all.len);
            receivers += 1;
            let (mut got, mut many) = (Vec::new(), Vec::new());
            bvh.occluded_by_candidates(&scene, origin, &targets, &front, &mut got);
            bvh.occluded_many(&scene, origin, &targets, Some(plane), &mut many);
            for ((&y, &g), &m) in targets.iter().zip(&got).zip(&many) {
                let single = bvh.occluded(&scene, origin, y - origin, 1.0);
                assert_eq!((g, m), (single, single), "{point} -> {y}");
                blocked += usize::from(g);
                traced += 1;
            }
        }
        assert!(
            cut >= 10 && blocked > 100 && 2 * blocked < traced,
            "{cut} of {receivers} receivers cut, {blocked} of {traced} rays blocked"
        );
        Ok(())
    }

    /// Fuzzing regression: a NaN or infinite origin or direction (a receiver or sample near
    /// f32::MAX overflowing `p + epsilon n` or `y - p`) made the slab test accept the empty child
    /// slots of a node, and traversal indexed past the blocks. Such segments now hit nothing.
    #[test]
    fn non_finite_rays_hit_nothing() {
        // Twelve triangles in a row: the 4-wide root has empty child slots.
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for i in 0..12u32 {
            let x = i as f32 * 2.0;
            positions.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]);
            faces.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let scene =
            Scene::new(vec![Mesh::new(positions, faces, None, None, false).unwrap()]).unwrap();
        let bvh = Bvh::build(&scene).unwrap();
        let big = Vec3::new(f32::MAX, 0.5, 1.0);
        let inside = Vec3::new(0.2, 0.2, 1.0);
        let rays = [
            (Vec3::NAN, Vec3::new(-0.125, 0.0, 1e-30)),
            (big + big, -Vec3::Z),
            (inside, Vec3::new(f32::NEG_INFINITY, 0.0, -1.0)),
            (inside, Vec3::new(f32::NAN, 0.0, -1.0)),
        ];
        for (o, d) in rays {
            assert_eq!(bvh.intersect(&scene, o, d, 2.0), None, "{o} {d}");
            assert!(!bvh.occluded(&scene, o, d, 2.0), "{o} {d}");
            assert_eq!(bvh.count_hits(o, d, 2.0, |_| true), 0, "{o} {d}");
            let mut out = Vec::new();
            bvh.occluded_many(&scene, o, &[o + d; 5], None, &mut out);
            assert_eq!(out, [false; 5], "{o} {d}");
        }
        // Fuzzing regression: a zero direction component at an origin coordinate of ±f32::MAX
        // nudged the slab origin to ±inf, and `-inf - -inf` (NaN) let empty slots pass.
        for o in [
            Vec3::new(-10.0, f32::MIN, f32::MIN),
            Vec3::new(-10.0, f32::MAX, f32::MAX),
        ] {
            assert_eq!(
                bvh.intersect(&scene, o, Vec3::X, f32::INFINITY),
                None,
                "{o}"
            );
            assert!(!bvh.occluded(&scene, o, Vec3::X, f32::INFINITY), "{o}");
        }
        // A finite ray through the first triangle still hits it.
        assert_eq!(
            bvh.intersect(&scene, inside, -Vec3::Z, 2.0).map(|h| h.face),
            Some(0)
        );
    }

    /// The box `lo..hi` as a mesh of 12 triangles (corner `i` takes `hi` on the axes of its set
    /// bits: bit 0 for x, 1 for y, 2 for z).
    fn cuboid(lo: Vec3, hi: Vec3) -> Result<Mesh> {
        let pick = |i: u32, bit: u32, a: usize| if i >> bit & 1 != 0 { hi[a] } else { lo[a] };
        let corners = (0..8)
            .map(|i| Vec3::new(pick(i, 0, 0), pick(i, 1, 1), pick(i, 2, 2)))
            .collect();
        let faces = vec![
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
        ];
        Mesh::new(corners, faces, None, None, false)
    }

    /// A room around a small box, as in `bench/alias_free.py`'s lamp room: every leaf holding
    /// triangles of the room's walls is flat, one wall's. Four triangles of two walls in one
    /// leaf (what the build made before it weighed splitting such leaves) give that leaf the
    /// room's box, entered by every ray in the room.
    #[test]
    fn the_walls_of_a_room_get_leaves_of_their_own() -> Result<()> {
        let room = cuboid(Vec3::splat(-2.0), Vec3::splat(2.0))?;
        let inside = cuboid(Vec3::new(0.9, -0.3, -0.4), Vec3::new(1.3, 0.5, 0.4))?;
        let bvh = Bvh::build(&Scene::new(vec![room, inside])?)?;
        for leaf in bvh.leaf_refs() {
            let faces = bvh.blocks[leaf.block as usize].ids;
            if faces.iter().any(|&f| f < 12) {
                let extent = Vec3::from(leaf.hi) - Vec3::from(leaf.lo);
                assert_eq!(extent.min_element(), 0.0, "faces {faces:?}, box {leaf:?}");
            }
        }
        Ok(())
    }
}
