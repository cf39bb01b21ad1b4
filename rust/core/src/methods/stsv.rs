//! `stsv`: soft textured shadow volumes (Forest, Barthe, Guennebaud and Paulin 2009,
//! Soft Textured Shadow Volume)
//! for perforated triangles, combined with an object-based method for the opaque meshes.
//!
//! For each perforated triangle `t` and each receiver inside its volume, every light sample is
//! projected through the receiver onto `t`'s plane and looked up in the alpha texture (Algorithm 1):
//!
//! 1. **Volume** (section 2.2): the front cap `t'` is `t` with its vertices moved towards the
//!    light's center until all are as far from it as the nearest; each edge of `t'` extrudes the
//!    outer quad of its penumbra wedge, the plane through the edge that touches the light with
//!    the whole light outside; adjacent outer planes meet along the closing lines (the cross
//!    product of their normals) through the shared vertex, extruded to the back cap, parallel to
//!    `t'` beyond the bounds of the scene and the receivers, which closes the volume ([`stsv_volumes`] returns these
//!    closed volumes). The light is bounded by a polygon or polytope ([`light_polytope`](crate::influence::light_polytope)): its
//!    corners for a rectangle, a circumscribed `hull_degree`-gon for a disk, the circumscribed box
//!    for spheres and ellipsoids; with samples off the light, one that holds them too
//!    ([`LightBounds::polytope`]), so that the volume holds every receiver they shadow.
//! 2. **Points in the volume** (section 2.3): a receiver is inside when it lies on the inner side
//!    of the four planes, the front cap and the three outer planes (the back cap only serves the
//!    paper's z-fail rasterization). Receivers are found through the triangle's influence region in the
//!    light-space lists (the paper rasterizes the volume in screen space).
//! 3. **Transmittance** (section 2.4, equations 1–5): per triangle `M'` (world to triangle
//!    space) and `S` (barycentric to texture space); per receiver `J = W M'` with `p` as the
//!    projective center; per sample `s_h = J (y − p)` gives homogeneous barycentrics, tested
//!    inside the triangle and beyond its plane, and `S s_h` the texture coordinates of the
//!    alpha lookup. An opaque texel blocks the sample.
//!
//! A one-sided volume is built on the side of `t` that holds the light's center; with
//! `two_sided`, a second one on the other side, for the part of the light behind `t`'s plane
//! (section 6: otherwise that part is never blocked by `t`). The opaque meshes go through
//! `Opaque::Bitmask` (`alias_free`'s exact bitmasks, OR-ed with the STSV masks), `Opaque::Dcs`
//! (each blocked sample adds one to its depth complexity) or `Opaque::PenumbraWedge` (the
//! STSV's occluded fraction is added to the wedges' visibility coefficient: approximate, the
//! overlaps of opaque and perforated occluders count twice, Forest et al. 2009, Figure 4a).

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::{AlphaTexture, Scene};
use crate::geometry::polygon::clip_to_side;
use crate::geometry::receivers::Receivers;
use crate::influence::{check_hull_degree, LightBounds, ObjectOptions, Origins};
use crate::light::lights::Light;
use crate::light::sampling::SampleSet;
use crate::limits::{self, object_work, Peak};
use crate::methods::alias_free::{masks_peak, sample_masks, AliasFreeOptions, TableSize};
use crate::methods::dcs::{depth_complexity, depth_complexity_peak, visible_fraction};
use crate::methods::penumbra_wedge::{wedge_occlusion, wedge_occlusion_peak};
use crate::methods::CasterFaces;
use crate::raster::cube::by_light_face;
use crate::stats::Stats;
use glam::{DMat3, DVec2, DVec3, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};

/// How the opaque meshes cast (Forest et al. 2009, section 3 and Algorithm 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Opaque {
    /// `alias_free`'s exact sample bitmasks, OR-ed with the STSV masks.
    Bitmask,
    /// Depth complexity sampling; blocked perforated samples add one to the count.
    Dcs,
    /// Penumbra wedges; the STSV's occluded fraction is added to the visibility coefficient.
    PenumbraWedge,
}

