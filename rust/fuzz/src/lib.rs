//! The one input decoder shared by every fuzz target of softshadows-core.
//!
//! libFuzzer's bytes become, through `arbitrary`, a [`FuzzScene`] (meshes, a light, receivers and
//! a light-sample choice) and, per target, one of the option structs below. Everything is kept
//! small so that one execution takes well under a millisecond: at most [`MAX_MESHES`] meshes and
//! [`MAX_TRIANGLES`] triangles, [`MAX_RECEIVERS`] receivers, [`MAX_SAMPLES`] samples per pattern,
//! map sides up to [`MAX_MAP`]. Numbers come from [`Num`], which favours the values that break
//! geometry code (zero, signed zero, tiny, subnormal, huge, `f32::MAX`, NaN, infinities) next to
//! small grid values that make ordinary, shadow-casting scenes. Geometry can be degenerate or
//! duplicated, alpha textures of any size (0x0 included) with uvs far outside [0, 1], lights of
//! zero, negative or huge size placed anywhere (at a vertex, inside a box), receivers exactly on
//! surfaces, at the light, with zero normals or flagged invalid.
//!
//! Only inputs the Python API can produce are built: every value goes through the core's own
//! validating constructors (`Mesh::new`, `Light::rect`, `Receivers::new`, ...), exactly as
//! `rust/py` does; a constructor error ends the execution (nothing to check).

// The core's option structs grow fields (e.g. a backend): targets set the fuzzed ones and
// default the rest, which clippy calls needless while no field is left over.
#![allow(clippy::needless_update)]

use arbitrary::Arbitrary;
use glam::{Mat3, Vec2, Vec3};
use softshadows_core::geometry::mesh::{AlphaTexture, Mesh, Scene};
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::light::lights::{tangent_frame, EmissionTexture, Light};
use softshadows_core::light::sampling::{Pattern, SampleSet};
use softshadows_core::methods::alias_free::{AliasFreeOptions, TableSize};
use softshadows_core::methods::CasterFaces;
use softshadows_core::methods::backprojection::{Acceleration, Accumulation, BackprojectionOptions, Budget, Occluder};
use softshadows_core::methods::cssm::{CssmOptions, Prefilter};
use softshadows_core::light::envmap::FitOptions;
use softshadows_core::methods::mvr::MultiViewOptions;
use softshadows_core::methods::pcss::PcssOptions;
use softshadows_core::methods::ray_traced::{auto_epsilon, RayTracedOptions};
use softshadows_core::methods::shadow_map::ShadowMapOptions;
use softshadows_core::methods::stsv::{Opaque, StsvOptions};
use softshadows_core::methods::vwss::{Mode, Parallel, Precision, SourceView, VwssOptions};
use softshadows_core::influence::ObjectOptions;
use softshadows_core::Result;

pub use arbitrary;

pub const MAX_MESHES: usize = 4;
pub const MAX_TRIANGLES: usize = 48;
pub const MAX_VERTICES: usize = 32;
pub const MAX_RECEIVERS: usize = 64;
pub const MAX_SAMPLES: usize = 64;
/// Largest map side (resolution option) a target passes.
pub const MAX_MAP: usize = 64;

/// Once per process: a single rayon thread (deterministic reproduction, no hand-off cost for
/// tiny inputs) and a 512 MiB core memory limit, so that an over-large estimate is refused
/// (`Error::TooLarge`) rather than hitting libFuzzer's RSS limit.
pub fn init() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = rayon::ThreadPoolBuilder::new().num_threads(1).build_global();
        softshadows_core::limits::set_memory_limit(512 << 20);
    });
}

/// Values that break geometry code.
const SPECIAL: [f32; 22] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-30,
    -1e-30,
    f32::MIN_POSITIVE,
    1e-45,
    f32::EPSILON,
    1e-7,
    1e7,
    1e20,
    -1e20,
    1e30,
    f32::MAX,
    f32::MIN,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    1e-4,
    1.0 + f32::EPSILON,
];

/// One f32: mostly small grid values, plus special values and raw bits.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Num {
    /// `k / 8`, in [-16, 16).
    Grid(i8),
    /// `k`, in [-128, 127].
    Int(i8),
    /// `k / 4096`, in [-8, 8).
    Fine(i16),
    Special(u8),
    Bits(u32),
}

