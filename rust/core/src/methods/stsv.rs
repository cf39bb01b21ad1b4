//! `stsv`: soft textured shadow volumes (Forest, Barthe, Guennebaud and Paulin 2009,
//! Soft Textured Shadow Volume)
//! for perforated triangles, combined with an object-based method for the opaque meshes.
//!
//! For each perforated triangle `t` and each receiver inside its volume, the light samples are
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
//!    space) and `S` (barycentric to texture space); per receiver `p`, the projective center of
//!    `J = W M'`, in triangle space; per sample the homogeneous barycentrics `s_h = J (y − p)`
//!    ([`Volume::hides`] forms them without building `J`), tested inside the triangle and
//!    beyond its plane, and `S s_h` the texture coordinates of the alpha lookup. An opaque texel blocks the sample. Where the paper projects every light
//!    sample for every receiver in the volume (Algorithm 1, line 5), only the samples that can be
//!    hidden are projected here, which leaves the bits as they are: samples that do not count
//!    for the receiver (behind its tangent plane, of weight 0) or are blocked already are
//!    skipped, and samples shared by the receivers (not rotated per receiver) are binned in the
//!    light's plane ([`SampleBins`]), where only those in the bounding box of the triangle's
//!    cone from the receiver are looked up; a rectangle light's samples rotated per receiver
//!    (section 4.1) are binned by their parameters, where the cone's box is shifted back by the
//!    receiver's offset ([`ShiftedBins`]), and a disk's or a sphere's, rotated rigidly about the
//!    light's center, are found in the pattern's bins by the cone rotated back
//!    ([`RotatedBack`]). A triangle's two volumes are visited together.
//!    Shared samples are moved into a triangle's space (`M' (y − v0)`) once per band of light-map
//!    rows, for all the band's receivers ([`Projected`]); the pass is compiled for AVX2 where
//!    the CPU has it, without FMA, so it rounds as the baseline and the bits are the same.
//!
//! A one-sided volume is built on the side of `t` that holds the light's center; with
//! `two_sided`, a second one on the other side, for the part of the light behind `t`'s plane
//! (section 6: otherwise that part is never blocked by `t`). The opaque meshes go through
//! `Opaque::Bitmask` (`alias_free`'s exact bitmasks, OR-ed with the STSV masks), `Opaque::Dcs`
//! (each blocked sample adds one to its depth complexity) or `Opaque::PenumbraWedge` (the
//! STSV's occluded fraction is added to the wedges' visibility coefficient: approximate, the
//! overlaps of opaque and perforated occluders count twice, Forest et al. 2009, Figure 4a).
//! The exact frameworks are not run where no opaque triangle can cut a segment from a receiver
//! to a sample (a ground plane under a fence: [`opaque_can_block`]).

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::bvh::{Bvh, SceneBvh};
use crate::geometry::mesh::{AlphaTexture, Scene};
use crate::geometry::polygon::clip_to_side;
use crate::geometry::receivers::Receivers;
use crate::influence::{check_hull_degree, LightBounds, ObjectOptions, Origins};
use crate::light::bins::BoxBins;
use crate::light::lights::{rect_shifted, Light, RotationSeed, Shape};
use crate::light::sampling::SampleSet;
use crate::limits::{self, object_work, Peak};
use crate::methods::alias_free::{
    masks_peak, sample_masks, AliasFreeOptions, TableSize, MAX_SAMPLES,
};
use crate::methods::dcs::{
    depth_complexity, depth_complexity_peak, unblocked_fraction, visible_fraction,
};
use crate::methods::penumbra_wedge::{wedge_occlusion, wedge_occlusion_peak};
use crate::methods::CasterFaces;
use crate::raster::cube::by_light_face;
use crate::stats::Stats;
use glam::{DMat2, DMat3, DVec2, DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;
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
    /// The mesh holding the triangle's alpha texture.
    mesh: usize,
    /// The triangle's vertices (for its influence region).
    triangle: [Vec3; 3],
    /// `S` of equation 4.
    to_texture: DMat3,
    /// The fields below are in world coordinates as built, in those of the [`SamplePlane`] once
    /// [`Volume::in_plane`] moved them there (where the perforated pass tests receivers and
    /// samples).
    ///
    /// Inside: on the inner side of the front cap and the three outer planes (a plane is left out,
    /// [`Bound::EVERYWHERE`], where the light reaches past it: conservative).
    planes: Planes,
    /// `M'` of equation 2 and the triangle's first vertex.
    to_triangle: DMat3,
    v0: DVec3,
}

/// A plane of a volume, inside where `m · x >= k - slack`: [`Volume::in_plane`] sets the slack
/// that keeps [`Volume::contains`] conservative against round-off.
#[derive(Clone, Copy)]
struct Bound {
    m: DVec3,
    k: f64,
    slack: f64,
}

impl Bound {
    /// No bound: every point is inside.
    const EVERYWHERE: Bound = Bound {
        m: DVec3::ZERO,
        k: -1.0,
        slack: 0.0,
    };

    fn new((m, k): (DVec3, f64)) -> Self {
        Self { m, k, slack: 0.0 }
    }

    /// The bound in the coordinates of `plane` (`x = R^T u + o`, so `m · x = (R m) · u + m · o`),
    /// for points whose world coordinates are at most `reach` in magnitude: a slack of 1e-9 of
    /// the largest `|m · x|` covers the round-off of both frames many times over.
    fn in_plane(&self, plane: &SamplePlane, reach: f64) -> Self {
        let m = plane.to_plane * self.m;
        Self {
            m,
            k: self.k - self.m.dot(plane.origin),
            slack: 1e-9 * self.m.length() * (1.0 + reach + plane.origin.abs().max_element()),
        }
    }
}

/// The four [`Bound`]s of a volume, one lane per plane, so that [`Volume::contains`] tests them
/// together.
#[derive(Clone, Copy)]
struct Planes {
    /// Per axis, the planes' `m`.
    m: [[f64; 4]; 3],
    k: [f64; 4],
    slack: [f64; 4],
}

