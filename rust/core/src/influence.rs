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
//!
//! The paper's samples may lie anywhere (section 4.2), and explicit samples may lie off the light:
//! the regions then bound the light and every sample ([`LightBounds`]), since a region that misses
//! a sample misses the receivers its segments shadow.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::polygon::{circumscribed_polygon, convex_hull};
use crate::geometry::receivers::Receivers;
use crate::light::lights::{Light, Shape};
use crate::light::sampling::SampleSet;
use crate::limits::Peak;
use crate::raster::cube::enclosing_face;
use crate::raster::depth::{band_rows, bin_row_ranges};
use crate::raster::frustum::{check_resolution, LightFrustum, NEAR_FRACTION};
use crate::raster::region::{conservative_row_extent, conservative_spans};
use crate::stats::Stats;
use glam::{DMat3, DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::borrow::Cow;
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
            return Err(Error::invalid(
                "epsilon",
                format!("must be finite and >= 0, got {}", self.epsilon),
            ));
        }
        let (lo, hi) = scene.bounds();
        let (lo, hi) = receivers
            .bounds()
            .map_or((lo, hi), |(a, b)| (lo.min(a), hi.max(b)));
        let diagonal = (hi - lo).length();
        if diagonal.is_finite() && self.epsilon > diagonal.max(f32::MIN_POSITIVE) {
            return Err(Error::invalid(
                "epsilon",
                format!("must be at most the size of the scene and receivers (their bounds' diagonal, {diagonal}), got {}; it offsets shadow-ray origins, typically by 1e-4 of that", self.epsilon),
            ));
        }
        check_resolution("resolution", self.resolution)?;
        check_hull_degree(self.hull_degree)
    }
}

/// Refuses bounding polygons of fewer than 3 or more than 64 sides.
pub fn check_hull_degree(degree: usize) -> Result<()> {
    if !(3..=64).contains(&degree) {
        return Err(Error::invalid(
            "hull_degree",
            format!("must be in 3..=64, got {degree}"),
        ));
    }
    Ok(())
}

/// The receivers the object-based methods test: the valid ones facing some part of the light
/// or some sample, their shadow-ray origins, and those origins in light-space lists; with the
/// light and the samples they are tested against, and the bounds of both.
pub(crate) struct Origins<'a> {
    pub light: &'a Light,
    pub receivers: &'a Receivers,
    pub samples: &'a SampleSet,
    pub bounds: LightBounds<'a>,
    /// Receiver index of each origin.
    pub ids: Vec<u32>,
    pub origins: Vec<Vec3>,
    pub lists: ReceiverLists,
    /// Per pattern of `samples`, its samples' weights: the receivers' own where the samples are
    /// not rotated per receiver.
    pattern_weights: Vec<Vec<f32>>,
}

impl<'a> Origins<'a> {
    /// The memory of the origins of `receivers` receivers (ids and points) and their lists.
    pub fn peak(receivers: usize, opts: &ObjectOptions) -> Peak {
        Peak::default()
            .buffer(&[receivers as u64, 4 + 12])
            .and(ReceiverLists::peak(receivers, opts.resolution))
    }

    /// `None` when no receiver faces the light or a sample. Errors: samples whose bounds
    /// overflow f32 ([`LightBounds::new`]), the lists' frustum's.
    pub fn new(
        light: &'a Light,
        receivers: &'a Receivers,
        samples: &'a SampleSet,
        opts: &ObjectOptions,
    ) -> Result<Option<Self>> {
        let bounds = LightBounds::new(light, samples, opts.hull_degree)?;
        let (c, reach) = (light.center(), bounds.reach());
        let ids: Vec<u32> = (0..receivers.len() as u32)
            .filter(|&i| {
                let (p, n) = (receivers.points[i as usize], receivers.normals[i as usize]);
                receivers.valid[i as usize] && n.dot(c - p) > -reach * n.length() && p != c
            })
            .collect();
        if ids.is_empty() {
            return Ok(None);
        }
        let origins: Vec<Vec3> = ids
            .iter()
            .map(|&i| receivers.points[i as usize] + receivers.normals[i as usize] * opts.epsilon)
            .collect();
        let lists = ReceiverLists::build(light, &origins, opts.resolution)?;
        let pattern_weights = samples
            .patterns()
            .iter()
            .map(|pattern| pattern.iter().map(|&y| light.weight(y)).collect())
            .collect();
        Ok(Some(Origins {
            light,
            receivers,
            samples,
            bounds,
            ids,
            origins,
            lists,
            pattern_weights,
        }))
    }