impl Num {
    pub fn get(self) -> f32 {
        match self {
            Num::Grid(k) => k as f32 / 8.0,
            Num::Int(k) => k as f32,
            Num::Fine(k) => k as f32 / 4096.0,
            Num::Special(k) => SPECIAL[k as usize % SPECIAL.len()],
            Num::Bits(b) => f32::from_bits(b),
        }
    }
}

pub fn v3(v: [Num; 3]) -> Vec3 {
    Vec3::new(v[0].get(), v[1].get(), v[2].get())
}

fn opt(n: Option<Num>) -> Option<f32> {
    n.map(Num::get)
}

/// A point of the scene: explicit, at a vertex, at a face centroid, or off a face's centroid
/// along its normal (inside a box for negative distances).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Place {
    At([Num; 3]),
    Vertex(u8),
    Centroid(u8),
    OffFace { face: u8, distance: Num },
}

impl Place {
    pub fn resolve(&self, scene: &Scene) -> Vec3 {
        let tris: Vec<[Vec3; 3]> = scene.triangles().map(|(_, t)| t).collect();
        let tri = |k: u8| tris.get(k as usize % tris.len().max(1)).copied();
        match *self {
            Place::At(p) => v3(p),
            Place::Vertex(k) => tri(k / 3).map_or(Vec3::ZERO, |t| t[k as usize % 3]),
            Place::Centroid(k) => tri(k).map_or(Vec3::ZERO, |t| (t[0] + t[1] + t[2]) / 3.0),
            Place::OffFace { face, distance } => tri(face).map_or(Vec3::ZERO, |t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                (t[0] + t[1] + t[2]) / 3.0 + n * distance.get()
            }),
        }
    }
}

/// An alpha texture of 0..=8 x 0..=8 texels (0 is refused by the core), one value possibly
/// replaced by a special number (NaN is refused).
#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzAlpha {
    pub width: u8,
    pub height: u8,
    pub values: Vec<u8>,
    pub special: Option<(u8, Num)>,
}

impl FuzzAlpha {
    fn build(&self) -> Result<AlphaTexture> {
        let (w, h) = (self.width as usize % 9, self.height as usize % 9);
        let mut values: Vec<f32> =
            (0..w * h).map(|i| self.values.get(i % self.values.len().max(1)).map_or(1.0, |&v| v as f32 / 255.0)).collect();
        if let (Some((i, x)), false) = (self.special, values.is_empty()) {
            let k = i as usize % values.len();
            values[k] = x.get();
        }
        AlphaTexture::new(w, h, &values)
    }
}

/// One mesh: raw triangles, or a quad or a box of a few bytes (ordinary occluders).
#[derive(Arbitrary, Debug, Clone)]
pub enum FuzzMesh {
    Raw { vertices: Vec<[Num; 3]>, faces: Vec<[u8; 3]>, uvs: Option<Vec<[Num; 2]>>, alpha: Option<FuzzAlpha>, closed: bool },
    Quad { center: [Num; 3], u: [Num; 3], v: [Num; 3], uv_scale: Num, alpha: Option<FuzzAlpha>, closed: bool },
    Box { center: [Num; 3], half: [Num; 3], alpha: Option<FuzzAlpha>, closed: bool },
    /// A copy of an earlier mesh moved by `offset` (0: duplicate triangles).
    Copy { of: u8, offset: [Num; 3] },
}

/// The 12 outward-wound triangles of a box whose vertex `i` has the signs of bits 0, 1, 2 on
/// x, y, z: faces -x, +x, -y, +y, -z, +z.
const BOX_FACES: [[u32; 3]; 12] =
    [[0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5], [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3], [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6]];

/// A mesh before validation.
struct RawMesh {
    positions: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    uvs: Option<Vec<Vec2>>,
    alpha: Option<FuzzAlpha>,
    closed: bool,
}

