//! `dcs`: depth complexity sampling (Forest, Barthe and Paulin 2008), the exact object-based
//! framework of Forest et al. 2009, Soft Textured Shadow Volume (section 3.2), for opaque meshes.
//!
//! For each receiver, with shadow-ray origin `p' = p + epsilon n` (`docs/design.md` section 3), DCS
//! counts the faces between `p'` and every light sample, its *depth complexity*; a sample is
//! visible when its count is 0 (and it lies in front of the receiver's tangent plane):
//!
//! 1. **Reference sample**: the light's center `y0`. Its count is that of a hard shadow volume;
//!    here the faces the segment `p' → y0` meets are counted through the BVH.
//! 2. **Silhouette edges**: the edges that are silhouettes from some point of the light or some
//!    sample (the sphere about the center that holds both, [`crate::geometry::edges`]); no other
//!    edge changes a count.
//! 3. **Wedges**: each such edge updates the receivers inside its penumbra wedge, its influence
//!    region in the light-space receiver lists from the bounds of the light and its samples
//!    ([`crate::influence`]; the paper rasterizes the wedges in screen space). For a
//!    receiver the edge is a silhouette from, every sample `y` for which the edge crosses the
//!    triangle `(p', y0, y)` gets the edge's change in count ([`crate::geometry::edges::Sweep`]).
//! 4. **Samples past a face**: the sweeps carry `y0`'s count to `y` only if the segment `y0 → y`
//!    crosses no face, since the count also changes where the segment's far end passes through
//!    one, which no edge sees. Samples whose segment from `y0` crosses an opaque face (explicit
//!    samples between occluders or beyond a wall, a light that cuts into the scene) are counted
//!    through the BVH instead. Without an opaque face near enough to `y0` no sample is.
//!
//! Counts are exact integers, so the result equals `ray_traced`'s on the same samples up to
//! floating-point ties. Perforated meshes are left out here: `stsv` adds them.

use crate::error::Result;
use crate::geometry::bvh::Bvh;
use crate::geometry::edges::{edges_peak, opaque_silhouettes};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::influence::{ObjectOptions, Origins};
use crate::interrupt;
use crate::light::lights::Light;
use crate::light::sampling::{lit_fraction, plus_zero_sum, SampleSet};
use crate::limits::{self, object_work, Peak, Work};
use crate::raster::cube::by_light_face;
use crate::stats::Stats;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The memory of [`depth_complexity`] for `receivers` receivers and `samples` samples: the counts
/// and the silhouettes.
pub(crate) fn depth_complexity_peak(scene: &Scene, receivers: usize, samples: usize) -> Peak {
    Peak::default()
        .buffer(&[receivers as u64, samples as u64, 4])
        .and(edges_peak(scene))
}

/// Per origin and sample, the number of opaque faces between the origin and the sample (see the
/// module doc), in list order (`S` values per list entry); and the stats of the passes.
pub(crate) fn depth_complexity(
    scene: &Scene,
    bvh: &Bvh,
    origins: &Origins,
    opts: &ObjectOptions,
    stats: &mut Stats,
) -> Result<Vec<i32>> {
    let (light, samples) = (origins.light, origins.samples);
    let s = samples.count();
    let lists = &origins.lists;
    limits::check_memory(
        "dcs counters",
        limits::bytes(&[lists.entries.len() as u64, s as u64, 4]),
    )?;
    let center = light.center();
    let opaque = |f: u32| !scene.is_perforated_face(f);
    let mut counts = vec![0i32; lists.entries.len() * s];
    stats.time("reference", || {
        counts
            .par_chunks_mut(s)
            .zip(&lists.entries)
            .for_each(|(c, &k)| {
                let o = origins.origins[k as usize];
                c.fill(bvh.count_hits(o, center - o, 1.0, opaque) as i32);
            });
    });
    let radius = samples.bounding_radius(light);
    let silhouettes = stats.time("silhouettes", || {
        opaque_silhouettes(scene, center.as_dvec3(), radius)
    });
    stats.set("silhouette_edges", silhouettes.len() as f64);
    let (tested, sample_tests) = (AtomicU64::new(0), AtomicU64::new(0));
    stats.time("wedges", || {
        let shared = samples.is_shared().then(|| samples.pattern_for(0, 0));
        lists.visit_regions(
            &origins.bounds,
            opts.hull_degree,
            &silhouettes,
            |e| &e.ends,
            &mut counts,
            s,
            |edge, k, c| {
                let Some(sweep) = edge.sweep(origins.origins[k].as_dvec3(), center.as_dvec3())
                else {
                    return;
                };
                tested.fetch_add(1, Ordering::Relaxed);
                let mut own = (Vec::new(), Vec::new());
                let ys = match shared {
                    Some(ys) => ys,
                    None => {
                        origins.fill(k, &mut own.0, &mut own.1);
                        &own.0
                    }
                };
                sample_tests.fetch_add(c.len().min(ys.len()) as u64, Ordering::Relaxed);
                for (c, y) in c.iter_mut().zip(ys) {
                    if sweep.crosses(y.as_dvec3()) {
                        *c += sweep.delta;
                    }
                }
            },
        )?;
        recount_samples_past_faces(scene, bvh, origins, radius, &mut counts)
    })?;
    stats.set("wedge_tests", tested.into_inner() as f64);
    stats.set("sample_tests", sample_tests.into_inner() as f64);
    Ok(counts)
}

