//! `alias_free`: sample-based visibility with alias-free shadow maps (Sintorn, Eisemann and
//! Assarsson 2008, Sample Based Visibility for Soft Shadows using Alias-free Shadow Maps).
//!
//! The receivers (the paper's *view samples*) are stored in the light's shadow map instead of
//! depths, so every receiver is tested exactly, whatever the map's resolution:
//!
//! 1. **View samples** (section 3): valid receivers that see the light (for a point light: facing
//!    it, `n · (l − p) > 0`; for an area or volume light: facing any part of it). The others get 0.
//! 2. **Parametrization** (section 4.3): the light frustum, from the light's center, fitted to the
//!    view samples' projected bounding box and depth range.
//! 3. **Lists** (section 3.1): each view sample goes to the list of the texel it projects to, by
//!    count, prefix sum and scatter ([`crate::influence::ReceiverLists`]).
//! 4. **Casters**: with `CasterFaces::Backfacing` (the default), closed meshes cast with their light
//!    back-facing triangles only, which never shadow the front-facing surface they belong to, so
//!    no bias is needed (section 3.3); open meshes cast with every triangle. Culling holds for
//!    receivers outside every closed mesh, the paper's view samples, seen by an eye outside the
//!    objects: a segment from outside that crosses a closed mesh enters it through a light
//!    back-facing triangle. From inside one (a receiver within it, or one whose normal points
//!    into it) a segment first leaves through a light front-facing triangle, which culling drops.
//!    So a view sample whose moved point lies inside a closed mesh ([`mark_inside_closed_meshes`])
//!    is tested from its moved point against every triangle of the closed meshes. With
//!    `CasterFaces::All` every triangle casts. A caster that can be its own receiver's surface (every
//!    triangle of an open mesh, every triangle with `All`) tests the receiver moved `bias` along
//!    its normal, as the ray tracer does.
//! 5. **Influence regions** (section 4.1, [`crate::influence`]): the union of the
//!    triangle's projections from every point of the light, bounded by the convex hull of the
//!    projections of its vertices from the light's bounding points (`hull_degree`-gons for disks,
//!    spheres and, by virtual scaling, ellipsoids), rasterized conservatively. Bands of rows are
//!    processed in parallel, each owning the lists of its texels and projecting the regions onto
//!    the plane of its own farthest view sample (the regions nest, shrinking towards the light).
//! 6. **Visibility** (sections 3.3 and 4.2): each view sample keeps a bitmask over the `S` light
//!    samples (1 for a point light). A triangle blocks sample `y` from `p` when `p` and `y` lie
//!    strictly on opposite sides of its plane and `y` lies strictly inside the three planes through
//!    `p` and its edges: the masks of those four planes are AND-ed, and the triangles' masks OR-ed.
//!    With `TableSize::Exact` every plane tests every sample exactly; with a table of `k` bins a
//!    plane's mask is read from a table indexed by its normal and its signed distance from the
//!    light's center (the plane-to-bitmask lookup table; Eisemann and Décoret 2007), `k` bins
//!    of distance and about `k²` of normal (the paper's two angles, here hemi-octahedral
//!    coordinates and a sign, whose bin is arithmetic: [`tables`]), `k` sized from the sample
//!    count by default ([`table_bins_for`], section 4.3).
//!    The exact tests read a bracketing table instead ([`tables`]): per bin, the samples behind
//!    every plane of the bin and those behind some of its planes only; the planes' masks are
//!    AND-ed word by word, and only the samples left unsure are tested, against every plane at
//!    once: the bits of testing every sample.
//!    The bins are directions and distances relative to the light, so a binned plane's error, as seen
//!    from a view sample, grows with the light's apparent size there: a view sample that sees the
//!    samples' bounding sphere wider than [`TABLE_MAX_SPREAD`] tests its planes exactly instead.
//!    A view sample whose mask is full skips the remaining tests. One caster's planes and bins
//!    are found for several view samples side by side ([`lanes`]), the same bits as one by one.
//!    With per-receiver rotation of the samples (disk and sphere lights) a view sample's planes
//!    are rotated the other way instead, so the one table serves every rotation (the paper's
//!    rotated lookups for symmetric lights). Samples behind the receiver's tangent plane start
//!    blocked (`docs/design.md` section 3), and a perforated caster's blocked samples are kept
//!    only where the segment meets an opaque texel.
//!
//! 7. **Penumbra restriction** (section 4.3, `restrict_to_penumbra`): occlusion seen from a
//!    view sample can only change across the light where its segments to the light cross an
//!    edge that is a silhouette from some light point ([`crate::geometry::edges`]). Texels outside
//!    the influence regions of those edges (and of perforated casters, whose texture cuts
//!    anywhere) hold view samples that see all of the light blocked or none of it: there one test
//!    of the segment to the light's center decides the whole bitmask, made only against the
//!    casters whose projection from the center covers the texel (the paper's hard-shadow test
//!    there), in lists of their own. The result is the same.
//! 8. **Supporting-plane cut** (section 4.3, `cut_at_supporting_plane`): a triangle blocks a
//!    sample only from the other side of its plane, and a closed mesh's light back-facing
//!    triangle only from its front, so each influence region is cut to the side of the plane
//!    where the receivers it may shadow lie ([`cut_at_supporting_plane`]). The result is the same.
//!
//! The result is the emission-weighted fraction of unblocked samples, as `ray_traced`'s.

#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(not(feature = "gpu"))]
#[path = "no_gpu.rs"]
pub mod gpu;
mod lanes;
mod tables;

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::bvh::SceneBvh;
use crate::geometry::edges::{edges, edges_peak, Edge};
use crate::geometry::inside::inside_closed_meshes;
use crate::geometry::mesh::Scene;
use crate::geometry::polygon::{clip_affine, convex_hull};
use crate::geometry::receivers::Receivers;
use crate::influence::{
    check_hull_degree, influence_hull, influence_points, record_list_stats, LightBounds,
    ReceiverLists,
};
use crate::isa::{isa_dispatch, signum, Isa};
use crate::light::lights::{Light, Shape};
use crate::light::sampling::{lit_fraction, SampleSet};
use crate::limits::{self, object_work, Peak};
use crate::methods::CasterFaces;
use crate::raster::cube::by_light_face;
use crate::raster::depth::{
    balanced_runs, band_rows, bin_to_runs, casters, Caster, FaceFilter, RasterMode, RasterOptions,
};
use crate::raster::frustum::check_resolution;
use crate::raster::frustum::LightFrustum;
use crate::raster::region::{conservative_row_range, conservative_spans, texel_box};
use crate::stats::Stats;
use glam::{DMat3, DVec2, DVec3, Vec3};
use lanes::{CasterLanes, Lanes};
use rayon::prelude::*;
use std::borrow::Cow;
use std::ops::Range;
pub(crate) use tables::{BracketTable, Lut};

/// The most light samples a view sample's bitmask holds.
pub const MAX_SAMPLES: usize = 1024;

/// The widest light the lookup table serves a view sample: the radius of the samples' bounding
/// sphere over the view sample's distance from the light's center (a cone of 47 degrees). The
/// table's bins are directions and distances relative to the light (Sintorn et al. 2008, Sample
/// Based Visibility for Soft Shadows using Alias-free Shadow Maps, section 4.2), so the light
/// points a binned plane puts on the wrong side span a fixed part of the light, which looks the
/// wider the nearer the light, while the casters' shadows on it do not grow. Farther from the
/// light than this, a view sample reads its planes from the table; nearer, it tests them exactly.
/// The built-in scenes' default lights stay below 0.36. (At 0.5, a sphere light of radius 1.16
/// over a small closed sphere, 32 samples, put the table's mean error on the ground at 0.011:
/// the binned planes of a triangle smaller than a bin in light space form a triangle of about a
/// bin's size, empty half the time and larger than the true one otherwise, so the table darkens,
/// the more the wider the light looks.)
pub const TABLE_MAX_SPREAD: f64 = 0.4;

/// The fewest view samples for which the exact tests build a [`BracketTable`]: its set-up, paid
/// once per call, is worth it only over many view samples; fewer test every sample against
/// every plane.
const BRACKETS_MIN_VIEW_SAMPLES: usize = 1024;

/// The memory a table sized from the sample count may take (64 MiB: the paper's 64^3 texels of
/// 128 bits for each block of 128 of 1024 samples come to 32 MiB).
pub const TABLE_BUDGET_BYTES: u64 = 64 << 20;

/// How the light samples behind a plane are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableSize {
    /// Every plane tests every sample.
    Exact,
    /// The plane-to-bitmask table with this many bins per parameter.
    Bins(usize),
    /// The table sized from the sample count: [`table_bins_for`].
    FromSamples,
}

impl TableSize {
    /// Bins per parameter of the table for `samples` light samples, `None` for exact tests.
    pub fn bins(self, samples: usize) -> Option<usize> {
        match self {
            Self::Exact => None,
            Self::Bins(bins) => Some(bins),
            Self::FromSamples => Some(table_bins_for(samples)),
        }
    }
}

/// Bins per parameter of the table for `samples` light samples (Sintorn et al. 2008, section
/// 4.3: the table's size is chosen relative to the number of samples, to keep its
/// discretization error down, "typically 64^3"): 8 sqrt(S) rounded up to a multiple of 8, from
/// the paper's 64 to 128, and as many as [`TABLE_BUDGET_BYTES`] hold (S = 16, 64, 128, 256, 512,
/// 1024: 64, 64, 96, 128, 96 and 80 bins). A bin's width in angle and in distance then stays near
/// the samples' spacing on the light (its extent over sqrt(S)), up to the budget, and no wider
/// than the paper's.
pub fn table_bins_for(samples: usize) -> usize {
    let words = samples.div_ceil(64).max(1) as u64;
    let wanted = ((8.0 * (samples.max(1) as f64).sqrt() / 8.0).ceil() as usize * 8).clamp(64, 128);
    let fits = |bins: usize| (bins as u64).pow(3) * words * 8 <= TABLE_BUDGET_BYTES;
    (8..=wanted)
        .rev()
        .step_by(8)
        .find(|&b| fits(b))
        .unwrap_or(8)
}

/// Options of [`alias_free`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AliasFreeOptions {
    /// Side of the light's list map in texels (default 512, the paper's).
    pub resolution: usize,
    pub caster_faces: CasterFaces,
    /// Receiver offset along its normal for casters that may be its own surface (world units).
    pub bias: f32,
    /// The plane-to-bitmask table's size, or exact tests (default: sized from the sample count).
    pub lut: TableSize,
    /// Sides of the bounding polygons of disk and sphere lights (default 6, hexagons).
    pub hull_degree: usize,
    /// Restrict the per-sample tests to the penumbra (section 4.3, default true): view samples
    /// outside the influence regions of the light's potential silhouette edges (and of perforated
    /// casters) see all of the light or none of it, so one test against the light's center
    /// decides their whole bitmask. Same result, less work.
    pub restrict_to_penumbra: bool,
    /// Cut each caster's influence region at its supporting plane (section 4.3, default true):
    /// where every sample lies on one side of a triangle's plane, only receivers on the other
    /// side (or within `bias` of it) can be shadowed by it. Same result, fewer pairs tested.
    pub cut_at_supporting_plane: bool,
    /// Where the lists, influence regions and per-texel tests run (`methods/alias_free/gpu.rs`); the
    /// casters, their regions' polygons, the penumbra texels and the table are set up on the
    /// CPU for both. Same bits either way.
    pub backend: Backend,
}