impl FuzzMesh {
    fn raw(&self, earlier: &[RawMesh]) -> Option<RawMesh> {
        Some(match self {
            FuzzMesh::Raw { vertices, faces, uvs, alpha, closed } => {
                let positions: Vec<Vec3> = vertices.iter().take(MAX_VERTICES).map(|&p| v3(p)).collect();
                let n = positions.len();
                // Indices past the vertices mostly wrap; 250..=255 stay out of range (refused).
                let index = |i: u8| if (i as usize) < n || i >= 250 || n == 0 { i as u32 } else { (i as usize % n) as u32 };
                let faces = faces.iter().take(MAX_TRIANGLES).map(|f| f.map(index)).collect();
                let uvs = uvs.as_ref().map(|uv| {
                    (0..n).map(|i| uv.get(i).map_or(Vec2::ZERO, |t| Vec2::new(t[0].get(), t[1].get()))).collect()
                });
                RawMesh { positions, faces, uvs, alpha: alpha.clone(), closed: *closed }
            }
            FuzzMesh::Quad { center, u, v, uv_scale, alpha, closed } => {
                let (c, u, v, s) = (v3(*center), v3(*u), v3(*v), uv_scale.get());
                RawMesh {
                    positions: vec![c - u - v, c + u - v, c + u + v, c - u + v],
                    faces: vec![[0, 1, 2], [0, 2, 3]],
                    uvs: Some([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(a, b)| Vec2::new(a, b) * s).to_vec()),
                    alpha: alpha.clone(),
                    closed: *closed,
                }
            }
            FuzzMesh::Box { center, half, alpha, closed } => {
                let (c, h) = (v3(*center), v3(*half));
                let sign = |i: usize, b: usize| if i >> b & 1 == 1 { 1.0 } else { -1.0 };
                let positions = (0..8).map(|i| c + h * Vec3::new(sign(i, 0), sign(i, 1), sign(i, 2))).collect();
                let uvs = (0..8).map(|i| Vec2::new((i & 1) as f32, (i >> 1 & 1) as f32 + (i >> 2) as f32 * 0.5)).collect();
                RawMesh { positions, faces: BOX_FACES.to_vec(), uvs: Some(uvs), alpha: alpha.clone(), closed: *closed }
            }
            FuzzMesh::Copy { of, offset } => {
                let m = earlier.get(*of as usize % earlier.len().max(1))?;
                let d = v3(*offset);
                RawMesh {
                    positions: m.positions.iter().map(|&p| p + d).collect(),
                    faces: m.faces.clone(),
                    uvs: m.uvs.clone(),
                    alpha: m.alpha.clone(),
                    closed: m.closed,
                }
            }
        })
    }
}

/// The shape of a light; sizes may be zero, negative, huge or NaN (the core refuses some).
#[derive(Arbitrary, Debug, Clone)]
pub enum LightShape {
    Point,
    Rect { u: [Num; 3], v: [Num; 3] },
    /// A square of half side `size` facing `normal` (usually valid).
    Square { normal: [Num; 3], size: Num },
    Disk { normal: [Num; 3], radius: Num },
    Sphere { radius: Num },
    Ellipsoid { axes: [[Num; 3]; 3] },
    /// Orthogonal semi-axes: a rotation by three angles (k * pi / 64) scaled by `scales`.
    RotatedEllipsoid { angles: [i8; 3], scales: [Num; 3] },
}

/// An emission texture of 0..=4 x 0..=4 values `k / 16`, one possibly special.
#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzEmission {
    pub width: u8,
    pub height: u8,
    pub values: Vec<u8>,
    pub special: Option<(u8, Num)>,
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzLight {
    pub place: Place,
    pub shape: LightShape,
    pub emission: Option<FuzzEmission>,
}

impl FuzzLight {
    pub fn build(&self, scene: &Scene) -> Result<Light> {
        let c = self.place.resolve(scene);
        let light = match &self.shape {
            LightShape::Point => Light::point(c),
            LightShape::Rect { u, v } => Light::rect(c, v3(*u), v3(*v)),
            LightShape::Square { normal, size } => {
                let (t, b) = tangent_frame(v3(*normal).normalize());
                Light::rect(c, t * size.get(), b * size.get())
            }
            // `softshadows.DiskLight` normalizes the normal in float32 before the core sees it
            // (a huge normal becomes zero, a tiny one NaN: both refused), so the decoder does too.
            LightShape::Disk { normal, radius } => Light::disk(c, v3(*normal) / v3(*normal).length(), radius.get()),
            LightShape::Sphere { radius } => Light::sphere(c, radius.get()),
            LightShape::Ellipsoid { axes } => Light::ellipsoid(c, axes.map(v3)),
            LightShape::RotatedEllipsoid { angles, scales } => {
                let a = angles.map(|k| k as f32 * std::f32::consts::PI / 64.0);
                let r = Mat3::from_rotation_z(a[2]) * Mat3::from_rotation_y(a[1]) * Mat3::from_rotation_x(a[0]);
                Light::ellipsoid(c, [r.x_axis * scales[0].get(), r.y_axis * scales[1].get(), r.z_axis * scales[2].get()])
            }
        }?;
        match &self.emission {
            None => Ok(light),
            Some(e) => {
                let (w, h) = (e.width as usize % 5, e.height as usize % 5);
                let mut values: Vec<f32> =
                    (0..w * h).map(|i| e.values.get(i % e.values.len().max(1)).map_or(1.0, |&v| v as f32 / 16.0)).collect();
                if let (Some((i, x)), false) = (e.special, values.is_empty()) {
                    let k = i as usize % values.len();
                    values[k] = x.get();
                }
                light.with_emission(EmissionTexture::new(w, h, values)?)
            }
        }
    }
}