impl Planes {
    fn new(bounds: [Bound; 4]) -> Self {
        Self {
            m: [0, 1, 2].map(|axis| bounds.map(|b| b.m[axis])),
            k: bounds.map(|b| b.k),
            slack: bounds.map(|b| b.slack),
        }
    }

    fn bound(&self, i: usize) -> Bound {
        Bound {
            m: DVec3::new(self.m[0][i], self.m[1][i], self.m[2][i]),
            k: self.k[i],
            slack: self.slack[i],
        }
    }
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
    /// the light's polytope on one side of it, seen from `center`, with the closed volume's
    /// corners (the front cap t', then the back cap: only [`stsv_volumes`] returns them, the
    /// volume is not kept with them); `None` for a degenerate triangle.
    fn build(
        face: u32,
        mesh: usize,
        tri: [Vec3; 3],
        uv: [DVec2; 3],
        light: &[DVec3],
        center: DVec3,
        bounds: (DVec3, DVec3),
    ) -> Option<(Volume, [DVec3; 6])> {
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
        let mut bounds = [Bound::EVERYWHERE; 4];
        for (b, &plane) in bounds.iter_mut().zip(&planes) {
            *b = Bound::new(plane);
        }
        let volume = Volume {
            face,
            mesh,
            triangle: tri,
            planes: Planes::new(bounds),
            to_texture,
            to_triangle,
            v0: v[0],
        };
        Some((volume, corners))
    }

    /// The volume with its planes and triangle space in the coordinates of `plane`, for
    /// receivers whose world coordinates are at most `reach` in magnitude.
    fn in_plane(&self, plane: &SamplePlane, reach: f64) -> Self {
        Self {
            planes: Planes::new(std::array::from_fn(|i| {
                self.planes.bound(i).in_plane(plane, reach)
            })),
            // M' (x − v0) = M' R^T (u − R (v0 − o)) for x = R^T u + o.
            to_triangle: self.to_triangle * plane.to_plane.transpose(),
            v0: plane.coordinates(self.v0),
            ..*self
        }
    }

    /// Whether `p` lies inside (section 2.3), within the planes' slack.
    #[inline(always)]
    fn contains(&self, p: DVec3) -> bool {
        // Every plane, without a branch per plane: receivers fall on either side at random. The
        // lanes round as `m.dot(p)` does.
        let Planes { m, k, slack } = &self.planes;
        (0..4).fold(true, |inside, i| {
            let dot = m[0][i] * p.x + m[1][i] * p.y + m[2][i] * p.z;
            inside & (dot - k[i] >= -slack[i])
        })
    }

    /// The receiver `p`, the projective center of equations 1 and 3, in triangle space
    /// (`M' (p − v0)`, see [`Volume::hides`]); `None` when `p` lies in the triangle's plane.
    #[inline(always)]
    fn center(&self, p: DVec3) -> Option<DVec3> {
        let q = self.to_triangle * (p - self.v0);
        (q.z != 0.0).then_some(q)
    }

    /// A point `y` in triangle space, `M' (y − v0)` (see [`Volume::hides`]).
    #[inline(always)]
    fn in_triangle(&self, y: DVec3) -> DVec3 {
        self.to_triangle * (y - self.v0)
    }

    /// Whether an opaque texel of the triangle hides sample `y`, at `q` in triangle space
    /// ([`Volume::in_triangle`]), from the receiver of [`Volume::center`] `c` (equations 1–5).
    ///
    /// With `(α, β, γ) = M' (x − v0)` the triangle-space coordinates of a point `x` (γ its
    /// distance across the plane), the homogeneous barycentrics `s_h = J (y − p)` of equation 1
    /// are, times `γ_p`, `(γ_p α_y − α_p γ_y, γ_p β_y − β_p γ_y, γ_p − γ_y)`: the same tests
    /// (`s_h` inside the triangle, and `y` across the plane from `p`), without building `J` per
    /// receiver. Then the texture coordinates `S s_h / s_h.z` (equations 4 and 5) are looked up.
    #[inline(always)]
    fn hides(&self, c: DVec3, q: DVec3, texture: &AlphaTexture) -> bool {
        // Both sides of the plane alike: every γ times the sign of γ_p.
        let side = c.z.signum();
        let (g, qz) = (c.z * side, q.z * side);
        let (a, b) = (g * q.x - c.x * qz, g * q.y - c.y * qz);
        let d = g - qz;
        if !(qz < 0.0 && a >= 0.0 && b >= 0.0 && a + b <= d) {
            return false;
        }
        let st = self.to_texture * DVec3::new(a / d, b / d, 1.0);
        texture.is_opaque(glam::Vec2::new(st.x as f32, st.y as f32))
    }

    /// Sets in `blocked` the samples of `candidates` (sample `k` at `in_triangle(k)` in triangle
    /// space) that the triangle's opaque texels hide from `p` (equations 1–5); returns how many it
    /// projected: the candidates not blocked yet, since a sample blocked once stays blocked.
    #[inline(always)]
    fn block(
        &self,
        p: DVec3,
        in_triangle: impl Fn(usize) -> DVec3,
        candidates: &[u64],
        texture: &AlphaTexture,
        blocked: &mut [u64],
    ) -> u64 {
        if candidates.iter().zip(&*blocked).all(|(c, b)| c & !b == 0) {
            return 0;
        }
        let Some(center) = self.center(p) else {
            return 0;
        };
        let mut projected = 0;
        for (word, (&c, b)) in candidates.iter().zip(blocked.iter_mut()).enumerate() {
            let mut bits = c & !*b;
            projected += u64::from(bits.count_ones());
            while bits != 0 {
                let bit = bits.trailing_zeros();
                if self.hides(center, in_triangle(word * 64 + bit as usize), texture) {
                    *b |= 1 << bit;
                }
                bits &= bits - 1;
            }
        }
        projected
    }
}

