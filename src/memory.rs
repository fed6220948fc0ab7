//! Where a simulation's memory goes: a named list of the bytes each of its large buffers holds
//! (per-tet, per-vertex and per-block arrays; the small ones are left out), which `tetsim bench`
//! prints per tet beside the resident memory it measures.

use serde::Serialize;

/// One buffer (or group of buffers) and the bytes it holds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MemoryPart {
    /// What it is ("per-tet tangents", "AMG: P and Pᵀ", ...).
    pub name: String,
    /// Bytes held (capacity, not length).
    pub bytes: usize,
}

/// A memory inventory: parts in the order they were listed.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Inventory {
    /// The parts.
    pub parts: Vec<MemoryPart>,
}

impl Inventory {
    /// Add a part.
    pub fn add(&mut self, name: impl Into<String>, bytes: usize) {
        self.parts.push(MemoryPart {
            name: name.into(),
            bytes,
        });
    }

    /// The sum over the parts.
    pub fn total(&self) -> usize {
        self.parts.iter().map(|p| p.bytes).sum()
    }
}

/// Bytes a vector holds (its capacity).
pub fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}
