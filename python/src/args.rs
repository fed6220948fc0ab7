//! Python arguments into Rust values: numbers (or strings with a unit, as scene files take them),
//! 3-vectors, indices, flags, names and paths, and the shape of a call itself (no positional
//! argument too many, no unknown keyword). Each failure is a `tetsim.Error` whose key is the
//! argument and whose message starts with it, never a bare `TypeError` or `OverflowError`.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use tetsim::scene::units::{Kind, parse_quantity};

use crate::errors::{Fields, argument};

/// An error about argument `key`, the message starting with `label` (`translate[1]`).
fn argument_at(key: &str, label: &str, message: impl std::fmt::Display) -> PyErr {
    Fields {
        message: format!("{label}: {message}"),
        key: Some(key.to_string()),
        ..Default::default()
    }
    .raise()
}

/// How a message shows a value it refuses: its type and a clipped repr (`str '1 MPa'`).
pub fn describe(obj: &Bound<'_, PyAny>) -> String {
    let kind = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "object".into());
    if obj.is_none() {
        return "None".into();
    }
    let shown = obj.repr().map(|r| r.to_string()).unwrap_or_default();
    let shown: String = if shown.chars().count() > 40 {
        shown.chars().take(37).chain("...".chars()).collect()
    } else {
        shown
    };
    format!("{kind} {shown}")
}

/// What a key of `kind` takes, for messages about a value of the wrong type.
fn expected(kind: Kind) -> &'static str {
    match kind {
        Kind::Length => "a number in m (or a string with a unit, e.g. \"5 mm\")",
        Kind::Time => "a number in s (or a string with a unit, e.g. \"2 ms\")",
        Kind::Velocity => "a number in m/s (or a string with a unit, e.g. \"30 mm/s\")",
        Kind::Acceleration => "a number in m/s² (or a string with a unit, e.g. \"9.81 m/s^2\")",
        Kind::Pressure => "a number in Pa (or a string with a unit, e.g. \"1.2 MPa\")",
        Kind::Force => "a number in N (or a string with a unit, e.g. \"2 kN\")",
        Kind::Density => "a number in kg/m³ (or a string with a unit, e.g. \"1100 kg/m^3\")",
        Kind::Frequency => "a number in Hz (or a string with a unit, e.g. \"50 Hz\")",
        Kind::Degrees => "a number in degrees (or a string with a unit, e.g. \"0.5 rad\")",
        Kind::Ratio => "a number",
    }
}

/// Python's `bool` and numpy's (`bool_` before numpy 2): numbers to Python, never to a scene.
fn is_bool(obj: &Bound<'_, PyAny>) -> bool {
    obj.get_type()
        .name()
        .is_ok_and(|n| n == "bool" || n == "bool_")
}

/// A numpy array of one or more dimensions (which also converts to a float when it holds one
/// element, a conversion numpy itself deprecates).
fn array_ndim(obj: &Bound<'_, PyAny>) -> Option<usize> {
    if obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>() {
        return None;
    }
    obj.getattr("ndim")
        .ok()
        .and_then(|n| n.extract::<usize>().ok())
        .filter(|&n| n > 0)
}

/// A Python str as Rust text (a lone surrogate cannot be: say so instead of UnicodeEncodeError).
pub fn text(obj: &Bound<'_, PyAny>, key: &str, what: &str) -> PyResult<String> {
    text_at(obj, key, key, what)
}

fn text_at(obj: &Bound<'_, PyAny>, key: &str, label: &str, what: &str) -> PyResult<String> {
    if !obj.is_instance_of::<PyString>() {
        return Err(argument_at(
            key,
            label,
            format!("expected {what} (a str), got {}", describe(obj)),
        ));
    }
    obj.extract::<String>().map_err(|_| {
        argument_at(
            key,
            label,
            format!(
                "{} is not valid text: it holds a lone surrogate, which UTF-8 cannot encode",
                describe(obj)
            ),
        )
    })
}

/// A number of `kind` in its SI unit: a Python or numpy int or float, or a string with a unit
/// ("1 MPa") read as the scene reads it. Range checks are the caller's (the library's).
pub fn real(obj: &Bound<'_, PyAny>, key: &str, kind: Kind) -> PyResult<f64> {
    real_at(obj, key, key, kind)
}

