//! ParaView collections (`.pvd`): the list of frames with their times.

use std::path::Path;

use super::xml;
use super::{atomic_write, read_bytes};
use crate::error::{Error, Result};

/// Write a ParaView collection listing `(time in s, file name relative to the .pvd)` entries.
pub fn write_pvd(path: &Path, entries: &[(f64, String)]) -> Result<()> {
    atomic_write(path, |w| {
        writeln!(
            w,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>"
        )?;
        for (t, file) in entries {
            writeln!(
                w,
                "    <DataSet timestep=\"{t:?}\" group=\"\" part=\"0\" file=\"{}\"/>",
                xml::escape(file)
            )?;
        }
        writeln!(w, "  </Collection>\n</VTKFile>")
    })
}

/// Read a `.pvd` collection back: `(time, file)` entries in file order.
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, String)>> {
    let data = read_bytes(path)?;
    let (root, _) = xml::parse(path, &data)?;
    let collection = root
        .child("Collection")
        .ok_or_else(|| Error::parse(path, Some(root.line), "no <Collection>"))?;
    collection
        .children
        .iter()
        .filter(|d| d.name == "DataSet")
        .map(|d| {
            let t = d
                .attr("timestep")
                .unwrap_or("0")
                .trim()
                .parse()
                .map_err(|_| Error::parse(path, Some(d.line), "bad timestep"))?;
            let file = d
                .attr("file")
                .ok_or_else(|| Error::parse(path, Some(d.line), "<DataSet> without file"))?;
            Ok((t, file.to_string()))
        })
        .collect()
}
