//! Convex regions in texel space and their conservative coverage: the influence regions of
//! the soft alias-free shadow maps of Sintorn et al. 2008, Sample Based Visibility for Soft
//! Shadows (the union of a triangle's projections from every light point) are convex hulls of
//! projected points, rasterized so that every texel they touch is
//! visited.

use glam::DVec2;
use std::ops::Range;

/// Slack of the conservative coverage, in texels.
const SLACK: f64 = 1e-6;

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
    let y_first = (lo_y - SLACK).floor().max(0.0) as usize;
    let y_last = ((hi_y + SLACK).floor().min(height as f64 - 1.0)).max(-1.0);
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
        let first = (lo.floor() - 1.0).clamp(0.0, n as f64) as usize;
        let end = (hi.floor() + 2.0).clamp(0.0, n as f64) as usize;
        first..end.max(first)
    };
    (range(lo.y, hi.y, height), range(lo.x, hi.x, width))
}

/// The half-open columns `[x0, x1)` of row `y` of a `width`-column map whose texel squares the
/// polygon `hull` touches (with the slack of [`conservative_rows`]); `None` for none. The GPU
/// repeats it operation for operation (`row_span` in `methods/alias_free/alias_free.wgsl`).
pub fn conservative_span(hull: &[DVec2], y: usize, width: usize) -> Option<(usize, usize)> {
    let (top, bottom) = (y as f64 - SLACK, y as f64 + 1.0 + SLACK);
    let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let n = hull.len();
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        if a.y >= top && a.y <= bottom {
            x_lo = x_lo.min(a.x);
            x_hi = x_hi.max(a.x);
        }
        for edge_y in [top, bottom] {
            if (a.y - edge_y) * (b.y - edge_y) < 0.0 {
                let x = a.x + (b.x - a.x) * (edge_y - a.y) / (b.y - a.y);
                x_lo = x_lo.min(x);
                x_hi = x_hi.max(x);
            }
        }
    }
    if x_lo > x_hi {
        return None;
    }
    let x0 = (x_lo - SLACK).floor().max(0.0);
    let x1 = ((x_hi + SLACK).floor() + 1.0).min(width as f64);
    (x1 > x0).then_some((x0 as usize, x1 as usize))
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
