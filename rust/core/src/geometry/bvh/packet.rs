//! Coherent shadow-ray packets: segments from many origins to one common target.
//!
//! When every receiver uses the same light samples, the rays of neighbouring receivers to one
//! sample `y` converge at `y`: read backwards they share their origin, so their frustum (apex
//! `y`, through the bounding box of the origins) is narrow, the classic coherent packet of
//! Wald et al., "Interactive Rendering with Coherent Ray Tracing" (2001), used for soft shadows
//! by Benthin and Wald, "Efficient Ray Traced Soft Shadows using Multi-Frusta Tracing" (2009).
//! One traversal serves a packet of up to [`LANES`] rays:
//!
//! - inner nodes are culled with the [`Frustum`] of the packet (conservative, see
//!   `bvh/frustum.rs`: it bounds the very same segments, read from `y`), so the inner-node work
//!   is shared by all lanes (about one node test per ray instead of nine);
//! - each child also gets the lanes that may reach it, by the central projection from `y`
//!   ([`Slopes`]: a box's slope rectangle against each lane's slopes, whole groups of four
//!   lanes first): penumbra rays graze different small leaves, and lanes leave the packet
//!   when blocked, so the lines of the active lanes are far thinner than the frustum and whole
//!   subtrees are skipped once no active lane can reach them;
//! - at a leaf, the lanes left are box-tested with the exact arithmetic of the single-ray slab
//!   test (`Node4::hit`), four at a time, and each survivor runs the single-ray leaf test
//!   [`Bvh::block_occludes`] on its own [`RayData`], built on its first leaf;
//! - a blocked lane leaves the packet, and the traversal stops when no lane is left.
//!
//! Exactness: every lane is tested with the `RayData` that [`Bvh::occluded`] builds for the
//! same segment; a leaf is skipped for a lane only when the frustum or the projection test
//! (both conservative, with margins far above float rounding) or that lane's own slab test
//! (identical to the single ray's, which never culls a leaf holding a watertight hit) rejects
//! it. An opaque hit anywhere in the open segment answers either way, so each lane's answer
//! equals [`Bvh::occluded`] bit for bit, whatever the packet it travels in.

use super::frustum::Frustum;
use super::triangle::RayData;
use super::{Bvh, Node4, LEAF, ROBUST, STACK};
use crate::geometry::mesh::Scene;
use glam::{Vec3, Vec4};
use std::cell::RefCell;

thread_local! {
    /// Per-thread packet buffer (about 20 KiB, rewritten lane by lane, never zeroed again).
    static PACKET: RefCell<Box<Packet>> = RefCell::new(Box::new(Packet::empty()));
}

/// Most rays of one packet (one bit each in the lane masks).
pub(super) const LANES: usize = 64;
/// Groups of four lanes.
const GROUPS: usize = LANES / 4;

/// The rays of one packet, with their slab-test data transposed four lanes per `Vec4`.
pub(super) struct Packet {
    origins: [Vec3; LANES],
    /// The single-ray data of each lane, built on the lane's first leaf test (`built` bits):
    /// many lanes never reach a leaf.
    rays: [Option<RayData>; LANES],
    built: u64,
    org_near: [[Vec4; 3]; GROUPS],
    org_far: [[Vec4; 3]; GROUPS],
    inv: [[Vec4; 3]; GROUPS],
    /// Per axis, lanes whose entry plane is the box maximum (as in `RayData::near`).
    near: [[glam::BVec4A; 3]; GROUPS],
    /// The lanes' footprint slopes (see [`Slopes`]).
    slopes: Slopes,
    sa: [Vec4; GROUPS],
    sb: [Vec4; GROUPS],
    /// Per group of four lanes, the range of their slopes (`[a min, a max, b min, b max]`,
    /// four groups per `Vec4`), to skip whole groups at once.
    group_range: [[Vec4; 4]; GROUPS / 4],
    /// The lanes that may reach each node on the traversal stack.
    lane_stack: [u64; STACK],
}

