//! numpy arrays in and out: float64 and int64, C-contiguous, with an error naming the argument,
//! the shape or dtype expected and the one given (never a silent copy or cast).

use numpy::{
    PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use tetsim::math::{Mat3, Vec3};

use crate::errors::argument;

/// The shape a check expects: `None` is any length.
type Shape<'a> = &'a [Option<usize>];

fn shape_text(shape: Shape, free: &str) -> String {
    let parts: Vec<String> = shape
        .iter()
        .map(|d| d.map_or(free.to_string(), |d| d.to_string()))
        .collect();
    if parts.len() == 1 {
        format!("({},)", parts[0])
    } else {
        format!("({})", parts.join(", "))
    }
}

/// The array behind `obj`, checked for dtype `T`, C order and `shape`.
fn checked<'py, T: numpy::Element>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    dtype: &str,
    shape: Shape,
    free: &str,
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    let py = obj.py();
    let Ok(untyped) = obj.cast::<PyUntypedArray>() else {
        let given = obj.get_type().name()?;
        return Err(argument(
            name,
            format!(
                "expected a numpy array of {dtype} with shape {}, got {given} \
                 (convert with np.ascontiguousarray(x, dtype=np.{dtype}))",
                shape_text(shape, free)
            ),
        ));
    };
    let expected = numpy::dtype::<T>(py);
    if !untyped.dtype().is_equiv_to(&expected) {
        return Err(argument(
            name,
            format!(
                "expected dtype {dtype}, got {} (convert with np.asarray(x, dtype=np.{dtype}))",
                untyped.dtype().str()?
            ),
        ));
    }
    let given = untyped.shape();
    let fits = given.len() == shape.len()
        && given
            .iter()
            .zip(shape)
            .all(|(g, s)| s.is_none_or(|s| s == *g));
    if !fits {
        let given: Vec<String> = given.iter().map(usize::to_string).collect();
        let given = if given.len() == 1 {
            format!("({},)", given[0])
        } else {
            format!("({})", given.join(", "))
        };
        return Err(argument(
            name,
            format!("expected shape {}, got {given}", shape_text(shape, free)),
        ));
    }
    if !untyped.is_c_contiguous() {
        return Err(argument(
            name,
            "expected a C-contiguous array (make one with np.ascontiguousarray(x))",
        ));
    }
    Ok(obj.cast::<PyArrayDyn<T>>()?.clone())
}

/// A copy of the data of a checked array, in C order.
fn data<T: numpy::Element + Copy>(array: &Bound<'_, PyArrayDyn<T>>) -> PyResult<Vec<T>> {
    let read = array.try_readonly()?;
    Ok(read.as_slice()?.to_vec())
}

/// An (n, 3) float64 array as points (n given or any).
pub fn vec3s(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<Vec3>> {
    let array = checked::<f64>(obj, name, "float64", &[rows, Some(3)], "n")?;
    Ok(data(&array)?
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect())
}

/// A (k, 3, 3) float64 array as matrices.
pub fn mat3s(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Mat3>> {
    let array = checked::<f64>(obj, name, "float64", &[None, Some(3), Some(3)], "k")?;
    Ok(data(&array)?
        .chunks_exact(9)
        .map(Mat3::from_row_slice)
        .collect())
}

/// A (n,) int64 array.
pub fn indices(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<i64>> {
    let array = checked::<i64>(obj, name, "int64", &[None], "n")?;
    data(&array)
}

/// A (m, 4) int64 array.
pub fn tets(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[i64; 4]>> {
    let array = checked::<i64>(obj, name, "int64", &[None, Some(4)], "m")?;
    Ok(data(&array)?
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect())
}

/// A (m, 3) int64 array (triangles).
pub fn triangles(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[i64; 3]>> {
    let array = checked::<i64>(obj, name, "int64", &[None, Some(3)], "m")?;
    Ok(data(&array)?
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect())
}

/// A flat vector as a numpy array of `shape` (C order).
fn shaped<'py, T: numpy::Element>(
    py: Python<'py>,
    flat: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, flat).reshape(shape)?.into_any())
}

/// Points as an (n, 3) float64 array.
pub fn from_vec3s<'py>(py: Python<'py>, points: &[Vec3]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    shaped(py, flat, &[points.len(), 3])
}

/// Matrices as a (k, 3, 3) float64 array.
pub fn from_mat3s<'py>(py: Python<'py>, mats: &[Mat3]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = mats
        .iter()
        .flat_map(|m| (0..3).flat_map(move |i| (0..3).map(move |j| m[(i, j)])))
        .collect();
    shaped(py, flat, &[mats.len(), 3, 3])
}

/// Reals as a (k,) float64 array, or any shape.
pub fn from_reals<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    shaped(py, values, shape)
}

/// Tets as an (m, 4) int64 array.
pub fn from_tets<'py, const N: usize>(
    py: Python<'py>,
    tets: &[[usize; N]],
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = tets.iter().flatten().map(|&v| v as i64).collect();
    shaped(py, flat, &[tets.len(), N])
}

/// Indices as an (n,) int64 array.
pub fn from_indices<'py>(py: Python<'py>, ids: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = ids.iter().map(|&v| v as i64).collect();
    let n = flat.len();
    shaped(py, flat, &[n])
}
