//! Where a key sits in the scene's TOML text, so that every message about a value names the
//! file, the line and the key.
//!
//! The text is parsed a second time into toml's spanned document ([`toml::de::DeTable`]), which
//! keeps the byte span of every key and value. A key path walks that tree, so keys in inline
//! tables (`region = { box = { min = [...] } }`), dotted keys (`solver.dt = 0.1`) and the entries
//! of arrays of tables (`[[fixed]]`) are all found the way TOML itself reads them, not by
//! scanning lines.

use std::fmt;
use std::ops::Range;
use std::path::Path;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use crate::error::Error;

/// One step of a key path: a table key, or a 0-based index into an array (of tables).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Seg<'a> {
    /// A key of a table.
    Key(&'a str),
    /// An entry of an array, 0-based (`[[fixed]]` #2 is index 1).
    Index(usize),
}

impl<'a> From<&'a str> for Seg<'a> {
    fn from(key: &'a str) -> Self {
        Seg::Key(key)
    }
}

impl From<usize> for Seg<'_> {
    fn from(index: usize) -> Self {
        Seg::Index(index)
    }
}

/// A key path from mixed keys and indices: `key!["fixed", i, "duration"]`.
macro_rules! key {
    ($($seg:expr),* $(,)?) => {
        [$($crate::scene::locate::Seg::from($seg)),*]
    };
}
pub(crate) use key;

/// A key path as a user reads it: `solver.newton_tolerance`, `gravity`,
/// `[[fixed]] #2 duration`, `[[load]] #1 region.box.min`.
pub(crate) struct Dotted<'p, 'a>(pub &'p [Seg<'a>]);

impl fmt::Display for Dotted<'_, '_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = self.0;
        let mut first = true;
        let mut i = 0;
        while i < path.len() {
            match (path[i], path.get(i + 1)) {
                (Seg::Key(array), Some(Seg::Index(n))) => {
                    if !first {
                        f.write_str(" ")?;
                    }
                    write!(f, "[[{array}]] #{}", n + 1)?;
                    // The entry's own keys follow after a space, then dotted.
                    if i + 2 < path.len() {
                        f.write_str(" ")?;
                    }
                    first = true;
                    i += 2;
                    continue;
                }
                (Seg::Key(key), _) => {
                    if !first {
                        f.write_str(".")?;
                    }
                    f.write_str(key)?;
                }
                (Seg::Index(n), _) => write!(f, "[{n}]")?,
            }
            first = false;
            i += 1;
        }
        Ok(())
    }
}

/// The scene text and its spanned parse.
pub(crate) struct Locator<'t> {
    text: &'t str,
    /// `None` only if the text does not parse, which `Scene::parse` has ruled out already;
    /// messages then fall back to line 1.
    root: Option<Spanned<DeTable<'t>>>,
}

impl<'t> Locator<'t> {
    /// Parse `text` for spans.
    pub(crate) fn new(text: &'t str) -> Self {
        Locator {
            text,
            root: DeTable::parse(text).ok(),
        }
    }

    /// The byte span of `path` in the text: the key itself for a key, the entry (the
    /// `[[table]]` header, or the inline value) for an index. A path that is not all in the
    /// text (a default value) stops at its deepest part that is, e.g. the `[mesh]` header for
    /// `mesh.file` when `[mesh]` has no `file`; `None` when not even its first key is there.
    pub(crate) fn span(&self, path: &[Seg]) -> Option<Range<usize>> {
        let root = self.root.as_ref()?;
        let mut table: Option<&DeTable> = Some(root.get_ref());
        let mut value: Option<&Spanned<DeValue>> = None;
        let mut found = None;
        for seg in path {
            let next = match (*seg, table, value.map(|v| v.get_ref())) {
                (Seg::Key(key), Some(t), _) => t
                    .iter()
                    .find(|(k, _)| k.get_ref().as_ref() == key)
                    .map(|(k, v)| (k.span(), v)),
                (Seg::Index(n), _, Some(DeValue::Array(items))) => {
                    items.get(n).map(|item| (item.span(), item))
                }
                _ => None,
            };
            let Some((span, next)) = next else { break };
            found = Some(span);
            value = Some(next);
            table = match next.get_ref() {
                DeValue::Table(t) => Some(t),
                _ => None,
            };
        }
        found
    }

    /// Whether the text gives `path` itself (not only a table above it): `solver.rayleigh_mass`
    /// written out, as opposed to left at its default.
    pub(crate) fn has(&self, path: &[Seg]) -> bool {
        self.value(path).is_some()
    }

