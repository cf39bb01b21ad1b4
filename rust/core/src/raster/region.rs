//! Convex regions in texel space and their conservative coverage: the influence regions of
//! the soft alias-free shadow maps of Sintorn et al. 2008, Sample Based Visibility for Soft
//! Shadows (the union of a triangle's projections from every light point) are convex hulls of
//! projected points, rasterized so that every texel they touch is
//! visited.

use glam::DVec2;
use std::ops::Range;

/// Slack of the conservative coverage, in texels.
const SLACK: f64 = 1e-6;

/// `v.floor()`, up to the sign of a zero, without the call that `floor` compiles to on CPUs
/// without SSE4.1 (the baseline): the region code runs it millions of times a frame. Values of
/// magnitude 2^52 and beyond, infinities and NaN are their own floor.
#[inline(always)]
fn floor(v: f64) -> f64 {
    if v.abs() < 4_503_599_627_370_496.0 {
        let t = v as i64 as f64;
        if t > v {
            t - 1.0
        } else {
            t
        }
    } else {
        v
    }
}

/// For each texel row the convex polygon `hull` (texel coordinates, any orientation) touches,
/// `(y, x0, x1)`: the half-open texel columns `[x0, x1)` whose squares it touches in that row,
/// clipped to a `width × height` map. Conservative: every texel square the polygon overlaps is
/// included (up to `1e-6` texel of slack).
pub fn conservative_rows(
    hull: &[DVec2],
    width: usize,
    height: usize,
) -> Vec<(usize, usize, usize)> {
    let Some((first, last)) = conservative_row_range(hull, height) else {
        return Vec::new();
    };
    (first..=last)
        .filter_map(|y| conservative_span(hull, y, width).map(|(x0, x1)| (y, x0, x1)))
        .collect()
}

/// The first and last rows of a `height`-row map that the polygon `hull` may touch (with the
/// slack of [`conservative_rows`]); `None` for none.
pub fn conservative_row_range(hull: &[DVec2], height: usize) -> Option<(usize, usize)> {
    if hull.is_empty() {
        return None;
    }
    let (lo_y, hi_y) = hull
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.y), b.max(p.y))
        });
    let y_first = floor(lo_y - SLACK).max(0.0) as usize;
    let y_last = floor(hi_y + SLACK).min(height as f64 - 1.0).max(-1.0);
    (y_last >= 0.0 && y_first < height).then_some((y_first, y_last as usize))
}

/// The first and last rows of a `width × height` map in which the polygon `hull` touches a
/// texel: the first and last rows of [`conservative_rows`], found from the ends of its row
/// range inwards, without the spans of the rows between.
pub fn conservative_row_extent(
    hull: &[DVec2],
    width: usize,
    height: usize,
) -> Option<(usize, usize)> {
    let (first, last) = conservative_row_range(hull, height)?;
    let touches = |y: &usize| conservative_span(hull, *y, width).is_some();
    let first = (first..=last).find(touches)?;
    let last = (first..=last).rev().find(touches)?;
    Some((first, last))
}

/// The texels `(rows, columns)` of a `width × height` map within a texel of the bounding box of
/// the polygon `hull` (empty for none): they hold every span of [`conservative_rows`], and of
/// any polygon that `hull` holds up to round-off.
pub fn texel_box(hull: &[DVec2], width: usize, height: usize) -> (Range<usize>, Range<usize>) {
    let (lo, hi) = hull
        .iter()
        .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let range = |lo: f64, hi: f64, n: usize| {
        let first = (floor(lo) - 1.0).clamp(0.0, n as f64) as usize;
        let end = (floor(hi) + 2.0).clamp(0.0, n as f64) as usize;
        first..end.max(first)
    };
    (range(lo.y, hi.y, height), range(lo.x, hi.x, width))
}

/// The half-open columns `[x0, x1)` of row `y` of a `width`-column map whose texel squares the
/// polygon `hull` touches (with the slack of [`conservative_rows`]); `None` for none. The GPU
/// finds the same spans (`row_span` in `methods/alias_free/alias_free.wgsl`).
pub fn conservative_span(hull: &[DVec2], y: usize, width: usize) -> Option<(usize, usize)> {
    let lines = row_lines(y);
    let mut bounds = DVec2::new(f64::INFINITY, f64::NEG_INFINITY);
    let n = hull.len();
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        if in_row(a, lines) {
            widen(&mut bounds, a.x);
        }
        for line in lines {
            if let Some(x) = crossing(a, b, line) {
                widen(&mut bounds, x);
            }
        }
    }
    columns(bounds, width)
}