    /// The samples and weights of origin `k`: its pattern's own where the samples are not
    /// rotated per receiver, else written into the buffers ([`Origins::fill`]).
    pub fn samples_of<'s>(
        &'s self,
        k: usize,
        ys: &'s mut Vec<Vec3>,
        ws: &'s mut Vec<f32>,
    ) -> (&'s [Vec3], &'s [f32]) {
        if self.samples.rotates() {
            self.fill(k, ys, ws);
            return (ys, ws);
        }
        let (x, y) = self.receivers.pixel(self.ids[k] as usize);
        let pattern = self.samples.pattern_index(x, y);
        (
            &self.samples.patterns()[pattern],
            &self.pattern_weights[pattern],
        )
    }

    /// The samples and weights of origin `k` (its receiver's samples) into the buffers.
    pub fn fill(&self, k: usize, ys: &mut Vec<Vec3>, ws: &mut Vec<f32>) {
        let i = self.ids[k] as usize;
        self.samples
            .fill(self.light, i, self.receivers.pixel(i), ys, ws);
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
        // Per point: its texel while binning (an `Option<usize>`), its entry and its depth.
        Peak::default()
            .buffer(&[points as u64, 16 + 4 + 8])
            .buffer(&[resolution as u64, resolution as u64, 2 * 8])
    }

    /// Bins `points` (at least one, none at the light's center) into the texels of the frustum
    /// from the light's center fitted to them (section 4.3): the square fit of
    /// [`LightFrustum::fit`] for its axes, then the tightest fields of view and depth range.
    pub fn build(light: &Light, points: &[Vec3], resolution: usize) -> Result<Self> {
        Ok(Self::with_frustum(
            Self::fit(light, points, resolution)?,
            points,
        ))
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
        let (x, y) = (
            (p.x.max(0.0) as usize).min(w - 1),
            (p.y.max(0.0) as usize).min(h - 1),
        );
        y * w + x
    }

    /// Bins `points` into the texels of `frustum` (fitted to them).
    pub fn with_frustum(frustum: LightFrustum, points: &[Vec3]) -> Self {
        Self::with_frustum_where(frustum, points, |_| true)
    }

    /// Bins the `points` whose texel `keep` accepts into the texels of `frustum` (fitted to
    /// them); the entries are indices into `points`, and `depths` holds every point's.
    pub fn with_frustum_where(
        frustum: LightFrustum,
        points: &[Vec3],
        keep: impl Fn(usize) -> bool + Sync,
    ) -> Self {
        let (w, h) = (frustum.width, frustum.height);
        let texel: Vec<Option<usize>> = points
            .par_iter()
            .map(|&p| Some(Self::texel(&frustum, p)).filter(|&t| keep(t)))
            .collect();
        let mut start = vec![0usize; w * h + 1];
        for &t in texel.iter().flatten() {
            start[t + 1] += 1;
        }
        for t in 0..w * h {
            start[t + 1] += start[t];
        }
        let mut fill = start.clone();
        let mut entries = vec![0u32; start[w * h]];
        for (i, t) in texel.iter().enumerate() {
            if let Some(t) = *t {
                entries[fill[t]] = i as u32;
                fill[t] += 1;
            }
        }
        let depths = points
            .iter()
            .map(|&p| f64::from(frustum.to_view(p).z))
            .collect();
        Self {
            frustum,
            start,
            entries,
            depths,
        }
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
    /// covers conservatively: [`conservative_rows`](crate::raster::region::conservative_rows)
    /// restricted to `rows`, computed for those rows only (a band visits the regions of every
    /// caster binned to it) by [`conservative_spans`]; `bounds` is its scratch memory.
    pub fn spans<'s>(
        &self,
        hull: Option<&[DVec2]>,
        rows: &Range<usize>,
        bounds: &'s mut Vec<DVec2>,
    ) -> impl Iterator<Item = (usize, usize, usize)> + 's {
        let w = self.frustum.width;
        let whole = hull.is_none().then(|| rows.clone().map(move |y| (y, 0, w)));
        let region = hull.map(|hull| conservative_spans(hull, rows.clone(), w, bounds));
        whole
            .into_iter()
            .flatten()
            .chain(region.into_iter().flatten())
    }

    /// Whether a texel of rows `rows` and columns `columns` holds a list entry.
    pub fn any_entry_in(&self, rows: &Range<usize>, columns: &Range<usize>) -> bool {
        let w = self.frustum.width;
        rows.clone()
            .any(|y| self.start[y * w + columns.start] < self.start[y * w + columns.end])
    }

    /// The list entries of the texels of a span.
    pub fn span_entries(&self, (y, x0, x1): (usize, usize, usize)) -> Range<usize> {
        let w = self.frustum.width;
        self.start[y * w + x0]..self.start[y * w + x1]
    }

    /// Splits `data` (`per_entry` values per list entry, in list order) into the parts of each
    /// band, `(band, rows, first entry, part)`, as a parallel iterator of one job per band.
    ///
    /// One job per band (`with_max_len(1)`): a shadow crosses neighbouring rows, so the costly
    /// bands lie together, and rayon's adaptive splitting, which stops at a few runs of bands
    /// per thread, leaves one thread a run it cannot share.
    /// On the bunny (512x512 receivers, 256 samples, lookup table of 64 bins, two threads)
    /// `alias_free`'s per-texel tests took 2.1 s in runs of bands, though two single-threaded
    /// processes side by side ran as fast as one alone, and 1.5 s with a job per band.
    pub fn split_by_band<'a, T: Send>(
        &self,
        data: &'a mut [T],
        per_entry: usize,
    ) -> impl IndexedParallelIterator<Item = (usize, Range<usize>, usize, &'a mut [T])> {
        let mut rest = data;
        let mut out = Vec::with_capacity(self.bands());
        for b in 0..self.bands() {
            let rows = self.rows(b);
            let entries = self.entries_of(&rows);
            let (head, tail) = rest.split_at_mut(entries.len() * per_entry);
            out.push((b, rows, entries.start, head));
            rest = tail;
        }
        out.into_par_iter().with_max_len(1)
    }

    /// A frustum for the receivers of `rows`: the map's, with its far plane at their farthest
    /// depth (regions shrink towards the light, so projecting them there stays conservative
    /// for those receivers); `None` when the rows hold none.
    pub fn band_frustum(&self, rows: &Range<usize>) -> Option<LightFrustum> {
        let far = self.entries[self.entries_of(rows)]
            .iter()
            .map(|&e| self.depths[e as usize] as f32)
            .fold(0.0f32, f32::max);
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
    /// item's influence region (the region of the world points `vertices(item)` from the points
    /// of `bounds`), with the point's `per_entry` values of `data` (one run of values per list
    /// entry, in list order). Bands of rows run in parallel, each projecting the regions onto its
    /// own farthest point; within a band, items go in order, so the result does not depend on
    /// the thread count. Errors: interrupted.
    #[allow(clippy::too_many_arguments)]
    pub fn visit_regions<I: Sync, T: Send>(
        &self,
        bounds: &LightBounds<'_>,
        degree: usize,
        items: &[I],
        vertices: impl Fn(&I) -> &[Vec3] + Sync,
        data: &mut [T],
        per_entry: usize,
        visit: impl Fn(&I, usize, &mut [T]) + Sync,
    ) -> Result<()> {
        self.visit_region_spans(
            bounds,
            degree,
            items,
            vertices,
            data,
            per_entry,
            || (),
            |item, entries, values, _| {
                for (e, values) in entries.zip(values.chunks_mut(per_entry)) {
                    visit(item, self.entries[e] as usize, values);
                }
            },
        )
    }

    /// [`ReceiverLists::visit_regions`] a span of texels at a time: calls `visit(item, entries,
    /// values, scratch)` for the list entries `entries` of each span of texels (one row) that the
    /// item's region covers, with their values of `data` (`per_entry` per entry, in list order), so
    /// that a visit can test the span's points together, and the band's own `scratch()` (kept
    /// from one item's spans to the next).
    #[allow(clippy::too_many_arguments)]
    pub fn visit_region_spans<I: Sync, T: Send, S>(
        &self,
        bounds: &LightBounds<'_>,
        degree: usize,
        items: &[I],
        vertices: impl Fn(&I) -> &[Vec3] + Sync,
        data: &mut [T],
        per_entry: usize,
        scratch: impl Fn() -> S + Sync,
        visit: impl Fn(&I, Range<usize>, &mut [T], &mut S) + Sync,
    ) -> Result<()> {
        let hulls: Vec<Option<Vec<DVec2>>> = items
            .par_iter()
            .map(|it| influence_hull(&self.frustum, bounds, vertices(it), degree))
            .collect();
        let bins = self.bin(&hulls);
        // A band visits every item of its bin, seconds of work for a large scene: each band
        // stops at the next item once the call is asked to stop.
        let watch = crate::interrupt::watch();
        self.split_by_band(data, per_entry)
            .for_each(|(b, rows, base, part)| {
                let Some(band_frustum) = self.band_frustum(&rows) else {
                    return;
                };
                let (mut scratch, mut span_bounds) = (scratch(), Vec::new());
                for &k in bins[b].iter().take_while(|_| !watch.requested()) {
                    let item = &items[k as usize];
                    let region = match &hulls[k as usize] {
                        Some(_) => influence_hull(&band_frustum, bounds, vertices(item), degree),
                        None => None,
                    };
                    for span in self.spans(region.as_deref(), &rows, &mut span_bounds) {
                        let entries = self.span_entries(span);
                        let values = &mut part
                            [(entries.start - base) * per_entry..(entries.end - base) * per_entry];
                        visit(item, entries, values, &mut scratch);
                    }
                }
            });
        crate::interrupt::check()
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
                conservative_row_extent(hull, w, h).map(|(first, last)| (first, last + 1))
            }
        })
        .collect();
    bin_row_ranges(&rows, band, h.div_ceil(band))
}