/// Counts through the BVH, for every origin, the samples whose segment from the light's center
/// crosses an opaque face (step 4 of the module doc), over the counts of the sweeps. Such a
/// segment lies within `radius` of the center, so only a face that comes that close can make
/// one: without one, nothing is recounted.
fn recount_samples_past_faces(
    scene: &Scene,
    bvh: &Bvh,
    origins: &Origins,
    radius: f64,
    counts: &mut [i32],
) -> Result<()> {
    let (center, samples) = (origins.light.center(), origins.samples);
    let opaque = |f: u32| !scene.is_perforated_face(f);
    if !opaque_face_within(scene, center.as_dvec3(), radius) {
        return Ok(());
    }
    let past_a_face = |y: Vec3| bvh.count_hits(center, y - center, 1.0, opaque) > 0;
    let shared: Option<Vec<bool>> = samples.is_shared().then(|| {
        samples
            .pattern_for(0, 0)
            .iter()
            .map(|&y| past_a_face(y))
            .collect()
    });
    let s = samples.count();
    interrupt::rounds(
        counts,
        interrupt::round_len(s, Work::RAY),
        |offset, part| {
            part.par_chunks_mut(s)
                .zip(&origins.lists.entries[offset / s..])
                .for_each_init(
                    || (Vec::new(), Vec::new()),
                    |(ys, ws), (c, &k)| {
                        origins.fill(k as usize, ys, ws);
                        let o = origins.origins[k as usize];
                        for (j, (c, &y)) in c.iter_mut().zip(ys.iter()).enumerate() {
                            if shared
                                .as_ref()
                                .map_or_else(|| past_a_face(y), |past| past[j])
                            {
                                *c = bvh.count_hits(o, y - o, 1.0, opaque) as i32;
                            }
                        }
                    },
                );
        },
    )
}

/// Whether the bounding box of some opaque face of `scene` comes within `radius` of `center`.
fn opaque_face_within(scene: &Scene, center: DVec3, radius: f64) -> bool {
    scene.triangles().any(|(id, t)| {
        let (lo, hi) = (
            t[0].min(t[1]).min(t[2]).as_dvec3(),
            t[0].max(t[1]).max(t[2]).as_dvec3(),
        );
        !scene.is_perforated_face(id) && (center.clamp(lo, hi) - center).length() <= radius
    })
}

/// The weighted fraction of each receiver's samples in front of its tangent plane whose count
/// is 0, scattered to the receivers' order.
pub(crate) fn visible_fraction(origins: &Origins, counts: &[i32]) -> Vec<f32> {
    let s = origins.samples.count();
    unblocked_fraction(origins, |e, k| counts[e * s + k] != 0)
}

