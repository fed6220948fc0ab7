//! Errors are data: typed, located (file, line, element), and collected (every degenerate tet at
//! once). A panic inside tetsim is a bug; bad input always comes back as an [`Error`].

use std::fmt;
use std::path::PathBuf;

/// The crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong with user input or a run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A malformed input file (mesh, positions), located by line where the format has lines.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line, when the format is line-oriented.
        line: Option<usize>,
        /// What is wrong, in words.
        message: String,
    },
    /// A scene file that does not parse or names an unknown key.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong, in words.
        message: String,
    },
    /// A mesh that reads but cannot be simulated.
    #[error("{}{problem}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Mesh {
        /// The mesh file, if the mesh came from one.
        path: Option<PathBuf>,
        /// What is wrong with it.
        problem: MeshProblem,
    },
    /// A parameter outside its physical or numerical range.
    #[error("invalid {name}: {message}")]
    Parameter {
        /// The parameter (a scene key where there is one, e.g. `material.poisson_ratio`).
        name: String,
        /// Why it is rejected.
        message: String,
    },
    /// A run that cannot continue (non-finite state, a failed step under `on_failure = "stop"`).
    #[error("frame {frame}: {message}")]
    Solve {
        /// The frame being computed.
        frame: usize,
        /// What happened and what to try.
        message: String,
    },
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// A parse error on `path` at an optional 1-based line.
    pub fn parse(
        path: impl Into<PathBuf>,
        line: Option<usize>,
        message: impl Into<String>,
    ) -> Self {
        Error::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }

    /// A rejected parameter.
    pub fn parameter(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Parameter {
            name: name.into(),
            message: message.into(),
        }
    }
}

/// What can be wrong with a mesh. Elements and vertices are named by their ids in the source
/// file when the mesh came from one (see `TetMesh::tet_ids`), else by 0-based index.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshProblem {
    /// No tetrahedra at all (a surface mesh, say).
    NoTetrahedra,
    /// A tet refers to a vertex that does not exist.
    IndexOutOfRange {
        /// The element.
        tet: u64,
        /// The missing vertex it names.
        vertex: u64,
    },
    /// A vertex with a NaN or infinite coordinate.
    NonFinite {
        /// The vertex.
        vertex: u64,
    },
    /// Tets of zero or near-zero volume; every one is listed.
    Degenerate {
        /// The elements.
        tets: Vec<u64>,
    },
}

/// How many items an error message lists before "(and N more)".
const LIST_MAX: usize = 10;

impl fmt::Display for MeshProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshProblem::NoTetrahedra => write!(f, "the mesh has no tetrahedra"),
            MeshProblem::IndexOutOfRange { tet, vertex } => {
                write!(
                    f,
                    "element {tet} refers to node {vertex}, which does not exist"
                )
            }
            MeshProblem::NonFinite { vertex } => {
                write!(
                    f,
                    "node {vertex} has a non-finite (NaN or infinite) coordinate"
                )
            }
            MeshProblem::Degenerate { tets } => {
                let shown: Vec<String> = tets.iter().take(LIST_MAX).map(u64::to_string).collect();
                let plural = if tets.len() == 1 { "" } else { "s" };
                write!(
                    f,
                    "degenerate element{plural} (zero or near-zero volume): {}",
                    shown.join(", ")
                )?;
                if tets.len() > LIST_MAX {
                    write!(f, " (and {} more)", tets.len() - LIST_MAX)?;
                }
                Ok(())
            }
        }
    }
}
