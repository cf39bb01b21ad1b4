//! The method entry points: each converts its options, runs the core method with the GIL
//! released and returns `(visibility (N,), stats dict)`.

use crate::error::OrRaise;
use crate::spelling::{choice, Spelling};
use crate::temporal::{temporal_options, NativeHistory};
use crate::{NativeCamera, NativeLight, NativeReceivers, NativeSamples, NativeScene};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softshadows_core::backend::Backend;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::geometry::mesh::Scene;
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::influence::ObjectOptions;
use softshadows_core::light::envmap::{fit_area_lights as fit_core, texel_solid_angle, FitOptions};
use softshadows_core::light::lights::Light;
use softshadows_core::light::sampling::SampleSet;
use softshadows_core::methods::alias_free::{
    alias_free as alias_free_core, AliasFreeOptions, TableSize,
};
use softshadows_core::methods::backprojection::{
    backprojection_levels, Acceleration, Accumulation, BackprojectionOptions, Budget, Occluder,
};
use softshadows_core::methods::cssm::{cssm as cssm_core, CssmOptions, Prefilter};
use softshadows_core::methods::dcs::dcs as dcs_core;
use softshadows_core::methods::denoised::{denoised as denoised_core, DenoisedOptions};
use softshadows_core::methods::mvr::{mvr as mvr_core, MultiViewOptions};
use softshadows_core::methods::pcss::{pcss as pcss_core, PcssOptions};
use softshadows_core::methods::penumbra_wedge::penumbra_wedge as penumbra_wedge_core;
use softshadows_core::methods::ray_traced::{ray_traced as ray_traced_core, RayTracedOptions};
use softshadows_core::methods::shadow_map::{shadow_map as shadow_map_core, ShadowMapOptions};
use softshadows_core::methods::stsv::{
    stsv as stsv_core, stsv_volumes as stsv_volumes_core, Opaque, StsvOptions,
};
use softshadows_core::methods::vwss::{
    vwss as vwss_core, Mode, Parallel, Precision, SourceView, VwssOptions,
};
use softshadows_core::methods::CasterFaces;
use softshadows_core::Result as CoreResult;
use softshadows_core::Stats;

type Output<'py> = (Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>);

/// `stats` as a Python dict, in their order.
pub fn stats_dict(py: Python<'_>, stats: Stats) -> PyResult<Bound<'_, PyDict>> {
    let dict = PyDict::new(py);
    for (name, value) in stats.entries {
        dict.set_item(name, value)?;
    }
    Ok(dict)
}

fn output<'py>(py: Python<'py>, (vis, stats): (Vec<f32>, Stats)) -> PyResult<Output<'py>> {
    Ok((vis.into_pyarray(py), stats_dict(py, stats)?))
}

/// Exact sampled visibility by BVH shadow rays (the oracle).
#[pyfunction]
fn ray_traced<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    epsilon: f32,
    caster_faces: Spelling<CasterFaces>,
) -> PyResult<Output<'py>> {
    let opts = RayTracedOptions {
        epsilon,
        caster_faces: caster_faces.0,
    };
    let bvh = scene.bvh(py)?;
    let out = crate::threads::detached(py, || {
        ray_traced_core(
            &scene.scene,
            bvh,
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// The denoised visibility `(N,)`, the temporal stage's accumulation and history lengths
/// `(N,)` each, and the stats.
type DenoisedOutput<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyDict>,
);

/// A few stochastic shadow rays per pixel and a penumbra-aware spatio-temporal denoiser; the
/// temporal stage runs when `temporal` (on `history`, None for a sequence's first frame).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn denoised<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    camera: &NativeCamera,
    spp: usize,
    seed: u64,
    frame: u64,
    epsilon: f32,
    search_radius: usize,
    max_radius: usize,
    sigma_z: f32,
    sigma_n: f32,
    temporal: bool,
    history: Option<&NativeHistory>,
    alpha: f32,
    depth_tolerance: f32,
    normal_tolerance: f32,
) -> PyResult<DenoisedOutput<'py>> {
    let opts = DenoisedOptions {
        spp,
        seed,
        frame,
        epsilon,
        search_radius,
        max_radius,
        sigma_z,
        sigma_n,
        temporal: temporal.then(|| temporal_options(alpha, depth_tolerance, normal_tolerance)),
    };
    let bvh = scene.bvh(py)?;
    let previous = history.map(NativeHistory::previous);
    let (out, stats) = crate::threads::detached(py, || {
        denoised_core(
            &scene.scene,
            bvh,
            &light.light,
            &receivers.receivers,
            &camera.camera,
            previous.as_ref(),
            &opts,
        )
    })?;
    Ok((
        out.visibility.into_pyarray(py),
        out.accumulated.visibility.into_pyarray(py),
        out.accumulated.length.into_pyarray(py),
        stats_dict(py, stats)?,
    ))
}

