//! Image pyramids over shadow maps: min/max depth pyramids (hierarchical shadow maps for
//! backprojection), multi-scale shadow maps (the depth range of every power-of-two
//! neighbourhood of every texel), summed-area tables and mipmaps (prefiltering for CSSM and PCSS).
//!
//! # Conventions
//!
//! - Images are row-major, texel `(x, y)` at `y * width + x`; multi-channel images interleave
//!   channels (`(y * width + x) * channels + c`).
//! - Each pyramid level is half the size of the one below, **rounding up**; texel `i` of level
//!   `L + 1` is built from texels `2i` and `2i + 1` of level `L` (whichever exist), so texel `i` of
//!   level `L` covers exactly the level-0 texels `[i·2^L, (i+1)·2^L)` that lie in the image.
//! - Continuous coordinates are in **level-0 texel units**: texel `x` covers `[x, x+1)` and its
//!   center is `x + 0.5`, whatever the level.

use crate::error::{Error, Result};
use crate::limits::{self, Peak};
use crate::raster::depth::DepthMap;
use rayon::prelude::*;

fn check_image(arg: &str, width: usize, height: usize, channels: usize, len: usize) -> Result<()> {
    if width == 0 || height == 0 || channels == 0 || len != width * height * channels {
        return Err(Error::invalid(
            arg,
            format!("expected a non-empty {height}x{width} image with {channels} channel(s) ({} values), got {len}", width * height * channels),
        ));
    }
    Ok(())
}

/// One level of a [`MinMaxPyramid`]: per texel the minimum and maximum over the drawn (finite)
/// level-0 texels it covers; `min = +inf`, `max = −inf` where it covers none.
#[derive(Debug, Clone, PartialEq)]
pub struct MinMaxLevel {
    pub width: usize,
    pub height: usize,
    pub min: Vec<f32>,
    pub max: Vec<f32>,
}

/// Min/max depth pyramid of a depth map (hierarchical shadow map). Empty texels (`+inf`, nothing
/// drawn) are ignored: they lower no minimum and raise no maximum, so a region's `(min, max)` is
/// the depth range of the occluders inside it, and a region with no occluder reads as empty.
#[derive(Debug, Clone, PartialEq)]
pub struct MinMaxPyramid {
    /// Level 0 is the full-resolution map; the last level is 1 × 1.
    pub levels: Vec<MinMaxLevel>,
}

impl MinMaxPyramid {
    /// Builds the pyramid of a `width × height` depth image (`+inf` = empty).
    ///
    /// Errors: wrong length; NaN or `−inf` depths; `TooLarge` past the memory limit.
    /// The memory of the pyramid of a `width × height` image: two f32 per texel over all levels,
    /// at most 4/3 of level 0 (plus rounding), so 3x is safe.
    pub fn peak(width: usize, height: usize) -> Peak {
        Peak::default().buffer(&[width as u64, height as u64, 8, 3])
    }

    pub fn new(width: usize, height: usize, depth: &[f32]) -> Result<Self> {
        check_image("depth", width, height, 1, depth.len())?;
        if depth.iter().any(|d| d.is_nan() || *d == f32::NEG_INFINITY) {
            return Err(Error::invalid(
                "depth",
                "contains NaN or -inf (use +inf for empty texels)",
            ));
        }
        limits::check_memory("min/max pyramid", Self::peak(width, height).bytes())?;
        let base = MinMaxLevel {
            width,
            height,
            min: depth.to_vec(),
            max: depth
                .iter()
                .map(|&d| if d.is_finite() { d } else { f32::NEG_INFINITY })
                .collect(),
        };
        let mut levels = vec![base];
        while let Some(next) = levels.last().and_then(reduce_min_max) {
            levels.push(next);
        }
        Ok(Self { levels })
    }

    /// The pyramid of a [`DepthMap`].
    pub fn from_depth_map(map: &DepthMap) -> Result<Self> {
        Self::new(map.width, map.height, &map.depth)
    }