/// The volumes of every perforated triangle of `scene` (two per triangle with `two_sided` when
/// the light or its samples reach both sides) for the light and samples of `light`, within
/// `bounds`, each as `keep` keeps it from the volume and its corners (see [`Volume::build`]).
fn volumes<T>(
    scene: &Scene,
    light: &LightBounds<'_>,
    degree: usize,
    two_sided: bool,
    bounds: (DVec3, DVec3),
    keep: impl Fn(Volume, [DVec3; 6]) -> T,
) -> Vec<T> {
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
            out.extend(
                Volume::build(id, r.mesh as usize, tri, uv, &part, part_center, bounds)
                    .map(|(volume, corners)| keep(volume, corners)),
            );
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
        |v, corners| (v.face, corners.map(|c| c.as_vec3())),
    );
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

/// The plane through the light's center in which the light samples are binned: the light's own
/// for a rectangle or a disk, else the one facing the receivers (normal `forward`).
struct SamplePlane {
    origin: DVec3,
    /// World to plane coordinates `(a, b, z)`: rows the plane's two axes and its unit normal,
    /// orthonormal in f64, so that its transpose takes plane coordinates back to the world (the
    /// volumes' planes and triangle spaces are moved by it: [`Volume::in_plane`]).
    to_plane: DMat3,
}

impl SamplePlane {
    fn new(light: &Light, forward: Vec3) -> Self {
        let n = light.normal().unwrap_or(forward).as_dvec3().normalize();
        let (t, b) = n.any_orthonormal_pair();
        Self {
            origin: light.center().as_dvec3(),
            to_plane: DMat3::from_cols(t, b, n).transpose(),
        }
    }

    #[inline(always)]
    fn coordinates(&self, x: DVec3) -> DVec3 {
        self.to_plane * (x - self.origin)
    }
}

/// A pattern of light samples shared by receivers, or rotated rigidly per receiver
/// ([`RotatedBack`]), binned along each axis of a [`SamplePlane`].
///
/// A sample that a triangle hides from a receiver `p` lies in the cone from `p` through the
/// triangle, whose section by the plane is the triangle of the vertices' projections from `p`.
/// Equations 1–5 project every light sample for every receiver in the volume (Algorithm 1, line
/// 5); only the samples in the bounding box of that section, found by four table lookups, are
/// projected here: the others cannot be hidden, so the bits are the same.
struct SampleBins {
    /// The largest distance of a sample from the plane.
    thickness: f64,
    /// The samples binned at their plane coordinates `(a, b)`.
    boxes: BoxBins,
    /// Every sample.
    all: Vec<u64>,
}

impl SampleBins {
    /// The bytes of the bins of `count` samples: their tables and the whole set.
    fn bytes(count: usize) -> u64 {
        BoxBins::bytes(count) + count.div_ceil(64) as u64 * 8
    }

    /// Bins `at`, samples in the coordinates of the [`SamplePlane`].
    fn new(at: &[DVec3]) -> Self {
        Self {
            thickness: at.iter().map(|c| c.z.abs()).fold(0.0, f64::max),
            boxes: BoxBins::new(&at.iter().map(|c| [c.x, c.y]).collect::<Vec<_>>()),
            all: every_sample(at.len()),
        }
    }

    /// Into `out`, the samples that may lie within `slack` of the cone from `p` through the
    /// triangle `tri` (both in plane coordinates): those binned in its [`cone_box`] widened by
    /// `slack`, or every sample where the box is unbounded. `slack` is 0 for shared samples.
    #[inline(always)]
    fn candidates(&self, p: DVec3, tri: &[DVec3; 3], slack: f64, out: &mut [u64]) {
        match cone_box(p, tri, self.thickness + slack) {
            Some((lo, hi)) => self.boxes.merge_box(
                lo.map(|x| x - slack),
                hi.map(|x| x + slack),
                out,
                |o, binned| *o = binned,
            ),
            None => out.copy_from_slice(&self.all),
        }
    }
}

/// The bounding box `(low, high)` of the [`cone_section`] of the cone from `p` through `tri`.
#[inline(always)]
fn cone_box(p: DVec3, tri: &[DVec3; 3], thickness: f64) -> Option<([f64; 2], [f64; 2])> {
    let (corners, margin) = cone_section(p, tri, thickness)?;
    let low = corners.into_iter().fold(DVec2::INFINITY, DVec2::min) - margin;
    let high = corners.into_iter().fold(DVec2::NEG_INFINITY, DVec2::max) + margin;
    Some((low.to_array(), high.to_array()))
}

/// The section of the cone from `p` through `tri` by the plane `z = 0` (both in plane
/// coordinates): the triangle of the vertices' projections from `p`, and per axis the margin
/// that widens it by `thickness`, the samples' largest distance from the plane, times the cone's
/// slope (a sample off the plane is binned where the plane's normal through it meets the plane,
/// its segment from `p` meets the plane within that of it) and against round-off; `None` when
/// `p` lies within the samples' slab or a vertex is not strictly nearer the plane than `p`.
#[inline(always)]
fn cone_section(p: DVec3, tri: &[DVec3; 3], thickness: f64) -> Option<([DVec2; 3], DVec2)> {
    let height = p.z.abs();
    if height <= thickness {
        return None;
    }
    let toward = -p.z.signum();
    let mut slope = DVec2::ZERO;
    let mut corners = [DVec2::ZERO; 3];
    for (v, corner) in tri.iter().zip(&mut corners) {
        let dz = (v.z - p.z) * toward;
        if dz <= 0.0 {
            return None;
        }
        let per_height = 1.0 / dz;
        let d = (*v - p).truncate();
        *corner = p.truncate() + d * (height * per_height);
        slope = slope.max(d.abs() * per_height);
    }
    let reach = corners.into_iter().fold(DVec2::ZERO, |r, c| r.max(c.abs()));
    let size = height + p.truncate().abs() + reach;
    let margin = thickness * slope + 1e-7 * size;
    (corners.iter().all(|c| c.is_finite()) && margin.is_finite()).then_some((corners, margin))
}