/// Central projection from the common target `y` along the frustum's dominant axis `k`
/// (`d_k = (p_k - y_k) sign > 0` on the whole packet): a point `p` maps to the slopes
/// `(d_i / d_k, d_j / d_k)` of its offset from `y`. Every point of a lane's segment maps to
/// the lane's own slopes (they all lie on one line through `y`), so a segment can only meet a
/// box whose slope rectangle holds the lane's slopes: four comparisons per four lanes reject
/// most lanes (a per-ray refinement of the frustum test of Benthin and Wald 2009).
#[derive(Debug, Clone, Copy)]
struct Slopes {
    y: Vec3,
    k: usize,
    sign: f32,
    /// Absolute rounding scale of the slopes: the largest coordinate magnitude of the target
    /// and the origins.
    scale: f32,
}

impl Packet {
    /// A packet with no lanes.
    fn empty() -> Packet {
        Packet {
            origins: [Vec3::ZERO; LANES],
            rays: [None; LANES],
            built: 0,
            org_near: [[Vec4::ZERO; 3]; GROUPS],
            org_far: [[Vec4::ZERO; 3]; GROUPS],
            inv: [[Vec4::ONE; 3]; GROUPS],
            near: [[glam::BVec4A::FALSE; 3]; GROUPS],
            slopes: Slopes { y: Vec3::ZERO, k: 0, sign: 1.0, scale: 0.0 },
            sa: [Vec4::ZERO; GROUPS],
            sb: [Vec4::ZERO; GROUPS],
            group_range: [[Vec4::ZERO; 4]; GROUPS / 4],
            lane_stack: [0; STACK],
        }
    }

    /// Sets the lanes to the segments `origins[i] -> target` (t in (0, 1) along
    /// `target - origins[i]`, at most [`LANES`]) for the frustum axis `(k, sign)`; returns the
    /// mask of lanes with a non-empty segment. Only the groups of those lanes are written; the
    /// others keep stale data that the lane masks never read.
    fn fill(&mut self, origins: &[Vec3], target: Vec3, (k, sign): (usize, f32)) -> u64 {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let scale = origins.iter().fold(target.abs().max_element(), |m, o| m.max(o.abs().max_element()));
        self.slopes = Slopes { y: target, k, sign, scale };
        let n = origins.len().min(LANES);
        self.origins[..n].copy_from_slice(&origins[..n]);
        self.built = 0;
        for (lane, &o) in origins[..n].iter().enumerate() {
            let (g, l) = (lane / 4, lane % 4);
            for a in 0..3 {
                self.org_far[g][a][l] = o[a];
            }
        }
        let mut live = 0u64;
        for g in 0..n.div_ceil(4) {
            live |= u64::from(self.slab_group(g, target)) << (4 * g);
        }
        // Lanes past `n` in the last group hold stale origins.
        live &= if n == LANES { u64::MAX } else { (1 << n) - 1 };
        let y = target.to_array().map(Vec4::splat);
        for g in 0..n.div_ceil(4) {
            // `org_far` is the origin up to one ulp on axes of zero direction: far below the
            // tolerance of the slope test.
            let o = &self.org_far[g];
            let dk = (o[k] - y[k]) * Vec4::splat(sign);
            (self.sa[g], self.sb[g]) = ((o[i] - y[i]) / dk, (o[j] - y[j]) / dk);
            let bits = live >> (4 * g);
            let m = glam::BVec4A::new(bits & 1 != 0, bits & 2 != 0, bits & 4 != 0, bits & 8 != 0);
            let (inf, ninf) = (Vec4::INFINITY, Vec4::NEG_INFINITY);
            let r = [
                Vec4::select(m, self.sa[g], inf).min_element(),
                Vec4::select(m, self.sa[g], ninf).max_element(),
                Vec4::select(m, self.sb[g], inf).min_element(),
                Vec4::select(m, self.sb[g], ninf).max_element(),
            ];
            for (q, v) in r.into_iter().enumerate() {
                self.group_range[g / 4][q][g % 4] = v;
            }
        }
        live
    }