impl Default for AliasFreeOptions {
    fn default() -> Self {
        Self {
            resolution: 512,
            caster_faces: CasterFaces::Backfacing,
            bias: 0.0,
            lut: TableSize::FromSamples,
            hull_degree: 6,
            restrict_to_penumbra: true,
            cut_at_supporting_plane: true,
            backend: Backend::Cpu,
        }
    }
}

impl AliasFreeOptions {
    fn validate(&self) -> Result<()> {
        check_resolution("resolution", self.resolution)?;
        if !(self.bias.is_finite() && self.bias >= 0.0) {
            return Err(Error::invalid(
                "bias",
                format!("must be finite and >= 0, got {}", self.bias),
            ));
        }
        if let TableSize::Bins(k) = self.lut {
            if !(4..=256).contains(&k) {
                return Err(Error::invalid(
                    "lut",
                    format!("must be in 4..=256 bins (or \"auto\" to size it from the samples, or None for exact tests), got {k}"),
                ));
            }
        }
        check_hull_degree(self.hull_degree)
    }
}

/// One view sample: its receiver, position, position moved along the normal, and normal.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ViewSample {
    pub receiver: u32,
    pub p: DVec3,
    pub moved: DVec3,
    pub n: DVec3,
    /// The transpose of its samples' rotation about the light's center (`rotate="per_receiver"`).
    pub rotation: Option<DMat3>,
    /// Whether its moved point lies inside a closed mesh under `CasterFaces::Backfacing`: it is listed
    /// at its moved point and tested from there against every closed triangle, culled or not.
    pub inside: bool,
    /// Whether its planes are tested exactly although a table was asked for: the light looks too
    /// wide from it for the table ([`TABLE_MAX_SPREAD`]).
    pub exact_planes: bool,
}

/// The light samples as f64 points, their weights, and the bitmask word count.
pub(crate) struct LightSamples {
    pub points: Vec<DVec3>,
    pub weights: Vec<f64>,
    pub words: usize,
}

impl LightSamples {
    fn full_mask(&self) -> Vec<u64> {
        (0..self.words)
            .map(|k| valid_bits(k, self.points.len()))
            .collect()
    }

    /// The samples with `m · y < k`.
    fn below(&self, m: DVec3, k: f64, out: &mut [u64]) {
        out.iter_mut().for_each(|w| *w = 0);
        for (s, y) in self.points.iter().enumerate() {
            if m.dot(*y) < k {
                out[s / 64] |= 1 << (s % 64);
            }
        }
    }
}

/// Plane masks of the light samples, through the paper's table or exactly (through the
/// bracketing table where one was built), for one view sample whose samples may be rotated about
/// the light's center.
#[derive(Clone, Copy)]
struct Planes<'a> {
    samples: &'a LightSamples,
    lut: Option<&'a Lut>,
    brackets: Option<&'a BracketTable>,
    center: DVec3,
    /// The radius of a sphere about `center` holding every sample (a hair more than the light's
    /// extent, against round-off).
    radius: f64,
    /// The transpose of the view sample's rotation: a rotated sample `c + R (y − c)` lies below
    /// `m · x < k` exactly when `y` lies below `(Rᵀ m) · y < k − m · c + (Rᵀ m) · c`.
    rotation: Option<DMat3>,
}

impl<'a> Planes<'a> {
    /// The plane `(m, k)` (`inv = 1 / |m|`) for the unrotated samples, with its `1 / |m|`.
    fn unrotated(&self, (m, k, inv): Plane) -> Plane {
        match self.rotation {
            Some(rt) => {
                let r = rt * m;
                (
                    r,
                    k - m.dot(self.center) + r.dot(self.center),
                    1.0 / r.length(),
                )
            }
            None => (m, k, inv),
        }
    }

    /// How the bracketing table serves the unrotated plane `(m, k)` (`inv = 1 / |m|`) for the
    /// exact tests.
    #[inline]
    fn read(&self, (m, k, inv): Plane) -> Read<'a> {
        match self.brackets.and_then(|b| b.lookup(m, k, inv)) {
            Some((sure, unsure)) => Read::Bracket(sure, unsure),
            None => Read::Test,
        }
    }

    /// The samples that every plane of `pair` puts strictly below it, into `out` (`scratch` and
    /// `sure` of the same length); false when none. Counts the planes' masks AND-ed in `ops`.
    fn below_all(
        &self,
        pair: &PairPlanes<'a>,
        full: &[u64],
        out: &mut [u64],
        scratch: &mut [u64],
        sure: &mut [u64],
        ops: &mut u64,
    ) -> bool {
        let planes = &pair.planes[..pair.count];
        if let Some(lut) = self.lut {
            // The paper's table: the planes' rows, those left out read as every sample's.
            let mut codes = [lut.grid.misses_below(); 4];
            for (code, &(m, k, inv)) in codes.iter_mut().zip(planes) {
                *code = lut.grid.code(m, k, inv);
            }
            *ops += planes.len() as u64;
            return lut.below_all(codes, out);
        }
        let read = |i: usize| pair.known[i].unwrap_or_else(|| self.read(planes[i]));
        out.copy_from_slice(full);
        // Exact: `out` gathers the samples some planes may put below all of them, `sure` those
        // every plane does; the rest of `out` is tested against every plane, sample by sample.
        // The bracketing table's entries are found before any is read, so that the reads (far
        // apart in a table of megabytes) overlap.
        let mut reads = [Read::Test; 4];
        for (i, r) in reads.iter_mut().enumerate().take(planes.len()) {
            *r = read(i);
        }
        sure.copy_from_slice(full);
        for (&(m, k, _), read) in planes.iter().zip(reads) {
            *ops += 1;
            match read {
                Read::Bracket(below, unsure) => {
                    and_into(sure, below);
                    out.iter_mut()
                        .zip(below.iter().zip(unsure))
                        .for_each(|(a, (b, u))| *a &= b | u);
                }
                _ => {
                    self.samples.below(m, k, scratch);
                    and_into(sure, scratch);
                    and_into(out, scratch);
                }
            }
            if out.iter().all(|w| *w == 0) {
                return false;
            }
        }
        for (w, (word, sure)) in out.iter_mut().zip(sure.iter()).enumerate() {
            let mut unsure = *word & !sure;
            *word = *sure;
            while unsure != 0 {
                let bit = unsure.trailing_zeros() as usize;
                unsure &= unsure - 1;
                let y = self.samples.points[w * 64 + bit];
                if planes.iter().all(|&(m, k, _)| m.dot(y) < k) {
                    *word |= 1 << bit;
                }
            }
        }
        out.iter().any(|w| *w != 0)
    }
}

/// The planes of one pair's test that straddle the light, unrotated, in the order they are
/// tested (the supporting plane's, then the edges'), with how the tables serve those whose reads
/// are known already.
#[derive(Clone, Copy)]
struct PairPlanes<'a> {
    planes: [Plane; 4],
    known: [Option<Read<'a>>; 4],
    count: usize,
}

impl<'a> PairPlanes<'a> {
    fn new() -> Self {
        Self {
            planes: [(DVec3::ZERO, 0.0, 0.0); 4],
            known: [None; 4],
            count: 0,
        }
    }

    fn clear(&mut self) {
        self.count = 0;
    }

    fn push(&mut self, plane: Plane, known: Option<Read<'a>>) {
        self.planes[self.count] = plane;
        self.known[self.count] = known;
        self.count += 1;
    }
}

/// How the exact tests serve one plane `m · y < k`.
#[derive(Clone, Copy)]
enum Read<'a> {
    /// The bracketing table's `(sure, unsure)` masks.
    Bracket(&'a [u64], &'a [u64]),
    /// No table serves it: every sample is tested.
    Test,
}

/// Where a plane lies against the light's bounding sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reach {
    /// Wholly above it: nothing is blocked.
    Above,
    /// Wholly below it: the plane removes nothing.
    Below,
    /// Across it.
    Straddles,
}

/// Where the plane `(m, k)` lies against the sphere `(center, radius)`, and `1 / |m|` where it
/// straddles it (NaN otherwise). Squared, so that only a plane the tables will read pays for
/// the square root and the division.
#[inline]
fn reach(m: DVec3, k: f64, center: DVec3, radius: f64) -> (Reach, f64) {
    match straddles_or_above(m, k, center, radius) {
        (true, _) => (Reach::Straddles, inverse_length(m)),
        (false, true) => (Reach::Above, f64::NAN),
        (false, false) => (Reach::Below, f64::NAN),
    }
}

/// [`reach`] without a branch, for lane loops: whether the plane straddles the sphere, and
/// whether it lies wholly above it.
#[inline(always)]
fn straddles_or_above(m: DVec3, k: f64, center: DVec3, radius: f64) -> (bool, bool) {
    let length_squared = m.length_squared();
    let distance = k - m.dot(center);
    let straddles = distance * distance <= radius * radius * length_squared;
    (straddles, !straddles & (distance < 0.0))
}

/// `1 / |m|`.
#[inline(always)]
fn inverse_length(m: DVec3) -> f64 {
    1.0 / m.length_squared().sqrt()
}

/// A caster's supporting plane seen from either of its sides, set up once per caster and band:
/// from a view sample on side `σ` of the triangle's plane (index 0 for `σ = +1`, 1 for `−1`),
/// a blocked sample lies strictly below `σ n · y < σ n · v0`, whichever the view sample.
struct Supporting<'a> {
    sides: [SupportingSide<'a>; 2],
}

/// One side of [`Supporting`]: the plane, where it lies against the light's bounding sphere and
/// its table reads, the same for every view sample on that side, so that the pair loop builds
/// and looks up only the three edge planes.
#[derive(Clone, Copy)]
struct SupportingSide<'a> {
    plane: Plane,
    reach: Reach,
    /// How the bracketing table serves it for unrotated samples tested exactly.
    exact: Read<'a>,
    /// Its [`tables::PlaneBins::code`] in the paper's table where it straddles the light, the
    /// code of every sample where it lies below (meaningless without a table).
    code: u32,
}

impl<'a> Supporting<'a> {
    /// The side a view sample on the negative side of the triangle's plane (or not) sees.
    fn side(&self, negative: bool) -> &SupportingSide<'a> {
        &self.sides[usize::from(negative)]
    }

    fn new(t: &Prepared, unrotated: &Planes<'a>) -> Self {
        let exact = Planes {
            lut: None,
            ..*unrotated
        };
        let side = |sigma: f64| {
            let (m, k) = (t.normal * sigma, sigma * t.normal.dot(t.v[0]));
            let (reach, inv) = reach(m, k, unrotated.center, unrotated.radius);
            let plane = (m, k, inv);
            let code = unrotated.lut.map_or(0, |lut| match reach {
                Reach::Straddles => lut.grid.code(m, k, inv),
                _ => lut.grid.misses_below(),
            });
            SupportingSide {
                plane,
                reach,
                exact: match reach {
                    Reach::Straddles => exact.read(plane),
                    _ => Read::Test,
                },
                code,
            }
        };
        Self {
            sides: [side(1.0), side(-1.0)],
        }
    }
}