/// One receiver.
#[derive(Arbitrary, Debug, Clone)]
pub enum FuzzReceiver {
    Free { place: Place, normal: [Num; 3] },
    /// Exactly on a face (barycentrics `b / 255`), with its geometric normal (flipped by `back`;
    /// zero, hence refused, for a degenerate face), optionally lifted along it.
    OnFace { face: u8, b: [u8; 2], back: bool, lift: Option<Num> },
    AtLight { normal: [Num; 3] },
    /// Flagged invalid (a G-buffer miss), with any point and normal: must get visibility 0.
    Invalid { point: [Num; 3], normal: [Num; 3] },
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzReceivers {
    pub items: Vec<FuzzReceiver>,
    /// Grid width `1 + width % 8` (the interleaving and tiles use the pixel grid).
    pub width: u8,
}

impl FuzzReceivers {
    pub fn build(&self, scene: &Scene, light: &Light) -> Result<Receivers> {
        let tris: Vec<[Vec3; 3]> = scene.triangles().map(|(_, t)| t).collect();
        let items = &self.items[..self.items.len().min(MAX_RECEIVERS)];
        let w = (1 + self.width as usize % 8).min(items.len().max(1));
        let h = items.len() / w;
        let (mut points, mut normals, mut valid) = (Vec::new(), Vec::new(), Vec::new());
        for item in &items[..w * h] {
            let (p, n, ok) = match *item {
                FuzzReceiver::Free { place, normal } => (place.resolve(scene), v3(normal), true),
                FuzzReceiver::OnFace { face, b, back, lift } => {
                    let t = tris[face as usize % tris.len()];
                    let (b1, b2) = (b[0] as f32 / 255.0, b[1] as f32 / 255.0 * (1.0 - b[0] as f32 / 255.0));
                    let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero() * if back { -1.0 } else { 1.0 };
                    let p = t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2;
                    (p + n * lift.map_or(0.0, Num::get), n, true)
                }
                FuzzReceiver::AtLight { normal } => (light.center(), v3(normal), true),
                FuzzReceiver::Invalid { point, normal } => (v3(point), v3(normal), false),
            };
            points.push(p);
            normals.push(n);
            valid.push(ok);
        }
        Receivers::new(points, normals, valid, w, h)
    }
}

/// A light-sample point: on the light (unit-cube coordinates `k / 255`) or anywhere.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum SamplePoint {
    OnLight([u8; 3]),
    Free([Num; 3]),
}

/// How the light samples are chosen, as the Python API allows: `samples=n` with a pattern, a
/// seed, per-receiver rotation, interleaving and a frame, or explicit points.
#[derive(Arbitrary, Debug, Clone)]
pub enum FuzzSamples {
    Generate { n: u8, pattern: u8, seed: u64, interleave: u8, rotate: bool, frame: u8 },
    Explicit { points: Vec<SamplePoint>, rotate: Option<u64> },
}

pub const PATTERNS: [Pattern; 5] = [Pattern::Uniform, Pattern::Stratified, Pattern::Poisson, Pattern::Sobol, Pattern::Halton];

impl FuzzSamples {
    pub fn build(&self, light: &Light) -> Result<SampleSet> {
        match self {
            FuzzSamples::Generate { n, pattern, seed, interleave, rotate, frame } => SampleSet::generate(
                light,
                *n as usize % (MAX_SAMPLES + 1),
                PATTERNS[*pattern as usize % 5],
                *seed,
                *interleave as usize % 4,
                *rotate,
                *frame as u64,
            ),
            FuzzSamples::Explicit { points, rotate } => {
                let pts = points
                    .iter()
                    .take(MAX_SAMPLES)
                    .map(|p| match *p {
                        SamplePoint::OnLight(k) => light.map(k.map(|x| x as f32 / 255.0)),
                        SamplePoint::Free(q) => v3(q),
                    })
                    .collect();
                SampleSet::explicit(pts, *rotate)
            }
        }
    }
}

