//! `tetsim.Error`: the library's [`tetsim::Error`] as a Python `ValueError` with attributes, and
//! the argument errors of the bindings themselves (wrong dtype, shape, index).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(
    tetsim,
    Error,
    PyValueError,
    "A bad input or a run that cannot go on: str(e) is the command line's message.\n\n\
     Attributes: message (str, the same as str(e)), file (str or None), line (int or None, \
     1-based), column (int or None), key (the scene key or argument, e.g. 'solver.dt', or None), \
     frame (int or None: the frame that failed)."
);

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
            let err = Error::new_err(self.message.clone());
            let value = err.value(py);
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