/// A plane `m · y < k` and `1 / |m|`.
type Plane = (DVec3, f64, f64);

/// Whether `mask` equals `full`, word by word (inlined, where a slice comparison calls `memcmp`
/// once per pair).
#[inline]
fn is_full(mask: &[u64], full: &[u64]) -> bool {
    mask.iter().zip(full).all(|(a, b)| a == b)
}

/// `a &= b`, word by word.
fn and_into(a: &mut [u64], b: &[u64]) {
    a.iter_mut().zip(b).for_each(|(a, b)| *a &= b);
}

/// A caster prepared for the tests: vertices in f64, plane, whether it tests moved receivers.
pub(crate) struct Prepared {
    pub id: u32,
    pub v: [DVec3; 3],
    pub normal: DVec3,
    pub alpha: bool,
    pub moved: bool,
    /// A closed mesh's triangle under `CasterFaces::Backfacing`: it blocks only samples it is back-facing
    /// to, from receivers in front of it (so never its own surface).
    pub front_only: bool,
    /// A closed triangle that culling leaves out (facing every sample, or a point light's front
    /// face): it casts for the view samples inside a closed mesh only.
    pub culled: bool,
    /// Its nearest linear depth in the light's frustum.
    pub near_depth: f64,
    /// `(n · v0 − n · c) / |n|` for its normal `n`, a vertex `v0` and the light's center `c`: the
    /// signed distance of its supporting plane beyond the center, as [`blocked_by`] computes it
    /// for a view sample on the positive side (negated on the other).
    pub center_distance: f64,
}

impl Prepared {
    /// This caster as a view sample inside a closed mesh sees it: blocking from either side of
    /// its plane, tested from the moved point.
    fn seen_from_inside(&self) -> Prepared {
        Prepared {
            moved: true,
            front_only: false,
            ..*self
        }
    }
}

/// The four planes `(m, k)` of the test of triangle `t` from view point `p` (section 3.3): a light
/// point `y` is blocked exactly when `m · y < k` for all four, i.e. when it lies strictly behind
/// the triangle's plane as seen from `p` and strictly inside the three planes through `p` and the
/// triangle's edges. `None` when no point can be blocked (`p` on the triangle's plane or one of
/// its edge planes, or behind a front-only caster).
fn bounding_planes(t: &Prepared, p: DVec3) -> Option<[(DVec3, f64); 4]> {
    let sigma = side_of(t, p)?;
    let [a, b, c] = edge_planes(t, p)?;
    Some([(t.normal * sigma, sigma * t.normal.dot(t.v[0])), a, b, c])
}

/// The side (+1 or −1) of `t`'s plane that `p` lies on, `None` where `t` can block nothing from
/// `p` (on its plane, or behind a front-only caster).
fn side_of(t: &Prepared, p: DVec3) -> Option<f64> {
    let side = side_value(t, p);
    can_block_from(t, side).then(|| side.signum())
}

/// `n · (p − v0)`: where `p` lies against `t`'s plane (of normal `n` through vertex `v0`).
#[inline(always)]
fn side_value(t: &Prepared, p: DVec3) -> f64 {
    t.normal.dot(p - t.v[0])
}

/// Whether `t` may block anything from a point at [`side_value`] `side`: off its plane, and
/// not behind a front-only caster.
#[inline(always)]
fn can_block_from(t: &Prepared, side: f64) -> bool {
    // `&`, not `&&`: no branch, for lane loops.
    (side != 0.0) & !(t.front_only & (side < 0.0))
}

/// The three edge planes of [`bounding_planes`]: inside the planes through `p` and each edge of
/// `t`, i.e. `e · (y − p)` with the sign of `e · (w − p)`: `(−sign e) · y < −sign e · p`.
#[inline]
fn edge_planes(t: &Prepared, p: DVec3) -> Option<[(DVec3, f64); 3]> {
    let mut bounds = [(DVec3::ZERO, 0.0); 3];
    for (k, bound) in bounds.iter_mut().enumerate() {
        let (plane, s) = edge_plane(t, p, k);
        if s == 0.0 {
            return None;
        }
        *bound = plane;
    }
    Some(bounds)
}

/// The plane of [`edge_planes`] through `p` and edge `k` of `t`, and `e · (w − p)`, zero (and
/// the plane meaningless) where `p` lies in the triangle's plane or on the edge's line.
#[inline(always)]
fn edge_plane(t: &Prepared, p: DVec3, k: usize) -> ((DVec3, f64), f64) {
    let (u, v, w) = (t.v[k], t.v[(k + 1) % 3], t.v[(k + 2) % 3]);
    let e = (u - p).cross(v - p);
    let s = e.dot(w - p);
    let m = -e * signum(s);
    ((m, m.dot(p)), s)
}

/// Whether triangle `t` blocks the single light point `y` from view point `p`.
fn blocks_point(t: &Prepared, p: DVec3, y: DVec3) -> bool {
    bounding_planes(t, p).is_some_and(|planes| planes.iter().all(|(m, k)| m.dot(y) < *k))
}

/// The samples of `samples` that triangle `t` (its supporting plane set up in `supporting`)
/// blocks from view point `p`, written into `buffers.blocked` (false when none), following the
/// module documentation.
#[inline]
fn blocked_by(
    t: &Prepared,
    p: DVec3,
    supporting: &Supporting<'_>,
    planes: &Planes<'_>,
    full: &[u64],
    buffers: &mut Buffers,
    work: &mut Work,
) -> bool {
    let mut pair = PairPlanes::new();
    pair_planes(t, p, supporting, planes, &mut pair)
        && below_all_planes(&pair, planes, full, buffers, work)
}

/// The planes of the test of triangle `t` from view point `p` that straddle the light, into
/// `pair`; false where one leaves every sample unblocked (or where `t` can block nothing from
/// `p`).
#[inline]
fn pair_planes<'a>(
    t: &Prepared,
    p: DVec3,
    supporting: &Supporting<'a>,
    planes: &Planes<'a>,
    pair: &mut PairPlanes<'a>,
) -> bool {
    let Some(sigma) = side_of(t, p) else {
        return false;
    };
    // The light wholly on p's side of the supporting plane: nothing is behind it (the test of
    // its plane, made before the edge planes are built).
    let side = supporting.side(sigma < 0.0);
    if side.reach == Reach::Above {
        return false;
    }
    let Some(edges) = edge_planes(t, p) else {
        return false;
    };
    // The light's bounding sphere decides most planes without looking at a sample: wholly above a
    // plane, nothing is blocked; wholly below, the plane removes nothing.
    pair.clear();
    if side.reach == Reach::Straddles {
        // The supporting plane's reads hold for unrotated samples only.
        let known = planes.rotation.is_none().then_some(side.exact);
        pair.push(planes.unrotated(side.plane), known);
    }
    for (m, bound) in edges {
        match reach(m, bound, planes.center, planes.radius) {
            (Reach::Above, _) => return false,
            (Reach::Straddles, inv) => pair.push(planes.unrotated((m, bound, inv)), None),
            (Reach::Below, _) => {}
        }
    }
    true
}

/// The samples below every plane of `pair`, into `buffers.blocked` (false when none).
#[inline]
fn below_all_planes(
    pair: &PairPlanes<'_>,
    planes: &Planes<'_>,
    full: &[u64],
    buffers: &mut Buffers,
    work: &mut Work,
) -> bool {
    let Buffers {
        blocked,
        scratch,
        sure,
    } = buffers;
    planes.below_all(pair, full, blocked, scratch, sure, &mut work.plane_mask_ops)
}

/// The per-band buffers of the tests: a pair's blocked samples and two of scratch.
struct Buffers {
    blocked: Vec<u64>,
    scratch: Vec<u64>,
    sure: Vec<u64>,
}

impl Buffers {
    fn new(words: usize) -> Self {
        Self {
            blocked: vec![0; words],
            scratch: vec![0; words],
            sure: vec![0; words],
        }
    }
}

/// For a perforated caster, clears the blocked samples whose segment crosses a transparent texel.
fn alpha_test(
    scene: &Scene,
    t: &Prepared,
    p: DVec3,
    samples: &LightSamples,
    rotated: impl Fn(DVec3) -> DVec3,
    blocked: &mut [u64],
) {
    let (e1, e2) = (t.v[1] - t.v[0], t.v[2] - t.v[0]);
    let nn = t.normal.length_squared();
    for s in 0..samples.points.len() {
        if blocked[s / 64] >> (s % 64) & 1 == 0 {
            continue;
        }
        let y = rotated(samples.points[s]);
        let (sp, sy) = (t.normal.dot(p - t.v[0]), t.normal.dot(y - t.v[0]));
        let x = p + (y - p) * (sp / (sp - sy));
        let r = x - t.v[0];
        let b1 = r.cross(e2).dot(t.normal) / nn;
        let b2 = e1.cross(r).dot(t.normal) / nn;
        if !scene.is_opaque_at(t.id, b1 as f32, b2 as f32) {
            blocked[s / 64] &= !(1 << (s % 64));
        }
    }
}

/// Whether every point of the light and of its samples lies strictly in front of triangle `t`'s
/// plane: only then is a closed triangle back-facing to no sample.
fn faces_whole_light(bounds: &LightBounds<'_>, t: &[Vec3; 3]) -> bool {
    let v = t.map(|p| p.as_dvec3());
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    let ahead = |y: DVec3| n.dot(y - v[0]);
    let Some(light) = bounds.volume() else {
        return bounds
            .corners()
            .is_some_and(|corners| corners.iter().all(|&y| ahead(y) > 0.0));
    };
    match light.shape {
        Shape::Point { position } => ahead(position.as_dvec3()) > 0.0,
        Shape::Rect { center, u, v: w } => {
            let (c, u, w) = (center.as_dvec3(), u.as_dvec3(), w.as_dvec3());
            [c + u + w, c + u - w, c - u - w, c - u + w]
                .into_iter()
                .all(|y| ahead(y) > 0.0)
        }
        Shape::Disk {
            center,
            normal,
            radius,
        } => {
            let (nn, d) = (n.length(), normal.as_dvec3());
            let spread = f64::from(radius) * nn * (1.0 - (n.dot(d) / nn).powi(2)).max(0.0).sqrt();
            ahead(center.as_dvec3()) > spread
        }
        Shape::Sphere { center, radius } => {
            ahead(center.as_dvec3()) > f64::from(radius) * n.length()
        }
        // The ellipsoid's support function along n: |Aᵀ n|.
        Shape::Ellipsoid { center, axes } => {
            ahead(center.as_dvec3()) > (axes.as_dmat3().transpose() * n).length()
        }
    }
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "list_build_seconds",
    "rasterization_seconds",
    "visibility_seconds",
    "view_samples",
    "casters",
    "average_list_length",
    "max_list_length",
    "occupied_texels_percent",
    "silhouette_edges",
    "penumbra_texels_percent",
    "light_samples",
    "exact_view_samples",
    "inside_view_samples",
    "lut_bins",
    "pair_tests",
    "plane_mask_ops",
    "light_faces",
];