/// The rigid rotation of a disk's or a sphere's samples about the light's center for one
/// receiver (`Light::rotate`, the decorrelation of Forest et al. 2009, section 4.1), undone in
/// the [`SamplePlane`]'s coordinates: a rotated sample lies in the cone from `p` through a
/// triangle where its pattern sample lies in the cone rotated back, which the pattern's
/// [`SampleBins`] look up, the cone widened by the f32 round-off of the rotated samples
/// ([`RotatedBack::slack`]). Every rotated sample in the cone is among those found, so the bits
/// are the same.
struct RotatedBack {
    /// Plane coordinates to plane coordinates: the inverse of the receiver's rotation.
    back: DMat3,
}

impl RotatedBack {
    /// The rotation undone for seed `r`; `None` unless `light` rotates its samples rigidly.
    fn new(light: &Light, plane: &SamplePlane, r: RotationSeed) -> Option<Self> {
        let rotation = light.rigid_rotation(r)?.as_dmat3();
        Some(Self {
            back: plane.to_plane * rotation.transpose() * plane.to_plane.transpose(),
        })
    }

    /// A bound of the distance between a sample rotated by `Light::rotate` (in f32, about the
    /// light's center) and its pattern sample rotated exactly, for the pattern `at` (plane
    /// coordinates, about the center): a few f32 roundings of the center and of the sample's
    /// offset, and the f32 rotation's departure from orthonormal, generously.
    fn slack<'a>(light: &Light, at: impl IntoIterator<Item = &'a DVec3>) -> f64 {
        let reach = at.into_iter().map(|y| y.length()).fold(0.0, f64::max);
        64.0 * f64::from(f32::EPSILON) * (light.center().as_dvec3().length() + reach)
    }

    /// `p` and the triangle `tri` (plane coordinates) rotated back.
    fn cone(&self, p: DVec3, tri: &[DVec3; 3]) -> (DVec3, [DVec3; 3]) {
        (self.back * p, tri.map(|v| self.back * v))
    }
}

/// A rectangle light's pattern binned by its samples' parameters `(s, t)`, for receivers whose
/// samples are shifted by their own offset `r` and wrapped (`Light::rotate`: `st' = frac(st +
/// r)`, the decorrelation of Forest et al. 2009, section 4.1): a rotated sample lies in a box of
/// the plane where its parameters lie in the box's parameter box, and its pattern sample where
/// they lie in that box shifted back by `r` and wrapped, which the pattern's bins look up. Every
/// rotated sample in the cone is among those found, so the bits are the same.
struct ShiftedBins {
    /// The pattern's samples, binned at `(s, t, 0)`.
    bins: SampleBins,
    /// A bound of the f32 round-off of a rotated sample's position (`Light::rotate`) and of its
    /// distance from the plane: the cone boxes are widened by it.
    slack: f64,
    /// Plane coordinates `(a, b)` to parameters: `st = 0.5 + to_params (a, b)`.
    to_params: DMat2,
    /// The rectangle's center and half-extent vectors, and the pattern's parameters.
    rect: [Vec3; 3],
    params: Vec<Vec2>,
}

impl ShiftedBins {
    /// The bins of `pattern` (in the world), a pattern of `light`, with the cone boxes in the
    /// coordinates of `plane`; `None` unless `light` is a rectangle.
    fn new(light: &Light, pattern: &[Vec3], plane: &SamplePlane) -> Option<Self> {
        let Shape::Rect { center, u, v } = light.shape else {
            return None;
        };
        let params: Vec<Vec2> = pattern.iter().map(|&y| light.params(y)).collect();
        let rect = [center, u, v];
        // The Gram solve of `Light::params`, for the plane's two axes (rows of `to_plane`).
        let (u, v) = (u.as_dvec3(), v.as_dvec3());
        let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
        let det = uu * vv - uv * uv;
        let st = |d: DVec3| {
            let (du, dv) = (d.dot(u), d.dot(v));
            DVec2::new(du * vv - dv * uv, dv * uu - du * uv) * (0.5 / det)
        };
        let axes = plane.to_plane.transpose();
        let scale = center.as_dvec3().length() + u.length() + v.length();
        Some(Self {
            bins: SampleBins::new(
                &params
                    .iter()
                    .map(|st| st.as_dvec2().extend(0.0))
                    .collect::<Vec<_>>(),
            ),
            slack: 16.0 * f64::from(f32::EPSILON) * scale,
            to_params: DMat2::from_cols(st(axes.x_axis), st(axes.y_axis)),
            rect,
            params,
        })
    }

    /// Sample `s` of the pattern shifted by `r`: `Light::rotate` of the pattern's sample, its
    /// parameters kept rather than solved for again.
    #[inline(always)]
    fn sample(&self, s: usize, r: RotationSeed) -> Vec3 {
        let [center, u, v] = self.rect;
        rect_shifted(center, u, v, self.params[s], r)
    }