/// Options of [`stsv`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StsvOptions {
    pub object: ObjectOptions,
    pub opaque: Opaque,
    /// Extrude a volume on each side of every perforated triangle (section 6).
    pub two_sided: bool,
}

/// One soft textured shadow volume.
struct Volume {
    face: u32,
    /// The triangle's vertices (for its influence region).
    triangle: [Vec3; 3],
    /// Inside: `m · x >= k` for the front cap and the three outer planes (a plane is left out
    /// where the light reaches past it: conservative).
    planes: Vec<(DVec3, f64)>,
    /// The closed volume's corners: the front cap t', then the back cap.
    corners: [DVec3; 6],
    /// `M'` of equation 2, `S` of equation 4, the triangle's first vertex.
    to_triangle: DMat3,
    to_texture: DMat3,
    v0: DVec3,
}

/// The plane through the line `a b` that touches `light` with every light point outside and `c`
/// inside, as `(m, k)` with inside `m · x >= k`; `None` when no plane through the line separates
/// them (the line passes through the light's hull).
fn outer_plane(
    a: DVec3,
    b: DVec3,
    c: DVec3,
    light: &[DVec3],
    toward_light: DVec3,
) -> Option<(DVec3, f64)> {
    let d = (b - a).normalize();
    let u = ((c - a) - d * (c - a).dot(d)).normalize();
    let w = d.cross(u) * d.cross(u).dot(toward_light).signum();
    let angles: Vec<f64> = light
        .iter()
        .map(|q| (*q - a).dot(w).atan2((*q - a).dot(u)))
        .collect();
    let (lo, hi) = angles
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    // Every light point at an angle in [lo, lo + pi) about the line, measured from c's direction
    // towards the light's side: then c, at angle 0, is inside.
    if !(lo >= 0.0 && hi - lo < std::f64::consts::PI) {
        return None;
    }
    let m = u * lo.sin() - w * lo.cos();
    Some((m, m.dot(a)))
}

