//! numpy ↔ core conversion. Shapes are checked here (the Python layer has already converted
//! dtypes and contiguity); values are validated by the core constructors.

use glam::{Vec2, Vec3};
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::PyResult;

fn check_cols(name: &str, shape: &[usize], cols: usize) -> PyResult<()> {
    if shape.len() != 2 || shape[1] != cols {
        return Err(PyValueError::new_err(format!(
            "{name}: expected shape (N, {cols}), got {shape:?}"
        )));
    }
    Ok(())
}

fn rows<const C: usize>(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<[f32; C]>> {
    check_cols(name, a.shape(), C)?;
    let view = a.as_array();
    Ok(view
        .rows()
        .into_iter()
        .map(|r| std::array::from_fn(|k| r[k]))
        .collect())
}

/// An (N, 3) float32 array as points.
pub fn vec3s(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<Vec3>> {
    Ok(rows::<3>(name, a)?.into_iter().map(Vec3::from).collect())
}

/// An (N, 2) float32 array as uvs.
pub fn vec2s(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<Vec2>> {
    Ok(rows::<2>(name, a)?.into_iter().map(Vec2::from).collect())
}

/// An (M, 3) uint32 array as faces.
pub fn faces(a: &PyReadonlyArray2<'_, u32>) -> PyResult<Vec<[u32; 3]>> {
    check_cols("faces", a.shape(), 3)?;
    Ok(a.as_array()
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect())
}

/// A (3,) float32 array as a vector.
pub fn vec3(name: &str, a: &PyReadonlyArray1<'_, f32>) -> PyResult<Vec3> {
    let s = a
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a contiguous array")))?;
    match s {
        [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
        _ => Err(PyValueError::new_err(format!(
            "{name}: expected shape (3,), got ({},)",
            s.len()
        ))),
    }
}

/// An (H, W) float32 array as `(width, height, row-major values)`.
pub fn image(a: &PyReadonlyArray2<'_, f32>) -> (usize, usize, Vec<f32>) {
    let shape = a.shape();
    (shape[1], shape[0], a.as_array().iter().copied().collect())
}

/// Points as a flat float32 buffer of shape (N, 3).
pub fn flat3(points: &[Vec3]) -> Vec<f32> {
    points.iter().flat_map(|p| p.to_array()).collect()
}
