//! What a resumed run finds on disk, checked against its checkpoint.

use std::path::Path;

use super::FrameFiles;
use crate::error::{Error, Result};

/// Check that every frame file the checkpoint lists is on disk with the bytes it was written
/// with (SHA-256): a resumed run must not leave a missing or edited frame in its record.
/// Hashed in parallel; the first bad frame (lowest number) is named.
pub(super) fn verify_frames(dir: &Path, frames: &[FrameFiles]) -> Result<()> {
    use rayon::prelude::*;
    let problem = frames
        .par_iter()
        .flat_map_iter(|f| {
            f.files
                .iter()
                .map(move |(name, hash)| (f.frame, name, hash))
        })
        .filter_map(|(frame, name, hash)| {
            let path = dir.join(name);
            let problem = match crate::manifest::sha256_file(&path) {
                Ok(now) if now == *hash => return None,
                Ok(_) => "was changed since the run wrote it",
                Err(_) if !path.exists() => "is missing",
                Err(_) => "cannot be read",
            };
            Some((
                frame,
                format!("{}: frame {frame} {problem}", path.display()),
            ))
        })
        .min_by_key(|(frame, _)| *frame);
    match problem {
        None => Ok(()),
        Some((_, what)) => Err(Error::parameter(
            "resume",
            format!("{what}; restore it, or start the run again"),
        )),
    }
}
