//! `softshadows._core`: the Python face of softshadows-core. Only conversion, validation and
//! error mapping live here; every algorithm is in the core crate. The native classes wrap core
//! values immutably, so concurrent calls from several Python threads are safe, and every heavy
//! call releases the GIL.

mod convert;
mod error;
mod methods;
mod spelling;
mod temporal;
mod threads;

use convert::{faces, image, vec2s, vec3, vec3s};
use error::OrRaise;
use glam::Vec3;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
};
use pyo3::prelude::*;
use softshadows_core::geometry::bvh::{Bvh, SceneBvh};
use softshadows_core::geometry::camera::Camera;
use softshadows_core::geometry::gbuffer::gbuffer;
use softshadows_core::geometry::mesh::{AlphaTexture, Mesh, Scene};
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::light::lights::{tangent_frame, EmissionTexture, Light};
use softshadows_core::light::sampling::{light_samples, Interleave, Pattern, SampleSet};
use softshadows_core::raster::cube::light_frusta;
use spelling::{Spelled, Spelling};
use std::sync::OnceLock;

/// A scene, its default shadow-ray offset and its BVH, each computed once.
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeScene {
    pub scene: Scene,
    /// Every method's default offset: a pass over all vertices, not repeated per call.
    epsilon: f64,
    /// Built on first use: image-based methods never trace rays.
    bvh: OnceLock<Bvh>,
}

impl NativeScene {
    /// The scene's BVH, built (with the GIL released) the first time it is needed.
    pub fn bvh(&self, py: Python<'_>) -> PyResult<&Bvh> {
        threads::detached(py, || self.lazy_bvh().get(&self.scene))
    }

    /// The scene's BVH kept with it, for a method that builds it only if it needs it.
    pub fn lazy_bvh(&self) -> SceneBvh<'_> {
        SceneBvh::Cached(&self.bvh)
    }
}

type MeshArgs<'py> = (
    PyReadonlyArray2<'py, f32>,
    PyReadonlyArray2<'py, u32>,
    Option<PyReadonlyArray2<'py, f32>>,
    Option<PyReadonlyArray2<'py, f32>>,
    bool,
);

fn mesh(args: MeshArgs<'_>) -> PyResult<Mesh> {
    let (vertices, f, uvs, alpha, closed) = args;
    let uvs = uvs.map(|u| vec2s("uvs", &u)).transpose()?;
    let alpha = alpha
        .map(|a| {
            let (w, h, values) = image(&a);
            AlphaTexture::new(w, h, &values)
        })
        .transpose()
        .or_raise()?;
    Mesh::new(
        vec3s("vertices", &vertices)?,
        faces(&f)?,
        uvs,
        alpha,
        closed,
    )
    .or_raise()
}

#[pymethods]
impl NativeScene {
    /// `meshes`: a list of `(vertices, faces, uvs, alpha, closed)`.
    #[new]
    fn new(meshes: Vec<MeshArgs<'_>>) -> PyResult<Self> {
        let meshes = meshes.into_iter().map(mesh).collect::<PyResult<Vec<_>>>()?;
        let scene = Scene::new(meshes).or_raise()?;
        Ok(Self {
            epsilon: softshadows_core::methods::ray_traced::auto_epsilon(&scene),
            scene,
            bvh: OnceLock::new(),
        })
    }

    #[getter]
    fn num_faces(&self) -> usize {
        self.scene.num_faces()
    }

