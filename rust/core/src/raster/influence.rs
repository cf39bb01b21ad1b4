//! Receivers binned in light space and the influence regions of primitives, shared by the
//! object-based methods (`alias_free`, `dcs`, `penumbra_wedge`, `stsv`).
//!
//! The receivers are stored in per-texel lists of a light frustum fitted to them, by count,
//! prefix sum and scatter (Sintorn, Eisemann and Assarsson 2008, section 3.1). A primitive (a
//! triangle, an edge, a shadow volume) can only affect the segments from a receiver to the light
//! if the receiver projects into the primitive's *influence region*: the union of its projections
//! from every point of the light onto a plane beyond the receiver (section 4.1). The region is
//! bounded by the convex hull of the projections of its vertices from the light's bounding
//! points: the corners of a rectangle (exact), a circumscribed `degree`-gon of a disk, for a
//! sphere the circumscribed `degree`-gon of its silhouette seen from each vertex (the paper's
//! bounding polygons), and for an ellipsoid the sphere's by virtual scaling. A point light's
//! region is the primitive's own projection. Regions are rasterized conservatively
//! ([`crate::raster::region`]) and processed by bands of rows in parallel, each band owning the
//! lists of its texels. [`Origins`] are the receivers of the object-based methods in such lists.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::light::lights::{tangent_frame, Light, Shape};
use crate::light::sampling::SampleSet;
use crate::limits::Peak;
use crate::raster::depth::{band_rows, bin_row_ranges, LightFrustum, NEAR_FRACTION};
use crate::raster::region::{conservative_rows, convex_hull};
use crate::stats::Stats;
use glam::{DMat3, DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range;

/// Options of the object-based methods (`dcs`, `penumbra_wedge`, `stsv`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectOptions {
    /// Offset of the shadow-ray origins along the receiver normal (world units), as `ray_traced`.
    pub epsilon: f32,
    /// Side of the light-space receiver lists in texels.
    pub resolution: usize,
    /// Sides of the bounding polygons of disk, sphere and ellipsoid lights.
    pub hull_degree: usize,
}

impl ObjectOptions {
    /// Ranges, and an `epsilon` of at most the diagonal of the bounds of `scene` and `receivers`:
    /// a longer offset moves every shadow-ray origin out of the scene (and then the light's
    /// frustum, whose error would blame the light).
    pub fn validate(&self, scene: &Scene, receivers: &Receivers) -> Result<()> {
        if !(self.epsilon.is_finite() && self.epsilon >= 0.0) {
            return Err(Error::invalid("epsilon", format!("must be finite and >= 0, got {}", self.epsilon)));
        }
        let (lo, hi) = scene.bounds();
        let (lo, hi) = receivers.bounds().map_or((lo, hi), |(a, b)| (lo.min(a), hi.max(b)));
        let diagonal = (hi - lo).length();
        if diagonal.is_finite() && self.epsilon > diagonal.max(f32::MIN_POSITIVE) {
            return Err(Error::invalid(
                "epsilon",
                format!("must be at most the size of the scene and receivers (their bounds' diagonal, {diagonal}), got {}; it offsets shadow-ray origins, typically by 1e-4 of that", self.epsilon),
            ));
        }
        if !(1..=crate::raster::depth::MAX_RESOLUTION).contains(&self.resolution) {
            return Err(Error::invalid("resolution", format!("must be in 1..=65536, got {}", self.resolution)));
        }
        check_hull_degree(self.hull_degree)
    }
}

/// Refuses bounding polygons of fewer than 3 or more than 64 sides.
pub fn check_hull_degree(degree: usize) -> Result<()> {
    if !(3..=64).contains(&degree) {
        return Err(Error::invalid("hull_degree", format!("must be in 3..=64, got {degree}")));
    }
    Ok(())
}

/// The receivers the object-based methods test: the valid ones facing some part of the light,
/// their shadow-ray origins, and those origins in light-space lists; with the light and the
/// samples they are tested against.
pub(crate) struct Origins<'a> {
    pub light: &'a Light,
    pub receivers: &'a Receivers,
    pub samples: &'a SampleSet,
    /// Receiver index of each origin.
    pub ids: Vec<u32>,
    pub origins: Vec<Vec3>,
    pub lists: ReceiverLists,
}

