//! The pair tests of one caster against [`LANES`] view samples at once.
//!
//! Most of a pair test (section 3.3) is arithmetic on the pair alone: the side of the triangle's
//! plane the view sample lies on, the three planes through it and the triangle's edges, where
//! each lies against the light's bounding sphere, and the bin of each in the paper's table. Made
//! one pair at a time, every step waits on the one before (square root, division, the bin's
//! divisions, the table read); here one caster's steps run for [`LANES`] view samples side by
//! side, in plain loops over arrays that LLVM compiles to the CPU's widest registers
//! ([`crate::isa`]). Each lane calls the very functions of the one-pair test, so its bits are
//! the same; the reads and AND-s of the tables' masks stay one pair at a time.

use super::tables::PlaneBins;
use super::{
    can_block_from, edge_plane, inverse_length, side_value, straddles_or_above, PairPlanes, Planes,
    Prepared, Reach, Supporting,
};
use crate::isa::{isa_dispatch, Isa};
use glam::DVec3;

/// The view samples tested side by side.
pub(super) const LANES: usize = 8;

/// Up to [`LANES`] pairs of one caster: their list entries, view points, and planes.
pub(super) struct Lanes {
    entries: [usize; LANES],
    /// The view points, per axis.
    p: [[f64; LANES]; 3],
    count: usize,
    found: LanePlanes,
}

impl Lanes {
    pub(super) fn new() -> Self {
        Self {
            entries: [0; LANES],
            p: [[0.0; LANES]; 3],
            count: 0,
            found: LanePlanes::new(),
        }
    }

    /// The list entries of the pairs, lane by lane.
    pub(super) fn entries(&self) -> &[usize] {
        &self.entries[..self.count]
    }

    /// Empties the lanes.
    pub(super) fn clear(&mut self) {
        self.count = 0;
    }

    /// Finds the planes of every lane's test of `caster`.
    pub(super) fn find_planes(&mut self, caster: &CasterLanes<'_>) {
        caster.planes_on(Isa::detect(), &self.p, &mut self.found);
    }

    /// The planes of lane `l` (once found) that straddle the light, into `pair`, as
    /// [`super::pair_planes`] finds them for its view sample tested exactly and unrotated (with
    /// the paper's table, [`Self::codes`] serve); false where one leaves every sample unblocked.
    pub(super) fn pair<'a>(
        &self,
        l: usize,
        supporting: &Supporting<'a>,
        pair: &mut PairPlanes<'a>,
    ) -> bool {
        let found = &self.found;
        if !found.live[l] {
            return false;
        }
        let side = supporting.side(found.negative[l]);
        pair.clear();
        if side.reach == Reach::Straddles {
            pair.push(side.plane, Some(side.exact));
        }
        for edge in found.edges.iter().filter(|edge| edge.straddles[l]) {
            let m = DVec3::new(edge.m[0][l], edge.m[1][l], edge.m[2][l]);
            pair.push((m, edge.k[l], edge.inv[l]), None);
        }
        true
    }

    /// The [`PlaneBins::code`]s of lane `l`'s planes (once found) in the paper's table, the
    /// supporting plane's then the edges', a plane that does not straddle the light coded as
    /// every sample's, and how many straddle; `None` where a plane leaves every sample
    /// unblocked.
    pub(super) fn codes(&self, l: usize, supporting: &Supporting<'_>) -> Option<([u32; 4], u64)> {
        let found = &self.found;
        if !found.live[l] {
            return None;
        }
        let side = supporting.side(found.negative[l]);
        let [a, b, c] = &found.edges;
        let straddling = [a, b, c]
            .iter()
            .fold(u64::from(side.reach == Reach::Straddles), |n, edge| {
                n + u64::from(edge.straddles[l])
            });
        Some(([side.code, a.code[l], b.code[l], c.code[l]], straddling))
    }

    /// Adds the pair of list entry `e` at view point `p`; true when every lane is taken. The
    /// caller tests the lanes (and empties them) as soon as it says so, so a lane is free here.
    pub(super) fn push(&mut self, e: usize, p: DVec3) -> bool {
        let l = self.count;
        self.entries[l] = e;
        [self.p[0][l], self.p[1][l], self.p[2][l]] = p.to_array();
        self.count += 1;
        self.count == LANES
    }
}

