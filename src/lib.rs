//! # tetsim: large elastic deformation on tetrahedral meshes
//!
//! A library (and the `tetsim` command) that simulates elastic solids meshed with linear
//! tetrahedra, robust to inversion, with backward Euler or quasistatic Newton and a matrix-free
//! conjugate gradient. The math, in the conventions used everywhere in this crate:
//!
//! ## Discretisation (SPEC §1)
//! For tet e with rest vertices X₀..X₃ and current x₀..x₃ (column vectors):
//! `Dm = [X₁−X₀, X₂−X₀, X₃−X₀]`, `Bm = Dm⁻¹`, `W = |det Dm|/6`;
//! `Ds = [x₁−x₀, x₂−x₀, x₃−x₀]`, `F = Ds·Bm`. Energy `E(x) = Σₑ W Ψ(Fₑ)`; forces `f = −∂E/∂x`:
//! `H = −W·P(F)·Bmᵀ`, columns on x₁, x₂, x₃, minus their sum on x₀. Stiffness
//! `K = ∂²E/∂x² = −∂f/∂x`, so `K·dx = −df` (methods that return K·dx say "stiffness").
//! Lumped masses: each tet gives ρW/4 to each of its vertices.
//!
//! ## Materials (SPEC §2, §3, §6)
//! Models are written in principal stretches σ of the rotation-variant SVD
//! `F = U·diag(σ)·Vᵀ` (det U = det V = +1, an inversion carried by σ₃ < 0): each is exactly its
//! formula wherever every stretch is at least the inversion threshold (0.1), and extended below it
//! so that energy, stress and tangent are finite for every F and a crushed stretch's resistance
//! keeps growing. Tangled elements (a collapsed or scrambled start, a tet that inverts) are
//! evaluated with recovery forms until the body is untangled ([`elastic::recovery`]). The tangent
//! ∂P/∂F splits in diagonal space into a 3×3 block and three 2×2 blocks whose negative
//! eigenvalues are handled per element by a [`material::Definiteness`] strategy: `adaptive` (the
//! default: Newton solves with Teran's projected tangent and switches to the exact one once it
//! stalls while no tet is inverted, back to the projection where that gives no descent; a
//! Newton policy, [`integrator::policy`]), `teran` (clamped to zero, Teran et al. 2005),
//! `analytic` (the same with closed-form eigensystems, Smith et al. 2019), `abs` (absolute
//! values) or `none` (the exact, possibly indefinite Hessian).
//! The Rayleigh stiffness damping force `−γ·K_d(x)·v` uses its own stiffness
//! ([`material::DampingStiffness`]: Teran's projection by default, so damping only dissipates,
//! or the exact K), the same under every strategy: strategies shape Newton's matrix, never the
//! forces.
//! Models ([`material::ModelKind`]): Neo-Hookean (with a Taylor-extended log below the
//! threshold, or inside Irving et al. 2004's clamped stretches as `neo-hookean-clamped`), corotated, Stable Neo-Hookean, St. Venant-Kirchhoff,
//! compressible Mooney-Rivlin, and linear elasticity (on F, not rotation invariant); all are
//! parametrised by the small-strain Lamé parameters (μ, λ).
//!
//! ## Modules
//! Always built:
//! - [`math`]: rotation-variant SVD, symmetric eigensolver, PSD clamp.
//! - [`material`]: Ψ, P, dP; the principal-stretch adaptor and definiteness strategies; the
//!   models.
//! - [`mesh`]: tet meshes, validation, boundary faces, the box generator.
//! - [`elastic`]: the elastic body: energy, forces, linearization and stiffness product.
//! - [`boundary`]: regions, Dirichlet constraints and motions, loads, ramps.
//! - [`linear`]: Newton's linear systems, knowing nothing of FEM: the [`linear::LinearSolver`]
//!   strategies (matrix-free, multigrid, Cholesky) on any [`linear::System`], and their parts
//!   ([`linear::cg`], [`linear::sparse`] block matrices, [`linear::amg`]).
//! - [`integrator`]: one step as Newton on the incremental potential (SPEC §4): settings, the
//!   potential's [`integrator::Term`]s (inertia, elasticity, loads; contact and a user's own
//!   terms join them), the time schemes ([`integrator::scheme`]: backward Euler, BDF2, Newmark),
//!   Newton, the line search, the tangent policy, statistics.
//! - [`contact`]: Incremental Potential Contact: distances, barrier, CCD, broad phase, contact
//!   surfaces, rigid obstacles, friction, and the contact term of the incremental potential.
//! - [`audit`]: the energy audit of every step (steps.csv, run summary).
//! - [`sim`]: the simulation (state + solver), advanced frame by frame.
//! - [`modes`]: vibration modes at rest (LOBPCG, [`linear::lobpcg`]) and Rayleigh damping from
//!   a damping ratio.
//! - [`scene`]: the TOML scene contract (SPEC §10).
//! - [`io`]: mesh files in and out (Gmsh, TetGen, VTK/VTU, MEDIT, OBJ), VTU frames, PVD.
//! - [`runner`]: the frame loop the command line and Python share: frames, checkpoints, stop flag,
//!   the run's ending.
//! - [`output`]: the run's output files (frames, collection, surfaces, steps.csv).
//! - [`manifest`]: `manifest.json`: version, input hashes, resolved parameters, output hashes.
//! - [`checkpoint`]: `checkpoint.bin`: what a stopped run needs to go on with the same bytes.
//! - [`check`]: the derivative self-check (`tetsim check`).
//! - [`diagnose`]: what went wrong, in words: inverted elements, run summary, warnings.
//! - [`field`]: the fields pictures are coloured by (displacement, J, von Mises, Ψ).
//! - [`error`]: typed, located errors.
//! - [`resources`]: memory and cores a run may ask for, checked before it asks.
//!
//! Behind cargo features (see below):
//! - `linear::direct` and `linear::cholesky` (feature `direct`): faer's sparse Cholesky of the
//!   assembled system, the other preconditioner for it.
//! - `render` (feature `render`): headless pictures: software renderer → PNG and GIF, plots of
//!   `steps.csv`.
//! - `progress` (feature `cli`): the run display: progress bar and end-of-run summary.
//! - `bench` (feature `cli`): the `tetsim bench` workload.
//!
//! ## Features
//! - `cli` and `render`, the defaults: the `tetsim` command (`cli` implies `render`) and the
//!   pictures (`preview.png`, `animation.gif`, `steps_*.png`).
//! - `--no-default-features` (`default-features = false` in a dependent's Cargo.toml): a lean
//!   library for a Python extension or an MPI rank: physics, meshes, scene files and the VTU,
//!   PVD, OBJ and CSV output, with none of the command-line or picture crates (clap, anyhow,
//!   env_logger, indicatif, plotters, ab_glyph, png, gif). The library never draws pictures
//!   itself: `[output] pictures` and `plots` are honoured by the `tetsim` command, so such a
//!   build still writes every frame and `steps.csv`, and simply has no picture to draw.
//! - `direct` (opt-in): the sparse Cholesky preconditioner (`[solver] preconditioner =
//!   "cholesky"`); faer adds minutes to a cold build.