/// Soft (or, for a point light, hard) visibility of every receiver by alias-free shadow maps.
///
/// Returns the visibility (receivers' order) and stats: `list_build_seconds`,
/// `rasterization_seconds` (influence regions and their binning), `visibility_seconds` (the
/// per-texel tests), `view_samples`, `casters`, `average_list_length` and `max_list_length` (over
/// occupied texels), `occupied_texels_percent` (the paper's Figure 9 inlay), `light_samples`,
/// `exact_view_samples` (view samples that test their planes exactly although a table was asked
/// for, [`TABLE_MAX_SPREAD`]), `inside_view_samples` (view samples inside a closed mesh, which
/// culling does not serve), `pair_tests` (the (view sample, caster) pairs tested, section 3.3)
/// and `plane_mask_ops` (plane masks built or looked up and AND-ed, section 4.1), both counted
/// on the CPU backend only (NaN on the GPU).
///
/// Errors: invalid options; no samples or more than [`MAX_SAMPLES`]; explicit samples of a
/// point light off its position; rotated or interleaved samples; the light's center inside the
/// view samples' bounds; `TooLarge`.
pub fn alias_free(
    scene: &Scene,
    bvh: SceneBvh<'_>,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &AliasFreeOptions,
) -> Result<(Vec<f32>, Stats)> {
    by_light_face(light, receivers, |part, _| {
        alias_free_in_one_frustum(scene, bvh, light, part, samples, opts)
    })
}

/// [`alias_free`] on receivers that one light frustum holds.
fn alias_free_in_one_frustum(
    scene: &Scene,
    bvh: SceneBvh<'_>,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &AliasFreeOptions,
) -> Result<(Vec<f32>, Stats)> {
    let mut stats = Stats::declared(STATS);
    let n = receivers.len();
    Peak::default()
        .buffer(&[n as u64, 4])
        .and(masks_peak(scene, n, samples.count(), opts))
        .check("alias_free", &mut stats)?;
    object_work(scene, n, samples.count()).check("alias_free", &mut stats)?;
    let masks = sample_masks(
        scene, bvh, light, receivers, samples, opts, false, &mut stats,
    )?;
    Ok((
        (0..receivers.len())
            .into_par_iter()
            .map(|i| masks.visibility(i))
            .collect(),
        stats,
    ))
}

/// Per receiver, the bitmask of its blocked light samples (bit `k`: sample `k`; one bit, the
/// light's center, for a point light), and the samples' weights.
pub(crate) struct SampleMasks {
    pub words: usize,
    /// `words` per receiver, in receivers' order; all set for receivers that see no part of the
    /// light (and invalid ones).
    pub masks: Vec<u64>,
    pub weights: Vec<f64>,
    /// The sum of `weights`, summed once.
    pub total: f64,
    /// The weight every sample has, where they share one that is a power of two (1 for an
    /// untextured light): any sum of such weights is exact, so the unblocked samples' count
    /// times it is the very sum of their weights.
    pub shared_weight: Option<f64>,
}

impl SampleMasks {
    /// The bitmask of receiver `i`.
    pub fn mask(&self, i: usize) -> &[u64] {
        &self.masks[i * self.words..(i + 1) * self.words]
    }

    /// The masks of `receivers` receivers, every sample blocked, for samples of weights
    /// `weights` in `words` words.
    fn all_blocked(receivers: usize, words: usize, weights: &[f64]) -> Self {
        let w = weights.first().copied().unwrap_or(0.0);
        let power_of_two = w.is_normal() && w > 0.0 && w.to_bits() << 12 == 0;
        SampleMasks {
            words,
            masks: vec![!0u64; receivers * words],
            weights: weights.to_vec(),
            total: weights.iter().sum(),
            shared_weight: (power_of_two && weights.iter().all(|&v| v == w)).then_some(w),
        }
    }

    /// The emission-weighted fraction of receiver `i`'s unblocked samples.
    pub fn visibility(&self, i: usize) -> f32 {
        if let Some(w) = self.shared_weight {
            let lit: u32 = self
                .mask(i)
                .iter()
                .enumerate()
                .map(|(k, &word)| (!word & valid_bits(k, self.weights.len())).count_ones())
                .sum();
            return lit_fraction(f64::from(lit) * w, self.total);
        }
        // The unblocked samples' weights in sample order, visited through the mask's clear bits.
        let mut lit = 0.0f64;
        for (w, &word) in self.mask(i).iter().enumerate() {
            let mut clear = !word;
            while clear != 0 {
                let k = w * 64 + clear.trailing_zeros() as usize;
                if k >= self.weights.len() {
                    break;
                }
                lit += self.weights[k];
                clear &= clear - 1;
            }
        }
        lit_fraction(lit, self.total)
    }
}

/// The bits of word `k` of a mask of `n` samples that stand for one.
fn valid_bits(k: usize, n: usize) -> u64 {
    match n.saturating_sub(64 * k) {
        0 => 0,
        left if left >= 64 => !0,
        left => (1 << left) - 1,
    }
}

/// The memory of [`sample_masks`] for `receivers` receivers and `samples` light samples: per
/// receiver its bitmask, its list entry's and its view sample's (or the GPU's, read back), its
/// view sample and point, and the lists; per caster its set-up, influence region and band bins;
/// the lookup table and, on the CPU, the bracketing table and each pass's copies of its list
/// entries; with the penumbra restriction, the flags, the silhouettes and the second set of lists
/// (its points' depths and texel ranges). (The row spans of the penumbra regions, transient, are
/// left out.)
pub(crate) fn masks_peak(
    scene: &Scene,
    receivers: usize,
    samples: usize,
    opts: &AliasFreeOptions,
) -> Peak {
    let (n, words, res) = (
        receivers as u64,
        samples.div_ceil(64).max(1) as u64,
        opts.resolution as u64,
    );
    let hull = 24 + 16 * 3 * opts.hull_degree.max(8) as u64;
    let bands = res.div_ceil(band_rows(opts.resolution) as u64);
    let per_caster =
        (std::mem::size_of::<Caster>() + std::mem::size_of::<Prepared>()) as u64 + hull + 4 * bands;
    let lut = opts.lut.bins(samples).map_or(Peak::default(), |bins| {
        Peak::default().buffer(&[bins as u64, bins as u64, bins as u64, words, 8])
    });
    let bracket_bins = BracketTable::bins_for(words as usize) as u64;
    let cpu_passes = match opts.backend {
        Backend::Cpu => Peak::default()
            .buffer(&[bracket_bins.pow(3), 2 * words, 8])
            .buffer(&[n, std::mem::size_of::<Entry>() as u64]),
        Backend::Gpu => Peak::default(),
    };
    let penumbra = if opts.restrict_to_penumbra {
        Peak::default()
            .buffer(&[res, res])
            .and(edges_peak(scene))
            .buffer(&[n, 8])
            .buffer(&[res, res, 2 * 8])
    } else {
        Peak::default()
    };
    Peak::default()
        .buffer(&[n, words, 3 * 8])
        .buffer(&[n, std::mem::size_of::<ViewSample>() as u64 + 12])
        .and(ReceiverLists::peak(receivers, opts.resolution))
        .buffer(&[scene.num_faces() as u64, per_caster])
        .and(lut)
        .and(cpu_passes)
        .and(penumbra)
}

/// The bitmasks of [`alias_free`] (see the module documentation) with its stats; with
/// `opaque_only`, perforated casters are left out (`stsv` adds their shadows). `bvh` serves the
/// test of which view samples lie inside a closed mesh, where one may.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_masks(
    scene: &Scene,
    bvh: SceneBvh<'_>,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &AliasFreeOptions,
    opaque_only: bool,
    stats: &mut Stats,
) -> Result<SampleMasks> {
    opts.validate()?;
    let light_samples = light_samples(light, samples)?;
    stats.set("light_samples", light_samples.points.len() as f64);
    let words = light_samples.words;
    limits::check_memory(
        "alias_free bitmasks",
        limits::bytes(&[receivers.len() as u64, words as u64, 8]),
    )?;
    let mut out = SampleMasks::all_blocked(receivers.len(), words, &light_samples.weights);
    let bounds = LightBounds::new(light, samples, opts.hull_degree)?;
    let mut view = view_samples(light, &bounds, receivers, samples, opts.bias);
    stats.set("view_samples", view.len() as f64);
    if view.is_empty() {
        return Ok(out);
    }
    let inside = if opts.caster_faces == CasterFaces::Backfacing {
        stats.time_add("list_build", || {
            mark_inside_closed_meshes(scene, bvh, &mut view, opts.bias)
        })?
    } else {
        0
    };
    stats.set("inside_view_samples", inside as f64);
    // A view sample inside a closed mesh is tested from its moved point against every closed
    // triangle, so it is listed there: the casters' regions must hold the point they block.
    let points: Vec<Vec3> = view
        .iter()
        .map(|s| if s.inside { s.moved } else { s.p }.as_vec3())
        .collect();
    let frustum = stats.time_add("list_build", || {
        ReceiverLists::fit(light, &points, opts.resolution)
    })?;
    let center = light.center().as_dvec3();
    let radius = light_samples
        .points
        .iter()
        .map(|y| (*y - center).length())
        .fold(0.0f64, f64::max)
        * (1.0 + 1e-9)
        + 1e-12;
    let table_bins = opts.lut.bins(light_samples.points.len());
    let exact_views = if table_bins.is_some() && light_samples.points.len() > 1 {
        mark_too_near_for_the_table(&mut view, center, radius)
    } else {
        0
    };
    stats.set("exact_view_samples", exact_views as f64);
    let cut = opts.cut_at_supporting_plane.then_some(Cut {
        bias: f64::from(opts.bias),
        front_only: inside == 0,
    });
    let casters = stats.time_add("rasterization", || {
        CasterSet::prepare(
            scene,
            &bounds,
            &frustum,
            opts,
            opaque_only,
            inside > 0,
            (center, radius),
            cut,
        )
    });
    stats.set("casters", casters.prepared.len() as f64);
    let penumbra = if opts.restrict_to_penumbra && light_samples.points.len() > 1 {
        let (flags, silhouettes) = stats.time_add("rasterization", || {
            penumbra_texels(
                scene,
                &bounds,
                &frustum,
                &casters,
                opts.hull_degree,
                (center, radius),
            )
        });
        stats.set("silhouette_edges", silhouettes as f64);
        stats.set(
            "penumbra_texels_percent",
            100.0 * flags.iter().filter(|&&f| f).count() as f64 / flags.len() as f64,
        );
        Some(flags)
    } else {
        stats.set("penumbra_texels_percent", 100.0);
        None
    };
    // The table's distances span the light and every sample (a plane past them all leaves the
    // center to decide, which is right only for planes that miss every sample).
    let extent = f64::from(bounds.reach());
    let lut = match table_bins {
        Some(bins)
            if light_samples.points.len() > 1 && extent > 0.0 && exact_views < view.len() =>
        {
            Some(Lut::new(&light_samples, center, extent, bins)?)
        }
        _ => None,
    };
    stats.set("lut_bins", lut.as_ref().map_or(0.0, |t| t.grid.bins as f64));
    // The exact tests read a bracketing table when there are enough of them to repay its build.
    let exactly_tested = if table_bins.is_some() {
        exact_views
    } else {
        view.len()
    };
    let brackets = match exactly_tested >= BRACKETS_MIN_VIEW_SAMPLES
        && light_samples.points.len() > 1
        && extent > 0.0
        && opts.backend == Backend::Cpu
    {
        true => Some(BracketTable::new(&light_samples, center, extent)?),
        false => None,
    };
    let setup = TexelTests {
        scene,
        bounds: &bounds,
        hull_degree: opts.hull_degree,
        frustum,
        points: &points,
        view: &view,
        casters: &casters,
        penumbra: penumbra.as_deref(),
        samples: &light_samples,
        lut: lut.as_ref(),
        brackets: brackets.as_ref(),
        center,
        radius,
        full: light_samples.full_mask(),
        cut,
    };
    let masks = match opts.backend {
        Backend::Cpu => cpu_masks(&setup, stats)?,
        Backend::Gpu => {
            // The shaders do not count their tests: NaN says "not counted", where 0 would lie.
            stats.set("pair_tests", f64::NAN);
            stats.set("plane_mask_ops", f64::NAN);
            gpu::masks(&setup, stats)?
        }
    };
    for (k, s) in view.iter().enumerate() {
        let r = s.receiver as usize;
        out.masks[r * words..(r + 1) * words].copy_from_slice(&masks[k * words..(k + 1) * words]);
    }
    Ok(out)
}

