//! Plane-to-bitmask tables of `alias_free`: a plane `m · y < k` is binned by two coordinates of
//! its unit normal and its signed distance from the light's center, and a table holds, per bin,
//! a bitmask over the light samples (Sintorn et al. 2008, Sample Based Visibility for Soft
//! Shadows using Alias-free Shadow Maps, sections 4.2 and 4.3, after Eisemann and Décoret 2007).
//! The paper's two coordinates are the normal's two angles; these are its hemi-octahedral
//! coordinates and sign ([`PlaneBins`]), whose bin is found by arithmetic where the angles'
//! bins took a search (or trigonometry).
//!
//! - [`Lut`], the paper's table: the samples behind the plane at the bin's center. It
//!   approximates: a plane is moved to its bin's center, so a sample near the plane may land on
//!   the wrong side.
//! - [`BracketTable`], for the exact tests: the samples behind *every* plane of the bin (`sure`)
//!   and those that some planes of the bin put behind and others not (`unsure`). A plane's exact
//!   mask is `sure` plus the `unsure` samples that an exact test puts behind it, so the exact
//!   mode tests only the samples near each plane (a band a bin wide across the light) instead of
//!   every sample, with the very bits of testing them all.
//!
//! Both are built per normal bin from each sample's projection on the bin's normal, once: the
//! distance bins that put a sample behind a plane form a suffix of the bins (the plane moves
//! away from the light's center as the distance grows), so each sample sets one bit and a
//! running OR over the distance bins fills the rest.

use crate::error::Result;
use crate::limits;
use glam::DVec3;
use rayon::prelude::*;

use super::LightSamples;

/// The bins of a plane by its unit normal, on a hemi-octahedral grid, and its signed distance
/// from the light's center in units of `extent`.
///
/// A unit normal `u` is `±r` for the `r` of the upper hemisphere (`z > 0`, the equator's ties
/// broken by `y`, then `x`), which maps to the square `[−1, 1]²` by `(r.x + r.y, r.x − r.y) / |r|₁`
/// (the octahedral map of the hemisphere, turned by 45 degrees; Meyer et al. 2010, On
/// Floating-Point Normal Vectors), cut into `cells × cells` equal cells; the normal's bin is its
/// sign and cell. Its bin is then arithmetic: two divisions and a few sums, no search and no
/// trigonometry, the same operations in `methods/alias_free/alias_free.wgsl`, so both backends
/// read the same entries. The cells span 0.33 to 1.65 times their mean solid angle (the paper's
/// two angles, 0.04 to 1.57: cells at the poles a fortieth of those at the equator). `−u` falls
/// in the cell of `u` with the other sign, whose center is the negated center: a plane and its
/// complement (the two sides of an edge shared by two triangles) are binned to complementary
/// planes (up to round-off at a distance bin's boundary), so the table leaves no sample between
/// two triangles that share an edge, as the angles' bins did too, and as an octahedral map of
/// the whole sphere, not symmetric, did not (it left samples lit in the umbra). `cells` is
/// `bins / √2` rounded down: the `2 cells²` normal bins are at most the paper's `bins²` (the
/// table no larger than `bins³` entries), within 4.2% from 64 bins on; the distance takes `bins`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PlaneBins {
    pub bins: usize,
    /// Cells per side of the square of each sign.
    pub cells: usize,
    pub center: DVec3,
    pub extent: f64,
    /// `1 / extent`.
    inv_extent: f64,
    /// `|center|`, for the bracketing table's round-off bound.
    center_length: f64,
}

/// Whether the unit vector `u` lies in the upper hemisphere: `z > 0`, on the equator `y > 0`,
/// on its diameter `x > 0` (so that exactly one of `u` and `−u` does, −0 counting as 0).
#[inline(always)]
fn upper(u: DVec3) -> bool {
    // `|` and `&`, not `||` and `&&`: no branch, for lane loops.
    (u.z > 0.0) | ((u.z == 0.0) & ((u.y > 0.0) | ((u.y == 0.0) & (u.x > 0.0))))
}

