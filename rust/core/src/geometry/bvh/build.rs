//! Binned-SAH construction of a binary BVH, then its collapse into the 4-wide layout the
//! traversal uses.
//!
//! - Binning: 16 bins per axis over the centroid bounds; the split plane minimizing the surface
//!   area heuristic `area(L) * n(L) + area(R) * n(R)` (n: triangles) is taken.
//! - Leaves: a node of at most four triangles is one leaf (one block, a single SIMD test whatever
//!   its occupancy) unless two leaves cost less ([`split_small`]): their two areas plus
//!   [`SPLIT_COST`] times the node's, against the node's area for one leaf. So the walls of a room
//!   get leaves of their own, flat boxes that few rays enter, where four triangles of two walls
//!   would share a box as large as the room that every ray inside it tests. Counting blocks
//!   (`ceil(n / 4)`) instead of triangles in the binned cost had the same effect one level up:
//!   it filled blocks with triangles far apart. On the lamp room of `bench/alias_free.py` (72
//!   triangles, 256x256 receivers x 64 samples, one thread, same bits) `ray_traced` took 130-160
//!   ms with blocks counted and no leaf split, 67-115 ms with the leaf split alone and 32-35 ms
//!   with both changes; on the bunny and the other built-in scenes (1-2 alternating runs each)
//!   the time stayed within the noise or fell.
//! - Depth bound: below depth [`SAH_DEPTH_LIMIT`] the split is the object median instead, which
//!   halves the node, and a leaf's split adds at most three levels, so the binary tree is at most
//!   `48 + 32 + 3` levels deep and the traversal stacks of [`super::STACK`] entries cannot
//!   overflow (checked once in [`build`]).
//! - Determinism: subtrees above [`PAR_MIN`] triangles are built with `rayon::join` into their own
//!   node vectors and concatenated in (root, left, right) order, and every partition is an
//!   in-place sequential pass over a disjoint slice, so the result is the same for any thread count.
//! - Collapse: each 4-wide node takes its binary children and repeatedly opens the inner child
//!   with the largest surface area until it has four. Nodes and blocks are laid out depth-first.

use super::{Bvh, Node4, Tri4, EMPTY, LEAF, STACK};
use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::limits;
use glam::{Vec3, Vec4};
use rayon::prelude::*;

/// Bins per axis. The bunny's 128x128 shadow rays of bench/shadow_rays.py (one thread, trees of
/// each count in interleaved rounds of one process, same bits) took 0.98-1.00x the CPU time
/// with 8, 64 or 128 bins, and 1.18x with 32.
const BINS: usize = 16;
const LEAF_SIZE: usize = 4;
/// Depth after which splits are object medians (bounds the tree depth).
const SAH_DEPTH_LIMIT: u32 = 48;
/// Subtrees of at least this many triangles are built in parallel.
const PAR_MIN: usize = 8192;
/// Generous upper bound of the working memory per triangle during the build, in bytes.
const BYTES_PER_TRIANGLE: u64 = 480;