/// The eight corners of the box `(lo, hi)`.
fn box_corners((lo, hi): (DVec3, DVec3)) -> [DVec3; 8] {
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Distance along `dir` from `o` (inside or on the box) to where it leaves the box `(lo, hi)`.
fn exit_distance(o: DVec3, dir: DVec3, (lo, hi): (DVec3, DVec3)) -> f64 {
    (0..3)
        .filter(|&i| dir[i] != 0.0)
        .map(|i| ((if dir[i] > 0.0 { hi[i] } else { lo[i] }) - o[i]) / dir[i])
        .fold(f64::INFINITY, f64::min)
        .max(0.0)
}

impl Volume {
    /// The volume of triangle `tri` (face `face`, texture coordinates `uv`) for the part `light` of
    /// the light's polytope on one side of it, seen from `center`; `None` for a degenerate triangle.
    fn build(
        face: u32,
        tri: [Vec3; 3],
        uv: [DVec2; 3],
        light: &[DVec3],
        center: DVec3,
        bounds: (DVec3, DVec3),
    ) -> Option<Volume> {
        let v = tri.map(|p| p.as_dvec3());
        let normal = (v[1] - v[0]).cross(v[2] - v[0]);
        let dist = v.map(|p| (p - center).length());
        if normal.length_squared() == 0.0 || dist.contains(&0.0) {
            return None;
        }
        // The front cap t': every vertex as near to the center as the nearest one.
        let nearest = dist.iter().copied().fold(f64::INFINITY, f64::min);
        let front = [0, 1, 2].map(|i| center + (v[i] - center) * (nearest / dist[i]));
        let cap = (front[1] - front[0]).cross(front[2] - front[0]);
        if cap.length_squared() == 0.0 {
            return None;
        }
        let toward_light = cap * cap.dot(center - front[0]).signum();
        let mut planes = Vec::with_capacity(4);
        // The front cap bounds the volume only when the whole light lies in front of it.
        if light.iter().all(|q| toward_light.dot(*q - front[0]) > 0.0) {
            planes.push((-toward_light, -toward_light.dot(front[0])));
        }
        let outer: Vec<Option<(DVec3, f64)>> = (0..3)
            .map(|k| {
                outer_plane(
                    front[k],
                    front[(k + 1) % 3],
                    front[(k + 2) % 3],
                    light,
                    toward_light,
                )
            })
            .collect();
        planes.extend(outer.iter().flatten());
        // The closing lines through each vertex of t', extruded to the back cap: the plane
        // parallel to t' through the bounds' corner farthest from the light, so that the closed
        // volume holds every point of the bounds on the inner side of the planes.
        let away = -toward_light.normalize();
        let far = box_corners(bounds)
            .iter()
            .chain(&front)
            .map(|c| away.dot(*c))
            .fold(f64::NEG_INFINITY, f64::max);
        let back = [0, 1, 2].map(|k| {
            let dir = match (outer[(k + 2) % 3], outer[k]) {
                (Some((m1, _)), Some((m2, _))) if m1.cross(m2).length_squared() > 0.0 => {
                    m1.cross(m2)
                }
                _ => front[k] - center,
            };
            let dir = (dir * dir.dot(front[k] - center).signum()).normalize();
            let along = away.dot(dir);
            // A closing line (nearly) parallel to the cap never reaches the plane: it ends where
            // it leaves the bounds.
            let length = if along > 1e-6 {
                (far - away.dot(front[k])) / along
            } else {
                exit_distance(front[k], dir, bounds)
            };
            front[k] + dir * length
        });
        let n = normal.normalize();
        let to_triangle = DMat3::from_cols(v[1] - v[0], v[2] - v[0], -n).inverse();
        let (t01, t02) = (uv[1] - uv[0], uv[2] - uv[0]);
        let to_texture = DMat3::from_cols(
            DVec3::new(t01.x, t01.y, 0.0),
            DVec3::new(t02.x, t02.y, 0.0),
            DVec3::new(uv[0].x, uv[0].y, 1.0),
        );
        let corners = [front[0], front[1], front[2], back[0], back[1], back[2]];
        Some(Volume {
            face,
            triangle: tri,
            planes,
            corners,
            to_triangle,
            to_texture,
            v0: v[0],
        })
    }

    /// Whether `p` lies inside (section 2.3), with a relative tolerance that keeps the test
    /// conservative against round-off.
    fn contains(&self, p: DVec3) -> bool {
        self.planes
            .iter()
            .all(|(m, k)| m.dot(p) - k >= -1e-9 * m.length() * (1.0 + p.abs().max_element()))
    }

    /// Sets in `blocked` the samples `ys` that the triangle's opaque texels hide from `p`
    /// (equations 1–5); returns how many samples it projected.
    fn block(&self, p: DVec3, ys: &[Vec3], texture: &AlphaTexture, blocked: &mut [u64]) -> usize {
        let r = self.to_triangle * (self.v0 - p);
        let e = r.z;
        if e == 0.0 {
            return 0;
        }
        // W of equation 3: p as the projective center; the third row scales by the distance so
        // that s_h.z = 1 / t for the segment parameter t of the plane's crossing.
        let w = DMat3::from_cols(
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-r.x / e, -r.y / e, 1.0 / e),
        );
        let j = w * self.to_triangle;
        for (k, y) in ys.iter().enumerate().take(blocked.len() * 64) {
            let s = j * (y.as_dvec3() - p);
            if !(s.z > 1.0 && s.x >= 0.0 && s.y >= 0.0 && s.x + s.y <= s.z) {
                continue;
            }
            let st = self.to_texture * s;
            let uv = glam::Vec2::new((st.x / st.z) as f32, (st.y / st.z) as f32);
            if texture.is_opaque(uv) {
                blocked[k / 64] |= 1 << (k % 64);
            }
        }
        ys.len().min(blocked.len() * 64)
    }
}