    /// Sets the slab-test data of group `g` (origins already in `org_far`) for the segments to
    /// `target`, as `RayData::new` computes them lane by lane (same IEEE operations: the
    /// direction `target - o` and its safe reciprocal); returns the 4-bit mask of lanes with a
    /// non-empty segment. A group with a zero or non-finite direction component goes through
    /// `RayData::new` itself, which handles those cases.
    #[inline(always)]
    fn slab_group(&mut self, g: usize, target: Vec3) -> u32 {
        let o = self.org_far[g];
        let d = [0, 1, 2].map(|a| Vec4::splat(target[a]) - o[a]);
        let regular = d.iter().fold(glam::BVec4A::TRUE, |m, d| m & d.cmpne(Vec4::ZERO) & d.is_finite_mask());
        if regular.all() {
            let tiny = Vec4::splat(1e-30);
            self.inv[g] = d.map(|d| Vec4::ONE / Vec4::select(d.abs().cmplt(tiny), tiny.copysign(d), d));
            self.org_near[g] = o;
            self.near[g] = self.inv[g].map(|i| i.cmplt(Vec4::ZERO));
            return 0xF;
        }
        let mut live = 0u32;
        for l in 0..4 {
            let lane = 4 * g + l;
            let origin = self.origins[lane];
            let r = RayData::new(origin, target - origin);
            self.rays[lane] = r;
            self.built |= 1 << lane;
            let Some(r) = r else { continue };
            live |= 1 << l;
            for a in 0..3 {
                self.org_near[g][a][l] = r.org_near[a].x;
                self.org_far[g][a][l] = r.org_far[a].x;
                self.inv[g][a][l] = r.inv[a].x;
            }
        }
        self.near[g] = self.inv[g].map(|i| i.cmplt(Vec4::ZERO));
        live
    }

    /// The single-ray data of `lane` (live), built on first use.
    #[inline(always)]
    fn ray(&mut self, lane: usize) -> Option<RayData> {
        if self.built >> lane & 1 == 0 {
            let (o, y) = (self.origins[lane], self.slopes.y);
            self.rays[lane] = RayData::new(o, y - o);
            self.built |= 1 << lane;
        }
        self.rays[lane]
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
        let (k0, k1) = ((lo[k] - Vec4::splat(y[k])) * sign, (hi[k] - Vec4::splat(y[k])) * sign);
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
            (Vec4::select(ahead, qmin - tol, Vec4::NEG_INFINITY), Vec4::select(ahead, qmax + tol, Vec4::INFINITY))
        };
        let ((amin, amax), (bmin, bmax)) = (range(i), range(j));
        [amin, amax, bmin, bmax]
    }

    /// The lanes of `active` whose slopes lie in rectangle `c` of `rects` (see
    /// [`Packet::child_rects`]): whole groups first by their slope range, then lane by lane.
    #[inline(always)]
    fn rect_lanes(&self, rects: &[Vec4; 4], c: usize, active: u64) -> u64 {
        let [amin, amax, bmin, bmax] = rects.map(|r| Vec4::splat(r[c]));
        let quads = (64 - active.leading_zeros() as usize).div_ceil(16);
        let mut groups = 0u32;
        for (q, r) in self.group_range.iter().enumerate().take(quads) {
            let m = r[1].cmpge(amin) & r[0].cmple(amax) & r[3].cmpge(bmin) & r[2].cmple(bmax);
            groups |= m.bitmask() << (4 * q);
        }
        let mut out = 0u64;
        while groups != 0 {
            let g = groups.trailing_zeros() as usize;
            groups &= groups - 1;
            let (a, b) = (self.sa[g], self.sb[g]);
            let m = a.cmpge(amin) & a.cmple(amax) & b.cmpge(bmin) & b.cmple(bmax);
            out |= u64::from(m.bitmask()) << (4 * g);
        }
        out & active
    }

    /// The lanes of `active` whose slab test accepts child `c` of `node`: per lane the same
    /// IEEE operations, in the same order, as `Node4::hit` for that lane's single ray.
    #[inline(always)]
    fn box_lanes(&self, node: &Node4, c: usize, active: u64) -> u64 {
        let lo = [0, 1, 2].map(|a| Vec4::splat(node.bounds[0][a][c]));
        let hi = [0, 1, 2].map(|a| Vec4::splat(node.bounds[1][a][c]));
        let mut out = 0u64;
        let mut groups = active;
        while groups != 0 {
            let g = groups.trailing_zeros() as usize / 4;
            groups &= !(0xF << (4 * g));
            let d = |a: usize| {
                let (bn, bf) =
                    (Vec4::select(self.near[g][a], hi[a], lo[a]), Vec4::select(self.near[g][a], lo[a], hi[a]));
                ((bn - self.org_near[g][a]) * self.inv[g][a], (bf - self.org_far[g][a]) * self.inv[g][a])
            };
            let ((x0, x1), (y0, y1), (z0, z1)) = (d(0), d(1), d(2));
            let tnear = x0.max(y0).max(z0.max(Vec4::ZERO));
            let tfar = x1.min(y1).min(z1.min(Vec4::ONE)) * ROBUST;
            out |= u64::from(tnear.cmple(tfar).bitmask()) << (4 * g);
        }
        out & active
    }
}