    /// The value at `path`, when the text has it.
    fn value(&self, path: &[Seg]) -> Option<&DeValue<'t>> {
        let root = self.root.as_ref()?;
        let mut table: Option<&DeTable> = Some(root.get_ref());
        let mut value: Option<&Spanned<DeValue>> = None;
        for seg in path {
            let next = match (*seg, table, value.map(|v| v.get_ref())) {
                (Seg::Key(key), Some(t), _) => t
                    .iter()
                    .find(|(k, _)| k.get_ref().as_ref() == key)
                    .map(|(_, v)| v),
                (Seg::Index(n), _, Some(DeValue::Array(items))) => items.get(n),
                _ => None,
            };
            let next = next?;
            value = Some(next);
            table = match next.get_ref() {
                DeValue::Table(t) => Some(t),
                _ => None,
            };
        }
        value.map(|v| v.get_ref())
    }

    /// Whether the value at `path` is written as a string (`until = "2 s"`): for keys whose
    /// meaning a unit would change (a load factor).
    pub(crate) fn is_string(&self, path: &[Seg]) -> bool {
        matches!(self.value(path), Some(DeValue::String(_)))
    }

    /// Whether the value at `path` is a table (an entry of `[[fixed]]`, not of `[0, 1, 2]`).
    pub(crate) fn is_table(&self, path: &[Seg]) -> bool {
        matches!(self.value(path), Some(DeValue::Table(_)))
    }

    /// 1-based line and column of `path` (see [`Locator::span`]); (1, 1) when it is not there.
    pub(crate) fn line_column(&self, path: &[Seg]) -> (usize, usize) {
        self.span(path)
            .map_or((1, 1), |s| line_column(self.text, s.start))
    }

    /// The deepest key path whose key or value holds byte `offset`: which key a serde error
    /// (unknown field, wrong type) is about. Empty when the offset is outside every key.
    pub(crate) fn path_at(&self, offset: usize) -> Vec<Seg<'_>> {
        let mut path = Vec::new();
        if let Some(root) = &self.root {
            descend(root.get_ref(), offset, &mut path);
        }
        path
    }

    /// The one way a scene value is reported: `file:line:column: key.path: message`, at the
    /// key's line (or the deepest part of the path the text has).
    pub(crate) fn error(&self, file: &Path, path: &[Seg], message: impl fmt::Display) -> Error {
        let (line, column) = self.line_column(path);
        let key = Dotted(path).to_string();
        Error::Scene {
            path: file.to_path_buf(),
            line,
            column,
            message: format!("{key}: {message}"),
            key: Some(key),
        }
    }
}

/// Depth first: a key or value that holds `offset` wins only when none of its children does.
fn descend<'a>(table: &'a DeTable, offset: usize, path: &mut Vec<Seg<'a>>) -> bool {
    for (key, value) in table.iter() {
        path.push(Seg::Key(key.get_ref().as_ref()));
        if descend_value(value, offset, path) || key.span().contains(&offset) {
            return true;
        }
        path.pop();
    }
    false
}

fn descend_value<'a>(value: &'a Spanned<DeValue>, offset: usize, path: &mut Vec<Seg<'a>>) -> bool {
    match value.get_ref() {
        DeValue::Table(t) if descend(t, offset, path) => return true,
        DeValue::Array(items) => {
            for (n, item) in items.iter().enumerate() {
                path.push(Seg::Index(n));
                if descend_value(item, offset, path) {
                    return true;
                }
                path.pop();
            }
        }
        _ => {}
    }
    value.span().contains(&offset)
}

/// 1-based line and column of a byte offset.
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.len(), |nl| before.len() - nl - 1)
        + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
gravity = [0, nan, 0]
solver.dt = 0.1

[mesh]
generator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }

[[fixed]]
region = { vertices = [0] }

[[fixed]]
region = { box = { min = [0,0,0],
                   max = [1,1,1] } }
duration = -1
";

    #[test]
    fn keys_are_found_in_inline_tables_dotted_keys_and_array_entries() {
        let at = Locator::new(TEXT);
        assert_eq!(at.line_column(&key!["gravity"]), (1, 1));
        assert_eq!(at.line_column(&key!["solver", "dt"]), (2, 8));
        assert_eq!(
            at.line_column(&key!["mesh", "generator", "box", "cells"]),
            (5, 53)
        );
        assert_eq!(at.line_column(&key!["fixed", 1]).0, 10);
        assert_eq!(at.line_column(&key!["fixed", 1, "duration"]), (13, 1));
        assert_eq!(
            at.line_column(&key!["fixed", 1, "region", "box", "max"]),
            (12, 20)
        );
    }

    #[test]
    fn written_keys_are_told_from_defaults() {
        let at = Locator::new(TEXT);
        assert!(at.has(&key!["solver", "dt"]));
        assert!(at.has(&key!["mesh", "generator"]));
        assert!(!at.has(&key!["solver", "frames"]));
        assert!(!at.has(&key!["output", "dir"]));
    }

    #[test]
    fn a_missing_key_falls_back_to_its_deepest_present_part() {
        let at = Locator::new(TEXT);
        assert_eq!(at.line_column(&key!["mesh", "file"]), (4, 2));
        assert_eq!(at.line_column(&key!["fixed", 0, "until"]).0, 7);
        assert_eq!(at.line_column(&key!["output", "dir"]), (1, 1));
    }

    #[test]
    fn offsets_map_back_to_key_paths() {
        let at = Locator::new(TEXT);
        let offset = TEXT.find("duration").unwrap();
        assert_eq!(at.path_at(offset), key!["fixed", 1, "duration"].to_vec());
        let offset = TEXT.find("max = [1,1,1] }").unwrap();
        assert_eq!(
            at.path_at(offset),
            key!["fixed", 1, "region", "box", "max"].to_vec()
        );
        let offset = TEXT.find("0.1").unwrap();
        assert_eq!(at.path_at(offset), key!["solver", "dt"].to_vec());
    }

    #[test]
    fn paths_read_as_users_write_them() {
        assert_eq!(
            Dotted(&key!["solver", "newton_tolerance"]).to_string(),
            "solver.newton_tolerance"
        );
        assert_eq!(
            Dotted(&key!["fixed", 1, "duration"]).to_string(),
            "[[fixed]] #2 duration"
        );
        assert_eq!(
            Dotted(&key!["load", 0, "region", "box", "min"]).to_string(),
            "[[load]] #1 region.box.min"
        );
        assert_eq!(Dotted(&key!["volume", 2]).to_string(), "[[volume]] #3");
    }
}