/// The weighted fraction of each receiver's samples in front of its tangent plane that are not
/// `blocked(list entry, sample)`, scattered to the receivers' order.
pub(crate) fn unblocked_fraction(
    origins: &Origins,
    blocked: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<f32> {
    let lists = &origins.lists;
    let values: Vec<(usize, f32)> = lists
        .entries
        .par_iter()
        .enumerate()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(ys, ws), (e, &k)| {
                let (ys, ws) = origins.samples_of(k as usize, ys, ws);
                let i = origins.ids[k as usize] as usize;
                let (p, n) = origins.receiver(k as usize);
                let total: f64 = ws.iter().map(|&w| f64::from(w)).sum();
                let lit: f64 = ys
                    .iter()
                    .zip(ws.iter())
                    .enumerate()
                    .filter(|&(k, (y, _))| !blocked(e, k) && (*y - p).dot(n) > 0.0)
                    .map(|(_, (_, &w))| f64::from(w))
                    .fold(0.0, plus_zero_sum);
                (i, lit_fraction(lit, total))
            },
        )
        .collect();
    let mut vis = vec![0f32; origins.receivers.len()];
    for (i, v) in values {
        vis[i] = v;
    }
    vis
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "reference_seconds",
    "silhouettes_seconds",
    "wedges_seconds",
    "silhouette_edges",
    "wedge_tests",
    "sample_tests",
    "receivers",
    "light_samples",
    "light_faces",
];

/// Visibility of every receiver by depth complexity sampling (see the module doc), on the opaque
/// meshes of `scene` (perforated meshes are ignored). Returns the visibility (receivers' order)
/// and stats: `reference_seconds` (the counts to the light's center), `silhouettes_seconds`,
/// `wedges_seconds` (the per-sample updates), `silhouette_edges`, `wedge_tests` (receiver and
/// silhouette pairs updated), `sample_tests` (light samples tested against a wedge's sweep),
/// `receivers` (those facing the light), `light_samples`.
pub fn dcs(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &ObjectOptions,
) -> Result<(Vec<f32>, Stats)> {
    by_light_face(light, receivers, |part, _| {
        dcs_in_one_frustum(scene, bvh, light, part, samples, opts)
    })
}

