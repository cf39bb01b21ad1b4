//! `penumbra_wedge`: soft shadow volumes with penumbra wedges (Assarsson and Akenine-Möller 2003),
//! the approximate object-based framework of Forest et al. 2009, Soft Textured Shadow Volume
//! (section 3.1), for opaque meshes.
//!
//! The visibility coefficient of a receiver (shadow-ray origin `p' = p + epsilon n`) starts from
//! the hard shadow of the light's center `y0` (its shadow volume; here the segment `p' → y0`
//! through the BVH), and each edge that is a silhouette *from the center* and whose penumbra wedge
//! holds the receiver adds (entering an occluder) or removes (leaving one) the part of the light
//! it separates from the center as seen from the receiver. That part is measured on the light
//! samples in front of the receiver's tangent plane (the paper's 4D coverage texture integrates
//! the same area analytically): the samples `y` for which the edge crosses the triangle
//! `(p', y0, y)` ([`crate::geometry::edges::Edge::wedge_sweep`]), each edge counting once
//! whatever its number of faces, on the side its faces extend to. Then `V = front · (1 − clamp(occlusion, 0, 1))`, with `front` the weighted fraction
//! of samples in front of the tangent plane.
//!
//! The approximations are the method's: silhouettes are found from the center only, and the
//! coverages of different silhouette edges add up, so overlapping occluders are counted twice
//! and their penumbrae come out too dark (Forest et al. 2009, section 3.1 and Figure 4a). `dcs` counts per
//! sample instead and is exact.

use crate::error::Result;
use crate::geometry::bvh::Bvh;
use crate::geometry::edges::{edges_peak, opaque_silhouettes};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::influence::{ObjectOptions, Origins};
use crate::light::lights::Light;
use crate::light::sampling::plus_zero_sum;
use crate::light::sampling::SampleSet;
use crate::limits::{object_work, Peak};
use crate::raster::cube::by_light_face;
use crate::stats::Stats;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "hard_seconds",
    "silhouettes_seconds",
    "wedges_seconds",
    "silhouette_edges",
    "wedge_tests",
    "sample_tests",
    "receivers",
    "light_samples",
    "light_faces",
];

/// Visibility of every receiver by penumbra wedges (see the module doc) on the opaque meshes of
/// `scene`. Returns the visibility (receivers' order) and stats: `hard_seconds` (the center's
/// shadow), `silhouettes_seconds`, `wedges_seconds`, `silhouette_edges`, `wedge_tests`,
/// `sample_tests` (light samples tested against a wedge's sweep), `receivers`, `light_samples`.
pub fn penumbra_wedge(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &ObjectOptions,
) -> Result<(Vec<f32>, Stats)> {
    by_light_face(light, receivers, |part, _| {
        wedges_in_one_frustum(scene, bvh, light, part, samples, opts)
    })
}

/// [`penumbra_wedge`] on receivers that one light frustum holds.
fn wedges_in_one_frustum(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &ObjectOptions,
) -> Result<(Vec<f32>, Stats)> {
    opts.validate(scene, receivers)?;
    bvh.check_scene(scene)?;
    let mut stats = Stats::declared(STATS);
    stats.set("light_samples", samples.count() as f64);
    let n = receivers.len();
    Peak::default()
        .buffer(&[n as u64, 4])
        .and(Origins::peak(n, opts))
        .and(wedge_occlusion_peak(scene, n))
        .check("penumbra_wedge", &mut stats)?;
    object_work(scene, n, samples.count()).check("penumbra_wedge", &mut stats)?;
    let mut vis = vec![0.0f32; receivers.len()];
    let Some(origins) = Origins::new(light, receivers, samples, opts)? else {
        return Ok((vis, stats));
    };
    stats.set("receivers", origins.ids.len() as f64);
    let occlusion = wedge_occlusion(scene, bvh, &origins, opts, &mut stats)?;
    for (&k, occ) in origins.lists.entries.iter().zip(occlusion) {
        let i = origins.ids[k as usize] as usize;
        vis[i] = (occ.front * (1.0 - occ.occlusion.clamp(0.0, 1.0))) as f32;
    }
    Ok((vis, stats))
}