/// Everything the per-texel tests read (sections 3.3 and 4.2), set up on the CPU for either
/// backend: the view samples and their points, the lists' frustum, the casters with their
/// influence regions on its far plane, the penumbra texels, the light samples and the table.
pub(crate) struct TexelTests<'a> {
    pub scene: &'a Scene,
    /// The light and the bounds of it and its samples, from which the influence regions are
    /// projected.
    pub bounds: &'a LightBounds<'a>,
    /// Sides of the light's bounding polygons.
    pub hull_degree: usize,
    pub frustum: LightFrustum,
    pub points: &'a [Vec3],
    pub view: &'a [ViewSample],
    pub casters: &'a CasterSet,
    /// Per texel, whether it may hold penumbra (`None`: every texel may).
    pub penumbra: Option<&'a [bool]>,
    pub samples: &'a LightSamples,
    pub lut: Option<&'a Lut>,
    /// The exact tests' bracketing table, where one was built (the CPU's).
    pub brackets: Option<&'a BracketTable>,
    /// The light's center and the radius of a sphere about it holding every sample (a hair more
    /// than the light's extent, against round-off).
    pub center: DVec3,
    pub radius: f64,
    /// The mask of every light sample.
    pub full: Vec<u64>,
    /// The supporting-plane cut of the influence regions (section 4.3), if on.
    pub cut: Option<Cut>,
}

/// The settings of the supporting-plane cut ([`cut_at_supporting_plane`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cut {
    /// The receivers' offset along their normal: how far a moved receiver may cross a plane.
    pub bias: f64,
    /// Whether front-only casters are tested from their front alone (no view sample lies inside
    /// a closed mesh, from where every closed triangle is tested from either side).
    pub front_only: bool,
}

impl TexelTests<'_> {
    /// The casters' projections from the light's center on the lists' map: the regions of
    /// [`Pass::Center`]. Errors: none for a light center that [`Light::point`] takes.
    fn center_regions(&self) -> Result<Vec<Option<Vec<DVec2>>>> {
        let point = Light::point(self.bounds.light.center())?;
        let bounds = LightBounds::of_light(&point);
        Ok(self
            .casters
            .raw
            .par_iter()
            .map(|c| influence_hull(&self.frustum, &bounds, &c.vertices, 1))
            .collect())
    }

    /// `hull` (on `frustum`'s far plane) cut at caster `t`'s supporting plane, if the cut is on.
    fn cut(&self, hull: Vec<DVec2>, frustum: &LightFrustum, t: &Prepared) -> Vec<DVec2> {
        cut_at_supporting_plane(hull, frustum, t, (self.center, self.radius), self.cut)
    }
}

/// The part of an influence region `hull` (texel coordinates of `frustum`'s map, on its far
/// plane) where caster `t` may block a sample (Sintorn et al. 2008, section 4.3: the region cut
/// off at the triangle's supporting plane). A triangle blocks a sample only from a point on the
/// other side of its plane: when every sample lies on one side (the ball `(center, radius)` does,
/// beyond the receivers' offset), the receivers it may shadow lie on the other side or within the
/// offset of the plane. A front-only caster (a closed mesh's triangle under back-face culling)
/// blocks only from points strictly in front of it, wherever the samples lie. A receiver on the
/// ray from the center through texel point `s`, no deeper than the far plane, lies on a side of
/// the plane that the center does not lie on only if the ray's far point does (the distance to
/// the plane varies linearly along the ray): an affine condition on `s`, kept with a margin of a
/// hundredth of a texel and of the f32 round-off of the receivers' projections. Without a `cut`
/// (the option off), the region as it is.
fn cut_at_supporting_plane(
    hull: Vec<DVec2>,
    frustum: &LightFrustum,
    t: &Prepared,
    (center, radius): (DVec3, f64),
    cut: Option<Cut>,
) -> Vec<DVec2> {
    let Some(cut) = cut else {
        return hull;
    };
    if hull.is_empty() {
        return hull;
    }
    let unit = t.normal / t.normal.length();
    let (far, w, h) = (
        f64::from(frustum.far),
        frustum.width as f64,
        frustum.height as f64,
    );
    let (tx, ty) = (f64::from(frustum.tan_half_x), f64::from(frustum.tan_half_y));
    // n · (eye + far · texel_ray(s) − v0) = a · s + a0 for a unit normal n, and its margin.
    let far_side = |n: DVec3| {
        let [nf, nr, nu] =
            [frustum.forward, frustum.right, frustum.up].map(|axis| n.dot(axis.as_dvec3()));
        let a = DVec2::new(far * nr * 2.0 * tx / w, -far * nu * 2.0 * ty / h);
        let a0 = n.dot(center - t.v[0]) + far * (nf - nr * tx + nu * ty);
        let slack = 0.01 * a.length() + 1e-5 * far * (1.0 + tx + ty) + 1e-9 * a0.abs();
        (a, a0, slack)
    };
    // `-center_distance`: the center's signed distance from the plane along `unit`.
    let behind = -t.center_distance < -1e-9 * (center - t.v[0]).length();
    if cut.front_only && t.front_only && behind {
        let (a, a0, slack) = far_side(unit);
        return clip_affine(&hull, |s| a.dot(s) + a0 + slack);
    }
    if t.center_distance.abs() <= radius.max(cut.bias) * (1.0 + 1e-6) {
        return hull;
    }
    // The unit normal towards the samples: a receiver there within the offset of the plane.
    let (a, a0, slack) = far_side(unit * -t.center_distance.signum());
    clip_affine(&hull, |s| slack + cut.bias - (a.dot(s) + a0))
}

/// The bitmask of every view sample (view order) on the CPU: the lists, then bands of rows in
/// parallel over the casters binned to them. With the penumbra restriction, the view samples of
/// the penumbra texels and the others go to two sets of lists, tested by a [`Pass::Samples`] and
/// a [`Pass::Center`] pass. Errors: interrupted.
fn cpu_masks(setup: &TexelTests<'_>, stats: &mut Stats) -> Result<Vec<u64>> {
    let frustum = setup.frustum;
    let in_penumbra = |texel: usize| setup.penumbra.is_none_or(|flags| flags[texel]);
    let (penumbra, elsewhere) = stats.time_add("list_build", || {
        (
            ReceiverLists::with_frustum_where(frustum, setup.points, in_penumbra),
            setup.penumbra.map(|_| {
                ReceiverLists::with_frustum_where(frustum, setup.points, |t| !in_penumbra(t))
            }),
        )
    });
    let lengths = |l: &ReceiverLists, t: usize| l.start[t + 1] - l.start[t];
    record_list_stats(
        (0..frustum.width * frustum.height)
            .map(|t| lengths(&penumbra, t) + elsewhere.as_ref().map_or(0, |l| lengths(l, t))),
        stats,
    );
    let centers = match &elsewhere {
        Some(_) => stats.time_add("rasterization", || setup.center_regions())?,
        None => Vec::new(),
    };
    let mut passes = vec![(&penumbra, Pass::Samples, setup.casters.hulls.as_slice())];
    if let Some(lists) = &elsewhere {
        passes.push((lists, Pass::Center, centers.as_slice()));
    }
    let band_frustums: Vec<Option<LightFrustum>> = (0..penumbra.bands())
        .map(|b| {
            let rows = penumbra.rows(b);
            passes
                .iter()
                .filter_map(|(lists, _, _)| lists.band_frustum(&rows))
                .max_by(|a, b| a.far.total_cmp(&b.far))
        })
        .collect();
    let words = setup.full.len();
    let mut by_view = vec![0u64; setup.view.len() * words];
    for (lists, pass, regions) in passes {
        let tester = stats.time_add("rasterization", || {
            Tester::new(setup, lists, pass, regions, &band_frustums)
        });
        let mut masks = initial_masks(lists, setup.view, setup.samples, setup.center);
        stats
            .time_add("visibility", || tester.run(&mut masks))?
            .record(stats);
        for (e, &i) in lists.entries.iter().enumerate() {
            let i = i as usize;
            by_view[i * words..(i + 1) * words].copy_from_slice(&masks[e * words..(e + 1) * words]);
        }
    }
    Ok(by_view)
}

/// The light samples of `samples` (one bit each; the light's center for a point light), after
/// checking that one shared pattern of 1 to [`MAX_SAMPLES`] samples is asked for.
fn light_samples(light: &Light, samples: &SampleSet) -> Result<LightSamples> {
    if !samples.is_single_pattern() {
        return Err(Error::invalid("interleaved", "alias_free shares one sample pattern (one bitmask layout) across receivers: interleaving does not apply"));
    }
    let rotated = samples.rotates();
    if rotated && (light.rigid_rotation([0.0; 3]).is_none() || light.is_textured()) {
        return Err(Error::invalid(
            "rotate",
            "per-receiver rotation needs a symmetric, untextured light (point, disk, sphere): its lookups rotate the planes, not the samples; pass rotate=None to share one pattern (with stsv, opaque=\"dcs\" rotates for every light)",
        ));
    }
    let ys = samples.pattern_for(0, 0);
    if ys.is_empty() || ys.len() > MAX_SAMPLES {
        return Err(Error::invalid(
            "samples",
            format!("needs 1..={MAX_SAMPLES} light samples, got {}", ys.len()),
        ));
    }
    let point = matches!(light.shape, Shape::Point { .. });
    // A point light's one bit is its position (rotations map every sample there): samples
    // elsewhere would be ignored, and the result would not be `ray_traced`'s on them.
    if point && !rotated && ys.iter().any(|&y| y != light.center()) {
        return Err(Error::unsupported(
            "samples",
            "alias_free tests a point light at its position only; pass samples at the position (or a count), or a SphereLight for samples around it",
        ));
    }
    let points: Vec<DVec3> = if point {
        vec![light.center().as_dvec3()]
    } else {
        ys.iter().map(|y| y.as_dvec3()).collect()
    };
    Ok(LightSamples {
        weights: points
            .iter()
            .map(|y| f64::from(light.weight(y.as_vec3())))
            .collect(),
        words: points.len().div_ceil(64),
        points,
    })
}