/// The spans `(y, x0, x1)` of [`conservative_span`] of the rows `rows` that the polygon `hull`
/// touches, in increasing `y`, found by walking the polygon's edges once: each edge and vertex
/// visits only the rows whose top or bottom line it may meet, where [`conservative_span`] tests
/// every edge in every row. The same comparisons and crossings (minima and maxima taken in
/// another order, of the same values), so the same spans. `bounds` is scratch memory.
pub fn conservative_spans<'b>(
    hull: &[DVec2],
    rows: Range<usize>,
    width: usize,
    bounds: &'b mut Vec<DVec2>,
) -> impl Iterator<Item = (usize, usize, usize)> + 'b {
    bounds.clear();
    let first = match conservative_row_range(hull, rows.end) {
        Some((first, last)) if first.max(rows.start) <= last => {
            let first = first.max(rows.start);
            bounds.resize(
                last + 1 - first,
                DVec2::new(f64::INFINITY, f64::NEG_INFINITY),
            );
            walk_edges(hull, first, bounds);
            first
        }
        _ => 0,
    };
    bounds
        .iter()
        .enumerate()
        .filter_map(move |(k, &r)| columns(r, width).map(|(x0, x1)| (first + k, x0, x1)))
}

/// The least and greatest crossing `(x, x)` of each row `first + k` in `bounds[k]`: the
/// polygon's vertices within the row's slack and its edges' crossings of the row's top and
/// bottom lines, as in [`conservative_span`].
fn walk_edges(hull: &[DVec2], first: usize, bounds: &mut [DVec2]) {
    let end = first + bounds.len();
    // The rows `y` with `lo <= y <= hi`, and two more on each side (truncation, not `floor`),
    // clipped to `first..end`. A NaN bound gives rows near 0, where the tests of a NaN
    // coordinate fail as they should.
    let candidates = |lo: f64, hi: f64| {
        let clip = |row: i64| row.clamp(first as i64, end as i64) as usize;
        clip((lo as i64).saturating_sub(2))..clip((hi as i64).saturating_add(3))
    };
    let n = hull.len();
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        for y in candidates(a.y - 1.0 - SLACK, a.y + SLACK) {
            if in_row(a, row_lines(y)) {
                widen(&mut bounds[y - first], a.x);
            }
        }
        let (lo, hi) = (a.y.min(b.y), a.y.max(b.y));
        for y in candidates(lo - 1.0 - SLACK, hi + SLACK) {
            for line in row_lines(y) {
                if let Some(x) = crossing(a, b, line) {
                    widen(&mut bounds[y - first], x);
                }
            }
        }
    }
}

/// The top and bottom lines of row `y`, with the slack of [`conservative_rows`].
#[inline(always)]
fn row_lines(y: usize) -> [f64; 2] {
    [y as f64 - SLACK, y as f64 + 1.0 + SLACK]
}

/// Whether the point `a` lies between a row's `lines`.
#[inline(always)]
fn in_row(a: DVec2, [top, bottom]: [f64; 2]) -> bool {
    a.y >= top && a.y <= bottom
}

/// Where the edge `a -> b` crosses the horizontal `line` strictly between its ends.
#[inline(always)]
fn crossing(a: DVec2, b: DVec2, line: f64) -> Option<f64> {
    ((a.y - line) * (b.y - line) < 0.0).then(|| a.x + (b.x - a.x) * (line - a.y) / (b.y - a.y))
}

/// Widens the range `(least, greatest)` to hold `x`.
#[inline(always)]
fn widen(bounds: &mut DVec2, x: f64) {
    *bounds = DVec2::new(bounds.x.min(x), bounds.y.max(x));
}

