//! Light-sample patterns (`docs/design.md` section 2) and the per-receiver sample sets every
//! sample-based method draws from.
//!
//! Patterns live in the light's unit parameter cube ([`crate::light::lights::Light::map`]):
//! - `uniform`: independent uniform points;
//! - `stratified`: a jittered grid when `n` is a perfect square (cube for spheres), else
//!   Latin-hypercube (n-rooks) sampling;
//! - `poisson`: Poisson-disk dart throwing with the minimum distances that Forest et al. 2009
//!   (section 4.1) fix experimentally for 16 and 64 samples on the unit square (0.2456139,
//!   0.1076681), and for other counts `c / sqrt(n)` with `c` interpolated in log n between those
//!   two (`n^(-1/3)` scaled alike for spheres); when darts run out the radius shrinks by 1% and
//!   throwing resumes;
//! - `sobol`: the (0,2)-sequence (Sobol dimensions 1-2, plus 3 for spheres) with a random digital
//!   shift by the seed, which keeps every power-of-two prefix a (0,m,2)-net;
//! - `halton`: radical inverses in bases 2, 3, 5 with a Cranley-Patterson shift by the seed.
//!
//! A [`SampleSet`] holds `k*k` such patterns for interleaved sampling (pixel `(x, y)` uses
//! pattern `(x mod k) + k (y mod k)`, Forest et al. 2009, Soft Textured Shadow Volume, Figure 5f;
//! only the patterns a receiver grid uses are built, see [`Interleave`]), an optional
//! per-receiver decorrelating rotation (Forest et al. 2009, section 4.1) drawn from a hash of the
//! seed and the receiver index, so results never depend on thread scheduling, and a per-frame
//! global rotation for temporal jitter (Sintorn et al. 2008, Sample Based Visibility for Soft
//! Shadows using Alias-free Shadow Maps, section 4.3). Everything is a pure function of the seed.

use crate::error::{Error, Result};
use crate::light::lights::{Light, RotationSeed};
use glam::Vec3;

/// A sample pattern over the light's parameter domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    Uniform,
    Stratified,
    Poisson,
    Sobol,
    Halton,
}

/// SplitMix64: a tiny, well-mixed generator; also the hash that derives per-receiver streams.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// A generator for stream `stream` of `seed`, independent of other streams.
    pub fn stream(seed: u64, stream: u64) -> Self {
        let mut r = Rng(seed ^ 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(stream.wrapping_add(1)));
        r.next_u64();
        r
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform float in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }
}

/// The Poisson-disk minimum distance for `n` samples in a unit domain of dimension `dim`.
pub fn poisson_radius(n: usize, dim: usize) -> f32 {
    let (c16, c64) = (0.245_613_9 * 4.0, 0.107_668_1 * 8.0);
    let t = ((n.max(1) as f32).log2() - 4.0) / 2.0;
    let c = (c16 + (c64 - c16) * t).clamp(c64, c16);
    if dim == 3 {
        c * 0.85 / (n.max(1) as f32).cbrt()
    } else {
        match n {
            16 => 0.245_613_9,
            64 => 0.107_668_1,
            _ => c / (n.max(1) as f32).sqrt(),
        }
    }
}

/// `n` points of `pattern` in [0,1)^dim (unused coordinates are 0). `dim` is 2 or 3.
pub fn unit_pattern(pattern: Pattern, n: usize, dim: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = Rng::stream(seed, 0x5A4D);
    match pattern {
        Pattern::Uniform => (0..n).map(|_| point(dim, |_| rng.next_f32())).collect(),
        Pattern::Stratified => stratified(n, dim, &mut rng),
        Pattern::Poisson => poisson(n, dim, &mut rng),
        Pattern::Sobol => {
            let shift = [
                rng.next_u64() as u32,
                rng.next_u64() as u32,
                rng.next_u64() as u32,
            ];
            (0..n as u32)
                .map(|i| point(dim, |d| to_unit(sobol(i, d) ^ shift[d])))
                .collect()
        }
        Pattern::Halton => {
            let shift = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
            (0..n as u32)
                .map(|i| {
                    point(dim, |d| {
                        (radical_inverse(i, [2, 3, 5][d]) + shift[d]).fract()
                    })
                })
                .collect()
        }
    }
}

/// `n` points of `pattern` in the unit disk (the unit square mapped by Shirley and Chiu's
/// concentric map, which keeps strata and Poisson spacing), e.g. the tap patterns of PCSS.
pub fn unit_disk_pattern(pattern: Pattern, n: usize, seed: u64) -> Vec<glam::Vec2> {
    unit_pattern(pattern, n, 2, seed)
        .into_iter()
        .map(|p| crate::light::lights::concentric_disk(p[0], p[1]))
        .collect()
}

fn point(dim: usize, mut f: impl FnMut(usize) -> f32) -> [f32; 3] {
    let mut p = [0.0; 3];
    for (d, c) in p.iter_mut().enumerate().take(dim) {
        *c = f(d);
    }
    p
}

/// Maps a 32-bit fixed-point fraction to a float strictly below 1.
fn to_unit(bits: u32) -> f32 {
    ((bits >> 8) as f32) / (1u32 << 24) as f32
}

fn stratified(n: usize, dim: usize, rng: &mut Rng) -> Vec<[f32; 3]> {
    let k = (n as f64).powf(1.0 / dim as f64).round() as usize;
    if k.pow(dim as u32) == n {
        return (0..n)
            .map(|i| {
                let cell = [i % k, (i / k) % k, i / (k * k)];
                point(dim, |d| (cell[d] as f32 + rng.next_f32()) / k as f32)
            })
            .collect();
    }
    let mut perms: Vec<Vec<usize>> = (0..dim).map(|_| (0..n).collect()).collect();
    for perm in perms.iter_mut().skip(1) {
        for i in (1..n).rev() {
            perm.swap(i, rng.below(i + 1));
        }
    }
    (0..n)
        .map(|i| {
            point(dim, |d| {
                ((perms[d][i] as f32 + rng.next_f32()) / n as f32).min(1.0 - f32::EPSILON)
            })
        })
        .collect()
}