/// The sign (0 for `+`, 1 for `−`) and the coordinates in `[−1, 1]²` of the unit vector `u` (see
/// [`PlaneBins`]).
#[inline(always)]
fn hemi_octahedral(u: DVec3) -> (usize, [f64; 2]) {
    let (sign, r) = match upper(u) {
        true => (0, u),
        false => (1, -u),
    };
    let l1 = (r.x.abs() + r.y.abs()) + r.z.abs();
    let (x, y) = (r.x / l1, r.y / l1);
    (sign, [x + y, x - y])
}

/// The unit vector of sign `sign` at coordinates `(a, b)`: the inverse of [`hemi_octahedral`].
fn from_hemi_octahedral(sign: usize, a: f64, b: f64) -> DVec3 {
    let (x, y) = ((a + b) * 0.5, (a - b) * 0.5);
    let r = DVec3::new(x, y, 1.0 - x.abs() - y.abs()).normalize();
    match sign {
        0 => r,
        _ => -r,
    }
}

impl PlaneBins {
    fn new(center: DVec3, extent: f64, bins: usize) -> Self {
        Self {
            bins,
            cells: ((bins as f64) / std::f64::consts::SQRT_2) as usize,
            center,
            extent,
            inv_extent: 1.0 / extent,
            center_length: center.length(),
        }
    }

    /// The number of normal bins: `2 cells²`.
    pub fn normal_bins(&self) -> usize {
        2 * self.cells * self.cells
    }

    /// The bin of `t` in `[−1, 1]` (1 in the last) among `n`: clamped in f64 (NaN to bin 0, as
    /// `max` returns the number), then truncated without the checks of a saturating `as`,
    /// which LLVM makes lane by lane.
    #[inline(always)]
    fn bin(t: f64, n: usize) -> usize {
        let at = ((t + 1.0) * 0.5 * n as f64).max(0.0).min((n - 1) as f64);
        // SAFETY: `at` is a number in `0..=n − 1`, and `n` (at most 256 bins, or cells fewer)
        // is far below `i32::MAX`.
        unsafe { at.to_int_unchecked::<i32>() as usize }
    }

    /// The coordinate in `[−1, 1]` of the (fractional) cell boundary `k`.
    fn boundary(&self, k: f64) -> f64 {
        k / self.cells as f64 * 2.0 - 1.0
    }

    /// The sign and cell `(i, j)` of normal bin `n`.
    fn split(&self, n: usize) -> (usize, usize, usize) {
        let per_sign = self.cells * self.cells;
        (n / per_sign, n % per_sign / self.cells, n % self.cells)
    }

    /// The unit normal at the center of normal bin `n`.
    fn normal(&self, n: usize) -> DVec3 {
        let (sign, i, j) = self.split(n);
        let at = |k: usize| self.boundary(k as f64 + 0.5);
        from_hemi_octahedral(sign, at(i), at(j))
    }

    /// An upper bound of the distance from the center normal of normal bin `n` to any unit vector
    /// of that bin, with a margin. The lines `a = b` and `a = −b` (`y = 0` and `x = 0`) cut the
    /// bin's square into convex pieces, each on one face of the octahedron, where the map is
    /// affine: each piece is a spherical polygon with great-circle edges whose corners are the
    /// square's, the lines' crossings with its sides and their own crossing inside it. A cap
    /// about the center normal narrower than a hemisphere (a cell of a grid of 2 or more is) is
    /// convex, so it holds a piece when it holds the piece's corners: the farthest of these
    /// points bounds. Negation keeps distances: both signs share the bound.
    fn spread(&self, n: usize) -> f64 {
        let (_, i, j) = self.split(n);
        let (a0, a1) = (self.boundary(i as f64), self.boundary(i as f64 + 1.0));
        let (b0, b1) = (self.boundary(j as f64), self.boundary(j as f64 + 1.0));
        let in_a = |a: f64| (a0..=a1).contains(&a);
        let in_b = |b: f64| (b0..=b1).contains(&b);
        let mut corners = vec![(a0, b0), (a0, b1), (a1, b0), (a1, b1)];
        if in_a(0.0) && in_b(0.0) {
            corners.push((0.0, 0.0));
        }
        for a in [a0, a1] {
            corners.extend([a, -a].into_iter().filter(|&b| in_b(b)).map(|b| (a, b)));
        }
        for b in [b0, b1] {
            corners.extend([b, -b].into_iter().filter(|&a| in_a(a)).map(|a| (a, b)));
        }
        // The center of the bin's cell with sign `+`.
        let center = self.normal(n % (self.cells * self.cells));
        let far = corners
            .into_iter()
            .map(|(a, b)| (from_hemi_octahedral(0, a, b) - center).length())
            .fold(0.0f64, f64::max);
        far * (1.0 + 1e-6) + 1e-12
    }

