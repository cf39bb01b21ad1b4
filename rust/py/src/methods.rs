//! The method entry points: each converts its options, runs the core method with the GIL
//! released and returns `(visibility (N,), stats dict)`.

use crate::error::OrRaise;
use crate::{NativeLight, NativeReceivers, NativeSamples, NativeScene};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softshadows_core::methods::ray_traced::{ray_traced as ray_traced_core, RayTracedOptions};
use softshadows_core::methods::shadow_map::{shadow_map as shadow_map_core, ShadowMapOptions};
use softshadows_core::Stats;

type Output<'py> = (Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>);

fn output<'py>(py: Python<'py>, (vis, stats): (Vec<f32>, Stats)) -> PyResult<Output<'py>> {
    let dict = PyDict::new(py);
    for (name, value) in stats.entries {
        dict.set_item(name, value)?;
    }
    Ok((vis.into_pyarray(py), dict))
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
) -> PyResult<Output<'py>> {
    let opts = RayTracedOptions { epsilon };
    let out = py
        .detach(|| ray_traced_core(&scene.scene, &scene.bvh, &light.light, &receivers.receivers, &samples.samples, &opts))
        .or_raise()?;
    output(py, out)
}

/// Hard shadows from one depth map with bias and PCF.
#[pyfunction]
fn shadow_map<'py>(
    py: Python<'py>,
    scene: &NativeScene,
    light: &NativeLight,
    receivers: &NativeReceivers,
    resolution: usize,
    bias: Option<f32>,
    pcf: usize,
) -> PyResult<Output<'py>> {
    let opts = ShadowMapOptions { resolution, bias, pcf, frustum: None };
    let out = py.detach(|| shadow_map_core(&scene.scene, &light.light, &receivers.receivers, &opts)).or_raise()?;
    output(py, out)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(ray_traced, m)?)?;
    m.add_function(wrap_pyfunction!(shadow_map, m)?)?;
    Ok(())
}