    /// The default shadow-ray offset along the receiver normal (world units).
    #[getter]
    fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// Ray-casts a G-buffer: `(positions (N,3), normals (N,3), mask (N,), face_ids (N,), depths (N*msaa,))`.
    #[allow(clippy::type_complexity)]
    fn gbuffer<'py>(
        &self,
        py: Python<'py>,
        camera: &NativeCamera,
        msaa: usize,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let bvh = self.bvh(py)?;
        let gb = threads::detached(py, || gbuffer(&self.scene, bvh, &camera.camera, msaa))?;
        let n = gb.positions.len();
        let as2 = |v: Vec<f32>| v.into_pyarray(py).reshape([n, 3]);
        Ok((
            as2(convert::flat3(&gb.positions))?,
            as2(convert::flat3(&gb.normals))?,
            gb.mask.into_pyarray(py),
            gb.face_ids.into_pyarray(py),
            gb.sample_depths.into_pyarray(py),
        ))
    }
}

/// A light (see `softshadows.lights`).
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeLight {
    pub light: Light,
}

impl NativeLight {
    /// `light` as built, with the emission texture `emission` (H, W) when given.
    fn from(
        light: softshadows_core::Result<Light>,
        emission: Option<PyReadonlyArray2<'_, f32>>,
    ) -> PyResult<Self> {
        let light = light.or_raise()?;
        let light = match emission {
            Some(e) => {
                let (w, h, values) = image(&e);
                light
                    .with_emission(EmissionTexture::new(w, h, values).or_raise()?)
                    .or_raise()?
            }
            None => light,
        };
        Ok(Self { light })
    }
}

#[pymethods]
impl NativeLight {
    /// A point light at `center`.
    #[staticmethod]
    fn point(center: PyReadonlyArray1<'_, f32>) -> PyResult<Self> {
        Self::from(Light::point(vec3("center", &center)?), None)
    }

    /// A one-sided rectangle `center + s u + t v`, `s, t` in [-1, 1], emitting towards `u × v`.
    #[staticmethod]
    #[pyo3(signature = (center, u, v, emission=None))]
    fn rect(
        center: PyReadonlyArray1<'_, f32>,
        u: PyReadonlyArray1<'_, f32>,
        v: PyReadonlyArray1<'_, f32>,
        emission: Option<PyReadonlyArray2<'_, f32>>,
    ) -> PyResult<Self> {
        let light = Light::rect(vec3("center", &center)?, vec3("u", &u)?, vec3("v", &v)?);
        Self::from(light, emission)
    }

    /// A one-sided disk of `radius` about `center`, emitting towards `normal`.
    #[staticmethod]
    #[pyo3(signature = (center, normal, radius, emission=None))]
    fn disk(
        center: PyReadonlyArray1<'_, f32>,
        normal: PyReadonlyArray1<'_, f32>,
        radius: f32,
        emission: Option<PyReadonlyArray2<'_, f32>>,
    ) -> PyResult<Self> {
        let light = Light::disk(vec3("center", &center)?, vec3("normal", &normal)?, radius);
        Self::from(light, emission)
    }

    /// A sphere of `radius` about `center`.
    #[staticmethod]
    fn sphere(center: PyReadonlyArray1<'_, f32>, radius: f32) -> PyResult<Self> {
        Self::from(Light::sphere(vec3("center", &center)?, radius), None)
    }

    /// An ellipsoid about `center` with the rows of `axes` (3, 3) as its semi-axes.
    #[staticmethod]
    fn ellipsoid(
        center: PyReadonlyArray1<'_, f32>,
        axes: PyReadonlyArray2<'_, f32>,
    ) -> PyResult<Self> {
        let axes: [Vec3; 3] = vec3s("axes", &axes)?
            .try_into()
            .map_err(|_| pyo3::exceptions::PyValueError::new_err("axes: expected shape (3, 3)"))?;
        Self::from(Light::ellipsoid(vec3("center", &center)?, axes), None)
    }

    /// Largest distance from the center to a point of the light (world units).
    #[getter]
    fn extent(&self) -> f64 {
        self.light.extent()
    }

    /// The orthonormal `(t, b)` across the light's normal that orients its samples and its
    /// emission texture (the core's `tangent_frame`); None for a light without a plane.
    #[getter]
    fn tangent_frame(&self) -> Option<([f32; 3], [f32; 3])> {
        let (t, b) = tangent_frame(self.light.normal()?);
        Some((t.to_array(), b.to_array()))
    }

