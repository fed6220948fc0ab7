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
        /// The key the error is about, as the message names it (`solver.dt`,
        /// `[[fixed]] #2 duration`); None for a syntax error outside every key.
        key: Option<String>,
        /// What is wrong, in words (prefixed with the key when there is one).
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
    /// A frame stopped from outside (the flag of [`crate::Simulation::set_interrupt`]); the
    /// state is that of the last complete frame.
    #[error("frame {frame}: interrupted; the state is that of frame {}", frame - 1)]
    Interrupted {
        /// The frame that was being computed.
        frame: usize,
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

    /// The scene key (or parameter) the error is about, when there is one: for callers that
    /// want it apart from the message (the Python module's `tetsim.Error.key`).
    pub fn key(&self) -> Option<&str> {
        match self {
            Error::Scene { key, .. } => key.as_deref(),
            Error::Parameter { name, .. } => Some(name),
            _ => None,
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

/// Longest name (of a group, model, strategy, field, …) quoted whole in a message.
pub const NAME_CHARS: usize = 60;

/// `name` for a message: whole up to [`NAME_CHARS`] characters, else cut there with its
/// length said, so that a pasted blob does not flood the terminal.
pub fn clip(name: &str) -> String {
    let count = name.chars().count();
    if count <= NAME_CHARS {
        name.to_string()
    } else {
        let head: String = name.chars().take(NAME_CHARS).collect();
        format!("{head}… ({count} characters)")
    }
}

/// [`clip`] every over-long word of a message (one quoting a pasted blob), leaving words a
/// message already clipped alone.
pub fn clip_words(message: &str) -> String {
    message
        .split(' ')
        .map(|w| {
            if w.chars().count() > NAME_CHARS + 20 {
                clip(w)
            } else {
                w.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
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
    /// Tets whose smallest dihedral angle is below the sliver threshold: valid, but they make
    /// the stiffness badly conditioned.
    Slivers {
        /// The elements.
        tets: Vec<u64>,
        /// The smallest dihedral angle among them, in degrees.
        min_angle_degrees: f64,
    },
    /// Tets with the same four vertices as an earlier tet (double mass and stiffness).
    DuplicateTets {
        /// The later copies.
        tets: Vec<u64>,
    },
    /// Distinct vertices at the same position: the mesh is cut along them (a hidden crack).
    DuplicateVertices {
        /// The later copies.
        vertices: Vec<u64>,
    },
    /// Faces shared by more than two tets: overlapping or non-manifold elements.
    NonManifoldFaces {
        /// The tets around such faces.
        tets: Vec<u64>,
    },
    /// The boundary surface is not closed and manifold: edges not shared by exactly two
    /// boundary triangles (tets touching only along an edge, or at a vertex).
    OpenSurface {
        /// How many such edges.
        edges: usize,
    },
    /// The mesh falls apart into several pieces that do not share a vertex.
    Disconnected {
        /// Tets in each piece, largest first.
        components: Vec<usize>,
    },
    /// Several problems at once (every one is listed).
    Many(Vec<MeshProblem>),
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
                let plural = if tets.len() == 1 { "" } else { "s" };
                write!(
                    f,
                    "degenerate element{plural} (zero or near-zero volume): {}",
                    list(tets)
                )
            }
            MeshProblem::Slivers {
                tets,
                min_angle_degrees,
            } => write!(
                f,
                "{} sliver element(s) (smallest dihedral angle {min_angle_degrees:.3}°): {}",
                tets.len(),
                list(tets)
            ),
            MeshProblem::DuplicateTets { tets } => {
                write!(
                    f,
                    "duplicate element(s) (same four nodes as an earlier one): {}",
                    list(tets)
                )
            }
            MeshProblem::DuplicateVertices { vertices } => write!(
                f,
                "duplicate node(s) (same position as an earlier node): {}",
                list(vertices)
            ),
            MeshProblem::NonManifoldFaces { tets } => write!(
                f,
                "faces shared by more than two elements (overlapping elements): {}",
                list(tets)
            ),
            MeshProblem::OpenSurface { edges } => write!(
                f,
                "the boundary surface is not closed and manifold ({edges} edge(s) not shared by exactly two boundary faces)"
            ),
            MeshProblem::Disconnected { components } => {
                let sizes: Vec<u64> = components.iter().map(|&c| c as u64).collect();
                write!(
                    f,
                    "the mesh has {} disconnected pieces (tets per piece: {})",
                    components.len(),
                    list(&sizes)
                )
            }
            MeshProblem::Many(problems) => {
                for (i, p) in problems.iter().enumerate() {
                    if i > 0 {
                        write!(f, "; ")?;
                    }
                    write!(f, "{p}")?;
                }
                Ok(())
            }
        }
    }
}

/// `a, b, c (and N more)`, at most [`LIST_MAX`] items.
fn list(items: &[u64]) -> String {
    let shown: Vec<String> = items.iter().take(LIST_MAX).map(u64::to_string).collect();
    let mut s = shown.join(", ");
    if items.len() > LIST_MAX {
        s.push_str(&format!(" (and {} more)", items.len() - LIST_MAX));
    }
    s
}