#[derive(Debug, Clone, Copy)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    fn union(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    /// Half the surface area (the SAH only compares ratios); 0 for an empty box.
    fn half_area(self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A triangle's bounds and centroid.
#[derive(Debug, Clone, Copy)]
struct Prim {
    b: Aabb,
    c: Vec3,
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Triangles `idx[start .. start + count]`.
    Leaf { start: u32, count: u32 },
    /// Child indices within the same node vector.
    Inner { left: u32, right: u32 },
}

#[derive(Debug, Clone, Copy)]
struct Node2 {
    b: Aabb,
    kind: Kind,
}

/// Builds the BVH of all triangles of `scene` (see the module doc).
pub(super) fn build(scene: &Scene) -> Result<Bvh> {
    let n = scene.num_faces();
    limits::check_memory("BVH", limits::bytes(&[n as u64, BYTES_PER_TRIANGLE]))?;
    if n as u64 >= u64::from(LEAF) {
        // Leaf references keep 31 bits for the block index (blocks <= faces); the memory check
        // refuses such sizes far earlier.
        return Err(Error::TooLarge {
            what: "BVH".into(),
            bytes: n as u64 * BYTES_PER_TRIANGLE,
            limit: limits::memory_limit(),
        });
    }
    let tris: Vec<[Vec3; 3]> = scene.triangles().map(|(_, t)| t).collect();
    let alpha = perforated_faces(scene);
    let prims: Vec<Prim> = tris
        .par_iter()
        .map(|t| {
            let b = Aabb::EMPTY.grow(t[0]).grow(t[1]).grow(t[2]);
            Prim {
                b,
                c: (b.lo + b.hi) * 0.5,
            }
        })
        .collect();
    let mut idx: Vec<u32> = (0..n as u32).collect();
    let nodes2 = build_subtree(&prims, &mut idx, 0, 0);
    drop(prims);
    let mut out = Collapse {
        n2: &nodes2,
        idx: &idx,
        tris: &tris,
        alpha: &alpha,
        nodes: Vec::new(),
        blocks: Vec::new(),
        parents: Vec::new(),
        block_parents: Vec::new(),
        depth: 0,
    };
    let root = out.node(0, 1);
    if 3 * out.depth as usize + 1 > STACK {
        // Unreachable by the depth bound of the module doc; refuse rather than risk the stacks.
        return Err(Error::invalid(
            "meshes",
            format!("BVH depth {} exceeds the traversal stack", out.depth),
        ));
    }
    let b = nodes2[0].b;
    Ok(Bvh {
        nodes: out.nodes,
        blocks: out.blocks,
        parents: out.parents,
        block_parents: out.block_parents,
        root,
        depth: out.depth,
        bounds: (b.lo, b.hi),
        num_faces: n,
    })
}

/// Per global face, whether it belongs to a perforated mesh (precomputed so that opaque meshes
/// never look at textures).
fn perforated_faces(scene: &Scene) -> Vec<bool> {
    scene
        .meshes
        .iter()
        .flat_map(|m| std::iter::repeat_n(m.is_perforated(), m.faces.len()))
        .collect()
}

fn bounds_of(prims: &[Prim], idx: &[u32]) -> (Aabb, Aabb) {
    idx.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), &i| {
        let p = &prims[i as usize];
        (b.union(p.b), c.grow(p.c))
    })
}

/// Builds the subtree over `idx` (whose first entry sits at `start` of the full index array);
/// node 0 of the result is its root.
fn build_subtree(prims: &[Prim], idx: &mut [u32], start: u32, depth: u32) -> Vec<Node2> {
    if idx.len() < PAR_MIN {
        let mut out = Vec::with_capacity(2 * idx.len().div_ceil(LEAF_SIZE));
        build_serial(prims, idx, start, depth, &mut out);
        return out;
    }
    let (b, cb) = bounds_of(prims, idx);
    let mid = split(prims, idx, cb, depth);
    let (li, ri) = idx.split_at_mut(mid);
    let (l, r) = rayon::join(
        || build_subtree(prims, li, start, depth + 1),
        || build_subtree(prims, ri, start + mid as u32, depth + 1),
    );
    let mut out = Vec::with_capacity(1 + l.len() + r.len());
    out.push(Node2 {
        b,
        kind: Kind::Inner {
            left: 1,
            right: 1 + l.len() as u32,
        },
    });
    append_shifted(&mut out, &l);
    append_shifted(&mut out, &r);
    out
}

/// Appends `sub` to `out`, shifting its internal child indices to their new positions.
fn append_shifted(out: &mut Vec<Node2>, sub: &[Node2]) {
    let shift = out.len() as u32;
    out.extend(sub.iter().map(|n| match n.kind {
        Kind::Inner { left, right } => Node2 {
            b: n.b,
            kind: Kind::Inner {
                left: left + shift,
                right: right + shift,
            },
        },
        Kind::Leaf { .. } => *n,
    }));
}

/// Sequential build appending to `out`; returns the index of the subtree's root.
fn build_serial(
    prims: &[Prim],
    idx: &mut [u32],
    start: u32,
    depth: u32,
    out: &mut Vec<Node2>,
) -> u32 {
    let (b, cb) = bounds_of(prims, idx);
    let me = out.len() as u32;
    let mid = if idx.len() > LEAF_SIZE {
        Some(split(prims, idx, cb, depth))
    } else {
        split_small(prims, idx, b)
    };
    let Some(mid) = mid else {
        out.push(Node2 {
            b,
            kind: Kind::Leaf {
                start,
                count: idx.len() as u32,
            },
        });
        return me;
    };
    out.push(Node2 {
        b,
        kind: Kind::Leaf { start, count: 0 },
    });
    let (li, ri) = idx.split_at_mut(mid);
    let left = build_serial(prims, li, start, depth + 1, out);
    let right = build_serial(prims, ri, start + mid as u32, depth + 1, out);
    out[me as usize].kind = Kind::Inner { left, right };
    me
}

