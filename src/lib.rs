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
//! `F = U·diag(σ)·Vᵀ` (det U = det V = +1, an inversion carried by σ₃ < 0), extended below an
//! inversion threshold so that energy, stress and tangent are finite for every F. The tangent
//! ∂P/∂F splits in diagonal space into a 3×3 block and three 2×2 blocks whose negative
//! eigenvalues are fixed per element by a [`material::Definiteness`] strategy: `teran` (clamped
//! to zero, Teran et al. 2005; the default), `analytic` (the same with closed-form eigensystems,
//! Smith et al. 2019), `abs` (absolute values) or `none` (the exact, possibly indefinite Hessian).
//! Models ([`material::ModelKind`]): Neo-Hookean, corotated, Stable Neo-Hookean, St.
//! Venant-Kirchhoff, compressible Mooney-Rivlin, and linear elasticity (on F, not rotation
//! invariant); all are parametrised by the small-strain Lamé parameters (μ, λ).
//!
//! ## Modules
//! - [`math`]: rotation-variant SVD, symmetric eigensolver, PSD clamp.
//! - [`material`]: Ψ, P, dP; the principal-stretch adaptor and definiteness strategies; the six
//!   models.
//! - [`mesh`]: tet meshes, validation, boundary faces, the box generator.
//! - [`elastic`]: the elastic body: energy, forces, linearization and stiffness product.
//! - [`boundary`]: regions, Dirichlet constraints and motions, loads, ramps.
//! - [`cg`]: preconditioned conjugate gradient on any linear operator.
//! - [`contact`]: Incremental Potential Contact pieces: distances, barrier, CCD, broad phase,
//!   contact surfaces, rigid obstacles, friction (not yet wired into the integrator).
//! - [`amg`]: smoothed-aggregation algebraic multigrid, a preconditioner for the assembled system.
//! - `direct` (cargo feature `direct`): faer's sparse Cholesky of the assembled system, the
//!   other preconditioner for it.
//! - [`integrator`]: Newton on backward Euler or quasistatic equilibrium (SPEC §4).
//! - [`audit`]: the energy audit of every step (steps.csv, run summary).
//! - [`sim`]: the simulation (state + solver), advanced frame by frame.
//! - [`scene`]: the TOML scene contract (SPEC §10).
//! - [`io`]: mesh files in and out (Gmsh, TetGen, VTK/VTU, MEDIT, OBJ), VTU frames, PVD.
//! - [`output`]: the run's output files (frames, collection, surfaces, steps.csv).
//! - [`manifest`]: `manifest.json`: version, input hashes, resolved parameters, output hashes.
//! - [`sparse`]: assembled block-sparse matrices; [`bench`]: the `tetsim bench` workload.
//! - [`check`]: the derivative self-check (`tetsim check`).
//! - [`diagnose`]: what went wrong, in words: inverted elements, run summary, warnings.
//! - [`error`]: typed, located errors.
//! - [`render`]: headless pictures: software renderer → PNG and GIF, plots of `steps.csv`.
//! - [`progress`]: the run display: progress bar and end-of-run summary.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod amg;
pub mod audit;
pub mod bench;
pub mod boundary;
pub mod cg;
pub mod check;
pub mod contact;
pub mod diagnose;
#[cfg(feature = "direct")]
pub mod direct;
pub mod elastic;
pub mod error;
pub mod integrator;
pub mod io;
pub mod manifest;
pub mod material;
pub mod math;
pub mod mesh;
pub mod output;
pub mod progress;
pub mod render;
pub mod scene;
pub mod sim;
pub mod sparse;

pub use elastic::{ElasticBody, Linearization};
pub use error::{Error, MeshProblem, Result};
pub use material::{Definiteness, Lame, Material, Model, ModelKind};
pub use math::{Mat3, Vec3};
pub use mesh::TetMesh;
pub use scene::Scene;
pub use sim::{Simulation, State};
