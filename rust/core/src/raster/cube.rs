//! A light among the geometry: the six faces of a cube around it, one light frustum each.
//!
//! When no single frustum from the light's center holds the receivers' bounding box
//! ([`LightFrustum::fit`] fails: a lamp in a room, a low light beside a statue), every receiver
//! is served by the cube face its direction from the light falls in, as Sintorn et al. 2008
//! (section 5) cover an omni-directional light with six maps and as point-light shadow maps have
//! long been rendered into cube maps. [`by_light_face`] runs a method once per face on the
//! receivers of that face and merges their results receiver by receiver:
//!
//! - the object-based methods (`alias_free`, `dcs`, `stsv`, `penumbra_wedge`) fit their own
//!   frustum to the face's receivers ([`enclosing_face`]); their results are exact whatever
//!   frustum serves a receiver;
//! - the image-based methods that filter one map from the light's center (`shadow_map`, `pcss`,
//!   `cssm`, `backprojection`) render the face's map through [`face_frustum`], a cube face
//!   widened by [`SEAM_OVERLAP`] on every side, so that a receiver near a seam finds the texels
//!   its filter reads across the seam in its own face's map.
//!
//! `mvr` renders a cube around every light sample instead ([`face_of`] from each sample), since
//! a receiver near the light can lie on different sides of different samples.
//!
//! Every face that holds receivers is rendered, one-sided lights too: visibility does not depend
//! on the side a light emits to (`docs/design.md` section 3), and a receiver behind a one-sided
//! light still sees its samples.

use crate::error::Result;
use crate::geometry::receivers::Receivers;
use crate::light::lights::Light;
use crate::raster::frustum::{LightFrustum, MAX_FIT_TAN, NEAR_FRACTION};
use crate::stats::Stats;
use glam::Vec3;

/// The view directions of the faces of a cube around the light (world axes, each with an up
/// axis across it).
pub const FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// The methods that handle a light among the receivers, for error messages.
pub const METHODS: &str =
    "ray_traced, alias_free, stsv, dcs, penumbra_wedge, shadow_map, pcss, cssm, \
                           backprojection and mvr";

/// How far an image-based method's face map reaches past the face's own 90°, as a fraction of
/// the tangent of its half field of view: a filter reading up to 1/16 of the map's side across
/// a seam finds stored depths there; taps farther out read an empty texel (lit).
pub const SEAM_OVERLAP: f32 = 0.125;

/// The cube face whose direction is nearest that from `eye` to `p` (the first of equals).
pub fn face_of(eye: Vec3, p: Vec3) -> usize {
    let d = p - eye;
    (0..FACES.len()).fold(0, |best, k| {
        if d.dot(FACES[k].0) > d.dot(FACES[best].0) {
            k
        } else {
            best
        }
    })
}

/// A frustum from `eye` along the cube face direction that keeps every point of `points` at the
/// largest angle from its sides (a placeholder field of view and depth range, for the
/// object-based methods to fit to the points); `None` when that leaves some point within 0.06°
/// of its side plane or behind it, the limit of [`LightFrustum::fit`].
pub fn enclosing_face(eye: Vec3, points: &[Vec3], resolution: usize) -> Option<LightFrustum> {
    let least_cosine = |axis: Vec3| {
        points
            .iter()
            .map(|&p| (p - eye).normalize_or_zero().dot(axis))
            .fold(f32::INFINITY, f32::min)
    };
    let (cosine, (forward, up)) = FACES
        .iter()
        .map(|&f| (least_cosine(f.0), f))
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    let min_cosine = 1.0 / (1.0 + MAX_FIT_TAN * MAX_FIT_TAN).sqrt();
    (cosine > min_cosine)
        .then(|| {
            LightFrustum::from_axes(eye, forward, up, 1.0, 1.0, 1.0, 2.0, resolution, resolution)
                .ok()
        })
        .flatten()
}

/// The map frustum of cube face `face` around `eye` for `points` (the receivers whose direction
/// falls in it): `resolution²` texels over the face widened by [`SEAM_OVERLAP`], the near plane
/// at [`NEAR_FRACTION`] of the nearest point's depth and the far plane just beyond the
/// farthest, as [`LightFrustum::fit`] places them.
pub fn face_frustum(
    eye: Vec3,
    face: usize,
    points: impl IntoIterator<Item = Vec3>,
    resolution: usize,
) -> Result<LightFrustum> {
    let (forward, up) = FACES[face];
    let (z0, z1) = points
        .into_iter()
        .map(|p| (p - eye).dot(forward))
        .fold((f32::INFINITY, 0.0f32), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        });
    // A receiver at the eye itself has depth 0; the others still need a near plane in front.
    let z0 = z0.max(1e-6 * z1).max(f32::MIN_POSITIVE);
    let near = NEAR_FRACTION * z0;
    let far = (z1 * 1.001).max(near * 2.0);
    let tan = 1.0 + SEAM_OVERLAP;
    LightFrustum::from_axes(
        eye, forward, up, tan, tan, near, far, resolution, resolution,
    )
}

