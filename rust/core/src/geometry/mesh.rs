//! Triangle meshes, binary alpha textures and the scene (`docs/design.md` section 2).
//!
//! A mesh with uvs and an alpha texture is *perforated*: a texel with alpha >= 0.5 is opaque.
//! `alpha[i, j]` covers u in [j/W, (j+1)/W) and v in [i/H, (i+1)/H); uvs wrap and lookups take the
//! nearest texel. Faces of all meshes are numbered globally in mesh order (the G-buffer's face ids).

use crate::error::{Error, Result};
use glam::{Vec2, Vec3};

/// A binary transmittance texture: `opaque[i * width + j]` for row `i` (v) and column `j` (u).
#[derive(Debug, Clone, PartialEq)]
pub struct AlphaTexture {
    width: usize,
    height: usize,
    opaque: Vec<bool>,
}

impl AlphaTexture {
    /// Thresholds `alpha` (row-major, `height * width` values in \[0, 1\]) at 0.5.
    pub fn new(width: usize, height: usize, alpha: &[f32]) -> Result<Self> {
        if width == 0 || height == 0 || alpha.len() != width * height {
            return Err(Error::invalid(
                "alpha",
                format!("expected a non-empty (H, W) texture with H*W values, got {height}x{width} with {} values", alpha.len()),
            ));
        }
        if alpha.iter().any(|a| !a.is_finite()) {
            return Err(Error::invalid("alpha", "contains NaN or Inf"));
        }
        Ok(Self {
            width,
            height,
            opaque: alpha.iter().map(|&a| a >= 0.5).collect(),
        })
    }

    /// Whether each texel is opaque, row-major.
    pub fn texels(&self) -> &[bool] {
        &self.opaque
    }

    /// `(height, width)`.
    pub fn shape(&self) -> (usize, usize) {
        (self.height, self.width)
    }

    /// Nearest-texel lookup with wrapping uvs.
    #[inline]
    pub fn is_opaque(&self, uv: Vec2) -> bool {
        let wrap = |t: f32, n: usize| -> usize {
            let f = t - t.floor();
            ((f * n as f32) as usize).min(n - 1)
        };
        self.opaque[wrap(uv.y, self.height) * self.width + wrap(uv.x, self.width)]
    }
}

/// One triangle mesh. Build it with [`Mesh::new`], which validates every index and value.
#[derive(Debug, Clone)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
    pub uvs: Option<Vec<Vec2>>,
    pub alpha: Option<AlphaTexture>,
    /// Two-manifold and closed: methods may let only light back-facing triangles cast.
    pub closed: bool,
}

impl Mesh {
    /// A latitude-longitude sphere of `radius` around `center`: `m` rings of `n` columns,
    /// `2 n m` triangles (those at the poles degenerate), opaque, wound so that the normal
    /// `(b - a) x (c - a)` of each points inwards; `closed` declares it closed for the methods
    /// that cull by it. The test scenes' curved occluder and receiver.
    pub fn uv_sphere(center: Vec3, radius: f32, n: u32, m: u32, closed: bool) -> Result<Self> {
        let mut positions = Vec::new();
        for i in 0..=m {
            let theta = std::f32::consts::PI * i as f32 / m as f32;
            for j in 0..=n {
                let phi = std::f32::consts::TAU * (j % n) as f32 / n as f32;
                let dir = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                positions.push(center + radius * dir);
            }
        }
        let faces = (0..m)
            .flat_map(|i| (0..n).map(move |j| i * (n + 1) + j))
            .flat_map(|a| [[a, a + n + 1, a + 1], [a + 1, a + n + 1, a + n + 2]])
            .collect();
        Self::new(positions, faces, None, None, closed)
    }

    /// Validates and builds a mesh. `uvs` and `alpha` go together (a perforated mesh).
    pub fn new(
        positions: Vec<Vec3>,
        faces: Vec<[u32; 3]>,
        uvs: Option<Vec<Vec2>>,
        alpha: Option<AlphaTexture>,
        closed: bool,
    ) -> Result<Self> {
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("vertices", "contains NaN or Inf"));
        }
        let n = positions.len() as u64;
        if let Some((i, f)) = faces
            .iter()
            .enumerate()
            .find(|(_, f)| f.iter().any(|&k| k as u64 >= n))
        {
            return Err(Error::invalid(
                "faces",
                format!("face {i} = {f:?} indexes past the {n} vertices"),
            ));
        }
        match (&uvs, &alpha) {
            (Some(uv), _) if uv.len() != positions.len() => {
                return Err(Error::invalid(
                    "uvs",
                    format!(
                        "expected one uv per vertex ({}), got {}",
                        positions.len(),
                        uv.len()
                    ),
                ))
            }
            (Some(uv), _) if uv.iter().any(|t| !t.is_finite()) => {
                return Err(Error::invalid("uvs", "contains NaN or Inf"))
            }
            (None, Some(_)) => {
                return Err(Error::invalid(
                    "uvs",
                    "an alpha texture needs per-vertex uvs",
                ))
            }
            _ => {}
        }
        Ok(Self {
            positions,
            faces,
            uvs,
            alpha,
            closed,
        })
    }

    /// Whether the mesh has an alpha texture.
    pub fn is_perforated(&self) -> bool {
        self.alpha.is_some()
    }
}