    /// The normal bin of the unit vector `u`.
    #[inline(always)]
    fn normal_bin(&self, u: DVec3) -> usize {
        let (sign, [a, b]) = hemi_octahedral(u);
        let n = self.cells;
        (sign * n + Self::bin(a, n)) * n + Self::bin(b, n)
    }

    /// The bin of the plane `m · y < k` (flat index `normal bin · bins + distance bin`), or `None`
    /// when it misses the light (its distance from the center is `extent` or more); `inv` is
    /// `1 / |m|` (the shader's arithmetic, one division and one square root per plane).
    #[inline]
    fn locate(&self, m: DVec3, k: f64, inv: f64) -> Option<usize> {
        let (hits, at) = self.locate_parts(m, k, inv);
        hits.then_some(at)
    }

    /// [`Self::locate`] without a branch, for lane loops: whether the plane meets the light,
    /// and its bin (meaningless, but within the table, where it does not).
    #[inline(always)]
    fn locate_parts(&self, m: DVec3, k: f64, inv: f64) -> (bool, usize) {
        let u = m * inv;
        let d = (k * inv - u.dot(self.center)) * self.inv_extent;
        let hits = (-1.0..1.0).contains(&d);
        (
            hits,
            self.normal_bin(u) * self.bins + Self::bin(d, self.bins),
        )
    }

    /// The number of bins: normal bins times distance bins.
    fn entries(&self) -> usize {
        self.normal_bins() * self.bins
    }

    /// The [`Self::code`] of a plane that misses the light with its center below it: every
    /// sample lies behind it (a [`Lut`] row past its bins', of every sample).
    #[inline(always)]
    pub(crate) fn misses_below(&self) -> u32 {
        self.entries() as u32
    }

    /// The [`Self::code`] of a plane that misses the light with its center above it: no sample
    /// lies behind it (a [`Lut`] row past its bins', of none).
    #[inline(always)]
    pub(crate) fn misses_above(&self) -> u32 {
        self.entries() as u32 + 1
    }

    /// How a table of these bins serves the plane `m · y < k` (`inv = 1 / |m|`), as a code that
    /// a lane loop computes without a branch: the flat index of the plane's bin (its mask:
    /// [`Lut::mask`]), or, for a plane that misses the light, [`Self::misses_above`] or
    /// [`Self::misses_below`].
    #[inline(always)]
    pub(crate) fn code(&self, m: DVec3, k: f64, inv: f64) -> u32 {
        let (hits, at) = self.locate_parts(m, k, inv);
        let center_above = m.dot(self.center) >= k;
        match (hits, center_above) {
            (true, _) => at as u32,
            (false, true) => self.misses_above(),
            (false, false) => self.misses_below(),
        }
    }

    /// For each normal bin `n` (in index order, in parallel), calls `fill(n, chunk)` on its
    /// `bins * per_bin` values.
    fn fill_by_normal(
        &self,
        values: &mut [u64],
        per_bin: usize,
        fill: impl Fn(usize, &mut [u64]) + Sync,
    ) {
        values
            .par_chunks_mut(self.bins * per_bin)
            .enumerate()
            .for_each(|(n, chunk)| fill(n, chunk));
    }
}

