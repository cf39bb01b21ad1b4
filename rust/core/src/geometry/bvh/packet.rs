//! Packet traversal: up to [`LANES`] shadow rays walk the tree together.
//!
//! Why: the shadow rays of one receiver share their origin and point at one light, so they visit
//! nearly the same nodes. Walking the tree once per packet loads each node once for all its rays
//! and tests the four child boxes against every ray with straight-line lane arithmetic (which
//! LLVM vectorizes), instead of one dependent chain of loads, tests and branches per ray.
//!
//! Exactness: a ray is declared blocked only by the very watertight test of the per-ray
//! traversal (`block_occludes` with the ray's own [`RayData`]), and the box test is the same
//! conservative slab test (same operands, same `ROBUST` widening, the same one-ulp origin nudge
//! on axes where the direction is zero), written with `min`/`max` because the rays of a packet
//! may enter a box through different faces. Culling only ever skips boxes that no triangle hit
//! lies in, so the answer (whether any opaque hit exists) does not depend on the traversal.

use super::triangle::RayData;
use super::{Bvh, Node4, LEAF, ROBUST, STACK};
use crate::geometry::mesh::Scene;
use glam::Vec4;
use std::cell::RefCell;

/// Rays per packet.
pub(super) const LANES: usize = 8;

thread_local! {
    /// Per-thread traversal stack of (child reference, lanes that hit its box).
    static PACKET_STACK: RefCell<[(u32, u32); STACK]> = const { RefCell::new([(0, 0); STACK]) };
}

/// Groups of four lanes per packet.
const GROUPS: usize = LANES / 4;

/// Box-test data of a packet of rays that share their origin and the signs of their direction
/// components (so the same box planes are their entry planes): one lane per ray, four lanes
/// per `Vec4`. Unused lanes are masked out by `full`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Packet {
    /// The shared origin for the entry and for the exit planes (see `RayData`).
    org_near: Vec4x3,
    org_far: Vec4x3,
    near: [usize; 3],
    inv: [[Vec4; GROUPS]; 3],
    /// Bit `i` set when lane `i` holds a ray.
    pub full: u32,
}

type Vec4x3 = [Vec4; 3];

impl Packet {
    /// The packet of `rays` (1 to [`LANES`]), which must share `org_near`, `org_far` and `near`
    /// (see [`Packet::key`]).
    pub fn new(rays: &[RayData]) -> Packet {
        let mut inv = [[[1f32; 4]; GROUPS]; 3];
        let mut full = 0;
        for (l, r) in rays.iter().enumerate().take(LANES) {
            for a in 0..3 {
                inv[a][l / 4][l % 4] = r.inv[a].x;
            }
            full |= 1 << l;
        }
        let r = rays[0];
        Packet {
            org_near: r.org_near,
            org_far: r.org_far,
            near: r.near.map(usize::from),
            inv: inv.map(|a| a.map(Vec4::from_array)),
            full,
        }
    }

    /// The lanes of each child of `node` whose ray overlaps the child's box over t in (0, 1):
    /// exactly the operations of `Node4::hit`, one lane per ray instead of per child.
    #[inline(always)]
    fn hit(&self, node: &Node4) -> [u32; 4] {
        let b = &node.bounds;
        let n = self.near;
        let near = [
            (b[n[0]][0] - self.org_near[0]).to_array(),
            (b[n[1]][1] - self.org_near[1]).to_array(),
            (b[n[2]][2] - self.org_near[2]).to_array(),
        ];
        let far = [
            (b[1 - n[0]][0] - self.org_far[0]).to_array(),
            (b[1 - n[1]][1] - self.org_far[1]).to_array(),
            (b[1 - n[2]][2] - self.org_far[2]).to_array(),
        ];
        let mut out = [0u32; 4];
        for (c, m) in out.iter_mut().enumerate() {
            for g in 0..GROUPS {
                let x0 = Vec4::splat(near[0][c]) * self.inv[0][g];
                let y0 = Vec4::splat(near[1][c]) * self.inv[1][g];
                let z0 = Vec4::splat(near[2][c]) * self.inv[2][g];
                let x1 = Vec4::splat(far[0][c]) * self.inv[0][g];
                let y1 = Vec4::splat(far[1][c]) * self.inv[1][g];
                let z1 = Vec4::splat(far[2][c]) * self.inv[2][g];
                let tnear = x0.max(y0).max(z0.max(Vec4::ZERO));
                let tfar = x1.min(y1).min(z1.min(Vec4::ONE)) * ROBUST;
                *m |= tnear.cmple(tfar).bitmask() << (4 * g);
            }
        }
        out
    }
}

impl Bvh {
    /// Which of the packet's rays (`rays[i]` is lane `i`, segments t in (0, 1)) are blocked by an
    /// opaque surface: the bitmask of blocked lanes. `hint` is a block tested first and is
    /// replaced by the last block that blocked a ray.
    pub(super) fn occluded_packet(&self, scene: &Scene, rays: &[RayData], hint: &mut u32) -> u32 {
        let packet = Packet::new(rays);
        let mut blocked = 0u32;
        if let Some(b) = self.blocks.get(*hint as usize) {
            for (l, r) in rays.iter().enumerate().take(LANES) {
                if self.block_occludes(scene, b, r, 1.0) {
                    blocked |= 1 << l;
                }
            }
        }
        let active = packet.full & !blocked;
        if active == 0 {
            return blocked;
        }
        let more = PACKET_STACK.with(|s| match s.try_borrow_mut() {
            Ok(mut stack) => self.packet_any_hit(scene, &packet, rays, active, &mut stack, hint),
            // Only reachable if `is_opaque_at` re-entered the BVH on this thread.
            Err(_) => self.packet_any_hit(scene, &packet, rays, active, &mut [(0, 0); STACK], hint),
        });
        blocked | more
    }

    /// Any-hit traversal of the whole tree for the lanes `active`; returns the lanes blocked.
    fn packet_any_hit(
        &self,
        scene: &Scene,
        packet: &Packet,
        rays: &[RayData],
        mut active: u32,
        stack: &mut [(u32, u32); STACK],
        hint: &mut u32,
    ) -> u32 {
        let mut blocked = 0u32;
        let mut sp = 0usize;
        let (mut cur, mut lanes) = (self.root, active);
        loop {
            lanes &= active;
            if lanes != 0 {
                if cur & LEAF == 0 {
                    let node = &self.nodes[cur as usize];
                    super::NODES.with(|c| c.set(c.get() + 1));
                    let hits = packet.hit(node);
                    for c in 0..4 {
                        let m = hits[c] & lanes;
                        if m != 0 {
                            // At most 4 pushes per node and one pop: 3 * depth + 1 <= STACK.
                            stack[sp] = (node.child[c], m);
                            sp += 1;
                        }
                    }
                } else {
                    let b = cur & !LEAF;
                    let block = &self.blocks[b as usize];
                    let mut m = lanes;
                    while m != 0 {
                        let l = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if self.block_occludes(scene, block, &rays[l], 1.0) {
                            blocked |= 1 << l;
                            active &= !(1 << l);
                            *hint = b;
                        }
                    }
                    if active == 0 {
                        return blocked;
                    }
                }
            }
            if sp == 0 {
                return blocked;
            }
            sp -= 1;
            (cur, lanes) = stack[sp];
        }
    }
}