#![warn(missing_docs)]
// No unsafe code, except with the `mpi` feature in one module: PETSc's FFI
// (src/parallel/petsc.rs), where every block says why it is sound.
#![cfg_attr(not(feature = "mpi"), forbid(unsafe_code))]
#![cfg_attr(feature = "mpi", deny(unsafe_code))]

pub mod audit;
#[cfg(feature = "cli")]
pub mod bench;
pub mod boundary;
pub mod check;
pub mod checkpoint;
pub mod contact;
pub mod diagnose;
pub mod elastic;
pub mod error;
pub mod field;
pub mod info;
pub mod integrator;
pub mod io;
pub mod linear;
pub mod manifest;
pub mod material;
pub mod math;
pub mod memory;
pub mod mesh;
pub mod modes;
pub mod monitor;
pub mod output;
pub mod parallel;
#[cfg(feature = "cli")]
pub mod progress;
#[cfg(feature = "render")]
pub mod render;
pub mod resources;
pub mod runner;
pub mod scene;
pub mod sim;

pub use elastic::{ElasticBody, Linearization};
pub use error::{Error, MeshProblem, Result};
pub use material::{Definiteness, Lame, Material, Model, ModelKind};
pub use math::{Mat3, Vec3};
pub use mesh::TetMesh;
pub use scene::Scene;
pub use sim::{Simulation, State};