/// Sets bit `s` of the distance bin `first[s]` (none when it is `bins` or more) of a normal
/// bin's `chunk` (`bins` runs of `stride` words, the mask at word `offset` of each run), then
/// ORs each bin's mask into the next: bin `k` then holds the samples whose first bin is `k` or
/// less.
fn fill_suffixes(chunk: &mut [u64], stride: usize, offset: usize, words: usize, first: &[usize]) {
    let bins = chunk.len() / stride;
    for (s, &k) in first.iter().enumerate() {
        if k < bins {
            chunk[k * stride + offset + s / 64] |= 1 << (s % 64);
        }
    }
    for k in 1..bins {
        let (before, after) = chunk.split_at_mut(k * stride);
        let previous = &before[(k - 1) * stride + offset..(k - 1) * stride + offset + words];
        after[offset..offset + words]
            .iter_mut()
            .zip(previous)
            .for_each(|(a, b)| *a |= b);
    }
}

/// The paper's plane-to-bitmask lookup table: for a unit normal (its hemi-octahedral cell and
/// sign, [`PlaneBins`], where the paper bins two angles) and a signed distance from the light's
/// center (in units of the light's extent), the samples behind the plane at the bin's center;
/// then two rows for the planes that miss the light, every sample's
/// ([`PlaneBins::misses_below`]) and none ([`PlaneBins::misses_above`]), so that a pair's masks
/// are AND-ed by code without a branch ([`Lut::below_all`]).
pub(crate) struct Lut {
    pub grid: PlaneBins,
    pub words: usize,
    pub masks: Vec<u64>,
}

impl Lut {
    pub(crate) fn new(
        samples: &LightSamples,
        center: DVec3,
        extent: f64,
        bins: usize,
    ) -> Result<Self> {
        let words = samples.words;
        limits::check_memory(
            "alias_free lookup table",
            limits::bytes(&[bins as u64, bins as u64, bins as u64, words as u64, 8]),
        )?;
        let grid = PlaneBins::new(center, extent, bins);
        let mut masks = vec![0u64; (grid.entries() + 2) * words];
        let distance = |k: usize| ((k as f64 + 0.5) / bins as f64 * 2.0 - 1.0) * extent;
        grid.fill_by_normal(&mut masks, words, |n, chunk| {
            let m = grid.normal(n);
            // Sample y lies behind bin k's plane when m · y < m · c + d_k: from the first such k on.
            let limits: Vec<f64> = (0..bins).map(|k| m.dot(center) + distance(k)).collect();
            let first: Vec<usize> = samples
                .points
                .iter()
                .map(|y| {
                    let a = m.dot(*y);
                    limits.partition_point(|&l| l <= a)
                })
                .collect();
            fill_suffixes(chunk, words, 0, words, &first);
        });
        let every = grid.misses_below() as usize * words;
        masks[every..every + words].copy_from_slice(&samples.full_mask());
        Ok(Self { grid, words, masks })
    }

    /// The mask of the samples behind the planes of [`PlaneBins::code`] `code`.
    pub(crate) fn mask(&self, code: u32) -> &[u64] {
        let at = code as usize * self.words;
        &self.masks[at..at + self.words]
    }

    /// The samples behind all four planes of [`PlaneBins::code`]s `codes`, into `out` (of
    /// [`Self::words`] words); false when none. Each mask is read whole and AND-ed, without a
    /// branch on the codes or on the masks read before, so that the four reads (far apart in a
    /// table of megabytes) overlap; at the usual mask lengths in whole registers.
    #[inline]
    pub(crate) fn below_all(&self, codes: [u32; 4], out: &mut [u64]) -> bool {
        match self.words {
            1 => self.below_all_in::<1>(codes, out),
            2 => self.below_all_in::<2>(codes, out),
            4 => self.below_all_in::<4>(codes, out),
            8 => self.below_all_in::<8>(codes, out),
            16 => self.below_all_in::<16>(codes, out),
            _ => {
                out.copy_from_slice(self.mask(codes[0]));
                for &code in &codes[1..] {
                    super::and_into(out, self.mask(code));
                }
                out.iter().any(|&w| w != 0)
            }
        }
    }