/// One edge plane per lane: `m · y < k`, `1 / |m|`, whether it straddles the light's bounding
/// sphere and its [`PlaneBins::code`] (every sample's where it does not straddle).
#[derive(Clone, Copy)]
struct EdgeLanes {
    m: [[f64; LANES]; 3],
    k: [f64; LANES],
    inv: [f64; LANES],
    straddles: [bool; LANES],
    code: [u32; LANES],
}

/// The planes of one caster's test per lane.
struct LanePlanes {
    /// Whether no plane leaves the lane's every sample unblocked.
    live: [bool; LANES],
    /// Whether the view sample lies on the negative side of the triangle's plane.
    negative: [bool; LANES],
    edges: [EdgeLanes; 3],
}

impl LanePlanes {
    fn new() -> Self {
        let edge = EdgeLanes {
            m: [[0.0; LANES]; 3],
            k: [0.0; LANES],
            inv: [0.0; LANES],
            straddles: [false; LANES],
            code: [0; LANES],
        };
        Self {
            live: [false; LANES],
            negative: [false; LANES],
            edges: [edge; 3],
        }
    }
}

/// One caster's constants of the lane loops.
pub(super) struct CasterLanes<'a> {
    pub t: &'a Prepared,
    /// Per side of the triangle's plane (positive, negative), whether the light lies wholly
    /// above its supporting plane.
    above: [bool; 2],
    center: DVec3,
    radius: f64,
    lut: Option<&'a super::Lut>,
}

// Lane loops index by lane on purpose, as in `geometry/bvh/packet.rs`: plain index loops are
// what LLVM vectorizes reliably.
#[allow(clippy::needless_range_loop)]
impl<'a> CasterLanes<'a> {
    pub(super) fn new(t: &'a Prepared, supporting: &Supporting<'_>, planes: &Planes<'a>) -> Self {
        Self {
            t,
            above: [false, true].map(|negative| supporting.side(negative).reach == Reach::Above),
            center: planes.center,
            radius: planes.radius,
            lut: planes.lut,
        }
    }

    /// Whether the caster may block a sample from view point `p`: the first step of a lane's
    /// test, made for one pair before it takes a lane, as it rules out a quarter of the pairs
    /// (a view sample on the caster's plane, behind a front-only caster, or with the light wholly
    /// on its side of the supporting plane).
    #[inline(always)]
    pub(super) fn may_block_from(&self, p: DVec3) -> bool {
        let side = side_value(self.t, p);
        can_block_from(self.t, side) & !self.above[usize::from(side < 0.0)]
    }

    isa_dispatch! {
        /// The planes of every lane of `p` (meaningless past the lanes taken), into `out`, with
        /// the table's codes where a table is read: [`Self::planes_body`] compiled for `isa`.
        fn planes_on(&CasterLanes<'_>) => planes_body(
            p: &[[f64; LANES]; 3],
            out: &mut LanePlanes,
        ) -> ()
    }

    /// Each step is a loop over the lanes of its own, the innermost loop, as LLVM vectorizes
    /// only those; each edge's planes in a function of its own, whose arguments tell LLVM that
    /// the edge's arrays and the lanes' liveness do not overlap, and the table's codes in a
    /// loop after the planes' (in one body with `out`, or the codes in the edges' loop, LLVM
    /// left the loops scalar).
    #[inline(always)]
    fn planes_body(&self, p: &[[f64; LANES]; 3], out: &mut LanePlanes) {
        let t = self.t;
        let mut live = [false; LANES];
        for l in 0..LANES {
            let side = side_value(t, point(p, l));
            let negative = side < 0.0;
            let above = if negative {
                self.above[1]
            } else {
                self.above[0]
            };
            live[l] = can_block_from(t, side) & !above;
            out.negative[l] = negative;
        }
        for (k, edge) in out.edges.iter_mut().enumerate() {
            self.edge_lanes(p, k, edge, &mut live);
        }
        out.live = live;
        if let Some(lut) = self.lut {
            let grid = lut.grid;
            for edge in &mut out.edges {
                edge.codes(grid);
            }
        }
    }