impl Bvh {
    /// For each origin, whether the open segment from it to `target` is blocked (t in (0, 1)
    /// with `dir = target - origin`): the shadow rays of many receivers to one light sample.
    /// Clears and fills `out`.
    ///
    /// Same answers as [`Bvh::occluded`] per origin; faster for nearby origins, whose segments
    /// form a narrow frustum with apex `target` traced as coherent packets (see `bvh/packet.rs`).
    pub fn occluded_converging(&self, scene: &Scene, origins: &[Vec3], target: Vec3, out: &mut Vec<bool>) {
        out.clear();
        for chunk in origins.chunks(LANES) {
            let blocked = self.packet_blocked(scene, chunk, target);
            out.extend((0..chunk.len()).map(|lane| blocked >> lane & 1 != 0));
        }
    }

    /// The mask of blocked lanes of the packet `origins -> target` (at most [`LANES`]).
    fn packet_blocked(&self, scene: &Scene, origins: &[Vec3], target: Vec3) -> u64 {
        let one_by_one = || {
            (0..origins.len())
                .filter(|&lane| self.occluded(scene, origins[lane], target - origins[lane], 1.0))
                .fold(0, |m, lane| m | 1 << lane)
        };
        // No pyramid with apex `target` bounds the origins: the rays go one by one.
        let Some(frustum) = Frustum::new(target, origins) else { return one_by_one() };
        PACKET.with(|p| {
            // Only busy if `is_opaque_at` re-entered the BVH on this thread.
            let Ok(mut packet) = p.try_borrow_mut() else { return one_by_one() };
            let live = packet.fill(origins, target, frustum.axis());
            let mut active = live;
            super::ANY_STACK.with(|s| match s.try_borrow_mut() {
                Ok(mut stack) => self.packet_traverse(scene, &mut packet, &frustum, &mut active, &mut stack),
                Err(_) => self.packet_traverse(scene, &mut packet, &frustum, &mut active, &mut [0; STACK]),
            });
            live & !active
        })
    }

    /// Traverses the tree with the packet's frustum, clearing from `active` every lane found
    /// blocked; stops as soon as no lane is active. Each stacked node carries the lanes whose
    /// lines pass its box by the projection test, so a subtree is left as soon as none of the
    /// lanes still active can reach it (the frustum of all lanes stays as wide as at the start).
    fn packet_traverse(&self, scene: &Scene, p: &mut Packet, f: &Frustum, active: &mut u64, stack: &mut [u32; STACK]) {
        if self.root & LEAF != 0 {
            // A single-leaf tree has no node box: every lane tests the leaf.
            self.packet_leaf(scene, p, self.root & !LEAF, *active, active);
            return;
        }
        let mut sp = 0usize;
        let (mut cur, mut lanes) = (self.root, *active);
        loop {
            lanes &= *active;
            if lanes != 0 {
                let node = &self.nodes[cur as usize];
                let mut mask = f.overlaps(node);
                let rects = if mask != 0 { p.child_rects(node) } else { [Vec4::ZERO; 4] };
                while mask != 0 {
                    let c = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let sub = p.rect_lanes(&rects, c, lanes & *active);
                    if sub == 0 {
                        continue;
                    }
                    let child = node.child[c];
                    if child & LEAF == 0 {
                        // At most 4 pushes per level and 3 * depth + 1 <= STACK (see `build`):
                        // each level leaves at most 3 siblings behind, the deepest adds 4.
                        stack[sp] = child;
                        p.lane_stack[sp] = sub;
                        sp += 1;
                    } else {
                        let hit = p.box_lanes(node, c, sub);
                        self.packet_leaf(scene, p, child & !LEAF, hit, active);
                    }
                }
            }
            if sp == 0 || *active == 0 {
                return;
            }
            sp -= 1;
            (cur, lanes) = (stack[sp], p.lane_stack[sp]);
        }
    }