/// The volumes of every perforated triangle of `scene` (two per triangle with `two_sided` when
/// the light or its samples reach both sides) for the light and samples of `light`, within
/// `bounds`.
fn volumes(
    scene: &Scene,
    light: &LightBounds<'_>,
    degree: usize,
    two_sided: bool,
    bounds: (DVec3, DVec3),
) -> Vec<Volume> {
    let polytope = light.polytope(degree);
    let center = light.light.center().as_dvec3();
    let mut out = Vec::new();
    for (id, tri) in scene.triangles() {
        let r = scene.face_ref(id);
        let mesh = &scene.meshes[r.mesh as usize];
        let (Some(uvs), Some(_)) = (&mesh.uvs, &mesh.alpha) else {
            continue;
        };
        let f = mesh.faces[r.face as usize];
        let uv = f.map(|i| uvs[i as usize].as_dvec2());
        let v = tri.map(|p| p.as_dvec3());
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let own = if n.dot(center - v[0]) < 0.0 {
            -1.0
        } else {
            1.0
        };
        let sides: &[f64] = if two_sided { &[own, -own] } else { &[own] };
        for &sigma in sides {
            let part = clip_to_side(&polytope, n, v[0], sigma);
            if part.is_empty() {
                continue;
            }
            let part_center = if sigma == own {
                center
            } else {
                part.iter().sum::<DVec3>() / part.len() as f64
            };
            out.extend(Volume::build(id, tri, uv, &part, part_center, bounds));
        }
    }
    out
}

/// The bounds of the scene and of `points`, padded by 1% of their diagonal.
fn padded_bounds(scene: &Scene, points: &[Vec3]) -> (DVec3, DVec3) {
    let (lo, hi) = points
        .iter()
        .fold(scene.bounds(), |(l, h), &o| (l.min(o), h.max(o)));
    let pad = (hi - lo).length() * 0.01 + 1e-6;
    ((lo - pad).as_dvec3(), (hi + pad).as_dvec3())
}

/// The closed soft textured shadow volumes of the perforated triangles of `scene` (section 2.2,
/// Figure 3), each as its six corners: the front cap t', then the back cap, parallel to t' and
/// beyond the bounds of the scene and of `points`, so that each closed volume holds every
/// receiver that its triangle can shadow; with the face id of each. The faces: the two caps and the quads
/// between corners `k, k + 1` of the front and back caps.
///
/// Errors: `hull_degree` outside 3..=64; corners beyond f32's range (receivers so far from the
/// light that the back caps overflow).
pub fn stsv_volumes(
    scene: &Scene,
    light: &Light,
    hull_degree: usize,
    two_sided: bool,
    points: &[Vec3],
) -> Result<Vec<(u32, [Vec3; 6])>> {
    check_hull_degree(hull_degree)?;
    let volumes: Vec<(u32, [Vec3; 6])> = volumes(
        scene,
        &LightBounds::of_light(light),
        hull_degree,
        two_sided,
        padded_bounds(scene, points),
    )
    .iter()
    .map(|v| (v.face, v.corners.map(|c| c.as_vec3())))
    .collect();
    if volumes
        .iter()
        .any(|(_, corners)| !corners.iter().all(|c| c.is_finite()))
    {
        return Err(Error::invalid(
            "receivers",
            "the volumes' back caps reach beyond float32's range: receivers too far from the light",
        ));
    }
    Ok(volumes)
}

