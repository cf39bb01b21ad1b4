//! Plane-to-bitmask tables of `alias_free`: a plane `m · y < k` is binned by its unit normal's
//! two angles and its signed distance from the light's center, and a table holds, per bin, a
//! bitmask over the light samples (Sintorn et al. 2008, Sample Based Visibility for Soft Shadows
//! using Alias-free Shadow Maps, sections 4.2 and 4.3, after Eisemann and Décoret 2007).
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

/// The bins of a plane by its unit normal (polar angle from +z, azimuth about it) and its signed
/// distance from the light's center in units of `extent`, `bins` each.
///
/// A plane's bins are found without trigonometry, by counting the bins' boundaries (`theta_bounds`,
/// `phi_bounds`) that its normal reaches: the same bins as `acos` and `atan2` give up to rounding
/// at a boundary, and the same arithmetic as `methods/alias_free/alias_free.wgsl`, which has no
/// 64-bit `acos` or `atan2`, so both backends read the same entries. The shader counts by binary
/// search; the CPU reads a [`Guide`] (per cell of a fine grid over `u.z` and over a pseudo-angle
/// of the azimuth, the boundaries certainly reached there) and tests the next one or two: the
/// same count of the same tests, without a search's mispredicted branches.
pub(crate) struct PlaneBins {
    pub bins: usize,
    pub center: DVec3,
    pub extent: f64,
    /// `1 / extent`.
    inv_extent: f64,
    /// `|center|`, for the bracketing table's round-off bound.
    center_length: f64,
    /// `cos(k π / bins)` for k = 1..bins: the polar angle's inner bin boundaries, decreasing.
    pub theta_bounds: Vec<f64>,
    /// `(cos, sin)` of `2 k π / bins` for k = 1..bins: the azimuth's inner bin boundaries.
    pub phi_bounds: Vec<[f64; 2]>,
    /// Over `u.z + 1` in [0, 2): the polar boundaries reached.
    theta_guide: Guide,
    /// Over [`pseudo_angle`] in [0, 4): the azimuth boundaries reached.
    phi_guide: Guide,
}

/// Guide cells per bin of each angle: fine enough that a cell rarely holds two boundaries.
const GUIDE_CELLS: usize = 16;

/// A margin of the guides, far above the round-off of `u.z` and of [`pseudo_angle`].
const GUIDE_MARGIN: f64 = 1e-9;

/// Per cell of a uniform grid over `[0, span)`, the number of boundaries (of a predicate true
/// on a prefix of them, and monotone in the value) that every value of the cell reaches.
struct Guide {
    span: f64,
    starts: Vec<u16>,
}

impl Guide {
    /// `reached(k, value)`: whether boundary `k` of `n` is reached at `value`.
    fn new(cells: usize, span: f64, n: usize, reached: impl Fn(usize, f64) -> bool) -> Self {
        let edge = |c: usize| c as f64 / cells as f64 * span;
        let count = |value: f64| (0..n).take_while(|&k| reached(k, value)).count() as u16;
        Self {
            span,
            starts: (0..cells)
                .map(|c| count(edge(c) - GUIDE_MARGIN).min(count(edge(c + 1) + GUIDE_MARGIN)))
                .collect(),
        }
    }

    /// How many of `n` boundaries `value` (in `[0, span)`) reaches, `reached(k)` telling for
    /// boundary `k`: those its cell surely reaches, then the next one tested without branching,
    /// and only where the one after is reached too (a cell holding two boundaries), the rest in
    /// turn.
    #[inline]
    fn count(&self, value: f64, n: usize, reached: impl Fn(usize) -> bool) -> usize {
        let cells = self.starts.len();
        let start =
            usize::from(self.starts[((value / self.span * cells as f64) as usize).min(cells - 1)]);
        let at = |k: usize| (k < n) & reached(k.min(n.max(1) - 1));
        if at(start + 1) {
            return (start + 2..n).find(|&k| !reached(k)).unwrap_or(n);
        }
        start + usize::from(at(start))
    }
}

/// A value in [0, 4) that grows with the azimuth `atan2(y, x)` in [0, 2π) (the upper half-plane,
/// `y > 0` or `y = 0 < x`, in [0, 2)), without trigonometry.
fn pseudo_angle(x: f64, y: f64) -> f64 {
    let r = x / (x.abs() + y.abs());
    if y > 0.0 || (y == 0.0 && x > 0.0) {
        1.0 - r
    } else {
        3.0 + r
    }
}