/// [`ReceiverLists::band_frustum`] for receivers whose farthest linear depth is `far` (`None`
/// for none, `far <= 0`).
pub fn band_frustum(frustum: &LightFrustum, far: f32) -> Option<LightFrustum> {
    (far > 0.0).then(|| LightFrustum {
        far: (far * 1.001).max(frustum.near * 2.0),
        ..*frustum
    })
}

/// [`ReceiverLists::record_stats`] from the length of every texel's list.
pub fn record_list_stats(lengths: impl ExactSizeIterator<Item = usize>, stats: &mut Stats) {
    let texels = lengths.len().max(1);
    let (occupied, max, total) = lengths.fold((0usize, 0usize, 0usize), |(o, m, t), l| {
        (o + usize::from(l > 0), m.max(l), t + l)
    });
    stats.set(
        "average_list_length",
        if occupied > 0 {
            total as f64 / occupied as f64
        } else {
            0.0
        },
    );
    stats.set("max_list_length", max as f64);
    stats.set(
        "occupied_texels_percent",
        100.0 * occupied as f64 / texels as f64,
    );
}

/// The frustum of [`ReceiverLists::build`]: the square fit to the points' bounding box
/// ([`LightFrustum::fit`]), or where none holds the box, the frustum of the cube face around
/// the light that holds every point ([`enclosing_face`]); fitted to the points ([`fit_to_points`]).
/// Errors: neither holds the points (some lie on every side of the light, or at it).
fn fit_frustum(light: &Light, points: &[Vec3], resolution: usize) -> Result<LightFrustum> {
    let (lo, hi) = points
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let eye = light.center();
    let base = LightFrustum::fit(eye, lo, hi, resolution).ok().or_else(|| enclosing_face(eye, points, resolution)).ok_or_else(|| {
        Error::invalid(
            "light",
            format!(
                "no frustum from the light's center {eye} holds the receivers' shadow-ray origins {lo}..{hi}: \
                 some lie at the center or on every side of it; move the light off the receivers, or lower \
                 epsilon if origins within it of the center caused this"
            ),
        )
    })?;
    Ok(fit_to_points(base, points))
}