/// Poisson-disk dart throwing (Cook 1986, Stochastic Sampling in Computer Graphics, section 3.2):
/// uniform darts, each kept when no kept point lies closer than the radius; a radius that runs
/// out of darts (2000 per sample) shrinks by 1%.
fn poisson(n: usize, dim: usize, rng: &mut Rng) -> Vec<[f32; 3]> {
    poisson_with_radius(n, dim, rng).0
}

/// [`poisson`]'s points and the last radius darts were tested against (every pair of points is
/// at least that far apart).
fn poisson_with_radius(n: usize, dim: usize, rng: &mut Rng) -> (Vec<[f32; 3]>, f32) {
    let radius = poisson_radius(n, dim);
    match dim {
        // No coordinates: every point is the origin.
        0 => (vec![[0.0; 3]; n], radius),
        1 => throw_darts::<1>(n, radius, rng),
        2 => throw_darts::<2>(n, radius, rng),
        _ => throw_darts::<3>(n, radius, rng),
    }
}

/// [`poisson`] in `D` dimensions from the first radius `radius`.
fn throw_darts<const D: usize>(n: usize, mut radius: f32, rng: &mut Rng) -> (Vec<[f32; 3]>, f32) {
    let mut pts: Vec<[f32; 3]> = Vec::with_capacity(n);
    if n == 0 {
        return (pts, radius);
    }
    let mut grid = DartGrid::<D>::new(radius);
    let mut coverage: Option<Coverage> = None;
    let darts_per_radius = n.saturating_mul(2000);
    loop {
        let r2 = radius * radius;
        if let Some(cov) = coverage.as_mut() {
            cov.reset(radius, &pts);
        }
        let mut darts = 0;
        while pts.len() < n && darts < darts_per_radius {
            darts += 1;
            let mut c = [0.0; D];
            c.iter_mut().for_each(|x| *x = rng.next_f32());
            let p = point(D, |d| c[d]);
            if coverage.as_ref().is_some_and(|cov| cov.covers(&p)) {
                continue;
            }
            if grid.is_far(&c, r2) {
                grid.insert(c);
                if let Some(cov) = coverage.as_mut() {
                    cov.mark(&p);
                }
                pts.push(p);
            } else if D == 2
                && coverage.is_none()
                && darts > n.saturating_mul(Coverage::JAMMED_DARTS)
            {
                coverage = Some(Coverage::new(grid.cells, radius, &pts));
            }
        }
        if pts.len() == n {
            return (pts, radius);
        }
        radius *= 0.99;
    }
}

/// The parts of the unit square where a dart is certainly rejected, so that most darts of a
/// jammed pattern cost one bit instead of a grid search.
///
/// In two dimensions dart throwing jams: random sequential adsorption of disks saturates at a
/// covered fraction of about 0.547 (Feder 1980, Random Sequential Adsorption), below the 0.58
/// (0.76 at 16 samples) that the radius asks for, so the first radius of a large pattern (small
/// ones fit, helped by the square's border), and some after it, spend all their darts, nearly
/// every one rejected. In three dimensions the radius asks for a fraction of 0.2, far below
/// saturation, and patterns fill without jamming. So once
/// a radius has rejected [`Coverage::JAMMED_DARTS`] darts per sample, sub-cells of a quarter of
/// the grid's cell side are marked when they lie, with their bounds widened by
/// [`Coverage::SLACK`] against the round-off of a dart's sub-cell, within `1 - 1e-5` times the
/// radius of one kept point: a dart there is that close to that point, which its distance test
/// in `f32` (relative error near 1e-7) sees as closer than the radius too, so it is rejected
/// exactly as by testing every kept point. Marks are redrawn for each smaller radius.
struct Coverage {
    /// Sub-cells per side.
    per_side: usize,
    /// One bit per sub-cell, row by row: whether it lies within `safe` of a kept point.
    bits: Vec<u64>,
    /// The radius the marks hold for, a hair less than the current one.
    safe: f64,
}

impl Coverage {
    /// Sub-cells per grid cell side.
    const SUBDIVISION: usize = 4;
    /// Rejected darts per sample at one radius after which the pattern counts as jammed.
    const JAMMED_DARTS: usize = 16;
    /// How far (in unit-square coordinates) a dart may lie outside the sub-cell its rounded
    /// coordinates give: a few units of `f32` round-off at 1.
    const SLACK: f64 = 1e-6;

    /// The coverage of `pts` at `radius` on sub-cells of a grid of `cells` per side.
    fn new(cells: usize, radius: f32, pts: &[[f32; 3]]) -> Self {
        let per_side = cells.saturating_mul(Self::SUBDIVISION);
        let mut cov = Self {
            per_side,
            bits: vec![0; per_side.saturating_mul(per_side).div_ceil(64)],
            safe: 0.0,
        };
        cov.reset(radius, pts);
        cov
    }

    /// Redraws the marks for `radius`.
    fn reset(&mut self, radius: f32, pts: &[[f32; 3]]) {
        self.bits.iter_mut().for_each(|b| *b = 0);
        self.safe = f64::from(radius) * (1.0 - 1e-5);
        pts.iter().for_each(|p| self.mark(p));
    }