/// Hard shadows from one depth map with bias and PCF.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn shadow_map<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    resolution: usize,
    bias: Option<f32>,
    pcf: usize,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let opts = ShadowMapOptions {
        resolution,
        bias,
        pcf,
        frustum: None,
        backend: backend.0,
    };
    let out = crate::threads::detached(py, || {
        shadow_map_core(&scene.scene, &light.light, &receivers.receivers, &opts)
    })?;
    output(py, out)
}

/// Multi-view rasterization: one rasterized depth map per light sample.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn mvr<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    resolution: usize,
    pcf: usize,
    bias: Option<f32>,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let opts = MultiViewOptions {
        resolution,
        pcf,
        bias,
        backend: backend.0,
    };
    let out = crate::threads::detached(py, || {
        mvr_core(
            &scene.scene,
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// View-warped soft shadows: one source rasterization warped into every light sample's map.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn vwss<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    resolution: usize,
    pcf: usize,
    bias: Option<f32>,
    mode: Spelling<Mode>,
    parallel: Spelling<Parallel>,
    views_per_pass: usize,
    cull_backfaces: bool,
    layered: bool,
    precision: Spelling<Precision>,
    source_view: Spelling<SourceView>,
    point_density: f32,
    source_resolution: Option<usize>,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let opts = VwssOptions {
        multiview: MultiViewOptions {
            resolution,
            pcf,
            bias,
            backend: backend.0,
        },
        mode: mode.0,
        parallel: parallel.0,
        views_per_pass,
        cull_backfaces,
        layered,
        precision: precision.0,
        source_view: source_view.0,
        point_density,
        source_resolution,
    };
    let out = crate::threads::detached(py, || {
        vwss_core(
            &scene.scene,
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// Percentage-closer soft shadows from one light-center depth map.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn pcss<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    resolution: usize,
    blocker_samples: usize,
    filter_samples: usize,
    bias: Option<f32>,
    near: Option<f32>,
    seed: u64,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let opts = PcssOptions {
        resolution,
        blocker_samples,
        filter_samples,
        bias,
        near,
        seed,
        backend: backend.0,
    };
    let out = crate::threads::detached(py, || {
        pcss_core(&scene.scene, &light.light, &receivers.receivers, &opts)
    })?;
    output(py, out)
}

/// Convolution soft shadow maps (CSM with CSM-Z average blocker depth).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn cssm<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    resolution: usize,
    order: usize,
    prefilter: Spelling<Prefilter>,
    near: Option<f32>,
    offset: Option<f32>,
    scale: f32,
    sharpen_a: f32,
    sharpen_b: f32,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let opts = CssmOptions {
        resolution,
        order,
        prefilter: prefilter.0,
        near,
        offset,
        scale,
        sharpen_a,
        sharpen_b,
        backend: backend.0,
    };
    let out = crate::threads::detached(py, || {
        cssm_core(&scene.scene, &light.light, &receivers.receivers, &opts)
    })?;
    output(py, out)
}

/// One fitted environment light: `(face, i0, i1, j0, j1, (r, g, b) energy)`.
type FittedTuple = (usize, usize, usize, usize, usize, (f64, f64, f64));

/// Greedy area-light fit of a (6, n, n, 3) float32 cube map.
#[pyfunction]
fn fit_area_lights(
    py: Python<'_>,
    cube: PyReadonlyArrayDyn<'_, f32>,
    n: usize,
    threshold: f64,
    max_lights: Option<usize>,
    square: bool,
) -> PyResult<Vec<FittedTuple>> {
    let values = cube
        .as_slice()
        .map_err(|_| pyo3::exceptions::PyValueError::new_err("env: expected a contiguous array"))?;
    let opts = FitOptions {
        threshold,
        max_lights,
        square,
    };
    let lights = crate::threads::detached(py, || fit_core(values, n, &opts))?;
    Ok(lights
        .into_iter()
        .map(|l| {
            (
                l.face,
                l.i0,
                l.i1,
                l.j0,
                l.j1,
                (l.energy[0], l.energy[1], l.energy[2]),
            )
        })
        .collect())
}

/// Solid angles (n, n) of the texels of an n x n cube face, steradians.
#[pyfunction]
fn cube_solid_angles(py: Python<'_>, n: usize) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let values: Vec<f64> = (0..n * n)
        .map(|k| texel_solid_angle(n, k / n.max(1), k % n.max(1)))
        .collect();
    values.into_pyarray(py).reshape([n, n])
}

/// Sample-based visibility by alias-free shadow maps (hard for point lights, bitmasks otherwise).
/// `alias_free`'s `lut=`: bins per parameter, or a name (`"auto"`).
#[derive(FromPyObject)]
enum LutArg {
    Bins(usize),
    Named(String),
}

#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn alias_free<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    resolution: usize,
    caster_faces: Spelling<CasterFaces>,
    bias: f32,
    lut: Option<LutArg>,
    hull_degree: usize,
    restrict_to_penumbra: bool,
    cut_at_supporting_plane: bool,
    backend: Spelling<Backend>,
) -> PyResult<Output<'py>> {
    let lut = match lut {
        None => TableSize::Exact,
        Some(LutArg::Bins(bins)) => TableSize::Bins(bins),
        Some(LutArg::Named(name)) => {
            choice("lut", &name, &[("auto", TableSize::FromSamples)]).or_raise()?
        }
    };
    let opts = AliasFreeOptions {
        resolution,
        caster_faces: caster_faces.0,
        bias,
        lut,
        hull_degree,
        restrict_to_penumbra,
        cut_at_supporting_plane,
        backend: backend.0,
    };
    let out = crate::threads::detached(py, || {
        alias_free_core(
            &scene.scene,
            scene.lazy_bvh(),
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// The signature of the object-based methods of the core.
type ObjectMethod = fn(
    &Scene,
    &Bvh,
    &Light,
    &Receivers,
    &SampleSet,
    &ObjectOptions,
) -> CoreResult<(Vec<f32>, Stats)>;

/// Runs an object-based method with the GIL released.
#[allow(clippy::too_many_arguments)]
fn object_method<'py>(
    py: Python<'py>,
    method: ObjectMethod,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    (epsilon, resolution, hull_degree): (f32, usize, usize),
) -> PyResult<Output<'py>> {
    let opts = ObjectOptions {
        epsilon,
        resolution,
        hull_degree,
    };
    let bvh = scene.bvh(py)?;
    let out = crate::threads::detached(py, || {
        method(
            &scene.scene,
            bvh,
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// Depth complexity sampling on the opaque meshes (exact counts per light sample).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn dcs<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    epsilon: f32,
    resolution: usize,
    hull_degree: usize,
) -> PyResult<Output<'py>> {
    object_method(
        py,
        dcs_core,
        scene,
        light,
        receivers,
        samples,
        (epsilon, resolution, hull_degree),
    )
}

/// Soft shadow volumes with penumbra wedges on the opaque meshes (approximate).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn penumbra_wedge<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    epsilon: f32,
    resolution: usize,
    hull_degree: usize,
) -> PyResult<Output<'py>> {
    object_method(
        py,
        penumbra_wedge_core,
        scene,
        light,
        receivers,
        samples,
        (epsilon, resolution, hull_degree),
    )
}

/// Soft textured shadow volumes for the perforated meshes, with `opaque` for the others.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn stsv<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    samples: &NativeSamples,
    epsilon: f32,
    resolution: usize,
    hull_degree: usize,
    opaque: Spelling<Opaque>,
    two_sided: bool,
) -> PyResult<Output<'py>> {
    let opts = StsvOptions {
        object: ObjectOptions {
            epsilon,
            resolution,
            hull_degree,
        },
        opaque: opaque.0,
        two_sided,
    };
    let bvh = scene.bvh(py)?;
    let out = crate::threads::detached(py, || {
        stsv_core(
            &scene.scene,
            bvh,
            &light.light,
            &receivers.receivers,
            &samples.samples,
            &opts,
        )
    })?;
    output(py, out)
}

/// Face ids (V,) and corners (6 V, 3) of closed volumes.
type Volumes<'py> = (Bound<'py, PyArray1<u32>>, Bound<'py, PyArray2<f32>>);

/// The closed soft textured shadow volumes: face ids (V,) and corners (6 V, 3).
#[pyfunction]
fn stsv_volumes<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    hull_degree: usize,
    two_sided: bool,
) -> PyResult<Volumes<'py>> {
    let rx = &receivers.receivers;
    let points: Vec<_> = rx
        .points
        .iter()
        .zip(&rx.valid)
        .filter(|(_, &v)| v)
        .map(|(p, _)| *p)
        .collect();
    let volumes = crate::threads::detached(py, || {
        stsv_volumes_core(&scene.scene, &light.light, hull_degree, two_sided, &points)
    })?;
    let ids: Vec<u32> = volumes.iter().map(|(id, _)| *id).collect();
    let corners: Vec<f32> = volumes
        .iter()
        .flat_map(|(_, c)| c.iter().flat_map(|p| p.to_array()))
        .collect();
    Ok((
        ids.into_pyarray(py),
        corners.into_pyarray(py).reshape([volumes.len() * 6, 3])?,
    ))
}