/// `base`'s axes with the tightest fields of view and depth range holding `points` (all in
/// front of its eye).
fn fit_to_points(base: LightFrustum, points: &[Vec3]) -> LightFrustum {
    let (mut tx, mut ty, mut z0, mut z1) = (0.0f32, 0.0f32, f32::INFINITY, 0.0f32);
    for &p in points {
        let v = base.to_view(p);
        tx = tx.max(v.x.abs() / v.z);
        ty = ty.max(v.y.abs() / v.z);
        z0 = z0.min(v.z);
        z1 = z1.max(v.z);
    }
    let margin = 1.0 + 1e-3;
    LightFrustum {
        tan_half_x: (tx * margin).max(1e-4),
        tan_half_y: (ty * margin).max(1e-4),
        near: NEAR_FRACTION * z0,
        far: (z1 * 1.001).max(NEAR_FRACTION * z0 * 2.0),
        ..base
    }
}

/// The light's bounding points seen from world point `v` (see the module documentation).
pub fn light_points(light: &Light, v: DVec3, degree: usize) -> Vec<DVec3> {
    match light.shape {
        Shape::Point { position } => vec![position.as_dvec3()],
        Shape::Rect { center, u, v: w } => {
            let (c, u, w) = (center.as_dvec3(), u.as_dvec3(), w.as_dvec3());
            vec![c + u + w, c + u - w, c - u - w, c - u + w]
        }
        Shape::Disk {
            center,
            normal,
            radius,
        } => circumscribed_polygon(
            center.as_dvec3(),
            normal.as_dvec3(),
            f64::from(radius),
            degree,
        ),
        Shape::Sphere { center, radius } => {
            sphere_silhouette(center.as_dvec3(), f64::from(radius), v, degree)
        }
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

/// The bounding `degree`-gon of the silhouette circle of the sphere `(c, r)` seen from `v`
/// (empty when `v` is inside the sphere).
fn sphere_silhouette(c: DVec3, r: f64, v: DVec3, degree: usize) -> Vec<DVec3> {
    let d = v - c;
    let dist2 = d.length_squared();
    if dist2 <= r * r {
        return Vec::new();
    }
    // The silhouette circle seen from v: center c + d r²/|d|², radius r sqrt(1 − r²/|d|²).
    circumscribed_polygon(
        c + d * (r * r / dist2),
        d / dist2.sqrt(),
        r * (1.0 - r * r / dist2).sqrt(),
        degree,
    )
}

/// Points whose convex hull holds the light: a rectangle's corners, the circumscribed
/// `degree`-gon of a disk, the circumscribed box of a sphere or an ellipsoid, a point light itself.
pub fn light_polytope(light: &Light, degree: usize) -> Vec<DVec3> {
    let corners = |c: DVec3, a: DMat3| -> Vec<DVec3> {
        (0..8)
            .map(|k| {
                c + a * DVec3::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -1.0 } else { 1.0 },
                    if k & 4 == 0 { -1.0 } else { 1.0 },
                )
            })
            .collect()
    };
    match light.shape {
        Shape::Point { position } => vec![position.as_dvec3()],
        Shape::Rect { center, u, v } => {
            let (c, u, v) = (center.as_dvec3(), u.as_dvec3(), v.as_dvec3());
            vec![c + u + v, c + u - v, c - u - v, c - u + v]
        }
        Shape::Disk {
            center,
            normal,
            radius,
        } => circumscribed_polygon(
            center.as_dvec3(),
            normal.as_dvec3(),
            f64::from(radius),
            degree,
        ),
        Shape::Sphere { center, radius } => corners(
            center.as_dvec3(),
            DMat3::from_diagonal(DVec3::splat(f64::from(radius))),
        ),
        Shape::Ellipsoid { center, axes } => corners(center.as_dvec3(), axes.as_dmat3()),
    }
}

/// The influence region of the world points `points` (a triangle's or an edge's vertices): the
/// convex hull, in texel coordinates, of their projections from the bounding points of the light
/// and its samples onto the far plane; `None` for the whole map (a point not strictly beyond
/// some bounding point along the view direction). Every receiver whose segment to a light point
/// or a sample meets the convex hull of `points` projects inside it (Sintorn et al. 2008,
/// section 4.1), since the light's center, the frustum's eye, lies inside the bounds.
pub fn influence_hull(
    frustum: &LightFrustum,
    bounds: &LightBounds<'_>,
    points: &[Vec3],
    degree: usize,
) -> Option<Vec<DVec2>> {
    influence_points(frustum, bounds, points, degree).map(|pts| convex_hull(&pts))
}