    /// [`Self::below_all`] for masks of `W` words.
    #[inline(always)]
    fn below_all_in<const W: usize>(&self, codes: [u32; 4], out: &mut [u64]) -> bool {
        let (rows, _) = self.masks.as_chunks::<W>();
        let mut all = rows[codes[0] as usize];
        for &code in &codes[1..] {
            let row = &rows[code as usize];
            for w in 0..W {
                all[w] &= row[w];
            }
        }
        out.copy_from_slice(&all);
        all.iter().fold(0, |any, &w| any | w) != 0
    }
}

/// The margin, in units of the table's extent, by which a sample must clear every plane of a
/// bin to be sure; it absorbs the round-off of binning a plane and of the exact test
/// ([`BracketTable::lookup`] refuses a plane whose round-off could exceed a quarter of it).
const SURE_MARGIN: f64 = 1e-6;

/// The memory the [`BracketTable`] may take: 32 MiB (64 bins at 256 samples, 48 at 1024).
const BRACKET_BUDGET_BYTES: u64 = 32 << 20;

/// For each bin of planes, the samples behind every plane of the bin (`sure`) and the samples
/// some of its planes put behind and others not (`unsure`), stored side by side (`sure` then
/// `unsure`, `words` each) so that one lookup reads one run.
///
/// A plane `m · y < k` of normal bin `n` (unit normal `u` within `spread(n)` of the bin's
/// center normal `u0`) and distance bin `[d0, d1)` puts sample `y` (at `e = y − c` from the
/// center) behind it when `u · e < d · extent`; since `|u · e − u0 · e| <= spread · |e|`, every
/// plane of the bin does when `u0 · e + spread |e| < d0 · extent` and none does when
/// `u0 · e − spread |e| >= d1 · extent`, each with a margin of [`SURE_MARGIN`].
pub(crate) struct BracketTable {
    pub grid: PlaneBins,
    pub words: usize,
    pub masks: Vec<u64>,
}

impl BracketTable {
    /// Bins per parameter for `words` mask words: 64, or as many (a multiple of 8) as
    /// [`BRACKET_BUDGET_BYTES`] hold.
    pub(crate) fn bins_for(words: usize) -> usize {
        let fits = |bins: u64| bins.pow(3) * 2 * words as u64 * 8 <= BRACKET_BUDGET_BYTES;
        (8..=64)
            .rev()
            .step_by(8)
            .find(|&b| fits(b as u64))
            .unwrap_or(8)
    }

    pub(crate) fn new(samples: &LightSamples, center: DVec3, extent: f64) -> Result<Self> {
        let words = samples.words;
        let bins = Self::bins_for(words);
        limits::check_memory(
            "alias_free bracketing table",
            limits::bytes(&[bins as u64, bins as u64, bins as u64, 2 * words as u64, 8]),
        )?;
        let grid = PlaneBins::new(center, extent, bins);
        let mut masks = vec![0u64; grid.normal_bins() * bins * 2 * words];
        let b = bins as f64;
        // The first distance bin [d0, d1) whose d0 (d1 for `ahead`) exceeds `d`, in units of extent.
        let first_bin_past = |d: f64, ahead: bool| {
            let edge = (d + 1.0) * 0.5 * b - f64::from(u8::from(ahead));
            (edge.floor() + 1.0).clamp(0.0, b) as usize
        };
        grid.fill_by_normal(&mut masks, 2 * words, |n, chunk| {
            let (u0, spread) = (grid.normal(n), grid.spread(n));
            let (mut sure, mut maybe) = (Vec::new(), Vec::new());
            for y in &samples.points {
                let e = *y - center;
                let (along, reach) = (u0.dot(e) / extent, spread * e.length() / extent);
                sure.push(first_bin_past(along + reach + SURE_MARGIN, false));
                maybe.push(first_bin_past(along - reach - SURE_MARGIN, true));
            }
            fill_suffixes(chunk, 2 * words, 0, words, &sure);
            fill_suffixes(chunk, 2 * words, words, words, &maybe);
            for run in chunk.chunks_mut(2 * words) {
                let (sure, maybe) = run.split_at_mut(words);
                maybe
                    .iter_mut()
                    .zip(sure.iter())
                    .for_each(|(m, s)| *m &= !s);
            }
        });
        Ok(Self { grid, words, masks })
    }