/// Everything a method takes, decoded from the fuzzer's bytes.
#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzScene {
    pub meshes: Vec<FuzzMesh>,
    pub light: FuzzLight,
    pub receivers: FuzzReceivers,
    pub samples: FuzzSamples,
}

/// The validated core inputs.
pub struct Inputs {
    pub scene: Scene,
    pub light: Light,
    pub receivers: Receivers,
}

impl FuzzScene {
    /// The scene through `Mesh::new` and `Scene::new` (at most [`MAX_TRIANGLES`] triangles).
    pub fn scene(&self) -> Result<Scene> {
        let mut raws: Vec<RawMesh> = Vec::new();
        for m in self.meshes.iter().take(MAX_MESHES) {
            if let Some(r) = m.raw(&raws) {
                raws.push(r);
            }
        }
        let mut left = MAX_TRIANGLES;
        let mut meshes = Vec::new();
        for mut r in raws {
            r.faces.truncate(left);
            left -= r.faces.len();
            let alpha = r.alpha.as_ref().map(FuzzAlpha::build).transpose()?;
            meshes.push(Mesh::new(r.positions, r.faces, r.uvs, alpha, r.closed)?);
        }
        Scene::new(meshes)
    }

    /// Scene, light and receivers; `Err` when a constructor refuses them.
    pub fn build(&self) -> Result<Inputs> {
        let scene = self.scene()?;
        let light = self.light.build(&scene)?;
        let receivers = self.receivers.build(&scene, &light)?;
        Ok(Inputs { scene, light, receivers })
    }

    pub fn sample_set(&self, light: &Light) -> Result<SampleSet> {
        self.samples.build(light)
    }
}

/// The contract of every visibility output: one value per receiver, finite, in [0, 1], and 0
/// for invalid receivers.
pub fn check_visibility(method: &str, vis: &[f32], receivers: &Receivers) {
    assert_eq!(vis.len(), receivers.len(), "{method}: one value per receiver");
    for (i, (&v, &ok)) in vis.iter().zip(&receivers.valid).enumerate() {
        assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{method}: receiver {i} has visibility {v}");
        assert!(ok || v == 0.0, "{method}: invalid receiver {i} has visibility {v}");
    }
}

/// A map side in 0..=[`MAX_MAP`] (0 is refused by the core).
pub fn side(r: u8) -> usize {
    r as usize % (MAX_MAP + 1)
}

// ---- Per-method options ------------------------------------------------------------------

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzRayTracedOptions {
    /// `None`: the default `auto_epsilon(scene)`.
    pub epsilon: Option<Num>,
    pub backfacing: bool,
}

