//! The temporal accumulation of any method's visibility over a sequence: the history of the
//! previous frame as it crosses into the core, and `accumulate`.

use crate::methods::stats_dict;
use crate::{NativeCamera, NativeReceivers};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softshadows_core::geometry::camera::Camera;
use softshadows_core::temporal::{accumulate as accumulate_core, Previous, TemporalOptions};

/// The previous frame of a sequence: its camera and G-buffer, its accumulated visibility and
/// each pixel's history length, all flat in the G-buffer's pixel order.
#[pyclass(frozen, module = "softshadows._core")]
pub struct NativeHistory {
    camera: Camera,
    receivers: Py<NativeReceivers>,
    visibility: Vec<f32>,
    length: Vec<f32>,
}

#[pymethods]
impl NativeHistory {
    #[new]
    fn new(
        camera: &NativeCamera,
        receivers: Py<NativeReceivers>,
        visibility: PyReadonlyArray1<'_, f32>,
        length: PyReadonlyArray1<'_, f32>,
    ) -> Self {
        Self {
            camera: camera.camera,
            receivers,
            visibility: visibility.as_array().to_vec(),
            length: length.as_array().to_vec(),
        }
    }
}

impl NativeHistory {
    /// The core's view of this history.
    pub fn previous(&self) -> Previous<'_> {
        Previous {
            camera: &self.camera,
            receivers: &self.receivers.get().receivers,
            visibility: &self.visibility,
            length: &self.length,
        }
    }
}

/// The options of the temporal stage, as `accumulate` and `denoised` take them.
pub fn temporal_options(
    alpha: f32,
    depth_tolerance: f32,
    normal_tolerance: f32,
) -> TemporalOptions {
    TemporalOptions {
        alpha,
        depth_tolerance,
        normal_tolerance,
    }
}

/// The accumulated visibility `(N,)`, the history lengths `(N,)` and the stats.
type Accumulation<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyDict>,
);

/// Accumulates one frame's visibility `(N,)` over `receivers` with `history` (None for the first
/// frame): `(accumulated (N,), history length (N,), stats)`.
#[pyfunction]
fn accumulate<'py>(
    py: Python<'py>,
    visibility: PyReadonlyArray1<'_, f32>,
    receivers: &NativeReceivers,
    history: Option<&NativeHistory>,
    alpha: f32,
    depth_tolerance: f32,
    normal_tolerance: f32,
) -> PyResult<Accumulation<'py>> {
    let visibility = visibility.as_array().to_vec();
    let opts = temporal_options(alpha, depth_tolerance, normal_tolerance);
    let previous = history.map(NativeHistory::previous);
    let (out, stats) = crate::threads::detached(py, || {
        accumulate_core(&receivers.receivers, &visibility, previous.as_ref(), &opts)
    })?;
    Ok((
        out.visibility.into_pyarray(py),
        out.length.into_pyarray(py),
        stats_dict(py, stats)?,
    ))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeHistory>()?;
    m.add_function(wrap_pyfunction!(accumulate, m)?)?;
    let keys: Vec<&str> = softshadows_core::temporal::STATS
        .iter()
        .chain(softshadows_core::stats::COMMON)
        .copied()
        .collect();
    m.add("TEMPORAL_STATS", pyo3::types::PyTuple::new(m.py(), keys)?)?;
    Ok(())
}