/// Visibility (N,), LOQ levels (N,), micro-occluders processed (N,) and stats.
type LevelsOutput<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyDict>,
);

/// Backprojection soft shadow mapping with micro-occluders, budgets and LOQ blending.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn backprojection<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    resolution: usize,
    occluder: &str,
    extend: bool,
    accumulation: &str,
    bitmask_side: usize,
    accel: &str,
    ysm_resolution: usize,
    budget: Option<Vec<f32>>,
    level: Option<usize>,
    blend: bool,
    smoothing: usize,
    bias: Option<f32>,
) -> PyResult<LevelsOutput<'py>> {
    let occluder = choice(
        "occluder",
        occluder,
        &[
            ("micropatch", Occluder::Micropatch { extend }),
            ("microquad", Occluder::Microquad),
            ("microrect", Occluder::Microrect),
        ],
    )
    .or_raise()?;
    let accumulation = choice(
        "accumulation",
        accumulation,
        &[
            ("area", Accumulation::Area),
            ("bitmask", Accumulation::Bitmask { side: bitmask_side }),
        ],
    )
    .or_raise()?;
    let acceleration = choice(
        "accel",
        accel,
        &[
            ("hsm", Acceleration::Hsm),
            ("mssm", Acceleration::Mssm),
            (
                "ysm",
                Acceleration::Ysm {
                    resolution: ysm_resolution,
                },
            ),
        ],
    )
    .or_raise()?;
    let budget = match budget {
        None => Budget::Infinite,
        Some(b) if b.len() == 1 => Budget::Uniform(b[0]),
        Some(b) => Budget::Map(b),
    };
    let opts = BackprojectionOptions {
        resolution,
        occluder,
        accumulation,
        acceleration,
        budget,
        level,
        blend,
        smoothing,
        bias,
    };
    let out = crate::threads::detached(py, || {
        backprojection_levels(&scene.scene, &light.light, &receivers.receivers, &opts)
    })?;
    let (vis, stats) = output(py, (out.visibility, out.stats))?;
    Ok((
        vis,
        out.levels.into_pyarray(py),
        out.processed.into_pyarray(py),
        stats,
    ))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(backprojection, m)?)?;
    m.add_function(wrap_pyfunction!(stsv_volumes, m)?)?;
    m.add_function(wrap_pyfunction!(stsv, m)?)?;
    m.add_function(wrap_pyfunction!(dcs, m)?)?;
    m.add_function(wrap_pyfunction!(penumbra_wedge, m)?)?;
    m.add_function(wrap_pyfunction!(ray_traced, m)?)?;
    m.add_function(wrap_pyfunction!(denoised, m)?)?;
    m.add_function(wrap_pyfunction!(shadow_map, m)?)?;
    m.add_function(wrap_pyfunction!(mvr, m)?)?;
    m.add_function(wrap_pyfunction!(vwss, m)?)?;
    m.add_function(wrap_pyfunction!(pcss, m)?)?;
    m.add_function(wrap_pyfunction!(cssm, m)?)?;
    m.add_function(wrap_pyfunction!(alias_free, m)?)?;
    m.add_function(wrap_pyfunction!(fit_area_lights, m)?)?;
    m.add_function(wrap_pyfunction!(cube_solid_angles, m)?)?;
    Ok(())
}