impl PlaneBins {
    fn new(center: DVec3, extent: f64, bins: usize) -> Self {
        let angle = |k: usize, range: f64| k as f64 / bins as f64 * range;
        let theta_bounds: Vec<f64> = (1..bins)
            .map(|k| angle(k, std::f64::consts::PI).cos())
            .collect();
        // The boundary at π exactly on the axis: `sin(π)` rounds to 1.2e-16, which put it in the
        // upper half-plane while `phi_bin` counts it in the lower one, and a direction a hair below
        // the +x axis then failed its test (reaching 3π/2 but not π).
        let phi_bounds: Vec<[f64; 2]> = (1..bins)
            .map(|k| match 2 * k == bins {
                true => [-1.0, 0.0],
                false => {
                    let a = angle(k, 2.0 * std::f64::consts::PI);
                    [a.cos(), a.sin()]
                }
            })
            .collect();
        let cells = GUIDE_CELLS * bins;
        // Polar: `u.z` (the value less 1) at or below the boundary. Azimuth: the boundary's
        // pseudo-angle at or below the value.
        let theta_guide = Guide::new(cells, 2.0, bins - 1, |k, value| {
            value - 1.0 <= theta_bounds[k]
        });
        let phi_guide = Guide::new(cells, 4.0, bins - 1, |k, value| {
            let [x, y] = phi_bounds[k];
            pseudo_angle(x, y) <= value
        });
        Self {
            bins,
            center,
            extent,
            inv_extent: 1.0 / extent,
            center_length: center.length(),
            theta_bounds,
            phi_bounds,
            theta_guide,
            phi_guide,
        }
    }

    /// The unit normal at the center of normal bin `(i, j)`.
    fn normal(&self, i: usize, j: usize) -> DVec3 {
        self.direction(i as f64 + 0.5, j as f64 + 0.5)
    }

