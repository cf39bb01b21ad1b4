//! G-buffers by ray casting: one primary ray through each pixel center (`docs/design.md` section 2).
//!
//! Choices: positions are interpolated from the hit triangle's vertices with the hit's
//! barycentrics (they lie on the surface to within rounding, which keeps the receivers' normal
//! offset meaningful); normals are the geometric face normals flipped to face the camera (the
//! view ray's reverse for degenerate faces); pixels with no hit get position and normal 0, mask
//! false and face id -1. With `msaa > 1` every pixel also traces one ray per sample of the
//! standard Direct3D 11 pattern of that count and records the hit distance along the normalized
//! ray (`+inf` for no hit) in `sample_depths[(y * width + x) * msaa + s]`.

use crate::error::{Error, Result};
use crate::geometry::bvh::Bvh;
use crate::geometry::camera::Camera;
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::interrupt;
use crate::limits::{self, Work};
use crate::stats::Stats;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// A ray-cast G-buffer in row-major order (row 0 is the top of the image).
#[derive(Debug, Clone, PartialEq)]
pub struct GBuffer {
    pub width: usize,
    pub height: usize,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub mask: Vec<bool>,
    pub face_ids: Vec<i64>,
    pub msaa: usize,
    pub sample_depths: Vec<f32>,
}

/// The standard D3D11 sample positions in 1/16 pixel, relative to the pixel center (y down).
const D3D_2: [(i8, i8); 2] = [(4, 4), (-4, -4)];
const D3D_4: [(i8, i8); 4] = [(-2, -6), (6, -2), (-6, 2), (2, 6)];
const D3D_8: [(i8, i8); 8] = [
    (1, -3),
    (-1, 3),
    (5, 1),
    (-3, -5),
    (-5, 5),
    (-7, -1),
    (3, 7),
    (7, -7),
];
#[rustfmt::skip]
const D3D_16: [(i8, i8); 16] = [
    (1, 1), (-1, -3), (-3, 2), (4, -1), (-5, -2), (2, 5), (5, 3), (3, -5),
    (-2, 6), (0, -7), (-4, -6), (-6, 4), (-8, 0), (7, -4), (6, 7), (-7, -8),
];

/// The sample offsets (in pixels, from the pixel center) of `msaa` in {1, 2, 4, 8, 16}.
pub fn msaa_offsets(msaa: usize) -> Result<Vec<Vec2>> {
    let table: &[(i8, i8)] = match msaa {
        1 => &[(0, 0)],
        2 => &D3D_2,
        4 => &D3D_4,
        8 => &D3D_8,
        16 => &D3D_16,
        _ => {
            return Err(Error::invalid(
                "msaa",
                format!("expected 1, 2, 4, 8 or 16, got {msaa}"),
            ))
        }
    };
    Ok(table
        .iter()
        .map(|&(x, y)| Vec2::new(x as f32, y as f32) / 16.0)
        .collect())
}

/// The vertices of global face `id`.
fn face_vertices(scene: &Scene, id: u32) -> [Vec3; 3] {
    let r = scene.face_ref(id);
    let m = &scene.meshes[r.mesh as usize];
    m.faces[r.face as usize].map(|k| m.positions[k as usize])
}

/// One pixel's G-buffer entry.
#[derive(Debug, Clone, Copy)]
struct Texel {
    position: Vec3,
    normal: Vec3,
    face: i64,
}

const MISS: Texel = Texel {
    position: Vec3::ZERO,
    normal: Vec3::ZERO,
    face: -1,
};

/// Casts the primary ray of continuous pixel `(px, py)`.
fn cast(scene: &Scene, bvh: &Bvh, camera: &Camera, px: f32, py: f32) -> Texel {
    let dir = camera.ray(px, py);
    let Some(hit) = bvh.intersect(scene, camera.eye, dir, f32::INFINITY) else {
        return MISS;
    };
    let [a, b, c] = face_vertices(scene, hit.face);
    let position = a * (1.0 - hit.b1 - hit.b2) + b * hit.b1 + c * hit.b2;
    let n = (b - a).cross(c - a).normalize_or_zero();
    let n = if n == Vec3::ZERO { -dir } else { n };
    let normal = if n.dot(dir) > 0.0 { -n } else { n };
    Texel {
        position,
        normal,
        face: i64::from(hit.face),
    }
}

/// Ray-casts the G-buffer of `camera` (see the module doc); `msaa` in {1, 2, 4, 8, 16}.
pub fn gbuffer(scene: &Scene, bvh: &Bvh, camera: &Camera, msaa: usize) -> Result<GBuffer> {
    let offsets = msaa_offsets(msaa)?;
    bvh.check_scene(scene)?;
    let (w, h) = (camera.width, camera.height);
    let n = w
        .checked_mul(h)
        .ok_or_else(|| Error::invalid("width", format!("{w} x {h} pixels overflow")))?;
    // The output arrays (33 bytes) and the per-pixel hits collected first (32 bytes).
    let per_pixel = 33 + 32 + if msaa > 1 { 4 * msaa as u64 } else { 0 };
    limits::check_memory("G-buffer", limits::bytes(&[n as u64, per_pixel]))?;
    let rays_per_pixel = 1 + if msaa > 1 { msaa as u64 } else { 0 };
    Work::default()
        .loop_of(&[n as u64, rays_per_pixel, Work::RAY])
        .check("gbuffer", &mut Stats::default())?;
    let texels: Vec<Texel> = interrupt::par_map(n, Work::RAY, |i| {
        cast(
            scene,
            bvh,
            camera,
            (i % w) as f32 + 0.5,
            (i / w) as f32 + 0.5,
        )
    })?;
    let sample_depths = if msaa > 1 {
        depths(scene, bvh, camera, &offsets)?
    } else {
        Vec::new()
    };
    Ok(GBuffer {
        width: w,
        height: h,
        positions: texels.iter().map(|t| t.position).collect(),
        normals: texels.iter().map(|t| t.normal).collect(),
        mask: texels.iter().map(|t| t.face >= 0).collect(),
        face_ids: texels.iter().map(|t| t.face).collect(),
        msaa,
        sample_depths,
    })
}

/// Hit distances of every pixel's MSAA samples, `+inf` for no hit.
fn depths(scene: &Scene, bvh: &Bvh, camera: &Camera, offsets: &[Vec2]) -> Result<Vec<f32>> {
    let (w, m) = (camera.width, offsets.len());
    let mut out = vec![f32::INFINITY; camera.width * camera.height * m];
    interrupt::rounds(
        &mut out,
        interrupt::round_len(m, Work::RAY),
        |offset, part| {
            part.par_chunks_mut(m).enumerate().for_each(|(k, px)| {
                let i = offset / m + k;
                let center = Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                for (d, o) in px.iter_mut().zip(offsets) {
                    let p = center + *o;
                    let dir = camera.ray(p.x, p.y);
                    *d = bvh
                        .intersect(scene, camera.eye, dir, f32::INFINITY)
                        .map_or(f32::INFINITY, |h| h.t);
                }
            })
        },
    )?;
    Ok(out)
}

impl GBuffer {
    /// The hit pixels as receivers (no-hit pixels are invalid and get visibility 0).
    pub fn receivers(&self) -> Result<Receivers> {
        Receivers::new(
            self.positions.clone(),
            self.normals.clone(),
            self.mask.clone(),
            self.width,
            self.height,
        )
    }
}