impl FuzzRayTracedOptions {
    pub fn build(&self, scene: &Scene) -> RayTracedOptions {
        RayTracedOptions {
            epsilon: opt(self.epsilon).unwrap_or_else(|| auto_epsilon(scene) as f32),
            caster_faces: if self.backfacing { CasterFaces::Backfacing } else { CasterFaces::All },
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzShadowMapOptions {
    pub resolution: u8,
    pub bias: Option<Num>,
    pub pcf: u8,
}

impl FuzzShadowMapOptions {
    /// `frustum: None`, as the Python API always passes.
    pub fn build(&self) -> ShadowMapOptions {
        ShadowMapOptions {
            resolution: side(self.resolution),
            bias: opt(self.bias),
            pcf: self.pcf as usize % 8,
            frustum: None,
            ..ShadowMapOptions::default()
        }
    }
}

/// PCF tap counts: the valid ones (1, 5, odd squares) and some invalid ones.
const TAPS: [usize; 8] = [1, 5, 9, 25, 0, 2, 3, 49];

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzMultiViewOptions {
    pub resolution: u8,
    pub pcf: u8,
    pub bias: Option<Num>,
}

impl FuzzMultiViewOptions {
    pub fn build(&self) -> MultiViewOptions {
        MultiViewOptions {
            resolution: side(self.resolution),
            pcf: TAPS[self.pcf as usize % TAPS.len()],
            bias: opt(self.bias),
            ..MultiViewOptions::default()
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzVwssOptions {
    pub multiview: FuzzMultiViewOptions,
    pub unbuffered: bool,
    pub parallel: u8,
    pub views_per_pass: u8,
    pub cull_backfaces: bool,
    pub layered: bool,
    pub float16: bool,
    pub paper_source_view: bool,
    pub point_density: Num,
    pub source_resolution: Option<u8>,
}

impl FuzzVwssOptions {
    pub fn build(&self) -> VwssOptions {
        VwssOptions {
            multiview: self.multiview.build(),
            mode: if self.unbuffered { Mode::Unbuffered } else { Mode::Buffered },
            parallel: [Parallel::Serial, Parallel::Partial, Parallel::Full][self.parallel as usize % 3],
            views_per_pass: self.views_per_pass as usize % 10,
            cull_backfaces: self.cull_backfaces,
            layered: self.layered,
            precision: if self.float16 { Precision::Float16 } else { Precision::Float32 },
            source_view: if self.paper_source_view { SourceView::Paper } else { SourceView::Fitted },
            point_density: self.point_density.get(),
            source_resolution: self.source_resolution.map(side),
            // The CPU backend (the fuzz build has no `gpu` feature and CI no GPU).
            ..VwssOptions::default()
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzPcssOptions {
    pub resolution: u8,
    pub blocker_samples: u8,
    pub filter_samples: u8,
    pub bias: Option<Num>,
    pub near: Option<Num>,
    pub seed: u64,
}

impl FuzzPcssOptions {
    pub fn build(&self) -> PcssOptions {
        PcssOptions {
            resolution: side(self.resolution),
            blocker_samples: self.blocker_samples as usize % 65,
            filter_samples: self.filter_samples as usize % 97,
            bias: opt(self.bias),
            near: opt(self.near),
            seed: self.seed,
            ..PcssOptions::default()
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzCssmOptions {
    pub resolution: u8,
    pub order: u8,
    pub mipmap: bool,
    pub near: Option<Num>,
    pub offset: Option<Num>,
    pub scale: Option<Num>,
    pub sharpen_a: Option<Num>,
    pub sharpen_b: Option<Num>,
}

impl FuzzCssmOptions {
    pub fn build(&self) -> CssmOptions {
        CssmOptions {
            resolution: side(self.resolution),
            // 0..=17 and 65 (refused): the order sets 4M + 1 basis images, keep it small.
            order: if self.order == 255 { 65 } else { self.order as usize % 18 },
            prefilter: if self.mipmap { Prefilter::Mipmap } else { Prefilter::Sat },
            near: opt(self.near),
            offset: opt(self.offset),
            scale: opt(self.scale).unwrap_or(1.0),
            sharpen_a: opt(self.sharpen_a).unwrap_or(0.0),
            sharpen_b: opt(self.sharpen_b).unwrap_or(10.0),
            // The CPU backend (the fuzz build has no `gpu` feature and CI no GPU).
            ..CssmOptions::default()
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzAliasFreeOptions {
    pub resolution: u8,
    pub all_faces: bool,
    pub bias: Option<Num>,
    /// Raw bins (4..=256 are valid); `None`: exact tests; `Some(0)`: sized from the samples.
    pub lut: Option<u8>,
    pub hull_degree: u8,
    pub restrict_to_penumbra: bool,
    pub cut_at_supporting_plane: bool,
}

impl FuzzAliasFreeOptions {
    pub fn build(&self) -> AliasFreeOptions {
        AliasFreeOptions {
            resolution: side(self.resolution),
            caster_faces: if self.all_faces { CasterFaces::All } else { CasterFaces::Backfacing },
            bias: opt(self.bias).unwrap_or(0.0),
            lut: match self.lut {
                None => TableSize::Exact,
                Some(0) => TableSize::FromSamples,
                Some(k) => TableSize::Bins(k as usize % 70),
            },
            hull_degree: self.hull_degree as usize % 70,
            restrict_to_penumbra: self.restrict_to_penumbra,
            cut_at_supporting_plane: self.cut_at_supporting_plane,
            ..AliasFreeOptions::default()
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzObjectOptions {
    /// `None`: `auto_epsilon(scene)`, the Python default.
    pub epsilon: Option<Num>,
    pub resolution: u8,
    pub hull_degree: u8,
}

impl FuzzObjectOptions {
    pub fn build(&self, scene: &Scene) -> ObjectOptions {
        ObjectOptions {
            epsilon: opt(self.epsilon).unwrap_or_else(|| auto_epsilon(scene) as f32),
            resolution: side(self.resolution),
            hull_degree: self.hull_degree as usize % 70,
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzStsvOptions {
    pub object: FuzzObjectOptions,
    pub opaque: u8,
    pub two_sided: bool,
}

impl FuzzStsvOptions {
    pub fn build(&self, scene: &Scene) -> StsvOptions {
        StsvOptions {
            object: self.object.build(scene),
            opaque: [Opaque::Bitmask, Opaque::Dcs, Opaque::PenumbraWedge][self.opaque as usize % 3],
            two_sided: self.two_sided,
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub enum FuzzBudget {
    Infinite,
    Uniform(Num),
    /// One budget per receiver (`values` cycled; `extra` adds a value: a length mismatch).
    Map { values: Vec<Num>, extra: bool },
}

#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzBackprojectionOptions {
    pub resolution: u8,
    pub occluder: u8,
    pub bitmask_side: Option<u8>,
    pub acceleration: u8,
    pub ysm_resolution: u8,
    pub budget: FuzzBudget,
    pub level: Option<u8>,
    pub blend: bool,
    pub smoothing: u8,
    pub bias: Option<Num>,
}

impl FuzzBackprojectionOptions {
    pub fn build(&self, receivers: usize) -> BackprojectionOptions {
        BackprojectionOptions {
            resolution: side(self.resolution),
            occluder: [Occluder::Micropatch { extend: false }, Occluder::Micropatch { extend: true }, Occluder::Microquad, Occluder::Microrect]
                [self.occluder as usize % 4],
            accumulation: match self.bitmask_side {
                None => Accumulation::Area,
                Some(s) => Accumulation::Bitmask { side: s as usize % 34 },
            },
            acceleration: match self.acceleration % 3 {
                0 => Acceleration::Hsm,
                1 => Acceleration::Mssm,
                _ => Acceleration::Ysm { resolution: self.ysm_resolution as usize % 70 },
            },
            budget: match &self.budget {
                FuzzBudget::Infinite => Budget::Infinite,
                FuzzBudget::Uniform(b) => Budget::Uniform(b.get()),
                FuzzBudget::Map { values, extra } => Budget::Map(
                    (0..receivers + *extra as usize).map(|i| values.get(i % values.len().max(1)).map_or(1.0, |b| b.get())).collect(),
                ),
            },
            level: self.level.map(|l| l as usize % 10),
            blend: self.blend,
            smoothing: self.smoothing as usize % 16,
            bias: opt(self.bias),
            ..BackprojectionOptions::default()
        }
    }
}

/// A cube map of 6 x n x n RGB texels (n in 0..=6) and the fit options.
#[derive(Arbitrary, Debug, Clone)]
pub struct FuzzEnvmap {
    pub n: u8,
    /// Radiance `k / 16`, cycled over the texels.
    pub values: Vec<u8>,
    /// Replaced texel values (any number: negative, NaN, huge).
    pub special: Vec<(u16, Num)>,
    /// Hot spots: texel index and a large radiance `2^k`.
    pub hot: Vec<(u16, u8)>,
    pub length_mismatch: bool,
    pub threshold: Num,
    pub max_lights: u8,
    pub square: bool,
}

impl FuzzEnvmap {
    /// `(faces, n, options)` for `fit_area_lights`.
    pub fn build(&self) -> (Vec<f32>, usize, FitOptions) {
        let n = self.n as usize % 7;
        let len = 6 * n * n * 3 + self.length_mismatch as usize;
        let mut faces: Vec<f32> = (0..len).map(|i| self.values.get(i % self.values.len().max(1)).map_or(1.0, |&v| v as f32 / 16.0)).collect();
        if !faces.is_empty() {
            for &(i, v) in self.hot.iter().take(8) {
                let k = i as usize % faces.len();
                faces[k] = (2.0f32).powi((v % 130) as i32);
            }
            for &(i, v) in self.special.iter().take(4) {
                let k = i as usize % faces.len();
                faces[k] = v.get();
            }
        }
        let opts = FitOptions { threshold: f64::from(self.threshold.get()), max_lights: (self.max_lights < 200).then_some(self.max_lights as usize % 40), square: self.square };
        (faces, n, opts)
    }
}