/// Per list entry of `origins`, the bitmask of the samples that the perforated triangles block
/// (`words` per entry); stats `volumes`, `receivers_tested`, `receivers_inside`,
/// `sample_projections`.
fn perforated_masks(
    scene: &Scene,
    origins: &Origins,
    opts: &StsvOptions,
    words: usize,
    stats: &mut Stats,
) -> Result<Vec<u64>> {
    let lists = &origins.lists;
    limits::check_memory(
        "stsv bitmasks",
        limits::bytes(&[lists.entries.len() as u64, words as u64, 8]),
    )?;
    let bounds = padded_bounds(scene, &origins.origins);
    let volumes = volumes(
        scene,
        &origins.bounds,
        opts.object.hull_degree,
        opts.two_sided,
        bounds,
    );
    stats.set("volumes", volumes.len() as f64);
    let (tested, inside, projections) = (AtomicU64::new(0), AtomicU64::new(0), AtomicU64::new(0));
    let mut masks = vec![0u64; lists.entries.len() * words];
    let shared = origins
        .samples
        .is_shared()
        .then(|| origins.samples.pattern_for(0, 0));
    lists.visit_regions(
        &origins.bounds,
        opts.object.hull_degree,
        &volumes,
        |v| &v.triangle,
        &mut masks,
        words,
        |volume, k, mask| {
            tested.fetch_add(1, Ordering::Relaxed);
            let p = origins.origins[k].as_dvec3();
            if !volume.contains(p) {
                return;
            }
            inside.fetch_add(1, Ordering::Relaxed);
            let r = scene.face_ref(volume.face);
            let Some(texture) = &scene.meshes[r.mesh as usize].alpha else {
                return;
            };
            let projected = match shared {
                Some(ys) => volume.block(p, ys, texture, mask),
                None => {
                    let (mut ys, mut ws) = (Vec::new(), Vec::new());
                    origins.fill(k, &mut ys, &mut ws);
                    volume.block(p, &ys, texture, mask)
                }
            };
            projections.fetch_add(projected as u64, Ordering::Relaxed);
        },
    )?;
    stats.set("receivers_tested", tested.into_inner() as f64);
    stats.set("receivers_inside", inside.into_inner() as f64);
    stats.set("sample_projections", projections.into_inner() as f64);
    Ok(masks)
}

/// The stats keys of stsv's own stages (beside [`crate::stats::COMMON`]), zeroed at the start;
/// its opaque method adds its own. The one declaration the Python docstring and the key
/// tests read.
pub const STATS: &[&str] = &[
    "opaque_seconds",
    "perforated_seconds",
    "volumes",
    "receivers_tested",
    "receivers_inside",
    "sample_projections",
    "light_samples",
    "light_faces",
];

/// Visibility of every receiver with the perforated meshes' shadows by soft textured shadow
/// volumes and the opaque meshes' by `opts.opaque` (see the module doc). Returns the visibility
/// (receivers' order) and stats: `opaque_seconds`, `perforated_seconds`, `volumes`,
/// `receivers_tested` and `receivers_inside` (receiver and volume pairs), `sample_projections`
/// (light samples projected onto a perforated triangle and looked up, section 2.4),
/// `light_samples`, and the opaque method's own.
pub fn stsv(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &StsvOptions,
) -> Result<(Vec<f32>, Stats)> {
    by_light_face(light, receivers, |part, _| {
        stsv_in_one_frustum(scene, bvh, light, part, samples, opts)
    })
}