    /// Into `out`, the samples of the pattern that, shifted by `r`, may lie in the cone from `p`
    /// through the triangle `tri` (both in plane coordinates).
    #[inline(always)]
    fn candidates(&self, p: DVec3, tri: &[DVec3; 3], r: RotationSeed, out: &mut [u64]) {
        let Some((corners, margin)) = cone_section(p, tri, self.slack) else {
            out.copy_from_slice(&self.bins.all);
            return;
        };
        // The section's triangle in parameters, widened by its margin and the rotated samples'
        // round-off, mapped as well.
        let margin = margin + self.slack;
        let m = &self.to_params;
        let spread = m.x_axis.abs() * margin.x + m.y_axis.abs() * margin.y;
        let corners = corners.map(|c| DVec2::splat(0.5) + *m * c);
        // A rotated sample's parameters lie in [0, 1] (`frac`): the box beyond has none, and
        // shifted back it would wrap onto samples outside the cone.
        let low = (corners.into_iter().fold(DVec2::INFINITY, DVec2::min) - spread).max(DVec2::ZERO);
        let high =
            (corners.into_iter().fold(DVec2::NEG_INFINITY, DVec2::max) + spread).min(DVec2::ONE);
        out.fill(0);
        if low.cmpgt(high).any() {
            return;
        }
        // `st' = w - floor(w)` with `w = st + r` rounded to f32 (within 2^-23 of it, as w < 2),
        // so `st = st' - r + floor(w)`, `floor(w)` in -1..=2 (a parameter may round just
        // outside [0, 1]); the margin covers the rounding of `w` and of `to_params`, the box
        // being within [0, 1].
        let margin = 1e-6;
        // Only the shifts that meet the pattern's span are looked up (two at most per axis).
        let shifts = |axis: usize| {
            (-1..=2)
                .map(move |k| {
                    let back = f64::from(k) - f64::from(r[axis]);
                    (low[axis] + back - margin, high[axis] + back + margin)
                })
                .filter(move |&(lo, hi)| self.bins.boxes.overlaps(axis, lo, hi))
        };
        for (a0, a1) in shifts(0) {
            for (b0, b1) in shifts(1) {
                self.bins
                    .boxes
                    .merge_box([a0, b0], [a1, b1], out, |o, binned| *o |= binned);
            }
        }
    }
}

/// The bitmask of `count` samples, every bit set.
fn every_sample(count: usize) -> Vec<u64> {
    (0..count.div_ceil(64))
        .map(|w| match count - 64 * w {
            left if left >= 64 => !0,
            left => (1 << left) - 1,
        })
        .collect()
}

/// Per list entry of `origins` and its bitmask in `masks` (`words` each), `merge(mask, counted)`
/// with the bitmask of the samples that count for its receiver: in front of the receiver's
/// tangent plane and of non-zero weight, as `ray_traced` tells them (the others never count,
/// docs/design.md section 3). Computed per receiver where it is needed, not kept.
fn merge_counted_samples(
    origins: &Origins,
    masks: &mut [u64],
    words: usize,
    merge: impl Fn(&mut [u64], &[u64]) + Sync,
) {
    masks
        .par_chunks_mut(words)
        .zip(&origins.lists.entries)
        .for_each_init(
            || (Vec::new(), Vec::new()),
            |(ys, ws), (mask, &k)| {
                let (ys, ws) = origins.samples_of(k as usize, ys, ws);
                let (p, n) = origins.receiver(k as usize);
                let mut counted = [0u64; MAX_SAMPLES / 64];
                for (s, (y, &w)) in ys.iter().zip(ws).enumerate() {
                    if w != 0.0 && (*y - p).dot(n) > 0.0 {
                        counted[s / 64] |= 1 << (s % 64);
                    }
                }
                merge(mask, &counted[..words]);
            },
        );
}

/// Per list entry of `origins`, the bitmask of the samples that the perforated triangles block
/// or that do not count (`words` per entry: the one bit per sample and receiver of Forest et al.
/// 2009, section 5.1; [`unblocked_fraction`] and the penumbra wedges' sum read the samples that
/// count only); stats `volumes`, `receivers_tested`, `receivers_inside`,
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
    // Receivers and samples are tested in the light plane's coordinates, where the samples are
    // binned; a receiver's are computed where it is tested (three dot products), not stored.
    let plane = SamplePlane::new(origins.light, lists.frustum.forward);
    let reach = origins
        .origins
        .iter()
        .fold(0.0f32, |r, o| r.max(o.abs().max_element()));
    let volumes = volumes(
        scene,
        &origins.bounds,
        opts.object.hull_degree,
        opts.two_sided,
        padded_bounds(scene, &origins.origins),
        |v, _| v.in_plane(&plane, f64::from(reach)),
    );
    stats.set("volumes", volumes.len() as f64);
    let samples = origins.samples;
    let patterns: Vec<Vec<DVec3>> = samples
        .patterns()
        .iter()
        .map(|pattern| {
            pattern
                .iter()
                .map(|y| plane.coordinates(y.as_dvec3()))
                .collect()
        })
        .collect();
    // Receivers that share a pattern (not rotated) find the samples worth projecting in its bins,
    // and so do those of a disk or a sphere, rotated rigidly per receiver, through the cone
    // rotated back ([`RotatedBack`]); those of a rectangle light, rotated per receiver, in the
    // bins of its parameters.
    let rotated = samples.rotates();
    let rigid = origins.light.rigid_rotation([0.0; 3]).is_some();
    let bins: Option<Vec<SampleBins>> =
        (!rotated || rigid).then(|| patterns.iter().map(|p| SampleBins::new(p)).collect());
    let shifted: Option<Vec<ShiftedBins>> = rotated
        .then(|| {
            samples
                .patterns()
                .iter()
                .map(|pattern| ShiftedBins::new(origins.light, pattern, &plane))
                .collect()
        })
        .flatten();
    let pass = Pass {
        scene,
        origins,
        plane: &plane,
        patterns: &patterns,
        rotates: rotated,
        bins: bins.as_deref(),
        shifted: shifted.as_deref(),
        slack: match rotated && rigid {
            true => RotatedBack::slack(origins.light, patterns.iter().flatten()),
            false => 0.0,
        },
        every: every_sample(samples.count()),
    };
    // Each entry's one mask holds the samples blocked or that do not count: neither needs
    // projecting, and a receiver whose mask is full is done.
    let mut masks = vec![0u64; lists.entries.len() * words];
    merge_counted_samples(origins, &mut masks, words, |mask, counted| {
        mask.iter_mut().zip(counted).for_each(|(m, c)| *m = !c);
    });
    // A triangle's volumes (one per side of its plane that the light reaches) share its influence
    // region and its projection: a receiver inside either has each sample projected once.
    let triangles: Vec<&[Volume]> = volumes.chunk_by(|a, b| a.face == b.face).collect();
    // The pass's stats, summed over the spans of texels that the workers visit (integer sums:
    // the same whatever the order).
    let tally: [AtomicU64; 3] = Default::default();
    lists.visit_region_spans(
        &origins.bounds,
        opts.object.hull_degree,
        &triangles,
        |sides| &sides[0].triangle,
        &mut masks,
        words,
        Projected::default,
        |sides, entries, part, projected| {
            let counts = pass.span_on_this_cpu(sides, entries, part, projected);
            for (total, count) in tally.iter().zip(counts) {
                total.fetch_add(count, Ordering::Relaxed);
            }
        },
    )?;
    let keys = ["receivers_tested", "receivers_inside", "sample_projections"];
    for (key, total) in keys.into_iter().zip(&tally) {
        stats.set(key, total.load(Ordering::Relaxed) as f64);
    }
    Ok(masks)
}