/// The view samples: valid receivers that face some part of the light or some sample (depths
/// set later).
fn view_samples(
    light: &Light,
    bounds: &LightBounds<'_>,
    receivers: &Receivers,
    samples: &SampleSet,
    bias: f32,
) -> Vec<ViewSample> {
    let center = light.center().as_dvec3();
    let extent = f64::from(bounds.reach());
    let point = |i: usize| {
        (
            receivers.points[i].as_dvec3(),
            receivers.normals[i].as_dvec3(),
        )
    };
    let faces_the_light = |(p, n): (DVec3, DVec3)| {
        n.dot(center - p) > -extent * n.length() && (center - p).length_squared() > 0.0
    };
    // The receivers kept first, so that the view samples (tens of megabytes) are written once,
    // in place, by an indexed parallel pass.
    let kept: Vec<usize> = (0..receivers.len())
        .into_par_iter()
        .filter(|&i| receivers.valid[i] && faces_the_light(point(i)))
        .collect();
    kept.into_par_iter()
        .map(|i| {
            let (p, n) = point(i);
            let rotation = samples
                .rotation_for(i)
                .and_then(|r| light.rigid_rotation(r))
                .map(|m| m.as_dmat3().transpose());
            ViewSample {
                receiver: i as u32,
                p,
                moved: p + n * f64::from(bias),
                n,
                rotation,
                inside: false,
                exact_planes: false,
            }
        })
        .collect()
}

/// Flags the view samples whose moved point lies inside a closed mesh (see the module doc,
/// step 4, and [`inside_closed_meshes`]) and returns their number.
fn mark_inside_closed_meshes(
    scene: &Scene,
    bvh: SceneBvh<'_>,
    view: &mut [ViewSample],
    bias: f32,
) -> Result<usize> {
    let receivers: Vec<(DVec3, DVec3)> = view.iter().map(|s| (s.p, s.n)).collect();
    let inside = inside_closed_meshes(scene, &receivers, f64::from(bias), || {
        bvh.get(scene).map(Cow::Borrowed)
    })?;
    for (s, inside) in view.iter_mut().zip(inside) {
        s.inside = inside;
    }
    Ok(view.iter().filter(|s| s.inside).count())
}

/// Flags the view samples too near the light for the table (their distance from the light's
/// center under `radius / TABLE_MAX_SPREAD`, see [`TABLE_MAX_SPREAD`]) and returns their number.
fn mark_too_near_for_the_table(view: &mut [ViewSample], center: DVec3, radius: f64) -> usize {
    view.iter_mut().fold(0, |count, s| {
        s.exact_planes = radius > TABLE_MAX_SPREAD * (s.p - center).length();
        count + usize::from(s.exact_planes)
    })
}

/// The initial bitmask of every list entry: the samples behind its view sample's tangent plane
/// are blocked (`docs/design.md` section 3).
fn initial_masks(
    lists: &ReceiverLists,
    view: &[ViewSample],
    samples: &LightSamples,
    center: DVec3,
) -> Vec<u64> {
    let words = samples.words;
    let behind = BehindPlane::new(samples, center);
    let isa = Isa::detect();
    let mut masks = vec![0u64; lists.entries.len() * words];
    masks
        .par_chunks_mut(words)
        .zip(&lists.entries)
        .for_each(|(m, &e)| behind.mask_on(isa, &view[e as usize], m));
    masks
}

/// The light samples behind a view sample's tangent plane, 64 samples (a mask word) at a time in
/// lane loops compiled for the widest instruction set ([`isa_dispatch`]): per axis, the samples
/// and their offsets from the light's center (from which a rotated view sample's rotation turns
/// them). Each lane does the IEEE operations of `s.n.dot(rotate_about(center, s.rotation, y) -
/// s.p) <= 0.0`, in their order, so the bits are those of that test sample by sample.
struct BehindPlane {
    points: [Vec<f64>; 3],
    offsets: [Vec<f64>; 3],
    center: DVec3,
    count: usize,
}

impl BehindPlane {
    fn new(samples: &LightSamples, center: DVec3) -> Self {
        // Per axis, padded to whole words (the padding's bits are cleared after the test).
        let per_axis = |points: &[DVec3]| {
            [0, 1, 2].map(|a| {
                let mut v: Vec<f64> = points.iter().map(|y| y[a]).collect();
                v.resize(samples.words * 64, 0.0);
                v
            })
        };
        let offsets: Vec<DVec3> = samples.points.iter().map(|&y| y - center).collect();
        Self {
            points: per_axis(&samples.points),
            offsets: per_axis(&offsets),
            center,
            count: samples.points.len(),
        }
    }

    isa_dispatch! {
        /// Sets in `mask` the bits of the samples behind `s`'s tangent plane:
        /// [`Self::mask_body`] compiled for `isa`.
        fn mask_on(&BehindPlane) => mask_body(s: &ViewSample, mask: &mut [u64]) -> ()
    }

    #[inline(always)]
    fn mask_body(&self, s: &ViewSample, mask: &mut [u64]) {
        let rotation = s.rotation.map(|rt| rt.transpose());
        for (w, word) in mask.iter_mut().enumerate() {
            let at = w * 64..(w + 1) * 64;
            let dots = match rotation {
                None => plane_values(
                    s,
                    [
                        &self.points[0][at.clone()],
                        &self.points[1][at.clone()],
                        &self.points[2][at],
                    ],
                ),
                Some(r) => {
                    let [x, y, z] = &self.offsets;
                    rotated_plane_values(
                        s,
                        self.center,
                        r,
                        [&x[at.clone()], &y[at.clone()], &z[at]],
                    )
                }
            };
            let mut bits = 0u64;
            for (l, &dot) in dots.iter().enumerate() {
                bits |= u64::from(dot <= 0.0) << l;
            }
            *word |= bits & valid_bits(w, self.count);
        }
    }
}

/// `s.n.dot(y - s.p)` for 64 samples `y` given per axis.
#[inline(always)]
fn plane_values(s: &ViewSample, [x, y, z]: [&[f64]; 3]) -> [f64; 64] {
    let (n, p) = (s.n, s.p);
    let mut dots = [0.0; 64];
    for (l, dot) in dots.iter_mut().enumerate() {
        *dot = n.x * (x[l] - p.x) + n.y * (y[l] - p.y) + n.z * (z[l] - p.z);
    }
    dots
}

/// `s.n.dot(center + r * d - s.p)` for 64 offsets `d` from the center given per axis, with the
/// matrix product in glam's order (`r.x_axis * d.x + r.y_axis * d.y + r.z_axis * d.z`).
#[inline(always)]
fn rotated_plane_values(s: &ViewSample, c: DVec3, r: DMat3, [x, y, z]: [&[f64]; 3]) -> [f64; 64] {
    let (n, p) = (s.n, s.p);
    let mut dots = [0.0; 64];
    for (l, dot) in dots.iter_mut().enumerate() {
        let (dx, dy, dz) = (x[l], y[l], z[l]);
        let qx = c.x + (r.x_axis.x * dx + r.y_axis.x * dy + r.z_axis.x * dz);
        let qy = c.y + (r.x_axis.y * dx + r.y_axis.y * dy + r.z_axis.y * dz);
        let qz = c.z + (r.x_axis.z * dx + r.y_axis.z * dy + r.z_axis.z * dz);
        *dot = n.x * (qx - p.x) + n.y * (qy - p.y) + n.z * (qz - p.z);
    }
    dots
}

/// The casting triangles, prepared, with their influence regions on the lists' far plane (`None`:
/// the whole map).
pub(crate) struct CasterSet {
    pub raw: Vec<Caster>,
    pub prepared: Vec<Prepared>,
    pub hulls: Vec<Option<Vec<DVec2>>>,
}
impl CasterSet {
    /// The casters of `scene` for the light of `bounds` (see the module documentation, step 4)
    /// and their influence regions in the lists' `frustum`, which bound the light's samples too
    /// (cut at their supporting planes, with `cut`); with `any_inside`,
    /// the culled closed triangles too, for the view samples inside. The samples lie within
    /// `radius` of the light's `center`.
    #[allow(clippy::too_many_arguments)]
    fn prepare(
        scene: &Scene,
        bounds: &LightBounds<'_>,
        frustum: &LightFrustum,
        opts: &AliasFreeOptions,
        opaque_only: bool,
        any_inside: bool,
        (center, radius): (DVec3, f64),
        cut: Option<Cut>,
    ) -> CasterSet {
        let point = matches!(bounds.light.shape, Shape::Point { .. });
        let filter = match opts.caster_faces {
            CasterFaces::Backfacing if point => FaceFilter::BackFacingIfClosed,
            _ => FaceFilter::All,
        };
        let gathered = if any_inside { FaceFilter::All } else { filter };
        let mut raw = casters(
            scene,
            &RasterOptions {
                mode: RasterMode::Conservative,
                faces: gathered,
                alpha_test: true,
            },
            frustum.eye,
        );
        let front_only = |id: u32| {
            opts.caster_faces == CasterFaces::Backfacing && !point && scene.is_closed_face(id)
        };
        // A closed triangle facing every point of the light and every sample is back-facing to no
        // sample: it casts nothing, but for the view samples inside a closed mesh.
        let culled = |id: u32, t: &[Vec3; 3]| {
            (front_only(id) && faces_whole_light(bounds, t))
                || !filter.keeps(scene, id, t, frustum.eye)
        };
        // With `opaque_only`, perforated casters are left to `stsv`.
        let left_out = |id: u32, t: &[Vec3; 3], alpha: bool| {
            (!any_inside && culled(id, t)) || (opaque_only && alpha)
        };
        raw.retain(|c| !left_out(c.face, &c.vertices, c.alpha_tested));
        let prepared = raw
            .iter()
            .map(
                |&Caster {
                     face: id,
                     vertices: t,
                     alpha_tested: alpha,
                 }| {
                    let v = t.map(|p| p.as_dvec3());
                    // Closed casters under culling skip the offset (section 3.3), for area lights too:
                    // a closed triangle blocks only from receivers strictly in front of its plane
                    // (`front_only`), so never the surface a receiver lies on.
                    let moved = opts.caster_faces == CasterFaces::All || !scene.is_closed_face(id);
                    let near_depth = t
                        .iter()
                        .map(|p| f64::from(frustum.to_view(*p).z))
                        .fold(f64::INFINITY, f64::min);
                    let culled = any_inside && culled(id, &t);
                    let normal = (v[1] - v[0]).cross(v[2] - v[0]);
                    Prepared {
                        id,
                        v,
                        normal,
                        alpha,
                        moved,
                        front_only: front_only(id),
                        culled,
                        near_depth,
                        center_distance: (normal.dot(v[0]) - normal.dot(center))
                            * (1.0 / normal.length()),
                    }
                },
            )
            .collect::<Vec<Prepared>>();
        let hulls = raw
            .par_iter()
            .zip(&prepared)
            .map(|(c, t)| {
                influence_hull(frustum, bounds, &c.vertices, opts.hull_degree)
                    .map(|hull| cut_at_supporting_plane(hull, frustum, t, (center, radius), cut))
            })
            .collect();
        CasterSet {
            raw,
            prepared,
            hulls,
        }
    }
}