    /// The plane through each lane's view point and edge `k`, into `edge`, clearing the
    /// lanes of `live` whose plane leaves every sample unblocked.
    #[inline(always)]
    fn edge_lanes(
        &self,
        p: &[[f64; LANES]; 3],
        k: usize,
        edge: &mut EdgeLanes,
        live: &mut [bool; LANES],
    ) {
        for l in 0..LANES {
            let ((m, bound), s) = edge_plane(self.t, point(p, l), k);
            let (straddles, above) = straddles_or_above(m, bound, self.center, self.radius);
            live[l] &= (s != 0.0) & !above;
            [edge.m[0][l], edge.m[1][l], edge.m[2][l]] = m.to_array();
            edge.k[l] = bound;
            edge.inv[l] = inverse_length(m);
            edge.straddles[l] = straddles;
        }
    }
}

impl EdgeLanes {
    /// Each lane's plane's [`PlaneBins::code`] in `grid` (a copy, which LLVM knows the
    /// lanes' stores leave alone: read through the table, the loop stayed scalar), every
    /// sample's where the plane does not straddle the light's bounding sphere (the one-pair
    /// test leaves such a plane out).
    #[inline(always)]
    fn codes(&mut self, grid: PlaneBins) {
        let every = grid.misses_below();
        for l in 0..LANES {
            let m = DVec3::new(self.m[0][l], self.m[1][l], self.m[2][l]);
            let code = grid.code(m, self.k[l], self.inv[l]);
            self.code[l] = if self.straddles[l] { code } else { every };
        }
    }
}

/// Lane `l`'s point of `p` (per axis).
#[inline(always)]
fn point(p: &[[f64; LANES]; 3], l: usize) -> DVec3 {
    DVec3::new(p[0][l], p[1][l], p[2][l])
}

#[cfg(test)]
mod tests {
    use super::super::{pair_planes, LightSamples, Lut, Plane, Read};
    use super::*;
    use crate::error::Result;
    use crate::light::sampling::Rng;

    /// Whether two reads are the same (the same masks, by address).
    fn same(a: Read<'_>, b: Read<'_>) -> bool {
        match (a, b) {
            (Read::Test, Read::Test) => true,
            (Read::Bracket(a, u), Read::Bracket(b, v)) => std::ptr::eq(a, b) && std::ptr::eq(u, v),
            _ => false,
        }
    }

    /// How the tables serve plane `i` of `pair`.
    fn resolved<'a>(pair: &PairPlanes<'a>, planes: &Planes<'a>, i: usize) -> Read<'a> {
        pair.known[i].unwrap_or_else(|| planes.read(pair.planes[i]))
    }

    /// The samples the one-pair test finds below every plane of `pair` (false: none), and the
    /// masks AND-ed.
    fn below_all(pair: &PairPlanes<'_>, planes: &Planes<'_>) -> (bool, Vec<u64>, u64) {
        let (full, words) = (planes.samples.full_mask(), planes.samples.words);
        let (mut out, mut scratch, mut sure) = (vec![0; words], vec![0; words], vec![0; words]);
        let mut ops = 0;
        let any = planes.below_all(pair, &full, &mut out, &mut scratch, &mut sure, &mut ops);
        (any, out, ops)
    }