/// [`dcs`] on receivers that one light frustum holds.
fn dcs_in_one_frustum(
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
        .and(depth_complexity_peak(scene, n, samples.count()))
        .check("dcs", &mut stats)?;
    object_work(scene, n, samples.count()).check("dcs", &mut stats)?;
    let Some(origins) = Origins::new(light, receivers, samples, opts)? else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    stats.set("receivers", origins.ids.len() as f64);
    let counts = depth_complexity(scene, bvh, &origins, opts, &mut stats)?;
    Ok((visible_fraction(&origins, &counts), stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::Mesh;
    use crate::light::sampling::{Pattern, Rng};
    use glam::Vec3;

    /// A ground quad, a soup of random open triangles (overlapping, three boundary edges each) and
    /// a closed octahedron, under a rect light at y = 4.
    fn scene() -> Scene {
        let ground =
            [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
        let ground = Mesh::new(
            ground.to_vec(),
            vec![[0, 2, 1], [0, 3, 2]],
            None,
            None,
            false,
        )
        .unwrap();
        let mut rng = Rng::new(5);
        let mut pos = Vec::new();
        for _ in 0..120 {
            let c = Vec3::new(
                3.0 * rng.next_f32() - 1.5,
                0.6 + 1.5 * rng.next_f32(),
                3.0 * rng.next_f32() - 1.5,
            );
            pos.extend((0..3).map(|_| {
                c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.8
            }));
        }
        let faces = (0..120u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let soup = Mesh::new(pos, faces, None, None, false).unwrap();
        let c = Vec3::new(0.4, 1.2, -0.3);
        let octa = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
            .map(|d| c + d * 0.5)
            .to_vec();
        let of = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        Scene::new(vec![
            ground,
            soup,
            Mesh::new(octa, of, None, None, true).unwrap(),
        ])
        .unwrap()
    }

    #[test]
    fn every_count_is_the_number_of_faces_on_the_segment() {
        let scene = scene();
        let bvh = Bvh::build(&scene).unwrap();
        let light = Light::rect(
            Vec3::new(0.2, 4.0, 0.1),
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.9),
        )
        .unwrap();
        let (w, h) = (24, 24);
        let points = (0..w * h)
            .map(|i| {
                Vec3::new(
                    -2.5 + 5.0 * (i % w) as f32 / w as f32,
                    0.0,
                    -2.5 + 5.0 * (i / w) as f32 / h as f32,
                )
            })
            .collect();
        let receivers =
            Receivers::new(points, vec![Vec3::Y; w * h], vec![true; w * h], w, h).unwrap();
        let samples = SampleSet::generate(&light, 32, Pattern::Poisson, 2, 1, true, 0).unwrap();
        let opts = ObjectOptions {
            epsilon: 1e-4,
            resolution: 64,
            hull_degree: 6,
        };
        let origins = Origins::new(&light, &receivers, &samples, &opts)
            .unwrap()
            .unwrap();
        let counts =
            depth_complexity(&scene, &bvh, &origins, &opts, &mut Stats::default()).unwrap();
        let (mut ys, mut ws, mut deep) = (Vec::new(), Vec::new(), 0);
        for (e, &k) in origins.lists.entries.iter().enumerate() {
            origins.fill(k as usize, &mut ys, &mut ws);
            let o = origins.origins[k as usize];
            for (s, y) in ys.iter().enumerate() {
                let expected = bvh.count_hits(o, *y - o, 1.0, |_| true) as i32;
                assert_eq!(counts[e * 32 + s], expected, "receiver {k}, sample {s}");
                deep += usize::from(expected >= 2);
            }
        }
        assert!(
            deep > 100,
            "the soup must stack occluders: {deep} samples behind two or more faces"
        );
    }

    /// Per list entry and sample, whether the count is the number of faces on the segment; and
    /// how many samples a segment from the light's center to them crosses a face for.
    fn counts_match_the_segments(
        light: &Light,
        samples: &SampleSet,
    ) -> crate::error::Result<usize> {
        let scene = scene();
        let bvh = Bvh::build(&scene)?;
        let (w, h) = (24, 24);
        let points = (0..w * h)
            .map(|i| {
                Vec3::new(
                    -2.5 + 5.0 * (i % w) as f32 / w as f32,
                    0.0,
                    -2.5 + 5.0 * (i / w) as f32 / h as f32,
                )
            })
            .collect();
        let receivers = Receivers::new(points, vec![Vec3::Y; w * h], vec![true; w * h], w, h)?;
        let opts = ObjectOptions {
            epsilon: 1e-4,
            resolution: 64,
            hull_degree: 6,
        };
        let Some(origins) = Origins::new(light, &receivers, samples, &opts)? else {
            return Err(crate::error::Error::invalid(
                "receivers",
                "none faces the light or a sample",
            ));
        };
        let counts = depth_complexity(&scene, &bvh, &origins, &opts, &mut Stats::default())?;
        let (mut ys, mut ws, s) = (Vec::new(), Vec::new(), samples.count());
        let mut past = std::collections::HashSet::new();
        for (e, &k) in origins.lists.entries.iter().enumerate() {
            origins.fill(k as usize, &mut ys, &mut ws);
            let o = origins.origins[k as usize];
            for (j, y) in ys.iter().enumerate() {
                let expected = bvh.count_hits(o, *y - o, 1.0, |_| true) as i32;
                assert_eq!(
                    counts[e * s + j],
                    expected,
                    "receiver {k}, sample {j} at {y}"
                );
                if bvh.count_hits(light.center(), *y - light.center(), 1.0, |_| true) > 0 {
                    past.insert(y.to_array().map(f32::to_bits));
                }
            }
        }
        Ok(past.len())
    }

    #[test]
    fn counts_hold_for_samples_off_the_light() -> crate::error::Result<()> {
        // Samples of a light twice as large, pushed back, among the soup and below the ground:
        // the wedges' regions bound the samples, and samples whose segment from the center
        // crosses a face are counted directly (no edge sweep sees their end pass a face).
        let light = Light::rect(
            Vec3::new(0.2, 4.0, 0.1),
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.9),
        )?;
        let on: Vec<Vec3> = SampleSet::generate(&light, 16, Pattern::Poisson, 2, 1, false, 0)?
            .pattern_for(0, 0)
            .to_vec();
        let c = light.center();
        let shifted = |by: Vec3| on.iter().map(|&y| y + by).collect::<Vec<_>>();
        let twice = on.iter().map(|&y| c + (y - c) * 2.0).collect::<Vec<_>>();
        let mixed = [
            shifted(Vec3::Y * -2.8),
            shifted(Vec3::Y * -5.0),
            shifted(Vec3::Y * 2.0),
        ]
        .concat();
        assert_eq!(
            counts_match_the_segments(&light, &SampleSet::explicit(twice.clone(), None)?)?,
            0
        );
        assert!(
            counts_match_the_segments(&light, &SampleSet::explicit(mixed.clone(), None)?)? > 8,
            "samples must lie past faces"
        );
        let disk = Light::disk(c, -Vec3::Y, 0.9)?;
        assert!(
            counts_match_the_segments(
                &disk,
                &SampleSet::explicit([twice, mixed].concat(), Some(3))?
            )? > 8
        );
        Ok(())
    }
}