/// The points whose convex hull is [`influence_hull`]: `points`' projections from the bounding
/// points of the light and its samples, in texel coordinates (empty where the region is).
pub fn influence_points(
    frustum: &LightFrustum,
    bounds: &LightBounds<'_>,
    points: &[Vec3],
    degree: usize,
) -> Option<Vec<DVec2>> {
    let (eye, f) = (frustum.eye.as_dvec3(), frustum.forward.as_dvec3());
    if wholly_behind(frustum, bounds, points) {
        return Some(Vec::new());
    }
    let far = f64::from(frustum.far);
    let mut pts = Vec::with_capacity(points.len() * degree.max(4));
    for v in points.iter().map(|v| v.as_dvec3()) {
        let ys = bounds.points_seen_from(v, degree);
        if ys.is_empty() {
            return None;
        }
        for &y in ys.iter() {
            let (zy, dz) = ((y - eye).dot(f), (v - y).dot(f));
            if dz <= 1e-9 * (1.0 + zy.abs()) {
                return None;
            }
            let x = y + (v - y) * ((far - zy) / dz);
            let s = frustum.project(x.as_vec3())?;
            pts.push(DVec2::new(f64::from(s.x), f64::from(s.y)));
        }
    }
    Some(pts)
}

/// Whether the world points `points` lie wholly behind the light and its samples along the view
/// direction: a segment from a receiver in front of the eye to a light point or sample stays in
/// front of the nearer of its two ends, so nothing there can cut it (a cube face's frustum drops
/// the casters behind the face this way).
fn wholly_behind(frustum: &LightFrustum, bounds: &LightBounds<'_>, points: &[Vec3]) -> bool {
    let (eye, f) = (frustum.eye.as_dvec3(), frustum.forward.as_dvec3());
    let behind = if bounds.is_light() {
        bounds.light.half_extent_along(frustum.forward)
    } else {
        bounds.reach()
    };
    let slack = 1e-5 * (f64::from(behind) + eye.abs().max_element()) + 1e-30;
    let limit = -f64::from(behind) - slack;
    !points.is_empty() && points.iter().all(|v| (v.as_dvec3() - eye).dot(f) < limit)
}

/// Slack, in units in the last place of the light's coordinates, of the test that a sample lies
/// on the light: generated samples are rounded to f32 a few times over ([`Light::map`],
/// [`Light::rotate`]) and may stray that far.
const ON_LIGHT_ULPS: f64 = 16.0;

/// Relative margin of bounds enlarged to hold samples off the light, against the round-off of
/// their corners and of their f32 radii and axes.
const MARGIN: f64 = 1e-6;

/// The light and every light sample its receivers use: what the influence regions, the test of
/// which receivers face the light and the soft shadow volumes bound.
///
/// Sintorn et al. 2008 (Sample Based Visibility for Soft Shadows using Alias-free Shadow Maps,
/// section 4.2) test arbitrary light sample positions, and explicit samples may lie off the light
/// (samples of a larger light, behind it, on a shell around it). A region that bounds the light
/// but not a sample misses receivers that the sample's segments shadow. Samples on the light (to
/// float precision, as every generated pattern is) keep the light's own bounding points, and so
/// their results; otherwise a shape of the light's kind that holds the light and every sample
/// takes its place. Each such shape is symmetric under the light's per-receiver rotation (a ball
/// about the center, a prism about a disk's axis), and the rotations of rectangles and
/// ellipsoids map any point onto the light, so rotated samples stay inside.
pub struct LightBounds<'a> {
    pub light: &'a Light,
    /// `None` when every sample lies on the light.
    beyond: Option<Beyond>,
    /// For a light whose bounding points are the same from every point (point, rectangle and
    /// disk lights, with every sample on the light), the polygons' degree and those points:
    /// [`LightBounds::points_seen_from`] lends them, where millions of calls would each build
    /// its own copy.
    fixed: Option<(usize, Vec<DVec3>)>,
}

/// A shape holding a light and its samples off it.
enum Beyond {
    /// A sphere or an ellipsoid about the light's center (point, sphere and ellipsoid lights),
    /// bounded as a volume light is.
    Volume(Light),
    /// The corners of a convex polytope (rect and disk lights): a box over a rectangle's two
    /// parameters and its normal, or a prism of polygons circumscribing a disk about its axis.
    Corners(Vec<DVec3>),
}

impl<'a> LightBounds<'a> {
    /// The bounds of `light` alone.
    pub fn of_light(light: &'a Light) -> Self {
        Self {
            light,
            beyond: None,
            fixed: None,
        }
    }

