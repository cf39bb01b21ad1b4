//! `dcs`: depth complexity sampling (Forest, Barthe and Paulin 2008), the exact object-based
//! framework of seed 001 (section 3.2) for opaque meshes.
//!
//! For each receiver, with shadow-ray origin `p' = p + epsilon n` (DESIGN.md section 3), DCS
//! counts the faces between `p'` and every light sample, its *depth complexity*; a sample is
//! visible when its count is 0 (and it lies in front of the receiver's tangent plane):
//!
//! 1. **Reference sample**: the light's center `y0`. Its count is that of a hard shadow volume;
//!    here the faces the segment `p' → y0` meets are counted through the BVH.
//! 2. **Silhouette edges**: the edges that are silhouettes from some point of the light (its
//!    bounding sphere, [`crate::geometry::edges`]); no other edge changes a count.
//! 3. **Wedges**: each such edge updates the receivers inside its penumbra wedge, its influence
//!    region in the light-space receiver lists ([`crate::raster::influence`]; the paper rasterizes
//!    the wedges in screen space). For a receiver the edge is a silhouette from, every sample `y`
//!    for which the edge crosses the triangle `(p', y0, y)` gets the edge's change in count
//!    ([`crate::geometry::edges::Sweep`]).
//!
//! Counts are exact integers, so the result equals `ray_traced`'s on the same samples up to
//! floating-point ties. Perforated meshes are left out here: `stsv` adds them.

use crate::error::Result;
use crate::geometry::bvh::Bvh;
use crate::geometry::edges::{edges_peak, opaque_silhouettes};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::light::lights::Light;
use crate::light::sampling::SampleSet;
use crate::limits::{self, Peak};
use crate::raster::influence::{ObjectOptions, Origins};
use crate::stats::Stats;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The memory of [`depth_complexity`] for `receivers` receivers and `samples` samples: the counts
/// and the silhouettes.
pub(crate) fn depth_complexity_peak(scene: &Scene, receivers: usize, samples: usize) -> Peak {
    Peak::default().buffer(&[receivers as u64, samples as u64, 4]).and(edges_peak(scene))
}

/// Per origin and sample, the number of opaque faces between the origin and the sample (see the
/// module doc), in list order (`S` values per list entry); and the stats of the passes.
pub(crate) fn depth_complexity(scene: &Scene, bvh: &Bvh, origins: &Origins, opts: &ObjectOptions, stats: &mut Stats) -> Result<Vec<i32>> {
    let (light, samples) = (origins.light, origins.samples);
    let s = samples.count();
    let lists = &origins.lists;
    limits::check_memory("dcs counters", limits::bytes(&[lists.entries.len() as u64, s as u64, 4]))?;
    let center = light.center();
    let opaque = |f: u32| !scene.is_perforated_face(f);
    let mut counts = vec![0i32; lists.entries.len() * s];
    stats.time("reference", || {
        counts.par_chunks_mut(s).zip(&lists.entries).for_each(|(c, &k)| {
            let o = origins.origins[k as usize];
            c.fill(bvh.count_hits(o, center - o, 1.0, opaque) as i32);
        });
    });
    let radius = samples.bounding_radius(light);
    let silhouettes = stats.time("silhouettes", || opaque_silhouettes(scene, center.as_dvec3(), radius));
    stats.set("silhouette_edges", silhouettes.len() as f64);
    let tested = AtomicU64::new(0);
    stats.time("wedges", || {
        let shared = samples.is_shared().then(|| samples.pattern_for(0, 0));
        lists.visit_regions(light, opts.hull_degree, &silhouettes, |e| &e.ends, &mut counts, s, |edge, k, c| {
            let Some(sweep) = edge.sweep(origins.origins[k].as_dvec3(), center.as_dvec3()) else { return };
            tested.fetch_add(1, Ordering::Relaxed);
            let mut own = (Vec::new(), Vec::new());
            let ys = match shared {
                Some(ys) => ys,
                None => {
                    origins.fill(k, &mut own.0, &mut own.1);
                    &own.0
                }
            };
            for (c, y) in c.iter_mut().zip(ys) {
                if sweep.crosses(y.as_dvec3()) {
                    *c += sweep.delta;
                }
            }
        });
    });
    stats.set("wedge_tests", tested.into_inner() as f64);
    Ok(counts)
}

