//! `tetsim.Scene`: a validated scene, from a TOML file or from Python values with the same keys.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::args::{self, Signature};
use crate::errors::{Origin, argument, for_path, from_lib};

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
    #[pyo3(signature = (path=None, *extra, **unknown), text_signature = "(path)")]
    fn load(
        path: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Scene> {
        Signature {
            call: "Scene.load",
            positional: &["path"],
            keyword: &[],
        }
        .check(extra, unknown)?;
        let path = args::required(path, "path", "Scene.load", "the scene file (a str or Path)")?;
        let path = args::path(path, "path")?;
        Ok(Scene {
            inner: tetsim::Scene::load(&path)
                .map_err(|e| for_path(e, Origin::File, "path", &path))?,
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
    /// Raises tetsim.Error whose key names the bad key (e.g. 'solver.frobnicate'), also for a
    /// dict or list that contains itself or nests deeper than any scene key does.
    #[staticmethod]
    #[pyo3(
        signature = (values=None, base_dir=None, *extra, **unknown),
        text_signature = "(values, base_dir=None)"
    )]
    fn from_dict(
        values: Option<&Bound<'_, PyAny>>,
        base_dir: Option<&Bound<'_, PyAny>>,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Scene> {
        Signature {
            call: "Scene.from_dict",
            positional: &["values", "base_dir"],
            keyword: &[],
        }
        .check(extra, unknown)?;
        let what = "a dict of scene keys, e.g. {\"solver\": {\"frames\": 10}}";
        let values = args::required(values, "values", "Scene.from_dict", what)?;
        if !values.is_instance_of::<PyDict>() {
            return Err(argument(
                "values",
                format!("expected {what}, got {}", args::describe(values)),
            ));
        }
        let base = args::optional_path(base_dir, "base_dir")?;
        let table = match Walk::default().value(values)? {
            toml::Value::Table(t) => t,
            _ => unreachable!("a dict converts to a table"),
        };
        let text = toml::to_string(&table).map_err(|e| argument("scene", e))?;
        let base = base.unwrap_or_else(|| PathBuf::from("."));
        let inner = tetsim::Scene::parse(&text, Path::new("<dict>"), &base)
            .map_err(|e| from_lib(e, Origin::Values))?;
        Ok(Scene {
            inner,
            origin: Origin::Values,
        })
    }

    /// The built-in default scene (what `tetsim run` runs without a scene file).
    #[staticmethod]
    #[pyo3(signature = (*extra, **unknown), text_signature = "()")]
    fn default(extra: &Bound<'_, PyTuple>, unknown: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
        Signature {
            call: "Scene.default",
            positional: &[],
            keyword: &[],
        }
        .check(extra, unknown)?;
        Ok(Scene {
            inner: tetsim::Scene::default(),
            origin: Origin::File,
        })
    }

    /// Every key with its value, defaults filled in, as nested dicts and lists (from_dict takes
    /// it back).
    #[pyo3(signature = (*extra, **unknown), text_signature = "($self)")]
    fn to_dict<'py>(
        &self,
        py: Python<'py>,
        extra: &Bound<'py, PyTuple>,
        unknown: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Signature {
            call: "Scene.to_dict",
            positional: &[],
            keyword: &[],
        }
        .check(extra, unknown)?;
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

/// How deep Python values may nest in a scene. The schema's deepest values sit a few levels down
/// (`obstacle[0].motion.translate[1]`); anything far deeper is a mistake, and a dict or list that
/// holds itself would otherwise be walked until the stack overflows.
const MAX_DEPTH: usize = 32;

/// The walk of Python values into TOML: where it is, for messages, and which containers it is
/// inside, to refuse one that contains itself.
#[derive(Default)]
struct Walk {
    /// The key path so far (`solver`, `dt`; `fixed`, `[0]`).
    at: Vec<String>,
    /// The containers being walked (by identity), outermost first.
    open: Vec<usize>,
}

impl Walk {
    /// The key path for messages: `solver.dt`, `fixed[0].region`, or `scene` at the top.
    fn here(&self) -> String {
        self.path(&self.at)
    }

    fn path(&self, at: &[String]) -> String {
        if at.is_empty() {
            return "scene".to_string();
        }
        let mut path = String::new();
        for segment in at {
            if !path.is_empty() && !segment.starts_with('[') {
                path.push('.');
            }
            path.push_str(segment);
        }
        path
    }

    /// Enter a container: refused when it is already open (it contains itself) or when the
    /// values nest deeper than [`MAX_DEPTH`].
    fn enter(&mut self, obj: &Bound<'_, PyAny>) -> PyResult<()> {
        let id = obj.as_ptr() as usize;
        if self.open.contains(&id) {
            return Err(argument(
                &self.here(),
                format!(
                    "this {} contains itself (it holds a reference to itself or to a value \
                     around it), which no scene value can",
                    obj.get_type().name()?
                ),
            ));
        }
        if self.open.len() >= MAX_DEPTH {
            // The key where the nesting starts, not thirty-two levels of `[0]`.
            let start = self.path(&self.at[..self.at.len().min(3)]);
            return Err(argument(
                &format!("{start}…"),
                format!(
                    "values nest more than {MAX_DEPTH} levels deep, far deeper than any scene \
                     key"
                ),
            ));
        }
        self.open.push(id);
        Ok(())
    }

    /// A Python value as TOML.
    fn value(&mut self, obj: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
        if obj.is_instance_of::<PyBool>() {
            return Ok(toml::Value::Boolean(obj.is_truthy()?));
        }
        if obj.is_instance_of::<PyInt>() {
            return match obj.extract::<i64>() {
                Ok(i) => Ok(toml::Value::Integer(i)),
                Err(_) => Err(argument(
                    &self.here(),
                    "integer too large for a scene value",
                )),
            };
        }
        if obj.is_instance_of::<PyFloat>() {
            return Ok(toml::Value::Float(obj.extract()?));
        }
        if obj.is_instance_of::<PyString>() {
            let here = self.here();
            return Ok(toml::Value::String(args::text(obj, &here, "text")?));
        }
        if let Ok(dict) = obj.cast::<PyDict>() {
            self.enter(obj)?;
            let mut table = toml::Table::new();
            // A snapshot of the items: nothing the walk calls can change what it iterates.
            for item in dict.items().iter() {
                let (k, v) = item.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>()?;
                if !k.is_instance_of::<PyString>() {
                    return Err(argument(
                        &self.here(),
                        format!("keys must be strings, got {}", args::describe(&k)),
                    ));
                }
                let here = self.here();
                let k = args::text(&k, &here, "a key")?;
                self.at.push(k.clone());
                let value = self.value(&v)?;
                self.at.pop();
                table.insert(k, value);
            }
            self.open.pop();
            return Ok(toml::Value::Table(table));
        }
        if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
            self.enter(obj)?;
            let items = obj.try_iter()?.collect::<PyResult<Vec<_>>>()?;
            let mut values = Vec::with_capacity(items.len());
            for (i, item) in items.iter().enumerate() {
                self.at.push(format!("[{i}]"));
                values.push(self.value(item)?);
                self.at.pop();
            }
            self.open.pop();
            return Ok(toml::Value::Array(values));
        }
        if obj.is_none() {
            return Err(argument(
                &self.here(),
                "None is not a scene value (leave the key out for its default)",
            ));
        }
        // Paths, then numpy arrays and scalars (tolist gives Python numbers and lists).
        if obj.hasattr("__fspath__")? {
            return Ok(toml::Value::String(
                args::path(obj, &self.here())?.display().to_string(),
            ));
        }
        if obj.hasattr("tolist")? {
            // What tolist gives is walked one level down, so that a tolist that returns its
            // own object ends at the depth limit.
            self.enter(obj)?;
            let value = self.value(&obj.call_method0("tolist")?);
            self.open.pop();
            return value;
        }
        Err(argument(
            &self.here(),
            format!(
                "a {} is not a scene value (use numbers, strings, bools, lists and dicts)",
                obj.get_type().name()?
            ),
        ))
    }
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