    /// `n` world-space samples of `pattern`, shape (n, 3).
    fn samples<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        pattern: Spelling<Pattern>,
        seed: u64,
        frame: u64,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let pattern = pattern.0;
        softshadows_core::limits::check_memory(
            "light samples",
            softshadows_core::limits::bytes(&[n as u64, 12]),
        )
        .or_raise()?;
        let pts = threads::detached(py, || {
            Ok(light_samples(&self.light, n, pattern, seed, frame))
        })?;
        convert::flat3(&pts).into_pyarray(py).reshape([n, 3])
    }

    /// The light frusta of the single-view image-based methods for `receivers`, shape (K, 5, 3):
    /// each frustum's eye and the four corners of its far plane.
    fn frusta<'py>(
        &self,
        py: Python<'py>,
        receivers: &NativeReceivers,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let frusta = light_frusta(&self.light, &receivers.receivers, 1).or_raise()?;
        let points: Vec<Vec3> = frusta
            .iter()
            .flat_map(|f| std::iter::once(f.eye).chain(f.far_corners()))
            .collect();
        convert::flat3(&points)
            .into_pyarray(py)
            .reshape([frusta.len(), 5, 3])
    }

    /// Emission weights of world-space light points, shape (S,).
    fn weights<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'_, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let pts = vec3s("samples", &points)?;
        Ok(pts
            .iter()
            .map(|&y| self.light.weight(y))
            .collect::<Vec<_>>()
            .into_pyarray(py))
    }
}

/// A pinhole camera.
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeCamera {
    pub camera: Camera,
}

#[pymethods]
impl NativeCamera {
    #[new]
    fn new(
        eye: PyReadonlyArray1<'_, f32>,
        target: PyReadonlyArray1<'_, f32>,
        up: PyReadonlyArray1<'_, f32>,
        fov_y: f32,
        width: usize,
        height: usize,
    ) -> PyResult<Self> {
        let camera = Camera::look_at(
            vec3("eye", &eye)?,
            vec3("target", &target)?,
            vec3("up", &up)?,
            fov_y,
            width,
            height,
        )
        .or_raise()?;
        Ok(Self { camera })
    }
}

/// Receivers: points, normals and a validity mask over a `width x height` grid.
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeReceivers {
    pub receivers: Receivers,
}

#[pymethods]
impl NativeReceivers {
    #[new]
    fn new(
        points: PyReadonlyArray2<'_, f32>,
        normals: PyReadonlyArray2<'_, f32>,
        mask: PyReadonlyArray1<'_, bool>,
        width: usize,
        height: usize,
    ) -> PyResult<Self> {
        let valid = mask.as_array().to_vec();
        let receivers = Receivers::new(
            vec3s("points", &points)?,
            vec3s("normals", &normals)?,
            valid,
            width,
            height,
        )
        .or_raise()?;
        Ok(Self { receivers })
    }
}

/// How each receiver's light samples are chosen.
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeSamples {
    pub samples: SampleSet,
}

#[pymethods]
impl NativeSamples {
    /// `n` samples of `pattern` per receiver, `interleave x interleave` patterns over the screen:
    /// only those the pixels of `receivers` use, or every one without `receivers`.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (light, n, pattern, seed, interleave, rotate, frame, receivers=None))]
    fn generate(
        py: Python<'_>,
        light: &NativeLight,
        n: usize,
        pattern: Spelling<Pattern>,
        seed: u64,
        interleave: usize,
        rotate: bool,
        frame: u64,
        receivers: Option<&NativeReceivers>,
    ) -> PyResult<Self> {
        let pattern = pattern.0;
        let tile = match receivers {
            Some(r) => Interleave::for_grid(interleave, r.receivers.width, r.receivers.height),
            None => Interleave::full(interleave),
        };
        if let Some(r) = receivers {
            SampleSet::refuse_more_pairs_than_the_work_limit(r.receivers.len(), n).or_raise()?;
        }
        let total = SampleSet::estimated_bytes(&light.light, n, pattern, tile);
        softshadows_core::limits::check_memory("light sample patterns", total).or_raise()?;
        let samples = threads::detached(py, || {
            SampleSet::generate_for(&light.light, n, pattern, seed, tile, rotate, frame)
        })?;
        Ok(Self { samples })
    }