/// The weighted fraction of each receiver's samples in front of its tangent plane whose count
/// is 0, scattered to the receivers' order.
pub(crate) fn visible_fraction(origins: &Origins, counts: &[i32]) -> Vec<f32> {
    let s = origins.samples.count();
    let lists = &origins.lists;
    let values: Vec<(usize, f32)> = lists
        .entries
        .par_iter()
        .enumerate()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(ys, ws), (e, &k)| {
                origins.fill(k as usize, ys, ws);
                let i = origins.ids[k as usize] as usize;
                let (p, n) = origins.receiver(k as usize);
                let total: f64 = ws.iter().map(|&w| f64::from(w)).sum();
                let lit: f64 = ys
                    .iter()
                    .zip(ws.iter())
                    .zip(&counts[e * s..(e + 1) * s])
                    .filter(|((y, _), &c)| c == 0 && (**y - p).dot(n) > 0.0)
                    .map(|((_, &w), _)| f64::from(w))
                    .sum();
                (i, if total > 0.0 { (lit / total).clamp(0.0, 1.0) as f32 } else { 0.0 })
            },
        )
        .collect();
    let mut vis = vec![0f32; origins.receivers.len()];
    for (i, v) in values {
        vis[i] = v;
    }
    vis
}

/// Visibility of every receiver by depth complexity sampling (see the module doc), on the opaque
/// meshes of `scene` (perforated meshes are ignored). Returns the visibility (receivers' order)
/// and stats: `reference_seconds` (the counts to the light's center), `silhouettes_seconds`,
/// `wedges_seconds` (the per-sample updates), `silhouette_edges`, `wedge_tests` (receiver and
/// silhouette pairs updated), `receivers` (those facing the light), `light_samples`.
pub fn dcs(scene: &Scene, bvh: &Bvh, light: &Light, receivers: &Receivers, samples: &SampleSet, opts: &ObjectOptions) -> Result<(Vec<f32>, Stats)> {
    opts.validate(scene, receivers)?;
    bvh.check_scene(scene)?;
    let mut stats = Stats::default();
    for name in ["reference_seconds", "silhouettes_seconds", "wedges_seconds", "silhouette_edges", "wedge_tests", "receivers"] {
        stats.set(name, 0.0);
    }
    stats.set("light_samples", samples.count() as f64);
    let n = receivers.len();
    Peak::default()
        .buffer(&[n as u64, 4])
        .and(Origins::peak(n, opts))
        .and(depth_complexity_peak(scene, n, samples.count()))
        .check("dcs", &mut stats)?;
    let Some(origins) = Origins::new(light, receivers, samples, opts)? else { return Ok((vec![0.0; receivers.len()], stats)) };
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
        let ground = [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
        let ground = Mesh::new(ground.to_vec(), vec![[0, 2, 1], [0, 3, 2]], None, None, false).unwrap();
        let mut rng = Rng::new(5);
        let mut pos = Vec::new();
        for _ in 0..120 {
            let c = Vec3::new(3.0 * rng.next_f32() - 1.5, 0.6 + 1.5 * rng.next_f32(), 3.0 * rng.next_f32() - 1.5);
            pos.extend((0..3).map(|_| c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.8));
        }
        let faces = (0..120u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let soup = Mesh::new(pos, faces, None, None, false).unwrap();
        let c = Vec3::new(0.4, 1.2, -0.3);
        let octa = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z].map(|d| c + d * 0.5).to_vec();
        let of = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        Scene::new(vec![ground, soup, Mesh::new(octa, of, None, None, true).unwrap()]).unwrap()
    }

    #[test]
    fn every_count_is_the_number_of_faces_on_the_segment() {
        let scene = scene();
        let bvh = Bvh::build(&scene).unwrap();
        let light = Light::rect(Vec3::new(0.2, 4.0, 0.1), Vec3::new(0.9, 0.0, 0.0), Vec3::new(0.0, 0.0, -0.9)).unwrap();
        let (w, h) = (24, 24);
        let points = (0..w * h).map(|i| Vec3::new(-2.5 + 5.0 * (i % w) as f32 / w as f32, 0.0, -2.5 + 5.0 * (i / w) as f32 / h as f32)).collect();
        let receivers = Receivers::new(points, vec![Vec3::Y; w * h], vec![true; w * h], w, h).unwrap();
        let samples = SampleSet::generate(&light, 32, Pattern::Poisson, 2, 1, true, 0).unwrap();
        let opts = ObjectOptions { epsilon: 1e-4, resolution: 64, hull_degree: 6 };
        let origins = Origins::new(&light, &receivers, &samples, &opts).unwrap().unwrap();
        let counts = depth_complexity(&scene, &bvh, &origins, &opts, &mut Stats::default()).unwrap();
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
        assert!(deep > 100, "the soup must stack occluders: {deep} samples behind two or more faces");
    }
}