    /// The unit vector at fractional bin coordinates `(i, j)` (polar, azimuth).
    fn direction(&self, i: f64, j: f64) -> DVec3 {
        let theta = i / self.bins as f64 * std::f64::consts::PI;
        let phi = j / self.bins as f64 * 2.0 * std::f64::consts::PI;
        DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    /// An upper bound of the distance from the center normal of a bin of row `i` to any unit
    /// vector of that bin: the farthest of its corners (the distance from a point of the sphere
    /// has no maximum inside a bin, nor inside an edge of constant azimuth, and grows along an
    /// edge of constant polar angle away from the center's azimuth), with a margin.
    fn spread(&self, i: usize) -> f64 {
        let center = self.normal(i, 0);
        let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
        let far = corners
            .iter()
            .map(|&(di, dj)| (self.direction(i as f64 + di, dj) - center).length())
            .fold(0.0f64, f64::max);
        far * (1.0 + 1e-6) + 1e-12
    }

    /// The polar bin of the unit normal `u`: the number of boundaries `k π / bins` that
    /// `acos(u.z)` reaches, i.e. with `u.z <= cos(k π / bins)`.
    #[inline]
    fn theta_bin(&self, u: DVec3) -> usize {
        let bounds = &self.theta_bounds;
        self.theta_guide
            .count(u.z + 1.0, bounds.len(), |k| u.z <= bounds[k])
    }

    /// The azimuth bin of the unit normal `u`: the number of boundaries `2 k π / bins` that
    /// `atan2(u.y, u.x)` (in [0, 2π)) reaches. Within one half-plane the angle grows with the
    /// sign of the cross product against the boundary's direction; a boundary in the upper half
    /// ([0, π)) is reached by every direction of the lower half.
    #[inline]
    fn phi_bin(&self, u: DVec3) -> usize {
        if u.x == 0.0 && u.y == 0.0 {
            return 0;
        }
        let upper = u.y > 0.0 || (u.y == 0.0 && u.x > 0.0);
        let (bins, bounds) = (self.bins, &self.phi_bounds);
        self.phi_guide
            .count(pseudo_angle(u.x, u.y), bounds.len(), |k| {
                let bound_upper = 2 * (k + 1) < bins;
                let [c, s] = bounds[k];
                (bound_upper != upper && bound_upper)
                    | (bound_upper == upper && c * u.y - s * u.x >= 0.0)
            })
    }

    /// The bin of the plane `m · y < k` (flat index `(i · bins + j) · bins + k`), or `None` when
    /// it misses the light (its distance from the center is `extent` or more); `inv` is
    /// `1 / |m|` (the shader's arithmetic, one division and one square root per plane).
    #[inline]
    fn locate(&self, m: DVec3, k: f64, inv: f64) -> Option<usize> {
        let u = m * inv;
        let d = (k * inv - u.dot(self.center)) * self.inv_extent;
        if !(-1.0..1.0).contains(&d) {
            return None;
        }
        let b = self.bins as f64;
        let (i, j) = (self.theta_bin(u), self.phi_bin(u));
        let k = (((d + 1.0) * 0.5 * b) as usize).min(self.bins - 1);
        Some((i * self.bins + j) * self.bins + k)
    }

    /// For each normal bin `(i, j)` (in index order, in parallel), calls `fill(i, j, chunk)` on
    /// its `bins * per_bin` values.
    fn fill_by_normal(
        &self,
        values: &mut [u64],
        per_bin: usize,
        fill: impl Fn(usize, usize, &mut [u64]) + Sync,
    ) {
        let bins = self.bins;
        values
            .par_chunks_mut(bins * per_bin)
            .enumerate()
            .for_each(|(ij, chunk)| fill(ij / bins, ij % bins, chunk));
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

/// The paper's plane-to-bitmask lookup table: for a unit normal (two angles) and a signed
/// distance from the light's center (in units of the light's extent), the samples behind the
/// plane at the bin's center.
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
        let mut masks = vec![0u64; bins * bins * bins * words];
        let distance = |k: usize| ((k as f64 + 0.5) / bins as f64 * 2.0 - 1.0) * extent;
        grid.fill_by_normal(&mut masks, words, |i, j, chunk| {
            let m = grid.normal(i, j);
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
        Ok(Self { grid, words, masks })
    }

    /// The mask of samples with `m · y < k` (`inv = 1 / |m|`), or `None` when the plane misses
    /// the light (all or none of it behind: the caller decides by the center).
    pub(crate) fn lookup(&self, m: DVec3, k: f64, inv: f64) -> Option<&[u64]> {
        let at = self.grid.locate(m, k, inv)? * self.words;
        Some(&self.masks[at..at + self.words])
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
/// A plane `m · y < k` of normal bin `(i, j)` (unit normal `u` within `spread(i)` of the bin's
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
        let mut masks = vec![0u64; bins * bins * bins * 2 * words];
        let b = bins as f64;
        // The first distance bin [d0, d1) whose d0 (d1 for `ahead`) exceeds `d`, in units of extent.
        let first_bin_past = |d: f64, ahead: bool| {
            let edge = (d + 1.0) * 0.5 * b - f64::from(u8::from(ahead));
            (edge.floor() + 1.0).clamp(0.0, b) as usize
        };
        grid.fill_by_normal(&mut masks, 2 * words, |i, j, chunk| {
            let (u0, spread) = (grid.normal(i, j), grid.spread(i));
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

    /// The binary search of `alias_free.wgsl`.
    fn leading_true(n: usize, pred: impl Fn(usize) -> bool) -> usize {
        let (mut lo, mut hi) = (0, n);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if pred(mid) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    #[test]
    fn guided_bins_are_the_shaders_binary_searches() {
        // Random normals, normals on and next to every boundary, the poles and the axes.
        let mut rng = Rng::new(12);
        for bins in [4, 7, 16, 64, 128, 256] {
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
            for i in 0..=bins {
                for j in 0..=bins {
                    let u = g.direction(i as f64, j as f64);
                    normals.extend([
                        u,
                        u * (1.0 + 1e-16),
                        DVec3::new(u.x.next_up(), u.y.next_down(), u.z.next_up()),
                    ]);
                }
            }
            let tiny = f64::from_bits(1);
            normals.extend([
                DVec3::Z,
                -DVec3::Z,
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
            ]);
            normals.extend(
                [
                    (1.0, -tiny),
                    (-1.0, tiny),
                    (-1.0, -tiny),
                    (tiny, -1.0),
                    (-tiny, 1.0),
                ]
                .map(|(x, y)| DVec3::new(x, y, 0.3)),
            );
            for m in normals.into_iter().filter(|m| m.length() > 0.0) {
                let u = m / m.length();
                let theta = leading_true(g.theta_bounds.len(), |k| u.z <= g.theta_bounds[k]);
                assert_eq!(g.theta_bin(u), theta, "{bins} bins, {u}");
                if u.x != 0.0 || u.y != 0.0 {
                    let upper = u.y > 0.0 || (u.y == 0.0 && u.x > 0.0);
                    let phi = leading_true(g.phi_bounds.len(), |k| {
                        let bound_upper = 2 * (k + 1) < bins;
                        if bound_upper != upper {
                            return bound_upper;
                        }
                        let [c, s] = g.phi_bounds[k];
                        c * u.y - s * u.x >= 0.0
                    });
                    assert_eq!(g.phi_bin(u), phi, "{bins} bins, {u}");
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
        for i in 0..12 {
            for j in 0..12 {
                let m = g.normal(i, j);
                for k in 0..12 {
                    let d = ((k as f64 + 0.5) / 12.0 * 2.0 - 1.0) * 1.1;
                    let at = ((i * 12 + j) * 12 + k) * lut.words;
                    assert_eq!(
                        lut.masks[at..at + lut.words],
                        exact(&light, m, m.dot(center) + d)[..]
                    );
                }
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