/// The penumbra restriction of section 4.3: flags the texels that the influence region of a
/// potential silhouette edge of the ball `(center, radius)` around the samples (see
/// [`crate::geometry::edges`]) or of a perforated caster reaches, on the far plane (which holds
/// the regions at every nearer depth). A view sample in any other texel sees every sample, and
/// the light's center, blocked or none: both the ball and `bounds` hold the center and every
/// sample, and so the segment between them. Returns the flags and the number of silhouette edges.
fn penumbra_texels(
    scene: &Scene,
    bounds: &LightBounds<'_>,
    frustum: &LightFrustum,
    casters: &CasterSet,
    degree: usize,
    (center, radius): (DVec3, f64),
) -> (Vec<bool>, usize) {
    let (w, h) = (frustum.width, frustum.height);
    let silhouettes: Vec<Edge> = edges(scene)
        .into_iter()
        .filter(|e| e.is_potential_silhouette(center, radius))
        .collect();
    let edge_hulls = silhouettes
        .par_iter()
        .map(|e| influence_hull(frustum, bounds, &e.ends, degree));
    let perforated = casters
        .raw
        .iter()
        .zip(&casters.hulls)
        .filter(|(c, _)| c.alpha_tested)
        .map(|(_, hull)| hull.clone());
    let hulls: Option<Vec<Vec<DVec2>>> = edge_hulls
        .collect::<Vec<_>>()
        .into_iter()
        .chain(perforated)
        .collect();
    let Some(hulls) = hulls else {
        return (vec![true; w * h], silhouettes.len());
    };
    // The map is marked in parallel by runs of rows, each run over the spans of the regions
    // that reach it (millions of spans in all, each texel under hundreds, crowded in a few rows:
    // the runs are cut to about equal numbers of regions, few enough that a region meets few):
    // a span counts one up at its first column and one down past its last, and a texel is
    // marked where the running count along its row is positive.
    let row_ranges: Vec<Option<(usize, usize)>> = hulls
        .par_iter()
        .map(|hull| conservative_row_range(hull, h).map(|(first, last)| (first, last + 1)))
        .collect();
    let runs = balanced_runs(&row_ranges, h, 4 * rayon::current_num_threads());
    let bins = bin_to_runs(&row_ranges, &runs);
    let mut flags = vec![false; w * h];
    let mut parts = Vec::with_capacity(runs.len());
    let mut rest = flags.as_mut_slice();
    for rows in &runs {
        let (part, tail) = rest.split_at_mut(rows.len() * w);
        parts.push((rows.clone(), part));
        rest = tail;
    }
    parts
        .into_par_iter()
        .zip(&bins)
        .with_max_len(1)
        .for_each(|((rows, part), bin)| {
            let mut steps = vec![0i32; rows.len() * (w + 1)];
            let mut span_bounds = Vec::new();
            for &i in bin {
                for (y, x0, x1) in
                    conservative_spans(&hulls[i as usize], rows.clone(), w, &mut span_bounds)
                {
                    let at = (y - rows.start) * (w + 1);
                    steps[at + x0] += 1;
                    steps[at + x1] -= 1;
                }
            }
            for (row, steps) in part.chunks_mut(w).zip(steps.chunks(w + 1)) {
                let mut open = 0;
                for (flag, step) in row.iter_mut().zip(steps) {
                    open += step;
                    *flag = open > 0;
                }
            }
        });
    (flags, silhouettes.len())
}

/// The CPU's work counters of the per-texel tests (the stats `pair_tests`, `plane_mask_ops`).
#[derive(Debug, Clone, Copy, Default)]
struct Work {
    pair_tests: u64,
    plane_mask_ops: u64,
}

impl Work {
    fn plus(self, other: Work) -> Work {
        Work {
            pair_tests: self.pair_tests + other.pair_tests,
            plane_mask_ops: self.plane_mask_ops + other.plane_mask_ops,
        }
    }

    fn record(&self, stats: &mut Stats) {
        stats.add("pair_tests", self.pair_tests as f64);
        stats.add("plane_mask_ops", self.plane_mask_ops as f64);
    }
}

/// Which test a pass of the CPU's per-texel tests makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// Every sample, over the casters' influence regions (cut at their supporting planes).
    Samples,
    /// The light's center alone, for view samples outside every penumbra (section 4.3), over the
    /// casters' projections from the center: all of the light is blocked or none, and a caster
    /// that blocks the center covers the view sample's texel in its projection. Perforated
    /// casters, whose texture cuts anywhere, test every sample still.
    Center,
}

/// The CPU's per-texel tests of one pass over its lists, with the casters binned by bands of rows.
struct Tester<'a> {
    setup: &'a TexelTests<'a>,
    lists: &'a ReceiverLists,
    pass: Pass,
    /// Per caster, its region on the lists' far plane (`None`: the whole map): the influence
    /// region for [`Pass::Samples`] (recomputed per band on the band's far plane), the
    /// projection from the light's center for [`Pass::Center`].
    regions: &'a [Option<Vec<DVec2>>],
    bins: Vec<Vec<u32>>,
    /// Per band, the frustum whose far plane holds every view sample of its rows, in both
    /// passes' lists (`None`: none): the regions of a band are projected there, as the GPU's
    /// are, so that the two backends test the very same pairs (the table's bits depend on them).
    band_frustums: &'a [Option<LightFrustum>],
    /// The lists' view samples copied in list order (see [`Entry`]).
    entries: Vec<Entry>,
}

impl<'a> Tester<'a> {
    fn new(
        setup: &'a TexelTests<'a>,
        lists: &'a ReceiverLists,
        pass: Pass,
        regions: &'a [Option<Vec<DVec2>>],
        band_frustums: &'a [Option<LightFrustum>],
    ) -> Self {
        Tester {
            setup,
            lists,
            pass,
            regions,
            bins: lists.bin(regions),
            band_frustums,
            entries: Entry::of(lists, setup.view, setup.radius),
        }
    }

    /// Tests every band of rows in parallel, each over its own part of `masks` (the bitmasks of
    /// the list entries, in list order), returning the work done. Errors: interrupted (each
    /// band stops at its next caster once the call is asked to stop).
    fn run(&self, masks: &mut [u64]) -> Result<Work> {
        let parts = self.lists.split_by_band(masks, self.setup.full.len());
        let watch = crate::interrupt::watch();
        let work = parts
            .map(|(b, rows, base, band_masks)| self.band(b, rows, base, band_masks, &watch))
            .reduce(Work::default, Work::plus);
        crate::interrupt::check()?;
        Ok(work)
    }

    /// The region of caster `c` over the receivers of rows `rows`, whose far plane is
    /// `band_frustum`'s (`Some(None)`: the whole map); `None` where no texel of those rows within
    /// a texel of the region's bounding box holds a view sample. Most casters binned to a band
    /// meet none of the penumbra's sparse view samples there: they are passed over on the
    /// bounding box of the region's points, before its hull is built and cut.
    fn region(
        &self,
        c: usize,
        band_frustum: &LightFrustum,
        rows: &Range<usize>,
    ) -> Option<Option<Vec<DVec2>>> {
        let setup = self.setup;
        let points = match (&self.regions[c], self.pass) {
            (None, _) => return Some(None),
            (Some(hull), Pass::Center) => Cow::Borrowed(hull.as_slice()),
            (Some(_), Pass::Samples) => match influence_points(
                band_frustum,
                setup.bounds,
                &setup.casters.raw[c].vertices,
                setup.hull_degree,
            ) {
                None => return Some(None),
                Some(points) => Cow::Owned(points),
            },
        };
        let (w, h) = (self.lists.frustum.width, self.lists.frustum.height);
        let (box_rows, columns) = texel_box(&points, w, h);
        let rows = box_rows.start.max(rows.start)..box_rows.end.min(rows.end);
        if !self.lists.any_entry_in(&rows, &columns) {
            return None;
        }
        Some(Some(match self.pass {
            Pass::Center => points.into_owned(),
            Pass::Samples => setup.cut(
                convex_hull(&points),
                band_frustum,
                &setup.casters.prepared[c],
            ),
        }))
    }

    /// Tests the casters binned to band `b` (rows `rows`, list entries from `base` on) against
    /// the view samples of its lists.
    fn band(
        &self,
        b: usize,
        rows: std::ops::Range<usize>,
        base: usize,
        band_masks: &mut [u64],
        watch: &crate::interrupt::Watch,
    ) -> Work {
        let setup = self.setup;
        let (words, full) = (setup.full.len(), &setup.full);
        let (lists, view, casters) = (self.lists, setup.view, setup.casters);
        let mut buffers = Buffers::new(words);
        let mut work = Work::default();
        let Some(band_frustum) = self.band_frustums[b] else {
            return work;
        };
        let center = setup.center;
        let unrotated = self.unrotated_planes();
        let entries = &self.entries;
        let (mut lanes, mut span_bounds) = (Lanes::new(), Vec::new());
        for &c in self.bins[b].iter().take_while(|_| !watch.requested()) {
            let Some(region) = self.region(c as usize, &band_frustum, &rows) else {
                continue;
            };
            let t = &casters.prepared[c as usize];
            let center_only = self.pass == Pass::Center && !t.alpha;
            let supporting = Supporting::new(t, &unrotated);
            let caster_lanes = CasterLanes::new(t, &supporting, &unrotated);
            let slack = 1e-9 * t.near_depth.abs();
            for span in lists.spans(region.as_deref(), &rows, &mut span_bounds) {
                for e in lists.span_entries(span) {
                    let m = &mut band_masks[(e - base) * words..(e - base + 1) * words];
                    let s = &entries[e];
                    // Wholly beyond both the receiver and the light: it cannot cut their segment.
                    if (t.culled && !s.inside) || t.near_depth > s.reach + slack || is_full(m, full)
                    {
                        continue;
                    }
                    work.pair_tests += 1;
                    if !(center_only || s.inside || s.rotated) {
                        let p = if t.moved { s.moved } else { s.p };
                        if !caster_lanes.may_block_from(p) {
                            continue;
                        }
                        if lanes.push(e, p) {
                            let band = BandMasks {
                                masks: band_masks,
                                base,
                                words,
                            };
                            let (caster, buffers) = (&caster_lanes, &mut buffers);
                            self.test_lanes(
                                caster,
                                &supporting,
                                &mut lanes,
                                band,
                                buffers,
                                &mut work,
                            );
                        }
                        continue;
                    }
                    let from_inside;
                    let t = if s.inside {
                        from_inside = t.seen_from_inside();
                        &from_inside
                    } else {
                        t
                    };
                    let p = if t.moved { s.moved } else { s.p };
                    if center_only {
                        if blocks_point(t, p, center) {
                            m.copy_from_slice(full);
                        }
                        continue;
                    }
                    let rotation = match s.rotated {
                        true => view[s.view as usize].rotation,
                        false => None,
                    };
                    let planes = Planes {
                        rotation,
                        lut: setup.lut.filter(|_| !s.exact_planes),
                        ..unrotated
                    };
                    if blocked_by(t, p, &supporting, &planes, full, &mut buffers, &mut work) {
                        self.add_blocked(t, p, rotation, &mut buffers.blocked, m);
                    }
                }
            }
            let band = BandMasks {
                masks: band_masks,
                base,
                words,
            };
            self.test_lanes(
                &caster_lanes,
                &supporting,
                &mut lanes,
                band,
                &mut buffers,
                &mut work,
            );
        }
        work
    }