    /// The largest distance along one axis from `q` to sub-cell `i`, widened by the slack.
    fn farthest(&self, q: f64, i: usize) -> f64 {
        let f = self.per_side as f64;
        (q - (i as f64 / f - Self::SLACK)).max((i + 1) as f64 / f + Self::SLACK - q)
    }

    /// The sub-cells along one axis that may lie within `safe` of `q`.
    fn span(&self, q: f64) -> std::ops::RangeInclusive<usize> {
        let f = self.per_side as f64;
        let lo = ((q - self.safe) * f).floor().max(0.0) as usize;
        let hi = (((q + self.safe) * f).floor().max(0.0) as usize).min(self.per_side - 1);
        lo..=hi
    }

    /// Marks the sub-cells within `safe` of kept point `q`.
    fn mark(&mut self, q: &[f32; 3]) {
        let (qx, qy) = (f64::from(q[0]), f64::from(q[1]));
        let s2 = self.safe * self.safe;
        for j in self.span(qy) {
            let dy = self.farthest(qy, j);
            for i in self.span(qx) {
                let dx = self.farthest(qx, i);
                if dx * dx + dy * dy <= s2 {
                    let k = i + self.per_side * j;
                    self.bits[k / 64] |= 1 << (k % 64);
                }
            }
        }
    }

    /// Whether dart `c` lies in a marked sub-cell.
    fn covers(&self, c: &[f32; 3]) -> bool {
        let sub = |x: f32| ((x * self.per_side as f32) as usize).min(self.per_side - 1);
        let k = sub(c[0]) + self.per_side * sub(c[1]);
        self.bits[k / 64] >> (k % 64) & 1 == 1
    }
}

/// The squared distance of a kept point `q` and a dart `c`, summed over the axes in order: the
/// acceptance test of [`poisson`] (the grid only decides which points it is evaluated for).
fn squared_distance<const D: usize>(q: &[f32; D], c: &[f32; D]) -> f32 {
    q.iter().zip(c).map(|(a, b)| (a - b).powi(2)).sum::<f32>()
}

/// The shape of a [`DartGrid`] for the first radius `radius`: cells per side, the reach (in
/// cells) of a search, and its distance limit in cell sides.
fn dart_grid_shape(dim: usize, radius: f32) -> (usize, usize, f64) {
    let radius = f64::from(radius);
    let cells = ((dim as f64).sqrt() / radius).floor().max(1.0) as usize;
    // The margin the type doc of `DartGrid` relies on.
    let limit = radius * cells as f64 * 1.01;
    (cells, limit.floor() as usize + 1, limit)
}

/// The bytes the grid of a Poisson pattern of `n` points in `dim` dimensions takes while it is
/// generated (its cells and, in 2D, their sub-cells' coverage; the few crowded cells' extra
/// points aside).
pub fn poisson_scratch_bytes(n: usize, dim: usize) -> u64 {
    let dim = dim.min(3);
    if n == 0 || dim == 0 {
        return 0;
    }
    let (cells, reach, _) = dart_grid_shape(dim, poisson_radius(n, dim));
    let side = (cells as u64).saturating_add(2 * reach as u64);
    let grid = crate::limits::bytes(&[side; 3][..dim]).saturating_mul(4 * dim as u64 + 1);
    let sub_cells = (cells as u64).saturating_mul(Coverage::SUBDIVISION as u64);
    let coverage = if dim == 2 {
        crate::limits::bytes(&[sub_cells, sub_cells]) / 8
    } else {
        0
    };
    grid.saturating_add(coverage)
}

/// A uniform grid over the unit cube that finds the kept points a dart may be too close to, so a
/// dart costs a few distance tests instead of one per kept point (the background grid of Bridson
/// 2007, Fast Poisson Disk Sampling in Arbitrary Dimensions).
///
/// Cells have side at least `radius / sqrt(D)` for the first radius, so a cell holds at most one
/// point at that radius; as the radius shrinks a cell may get more, kept aside as crowded. Only
/// cells within `reach` cells of the dart's, in the order of their nearest possible point, are
/// searched: a point `reach + 1` or more cells away along an axis is at least `reach / cells` >
/// 1.01 times the first radius away there (less the round-off of its cell index, far below that
/// margin), so its distance test, which a shrinking radius only makes easier, would pass. The
/// decision for every dart is therefore exactly that of testing every kept point.
///
/// The grid has a border of `reach` empty cells on each side, so that the searched cells of any
/// dart are at fixed index offsets from its own, with no bounds to check; and each cell stores
/// its first point's coordinates (infinite when empty, which every distance test passes), so
/// the common case reads one array.
struct DartGrid<const D: usize> {
    /// Cells per side inside the border.
    cells: usize,
    /// Empty cells bordering each side.
    reach: usize,
    /// Cells per side with the border.
    side: usize,
    /// Index offsets of the cells to search, nearest first.
    offsets: Vec<isize>,
    /// The first point kept in each cell (infinite coordinates for none).
    first: Vec<[f32; D]>,
    /// One bit per cell: whether it holds more points than its first.
    crowded: Vec<u64>,
    /// The further points of the crowded cells.
    more: std::collections::HashMap<usize, Vec<[f32; D]>>,
}

impl<const D: usize> DartGrid<D> {
    const EMPTY: [f32; D] = [f32::INFINITY; D];

    fn new(radius: f32) -> Self {
        let (cells, reach, limit) = dart_grid_shape(D, radius);
        let side = cells + 2 * reach;
        let count = (0..D).fold(1usize, |acc, _| acc.saturating_mul(side));
        Self {
            cells,
            reach,
            side,
            offsets: Self::offsets(reach as isize, limit, side as isize),
            first: vec![Self::EMPTY; count],
            crowded: vec![0; count.div_ceil(64)],
            more: std::collections::HashMap::new(),
        }
    }

