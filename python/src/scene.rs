//! `tetsim.Scene`: a validated scene, from a TOML file or from Python values with the same keys.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::errors::{LibResult, Origin, argument, from_lib};

/// A scene: the mesh, material, boundary conditions, solver and output settings of a run, with
/// every value checked (SPEC §10; docs/scene-reference.md lists every key).
///
/// Make one with Scene.load(path), Scene.from_dict(d) or Scene.default(). A scene is
/// immutable: change a copy with scene.to_dict() and Scene.from_dict().
#[pyclass(module = "tetsim", frozen)]
pub struct Scene {
    pub inner: tetsim::Scene,
    /// Whether the text came from Python values (error lines then mean nothing to the caller).
    pub origin: Origin,
}

#[pymethods]
impl Scene {
    /// Read and check a scene file (TOML). Relative paths in it are relative to its folder.
    ///
    /// Raises tetsim.Error naming the file, line and key of the first bad value.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Scene> {
        Ok(Scene {
            inner: tetsim::Scene::load(&path).py()?,
            origin: Origin::File,
        })
    }

    /// A scene from Python values with the TOML keys: dicts for tables, lists of dicts for
    /// [[fixed]], [[load]], [[volume]], [[obstacle]]; numbers, strings, bools, lists, paths and
    /// numpy arrays for values. Relative paths are relative to base_dir (default: the current
    /// folder).
    ///
    /// Example: Scene.from_dict({"mesh": {"generator": {"box": {"min": [0, 0, 0],
    /// "max": [4, 1, 1], "cells": [8, 2, 2]}}}, "fixed": [{"region": {"physical": "xmin"}}],
    /// "solver": {"frames": 10}})
    ///
    /// Raises tetsim.Error whose key names the bad key (e.g. 'solver.frobnicate').
    #[staticmethod]
    #[pyo3(signature = (values, base_dir=None))]
    fn from_dict(values: &Bound<'_, PyDict>, base_dir: Option<PathBuf>) -> PyResult<Scene> {
        let table = match to_toml(values.as_any(), &mut Vec::new())? {
            toml::Value::Table(t) => t,
            _ => unreachable!("a dict converts to a table"),
        };
        let text = toml::to_string(&table).map_err(|e| argument("scene", e))?;
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let inner = tetsim::Scene::parse(&text, Path::new("<dict>"), &base)
            .map_err(|e| from_lib(e, Origin::Values))?;
        Ok(Scene {
            inner,
            origin: Origin::Values,
        })
    }

    /// The built-in default scene (what `tetsim run` runs without a scene file).
    #[staticmethod]
    fn default() -> Scene {
        Scene {
            inner: tetsim::Scene::default(),
            origin: Origin::File,
        }
    }

    /// Every key with its value, defaults filled in, as nested dicts and lists (from_dict takes
    /// it back).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let value = toml::Value::try_from(&self.inner).map_err(|e| argument("scene", e))?;
        from_toml(py, &value)
    }

    /// The scene file ('<dict>' for Scene.from_dict, '<built-in default scene>').
    #[getter]
    fn path(&self) -> String {
        self.inner.path.display().to_string()
    }

    /// The scene's TOML text.
    #[getter]
    fn source(&self) -> &str {
        self.inner.source()
    }

    /// Frames (backward Euler) or load steps (quasistatic) of the run.
    #[getter]
    fn frames(&self) -> usize {
        self.inner.solver.frames
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(path={:?}, frames={})",
            self.inner.path.display().to_string(),
            self.inner.solver.frames
        )
    }
}

/// A Python value as TOML; `at` is the key path so far, for messages.
fn to_toml(obj: &Bound<'_, PyAny>, at: &mut Vec<String>) -> PyResult<toml::Value> {
    let here = |at: &[String]| {
        if at.is_empty() {
            "scene".to_string()
        } else {
            at.join(".")
        }
    };
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return match obj.extract::<i64>() {
            Ok(i) => Ok(toml::Value::Integer(i)),
            Err(_) => Err(argument(&here(at), "integer too large for a scene value")),
        };
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(obj.extract()?));
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in dict.iter() {
            let Ok(k) = k.extract::<String>() else {
                return Err(argument(&here(at), "keys must be strings"));
            };
            at.push(k.clone());
            let value = to_toml(&v, at)?;
            at.pop();
            table.insert(k, value);
        }
        return Ok(toml::Value::Table(table));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, item) in obj.try_iter()?.enumerate() {
            at.push(format!("[{i}]"));
            items.push(to_toml(&item?, at)?);
            at.pop();
        }
        return Ok(toml::Value::Array(items));
    }
    if obj.is_none() {
        return Err(argument(
            &here(at),
            "None is not a scene value (leave the key out for its default)",
        ));
    }
    // Paths, then numpy arrays and scalars (tolist gives Python numbers and lists).
    if let Ok(path) = obj.extract::<PathBuf>() {
        return Ok(toml::Value::String(path.display().to_string()));
    }
    if obj.hasattr("tolist")? {
        return to_toml(&obj.call_method0("tolist")?, at);
    }
    Err(argument(
        &here(at),
        format!(
            "a {} is not a scene value (use numbers, strings, bools, lists and dicts)",
            obj.get_type().name()?
        ),
    ))
}

/// TOML as Python values.
fn from_toml<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(from_toml(py, item)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(table) => {
            let dict = PyDict::new(py);
            for (k, v) in table {
                dict.set_item(k, from_toml(py, v)?)?;
            }
            dict.into_any()
        }
    })
}