    /// Number of levels (level 0 included).
    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// `(min, max)` depth of the drawn texels in the half-open rectangle `[x0, x1) × [y0, y1)` of
    /// level `level`'s texels (clamped to the level). `None` when the rectangle is empty after
    /// clamping, the level does not exist, or no drawn texel lies inside.
    pub fn query(
        &self,
        level: usize,
        x0: usize,
        y0: usize,
        x1: usize,
        y1: usize,
    ) -> Option<(f32, f32)> {
        let l = self.levels.get(level)?;
        let (x1, y1) = (x1.min(l.width), y1.min(l.height));
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in y0..y1 {
            let row = y * l.width;
            for x in x0..x1 {
                lo = lo.min(l.min[row + x]);
                hi = hi.max(l.max[row + x]);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Conservative `(min, max)` over the level-0 rectangle `[x0, x1) × [y0, y1)`: read at the
    /// finest level where it spans at most 2 × 2 texels, so the answer covers a superset of the
    /// rectangle (up to twice its size per axis): `min` may be lower and `max` higher than exact.
    pub fn query_region(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> Option<(f32, f32)> {
        if x0 >= x1 || y0 >= y1 {
            return None;
        }
        let level = self.region_level(x0, y0, x1, y1);
        self.query(
            level,
            x0 >> level,
            y0 >> level,
            ((x1 - 1) >> level) + 1,
            ((y1 - 1) >> level) + 1,
        )
    }

    /// The level [`MinMaxPyramid::query_region`] reads for the non-empty level-0 rectangle
    /// `[x0, x1) × [y0, y1)`: the finest where it spans at most 2 × 2 texels.
    pub fn region_level(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> usize {
        (0..self.levels.len())
            .find(|&l| ((x1 - 1) >> l) - (x0 >> l) <= 1 && ((y1 - 1) >> l) - (y0 >> l) <= 1)
            .unwrap_or(self.levels.len().saturating_sub(1))
    }
}

/// The next coarser level, `None` once `l` is 1 × 1.
fn reduce_min_max(l: &MinMaxLevel) -> Option<MinMaxLevel> {
    if l.width == 1 && l.height == 1 {
        return None;
    }
    let (w, h) = (l.width.div_ceil(2), l.height.div_ceil(2));
    let mut min = vec![f32::INFINITY; w * h];
    let mut max = vec![f32::NEG_INFINITY; w * h];
    min.par_chunks_mut(w)
        .zip(max.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (mn, mx))| {
            for (x, (a, b)) in mn.iter_mut().zip(mx.iter_mut()).enumerate() {
                let (kids, n) = children(x, y, l.width, l.height);
                for &(cx, cy) in &kids[..n] {
                    *a = a.min(l.min[cy * l.width + cx]);
                    *b = b.max(l.max[cy * l.width + cx]);
                }
            }
        });
    Some(MinMaxLevel {
        width: w,
        height: h,
        min,
        max,
    })
}

/// The (1, 2 or 4) texels of a `w × h` level that texel `(x, y)` of the next level covers: the
/// first `count` entries of the array.
fn children(x: usize, y: usize, w: usize, h: usize) -> ([(usize, usize); 4], usize) {
    let mut out = [(0, 0); 4];
    let mut count = 0;
    for cy in 2 * y..(2 * y + 2).min(h) {
        for cx in 2 * x..(2 * x + 2).min(w) {
            out[count] = (cx, cy);
            count += 1;
        }
    }
    (out, count)
}

/// A multi-scale shadow map (MSSM, Schwarz and Stamminger 2007): for every texel `(x, y)` and
/// every scale `k`, the `(min, max)` depth over the `2^k × 2^k` square of texels from `(x, y)`
/// (clipped to the image). Any rectangle is the union of a few such squares, so its depth range
/// comes out exactly in a handful of reads (the HSM reads a superset). Empty texels as in
/// [`MinMaxPyramid`]. Memory: `8 · scales` bytes per texel.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiScaleMap {
    pub width: usize,
    pub height: usize,
    /// `scales[k]`: the per-texel `(min, max)` of the `2^k` squares, row-major.
    pub scales: Vec<MinMaxLevel>,
}

impl MultiScaleMap {
    /// The MSSM of a `width × height` depth image (`+inf` = empty), up to squares covering it.
    ///
    /// Errors: wrong length; NaN or `−inf` depths; `TooLarge` past the memory limit.
    pub fn new(width: usize, height: usize, depth: &[f32]) -> Result<Self> {
        Self::from_level(
            MinMaxPyramid::new(width, height, depth)?
                .levels
                .swap_remove(0),
        )
    }

    /// The number of scales of the MSSM of a `width × height` map: sides 1, 2, 4, … up to the
    /// first that covers the map.
    fn scale_count(width: usize, height: usize) -> usize {
        usize::BITS as usize - (width.max(height).max(1) - 1).leading_zeros() as usize + 1
    }

    /// The memory of the MSSM of a `width × height` map: one min/max level per scale.
    pub fn peak(width: usize, height: usize) -> Peak {
        Peak::default().buffer(&[
            width as u64,
            height as u64,
            8,
            Self::scale_count(width, height) as u64,
        ])
    }

    /// The MSSM over the texels of a min/max level (for the YSM: a level of an HSM, whose texels
    /// each hold a range already).
    pub fn from_level(base: MinMaxLevel) -> Result<Self> {
        let (width, height) = (base.width, base.height);
        limits::check_memory("multi-scale shadow map", Self::peak(width, height).bytes())?;
        let count = Self::scale_count(width, height);
        let mut scales = vec![base];
        for k in 1..count {
            let next = Self::coarser(&scales[k - 1], 1 << (k - 1));
            scales.push(next);
        }
        Ok(Self {
            width,
            height,
            scales,
        })
    }

    /// The MSSM of an HSM level that does not keep its own finest scale: that scale is `base`
    /// itself, which the HSM holds already (the Y shadow map of Schwarz and Stamminger 2008,
    /// section 6: "MSSM level 0 and HSM level n − 1 are identical and hence MSSM level 0 is not
    /// explicitly stored"). Query it with [`MultiScaleMap::query_over`] and that level.
    pub fn sharing_finest(base: &MinMaxLevel) -> Result<Self> {
        let mut map = Self::from_level(base.clone())?;
        map.scales[0] = MinMaxLevel {
            width: base.width,
            height: base.height,
            min: Vec::new(),
            max: Vec::new(),
        };
        Ok(map)
    }

    /// The `(min, max)` of the squares twice as large as those of `prev` (side `2 half`).
    fn coarser(prev: &MinMaxLevel, half: usize) -> MinMaxLevel {
        let (width, height) = (prev.width, prev.height);
        let mut min = vec![f32::INFINITY; width * height];
        let mut max = vec![f32::NEG_INFINITY; width * height];
        min.par_chunks_mut(width)
            .zip(max.par_chunks_mut(width))
            .enumerate()
            .for_each(|(y, (mn, mx))| {
                for x in 0..width {
                    for (dx, dy) in [(0, 0), (half, 0), (0, half), (half, half)] {
                        if x + dx < width && y + dy < height {
                            let i = (y + dy) * width + x + dx;
                            mn[x] = mn[x].min(prev.min[i]);
                            mx[x] = mx[x].max(prev.max[i]);
                        }
                    }
                }
            });
        MinMaxLevel {
            width,
            height,
            min,
            max,
        }
    }

    /// Exact `(min, max)` over the drawn texels of `[x0, x1) × [y0, y1)` (clamped to the image);
    /// `None` when it holds none.
    pub fn query(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> Option<(f32, f32)> {
        self.query_over(&self.scales[0], x0, y0, x1, y1)
    }

    /// [`MultiScaleMap::query`] reading its finest scale from `finest` (a map built by
    /// [`MultiScaleMap::sharing_finest`] from that level).
    pub fn query_over(
        &self,
        finest: &MinMaxLevel,
        x0: usize,
        y0: usize,
        x1: usize,
        y1: usize,
    ) -> Option<(f32, f32)> {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        if x0 >= x1 || y0 >= y1 {
            return None;
        }
        let side = (x1 - x0).min(y1 - y0);
        let k = ((usize::BITS - 1 - side.leading_zeros()) as usize).min(self.scales.len() - 1);
        let (s, level) = (1usize << k, if k == 0 { finest } else { &self.scales[k] });
        // Squares from a grid of step s, the last one flush with the far edge: they cover the
        // rectangle exactly (at most 2 per axis for a squarish one).
        let starts = |a: usize, b: usize| {
            (a..b)
                .step_by(s)
                .map(move |v| v.min(b.saturating_sub(s).max(a)))
        };
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in starts(y0, y1) {
            for x in starts(x0, x1) {
                let i = y * self.width + x;
                lo = lo.min(level.min[i]);
                hi = hi.max(level.max[i]);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.scales.iter().map(|l| l.min.len() * 8).sum()
    }
}

/// A multi-channel summed-area table in **f64**.
///
/// Why f64: an f32 table of a 2048 × 2048 image of uniform values in [0, 1] holds sums up to
/// 4·10^6, where an f32 ulp is 0.25-0.5, and a box sum is a difference of such values. Measured
/// on that image (2000 random boxes per size), the f32 table's worst relative box-sum errors are
/// 3.7e-2 (4 × 4 boxes), 6.2e-3 (16 × 16), 6.1e-4 (64 × 64) and 6.3e-5 (256 × 256). The f64
/// table gave exactly the brute-force f64 sums there (those values have 24-bit fractions and the
/// totals stay below 2^22, which fits f64's 53-bit mantissa); in general its relative box-sum
/// error is about 1e-16 times (table magnitude / box sum), far below anything a filter can see.
///
/// Layout: `(height + 1) × (width + 1)` entries of `channels` interleaved values; entry `(x, y)` is
/// the sum over texels `[0, x) × [0, y)`. Boxes take continuous level-0 coordinates: since the
/// image is piecewise constant, its integral `F(x, y)` over `[0, x] × [0, y]` is bilinear inside
/// each texel, so bilinear interpolation of the table gives *exact* fractional box sums.
#[derive(Debug, Clone, PartialEq)]
pub struct SummedAreaTable {
    width: usize,
    height: usize,
    channels: usize,
    table: Vec<f64>,
}

impl SummedAreaTable {
    /// The memory of the table of a `width × height` image with `channels` channels.
    pub fn peak(width: usize, height: usize, channels: usize) -> Peak {
        Peak::default().buffer(&[width as u64 + 1, height as u64 + 1, channels as u64, 8])
    }

    /// A table of a `width × height` image with `channels` interleaved channels.
    ///
    /// Errors: wrong length, non-finite values, `TooLarge` past the memory limit.
    pub fn new(width: usize, height: usize, channels: usize, data: &[f32]) -> Result<Self> {
        check_image("image", width, height, channels, data.len())?;
        if data.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("image", "contains NaN or Inf"));
        }
        let (tw, th) = (width + 1, height + 1);
        limits::check_memory(
            "summed-area table",
            Self::peak(width, height, channels).bytes(),
        )?;
        let mut table = vec![0.0f64; tw * th * channels];
        // Row prefix sums in parallel (row y of the image fills table row y + 1) ...
        table
            .par_chunks_mut(tw * channels)
            .skip(1)
            .enumerate()
            .for_each(|(y, row)| {
                let src = &data[y * width * channels..(y + 1) * width * channels];
                for x in 0..width {
                    for c in 0..channels {
                        row[(x + 1) * channels + c] =
                            row[x * channels + c] + src[x * channels + c] as f64;
                    }
                }
            });
        // ... then the column sums, one row after the other.
        let stride = tw * channels;
        for y in 1..th {
            let (above, rest) = table.split_at_mut(y * stride);
            let prev = &above[(y - 1) * stride..];
            rest[..stride]
                .iter_mut()
                .zip(prev)
                .for_each(|(v, p)| *v += *p);
        }
        Ok(Self {
            width,
            height,
            channels,
            table,
        })
    }

    /// A table of several single-channel images of the same size (stored interleaved).
    pub fn from_channels(width: usize, height: usize, images: &[&[f32]]) -> Result<Self> {
        if images.is_empty() {
            return Err(Error::invalid("images", "needs at least one channel"));
        }
        for img in images {
            check_image("images", width, height, 1, img.len())?;
        }
        let c = images.len();
        let data: Vec<f32> = (0..width * height)
            .flat_map(|i| images.iter().map(move |img| img[i]))
            .collect();
        debug_assert_eq!(data.len(), width * height * c);
        Self::new(width, height, c, &data)
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Table entries and weights whose blend is the integral over `[0, x] × [0, y]`, with `x`, `y`
    /// already clamped to the image.
    fn corners(&self, x: f64, y: f64) -> [(usize, f64); 4] {
        let (i, fx) = split(x, self.width);
        let (j, fy) = split(y, self.height);
        let (tw, c) = (self.width + 1, self.channels);
        let at = |xx: usize, yy: usize| (yy * tw + xx) * c;
        [
            (at(i, j), (1.0 - fx) * (1.0 - fy)),
            (at(i + 1, j), fx * (1.0 - fy)),
            (at(i, j + 1), (1.0 - fx) * fy),
            (at(i + 1, j + 1), fx * fy),
        ]
    }

    /// Channel `k` of the integral described by `corners` (zero weights skipped, so integer
    /// coordinates read the table exactly).
    #[inline]
    fn integral(&self, corners: &[(usize, f64); 4], k: usize) -> f64 {
        corners
            .iter()
            .filter(|(_, w)| *w != 0.0)
            .map(|(base, w)| self.table[base + k] * w)
            .sum()
    }

    /// The corners of the box `[x0, x1) × [y0, y1)` ∩ image as `(x1,y1), (x0,y1), (x1,y0), (x0,y0)`,
    /// or `None` when the intersection is empty.
    fn box_corners(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> Option<[[(usize, f64); 4]; 4]> {
        let (x0, x1) = (clamp_coord(x0, self.width), clamp_coord(x1, self.width));
        let (y0, y1) = (clamp_coord(y0, self.height), clamp_coord(y1, self.height));
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        Some([
            self.corners(x1, y1),
            self.corners(x0, y1),
            self.corners(x1, y0),
            self.corners(x0, y0),
        ])
    }

    #[inline]
    fn sum_channel(&self, b: &[[(usize, f64); 4]; 4], k: usize) -> f64 {
        self.integral(&b[0], k) - self.integral(&b[1], k) - self.integral(&b[2], k)
            + self.integral(&b[3], k)
    }

    /// Sums of every channel over the box `[x0, x1) × [y0, y1)` ∩ image (level-0 texel units,
    /// fractional allowed) into `out[..channels]`. An empty intersection sums to 0.
    pub fn box_sum_into(&self, x0: f64, y0: f64, x1: f64, y1: f64, out: &mut [f64]) {
        let b = self.box_corners(x0, y0, x1, y1);
        for (k, o) in out.iter_mut().enumerate().take(self.channels) {
            *o = b.as_ref().map_or(0.0, |b| self.sum_channel(b, k));
        }
    }

    /// The sum of `channel` over the box (see [`SummedAreaTable::box_sum_into`]). Panics when
    /// `channel >= channels()` (a programming error, like slice indexing).
    pub fn box_sum(&self, channel: usize, x0: f64, y0: f64, x1: f64, y1: f64) -> f64 {
        assert!(
            channel < self.channels,
            "channel {channel} of a {}-channel table",
            self.channels
        );
        self.box_corners(x0, y0, x1, y1)
            .map_or(0.0, |b| self.sum_channel(&b, channel))
    }

    /// The box a mean sums over and its area: the box ∩ image, or when that has zero area the
    /// texel nearest to the box center.
    fn mean_box(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> ([f64; 4], f64) {
        let (cx0, cx1) = (clamp_coord(x0, self.width), clamp_coord(x1, self.width));
        let (cy0, cy1) = (clamp_coord(y0, self.height), clamp_coord(y1, self.height));
        let area = (cx1 - cx0) * (cy1 - cy0);
        if cx1 > cx0 && cy1 > cy0 && area > 0.0 {
            ([cx0, cy0, cx1, cy1], area)
        } else {
            let tx = texel_index(0.5 * (x0 + x1), self.width) as f64;
            let ty = texel_index(0.5 * (y0 + y1), self.height) as f64;
            ([tx, ty, tx + 1.0, ty + 1.0], 1.0)
        }
    }

    /// Means of every channel over the box ∩ image (divided by the clamped area) into
    /// `out[..channels]`. When that intersection has zero area, the value of the texel nearest to
    /// the box center.
    pub fn box_mean_into(&self, x0: f64, y0: f64, x1: f64, y1: f64, out: &mut [f64]) {
        let ([a, b, c, d], area) = self.mean_box(x0, y0, x1, y1);
        self.box_sum_into(a, b, c, d, out);
        out.iter_mut().take(self.channels).for_each(|v| *v /= area);
    }

    /// The mean of `channel` over the box (see [`SummedAreaTable::box_mean_into`]). Panics when
    /// `channel >= channels()`.
    pub fn box_mean(&self, channel: usize, x0: f64, y0: f64, x1: f64, y1: f64) -> f64 {
        let ([a, b, c, d], area) = self.mean_box(x0, y0, x1, y1);
        self.box_sum(channel, a, b, c, d) / area
    }
}

/// `t` clamped to `[0, n]` (NaN → 0).
fn clamp_coord(t: f64, n: usize) -> f64 {
    if t.is_nan() {
        0.0
    } else {
        t.clamp(0.0, n as f64)
    }
}

/// The texel of `[0, n)` nearest to coordinate `t`.
fn texel_index(t: f64, n: usize) -> usize {
    (clamp_coord(t, n).floor() as usize).min(n - 1)
}

/// `t` in `[0, n]` as a cell `i` in `[0, n−1]` and a fraction in `[0, 1]`.
fn split(t: f64, n: usize) -> (usize, f64) {
    let i = (t.floor() as usize).min(n - 1);
    (i, t - i as f64)
}

/// One level of a [`MipMap`] (`channels` interleaved values per texel).
#[derive(Debug, Clone, PartialEq)]
pub struct MipLevel {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

/// A box-filtered mipmap: each texel of level `L + 1` is the mean of its (1, 2 or 4) children of
/// level `L`. Lookups take level-0 texel coordinates at every level and clamp to the edge.
#[derive(Debug, Clone, PartialEq)]
pub struct MipMap {
    channels: usize,
    levels: Vec<MipLevel>,
}

impl MipMap {
    /// The memory of the mipmap of a `width × height` image with `channels` channels: all levels
    /// hold at most 4/3 of level 0 (plus rounding), so 3x is safe.
    pub fn peak(width: usize, height: usize, channels: usize) -> Peak {
        Peak::default().buffer(&[width as u64, height as u64, channels as u64, 4, 3])
    }

    /// The mipmap of a `width × height` image with `channels` interleaved channels.
    ///
    /// Errors: wrong length, non-finite values, `TooLarge` past the memory limit.
    pub fn new(width: usize, height: usize, channels: usize, data: &[f32]) -> Result<Self> {
        check_image("image", width, height, channels, data.len())?;
        if data.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("image", "contains NaN or Inf"));
        }
        limits::check_memory("mipmap", Self::peak(width, height, channels).bytes())?;
        let mut levels = vec![MipLevel {
            width,
            height,
            data: data.to_vec(),
        }];
        while let Some(next) = levels.last().and_then(|l| reduce_mean(l, channels)) {
            levels.push(next);
        }
        Ok(Self { channels, levels })
    }

    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Number of levels (level 0 included; the last is 1 × 1).
    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `l`, if it exists.
    pub fn level(&self, l: usize) -> Option<&MipLevel> {
        self.levels.get(l)
    }

    /// The four texels and weights of a bilinear lookup at `level` (clamped to the last level).
    fn taps(&self, level: usize, x: f64, y: f64) -> Taps<'_> {
        let level = level.min(self.levels.len() - 1);
        let l = &self.levels[level];
        let scale = 0.5f64.powi(level as i32);
        let (i0, i1, fx) = lerp_taps(x * scale - 0.5, l.width);
        let (j0, j1, fy) = lerp_taps(y * scale - 0.5, l.height);
        let c = self.channels;
        let at = |i: usize, j: usize| (j * l.width + i) * c;
        Taps {
            data: &l.data,
            idx: [at(i0, j0), at(i1, j0), at(i0, j1), at(i1, j1)],
            fx,
            fy,
        }
    }

    /// Bilinear lookup of every channel at level `level` (clamped to the last level) and level-0
    /// texel coordinates `(x, y)`, into `out[..channels]`. Level `L` has its texel centers at
    /// `(i + 0.5)·2^L`; outside the outermost centers the lookup clamps to the edge.
    pub fn bilinear_into(&self, level: usize, x: f64, y: f64, out: &mut [f32]) {
        let t = self.taps(level, x, y);
        for (k, o) in out.iter_mut().enumerate().take(self.channels) {
            *o = t.sample(k);
        }
    }

    /// Channel 0 of [`MipMap::bilinear_into`] (the whole value of a single-channel map).
    pub fn bilinear(&self, level: usize, x: f64, y: f64) -> f32 {
        self.taps(level, x, y).sample(0)
    }

    /// The two levels and the blend weight of the upper one for a filter `footprint` texels wide.
    fn trilinear_levels(&self, footprint: f64) -> (usize, f32) {
        let top = (self.levels.len() - 1) as f64;
        let lambda = if footprint > 1.0 {
            footprint.log2().min(top)
        } else {
            0.0
        };
        let l0 = lambda.floor();
        (l0 as usize, (lambda - l0) as f32)
    }

    /// Trilinear lookup for a filter `footprint` level-0 texels wide: level `λ = log2(footprint)`
    /// clamped to the pyramid, bilinear at `floor(λ)` and `floor(λ) + 1`, blended linearly in `λ`;
    /// at integer `λ` this is exactly [`MipMap::bilinear_into`] at that level.
    pub fn trilinear_into(&self, x: f64, y: f64, footprint: f64, out: &mut [f32]) {
        let (l0, t) = self.trilinear_levels(footprint);
        let lower = self.taps(l0, x, y);
        let upper = (t > 0.0).then(|| self.taps(l0 + 1, x, y));
        for (k, o) in out.iter_mut().enumerate().take(self.channels) {
            *o = match &upper {
                Some(u) => lower.sample(k) * (1.0 - t) + u.sample(k) * t,
                None => lower.sample(k),
            };
        }
    }

    /// Channel 0 of [`MipMap::trilinear_into`].
    pub fn trilinear(&self, x: f64, y: f64, footprint: f64) -> f32 {
        let (l0, t) = self.trilinear_levels(footprint);
        let lower = self.taps(l0, x, y).sample(0);
        if t > 0.0 {
            lower * (1.0 - t) + self.taps(l0 + 1, x, y).sample(0) * t
        } else {
            lower
        }
    }
}

/// A bilinear lookup's four texel offsets (`(i0,j0), (i1,j0), (i0,j1), (i1,j1)`) and weights.
struct Taps<'a> {
    data: &'a [f32],
    idx: [usize; 4],
    fx: f64,
    fy: f64,
}

impl Taps<'_> {
    #[inline]
    fn sample(&self, k: usize) -> f32 {
        let v = |n: usize| self.data[self.idx[n] + k] as f64;
        let top = v(0) * (1.0 - self.fx) + v(1) * self.fx;
        let bottom = v(2) * (1.0 - self.fx) + v(3) * self.fx;
        (top * (1.0 - self.fy) + bottom * self.fy) as f32
    }
}

/// The two clamped taps and the weight of the second for a lookup at texel-center coordinate `u`.
fn lerp_taps(u: f64, n: usize) -> (usize, usize, f64) {
    let u = if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, (n - 1) as f64)
    };
    let i0 = (u.floor() as usize).min(n - 1);
    let i1 = (i0 + 1).min(n - 1);
    (i0, i1, u - i0 as f64)
}

/// The next coarser mip level, `None` once `l` is 1 × 1.
fn reduce_mean(l: &MipLevel, c: usize) -> Option<MipLevel> {
    if l.width == 1 && l.height == 1 {
        return None;
    }
    let (w, h) = (l.width.div_ceil(2), l.height.div_ceil(2));
    let mut data = vec![0.0f32; w * h * c];
    data.par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let (kids, n) = children(x, y, l.width, l.height);
            for k in 0..c {
                let sum: f64 = kids[..n]
                    .iter()
                    .map(|&(cx, cy)| l.data[(cy * l.width + cx) * c + k] as f64)
                    .sum();
                row[x * c + k] = (sum / n as f64) as f32;
            }
        }
    });
    Some(MipLevel {
        width: w,
        height: h,
        data,
    })
}