    /// Tests the `lanes` of the packet against block `b` with the single-ray leaf test and
    /// clears the blocked ones from `active`.
    #[inline]
    fn packet_leaf(&self, scene: &Scene, p: &mut Packet, b: u32, lanes: u64, active: &mut u64) {
        let block = &self.blocks[b as usize];
        let mut m = lanes;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            if let Some(r) = p.ray(lane) {
                if self.block_occludes(scene, block, &r, 1.0) {
                    *active &= !(1 << lane);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let faces: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let opaque = Mesh::new(pos.clone(), faces.clone(), None, None, false).unwrap();
        let uvs: Vec<Vec2> = pos.iter().map(|p| Vec2::new(p.x * 3.1, p.z * 2.7 + p.y)).collect();
        let alpha: Vec<f32> = (0..16 * 16).map(|k| ((k * 7919 + 13) % 5 < 2) as u8 as f32).collect();
        let shifted: Vec<Vec3> = pos.iter().map(|p| *p + Vec3::new(0.17, -0.11, 0.23)).collect();
        let tex = AlphaTexture::new(16, 16, &alpha).unwrap();
        let perforated = Mesh::new(shifted, faces, Some(uvs), Some(tex), false).unwrap();
        let g = [(-1.0, -1.0), (5.0, -1.0), (5.0, 5.0), (-1.0, 5.0)].map(|(x, z)| Vec3::new(x, -0.5, z));
        let ground = Mesh::new(g.to_vec(), vec![[0, 1, 2], [0, 2, 3]], None, None, false).unwrap();
        Scene::new(vec![opaque, perforated, ground]).unwrap()
    }

    /// Checks every lane of `occluded_converging` against `occluded`; returns (blocked, lit).
    fn check(bvh: &Bvh, scene: &Scene, origins: &[Vec3], target: Vec3) -> (usize, usize) {
        let mut out = vec![true; 3];
        bvh.occluded_converging(scene, origins, target, &mut out);
        assert_eq!(out.len(), origins.len());
        for (&o, &blocked) in origins.iter().zip(&out) {
            assert_eq!(blocked, bvh.occluded(scene, o, target - o, 1.0), "origin {o} target {target}");
        }
        let blocked = out.iter().filter(|&&b| b).count();
        (blocked, out.len() - blocked)
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
            let corner = Vec3::new(rng.next_f32() * 4.0, rng.next_f32() * 4.5 - 0.49, rng.next_f32() * 4.0);
            let step = 0.002 + rng.next_f32() * 0.05;
            let origins: Vec<Vec3> =
                (0..81).map(|k| corner + Vec3::new((k % 9) as f32 * step, 0.0, (k / 9) as f32 * step)).collect();
            for _ in 0..8 {
                let target = Vec3::new(rng.next_f32() * 6.0 - 1.0, 6.0 + rng.next_f32(), rng.next_f32() * 6.0 - 1.0);
                let (b, l) = check(&bvh, &scene, &origins, target);
                (blocked, lit) = (blocked + b, lit + l);
            }
        }
        assert!(blocked > 2000 && lit > 2000, "blocked {blocked}, lit {lit}");
    }

    #[test]
    fn converging_packets_handle_degenerate_rays() {
        let scene = scene(300, 3);
        let bvh = Bvh::build(&scene).unwrap();
        let target = Vec3::new(2.0, 6.0, 2.0);
        // Directions with exactly zero components (origins straight below or level with the
        // target) and an empty segment (origin at the target).
        let mut origins: Vec<Vec3> = (0..20).map(|k| Vec3::new(2.0, -0.5 + 0.3 * k as f32, 2.0)).collect();
        origins.extend((0..20).map(|k| Vec3::new(0.2 * k as f32, -0.4, 2.0)));
        origins.push(target);
        check(&bvh, &scene, &origins, target);
        // Origins on both sides of the target: no frustum, the rays go one by one.
        let around: Vec<Vec3> = (0..16).map(|k| Vec3::new(0.3 * k as f32 - 0.5, 2.0, 2.0)).collect();
        check(&bvh, &scene, &around, Vec3::new(2.0, 2.0, 2.1));
        // No origins at all.
        check(&bvh, &scene, &[], target);
    }
}