/// Partitions `idx` (more than [`LEAF_SIZE`] triangles) and returns the size of the left part,
/// always in `1 .. idx.len()`.
fn split(prims: &[Prim], idx: &mut [u32], cb: Aabb, depth: u32) -> usize {
    if depth < SAH_DEPTH_LIMIT {
        if let Some((axis, plane, scale)) = best_sah_split(prims, idx, cb) {
            let lo = cb.lo[axis];
            let mid = partition(idx, |i| {
                bin_of(prims[i as usize].c[axis], lo, scale) < plane
            });
            if mid > 0 && mid < idx.len() {
                return mid;
            }
        }
    }
    median_split(prims, idx, cb)
}

/// The bin of centroid coordinate `c`.
#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Stable-order-independent, deterministic in-place partition; returns the count of `pred` items.
fn partition(idx: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut first = 0;
    for k in 0..idx.len() {
        if pred(idx[k]) {
            idx.swap(first, k);
            first += 1;
        }
    }
    first
}

/// The best `(axis, plane, scale)` of binned SAH (left = bins `< plane`), `None` when the
/// centroids coincide.
fn best_sah_split(prims: &[Prim], idx: &[u32], cb: Aabb) -> Option<(usize, usize, f32)> {
    let ext = cb.hi - cb.lo;
    let mut best: Option<(f32, usize, usize, f32)> = None;
    for axis in 0..3 {
        // Extents of finite centroids are never NaN.
        if ext[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext[axis];
        let mut count = [0u32; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for &i in idx {
            let p = &prims[i as usize];
            let k = bin_of(p.c[axis], cb.lo[axis], scale);
            count[k] += 1;
            boxes[k] = boxes[k].union(p.b);
        }
        // Suffix costs, then a left-to-right sweep.
        let mut right = [(0u32, 0f32); BINS];
        let (mut rb, mut rn) = (Aabb::EMPTY, 0u32);
        for k in (1..BINS).rev() {
            rb = rb.union(boxes[k]);
            rn += count[k];
            right[k] = (rn, rb.half_area() * rn as f32);
        }
        let (mut lb, mut ln) = (Aabb::EMPTY, 0u32);
        for plane in 1..BINS {
            lb = lb.union(boxes[plane - 1]);
            ln += count[plane - 1];
            let (rn, rcost) = right[plane];
            let cost = lb.half_area() * ln as f32 + rcost;
            // Both sides non-empty; strict `<` keeps the first of equal candidates.
            if ln > 0 && rn > 0 && best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, plane, scale));
            }
        }
    }
    best.map(|(_, axis, plane, scale)| (axis, plane, scale))
}

/// The cost of one more split, in units of a block test over the node's area (see
/// [`split_small`]); small, since the collapse into the 4-wide tree absorbs most binary nodes.
/// Below 1/3 so that a cubic room's opposite walls part (their two flat boxes have 2/3 of the
/// room's area): 0.5 kept them two to a leaf (the lamp room of the module doc took 115-165 ms),
/// 0.1 took the same time as 0.3 there and on the bunny, within the noise.
const SPLIT_COST: f32 = 0.3;

/// Whether the node `idx` of at most [`LEAF_SIZE`] triangles (bounds `b`) costs less as two
/// leaves than as one (see the module doc): over every split of its triangles in two, the
/// cheapest `area(L) + area(R)` (the first on ties) against `(1 - SPLIT_COST) * area(b)`. If so,
/// reorders `idx` to put the left part first (each part in its order) and returns its size.
fn split_small(prims: &[Prim], idx: &mut [u32], b: Aabb) -> Option<usize> {
    let n = idx.len();
    let box_of = |mask: u32, inside: bool| {
        (0..n)
            .filter(|&k| (mask >> k & 1 != 0) == inside)
            .fold(Aabb::EMPTY, |a, k| a.union(prims[idx[k] as usize].b))
    };
    // The splits with the first triangle on the left, each once.
    let (cost, mask) = (1..(1u32 << n) - 1)
        .filter(|mask| mask & 1 != 0)
        .map(|mask| {
            (
                box_of(mask, true).half_area() + box_of(mask, false).half_area(),
                mask,
            )
        })
        .fold(None::<(f32, u32)>, |best, (cost, mask)| match best {
            Some((c, _)) if c <= cost => best,
            _ => Some((cost, mask)),
        })?;
    if cost >= (1.0 - SPLIT_COST) * b.half_area() {
        return None;
    }
    let mut order = [0u32; LEAF_SIZE];
    let left = (0..n).filter(|&k| mask >> k & 1 != 0);
    let right = (0..n).filter(|&k| mask >> k & 1 == 0);
    for (slot, k) in order.iter_mut().zip(left.chain(right)) {
        *slot = idx[k];
    }
    idx.copy_from_slice(&order[..n]);
    Some(mask.count_ones() as usize)
}