/// A band's shared samples of one pattern in the triangle space of the triangle that projected
/// them last ([`Volume::in_triangle`]): a triangle's spans in a band project the same samples,
/// each once for the band rather than once per receiver. A worker's scratch: one point per
/// sample, whatever the receivers and the triangles.
#[derive(Default)]
struct Projected {
    /// The triangle's face and the pattern.
    of: Option<(u32, usize)>,
    samples: Vec<DVec3>,
}

impl Projected {
    /// The samples `ys` of pattern `pattern` in the triangle space of `volume`.
    #[inline(always)]
    fn of(&mut self, volume: &Volume, pattern: usize, ys: &[DVec3]) -> &[DVec3] {
        if self.of != Some((volume.face, pattern)) {
            self.samples.clear();
            self.samples
                .extend(ys.iter().map(|&y| volume.in_triangle(y)));
            self.of = Some((volume.face, pattern));
        }
        &self.samples
    }
}

/// What the perforated pass reads for every span of receivers: the receivers, the samples in the
/// [`SamplePlane`]'s coordinates and their bins.
struct Pass<'a> {
    scene: &'a Scene,
    origins: &'a Origins<'a>,
    plane: &'a SamplePlane,
    /// Per pattern, its samples in the plane's coordinates.
    patterns: &'a [Vec<DVec3>],
    /// Whether each receiver rotates the samples (`SampleSet::rotation_for`).
    rotates: bool,
    /// Per pattern, its bins where the receivers share it or rotate it rigidly (disk, sphere);
    /// its [`ShiftedBins`] where a rectangle light's samples are rotated per receiver.
    bins: Option<&'a [SampleBins]>,
    shifted: Option<&'a [ShiftedBins]>,
    /// [`RotatedBack::slack`] of the patterns.
    slack: f64,
    /// Every sample's bit.
    every: Vec<u64>,
}

impl Pass<'_> {
    /// [`Pass::span`] compiled for AVX2 where the CPU has it: the alpha lookups' floors and the
    /// bit counts become one instruction each, and without FMA (not enabled) the arithmetic
    /// rounds as the baseline's, so the bits are the same.
    fn span_on_this_cpu(
        &self,
        sides: &[Volume],
        entries: Range<usize>,
        part: &mut [u64],
        projected: &mut Projected,
    ) -> [u64; 3] {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,popcnt")]
            fn avx2(
                pass: &Pass<'_>,
                sides: &[Volume],
                entries: Range<usize>,
                part: &mut [u64],
                projected: &mut Projected,
            ) -> [u64; 3] {
                pass.span(sides, entries, part, projected)
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("popcnt") {
                // SAFETY: the CPU has AVX2 and POPCNT (checked just above).
                return unsafe { avx2(self, sides, entries, part, projected) };
            }
        }
        self.span(sides, entries, part, projected)
    }

    /// The receiver of list entry `e` in the plane's coordinates.
    #[inline(always)]
    fn at(&self, e: usize) -> DVec3 {
        let k = self.origins.lists.entries[e] as usize;
        self.plane.coordinates(self.origins.origins[k].as_dvec3())
    }

    /// Sets in `part` (the masks of list entries `entries`) the samples that the triangle of
    /// `sides` (its volumes) hides; returns the stats `receivers_tested`, `receivers_inside` and
    /// `sample_projections` of the span.
    #[inline(always)]
    fn span(
        &self,
        sides: &[Volume],
        entries: Range<usize>,
        part: &mut [u64],
        projected: &mut Projected,
    ) -> [u64; 3] {
        let mut counts = [0u64; 3];
        let volume = &sides[0];
        let Some(texture) = &self.scene.meshes[volume.mesh].alpha else {
            return counts;
        };
        let (origins, samples, every) = (self.origins, self.origins.samples, &self.every[..]);
        let words = every.len();
        // The cone boxes' triangle in the plane's coordinates, as the volume's planes.
        let vertices = volume
            .triangle
            .map(|x| self.plane.coordinates(x.as_dvec3()));
        // Filled by each receiver's lookup before it is read.
        let mut candidates = [0u64; MAX_SAMPLES / 64];
        let candidates = &mut candidates[..words];
        for (e, done) in entries.zip(part.chunks_mut(words)) {
            // Every sample is blocked or does not count: the volume cannot change the bits.
            if every.iter().zip(&*done).all(|(a, d)| a & !d == 0) {
                continue;
            }
            let p = self.at(e);
            let inside = sides.iter().filter(|v| v.contains(p)).count();
            counts[0] += sides.len() as u64;
            counts[1] += inside as u64;
            if inside == 0 {
                continue;
            }
            let k = origins.lists.entries[e] as usize;
            let pattern = if self.patterns.len() == 1 {
                0
            } else {
                let (x, y) = origins.receivers.pixel(origins.ids[k] as usize);
                samples.pattern_index(x, y)
            };
            // Shared samples have no rotation: the receiver's id is not looked up for them.
            let rotation = if self.rotates {
                samples.rotation_for(origins.ids[k] as usize)
            } else {
                None
            };
            let light = origins.light;
            let rotated_back = rotation.and_then(|r| RotatedBack::new(light, self.plane, r));
            counts[2] += match (rotation, rotated_back, self.bins, self.shifted) {
                (None, _, Some(bins), _) => {
                    bins[pattern].candidates(p, &vertices, 0.0, candidates);
                    if candidates.iter().zip(&*done).all(|(c, d)| c & !d == 0) {
                        continue;
                    }
                    let ys = projected.of(volume, pattern, &self.patterns[pattern]);
                    volume.block(p, |s| ys[s], candidates, texture, done)
                }
                (Some(r), Some(back), Some(bins), _) => {
                    let (back_p, back_tri) = back.cone(p, &vertices);
                    bins[pattern].candidates(back_p, &back_tri, self.slack, candidates);
                    if candidates.iter().zip(&*done).all(|(c, d)| c & !d == 0) {
                        continue;
                    }
                    let ys = &samples.patterns()[pattern];
                    let own = |s: usize| {
                        volume
                            .in_triangle(self.plane.coordinates(light.rotate(ys[s], r).as_dvec3()))
                    };
                    volume.block(p, own, candidates, texture, done)
                }
                (Some(r), None, _, Some(shifted)) => {
                    let shifted = &shifted[pattern];
                    shifted.candidates(p, &vertices, r, candidates);
                    let own = |s: usize| {
                        volume.in_triangle(self.plane.coordinates(shifted.sample(s, r).as_dvec3()))
                    };
                    volume.block(p, own, candidates, texture, done)
                }
                (rotation, ..) => {
                    // Each sample rotated as the receiver's own (`SampleSet::fill`), and
                    // every one projected.
                    let ys = &samples.patterns()[pattern];
                    let own = |s: usize| {
                        let y = rotation.map_or(ys[s], |r| light.rotate(ys[s], r));
                        volume.in_triangle(self.plane.coordinates(y.as_dvec3()))
                    };
                    volume.block(p, own, every, texture, done)
                }
            };
        }
        counts
    }
}