/// A set of meshes with globally numbered faces.
#[derive(Debug, Clone)]
pub struct Scene {
    pub meshes: Vec<Mesh>,
    /// `face_offsets[m]` is the global id of mesh `m`'s first face; one more entry at the end.
    face_offsets: Vec<u32>,
}

/// Where a global face id lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaceRef {
    pub mesh: u32,
    pub face: u32,
}

impl Scene {
    /// A scene of at least one face.
    pub fn new(meshes: Vec<Mesh>) -> Result<Self> {
        let mut face_offsets = Vec::with_capacity(meshes.len() + 1);
        let mut total: u64 = 0;
        for m in &meshes {
            face_offsets.push(total as u32);
            total += m.faces.len() as u64;
        }
        if total == 0 {
            return Err(Error::invalid("meshes", "the scene has no triangles"));
        }
        if total >= u32::MAX as u64 {
            return Err(Error::invalid(
                "meshes",
                format!("{total} triangles exceed the 2^32-1 face ids"),
            ));
        }
        face_offsets.push(total as u32);
        Ok(Self {
            meshes,
            face_offsets,
        })
    }

    /// Total number of triangles.
    pub fn num_faces(&self) -> usize {
        *self.face_offsets.last().unwrap_or(&0) as usize
    }

    /// The mesh and local face of global face `id` (< `num_faces()`).
    pub fn face_ref(&self, id: u32) -> FaceRef {
        let mesh = self.face_offsets.partition_point(|&o| o <= id) - 1;
        FaceRef {
            mesh: mesh as u32,
            face: id - self.face_offsets[mesh],
        }
    }

    /// The vertices of global face `id`.
    pub fn triangle(&self, id: u32) -> [Vec3; 3] {
        let r = self.face_ref(id);
        let m = &self.meshes[r.mesh as usize];
        m.faces[r.face as usize].map(|v| m.positions[v as usize])
    }

    /// All triangles as `(global id, vertices)`, in global id order.
    pub fn triangles(&self) -> impl Iterator<Item = (u32, [Vec3; 3])> + '_ {
        self.meshes
            .iter()
            .zip(&self.face_offsets)
            .flat_map(|(m, &off)| {
                m.faces.iter().enumerate().map(move |(i, f)| {
                    (
                        off + i as u32,
                        [
                            m.positions[f[0] as usize],
                            m.positions[f[1] as usize],
                            m.positions[f[2] as usize],
                        ],
                    )
                })
            })
    }

    /// Whether global face `id` is opaque at barycentrics `(b1, b2)` (weights of vertices 1 and 2):
    /// always for plain meshes, by the alpha texture for perforated ones.
    #[inline]
    pub fn is_opaque_at(&self, id: u32, b1: f32, b2: f32) -> bool {
        let r = self.face_ref(id);
        let m = &self.meshes[r.mesh as usize];
        match (&m.alpha, &m.uvs) {
            (Some(tex), Some(uvs)) => {
                let f = m.faces[r.face as usize];
                let uv = uvs[f[0] as usize] * (1.0 - b1 - b2)
                    + uvs[f[1] as usize] * b1
                    + uvs[f[2] as usize] * b2;
                tex.is_opaque(uv)
            }
            _ => true,
        }
    }

    /// Whether global face `id` belongs to a mesh flagged `closed`.
    pub fn is_closed_face(&self, id: u32) -> bool {
        self.meshes[self.face_ref(id).mesh as usize].closed
    }

    /// Whether global face `id` belongs to a perforated mesh.
    pub fn is_perforated_face(&self, id: u32) -> bool {
        self.meshes[self.face_ref(id).mesh as usize].is_perforated()
    }

    /// Axis-aligned bounds `(min, max)` over all vertices referenced by faces.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.triangles().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), (_, t)| {
                (
                    lo.min(t[0]).min(t[1]).min(t[2]),
                    hi.max(t[0]).max(t[1]).max(t[2]),
                )
            },
        )
    }
}