    /// The bounds of `light` and every sample of `samples` (a disk's by `degree`-gons).
    ///
    /// Errors: samples so far from the light that their bounds overflow f32.
    pub fn new(light: &'a Light, samples: &SampleSet, degree: usize) -> Result<Self> {
        let c = light.center().as_dvec3();
        let tol =
            ON_LIGHT_ULPS * f64::from(f32::EPSILON) * (c.abs().max_element() + light.extent());
        let offsets: Vec<DVec3> = samples.points().map(|y| y.as_dvec3() - c).collect();
        let beyond = match light.shape {
            Shape::Point { .. } => ball_beyond(c, 0.0, &offsets, tol)?,
            Shape::Sphere { radius, .. } => ball_beyond(c, f64::from(radius), &offsets, tol)?,
            Shape::Ellipsoid { axes, .. } => ellipsoid_beyond(c, axes.as_dmat3(), &offsets, tol)?,
            Shape::Rect { u, v, .. } => rect_beyond(c, u.as_dvec3(), v.as_dvec3(), &offsets, tol),
            Shape::Disk { normal, radius, .. } => disk_beyond(
                c,
                normal.as_dvec3(),
                f64::from(radius),
                &offsets,
                tol,
                degree,
            ),
        };
        let fixed = match (&beyond, &light.shape) {
            (None, Shape::Point { .. } | Shape::Rect { .. } | Shape::Disk { .. }) => {
                Some((degree, light_points(light, c, degree)))
            }
            _ => None,
        };
        let bounds = Self {
            light,
            beyond,
            fixed,
        };
        if !bounds.reach().is_finite() {
            return Err(too_far());
        }
        Ok(bounds)
    }

    /// Whether every sample lies on the light.
    pub fn is_light(&self) -> bool {
        self.beyond.is_none()
    }

    /// The largest distance from the light's center to a bounded point: the light's extent when
    /// every sample lies on it.
    pub fn reach(&self) -> f32 {
        match &self.beyond {
            None => self.light.extent() as f32,
            Some(Beyond::Volume(volume)) => volume.extent() as f32,
            Some(Beyond::Corners(corners)) => {
                let c = self.light.center().as_dvec3();
                let far = corners
                    .iter()
                    .map(|q| (*q - c).length())
                    .fold(0.0f64, f64::max);
                (far * (1.0 + MARGIN)) as f32
            }
        }
    }

    /// The bounding points seen from world point `v`, whose cone from `v` holds the light and
    /// every sample: the light's or the larger volume's ([`light_points`]), or the polytope's
    /// corners; empty when `v` lies inside a volume.
    pub fn points_seen_from(&self, v: DVec3, degree: usize) -> Cow<'_, [DVec3]> {
        match &self.beyond {
            None => match &self.fixed {
                Some((fixed_degree, points)) if *fixed_degree == degree => Cow::Borrowed(points),
                _ => Cow::Owned(light_points(self.light, v, degree)),
            },
            Some(Beyond::Volume(volume)) => Cow::Owned(light_points(volume, v, degree)),
            Some(Beyond::Corners(corners)) => Cow::Borrowed(corners),
        }
    }

    /// Points whose convex hull holds the light and every sample: [`light_polytope`] of the light
    /// or of the larger volume, or the polytope's corners.
    pub fn polytope(&self, degree: usize) -> Vec<DVec3> {
        match &self.beyond {
            None => light_polytope(self.light, degree),
            Some(Beyond::Volume(volume)) => light_polytope(volume, degree),
            Some(Beyond::Corners(corners)) => corners.clone(),
        }
    }

    /// The light, or the larger sphere or ellipsoid holding it and its samples; `None` when a
    /// polytope's corners bound them ([`LightBounds::corners`]).
    pub fn volume(&self) -> Option<&Light> {
        match &self.beyond {
            None => Some(self.light),
            Some(Beyond::Volume(volume)) => Some(volume),
            Some(Beyond::Corners(_)) => None,
        }
    }

    /// The corners of the polytope holding the light and its samples, when one bounds them.
    pub fn corners(&self) -> Option<&[DVec3]> {
        match &self.beyond {
            Some(Beyond::Corners(corners)) => Some(corners),
            _ => None,
        }
    }
}

fn too_far() -> Error {
    Error::invalid("samples", "lie so far from the light that their bounds overflow float32: keep every sample within about 1e38 of the light's center")
}

/// A point light's or a sphere's bounds (radius `r` about `c`) for samples at `offsets` from `c`:
/// `None` when every sample lies within `r` (give or take `tol`), else a sphere about `c` holding
/// them.
fn ball_beyond(c: DVec3, r: f64, offsets: &[DVec3], tol: f64) -> Result<Option<Beyond>> {
    let far = offsets.iter().map(|d| d.length()).fold(0.0f64, f64::max);
    if far <= r + tol {
        return Ok(None);
    }
    let ball = Light::sphere(c.as_vec3(), (far * (1.0 + MARGIN)) as f32).map_err(|_| too_far())?;
    Ok(Some(Beyond::Volume(ball)))
}

/// An ellipsoid's bounds (semi-axes the columns of `a`): `None` when every sample lies inside it
/// (give or take `tol`), else the ellipsoid scaled about `c` until it holds them.
fn ellipsoid_beyond(c: DVec3, a: DMat3, offsets: &[DVec3], tol: f64) -> Result<Option<Beyond>> {
    let inverse = a.inverse();
    let scale = offsets
        .iter()
        .map(|d| (inverse * *d).length())
        .fold(0.0f64, f64::max);
    let thinnest = a
        .x_axis
        .length()
        .min(a.y_axis.length())
        .min(a.z_axis.length());
    if scale <= 1.0 + tol / thinnest {
        return Ok(None);
    }
    let s = scale * (1.0 + MARGIN);
    let axes = [a.x_axis * s, a.y_axis * s, a.z_axis * s].map(|axis| axis.as_vec3());
    let volume = Light::ellipsoid(c.as_vec3(), axes).map_err(|_| too_far())?;
    Ok(Some(Beyond::Volume(volume)))
}

