//! Files ↔ meshes and frames; nothing physical here.

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// Read a tet mesh, choosing the format by extension.
pub fn read_mesh(path: &Path) -> Result<TetMesh> {
    Err(Error::parse(
        path,
        None,
        "reading mesh files arrives with the mesh readers (issue 4)",
    ))
}

/// Positions for `[initial] positions`: one "x y z" line per vertex (blank lines and lines
/// starting with # are skipped), exactly `count` of them.
pub fn read_positions(path: &Path, count: usize) -> Result<Vec<Vec3>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut out = Vec::with_capacity(count);
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let values: Vec<f64> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| Error::parse(path, Some(i + 1), format!("expected three numbers: {e}")))?;
        if values.len() != 3 || !values.iter().all(|v| v.is_finite()) {
            return Err(Error::parse(
                path,
                Some(i + 1),
                format!("expected three finite numbers, got \"{line}\""),
            ));
        }
        out.push(Vec3::new(values[0], values[1], values[2]));
    }
    if out.len() != count {
        return Err(Error::parse(
            path,
            None,
            format!("{} positions for a mesh of {count} vertices", out.len()),
        ));
    }
    Ok(out)
}

/// Write a file atomically: into a temporary file beside it, then rename, so readers never see
/// a half-written file and an interrupted run leaves the previous version intact.
pub fn atomic_write(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp"));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut out = std::io::BufWriter::new(file);
        write(&mut out)?;
        // No fsync: the rename alone guarantees readers see the old or the new file, never a
        // torn one; surviving power loss is not worth an fsync per frame.
        out.flush()?;
        drop(out);
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}