impl<'a> Origins<'a> {
    /// The memory of the origins of `receivers` receivers (ids and points) and their lists.
    pub fn peak(receivers: usize, opts: &ObjectOptions) -> Peak {
        Peak::default().buffer(&[receivers as u64, 4 + 12]).and(ReceiverLists::peak(receivers, opts.resolution))
    }

    /// `None` when no receiver faces the light.
    pub fn new(light: &'a Light, receivers: &'a Receivers, samples: &'a SampleSet, opts: &ObjectOptions) -> Result<Option<Self>> {
        let (c, extent) = (light.center(), light.extent());
        let ids: Vec<u32> = (0..receivers.len() as u32)
            .filter(|&i| {
                let (p, n) = (receivers.points[i as usize], receivers.normals[i as usize]);
                receivers.valid[i as usize] && n.dot(c - p) > -extent * n.length() && p != c
            })
            .collect();
        if ids.is_empty() {
            return Ok(None);
        }
        let origins: Vec<Vec3> = ids.iter().map(|&i| receivers.points[i as usize] + receivers.normals[i as usize] * opts.epsilon).collect();
        let lists = ReceiverLists::build(light, &origins, opts.resolution)?;
        Ok(Some(Origins { light, receivers, samples, ids, origins, lists }))
    }

    /// The samples and weights of origin `k` (its receiver's samples) into the buffers.
    pub fn fill(&self, k: usize, ys: &mut Vec<Vec3>, ws: &mut Vec<f32>) {
        let i = self.ids[k] as usize;
        self.samples.fill(self.light, i, self.receivers.pixel(i), ys, ws);
    }

    /// The receiver point and normal of origin `k`.
    pub fn receiver(&self, k: usize) -> (Vec3, Vec3) {
        let i = self.ids[k] as usize;
        (self.receivers.points[i], self.receivers.normals[i])
    }
}

/// Receivers in per-texel lists (compressed rows): texel `t` holds the receiver indices
/// `entries[start[t]..start[t + 1]]`; `depths` are the receivers' linear depths in the frustum.
pub struct ReceiverLists {
    pub frustum: LightFrustum,
    pub start: Vec<usize>,
    pub entries: Vec<u32>,
    pub depths: Vec<f64>,
}

impl ReceiverLists {
    /// The memory of the lists of `points` receivers at `resolution`: per receiver its texel,
    /// entry and depth; per texel two list starts (the starts and the fill cursors).
    pub fn peak(points: usize, resolution: usize) -> Peak {
        Peak::default().buffer(&[points as u64, 8 + 4 + 8]).buffer(&[resolution as u64, resolution as u64, 2 * 8])
    }

    /// Bins `points` (at least one, none at the light's center) into the texels of the frustum
    /// from the light's center fitted to them (section 4.3): the square fit of
    /// [`LightFrustum::fit`] for its axes, then the tightest fields of view and depth range.
    pub fn build(light: &Light, points: &[Vec3], resolution: usize) -> Result<Self> {
        Ok(Self::with_frustum(Self::fit(light, points, resolution)?, points))
    }

    /// The frustum from the light's center that [`ReceiverLists::build`] fits to `points`.
    pub fn fit(light: &Light, points: &[Vec3], resolution: usize) -> Result<LightFrustum> {
        fit_frustum(light, points, resolution)
    }

    /// The texel of `p` in the lists of `frustum` (points nearer than its near plane and outside
    /// the map go to the nearest texel of the map's border).
    pub fn texel(frustum: &LightFrustum, p: Vec3) -> usize {
        let (w, h) = (frustum.width, frustum.height);
        let p = frustum.project(p).unwrap_or(Vec3::ZERO);
        let (x, y) = ((p.x.max(0.0) as usize).min(w - 1), (p.y.max(0.0) as usize).min(h - 1));
        y * w + x
    }

    /// Bins `points` into the texels of `frustum` (fitted to them).
    pub fn with_frustum(frustum: LightFrustum, points: &[Vec3]) -> Self {
        let (w, h) = (frustum.width, frustum.height);
        let texel: Vec<usize> = points.par_iter().map(|&p| Self::texel(&frustum, p)).collect();
        let mut start = vec![0usize; w * h + 1];
        for &t in &texel {
            start[t + 1] += 1;
        }
        for t in 0..w * h {
            start[t + 1] += start[t];
        }
        let mut fill = start.clone();
        let mut entries = vec![0u32; points.len()];
        for (i, &t) in texel.iter().enumerate() {
            entries[fill[t]] = i as u32;
            fill[t] += 1;
        }
        let depths = points.iter().map(|&p| f64::from(frustum.to_view(p).z)).collect();
        Self { frustum, start, entries, depths }
    }