/// A rectangle's bounds (half-extent vectors `u`, `v`): `None` when every sample lies on it
/// (give or take `tol`), else the corners of the box `c + a u + b v + h n` (unit normal `n`)
/// over the ranges of `a`, `b` and `h` of the rectangle and the samples; flat when every sample
/// lies in the rectangle's plane.
fn rect_beyond(c: DVec3, u: DVec3, v: DVec3, offsets: &[DVec3], tol: f64) -> Option<Beyond> {
    let n = u.cross(v).normalize();
    let to_params = DMat3::from_cols(u, v, n).inverse();
    let params: Vec<DVec3> = offsets.iter().map(|d| to_params * *d).collect();
    let slack = DVec3::new(1.0 + tol / u.length(), 1.0 + tol / v.length(), tol);
    if params.iter().all(|q| q.abs().cmple(slack).all()) {
        return None;
    }
    let (lo, hi) = params.iter().fold(
        (DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.0)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    );
    let (lo, hi) = (lo - (hi - lo) * MARGIN, hi + (hi - lo) * MARGIN);
    let heights: &[f64] = if lo.z == hi.z { &[lo.z] } else { &[lo.z, hi.z] };
    let corners = heights
        .iter()
        .flat_map(|&h| {
            [(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)]
                .map(|(a, b)| c + u * a + v * b + n * h)
        })
        .collect();
    Some(Beyond::Corners(corners))
}