/// Whether some opaque triangle of `scene` may cut a segment from an origin of `origins` to a
/// light sample: a triangle whose plane has the origins' bounding box and the bounds of the light
/// and its samples strictly on one side (beyond a relative margin) cuts none, and the ground under
/// a fence or a tree is such a triangle.
fn opaque_can_block(scene: &Scene, origins: &Origins, degree: usize) -> bool {
    let (lo, hi) = origins
        .origins
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &o| {
            (l.min(o), h.max(o))
        });
    let ends: Vec<DVec3> = box_corners((lo.as_dvec3(), hi.as_dvec3()))
        .into_iter()
        .chain(origins.bounds.polytope(degree))
        .collect();
    scene
        .triangles()
        .filter(|&(id, _)| !scene.is_perforated_face(id))
        .any(|(_, t)| {
            let v = t.map(|x| x.as_dvec3());
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let side: Vec<f64> = ends.iter().map(|x| n.dot(*x - v[0])).collect();
            let reach = ends
                .iter()
                .map(|x| (*x - v[0]).length())
                .fold(0.0, f64::max);
            let margin = 1e-6 * n.length() * reach;
            !(side.iter().all(|&d| d > margin) || side.iter().all(|&d| d < -margin))
        })
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
    // The visibility, the origins, the perforated bitmasks and volumes (per perforated triangle,
    // one per side of it), per pattern its samples in the light's plane (f64) and parameters
    // (f32) and its bins (two tables per axis and the whole set, `words` per bin), then the
    // opaque part's.
    let perforated_faces: u64 = scene
        .meshes
        .iter()
        .filter(|m| m.is_perforated())
        .map(|m| m.faces.len() as u64)
        .sum();
    let sides = if opts.two_sided { 2 } else { 1 };
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
            perforated_faces,
            sides * std::mem::size_of::<Volume>() as u64,
        ])
        .buffer(&[
            samples.patterns().len() as u64,
            s as u64 * (24 + 8) + SampleBins::bytes(s),
        ])
        .and(opaque_peak)
        .check("stsv", &mut stats)?;
    object_work(scene, n, samples.count()).check("stsv", &mut stats)?;
    let mut vis = vec![0.0f32; n];
    let Some(origins) = Origins::new(light, receivers, samples, &opts.object)? else {
        return Ok((vis, stats));
    };
    let mut perforated = {
        let start = std::time::Instant::now();
        let masks = perforated_masks(scene, &origins, opts, words, &mut stats)?;
        stats.add("perforated_seconds", start.elapsed().as_secs_f64());
        masks
    };
    if opts.opaque != Opaque::PenumbraWedge
        && !opaque_can_block(scene, &origins, opts.object.hull_degree)
    {
        // The exact frameworks would add no blocked sample: the volumes' bits are the answer.
        let vis = unblocked_fraction(&origins, |e, k| {
            perforated[e * words + k / 64] >> (k % 64) & 1 == 1
        });
        return Ok((vis, stats));
    }
    let start = std::time::Instant::now();
    match opts.opaque {
        Opaque::Bitmask => {
            let mut opaque = sample_masks(
                scene,
                SceneBvh::Built(bvh),
                light,
                receivers,
                samples,
                &af,
                true,
                &mut stats,
            )?;
            // `alias_free`'s visibility reads every bit: only the samples that count are added.
            merge_counted_samples(&origins, &mut perforated, words, |mask, counted| {
                mask.iter_mut().zip(counted).for_each(|(m, c)| *m &= c);
            });
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::{light_samples, Pattern, Rng};

    /// Whether `y` lies in the cone from `p` through `tri` beyond the triangle (`y - p` a
    /// combination of the vertices' directions with non-negative weights summing to >= 1),
    /// where a sample that the triangle hides lies.
    fn beyond(p: DVec3, tri: &[DVec3; 3], y: DVec3) -> bool {
        let m = DMat3::from_cols(tri[0] - p, tri[1] - p, tri[2] - p);
        let w = m.inverse() * (y - p);
        w.min_element() >= -1e-9 && w.element_sum() >= 1.0 - 1e-9
    }

    /// A receiver on the ground (`|x|, |z| < 2`) and a triangle of half-size `half` above it, at
    /// heights 0.5 to `top`.
    fn receiver_and_triangle(
        uniform: &mut impl FnMut(f32, f32) -> f32,
        top: f32,
        half: f32,
    ) -> (Vec3, [Vec3; 3]) {
        let p = Vec3::new(uniform(-2.0, 2.0), 0.0, uniform(-2.0, 2.0));
        let c = Vec3::new(uniform(-1.5, 1.5), uniform(0.5, top), uniform(-1.5, 1.5));
        let tri = [0, 1, 2].map(|_| {
            c + Vec3::new(
                uniform(-half, half),
                uniform(-0.05, 0.05),
                uniform(-half, half),
            )
        });
        (p, tri)
    }

    /// For a disk and a sphere rotating their samples per receiver, every rotated sample (the
    /// same bits as `Light::rotate`) that a triangle may hide from a receiver is among the
    /// pattern's bin candidates for the cone rotated back; and the bins leave most samples out.
    #[test]
    fn rotated_back_bins_find_every_rigidly_rotated_sample_in_the_cone() -> Result<()> {
        let center = Vec3::new(0.3, 4.0, -0.2);
        // A ball's samples are binned in one plane, and its cone rotated back comes from any
        // direction, its box widened by the ball's thickness times the cone's slope: the bins
        // leave fewer out than a disk's.
        for (light, most) in [
            (Light::disk(center, Vec3::new(0.2, -1.0, 0.1), 0.7)?, 4),
            (Light::sphere(center, 0.5)?, 2),
        ] {
            let pattern = light_samples(&light, 128, Pattern::Poisson, 7, 0);
            let plane = SamplePlane::new(&light, Vec3::NEG_Y);
            let at = |x: Vec3| plane.coordinates(x.as_dvec3());
            let in_plane: Vec<DVec3> = pattern.iter().map(|&y| at(y)).collect();
            let bins = SampleBins::new(&in_plane);
            let slack = RotatedBack::slack(&light, &in_plane);
            let mut rng = Rng::stream(5, 0);
            let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
            let (mut found, mut total) = (0, 0);
            for trial in 0..2000 {
                let (p, tri) = receiver_and_triangle(&mut uniform, 3.0, 0.2);
                let r = [uniform(0.0, 1.0), uniform(0.0, 1.0), uniform(0.0, 1.0)];
                let back = RotatedBack::new(&light, &plane, r).ok_or(Error::unsupported(
                    "light",
                    "a disk and a sphere rotate their samples rigidly",
                ))?;
                let (pp, tt) = (at(p), tri.map(at));
                let (back_p, back_tri) = back.cone(pp, &tt);
                let mut candidates = [0u64; 2];
                bins.candidates(back_p, &back_tri, slack, &mut candidates);
                for (s, &y) in pattern.iter().enumerate() {
                    let candidate = candidates[s / 64] >> (s % 64) & 1 == 1;
                    assert!(
                        candidate || !beyond(pp, &tt, at(light.rotate(y, r))),
                        "trial {trial}, sample {s}"
                    );
                    found += u32::from(candidate);
                    total += 1;
                }
            }
            assert!(
                found * most < total,
                "{light:?}: {found} candidates of {total}"
            );
        }
        Ok(())
    }

    /// On a rectangle whose sides are not orthogonal, every sample that a triangle may hide from
    /// a receiver, rotated as the receiver's own (the same bits as `Light::rotate`), is among the
    /// shifted bins' candidates, also where its parameters wrap; and the bins leave most samples
    /// out (what they are for).
    #[test]
    fn shifted_bins_find_every_rotated_sample_in_the_cone() -> Result<()> {
        let light = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(0.6, 0.0, 0.2),
            Vec3::new(0.2, 0.0, -0.3),
        )?;
        let pattern = light_samples(&light, 64, Pattern::Poisson, 7, 0);
        let plane = SamplePlane::new(&light, Vec3::NEG_Y);
        let bins = ShiftedBins::new(&light, &pattern, &plane).ok_or(Error::unsupported(
            "light",
            "a rectangle's samples are shifted by their parameters",
        ))?;
        let mut rng = Rng::stream(3, 0);
        let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let (mut found, mut total) = (0, 0);
        for trial in 0..2000 {
            let (p, tri) = receiver_and_triangle(&mut uniform, 3.5, 0.3);
            let r = match trial % 4 {
                0 => [1.0 - f32::EPSILON, uniform(0.0, 1.0)],
                _ => [uniform(0.0, 1.0), uniform(0.0, 1.0)],
            };
            let at = |x: Vec3| plane.coordinates(x.as_dvec3());
            let (pp, tt) = (at(p), tri.map(at));
            let mut candidates = [0u64; 1];
            bins.candidates(pp, &tt, [r[0], r[1], 0.0], &mut candidates);
            for (s, &y) in pattern.iter().enumerate() {
                let y = light.rotate(y, [r[0], r[1], 0.0]);
                assert_eq!(bins.sample(s, [r[0], r[1], 0.0]), y);
                let y = at(y);
                let candidate = candidates[0] >> s & 1 == 1;
                assert!(
                    candidate || !beyond(pp, &tt, y),
                    "trial {trial}, sample {s}"
                );
                found += u32::from(candidate);
                total += 1;
            }
        }
        assert!(found * 4 < total, "{found} candidates of {total}");
        Ok(())
    }
}
