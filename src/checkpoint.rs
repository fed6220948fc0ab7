//! `checkpoint.bin` (SPEC §14): everything a stopped run needs to go on as if it had never
//! stopped, written after every frame, replaced atomically (temp file + rename).
//!
//! **Contents.** The run as it was asked for ([`RunRecord`]: the scene's text and where its
//! paths resolve, the options), the simulation's state after the last written frame
//! ([`SimulationState`]: positions, velocities, clock, the energy audit's ledger, the linear
//! solver's reuse state, contact's barrier stiffness) and the output folder's bookkeeping
//! ([`RecorderState`]: the PVD entries, the hash of every frame file, how long steps.csv was).
//!
//! **Format.** `TETSIMCK`, the format version (u32), the tetsim version (u16 length + UTF-8),
//! the payload's length (u64) and CRC-32 (u32), then the payload in postcard (serde's compact
//! binary format: a documented, stable wire format, little-endian, f64 stored bit for bit).
//! A checkpoint of another format or tetsim version, a truncated or corrupted one (length or
//! checksum), is refused with the reason: resuming from it could not promise the same results.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::contact::term::ContactState;
use crate::error::{Error, Result};
use crate::linear::state::SolverState;

/// The checkpoint's file name in the output folder.
pub const FILE_NAME: &str = "checkpoint.bin";

/// The layout version of [`Checkpoint`]; a change of the structs below bumps it.
pub const FORMAT_VERSION: u32 = 8;

const MAGIC: &[u8; 8] = b"TETSIMCK";

/// What a stopped run needs to go on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The run as asked for.
    pub run: RunRecord,
    /// The simulation after the last written frame.
    pub simulation: SimulationState,
    /// The output folder's bookkeeping.
    pub recorder: RecorderState,
}

/// The run as it was asked for: scene and options.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The scene file as named (or `<built-in default scene>`).
    pub scene_path: String,
    /// The absolute folder the scene's relative paths resolve against.
    pub scene_base: String,
    /// The scene's TOML text as it was read.
    pub scene_source: String,
    /// The scene's input files with their hashes (JSON, as in manifest.json): a resumed run
    /// refuses inputs that changed.
    pub inputs: String,
    /// The output folder as named.
    pub out: String,
    /// Frames the run goes to.
    pub frames: usize,
    /// `--force`.
    pub force: bool,
    /// Pictures and plots on.
    pub pictures: bool,
    /// Plots on.
    pub plots: bool,
    /// `--deterministic`.
    pub deterministic: bool,
}

/// The simulation after the last written frame (see [`crate::sim::Simulation::snapshot`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimulationState {
    /// Frames done.
    pub frame: usize,
    /// Time (s; quasistatic: load factor).
    pub t: f64,
    /// Positions (m).
    pub x: Vec<[f64; 3]>,
    /// Velocities (m/s).
    pub v: Vec<[f64; 3]>,
    /// The 0/1 mask of free DOFs.
    pub free: Vec<[f64; 3]>,
    /// The energy audit's ledger: elastic energy, loads and reactions at the state.
    pub ledger: (f64, Vec<[f64; 3]>, Vec<[f64; 3]>),
    /// Frames the motions and loads ramp over.
    pub ramp_frames: usize,
    /// The Hessian pattern's generation number.
    pub pattern_generation: u64,
    /// The linear solver's reuse state.
    pub solver: SolverState,
    /// Contact's state, when contact is on.
    pub contact: Option<ContactState>,
    /// The tangled elements (see [`crate::elastic::recovery`]).
    pub tangled: Vec<u32>,
    /// While they use the collapsed form: its progress (fewest collapsed tets, frames since).
    pub unfolding: Option<(u64, u32)>,
    /// Inverted tets at the end of the last frame.
    pub inverted_at_end: u64,
    /// What the time scheme keeps between steps (BDF2's previous step, Newmark's acceleration).
    pub history: crate::integrator::scheme::SavedHistory,
    /// The energy audit's damping forces at the state (see [`crate::audit::Ledger::damping`]).
    pub ledger_damping: Vec<[f64; 3]>,
    /// The energy of added terms at the state (see [`crate::audit::Ledger::added`]).
    pub ledger_added: f64,
}

/// One written frame: (frame, time, [(file, SHA-256)]).
pub type FrameRecord = (usize, f64, Vec<(String, String)>);

/// The output folder's bookkeeping (see [`crate::output::Recorder::snapshot`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RecorderState {
    /// frames.pvd's entries (time, file).
    pub pvd: Vec<(f64, String)>,
    /// obstacles.pvd's entries, with contact.
    pub obstacles_pvd: Option<Vec<(f64, String)>>,
    /// Per frame: (frame, time, [(file, SHA-256)]).
    pub frames: Vec<FrameRecord>,
    /// steps.csv's length in bytes and the CRC-32 of those bytes.
    pub steps_csv: (u64, u32),
}

impl Checkpoint {
    /// Write to `path` atomically. The payload is encoded twice, once for its length and CRC
    /// (which come before it) and once into the file, so that it is never held whole in memory
    /// (43 MB at 192k tets).
    pub fn write(&self, path: &Path) -> Result<()> {
        let encoding =
            |e: postcard::Error| Error::parameter("checkpoint", format!("cannot encode: {e}"));
        let summary = postcard::to_io(self, Summary::default()).map_err(encoding)?;
        let version = env!("CARGO_PKG_VERSION").as_bytes();
        let mut failed = None;
        let written = crate::io::atomic_write(path, |w| {
            w.write_all(MAGIC)?;
            w.write_all(&FORMAT_VERSION.to_le_bytes())?;
            w.write_all(&(version.len() as u16).to_le_bytes())?;
            w.write_all(version)?;
            w.write_all(&summary.len.to_le_bytes())?;
            w.write_all(&summary.crc.finalize().to_le_bytes())?;
            postcard::to_io(self, w).map(|_| ()).map_err(|e| {
                failed = Some(e);
                std::io::Error::other("the checkpoint could not be encoded")
            })
        });
        match failed {
            Some(e) => Err(encoding(e)),
            None => written,
        }
    }