/// A disk's bounds (unit normal `n`, radius `r`): `None` when every sample lies on it (give or
/// take `tol`), else the prism of `degree`-gons circumscribing the circle through the farthest
/// sample from the axis (or the rim) at the lowest and highest heights along `n` of the disk and
/// the samples; one polygon when every sample lies in the disk's plane.
fn disk_beyond(
    c: DVec3,
    n: DVec3,
    r: f64,
    offsets: &[DVec3],
    tol: f64,
    degree: usize,
) -> Option<Beyond> {
    let (mut radial, mut lo, mut hi) = (0.0f64, 0.0f64, 0.0f64);
    for d in offsets {
        let h = d.dot(n);
        radial = radial.max((*d - n * h).length());
        (lo, hi) = (lo.min(h), hi.max(h));
    }
    if radial <= r + tol && lo >= -tol && hi <= tol {
        return None;
    }
    let (lo, hi) = (lo - (hi - lo) * MARGIN, hi + (hi - lo) * MARGIN);
    let heights: &[f64] = if lo == hi { &[lo] } else { &[lo, hi] };
    let radius = radial.max(r) * (1.0 + MARGIN);
    Some(Beyond::Corners(
        heights
            .iter()
            .flat_map(|&h| circumscribed_polygon(c + n * h, n, radius, degree))
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::{Pattern, Rng};
    use crate::raster::region::conservative_rows;

    /// Whether the segment `p → y` meets triangle `t` strictly inside (general position).
    fn segment_meets_triangle(p: DVec3, y: DVec3, t: [DVec3; 3]) -> bool {
        let orient = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).cross(c - a).dot(d - a);
        if orient(t[0], t[1], t[2], p) * orient(t[0], t[1], t[2], y) >= 0.0 {
            return false;
        }
        let s = [
            orient(p, y, t[0], t[1]),
            orient(p, y, t[1], t[2]),
            orient(p, y, t[2], t[0]),
        ];
        s.iter().all(|&v| v > 0.0) || s.iter().all(|&v| v < 0.0)
    }

    fn lights() -> Result<Vec<Light>> {
        let c = Vec3::new(0.3, 4.0, -0.2);
        Ok(vec![
            Light::point(c)?,
            Light::rect(c, Vec3::new(0.5, 0.1, 0.0), Vec3::new(0.1, 0.0, -0.4))?,
            Light::disk(c, Vec3::new(0.2, -1.0, 0.1), 0.5)?,
            Light::sphere(c, 0.4)?,
            Light::ellipsoid(
                c,
                [
                    Vec3::new(0.6, 0.0, 0.0),
                    Vec3::new(0.0, 0.2, 0.0),
                    Vec3::new(0.0, 0.0, 0.35),
                ],
            )?,
        ])
    }

    /// Samples of `light` off it: scaled by 2 about its center, on a shell around it, shifted
    /// sideways, pushed back, pulled among the occluders.
    fn off_light_samples(light: &Light, rng: &mut Rng) -> Vec<Vec<Vec3>> {
        let c = light.center();
        let on: Vec<Vec3> = (0..12)
            .map(|_| light.map([rng.next_f32(), rng.next_f32(), rng.next_f32()]))
            .collect();
        let mut shell = Vec::new();
        while shell.len() < 12 {
            let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            if d.length() > 0.1 && d.length() <= 1.0 {
                shell.push(c + d.normalize() * 1.3);
            }
        }
        let moved = |by: Vec3| on.iter().map(|&y| y + by).collect::<Vec<_>>();
        vec![
            on.iter().map(|&y| c + (y - c) * 2.0).collect(),
            shell,
            moved(Vec3::new(1.2, 0.0, -0.7)),
            moved(Vec3::Y * 2.0),
            moved(Vec3::Y * -2.6),
        ]
    }

    #[test]
    fn regions_hold_every_receiver_that_a_sample_off_the_light_shadows() -> Result<()> {
        // Sintorn et al. 2008, section 4.1, for samples anywhere: a receiver whose segment to a
        // sample meets a triangle projects into the triangle's region, rotated samples included.
        let mut rng = Rng::new(11);
        let (w, h) = (20, 20);
        let points: Vec<Vec3> = (0..w * h)
            .map(|i| {
                Vec3::new(
                    -3.0 + 6.0 * (i % w) as f32 / w as f32,
                    0.1 * (i / w) as f32 / h as f32,
                    -3.0 + 6.0 * (i / w) as f32 / h as f32,
                )
            })
            .collect();
        let receivers = Receivers::new(
            points.clone(),
            vec![Vec3::Y; w * h],
            vec![true; w * h],
            w,
            h,
        )?;
        let triangles: Vec<[Vec3; 3]> = (0..40)
            .map(|_| {
                let c = Vec3::new(
                    4.0 * rng.next_f32() - 2.0,
                    0.8 + 1.6 * rng.next_f32(),
                    4.0 * rng.next_f32() - 2.0,
                );
                [0, 1, 2].map(|_| {
                    c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 1.2
                })
            })
            .collect();
        let (mut shadowed, mut beyond) = (0usize, 0usize);
        for light in lights()? {
            let lists = ReceiverLists::build(&light, &points, 32)?;
            let (fw, fh) = (lists.frustum.width, lists.frustum.height);
            for (k, ys) in off_light_samples(&light, &mut rng).into_iter().enumerate() {
                let rotate = (k % 2 == 1 && light.rigid_rotation([0.0; 3]).is_some()).then_some(5);
                let samples = SampleSet::explicit(ys, rotate)?;
                let bounds = LightBounds::new(&light, &samples, 6)?;
                beyond += usize::from(!bounds.is_light());
                let (mut own, mut weights) = (Vec::new(), Vec::new());
                for t in &triangles {
                    let region = influence_hull(&lists.frustum, &bounds, t, 6)
                        .map(|hull| conservative_rows(&hull, fw, fh));
                    let covered = |texel: usize| {
                        region.as_ref().is_none_or(|rows| {
                            rows.iter().any(|&(y, x0, x1)| {
                                y == texel / fw && (x0..x1).contains(&(texel % fw))
                            })
                        })
                    };
                    for (i, &p) in points.iter().enumerate() {
                        samples.fill(&light, i, receivers.pixel(i), &mut own, &mut weights);
                        if own.iter().any(|y| {
                            segment_meets_triangle(
                                p.as_dvec3(),
                                y.as_dvec3(),
                                t.map(|v| v.as_dvec3()),
                            )
                        }) {
                            shadowed += 1;
                            assert!(
                                covered(ReceiverLists::texel(&lists.frustum, p)),
                                "{:?}, samples {k}: receiver {i} outside the region of {t:?}",
                                light.shape
                            );
                        }
                    }
                }
            }
        }
        // Every set lies off its light but one: a point light's samples scaled about it stay on it.
        assert_eq!(beyond, 24, "the sample sets must lie off their lights");
        assert!(
            shadowed > 5_000,
            "the triangles must shadow receivers: {shadowed}"
        );
        Ok(())
    }

    #[test]
    fn generated_samples_lie_on_their_light() -> Result<()> {
        // Their bounds are the light's own, so their regions and results stay as they were.
        for light in lights()? {
            for pattern in [
                Pattern::Uniform,
                Pattern::Stratified,
                Pattern::Poisson,
                Pattern::Sobol,
                Pattern::Halton,
            ] {
                for (interleave, rotate, frame) in
                    [(1, false, 0), (2, true, 0), (1, true, 3), (3, false, 7)]
                {
                    let samples =
                        SampleSet::generate(&light, 64, pattern, 9, interleave, rotate, frame)?;
                    assert!(
                        LightBounds::new(&light, &samples, 6)?.is_light(),
                        "{:?} {pattern:?} {interleave} {rotate} {frame}",
                        light.shape
                    );
                }
            }
            let c = light.center();
            let off = SampleSet::explicit(
                vec![c + Vec3::new(0.0, 0.0, 2.0 * light.extent() as f32 + 0.1)],
                None,
            )?;
            let bounds = LightBounds::new(&light, &off, 6)?;
            assert!(
                !bounds.is_light() && bounds.reach() >= 2.0 * light.extent() as f32 + 0.1,
                "{:?}",
                light.shape
            );
        }
        Ok(())
    }

    #[test]
    fn samples_whose_bounds_overflow_are_refused_by_name() -> Result<()> {
        let light = Light::sphere(Vec3::splat(-3e38), 1.0)?;
        let samples = SampleSet::explicit(vec![Vec3::splat(3e38)], None)?;
        let refused = LightBounds::new(&light, &samples, 6);
        assert!(
            matches!(&refused, Err(Error::InvalidInput { arg, .. }) if arg == "samples"),
            "{:?}",
            refused.err()
        );
        Ok(())
    }
}