    /// The index offsets of the cells within `reach` whose nearest possible point lies closer
    /// than `limit` cell sides, sorted by that distance and then by the distance of their
    /// centres, so that a close point, which rejects the dart, is usually found in the first
    /// cells.
    fn offsets(reach: isize, limit: f64, side: isize) -> Vec<isize> {
        // (index offset, nearest possible squared distance, squared distance of the centres)
        let mut offsets: Vec<(isize, f64, isize)> = vec![(0, 0.0, 0)];
        for _ in 0..D {
            offsets = offsets
                .into_iter()
                .flat_map(|(o, gap, centres)| {
                    (-reach..=reach).map(move |c| {
                        (
                            o * side + c,
                            gap + ((c.abs() - 1).max(0) as f64).powi(2),
                            centres + c * c,
                        )
                    })
                })
                .collect();
        }
        offsets.retain(|&(_, gap, _)| gap < limit * limit);
        offsets.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.2.cmp(&b.2)));
        offsets.into_iter().map(|(o, _, _)| o).collect()
    }

    /// The index of the cell holding `p` (a point of the unit cube).
    fn cell(&self, p: &[f32; D]) -> usize {
        p.iter().rev().fold(0, |index, &x| {
            index * self.side + ((x * self.cells as f32) as usize).min(self.cells - 1) + self.reach
        })
    }

    fn is_crowded(&self, cell: usize) -> bool {
        self.crowded[cell / 64] >> (cell % 64) & 1 == 1
    }

    /// Whether every kept point is at least `r2` (squared) from `c`, by the very test of
    /// [`squared_distance`] on the points of the cells that can hold a closer one.
    fn is_far(&self, c: &[f32; D], r2: f32) -> bool {
        let home = self.cell(c);
        self.offsets.iter().all(|&offset| {
            let cell = home.wrapping_add_signed(offset);
            squared_distance(&self.first[cell], c) >= r2
                && !(self.is_crowded(cell)
                    && self
                        .more
                        .get(&cell)
                        .is_some_and(|qs| qs.iter().any(|q| squared_distance(q, c) < r2)))
        })
    }

    /// Adds a kept point.
    fn insert(&mut self, p: [f32; D]) {
        let cell = self.cell(&p);
        if self.first[cell] == Self::EMPTY {
            self.first[cell] = p;
        } else {
            self.crowded[cell / 64] |= 1 << (cell % 64);
            self.more.entry(cell).or_default().push(p);
        }
    }
}

/// [`poisson`]'s darts with every dart tested against every kept point, as dart throwing was
/// first written here (quadratic in `n`): the reference the grid's points are checked against
/// (bit for bit) and the peer of the sampling benchmark.
pub fn poisson_testing_every_point(n: usize, dim: usize, rng: &mut Rng) -> Vec<[f32; 3]> {
    let mut radius = poisson_radius(n, dim);
    let mut pts: Vec<[f32; 3]> = Vec::with_capacity(n);
    let darts_per_radius = 2000 * n.max(1);
    while pts.len() < n {
        let r2 = radius * radius;
        let mut darts = 0;
        while pts.len() < n && darts < darts_per_radius {
            darts += 1;
            let c = point(dim, |_| rng.next_f32());
            if pts
                .iter()
                .all(|q| (0..dim).map(|d| (q[d] - c[d]).powi(2)).sum::<f32>() >= r2)
            {
                pts.push(c);
            }
        }
        radius *= 0.99;
    }
    pts
}

/// The `i`-th component of Sobol dimension `d` (0: van der Corput, 1: x+1, 2: x^2+x+1) as a 32-bit fraction.
fn sobol(i: u32, d: usize) -> u32 {
    let mut v = [0u32; 32];
    match d {
        0 => (0..32).for_each(|k| v[k] = 1 << (31 - k)),
        1 => {
            v[0] = 1 << 31;
            for k in 1..32 {
                v[k] = v[k - 1] ^ (v[k - 1] >> 1);
            }
        }
        _ => {
            v[0] = 1 << 31;
            v[1] = 3 << 30;
            for k in 2..32 {
                v[k] = v[k - 2] ^ (v[k - 2] >> 2) ^ v[k - 1];
            }
        }
    }
    (0..32)
        .filter(|&k| i >> k & 1 == 1)
        .fold(0, |acc, k| acc ^ v[k])
}

/// Point `index` of pixel `pixel`'s own sequence in [0,1)^dim (unused coordinates 0): the Sobol
/// (0,2)-sequence (plus dimension 3 for volumetric lights) under a nested uniform (Owen)
/// scrambling hashed from `(seed, pixel, dimension)`, by Burley 2020, Practical Hash-based Owen
/// Scrambling (JCGT 9(4)). Owen scrambling keeps every power-of-two block of consecutive indices
/// a stratified (0,m,2)-net, while pixels get independent points: consecutive frames can draw
/// consecutive blocks of one pixel's sequence, and neighbouring pixels' errors are uncorrelated,
/// as a screen-space denoiser needs. A pure function of its arguments.
pub fn pixel_sequence_point(seed: u64, pixel: u64, index: u32, dim: usize) -> [f32; 3] {
    let mut rng = Rng::stream(seed ^ 0x0E3B_C1A5_5C7D_1F29, pixel);
    point(dim, |d| {
        let scramble = rng.next_u64() as u32;
        to_unit(owen_scramble(sobol(index, d), scramble))
    })
}

/// Burley's nested uniform scramble of a 32-bit fraction: the Laine-Karras permutation of its
/// bits reversed, which flips each bit by a hash of the bits above it.
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut x = x.reverse_bits().wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x.reverse_bits()
}

fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let (mut inv, mut f) = (0.0f64, 1.0f64 / base as f64);
    while i > 0 {
        inv += (i % base) as f64 * f;
        i /= base;
        f /= base as f64;
    }
    (inv as f32).min(1.0 - f32::EPSILON)
}

/// Interleaved sampling's tile of patterns (Forest et al. 2009, Soft Textured Shadow Volume,
/// Figure 5f): `k x k` independent patterns, pixel `(x, y)` using pattern `(x mod k) + k (y mod k)`.
/// A receiver grid of `width x height` pixels uses only the tile's first `min(k, width)` columns
/// and `min(k, height)` rows, and only those are built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Interleave {
    k: usize,
    columns: usize,
    rows: usize,
}

impl Interleave {
    /// `k x k` patterns for the pixels of a `width x height` receiver grid (an empty grid counts
    /// as one pixel).
    pub fn for_grid(k: usize, width: usize, height: usize) -> Self {
        Self {
            k,
            columns: k.min(width.max(1)),
            rows: k.min(height.max(1)),
        }
    }

    /// Every pattern of the `k x k` tile, for receivers on any grid.
    pub fn full(k: usize) -> Self {
        Self {
            k,
            columns: k,
            rows: k,
        }
    }

    /// The number of patterns built (saturating).
    pub fn patterns(&self) -> u64 {
        (self.columns as u64).saturating_mul(self.rows as u64)
    }

    /// The stream index of pattern `(i, j)` of the tile, `i + k j`, as the full tile numbers it.
    fn stream(&self, i: usize, j: usize) -> u64 {
        (i as u64).wrapping_add((self.k as u64).wrapping_mul(j as u64))
    }

    /// The seed of pattern `(i, j)`: `seed` itself without interleaving, so that `samples=n`
    /// draws the very pattern of `light.samples(n, seed=seed)`; an independent stream of it for
    /// each pattern of a tile.
    fn seed(&self, seed: u64, i: usize, j: usize) -> u64 {
        if self.k == 1 {
            seed
        } else {
            Rng::stream(seed, self.stream(i, j)).next_u64()
        }
    }

    /// The position among the built patterns of pixel `(x, y)`'s pattern. A pixel off the grid
    /// the tile was built for wraps around the built columns and rows.
    fn position(&self, x: usize, y: usize) -> usize {
        (x % self.k) % self.columns + self.columns * ((y % self.k) % self.rows)
    }
}

/// A receiver's visibility from its samples' weights: `lit / total` in [0, 1], and 0 when no
/// sample carries weight. Every weighted method resolves its sums here.
pub fn lit_fraction(lit: f64, total: f64) -> f32 {
    if total > 0.0 {
        (lit / total).clamp(0.0, 1.0) as f32
    } else {
        0.0
    }
}

/// A step of a sum that starts from +0.0: `Iterator::sum` over f64 starts from -0.0, so a receiver
/// with no lit sample would get a visibility of -0.0.
pub fn plus_zero_sum(total: f64, term: f64) -> f64 {
    total + term
}

/// How the light samples of each receiver are chosen.
#[derive(Debug, Clone)]
pub struct SampleSet {
    /// The world-space patterns the receivers use, row by row of the interleaving tile (one when
    /// not interleaved), all of the same length.
    patterns: Vec<Vec<Vec3>>,
    tile: Interleave,
    /// `Some(seed)`: rotate each receiver's samples by a rotation hashed from (seed, receiver).
    rotate: Option<u64>,
}

impl SampleSet {
    /// `n` samples of `pattern` on `light` (`k*k` independent patterns when `interleave = k > 1`,
    /// every one built: see [`SampleSet::generate_for`] to build only those a receiver grid
    /// uses), jittered by frame `frame` (0: none).
    pub fn generate(
        light: &Light,
        n: usize,
        pattern: Pattern,
        seed: u64,
        interleave: usize,
        rotate: bool,
        frame: u64,
    ) -> Result<Self> {
        Self::generate_for(
            light,
            n,
            pattern,
            seed,
            Interleave::full(interleave),
            rotate,
            frame,
        )
    }

    /// [`SampleSet::generate`] with only the patterns of `tile` built; pattern `i + k j` of the
    /// tile is the same as in the full tile.
    ///
    /// Errors: no samples; `k = 0`; interrupted (between patterns).
    pub fn generate_for(
        light: &Light,
        n: usize,
        pattern: Pattern,
        seed: u64,
        tile: Interleave,
        rotate: bool,
        frame: u64,
    ) -> Result<Self> {
        if n == 0 {
            return Err(Error::invalid("samples", "needs at least one light sample"));
        }
        if tile.k == 0 {
            return Err(Error::invalid("interleaved", "must be >= 1"));
        }
        let mut patterns = Vec::with_capacity(tile.columns.saturating_mul(tile.rows));
        for j in 0..tile.rows {
            for i in 0..tile.columns {
                crate::interrupt::check()?;
                patterns.push(light_samples(
                    light,
                    n,
                    pattern,
                    tile.seed(seed, i, j),
                    frame,
                ));
            }
        }
        Ok(Self {
            patterns,
            tile,
            rotate: rotate.then_some(seed),
        })
    }

    /// Refuses `n` samples for each of `receivers` receivers before any pattern is built when
    /// even the least work of a method that takes samples, one operation per receiver and
    /// sample, is above the work limit (a mistyped count is told so at once, not after the
    /// patterns are drawn).
    pub fn refuse_more_pairs_than_the_work_limit(receivers: usize, n: usize) -> Result<()> {
        let what = format!("{n} light samples for each of {receivers} receivers");
        crate::limits::Work::default()
            .loop_of(&[receivers as u64, n as u64])
            .refuse_above_limit(&what)
    }