/// The map frustum of the methods that filter over a rectangular light's footprint (`pcss`,
/// `cssm`, `backprojection`) for the valid receivers of `part`, whose bounds are `bounds`:
/// cube face `face`'s ([`face_frustum`]), or with no face one fitted with its axes along the
/// light's edges ([`LightFrustum::for_light_aligned`]).
pub fn footprint_frustum(
    light: &Light,
    part: &Receivers,
    face: Option<usize>,
    bounds: (Vec3, Vec3),
    resolution: usize,
) -> Result<LightFrustum> {
    match face {
        Some(face) => face_frustum(light.center(), face, part.valid_points(), resolution),
        None => LightFrustum::for_light_aligned(light, bounds, resolution),
    }
}

/// For each receiver, the cube face around the light its direction falls in, when no single
/// light frustum holds the valid receivers' bounding box ([`LightFrustum::fit`]); `None` when
/// one does.
pub fn light_faces(light: &Light, receivers: &Receivers) -> Option<Vec<u8>> {
    let c = light.center();
    let (lo, hi) = receivers.bounds()?;
    LightFrustum::fit(c, lo, hi, 1)
        .is_err()
        .then(|| points_faces(c, receivers))
}

/// The light frusta the single-view image-based methods render for `receivers`: one fitted to
/// their bounds ([`LightFrustum::for_light`]), or one per cube face holding receivers when the
/// light lies among them; none without valid receivers.
pub fn light_frusta(
    light: &Light,
    receivers: &Receivers,
    resolution: usize,
) -> Result<Vec<LightFrustum>> {
    let Some(faces) = light_faces(light, receivers) else {
        return receivers
            .bounds()
            .map(|bounds| LightFrustum::for_light(light, bounds, resolution))
            .into_iter()
            .collect();
    };
    (0..FACES.len())
        .filter_map(|face| face_part(receivers, &faces, face).map(|part| (face, part)))
        .map(|(face, part)| face_frustum(light.center(), face, part.valid_points(), resolution))
        .collect()
}

/// For each receiver, the cube face around `eye` its direction falls in.
pub fn points_faces(eye: Vec3, receivers: &Receivers) -> Vec<u8> {
    receivers
        .points
        .iter()
        .map(|&p| face_of(eye, p) as u8)
        .collect()
}

/// `receivers` with only the valid ones whose face in `faces` is `face` left valid; `None` when
/// none is.
pub fn face_part(receivers: &Receivers, faces: &[u8], face: usize) -> Option<Receivers> {
    let valid: Vec<bool> = receivers
        .valid
        .iter()
        .zip(faces)
        .map(|(&v, &f)| v && usize::from(f) == face)
        .collect();
    valid.contains(&true).then(|| Receivers {
        valid,
        ..receivers.clone()
    })
}

/// Runs a method (`run`, on the receivers it is given and the cube face serving them) once per
/// light frustum: once, with no face, when one frustum holds the receivers; else once per face
/// of a cube around the light, on the receivers whose direction falls in it (the others
/// invalid). The faces' results merge receiver by receiver. Stats: the faces' seconds and
/// per-receiver counts added, other values the largest face's, and `light_faces`, the number of
/// frusta.
pub(crate) fn by_light_face(
    light: &Light,
    receivers: &Receivers,
    mut run: impl FnMut(&Receivers, Option<usize>) -> Result<(Vec<f32>, Stats)>,
) -> Result<(Vec<f32>, Stats)> {
    let Some(faces) = light_faces(light, receivers) else {
        let (vis, mut stats) = run(receivers, None)?;
        stats.set("light_faces", 1.0);
        return Ok((vis, stats));
    };
    let mut vis = vec![0.0f32; receivers.len()];
    let mut stats = Stats::default();
    let mut used = 0;
    for face in 0..FACES.len() {
        let Some(part) = face_part(receivers, &faces, face) else {
            continue;
        };
        let (face_vis, face_stats) = run(&part, Some(face))?;
        for (i, _) in part.valid.iter().enumerate().filter(|(_, &v)| v) {
            vis[i] = face_vis[i];
        }
        merge_face_stats(&mut stats, &face_stats);
        used += 1;
    }
    stats.set("light_faces", f64::from(used));
    Ok((vis, stats))
}

/// The stats that count work per receiver or per map: added over the faces.
const ADDED_STATS: [&str; 19] = [
    "receivers",
    "pair_tests",
    "plane_mask_ops",
    "sample_tests",
    "sample_projections",
    "processed",
    "backprojected",
    "search_taps",
    "filter_taps",
    "taps",
    "point_warps",
    "view_samples",
    "exact_view_samples",
    "inside_view_samples",
    "wedge_tests",
    "receivers_tested",
    "receivers_inside",
    "fragments",
    "texels_drawn",
];

/// Merges a face's stats into `total` (see [`by_light_face`]).
pub fn merge_face_stats(total: &mut Stats, face: &Stats) {
    for (name, value) in &face.entries {
        if name.ends_with("_seconds") || ADDED_STATS.contains(&name.as_str()) {
            total.add(name, *value);
        } else {
            total.set(name, total.get(name).map_or(*value, |t| t.max(*value)));
        }
    }
}