    /// The plane masks of the samples as the setup's tables serve them, unrotated.
    fn unrotated_planes(&self) -> Planes<'a> {
        let setup = self.setup;
        Planes {
            samples: setup.samples,
            lut: setup.lut,
            brackets: setup.brackets,
            center: setup.center,
            radius: setup.radius,
            rotation: None,
        }
    }

    /// Tests the caster of `caster` (its supporting plane set up in `supporting`) against the
    /// view samples of `lanes`, side by side ([`lanes`]), adding the samples it blocks to their
    /// masks; empties `lanes`.
    fn test_lanes(
        &self,
        caster: &CasterLanes<'_>,
        supporting: &Supporting<'a>,
        lanes: &mut Lanes,
        band: BandMasks<'_>,
        buffers: &mut Buffers,
        work: &mut Work,
    ) {
        let (setup, t) = (self.setup, caster.t);
        if lanes.entries().is_empty() {
            return;
        }
        lanes.find_planes(caster);
        let unrotated = self.unrotated_planes();
        let mut pair = PairPlanes::new();
        for (l, &e) in lanes.entries().iter().enumerate() {
            let s = &self.entries[e];
            let lut = setup.lut.filter(|_| !s.exact_planes);
            let blocked = match lut {
                Some(lut) => lanes
                    .codes(l, supporting)
                    .is_some_and(|(codes, straddling)| {
                        work.plane_mask_ops += straddling;
                        lut.below_all(codes, &mut buffers.blocked)
                    }),
                None => {
                    let planes = Planes { lut, ..unrotated };
                    lanes.pair(l, supporting, &mut pair)
                        && below_all_planes(&pair, &planes, &setup.full, buffers, work)
                }
            };
            if blocked {
                let p = if t.moved { s.moved } else { s.p };
                let m = &mut band.masks[(e - band.base) * band.words..][..band.words];
                self.add_blocked(t, p, None, &mut buffers.blocked, m);
            }
        }
        lanes.clear();
    }

    /// Adds to view sample `p`'s mask `m` the samples `blocked` by caster `t`, those whose
    /// segment crosses a transparent texel cleared first (`rotation`: the transpose of the view
    /// sample's samples' rotation).
    fn add_blocked(
        &self,
        t: &Prepared,
        p: DVec3,
        rotation: Option<DMat3>,
        blocked: &mut [u64],
        m: &mut [u64],
    ) {
        let setup = self.setup;
        if t.alpha {
            alpha_test(
                setup.scene,
                t,
                p,
                setup.samples,
                |y| rotate_about(setup.center, rotation, y),
                blocked,
            );
        }
        m.iter_mut().zip(blocked.iter()).for_each(|(a, b)| *a |= b);
    }
}

/// A band's part of the masks of the list entries: entry `e`'s at `(e − base) · words`.
struct BandMasks<'a> {
    masks: &'a mut [u64],
    base: usize,
    words: usize,
}

/// A list entry's view sample as the per-texel tests read it. The lists point into the view
/// samples at random; these copies lie in list order, so that a span's entries are read in turn.
#[derive(Debug, Clone, Copy)]
struct Entry {
    p: DVec3,
    moved: DVec3,
    /// Its depth in the lists' frustum, or the light's radius where larger: a caster nearer
    /// than neither cannot cut a segment from it to the light.
    reach: f64,
    /// Its index among the view samples, whose rotation is read only where `rotated`.
    view: u32,
    inside: bool,
    rotated: bool,
    exact_planes: bool,
}

impl Entry {
    /// The entries of `lists`, in list order.
    fn of(lists: &ReceiverLists, view: &[ViewSample], radius: f64) -> Vec<Entry> {
        lists
            .entries
            .par_iter()
            .map(|&i| {
                let s = &view[i as usize];
                Entry {
                    p: s.p,
                    moved: s.moved,
                    reach: lists.depths[i as usize].max(radius),
                    view: i,
                    inside: s.inside,
                    rotated: s.rotation.is_some(),
                    exact_planes: s.exact_planes,
                }
            })
            .collect()
    }
}

/// Sample `y` rotated about `center` by the rotation whose transpose is `rotation`.
fn rotate_about(center: DVec3, rotation: Option<DMat3>, y: DVec3) -> DVec3 {
    match rotation {
        Some(rt) => center + rt.transpose() * (y - center),
        None => y,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::influence::light_points;
    use crate::light::sampling::Rng;

    #[test]
    fn the_lanes_find_the_samples_behind_each_tangent_plane() {
        // 1 to 300 samples (spare lanes in the last word), view samples with and without a
        // rotation, some planes through samples (a zero value counts as behind): on every
        // instruction set, each bit is the scalar test of that sample, and no spare bit is set.
        let mut rng = Rng::new(9);
        let unit = |rng: &mut Rng| {
            DVec3::new(
                f64::from(rng.next_f32()) * 2.0 - 1.0,
                f64::from(rng.next_f32()) * 2.0 - 1.0,
                f64::from(rng.next_f32()) * 2.0 - 1.0,
            )
        };
        let center = DVec3::new(0.3, 2.0, -0.7);
        for n in [1usize, 63, 64, 65, 100, 256, 300] {
            let points: Vec<DVec3> = (0..n).map(|_| center + unit(&mut rng)).collect();
            let samples = LightSamples {
                weights: vec![1.0; n],
                words: n.div_ceil(64),
                points,
            };
            let behind = BehindPlane::new(&samples, center);
            for case in 0..40 {
                let rotation = (case % 2 == 1).then(|| {
                    DMat3::from_axis_angle(
                        unit(&mut rng).normalize(),
                        f64::from(rng.next_f32()) * 6.0,
                    )
                });
                let p = match case % 4 {
                    0 => samples.points[rng.below(n)],
                    _ => unit(&mut rng) * 3.0,
                };
                let s = ViewSample {
                    receiver: 0,
                    p,
                    moved: p,
                    n: unit(&mut rng),
                    rotation,
                    inside: false,
                    exact_planes: false,
                };
                let mut expected = vec![0u64; samples.words];
                for (k, &y) in samples.points.iter().enumerate() {
                    if s.n.dot(rotate_about(center, rotation, y) - s.p) <= 0.0 {
                        expected[k / 64] |= 1 << (k % 64);
                    }
                }
                for isa in Isa::all_on_this_cpu() {
                    let mut mask = vec![0u64; samples.words];
                    behind.mask_on(isa, &s, &mut mask);
                    assert_eq!(mask, expected, "{n} samples, case {case}, {isa:?}");
                }
            }
        }
    }

    #[test]
    fn visibility_by_count_is_the_sum_of_the_shared_power_of_two_weights() {
        // Random masks over 1 to 300 samples (spare bits set and clear), for weights of 1,
        // 1/256 and 2 (shared powers of two, counted), 0.1 and mixed ones (summed): each
        // receiver's visibility equals, bit for bit, that of the sum in sample order.
        let mut rng = Rng::new(7);
        for n in [1usize, 63, 64, 65, 100, 256, 300] {
            let words = n.div_ceil(64);
            let mut mixed = vec![1.0; n];
            mixed[0] = 0.5;
            for weights in [
                vec![1.0; n],
                vec![1.0 / 256.0; n],
                vec![2.0; n],
                vec![0.1; n],
                mixed,
            ] {
                let mut masks = SampleMasks::all_blocked(50, words, &weights);
                let counted = weights[0] != 0.1 && weights.iter().all(|&w| w == weights[0]);
                assert_eq!(
                    masks.shared_weight.is_some(),
                    counted,
                    "{n} {:?}",
                    &weights[..1]
                );
                masks.masks.iter_mut().for_each(|w| *w = rng.next_u64());
                let summed = SampleMasks {
                    shared_weight: None,
                    masks: masks.masks.clone(),
                    weights: weights.clone(),
                    ..masks
                };
                for i in 0..50 {
                    assert_eq!(
                        masks.visibility(i).to_bits(),
                        summed.visibility(i).to_bits()
                    );
                }
            }
        }
    }

    /// Whether the line from `v` through `y` meets the plane of the convex polygon `poly` inside it.
    fn through_polygon(v: DVec3, y: DVec3, poly: &[DVec3]) -> bool {
        let n = (poly[1] - poly[0]).cross(poly[2] - poly[0]);
        let x = v + (y - v) * (n.dot(poly[0] - v) / n.dot(y - v));
        let sides: Vec<f64> = (0..poly.len())
            .map(|k| {
                (poly[(k + 1) % poly.len()] - poly[k])
                    .cross(x - poly[k])
                    .dot(n)
            })
            .collect();
        let tol = 1e-9 * n.length() * (x - poly[0]).length().max(1.0);
        sides.iter().all(|&s| s >= -tol) || sides.iter().all(|&s| s <= tol)
    }

    /// The table grows with the samples' density on the light until its memory budget stops it.
    #[test]
    fn the_table_is_sized_from_the_sample_count_within_its_budget() {
        let bins: Vec<usize> = [1, 16, 64, 128, 256, 512, 1024]
            .map(table_bins_for)
            .to_vec();
        assert_eq!(bins, [64, 64, 64, 96, 128, 96, 80]);
        for s in 1..=MAX_SAMPLES {
            let b = table_bins_for(s) as u64;
            assert!(
                b.is_multiple_of(8) && b.pow(3) * s.div_ceil(64) as u64 * 8 <= TABLE_BUDGET_BYTES,
                "{s} samples"
            );
        }
        assert_eq!(TableSize::Exact.bins(64), None);
        assert_eq!(TableSize::Bins(20).bins(1024), Some(20));
    }

    #[test]
    fn virtually_scaled_polygons_bound_the_ellipsoid_seen_from_any_vertex() {
        // Section 4.1: the cone from a vertex over the bounding polygon holds the whole light.
        let r = glam::Mat3::from_rotation_z(0.5) * glam::Mat3::from_rotation_x(0.9);
        let center = Vec3::new(0.0, 4.0, 0.0);
        let light =
            Light::ellipsoid(center, [r.x_axis * 1.2, r.y_axis * 0.25, r.z_axis * 0.5]).unwrap();
        let mut rng = Rng::new(8);
        for degree in [3, 6, 16] {
            for _ in 0..50 {
                let offset =
                    Vec3::new(rng.next_f32() - 0.5, -rng.next_f32(), rng.next_f32() - 0.5) * 6.0;
                let v = (center + offset + Vec3::new(0.0, -1.3, 0.0)).as_dvec3();
                let poly = light_points(&light, v, degree);
                assert_eq!(poly.len(), degree);
                for _ in 0..200 {
                    let y = light
                        .map([rng.next_f32(), rng.next_f32(), rng.next_f32()])
                        .as_dvec3();
                    assert!(
                        through_polygon(v, y, &poly),
                        "degree {degree}, vertex {v}, light point {y}"
                    );
                }
            }
        }
        // A vertex inside the ellipsoid has no bounding polygon: the whole map.
        assert!(light_points(&light, center.as_dvec3(), 6).is_empty());
    }
}