fn real_at(obj: &Bound<'_, PyAny>, key: &str, label: &str, kind: Kind) -> PyResult<f64> {
    let wrong = || {
        argument_at(
            key,
            label,
            format!("expected {}, got {}", expected(kind), describe(obj)),
        )
    };
    if obj.is_instance_of::<PyString>() {
        let given = text_at(obj, key, label, expected(kind))?;
        return parse_quantity(&given, kind).map_err(|m| argument_at(key, label, m));
    }
    if is_bool(obj) || obj.is_none() || obj.is_instance_of::<PyBytes>() {
        return Err(wrong());
    }
    if let Some(ndim) = array_ndim(obj) {
        let shape = obj
            .getattr("shape")
            .and_then(|s| s.repr())
            .map(|r| r.to_string())
            .unwrap_or_default();
        return Err(argument_at(
            key,
            label,
            format!(
                "expected {}, got an array of {ndim} dimension(s), shape {shape}",
                expected(kind)
            ),
        ));
    }
    let numeric = obj.is_instance_of::<PyFloat>()
        || obj.is_instance_of::<PyInt>()
        || obj.hasattr("__float__").unwrap_or(false)
        || obj.hasattr("__index__").unwrap_or(false);
    if !numeric {
        return Err(wrong());
    }
    obj.extract::<f64>().map_err(|e| {
        if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) {
            argument_at(
                key,
                label,
                format!("{} does not fit in a double-precision float", describe(obj)),
            )
        } else {
            wrong()
        }
    })
}

/// `None` or a number of `kind` (see [`real`]).
pub fn optional_real(
    obj: Option<&Bound<'_, PyAny>>,
    key: &str,
    kind: Kind,
) -> PyResult<Option<f64>> {
    match obj {
        Some(obj) if !obj.is_none() => real(obj, key, kind).map(Some),
        _ => Ok(None),
    }
}

/// Three numbers of `kind` (a list, tuple, other sequence, or a numpy array of shape (3,)).
pub fn vec3(obj: &Bound<'_, PyAny>, key: &str, kind: Kind) -> PyResult<[f64; 3]> {
    let what = format!("3 numbers [x, y, z], each {}", expected(kind));
    let wrong = |got: String| argument(key, format!("expected {what}, got {got}"));
    if obj.is_instance_of::<PyString>()
        || obj.is_instance_of::<PyBytes>()
        || obj.is_instance_of::<PyDict>()
    {
        return Err(wrong(describe(obj)));
    }
    let items: Bound<'_, PyAny> = match array_ndim(obj) {
        Some(1) => obj.call_method0("tolist")?,
        Some(_) => {
            let shape = obj.getattr("shape")?.repr()?.to_string();
            return Err(wrong(format!("an array of shape {shape}")));
        }
        None => obj.clone(),
    };
    let list: Bound<'_, PyList> =
        if items.is_instance_of::<PyList>() || items.is_instance_of::<PyTuple>() {
            PyList::new(obj.py(), items.try_iter()?.collect::<PyResult<Vec<_>>>()?)?
        } else if let Ok(seq) = items.cast::<pyo3::types::PySequence>() {
            seq.to_list().map_err(|_| wrong(describe(obj)))?
        } else {
            return Err(wrong(describe(obj)));
        };
    if list.len() != 3 {
        return Err(wrong(format!(
            "{} of {} item(s)",
            obj.get_type().name()?,
            list.len()
        )));
    }
    let mut out = [0.0; 3];
    for (i, item) in list.iter().enumerate() {
        out[i] = real_at(&item, key, &format!("{key}[{i}]"), kind)?;
    }
    Ok(out)
}

/// An index into `count` things (`what`, e.g. "[[fixed]] entry"): a Python or numpy int from 0
/// to count - 1.
pub fn index(obj: &Bound<'_, PyAny>, key: &str, count: usize, what: &str) -> PyResult<usize> {
    let range = match count {
        0 => format!("the scene has no {what}"),
        1 => format!("the scene has 1 {what}, numbered 0"),
        n => format!("the scene has {n}, numbered from 0 to {}", n - 1),
    };
    let integer = !is_bool(obj)
        && (obj.is_instance_of::<PyInt>()
            || (array_ndim(obj).is_none()
                && !obj.is_instance_of::<PyFloat>()
                && obj.hasattr("__index__").unwrap_or(false)));
    if !integer {
        return Err(argument(
            key,
            format!("expected an integer index ({range}), got {}", describe(obj)),
        ));
    }
    match obj.extract::<i64>() {
        Ok(i) if i >= 0 && (i as u64) < count as u64 => Ok(i as usize),
        Ok(i) => Err(argument(key, format!("there is no {what} {i} ({range})"))),
        Err(_) => {
            let shown = obj.repr().map(|r| r.to_string()).unwrap_or_default();
            Err(argument(
                key,
                format!("there is no {what} {shown} ({range})"),
            ))
        }
    }
}