    /// Rows per band of the parallel passes.
    pub fn band_rows(&self) -> usize {
        band_rows(self.frustum.height)
    }

    /// Number of bands of rows.
    pub fn bands(&self) -> usize {
        self.frustum.height.div_ceil(self.band_rows())
    }

    /// The map rows of band `b`.
    pub fn rows(&self, b: usize) -> Range<usize> {
        let band = self.band_rows();
        b * band..((b + 1) * band).min(self.frustum.height)
    }

    /// The list entries of the texels of `rows`.
    pub fn entries_of(&self, rows: &Range<usize>) -> Range<usize> {
        let w = self.frustum.width;
        self.start[rows.start * w]..self.start[rows.end * w]
    }

    /// For each band, the indices of the regions (`None`: the whole map) whose rows reach it.
    pub fn bin(&self, hulls: &[Option<Vec<DVec2>>]) -> Vec<Vec<u32>> {
        bin_regions(&self.frustum, hulls)
    }

    /// The texel spans `(row, x0, x1)` of `rows` that the region `hull` (`None`: the whole map)
    /// covers conservatively.
    pub fn spans(&self, hull: Option<&[DVec2]>, rows: &Range<usize>) -> Vec<(usize, usize, usize)> {
        let (w, h) = (self.frustum.width, self.frustum.height);
        match hull {
            None => rows.clone().map(|y| (y, 0, w)).collect(),
            Some(hull) => conservative_rows(hull, w, h).into_iter().filter(|r| rows.contains(&r.0)).collect(),
        }
    }

    /// The list entries of the texels of a span.
    pub fn span_entries(&self, (y, x0, x1): (usize, usize, usize)) -> Range<usize> {
        let w = self.frustum.width;
        self.start[y * w + x0]..self.start[y * w + x1]
    }

    /// Splits `data` (`per_entry` values per list entry, in list order) into the parts of each
    /// band: `(band, rows, first entry, part)`, for passes that process the bands in parallel.
    pub fn split_by_band<'a, T>(&self, data: &'a mut [T], per_entry: usize) -> Vec<(usize, Range<usize>, usize, &'a mut [T])> {
        let mut rest = data;
        let mut out = Vec::with_capacity(self.bands());
        for b in 0..self.bands() {
            let rows = self.rows(b);
            let entries = self.entries_of(&rows);
            let (head, tail) = rest.split_at_mut(entries.len() * per_entry);
            out.push((b, rows, entries.start, head));
            rest = tail;
        }
        out
    }

    /// A frustum for the receivers of `rows`: the map's, with its far plane at their farthest
    /// depth (regions shrink towards the light, so projecting them there stays conservative
    /// for those receivers); `None` when the rows hold none.
    pub fn band_frustum(&self, rows: &Range<usize>) -> Option<LightFrustum> {
        let far = self.entries[self.entries_of(rows)].iter().map(|&e| self.depths[e as usize] as f32).fold(0.0f32, f32::max);
        band_frustum(&self.frustum, far)
    }

    /// The list statistics of the paper's Figure 9 inlay: `average_list_length` and
    /// `max_list_length` (over occupied texels) and `occupied_texels_percent`.
    pub fn record_stats(&self, stats: &mut Stats) {
        record_list_stats(self.start.windows(2).map(|w| w[1] - w[0]), stats);
    }
}

impl ReceiverLists {
    /// Calls `visit(item, point, values)` for every item and every listed point inside the
    /// item's influence region (the region of the world points `vertices(item)`), with the
    /// point's `per_entry` values of `data` (one run of values per list entry, in list order).
    /// Bands of rows run in parallel, each projecting the regions onto its own farthest point;
    /// within a band, items go in order, so the result does not depend on the thread count.
    #[allow(clippy::too_many_arguments)]
    pub fn visit_regions<I: Sync, T: Send>(
        &self,
        light: &Light,
        degree: usize,
        items: &[I],
        vertices: impl Fn(&I) -> &[Vec3] + Sync,
        data: &mut [T],
        per_entry: usize,
        visit: impl Fn(&I, usize, &mut [T]) + Sync,
    ) {
        let hulls: Vec<Option<Vec<DVec2>>> = items.par_iter().map(|it| influence_hull(&self.frustum, light, vertices(it), degree)).collect();
        let bins = self.bin(&hulls);
        self.split_by_band(data, per_entry).into_par_iter().for_each(|(b, rows, base, part)| {
            let Some(band_frustum) = self.band_frustum(&rows) else { return };
            for &k in &bins[b] {
                let item = &items[k as usize];
                let region = match &hulls[k as usize] {
                    Some(_) => influence_hull(&band_frustum, light, vertices(item), degree),
                    None => None,
                };
                for span in self.spans(region.as_deref(), &rows) {
                    for e in self.span_entries(span) {
                        visit(item, self.entries[e] as usize, &mut part[(e - base) * per_entry..(e - base + 1) * per_entry]);
                    }
                }
            }
        });
    }
}