    /// The `(sure, unsure)` masks of the plane `m · y < k`'s bin (`inv = 1 / |m|`), or `None`
    /// when the plane misses the table's span or its round-off could exceed the margin (test
    /// every sample then).
    pub(crate) fn lookup(&self, m: DVec3, k: f64, inv: f64) -> Option<(&[u64], &[u64])> {
        let g = &self.grid;
        let round_off = 1e-9 * (k.abs() * inv + g.center_length + g.extent);
        if round_off > 0.25 * SURE_MARGIN * g.extent {
            return None;
        }
        let at = g.locate(m, k, inv)? * 2 * self.words;
        let run = &self.masks[at..at + 2 * self.words];
        Some(run.split_at(self.words))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::Rng;

    fn samples(n: usize, center: DVec3, rng: &mut Rng) -> LightSamples {
        let points: Vec<DVec3> = (0..n)
            .map(|_| {
                let d = DVec3::new(
                    f64::from(rng.next_f32()),
                    f64::from(rng.next_f32()),
                    f64::from(rng.next_f32()),
                ) * 2.0
                    - 1.0;
                center + d * 0.6
            })
            .collect();
        LightSamples {
            weights: vec![1.0; n],
            words: n.div_ceil(64),
            points,
        }
    }

    fn exact(samples: &LightSamples, m: DVec3, k: f64) -> Vec<u64> {
        let mut out = vec![0u64; samples.words];
        samples.below(m, k, &mut out);
        out
    }

    /// Planes through points near the light, in every direction.
    fn planes(center: DVec3, rng: &mut Rng) -> Vec<(DVec3, f64)> {
        (0..3000)
            .map(|_| {
                let mut v = || {
                    DVec3::new(
                        f64::from(rng.next_f32()),
                        f64::from(rng.next_f32()),
                        f64::from(rng.next_f32()),
                    )
                };
                let m = (v() * 2.0 - 1.0) * 3.0;
                let through = center + (v() * 2.0 - 1.0) * 1.2;
                (m, m.dot(through))
            })
            .collect()
    }

    #[test]
    fn every_normal_lies_within_its_bins_spread() {
        // Random normals, normals on and next to every cell corner, the poles and the axes: each
        // maps back to itself, lies within its bin's spread of the bin's center normal (what the
        // bracketing table's bounds rest on), and its negation falls in the bin of the other
        // sign, whose center is the negated center. Odd grids (cells across the axes) included.
        let mut rng = Rng::new(12);
        for bins in [4, 7, 16, 64, 256] {
            let g = PlaneBins::new(DVec3::ZERO, 1.0, bins);
            let mut normals: Vec<DVec3> = (0..4000)
                .map(|_| {
                    DVec3::new(
                        f64::from(rng.next_f32()),
                        f64::from(rng.next_f32()),
                        f64::from(rng.next_f32()),
                    ) * 2.0
                        - 1.0
                })
                .collect();
            let step = g.cells.div_ceil(64);
            for i in (0..=g.cells).step_by(step) {
                for j in (0..=g.cells).step_by(step) {
                    let u = from_hemi_octahedral(0, g.boundary(i as f64), g.boundary(j as f64));
                    normals.extend([
                        u,
                        DVec3::new(u.x.next_up(), u.y.next_down(), u.z.next_up()),
                        DVec3::new(u.x.next_down(), u.y.next_up(), u.z.next_down()),
                    ]);
                }
            }
            let tiny = f64::from_bits(1);
            normals.extend([
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                DVec3::new(1.0, -0.0, 0.0),
                DVec3::new(-0.0, 1.0, -0.0),
                DVec3::new(tiny, -tiny, 1.0),
                DVec3::new(1.0, 1.0, 0.0),
            ]);
            for m in normals.into_iter().filter(|m| m.length() > 0.0) {
                for u in [m / m.length(), -m / m.length()] {
                    let (sign, [a, b]) = hemi_octahedral(u);
                    assert!(
                        (from_hemi_octahedral(sign, a, b) - u).length() < 1e-12,
                        "{bins} bins, {u}"
                    );
                    let n = g.normal_bin(u);
                    assert!(
                        (u - g.normal(n)).length() <= g.spread(n),
                        "{bins} bins, {u} in bin {n}"
                    );
                    let opposite = g.normal_bin(-u);
                    assert_eq!(opposite, (n + g.normal_bins() / 2) % g.normal_bins());
                    assert_eq!(g.normal(opposite), -g.normal(n));
                }
            }
        }
    }

    #[test]
    fn the_table_holds_the_samples_behind_each_bins_center_plane() -> Result<()> {
        // The build by suffixes gives, bit for bit, the test of every sample against every bin.
        let mut rng = Rng::new(3);
        let center = DVec3::new(0.3, 4.0, -0.2);
        let light = samples(100, center, &mut rng);
        let lut = Lut::new(&light, center, 1.1, 12)?;
        let g = &lut.grid;
        for n in 0..g.normal_bins() {
            let m = g.normal(n);
            for k in 0..12 {
                let d = ((k as f64 + 0.5) / 12.0 * 2.0 - 1.0) * 1.1;
                let at = (n * 12 + k) * lut.words;
                assert_eq!(
                    lut.masks[at..at + lut.words],
                    exact(&light, m, m.dot(center) + d)[..]
                );
            }
        }
        Ok(())
    }

    #[test]
    fn bracketing_masks_hold_every_plane_of_their_bin() -> Result<()> {
        // `sure` samples lie behind the plane, samples outside `sure` and `unsure` do not, and
        // the table errs only inside `unsure`.
        let mut rng = Rng::new(5);
        let center = DVec3::new(-1.0, 3.0, 0.5);
        for n in [7, 64, 200] {
            let light = samples(n, center, &mut rng);
            let table = BracketTable::new(&light, center, 0.6 * 3f64.sqrt())?;
            let (mut looked_up, mut unsure) = (0, 0);
            for (m, k) in planes(center, &mut rng) {
                let truth = exact(&light, m, k);
                let Some((sure, maybe)) = table.lookup(m, k, 1.0 / m.length()) else {
                    continue;
                };
                looked_up += 1;
                for w in 0..light.words {
                    assert_eq!(sure[w] & !truth[w], 0, "sure but not behind: {m} {k}");
                    assert_eq!(
                        truth[w] & !(sure[w] | maybe[w]),
                        0,
                        "behind but ruled out: {m} {k}"
                    );
                    unsure += maybe[w].count_ones();
                }
            }
            assert!(looked_up > 1000, "{looked_up} planes looked up");
            // A band about a bin wide across the light is left to the exact tests.
            let share = f64::from(unsure) / (looked_up * n) as f64;
            assert!(
                share < 0.25,
                "{n} samples: {share:.3} of the samples unsure"
            );
        }
        Ok(())
    }

    #[test]
    fn planes_far_from_the_origin_are_left_to_the_exact_tests() -> Result<()> {
        let mut rng = Rng::new(2);
        let light = samples(64, DVec3::ZERO, &mut rng);
        let table = BracketTable::new(&light, DVec3::ZERO, 1.0)?;
        let m = DVec3::new(0.0, 1.0, 1e-3);
        assert!(table
            .lookup(m, m.dot(DVec3::new(0.0, 0.1, 0.0)), 1.0 / m.length())
            .is_some());
        assert!(table
            .lookup(m, m.dot(DVec3::new(0.0, 0.1, 1e9)), 1.0 / m.length())
            .is_none());
        assert_eq!(BracketTable::bins_for(4), 64);
        assert_eq!(BracketTable::bins_for(16), 48);
        Ok(())
    }
}