/// [`stsv`] on receivers that one light frustum holds.
fn stsv_in_one_frustum(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &StsvOptions,
) -> Result<(Vec<f32>, Stats)> {
    opts.object.validate(scene, receivers)?;
    bvh.check_scene(scene)?;
    let s = samples.count();
    if s > crate::methods::alias_free::MAX_SAMPLES {
        return Err(Error::invalid(
            "samples",
            format!(
                "stsv keeps one bit per light sample: at most {}, got {s}",
                crate::methods::alias_free::MAX_SAMPLES
            ),
        ));
    }
    let mut stats = Stats::declared(STATS);
    stats.set("light_samples", s as f64);
    let words = s.div_ceil(64);
    // Every triangle from the moved receiver, as `dcs` and `penumbra_wedge` test, so the opaque
    // frameworks give the same bits: `ray_traced`'s.
    let af = AliasFreeOptions {
        resolution: opts.object.resolution,
        caster_faces: CasterFaces::All,
        bias: opts.object.epsilon,
        lut: TableSize::Exact,
        hull_degree: opts.object.hull_degree,
        restrict_to_penumbra: true,
        cut_at_supporting_plane: true,
        backend: Backend::Cpu,
    };
    let n = receivers.len();
    // The visibility, the origins, the perforated bitmasks and volumes, then the opaque part's.
    let opaque_peak = match opts.opaque {
        Opaque::Bitmask => masks_peak(scene, n, s, &af),
        Opaque::Dcs => depth_complexity_peak(scene, n, s),
        Opaque::PenumbraWedge => wedge_occlusion_peak(scene, n),
    };
    Peak::default()
        .buffer(&[n as u64, 4])
        .and(Origins::peak(n, &opts.object))
        .buffer(&[n as u64, words as u64, 8])
        .buffer(&[
            scene.num_faces() as u64,
            2 * std::mem::size_of::<Volume>() as u64 + 16 * 8,
        ])
        .and(opaque_peak)
        .check("stsv", &mut stats)?;
    object_work(scene, n, samples.count()).check("stsv", &mut stats)?;
    let mut vis = vec![0.0f32; n];
    let Some(origins) = Origins::new(light, receivers, samples, &opts.object)? else {
        return Ok((vis, stats));
    };
    let perforated = {
        let start = std::time::Instant::now();
        let masks = perforated_masks(scene, &origins, opts, words, &mut stats)?;
        stats.add("perforated_seconds", start.elapsed().as_secs_f64());
        masks
    };
    let start = std::time::Instant::now();
    match opts.opaque {
        Opaque::Bitmask => {
            let mut opaque = sample_masks(scene, light, receivers, samples, &af, true, &mut stats)?;
            for (e, &k) in origins.lists.entries.iter().enumerate() {
                let i = origins.ids[k as usize] as usize;
                let words = opaque.words.min(words);
                for (a, b) in opaque.masks[i * opaque.words..i * opaque.words + words]
                    .iter_mut()
                    .zip(&perforated[e * words..])
                {
                    *a |= b;
                }
            }
            vis.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = opaque.visibility(i));
        }
        Opaque::Dcs => {
            let mut counts = depth_complexity(scene, bvh, &origins, &opts.object, &mut stats)?;
            for (c, bits) in counts.chunks_mut(s).zip(perforated.chunks(words)) {
                for (k, c) in c.iter_mut().enumerate() {
                    *c += i32::from(bits[k / 64] >> (k % 64) & 1 == 1);
                }
            }
            vis = visible_fraction(&origins, &counts);
        }
        Opaque::PenumbraWedge => {
            let occlusion = wedge_occlusion(scene, bvh, &origins, &opts.object, &mut stats)?;
            let (mut ys, mut ws) = (Vec::new(), Vec::new());
            for (e, (&k, occ)) in origins.lists.entries.iter().zip(occlusion).enumerate() {
                origins.fill(k as usize, &mut ys, &mut ws);
                let (p, n) = origins.receiver(k as usize);
                let (mut front, mut hidden) = (0.0f64, 0.0f64);
                for (j, (y, &w)) in ys.iter().zip(&ws).enumerate() {
                    if (*y - p).dot(n) > 0.0 {
                        front += f64::from(w);
                        if perforated[e * words + j / 64] >> (j % 64) & 1 == 1 {
                            hidden += f64::from(w);
                        }
                    }
                }
                let stsv_coef = if front > 0.0 { hidden / front } else { 0.0 };
                vis[origins.ids[k as usize] as usize] =
                    (occ.front * (1.0 - (occ.occlusion + stsv_coef).clamp(0.0, 1.0))) as f32;
            }
        }
    }
    stats.add("opaque_seconds", start.elapsed().as_secs_f64());
    Ok((vis, stats))
}