/// [`ReceiverLists::bin`] for the lists of `frustum`.
pub fn bin_regions(frustum: &LightFrustum, hulls: &[Option<Vec<DVec2>>]) -> Vec<Vec<u32>> {
    let (w, h) = (frustum.width, frustum.height);
    let band = band_rows(h);
    let rows: Vec<Option<(usize, usize)>> = hulls
        .par_iter()
        .map(|hull| match hull {
            None => Some((0, h)),
            Some(hull) => {
                let r = conservative_rows(hull, w, h);
                r.first().map(|f| (f.0, r.last().map_or(f.0, |l| l.0) + 1))
            }
        })
        .collect();
    bin_row_ranges(&rows, band, h.div_ceil(band))
}

/// [`ReceiverLists::band_frustum`] for receivers whose farthest linear depth is `far` (`None`
/// for none, `far <= 0`).
pub fn band_frustum(frustum: &LightFrustum, far: f32) -> Option<LightFrustum> {
    (far > 0.0).then(|| LightFrustum { far: (far * 1.001).max(frustum.near * 2.0), ..*frustum })
}

/// [`ReceiverLists::record_stats`] from the length of every texel's list.
pub fn record_list_stats(lengths: impl ExactSizeIterator<Item = usize>, stats: &mut Stats) {
    let texels = lengths.len().max(1);
    let (occupied, max, total) = lengths.fold((0usize, 0usize, 0usize), |(o, m, t), l| (o + usize::from(l > 0), m.max(l), t + l));
    stats.set("average_list_length", if occupied > 0 { total as f64 / occupied as f64 } else { 0.0 });
    stats.set("max_list_length", max as f64);
    stats.set("occupied_texels_percent", 100.0 * occupied as f64 / texels as f64);
}

/// The frustum of [`ReceiverLists::build`].
fn fit_frustum(light: &Light, points: &[Vec3], resolution: usize) -> Result<LightFrustum> {
    let (lo, hi) = points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let base = LightFrustum::fit(light.center(), lo, hi, resolution)?;
    let (mut tx, mut ty, mut z0, mut z1) = (0.0f32, 0.0f32, f32::INFINITY, 0.0f32);
    for &p in points {
        let v = base.to_view(p);
        tx = tx.max(v.x.abs() / v.z);
        ty = ty.max(v.y.abs() / v.z);
        z0 = z0.min(v.z);
        z1 = z1.max(v.z);
    }
    let margin = 1.0 + 1e-3;
    Ok(LightFrustum {
        tan_half_x: (tx * margin).max(1e-4),
        tan_half_y: (ty * margin).max(1e-4),
        near: NEAR_FRACTION * z0,
        far: (z1 * 1.001).max(NEAR_FRACTION * z0 * 2.0),
        ..base
    })
}

/// The light's bounding points seen from world point `v` (see the module documentation).
pub fn light_points(light: &Light, v: DVec3, degree: usize) -> Vec<DVec3> {
    match light.shape {
        Shape::Point { position } => vec![position.as_dvec3()],
        Shape::Rect { center, u, v: w } => {
            let (c, u, w) = (center.as_dvec3(), u.as_dvec3(), w.as_dvec3());
            vec![c + u + w, c + u - w, c - u - w, c - u + w]
        }
        Shape::Disk { center, normal, radius } => polygon(center.as_dvec3(), normal.as_dvec3(), f64::from(radius), degree),
        Shape::Sphere { center, radius } => sphere_silhouette(center.as_dvec3(), f64::from(radius), v, degree),
        Shape::Ellipsoid { center, axes } => {
            // Virtual scaling (section 4.1): in the frame where the ellipsoid is the unit ball, its
            // silhouette from v is a circle; the axes map the circle's bounding polygon back onto
            // one around the ellipsoid's silhouette, since linear maps keep tangency and convexity.
            let (c, a) = (center.as_dvec3(), axes.as_dmat3());
            let unit = sphere_silhouette(DVec3::ZERO, 1.0, a.inverse() * (v - c), degree);
            unit.into_iter().map(|q| c + a * q).collect()
        }
    }
}