    /// The bytes [`SampleSet::generate_for`] takes: its patterns, and the grid of a Poisson
    /// pattern while it is thrown (saturating).
    pub fn estimated_bytes(light: &Light, n: usize, pattern: Pattern, tile: Interleave) -> u64 {
        let patterns = crate::limits::bytes(&[n as u64, tile.patterns(), 12]);
        let scratch = if pattern == Pattern::Poisson {
            poisson_scratch_bytes(n, light.dim().max(2))
        } else {
            0
        };
        patterns.saturating_add(scratch)
    }

    /// The same explicit world-space samples for every receiver (rotated per receiver if asked).
    pub fn explicit(samples: Vec<Vec3>, rotate: Option<u64>) -> Result<Self> {
        if samples.is_empty() {
            return Err(Error::invalid("samples", "needs at least one light sample"));
        }
        if let Some(i) = samples.iter().position(|s| !s.is_finite()) {
            return Err(Error::invalid(
                "samples",
                format!("sample {i} is not finite"),
            ));
        }
        Ok(Self {
            patterns: vec![samples],
            tile: Interleave::full(1),
            rotate,
        })
    }

    /// The radius of a sphere about the light's center that holds the light and every sample of
    /// every pattern (a hair more, against round-off). Rigid rotations about the center keep the
    /// samples' distances; the other decorrelations keep samples on the light.
    pub fn bounding_radius(&self, light: &Light) -> f64 {
        let center = light.center();
        let farthest = self
            .patterns
            .iter()
            .flatten()
            .map(|y| f64::from((*y - center).length()))
            .fold(light.extent(), f64::max);
        farthest * (1.0 + 1e-6) + 1e-12
    }

    /// Every sample of every pattern, before any per-receiver rotation.
    pub fn points(&self) -> impl Iterator<Item = &Vec3> {
        self.patterns.iter().flatten()
    }

    /// Samples per receiver.
    pub fn count(&self) -> usize {
        self.patterns[0].len()
    }

    /// The number of patterns built.
    pub fn pattern_count(&self) -> usize {
        self.patterns.len()
    }

    /// Whether every receiver uses the very same samples (no interleaving, no rotation).
    pub fn is_shared(&self) -> bool {
        self.is_single_pattern() && self.rotate.is_none()
    }

    /// Whether every receiver uses the same pattern before rotation (no interleaving asked for,
    /// even where the receiver grid would use one pattern of the tile only).
    pub fn is_single_pattern(&self) -> bool {
        self.tile.k == 1
    }

    /// Whether every receiver rotates its samples ([`SampleSet::rotation_for`] is `Some`).
    pub fn rotates(&self) -> bool {
        self.rotate.is_some()
    }

    /// The rotation seed of receiver `index`, when samples are rotated per receiver.
    pub fn rotation_for(&self, index: usize) -> Option<RotationSeed> {
        self.rotate.map(|seed| rotation_seed(seed, index as u64))
    }

    /// The patterns built, before any per-receiver rotation ([`SampleSet::pattern_index`] says
    /// which a receiver uses).
    pub fn patterns(&self) -> &[Vec<Vec3>] {
        &self.patterns
    }

    /// The index among [`SampleSet::patterns`] of the pattern of receiver pixel `(x, y)`.
    pub fn pattern_index(&self, x: usize, y: usize) -> usize {
        self.tile.position(x, y)
    }

    /// The pattern of receiver pixel `(x, y)` before any per-receiver rotation.
    pub fn pattern_for(&self, x: usize, y: usize) -> &[Vec3] {
        &self.patterns[self.pattern_index(x, y)]
    }

    /// Writes receiver `index`'s samples (at pixel `(x, y)`) and their weights into the buffers.
    pub fn fill(
        &self,
        light: &Light,
        index: usize,
        (x, y): (usize, usize),
        out: &mut Vec<Vec3>,
        weights: &mut Vec<f32>,
    ) {
        out.clear();
        out.extend_from_slice(self.pattern_for(x, y));
        if let Some(r) = self.rotation_for(index) {
            out.iter_mut().for_each(|y| *y = light.rotate(*y, r));
        }
        weights.clear();
        weights.extend(out.iter().map(|&y| light.weight(y)));
    }
}

fn rotation_seed(seed: u64, stream: u64) -> RotationSeed {
    let mut rng = Rng::stream(seed ^ 0xD1B5_4A32_D192_ED03, stream);
    [rng.next_f32(), rng.next_f32(), rng.next_f32()]
}