    /// Read and check `path`: refused (with the reason) when missing, of another format or
    /// tetsim version, truncated or corrupted.
    pub fn read(path: &Path) -> Result<Checkpoint> {
        let bytes = std::fs::read(path).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                refused(path, "there is no checkpoint (was the run made by tetsim run, and did it write a frame?)")
            } else {
                Error::io(path, e)
            }
        })?;
        let mut r = Reader(&bytes);
        if r.take(8) != Some(MAGIC.as_slice()) {
            return Err(refused(path, "not a tetsim checkpoint"));
        }
        let bad = || refused(path, "the checkpoint is truncated or corrupted");
        let format = u32::from_le_bytes(r.array().ok_or_else(bad)?);
        let len = u16::from_le_bytes(r.array().ok_or_else(bad)?) as usize;
        let version = r.take(len).ok_or_else(bad)?;
        let version = String::from_utf8_lossy(version).into_owned();
        if format != FORMAT_VERSION || version != env!("CARGO_PKG_VERSION") {
            return Err(refused(
                path,
                format!(
                    "it was written by tetsim {version} (checkpoint format {format}); this is tetsim {} \
                     (format {FORMAT_VERSION}), which cannot promise to continue it the same way: \
                     resume it with tetsim {version}, or start the run again",
                    env!("CARGO_PKG_VERSION")
                ),
            ));
        }
        let size = u64::from_le_bytes(r.array().ok_or_else(bad)?);
        let crc = u32::from_le_bytes(r.array().ok_or_else(bad)?);
        let payload = r.0;
        if payload.len() as u64 != size || crc32fast::hash(payload) != crc {
            return Err(refused(
                path,
                "the checkpoint is corrupted (its length or checksum does not match)",
            ));
        }
        postcard::from_bytes(payload)
            .map_err(|e| refused(path, format!("the checkpoint cannot be decoded: {e}")))
    }
}

/// The length and CRC-32 of what is written into it, keeping nothing else.
#[derive(Default)]
struct Summary {
    len: u64,
    crc: crc32fast::Hasher,
}

impl std::io::Write for Summary {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.crc.update(bytes);
        self.len += bytes.len() as u64;
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn refused(path: &Path, why: impl std::fmt::Display) -> Error {
    Error::parameter("resume", format!("{}: {why}", path.display()))
}

struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if self.0.len() < n {
            return None;
        }
        let (head, tail) = self.0.split_at(n);
        self.0 = tail;
        Some(head)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.take(N).map(|b| b.try_into().expect("N bytes"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            run: RunRecord {
                scene_path: "s.toml".into(),
                frames: 3,
                ..Default::default()
            },
            simulation: SimulationState {
                frame: 2,
                t: 0.1,
                x: vec![[1.0, f64::MIN_POSITIVE, -0.0]],
                ledger: (f64::INFINITY, vec![], vec![]),
                ..Default::default()
            },
            recorder: RecorderState::default(),
        }
    }

    #[test]
    fn round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        sample().write(&path).unwrap();
        let back = Checkpoint::read(&path).unwrap();
        assert_eq!(back, sample());
        assert_eq!(back.simulation.x[0][2].to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn the_streamed_file_is_the_header_then_the_payload_encoded_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        sample().write(&path).unwrap();
        let payload = postcard::to_stdvec(&sample()).unwrap();
        let version = env!("CARGO_PKG_VERSION").as_bytes();
        let mut expected = MAGIC.to_vec();
        expected.extend(FORMAT_VERSION.to_le_bytes());
        expected.extend((version.len() as u16).to_le_bytes());
        expected.extend(version);
        expected.extend((payload.len() as u64).to_le_bytes());
        expected.extend(crc32fast::hash(&payload).to_le_bytes());
        expected.extend(&payload);
        assert_eq!(std::fs::read(&path).unwrap(), expected);
    }

    #[test]
    fn a_flipped_byte_or_a_truncation_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        sample().write(&path).unwrap();
        let good = std::fs::read(&path).unwrap();
        let mut bad = good.clone();
        let last = bad.len() - 3;
        bad[last] ^= 0x10;
        std::fs::write(&path, &bad).unwrap();
        let msg = Checkpoint::read(&path).unwrap_err().to_string();
        assert!(msg.contains("corrupted"), "{msg}");
        std::fs::write(&path, &good[..good.len() / 2]).unwrap();
        assert!(Checkpoint::read(&path).is_err());
        std::fs::write(&path, b"hello").unwrap();
        let msg = Checkpoint::read(&path).unwrap_err().to_string();
        assert!(msg.contains("not a tetsim checkpoint"), "{msg}");
    }

    #[test]
    fn another_version_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        sample().write(&path).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[8] = 99; // format version
        std::fs::write(&path, &bytes).unwrap();
        let msg = Checkpoint::read(&path).unwrap_err().to_string();
        assert!(msg.contains("format 99"), "{msg}");
    }

    #[test]
    fn a_missing_checkpoint_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let msg = Checkpoint::read(&dir.path().join(FILE_NAME))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("there is no checkpoint"), "{msg}");
    }
}