/// The half-open columns of a `width`-column map that the range `(least, greatest)` of a row's
/// crossings touches (with the slack); `None` for an empty range. In integers, without `floor`
/// (a call without SSE4.1; this runs millions of times a frame): `v as usize` is
/// `v.floor().max(0.0)` for any `v` (truncating, saturating at 0), and a negative right end
/// leaves no span.
#[inline(always)]
fn columns(bounds: DVec2, width: usize) -> Option<(usize, usize)> {
    let right = bounds.y + SLACK;
    if bounds.x > bounds.y || right < 0.0 {
        return None;
    }
    let x0 = (bounds.x - SLACK) as usize;
    let x1 = (right as usize).saturating_add(1).min(width);
    (x1 > x0).then_some((x0, x1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::convex_hull;

    #[test]
    fn the_row_extent_and_box_hold_the_rows() {
        // Triangles and a long thin sliver, inside, across and wholly off a 10 x 12 map's sides:
        // the extent is the first and last rows', and the box holds every span.
        let hulls = [
            vec![(1.2, 1.5), (6.7, 2.1), (3.3, 7.9)],
            vec![(-4.0, -3.0), (2.5, 5.5), (-1.0, 14.0)],
            vec![(-9.0, 1.0), (-3.0, 2.0), (-5.0, 8.0)],
            vec![(-3.0, -1.0), (13.0, 11.5), (12.9, 11.6)],
            vec![(4.0, 20.0), (6.0, 25.0), (5.0, 30.0)],
        ];
        for points in hulls {
            let points: Vec<DVec2> = points.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
            let hull = convex_hull(&points);
            let rows = conservative_rows(&hull, 10, 12);
            let expected = rows
                .first()
                .map(|f| (f.0, rows.last().map_or(f.0, |l| l.0)));
            assert_eq!(conservative_row_extent(&hull, 10, 12), expected, "{hull:?}");
            let (box_rows, columns) = texel_box(&hull, 10, 12);
            assert!(rows.iter().all(|&(y, x0, x1)| box_rows.contains(&y)
                && columns.start <= x0
                && x1 <= columns.end));
        }
    }

    #[test]
    fn floor_is_the_standard_librarys() {
        let values = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_999,
            -2.000_000_001,
            1e-300,
            -1e-300,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
        ];
        for v in values {
            assert_eq!(floor(v), v.floor(), "{v}");
        }
        assert!(floor(f64::NAN).is_nan());
        // The columns in integers are those of `floor` in floats.
        for &lo in &values {
            for &hi in &values {
                let float = (lo <= hi).then(|| {
                    let x0 = (lo - SLACK).floor().max(0.0);
                    let x1 = ((hi + SLACK).floor() + 1.0).min(9.0);
                    (x1 > x0).then_some((x0 as usize, x1 as usize))
                });
                assert_eq!(columns(DVec2::new(lo, hi), 9), float.flatten(), "{lo} {hi}");
            }
        }
    }

    #[test]
    fn walking_the_edges_gives_every_rows_span() {
        // Random convex polygons of 1 to 12 points (some snapped to the rows' lines and their
        // slack, some far off the map or past an integer's range, some of one row), against
        // `conservative_span` row by row over row ranges cut anywhere, within
        // `conservative_row_range` as every caller asks: the very same spans.
        let mut rng = crate::light::sampling::Rng::new(7);
        let mut coordinate = |scale: f64| {
            let v = (f64::from(rng.next_f32()) - 0.25) * scale;
            match rng.below(4) {
                0 => v.round(),
                1 => v.round() + SLACK,
                2 => v.round() - SLACK,
                _ => v,
            }
        };
        let (width, height) = (23, 31);
        let mut bounds = Vec::new();
        for case in 0..3000 {
            let scale = [40.0, 4.0, 1e7, 1e19][case % 4];
            let points: Vec<DVec2> = (0..1 + case % 12)
                .map(|_| DVec2::new(coordinate(scale), coordinate(scale)))
                .collect();
            let hull = convex_hull(&points);
            let (start, end) = ((case * 7) % height, (case * 7) % height + 1 + case % height);
            let rows = start..end.min(height);
            let reach = conservative_row_range(&hull, height).map_or(0..0, |(f, l)| f..l + 1);
            let expected: Vec<_> = rows
                .clone()
                .filter(|y| reach.contains(y))
                .filter_map(|y| conservative_span(&hull, y, width).map(|(x0, x1)| (y, x0, x1)))
                .collect();
            let walked: Vec<_> = conservative_spans(&hull, rows, width, &mut bounds).collect();
            assert_eq!(walked, expected, "{hull:?}");
        }
    }

    #[test]
    fn coverage_is_conservative() {
        let hull = convex_hull(&[
            DVec2::new(1.2, 1.5),
            DVec2::new(6.7, 2.1),
            DVec2::new(3.3, 7.9),
        ]);
        let rows = conservative_rows(&hull, 10, 10);
        // Brute force: texels whose square overlaps the triangle, by dense point sampling.
        for y in 0..10 {
            for x in 0..10 {
                let touched = (0..=20)
                    .flat_map(|i| (0..=20).map(move |j| (i, j)))
                    .any(|(i, j)| {
                        let p = DVec2::new(x as f64 + i as f64 / 20.0, y as f64 + j as f64 / 20.0);
                        (0..hull.len()).all(|k| {
                            (hull[(k + 1) % hull.len()] - hull[k]).perp_dot(p - hull[k]) >= 0.0
                        })
                    });
                let covered = rows
                    .iter()
                    .any(|&(ry, x0, x1)| ry == y && (x0..x1).contains(&x));
                assert!(
                    !touched || covered,
                    "texel ({x}, {y}) touched but not covered"
                );
            }
        }
    }
}
