//! Light samples binned along the two axes of a plane, so that the samples in an axis-aligned box
//! of it are found, as a bitmask, by four table look-ups.
//!
//! Methods that test every light sample against a shape projected onto the light's plane (stsv's
//! cones through a triangle, backprojection's micro-occluders) need only test the samples in the
//! shape's bounding box: the others cannot be inside, so the bits are the same.

/// Points of a plane, as bits `k` of a `words`-word mask, binned along each axis: per axis and
/// bin `j`, the points in bins `>= j` and those in bins `<= j`. The points in a box are then the
/// AND of four rows (a superset: the box's end bins hold points outside it too).
#[derive(Debug, Clone)]
pub struct BoxBins {
    /// Per axis, the points' lowest and highest coordinates and the bins per unit between.
    low: [f64; 2],
    high: [f64; 2],
    scale: [f64; 2],
    bins: usize,
    words: usize,
    /// Per axis, `words` per bin `j`: the points in bins `>= j`, and in bins `<= j`.
    from: [Vec<u64>; 2],
    upto: [Vec<u64>; 2],
}

impl BoxBins {
    /// The bins per axis of `count` points: about one point per bin along each axis.
    pub fn bins_for(count: usize) -> usize {
        count.clamp(8, 256)
    }

    /// The bytes of the tables of `count` points (two per axis).
    pub fn bytes(count: usize) -> u64 {
        4 * Self::bins_for(count) as u64 * count.div_ceil(64) as u64 * 8
    }

    /// Bins the points `at` (their first two coordinates), point `k` as bit `k`.
    pub fn new(at: &[[f64; 2]]) -> Self {
        let words = at.len().div_ceil(64);
        let bins = Self::bins_for(at.len());
        let mut out = Self {
            low: [f64::INFINITY; 2],
            high: [f64::NEG_INFINITY; 2],
            scale: [0.0; 2],
            bins,
            words,
            from: [vec![0; bins * words], vec![0; bins * words]],
            upto: [vec![0; bins * words], vec![0; bins * words]],
        };
        for axis in 0..2 {
            for c in at {
                out.low[axis] = out.low[axis].min(c[axis]);
                out.high[axis] = out.high[axis].max(c[axis]);
            }
            let span = out.high[axis] - out.low[axis];
            out.scale[axis] = if span > 0.0 { bins as f64 / span } else { 0.0 };
            let mut per_bin = vec![0u64; bins * words];
            for (k, c) in at.iter().enumerate() {
                per_bin[out.bin(axis, c[axis]) * words + k / 64] |= 1 << (k % 64);
            }
            let (from, upto) = (&mut out.from[axis], &mut out.upto[axis]);
            for j in 0..bins {
                for w in 0..words {
                    let below = if j > 0 { upto[(j - 1) * words + w] } else { 0 };
                    upto[j * words + w] = below | per_bin[j * words + w];
                    let i = bins - 1 - j;
                    let above = if j > 0 { from[(i + 1) * words + w] } else { 0 };
                    from[i * words + w] = above | per_bin[i * words + w];
                }
            }
        }
        out
    }

    /// The bin of coordinate `x` along `axis` (monotone in `x`, clamped to the bins).
    #[inline(always)]
    fn bin(&self, axis: usize, x: f64) -> usize {
        // Clamped in f64 (NaN to 0 too), then one conversion instruction.
        let bin = ((x - self.low[axis]) * self.scale[axis]).clamp(0.0, (self.bins - 1) as f64);
        bin as u32 as usize
    }

    /// Whether the span `lo..=hi` along `axis` meets the points' coordinates.
    #[inline(always)]
    pub fn overlaps(&self, axis: usize, lo: f64, hi: f64) -> bool {
        hi >= self.low[axis] && lo <= self.high[axis]
    }

    /// Merges into `out` (`words` words), word by word (`merge(word, binned)`), the points binned
    /// in the box `lo..=hi` (a superset of those in it; none when the box misses every point's
    /// coordinates).
    #[inline(always)]
    pub fn merge_box(
        &self,
        lo: [f64; 2],
        hi: [f64; 2],
        out: &mut [u64],
        merge: impl Fn(&mut u64, u64),
    ) {
        if (0..2).any(|axis| !self.overlaps(axis, lo[axis], hi[axis])) {
            out.iter_mut().for_each(|o| merge(o, 0));
            return;
        }
        let w = self.words;
        fn run(table: &[u64], bin: usize, w: usize) -> &[u64] {
            &table[bin * w..bin * w + w]
        }
        let x = run(&self.from[0], self.bin(0, lo[0]), w).iter().zip(run(
            &self.upto[0],
            self.bin(0, hi[0]),
            w,
        ));
        let y = run(&self.from[1], self.bin(1, lo[1]), w).iter().zip(run(
            &self.upto[1],
            self.bin(1, hi[1]),
            w,
        ));
        for ((o, (a0, a1)), (b0, b1)) in out.iter_mut().zip(x).zip(y) {
            merge(o, a0 & a1 & b0 & b1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::Rng;

    #[test]
    fn a_box_finds_every_point_inside_it() {
        let mut rng = Rng::new(3);
        let mut next = || f64::from(rng.next_f32());
        for count in [1usize, 5, 64, 100, 256, 700] {
            let at: Vec<[f64; 2]> = (0..count).map(|_| [next() * 2.0 - 1.0, next()]).collect();
            let bins = BoxBins::new(&at);
            for _ in 0..200 {
                let (a, b) = ([next() * 2.4 - 1.2, next()], [next() * 2.4 - 1.2, next()]);
                let (lo, hi) = (
                    [a[0].min(b[0]), a[1].min(b[1])],
                    [a[0].max(b[0]), a[1].max(b[1])],
                );
                let mut found = vec![0u64; count.div_ceil(64)];
                bins.merge_box(lo, hi, &mut found, |o, binned| *o = binned);
                for (k, c) in at.iter().enumerate() {
                    let inside = (0..2).all(|i| lo[i] <= c[i] && c[i] <= hi[i]);
                    let bit = found[k / 64] >> (k % 64) & 1 == 1;
                    assert!(
                        bit || !inside,
                        "point {k} {c:?} in {lo:?}..{hi:?} not found"
                    );
                }
                // A superset, but a tight one: nothing beyond the box's end bins.
                let slack = [0, 1].map(|i| 1.0 / bins.scale[i].max(1e-300));
                for (k, c) in at.iter().enumerate() {
                    if found[k / 64] >> (k % 64) & 1 == 1 {
                        assert!(
                            (0..2).all(|i| lo[i] - slack[i] <= c[i] && c[i] <= hi[i] + slack[i])
                        );
                    }
                }
            }
        }
    }
}