/// The `degree`-gon circumscribing the circle of radius `r` about `c` in the plane normal to `n`.
pub(crate) fn polygon(c: DVec3, n: DVec3, r: f64, degree: usize) -> Vec<DVec3> {
    let (t, b) = tangent_frame(n.as_vec3());
    let (t, b) = (t.as_dvec3(), b.as_dvec3());
    let r = r / (std::f64::consts::PI / degree as f64).cos();
    (0..degree)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / degree as f64;
            c + (t * a.cos() + b * a.sin()) * r
        })
        .collect()
}

/// The bounding `degree`-gon of the silhouette circle of the sphere `(c, r)` seen from `v`
/// (empty when `v` is inside the sphere).
fn sphere_silhouette(c: DVec3, r: f64, v: DVec3, degree: usize) -> Vec<DVec3> {
    let d = v - c;
    let dist2 = d.length_squared();
    if dist2 <= r * r {
        return Vec::new();
    }
    // The silhouette circle seen from v: center c + d r²/|d|², radius r sqrt(1 − r²/|d|²).
    polygon(c + d * (r * r / dist2), d / dist2.sqrt(), r * (1.0 - r * r / dist2).sqrt(), degree)
}

/// Points whose convex hull holds the light: a rectangle's corners, the circumscribed
/// `degree`-gon of a disk, the circumscribed box of a sphere or an ellipsoid, a point light itself.
pub fn light_polytope(light: &Light, degree: usize) -> Vec<DVec3> {
    let corners = |c: DVec3, a: DMat3| -> Vec<DVec3> {
        (0..8).map(|k| c + a * DVec3::new(if k & 1 == 0 { -1.0 } else { 1.0 }, if k & 2 == 0 { -1.0 } else { 1.0 }, if k & 4 == 0 { -1.0 } else { 1.0 })).collect()
    };
    match light.shape {
        Shape::Point { position } => vec![position.as_dvec3()],
        Shape::Rect { center, u, v } => {
            let (c, u, v) = (center.as_dvec3(), u.as_dvec3(), v.as_dvec3());
            vec![c + u + v, c + u - v, c - u - v, c - u + v]
        }
        Shape::Disk { center, normal, radius } => polygon(center.as_dvec3(), normal.as_dvec3(), f64::from(radius), degree),
        Shape::Sphere { center, radius } => corners(center.as_dvec3(), DMat3::from_diagonal(DVec3::splat(f64::from(radius)))),
        Shape::Ellipsoid { center, axes } => corners(center.as_dvec3(), axes.as_dmat3()),
    }
}

/// The influence region of the world points `points` (a triangle's or an edge's vertices): the
/// convex hull, in texel coordinates, of their projections from the light's bounding points
/// onto the far plane; `None` for the whole map (a point not strictly beyond some light point
/// along the view direction). Every receiver whose segment to a light point meets the convex
/// hull of `points` projects inside it (Sintorn et al. 2008, section 4.1).
pub fn influence_hull(frustum: &LightFrustum, light: &Light, points: &[Vec3], degree: usize) -> Option<Vec<DVec2>> {
    let (eye, f) = (frustum.eye.as_dvec3(), frustum.forward.as_dvec3());
    let far = f64::from(frustum.far);
    let mut pts = Vec::with_capacity(points.len() * degree.max(4));
    for v in points.iter().map(|v| v.as_dvec3()) {
        let ys = light_points(light, v, degree);
        if ys.is_empty() {
            return None;
        }
        for y in ys {
            let (zy, dz) = ((y - eye).dot(f), (v - y).dot(f));
            if dz <= 1e-9 * (1.0 + zy.abs()) {
                return None;
            }
            let x = y + (v - y) * ((far - zy) / dz);
            let s = frustum.project(x.as_vec3())?;
            pts.push(DVec2::new(f64::from(s.x), f64::from(s.y)));
        }
    }
    Some(convex_hull(&pts))
}