/// `n` world-space samples of `pattern` on `light`, rotated as a whole for frame `frame` > 0.
pub fn light_samples(
    light: &Light,
    n: usize,
    pattern: Pattern,
    seed: u64,
    frame: u64,
) -> Vec<Vec3> {
    let unit = unit_pattern(pattern, n, light.dim().max(2), seed);
    let pts = unit.into_iter().map(|p| light.map(p));
    if frame == 0 {
        pts.collect()
    } else {
        let r = rotation_seed(seed ^ 0x00F4_A3E1, frame);
        pts.map(|y| light.rotate(y, r)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_prefixes_are_nets() {
        let pts = unit_pattern(Pattern::Sobol, 16, 2, 7);
        for (nx, ny) in [(16, 1), (8, 2), (4, 4), (2, 8), (1, 16)] {
            let mut hits = vec![0; 16];
            for p in &pts {
                hits[(p[0] * nx as f32) as usize * ny + (p[1] * ny as f32) as usize] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "{nx}x{ny}: {hits:?}");
        }
    }

    #[test]
    fn pixel_sequences_are_nets_and_differ_by_pixel() {
        for pixel in [0, 1, 977] {
            // Every block of 16 consecutive points of a pixel's sequence is a (0,4,2)-net.
            for block in [0u32, 16, 48] {
                let pts: Vec<[f32; 3]> = (block..block + 16)
                    .map(|i| pixel_sequence_point(3, pixel, i, 2))
                    .collect();
                for (nx, ny) in [(16, 1), (8, 2), (4, 4), (2, 8), (1, 16)] {
                    let mut hits = [0; 16];
                    for p in &pts {
                        hits[(p[0] * nx as f32) as usize * ny + (p[1] * ny as f32) as usize] += 1;
                    }
                    assert!(hits.iter().all(|&h| h == 1), "pixel {pixel}, block {block}");
                }
            }
        }
        let first = |pixel| pixel_sequence_point(3, pixel, 0, 3);
        assert_ne!(first(0), first(1));
        assert_eq!(first(5), first(5));
        assert_ne!(pixel_sequence_point(4, 5, 0, 3), first(5));
    }

    #[test]
    fn poisson_keeps_the_papers_distances() {
        for (n, r) in [(16, 0.245_613_9f32), (64, 0.107_668_1)] {
            let pts = unit_pattern(Pattern::Poisson, n, 2, 3);
            assert_eq!(pts.len(), n);
            for (i, a) in pts.iter().enumerate() {
                for b in &pts[i + 1..] {
                    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
                    assert!(d >= r, "{d} < {r}");
                }
            }
        }
    }

    fn bits(pts: &[[f32; 3]]) -> Vec<[u32; 3]> {
        pts.iter().map(|p| p.map(f32::to_bits)).collect()
    }

    #[test]
    fn poisson_grid_throws_the_same_darts_as_the_reference() {
        // Counts about the interpolation's anchors (16, 64), powers of two and their neighbours,
        // and counts whose radius needs several shrinking rounds.
        let counts = [
            1, 2, 3, 4, 5, 7, 9, 15, 16, 17, 31, 32, 33, 63, 64, 65, 100, 127, 128, 129, 200, 255,
            256, 299, 300,
        ];
        for dim in [2, 3] {
            for seed in [0, 1, 0xDEAD_BEEF] {
                for n in counts {
                    let (mut grid_rng, mut reference_rng) =
                        (Rng::stream(seed, 0x5A4D), Rng::stream(seed, 0x5A4D));
                    let grid = poisson(n, dim, &mut grid_rng);
                    let reference = poisson_testing_every_point(n, dim, &mut reference_rng);
                    assert_eq!(grid.len(), n);
                    assert_eq!(
                        bits(&grid),
                        bits(&reference),
                        "n {n}, dim {dim}, seed {seed}"
                    );
                    // The very same number of darts was drawn.
                    assert_eq!(
                        grid_rng.next_u64(),
                        reference_rng.next_u64(),
                        "n {n}, dim {dim}, seed {seed}"
                    );
                }
            }
        }
    }

    /// The grid's answer against testing every point, for `count` uniform points (many cells
    /// crowded, as no spacing is kept) and darts, at the first radius and smaller ones.
    fn grid_matches_every_point<const D: usize>(count: usize, radius: f32, seed: u64) {
        let mut rng = Rng::new(seed);
        let mut draw = || {
            let mut p = [0.0f32; D];
            p.iter_mut().for_each(|x| *x = rng.next_f32());
            p
        };
        let mut grid = DartGrid::<D>::new(radius);
        let pts: Vec<[f32; D]> = (0..count).map(|_| draw()).collect();
        pts.iter().for_each(|&p| grid.insert(p));
        assert!(
            grid.more.values().map(Vec::len).sum::<usize>() > count / 2,
            "dim {D}, radius {radius}: few crowded cells"
        );
        for shrink in [1.0, 0.99, 0.7, 0.3] {
            let r2 = (radius * shrink).powi(2);
            for _ in 0..2000 {
                let c = draw();
                let far = pts.iter().all(|q| squared_distance(q, &c) >= r2);
                assert_eq!(
                    grid.is_far(&c, r2),
                    far,
                    "dim {D}, radius {radius} x {shrink}, dart {c:?}"
                );
            }
        }
    }

    #[test]
    fn grid_finds_every_close_point_in_crowded_cells() {
        // Radii whose cells hold four points each on average.
        for (count, seed) in [(50, 1), (400, 2), (3000, 3)] {
            let four_per_cell = |dim: i32| (count as f32 / 4.0).powf(-1.0 / dim as f32);
            grid_matches_every_point::<1>(count, four_per_cell(1), seed);
            grid_matches_every_point::<2>(count, 2f32.sqrt() * four_per_cell(2), seed);
            grid_matches_every_point::<3>(count, 3f32.sqrt() * four_per_cell(3), seed);
        }
    }

    #[test]
    fn covered_sub_cells_hold_only_rejected_darts() {
        let mut rng = Rng::new(5);
        let mut draw = || [rng.next_f32(), rng.next_f32(), 0.0];
        for (count, radius) in [(200, 0.1f32), (2000, 0.03), (20, 0.5)] {
            let pts: Vec<[f32; 3]> = (0..count).map(|_| draw()).collect();
            let (cells, _, _) = dart_grid_shape(2, radius);
            let mut cov = Coverage::new(cells, radius * 1.2, &[]);
            pts.iter().for_each(|p| cov.mark(p));
            cov.reset(radius, &pts);
            let r2 = radius * radius;
            let (mut covered, mut rejected) = (0, 0);
            for _ in 0..20_000 {
                let c = draw();
                let rejects = pts.iter().any(|q| squared_distance(q, &c) < r2);
                if cov.covers(&c) {
                    assert!(
                        rejects,
                        "radius {radius}: dart {c:?} covered but far from every point"
                    );
                    covered += 1;
                }
                rejected += usize::from(rejects);
            }
            // Most rejected darts are caught by the coverage alone.
            assert!(
                covered * 10 > rejected * 6,
                "radius {radius}: {covered} of {rejected}"
            );
        }
    }

    #[test]
    fn ten_thousand_poisson_samples_keep_their_distance() {
        for dim in [2, 3] {
            let (pts, radius) = poisson_with_radius(10_000, dim, &mut Rng::stream(4, 0x5A4D));
            assert_eq!(pts.len(), 10_000);
            // The radius shrank by a few 1% steps at most, so the spacing is still Poisson's.
            assert!(
                radius >= 0.9 * poisson_radius(10_000, dim),
                "dim {dim}: radius {radius}"
            );
            let closest = closest_pair(&pts);
            assert!(
                closest >= radius * radius,
                "dim {dim}: squared distance {closest} < {}",
                radius * radius
            );
        }
    }

    /// The smallest squared distance between two of `pts` (unused coordinates are 0), over every pair.
    fn closest_pair(pts: &[[f32; 3]]) -> f32 {
        let mut closest = f32::INFINITY;
        for (i, a) in pts.iter().enumerate() {
            for b in &pts[i + 1..] {
                closest = closest.min(squared_distance(a, b));
            }
        }
        closest
    }

    /// Pattern `j` of an interleaved set seeded `seed`, built on its own.
    fn pattern_j(light: &Light, n: usize, seed: u64, j: u64) -> Vec<Vec3> {
        light_samples(
            light,
            n,
            Pattern::Poisson,
            Rng::stream(seed, j).next_u64(),
            2,
        )
    }

    #[test]
    fn interleaving_builds_only_the_patterns_the_grid_uses() -> Result<()> {
        let light = Light::rect(Vec3::new(0.0, 4.0, 0.0), Vec3::X, Vec3::Z)?;
        let (w, h) = (5, 4);
        let set = SampleSet::generate_for(
            &light,
            16,
            Pattern::Poisson,
            9,
            Interleave::for_grid(1000, w, h),
            true,
            2,
        )?;
        assert_eq!(set.pattern_count(), w * h);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(
                    set.pattern_for(x, y),
                    pattern_j(&light, 16, 9, (x + 1000 * y) as u64).as_slice(),
                    "pixel ({x}, {y})"
                );
            }
        }
        assert_eq!(
            SampleSet::estimated_bytes(
                &light,
                16,
                Pattern::Poisson,
                Interleave::for_grid(1000, w, h)
            ),
            16 * 20 * 12 + poisson_scratch_bytes(16, 2)
        );
        // An explicit point set (height 1) uses one row of the tile.
        assert_eq!(
            SampleSet::generate_for(
                &light,
                4,
                Pattern::Uniform,
                9,
                Interleave::for_grid(1000, 3, 1),
                false,
                0
            )?
            .pattern_count(),
            3
        );
        // Interleaving asked for stays interleaving (the methods that refuse it still do), even
        // where the grid uses one pattern only.
        let one = SampleSet::generate_for(
            &light,
            4,
            Pattern::Uniform,
            9,
            Interleave::for_grid(4, 1, 1),
            false,
            0,
        )?;
        assert_eq!(one.pattern_count(), 1);
        assert!(!one.is_single_pattern() && !one.is_shared());
        Ok(())
    }

    #[test]
    fn a_grid_that_uses_every_pattern_gets_the_full_tile() -> Result<()> {
        let light = Light::sphere(Vec3::ZERO, 0.5)?;
        let full = SampleSet::generate(&light, 8, Pattern::Poisson, 3, 3, false, 0)?;
        let (w, h) = (7, 5);
        let fitted = SampleSet::generate_for(
            &light,
            8,
            Pattern::Poisson,
            3,
            Interleave::for_grid(3, w, h),
            false,
            0,
        )?;
        assert_eq!((full.pattern_count(), fitted.pattern_count()), (9, 9));
        for y in 0..h {
            for x in 0..w {
                assert_eq!(
                    fitted.pattern_for(x, y),
                    full.pattern_for(x, y),
                    "pixel ({x}, {y})"
                );
            }
        }
        Ok(())
    }

    #[test]
    fn pixels_off_the_grid_reuse_its_patterns() -> Result<()> {
        let light = Light::rect(Vec3::ZERO, Vec3::X, Vec3::Z)?;
        let set = SampleSet::generate_for(
            &light,
            4,
            Pattern::Uniform,
            1,
            Interleave::for_grid(1000, 2, 3),
            false,
            0,
        )?;
        assert_eq!(set.pattern_for(2, 3), set.pattern_for(0, 0));
        assert_eq!(set.pattern_for(1003, 2000), set.pattern_for(1, 0));
        assert_eq!(
            set.pattern_for(usize::MAX, usize::MAX),
            set.pattern_for(usize::MAX % 1000 % 2, usize::MAX % 1000 % 3)
        );
        Ok(())
    }

    #[test]
    fn patterns_are_deterministic_and_in_range() {
        for pat in [
            Pattern::Uniform,
            Pattern::Stratified,
            Pattern::Poisson,
            Pattern::Sobol,
            Pattern::Halton,
        ] {
            for dim in [2, 3] {
                let a = unit_pattern(pat, 37, dim, 11);
                assert_eq!(a, unit_pattern(pat, 37, dim, 11));
                assert_ne!(a, unit_pattern(pat, 37, dim, 12));
                assert!(a
                    .iter()
                    .all(|p| p.iter().take(dim).all(|&c| (0.0..1.0).contains(&c))));
            }
        }
    }
}