    /// The same explicit world-space samples (S, 3) for every receiver, optionally rotated per receiver.
    #[staticmethod]
    #[pyo3(signature = (samples, rotate_seed=None))]
    fn explicit(samples: PyReadonlyArray2<'_, f32>, rotate_seed: Option<u64>) -> PyResult<Self> {
        Ok(Self {
            samples: SampleSet::explicit(vec3s("samples", &samples)?, rotate_seed).or_raise()?,
        })
    }

    #[getter]
    fn count(&self) -> usize {
        self.samples.count()
    }

    /// The number of patterns built.
    #[getter]
    fn patterns(&self) -> usize {
        self.samples.pattern_count()
    }
}

/// Sets the memory limit in bytes (0 restores the default of 75% of physical memory).
#[pyfunction]
fn set_memory_limit(bytes: u64) {
    softshadows_core::limits::set_memory_limit(bytes);
}

/// The memory limit in bytes.
#[pyfunction]
fn memory_limit() -> u64 {
    softshadows_core::limits::memory_limit()
}

/// Sets the work limit in operations (0 restores the default of 10^12).
#[pyfunction]
fn set_work_limit(operations: u64) {
    softshadows_core::limits::set_work_limit(operations);
}

/// The work limit in operations.
#[pyfunction]
fn work_limit() -> u64 {
    softshadows_core::limits::work_limit()
}

/// The GPU adapter as `(name, value)` pairs (creates the device on first use).
#[pyfunction]
fn gpu_info(py: Python<'_>) -> PyResult<Vec<(String, String)>> {
    threads::detached(py, softshadows_core::gpu::info)
}

/// `{method: (key, ...)}`: each method's stats keys as the core declares them, the common ones
/// last.
fn stats_keys(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    let table = pyo3::types::PyDict::new(py);
    for (method, own) in softshadows_core::methods::STATS {
        let keys: Vec<&str> = own
            .iter()
            .chain(softshadows_core::stats::COMMON)
            .copied()
            .collect();
        table.set_item(method, pyo3::types::PyTuple::new(py, keys)?)?;
    }
    Ok(table)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeScene>()?;
    m.add_class::<NativeLight>()?;
    m.add_class::<NativeCamera>()?;
    m.add_class::<NativeReceivers>()?;
    m.add_class::<NativeSamples>()?;
    m.add_function(wrap_pyfunction!(set_memory_limit, m)?)?;
    m.add_function(wrap_pyfunction!(memory_limit, m)?)?;
    m.add_function(wrap_pyfunction!(set_work_limit, m)?)?;
    m.add_function(wrap_pyfunction!(work_limit, m)?)?;
    m.add("WorkLimitError", m.py().get_type::<error::WorkLimitError>())?;
    m.add(
        "UnsupportedSetup",
        m.py().get_type::<error::UnsupportedSetup>(),
    )?;
    let patterns: Vec<&str> = Pattern::SPELLINGS.iter().map(|(name, _)| *name).collect();
    m.add("PATTERNS", pyo3::types::PyTuple::new(m.py(), patterns)?)?;
    m.add("STATS", stats_keys(m.py())?)?;
    m.add_function(wrap_pyfunction!(gpu_info, m)?)?;
    m.add_function(wrap_pyfunction!(threads::set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(threads::num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(threads::after_fork_in_child, m)?)?;
    methods::register(m)?;
    temporal::register(m)?;
    Ok(())
}