    /// Every lane finds the very planes and table reads of the one-pair test, on every
    /// instruction set of this CPU: view points in general position, and on the degenerate ones
    /// (a vertex: on the triangle's plane and on two edge planes), from both sides of front-only
    /// and two-sided casters, with the paper's table (the same samples below all planes,
    /// through the lanes' codes) and without it (the same planes, bit for bit).
    #[test]
    fn lanes_find_the_planes_of_one_pair_at_a_time_on_every_instruction_set() -> Result<()> {
        let mut rng = Rng::new(5);
        let mut next = move |scale: f64| (f64::from(rng.next_f32()) * 2.0 - 1.0) * scale;
        let center = DVec3::new(0.0, 4.0, 0.0);
        let points: Vec<DVec3> = (0..100)
            .map(|_| center + DVec3::new(next(0.4), next(0.1), next(0.4)))
            .collect();
        let samples = LightSamples {
            weights: vec![1.0; points.len()],
            words: points.len().div_ceil(64),
            points,
        };
        let lut = Lut::new(&samples, center, 0.6, 16)?;
        let (mut tested, mut blocking) = ([0usize; 2], 0);
        for trial in 0..300 {
            let v = [0; 3].map(|_| DVec3::new(next(1.0), 2.0 + next(1.0), next(1.0)));
            let normal = (v[1] - v[0]).cross(v[2] - v[0]);
            let t = Prepared {
                id: 0,
                v,
                normal,
                alpha: false,
                moved: false,
                front_only: trial % 2 == 0,
                culled: false,
                near_depth: 0.0,
                center_distance: 0.0,
            };
            let mut lanes = Lanes::new();
            for l in 0..LANES {
                let p = match (trial % 5, l) {
                    (0, 0) => v[0],
                    (0, 1) => v[2],
                    _ => DVec3::new(next(3.0), next(1.0), next(3.0)),
                };
                lanes.push(l, p);
            }
            for lut in [Some(&lut), None] {
                let planes = Planes {
                    samples: &samples,
                    lut,
                    brackets: None,
                    center,
                    radius: 0.6,
                    rotation: None,
                };
                let supporting = Supporting::new(&t, &planes);
                let caster = CasterLanes::new(&t, &supporting, &planes);
                for isa in Isa::all_on_this_cpu() {
                    caster.planes_on(isa, &lanes.p, &mut lanes.found);
                    for l in 0..LANES {
                        let at = format!("{isa:?} trial {trial} lane {l}");
                        let mut one = PairPlanes::new();
                        let found =
                            pair_planes(&t, point(&lanes.p, l), &supporting, &planes, &mut one);
                        if let Some(lut) = lut {
                            let codes = lanes.codes(l, &supporting);
                            assert_eq!(codes.is_some(), found, "{at}");
                            let Some((codes, straddling)) = codes else {
                                continue;
                            };
                            tested[0] += 1;
                            let (any, mask, ops) = below_all(&one, &planes);
                            let mut side = vec![0; samples.words];
                            assert_eq!(lut.below_all(codes, &mut side), any, "{at}");
                            assert_eq!(straddling, one.count as u64, "{at}");
                            assert!(ops <= straddling, "{at}");
                            if any {
                                blocking += 1;
                                assert_eq!(side, mask, "{at}");
                            }
                            continue;
                        }
                        let mut side = PairPlanes::new();
                        assert_eq!(lanes.pair(l, &supporting, &mut side), found, "{at}");
                        if !found {
                            continue;
                        }
                        tested[1] += 1;
                        assert_eq!(one.count, side.count, "{at}");
                        for i in 0..one.count {
                            let bits = |(m, k, inv): Plane| {
                                (m.to_array().map(f64::to_bits), k.to_bits(), inv.to_bits())
                            };
                            assert_eq!(bits(one.planes[i]), bits(side.planes[i]), "{at} plane {i}");
                            assert!(
                                same(resolved(&one, &planes, i), resolved(&side, &planes, i)),
                                "{at} plane {i}"
                            );
                        }
                    }
                }
            }
        }
        // Enough pairs reach the table (or the samples), and block samples, to mean something.
        assert!(
            tested.iter().all(|&n| n > 500) && blocking > 100,
            "{tested:?} {blocking}"
        );
        Ok(())
    }
}