/// Object-median split along the widest centroid axis (halves the node: bounds the depth).
fn median_split(prims: &[Prim], idx: &mut [u32], cb: Aabb) -> usize {
    let mid = idx.len() / 2;
    let ext = cb.hi - cb.lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    if ext[axis] > 0.0 {
        // A strict total order (coordinate, then index) makes the selection deterministic.
        idx.select_nth_unstable_by(mid, |&a, &b| {
            let (ca, cb) = (prims[a as usize].c[axis], prims[b as usize].c[axis]);
            ca.total_cmp(&cb).then(a.cmp(&b))
        });
    }
    mid
}

/// State of the BVH2 -> BVH4 collapse.
struct Collapse<'a> {
    n2: &'a [Node2],
    idx: &'a [u32],
    tris: &'a [[Vec3; 3]],
    alpha: &'a [bool],
    nodes: Vec<Node4>,
    blocks: Vec<Tri4>,
    /// Parent node of each node (`EMPTY` for the root) and of each block.
    parents: Vec<u32>,
    block_parents: Vec<u32>,
    depth: u32,
}

impl Collapse<'_> {
    /// Emits the subtree of binary node `i` (at 4-wide depth `depth`) and returns its child reference.
    fn node(&mut self, i: usize, depth: u32) -> u32 {
        self.depth = self.depth.max(depth);
        let (left, right) = match self.n2[i].kind {
            Kind::Leaf { start, count } => return self.leaf(start as usize, count as usize),
            Kind::Inner { left, right } => (left as usize, right as usize),
        };
        let mut kids = vec![left, right];
        while kids.len() < 4 {
            // Open the inner child with the largest area (first on ties).
            let pick = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| matches!(self.n2[k].kind, Kind::Inner { .. }))
                .fold(None::<(usize, f32)>, |acc, (pos, &k)| {
                    let a = self.n2[k].b.half_area();
                    if acc.is_none_or(|(_, best)| a > best) {
                        Some((pos, a))
                    } else {
                        acc
                    }
                });
            let Some((pos, _)) = pick else { break };
            if let Kind::Inner { left, right } = self.n2[kids[pos]].kind {
                kids.splice(pos..=pos, [left as usize, right as usize]);
            }
        }
        let me = self.nodes.len();
        self.nodes.push(Node4::EMPTY_NODE);
        self.parents.push(EMPTY);
        let mut lo = [[f32::INFINITY; 4]; 3];
        let mut hi = [[f32::NEG_INFINITY; 4]; 3];
        let mut child = [EMPTY; 4];
        for (lane, &k) in kids.iter().enumerate() {
            child[lane] = self.node(k, depth + 1);
            match child[lane] {
                c if c & LEAF != 0 => self.block_parents[(c & !LEAF) as usize] = me as u32,
                c => self.parents[c as usize] = me as u32,
            }
            let b = self.n2[k].b;
            for a in 0..3 {
                lo[a][lane] = b.lo[a];
                hi[a][lane] = b.hi[a];
            }
        }
        self.nodes[me] = Node4 {
            bounds: [lo.map(Vec4::from_array), hi.map(Vec4::from_array)],
            child,
        };
        me as u32
    }

    /// Emits the block of triangles `idx[start .. start + count]` (1 to 4 of them).
    fn leaf(&mut self, start: usize, count: usize) -> u32 {
        let faces = &self.idx[start..start + count];
        self.blocks
            .push(Tri4::from_faces(faces, self.tris, self.alpha));
        self.block_parents.push(EMPTY);
        LEAF | (self.blocks.len() - 1) as u32
    }
}