/// True or False (Python's or numpy's bool; not 0, 1 or "yes").
pub fn flag(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<bool> {
    if !is_bool(obj) {
        return Err(argument(
            key,
            format!("expected True or False, got {}", describe(obj)),
        ));
    }
    obj.is_truthy()
}

/// `None` or a flag (see [`flag`]).
pub fn optional_flag(obj: Option<&Bound<'_, PyAny>>, key: &str) -> PyResult<Option<bool>> {
    match obj {
        Some(obj) if !obj.is_none() => flag(obj, key).map(Some),
        _ => Ok(None),
    }
}

/// A file or folder name: a str or an os.PathLike (pathlib.Path).
pub fn path(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<PathBuf> {
    let pathlike = obj.is_instance_of::<PyString>()
        || obj.is_instance_of::<PyBytes>()
        || obj.hasattr("__fspath__").unwrap_or(false);
    if !pathlike {
        return Err(argument(
            key,
            format!(
                "expected a path (a str or pathlib.Path), got {}",
                describe(obj)
            ),
        ));
    }
    // os.fsdecode takes str, bytes and os.PathLike alike, as open() does.
    obj.py()
        .import("os")?
        .getattr("fsdecode")?
        .call1((obj,))
        .and_then(|name| name.extract::<PathBuf>())
        .map_err(|e| {
            argument(
                key,
                format!("{} is not a usable file name ({e})", describe(obj)),
            )
        })
}

/// `None` or a path (see [`path`]).
pub fn optional_path(obj: Option<&Bound<'_, PyAny>>, key: &str) -> PyResult<Option<PathBuf>> {
    match obj {
        Some(obj) if !obj.is_none() => path(obj, key).map(Some),
        _ => Ok(None),
    }
}

/// A required argument given as `None` or left out (signatures default every argument to `None`
/// so that a missing one is refused here, by name, as a `tetsim.Error`).
pub fn required<'a, 'py>(
    obj: Option<&'a Bound<'py, PyAny>>,
    key: &str,
    call: &str,
    what: &str,
) -> PyResult<&'a Bound<'py, PyAny>> {
    match obj {
        Some(obj) if !obj.is_none() => Ok(obj),
        _ => Err(argument(key, format!("{call}() needs {key}: {what}"))),
    }
}

/// The parameters of a call, for [`Signature::check`].
pub struct Signature<'a> {
    /// How messages name the callable: `Material`, `Simulation.set_fixed_motion`.
    pub call: &'a str,
    /// Parameters that may be given by position, in order.
    pub positional: &'a [&'a str],
    /// Parameters given by keyword only.
    pub keyword: &'a [&'a str],
}

impl Signature<'_> {
    /// Refuse positional arguments beyond the signature's (`extra`, caught by `*args`) and
    /// unknown keywords (`unknown`, caught by `**kwargs`), naming them and the nearest known
    /// keyword when one is a likely misspelling.
    pub fn check(
        &self,
        extra: &Bound<'_, PyTuple>,
        unknown: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let call = self.call;
        let all: Vec<&str> = self
            .positional
            .iter()
            .chain(self.keyword)
            .copied()
            .collect();
        let listed = if all.is_empty() {
            "it takes no arguments".to_string()
        } else {
            format!("its arguments: {}", all.join(", "))
        };
        if let Some(unknown) = unknown
            && let Some((name, _)) = unknown.iter().next()
        {
            let name = name.extract::<String>().unwrap_or_else(|_| describe(&name));
            let hint = nearest(&name, &all)
                .map(|n| format!(" (did you mean {n}?)"))
                .unwrap_or_default();
            return Err(argument(
                &name,
                format!("{call}() has no argument {name}{hint}; {listed}"),
            ));
        }
        if !extra.is_empty() {
            let n = self.positional.len();
            let given = n + extra.len();
            let takes = match n {
                0 => "no positional arguments".to_string(),
                1 => format!("1 positional argument ({})", self.positional[0]),
                n => format!("{n} positional arguments ({})", self.positional.join(", ")),
            };
            let rest = if self.keyword.is_empty() {
                String::new()
            } else {
                format!("; give {} by keyword", self.keyword.join(", "))
            };
            return Err(argument(
                call,
                format!("{call}() takes {takes}, got {given}{rest}"),
            ));
        }
        Ok(())
    }
}

/// The known name `given` is likely a slip for: within one edit (two for names of five letters
/// or more), or a prefix of it; none for names too short to tell.
fn nearest<'a>(given: &str, known: &[&'a str]) -> Option<&'a str> {
    let len = given.chars().count();
    let allowed = match len {
        0..=2 => return None,
        3..=4 => 1,
        _ => 2,
    };
    known
        .iter()
        .map(|k| (edit_distance(given, k), *k))
        .filter(|(d, _)| *d <= allowed)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
        .or_else(|| {
            // A prefix (youngs → youngs_modulus) is as likely a slip as a typo.
            known
                .iter()
                .find(|k| given.len() >= 3 && (k.starts_with(given) || given.starts_with(*k)))
                .copied()
        })
}

/// Levenshtein distance over chars.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitution = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitution.min(row[j] + 1).min(row[j + 1] + 1);
        }
    }
    row[b.len()]
}