/// A receiver's weighted fraction of samples in front of its tangent plane and its occlusion
/// estimate (hard shadow plus the coverages of the wedges, unclamped).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct WedgeOcclusion {
    pub front: f64,
    pub occlusion: f64,
}

/// The memory of [`wedge_occlusion`] for `receivers` receivers: one [`WedgeOcclusion`] each and
/// the silhouettes.
pub(crate) fn wedge_occlusion_peak(scene: &Scene, receivers: usize) -> Peak {
    Peak::default()
        .buffer(&[
            receivers as u64,
            std::mem::size_of::<WedgeOcclusion>() as u64,
        ])
        .and(edges_peak(scene))
}

/// The per list entry [`WedgeOcclusion`] of the receivers (see the module doc).
pub(crate) fn wedge_occlusion(
    scene: &Scene,
    bvh: &Bvh,
    origins: &Origins,
    opts: &ObjectOptions,
    stats: &mut Stats,
) -> Result<Vec<WedgeOcclusion>> {
    let (lists, light) = (&origins.lists, origins.light);
    let center = light.center();
    let opaque = |f: u32| !scene.is_perforated_face(f);
    let fill = |k: usize, ys: &mut Vec<glam::Vec3>, ws: &mut Vec<f32>| origins.fill(k, ys, ws);
    // Per entry: the center's shadow and the front weights, then the wedges' signed coverages.
    let mut occ: Vec<WedgeOcclusion> = stats.time("hard", || {
        lists
            .entries
            .par_iter()
            .map_init(
                || (Vec::new(), Vec::new()),
                |(ys, ws), &k| {
                    let k = k as usize;
                    fill(k, ys, ws);
                    let ((p, n), o) = (origins.receiver(k), origins.origins[k]);
                    let total: f64 = ws.iter().map(|&w| f64::from(w)).sum();
                    let front: f64 = ys
                        .iter()
                        .zip(ws.iter())
                        .filter(|(y, _)| (**y - p).dot(n) > 0.0)
                        .map(|(_, &w)| f64::from(w))
                        .fold(0.0, plus_zero_sum);
                    let hard = bvh.count_hits(o, center - o, 1.0, opaque) > 0;
                    WedgeOcclusion {
                        front: if total > 0.0 { front / total } else { 0.0 },
                        occlusion: f64::from(u8::from(hard)),
                    }
                },
            )
            .collect()
    });
    let silhouettes = stats.time("silhouettes", || {
        opaque_silhouettes(scene, center.as_dvec3(), 0.0)
    });
    stats.set("silhouette_edges", silhouettes.len() as f64);
    let (tested, sample_tests) = (AtomicU64::new(0), AtomicU64::new(0));
    stats.time("wedges", || {
        lists.visit_regions(
            &origins.bounds,
            opts.hull_degree,
            &silhouettes,
            |e| &e.ends,
            &mut occ,
            1,
            |edge, k, occ| {
                let Some(sweep) =
                    edge.wedge_sweep(origins.origins[k].as_dvec3(), center.as_dvec3())
                else {
                    return;
                };
                tested.fetch_add(1, Ordering::Relaxed);
                let (mut ys, mut ws) = (Vec::new(), Vec::new());
                fill(k, &mut ys, &mut ws);
                let (p, n) = origins.receiver(k);
                sample_tests.fetch_add(ys.len() as u64, Ordering::Relaxed);
                let (mut covered, mut front) = (0.0f64, 0.0f64);
                for (y, &w) in ys.iter().zip(&ws) {
                    if (*y - p).dot(n) > 0.0 {
                        front += f64::from(w);
                        if sweep.crosses(y.as_dvec3()) {
                            covered += f64::from(w);
                        }
                    }
                }
                if front > 0.0 {
                    occ[0].occlusion += f64::from(sweep.delta) * covered / front;
                }
            },
        )
    })?;
    stats.set("wedge_tests", tested.into_inner() as f64);
    stats.set("sample_tests", sample_tests.into_inner() as f64);
    Ok(occ)
}
