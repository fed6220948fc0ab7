//! `tetsim.Error`: the library's [`tetsim::Error`] as a Python exception with attributes, and
//! the argument errors of the bindings themselves (wrong type, dtype, shape, index, keyword).
//!
//! The class derives from both `ValueError` and `TypeError`: every bad argument, whether its
//! value or its type is wrong, raises this one class naming the argument, while code written
//! `except ValueError` (values) or `except TypeError` (types, as Python's own argument errors
//! are) keeps catching what it caught before.

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

const DOC: &str = "A bad input or a run that cannot go on: str(e) is the command line's message.\n\n\
     Raised for every bad argument, of a wrong value or of a wrong type, so it derives from both \
     ValueError and TypeError.\n\n\
     Attributes: message (str, the same as str(e)), file (str or None), line (int or None, \
     1-based), column (int or None), key (the scene key or argument, e.g. 'solver.dt', or None), \
     frame (int or None: the frame that failed).";

static ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// The class `tetsim.Error` (made once, on first use).
pub fn error_type(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    ERROR
        .get_or_try_init(py, || {
            let builtins = py.import("builtins")?;
            let bases = PyTuple::new(
                py,
                [
                    builtins.getattr("ValueError")?,
                    builtins.getattr("TypeError")?,
                ],
            )?;
            let namespace = PyDict::new(py);
            namespace.set_item("__module__", "tetsim")?;
            namespace.set_item("__doc__", DOC)?;
            let class = builtins
                .getattr("type")?
                .call1(("Error", bases, namespace))?
                .cast_into::<PyType>()?;
            Ok(class.unbind())
        })
        .map(|class| class.bind(py))
}

/// Where the text of a scene came from: a file (locations are real) or Python values
/// (`Scene.from_dict`, `Material`: the TOML text is made here, so its lines mean nothing to the
/// caller and are left out; the key says where).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A file on disk, or a library call with no scene text.
    File,
    /// TOML text made from Python values.
    Values,
}

/// The fields of a `tetsim.Error`.
#[derive(Debug, Default)]
pub struct Fields {
    pub message: String,
    pub file: Option<String>,
    pub line: Option<usize>,
    pub column: Option<usize>,
    pub key: Option<String>,
    pub frame: Option<usize>,
}

impl Fields {
    /// Raise these as a `tetsim.Error`.
    pub fn raise(self) -> PyErr {
        Python::attach(|py| {
            let value = match error_type(py).and_then(|class| class.call1((&self.message,))) {
                Ok(value) => value,
                Err(e) => return e,
            };
            let err = PyErr::from_value(value.clone());
            let set = |name: &str, v: Bound<'_, PyAny>| value.setattr(name, v);
            let results = [
                set(
                    "message",
                    self.message.into_pyobject(py).unwrap().into_any(),
                ),
                set("file", self.file.into_pyobject(py).unwrap()),
                set("line", self.line.into_pyobject(py).unwrap()),
                set("column", self.column.into_pyobject(py).unwrap()),
                set("key", self.key.into_pyobject(py).unwrap()),
                set("frame", self.frame.into_pyobject(py).unwrap()),
            ];
            match results.into_iter().find_map(Result::err) {
                Some(e) => e,
                None => err,
            }
        })
    }
}

/// A library error as a `tetsim.Error` with the command line's message.
pub fn from_lib(error: tetsim::Error, origin: Origin) -> PyErr {
    use tetsim::Error as E;
    let key = error.key().map(str::to_string);
    let fields = match &error {
        E::Scene {
            path,
            line,
            column,
            message,
            ..
        } => match origin {
            Origin::File => Fields {
                message: error.to_string(),
                file: Some(path.display().to_string()),
                line: Some(*line),
                column: Some(*column),
                ..Default::default()
            },
            Origin::Values => Fields {
                message: message.clone(),
                ..Default::default()
            },
        },
        E::Io { path, .. } => Fields {
            message: error.to_string(),
            file: Some(path.display().to_string()),
            ..Default::default()
        },
        E::Parse { path, line, .. } => Fields {
            message: error.to_string(),
            file: Some(path.display().to_string()),
            line: *line,
            ..Default::default()
        },
        E::Mesh { path, .. } => Fields {
            message: error.to_string(),
            file: path.as_ref().map(|p| p.display().to_string()),
            ..Default::default()
        },
        E::Parameter { .. } => Fields {
            message: error.to_string(),
            ..Default::default()
        },
        E::Solve { frame, .. } | E::Interrupted { frame } => Fields {
            message: error.to_string(),
            frame: Some(*frame),
            ..Default::default()
        },
    };
    Fields { key, ..fields }.raise()
}

/// A library error about the file or folder an argument names: the command line's message, with
/// the key set to the argument when the operating system refused that very path (missing,
/// unreadable), so that `e.key` says which argument to fix.
pub fn for_path(error: tetsim::Error, origin: Origin, key: &str, given: &std::path::Path) -> PyErr {
    let about_it = matches!(&error, tetsim::Error::Io { path, .. } if path == given);
    let err = from_lib(error, origin);
    if about_it {
        Python::attach(|py| {
            let _ = err.value(py).setattr("key", key);
        });
    }
    err
}

/// An error about an argument of a binding (`key` names it), with no file.
pub fn argument(key: &str, message: impl std::fmt::Display) -> PyErr {
    Fields {
        message: format!("{key}: {message}"),
        key: Some(key.to_string()),
        ..Default::default()
    }
    .raise()
}

/// `?` on library results inside the bindings.
pub trait LibResult<T> {
    /// The error as a `tetsim.Error` (locations of a file).
    fn py(self) -> PyResult<T>;
}

impl<T> LibResult<T> for tetsim::Result<T> {
    fn py(self) -> PyResult<T> {
        self.map_err(|e| from_lib(e, Origin::File))
    }
}
