//! Vibration modes of a body at rest (SPEC §13) and Rayleigh damping from a damping ratio.
//!
//! **Problem.** Small vibrations `x = x_rest + φ·sin(ωt)` about the rest shape solve
//! `K·φ = ω²·M·φ` over the free DOFs: K = ∂²E/∂x² at the rest positions (at F = I every model
//! here reduces to linear elasticity with its small-strain Lamé parameters; loads and gravity
//! do not prestress it), M the lumped mass the simulator uses, the scene's `[[fixed]]` DOFs
//! removed. Frequencies are `f = ω/2π` in Hz, shapes are mass-normalised (`φᵀ·M·φ = 1`).
//!
//! **Rigid-body modes.** A piece of the mesh that the constraints do not hold (a free body, a
//! body held by one vertex, a second body of the scene) moves rigidly at no cost: those motions
//! are eigenvectors at ω = 0. They are found here in closed form — per connected piece of the
//! mesh, the combinations of its 3 translations and 3 infinitesimal rotations that leave every
//! constrained component at rest — reported as the first modes, at 0 Hz, as engineering codes
//! do, and deflated from the iterative solve, which then finds the elastic modes above them.
//! `--count` counts both: a free body's first six modes are rigid.
//!
//! **Solve.** [`lobpcg`](crate::linear::lobpcg) on the assembled K, preconditioned by one
//! V-cycle of the solver's smoothed-aggregation multigrid ([`crate::linear::amg`]) built on
//! `K + σ·M` with a tiny shift `σ = 1e-10·λ̄` (λ̄ the Gershgorin bound of M⁻¹K): the shift makes
//! the preconditioner's matrix positive definite when K is singular (rigid modes, a mechanism
//! in the mesh) and changes nothing measurable otherwise. The eigensolver runs on `K + σ·M`
//! itself (one matrix in memory instead of two) and σ is subtracted from its eigenvalues.
//!
//! **Damping.** [`rayleigh_from_ratio`]: the Rayleigh damping `C = α·M + γ·K` whose modal
//! damping ratio `ζ(ω) = α/(2ω) + γ·ω/2` equals ζ at ω₁ and ω₂.

use std::time::Instant;

use crate::elastic::{AssemblyWork, ElasticBody};
use crate::linear::amg::{Amg, AmgParams};
use crate::linear::cg::LinearOperator;
use crate::linear::lobpcg::{self, LobpcgError, LobpcgInfo, LobpcgParams};
use crate::linear::sparse::BlockCsr;
use crate::material::Definiteness;
use crate::math::Vec3;

/// The shift of the preconditioner's (and operator's) matrix, relative to λ̄ (see the module
/// docs): large enough to make K + σM factor on the coarsest multigrid level with 6 null
/// directions (its rounding is ~1e-16·λ̄), far below the lowest elastic eigenvalue of any
/// sensible mesh (λ₁/λ̄ = 1e-6 on the 4:1 cantilever meshed 12 across, 4e-7 at 20 across).
const SHIFT: f64 = 1e-10;

/// A constrained rigid motion: its share of the piece's mass on constrained components is
/// below this (rounding), so it moves nothing the constraints hold.
const RIGID_NULL: f64 = 1e-10;

/// At most this many rigid-body modes (pieces × 6) are deflated: each is a full vector, and a
/// mesh of hundreds of loose pieces is a meshing problem, not a vibration problem.
const MAX_RIGID_MODES: usize = 600;

/// Settings of [`VibrationProblem::solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct ModesParams {
    /// How many modes, the lowest first, rigid-body modes included. Default 6.
    pub count: usize,
    /// Relative residual each elastic mode must reach (see [`crate::linear::lobpcg`]).
    /// Default 1e-6: frequencies within 5e-7 (in practice far closer).
    pub tolerance: f64,
    /// LOBPCG iteration cap. Default 1000.
    pub max_iterations: usize,
}

impl Default for ModesParams {
    fn default() -> Self {
        ModesParams {
            count: 6,
            tolerance: 1e-6,
            max_iterations: 1000,
        }
    }
}

/// One vibration mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Frequency in Hz, `√max(λ, 0)/2π`; exactly 0 for a rigid-body mode (its computed λ is
    /// rounding, and would order the rigid modes at random).
    pub frequency_hz: f64,
    /// The eigenvalue λ = ω² (1/s²) as computed (rounding, possibly negative, for rigid modes).
    pub eigenvalue: f64,
    /// The shape, one vector per vertex (m per √kg), zero on constrained components,
    /// `φᵀ·M·φ = 1`, its largest component positive.
    pub shape: Vec<Vec3>,
    /// A rigid-body motion (found in closed form) rather than an elastic mode.
    pub rigid: bool,
}

/// The modes and what finding them took.
#[derive(Clone, Debug, Default)]
pub struct Modes {
    /// Ascending frequency (rigid-body modes first).
    pub modes: Vec<Mode>,
    /// The eigensolver's counts (None when every mode asked for was rigid).
    pub info: Option<LobpcgInfo>,
    /// Seconds of the eigensolver.
    pub solve_seconds: f64,
}

/// Why the modes could not be found.
#[derive(Clone, Debug, thiserror::Error)]
pub enum ModesError {
    /// More modes asked for than the body has free degrees of freedom.
    #[error("{wanted} modes asked for, but the body has only {available} free degrees of freedom")]
    TooFewDofs {
        /// Modes asked for.
        wanted: usize,
        /// Free DOFs.
        available: usize,
    },
    /// The mesh falls apart into too many unconstrained pieces.
    #[error(
        "the mesh has {pieces} pieces that the constraints leave free to move ({modes} rigid-body modes; at most {MAX_RIGID_MODES} are handled): check the mesh with `tetsim mesh check`"
    )]
    TooManyPieces {
        /// Connected pieces of the mesh.
        pieces: usize,
        /// Their rigid-body modes.
        modes: usize,
    },
    /// The eigensolver stopped without meeting its tolerance.
    #[error("{0}; try --tolerance 1e-5 or fewer modes")]
    NotConverged(String),
    /// A NaN or infinity (a broken material or mesh).
    #[error("{0}")]
    NonFinite(String),
}

/// K at rest (shifted), the mass, the free DOFs, the rigid-body modes and the preconditioner of
/// one body: built once, then solved for as many modes as asked.
pub struct VibrationProblem {
    /// K + σ·M, constrained.
    a: BlockCsr,
    amg: Amg,
    mass: Vec<f64>,
    free: Vec<Vec3>,
    shift: f64,
    spectrum_bound: f64,
    rigid: Vec<Vec<Vec3>>,
    /// Seconds to assemble K and build the multigrid hierarchy.
    pub setup_seconds: f64,
}

impl VibrationProblem {
    /// Assemble K at the rest positions, find the rigid-body modes the constraints allow and
    /// build the multigrid preconditioner. `free` is the 0/1 mask of the DOFs (the
    /// simulation's [`crate::Simulation::free_mask`]); vertices without mass count as fixed.
    pub fn new(body: &ElasticBody, free: &[Vec3]) -> Result<Self, ModesError> {
        let started = Instant::now();
        let n = body.vertex_count();
        assert_eq!(free.len(), n);
        let mass = body.masses().to_vec();
        let free: Vec<Vec3> = free
            .iter()
            .zip(&mass)
            .map(|(f, &m)| if m > 0.0 { *f } else { Vec3::zeros() })
            .collect();
        let rest = &body.mesh.positions;
        let mut a = BlockCsr::zeros(body.stiffness_pattern());
        {
            let lin = body.linearize(rest, Definiteness::Exact);
            let mut work = AssemblyWork::default();
            body.write_stiffness(&lin, 1.0, &mut a, &mut work, true);
        }
        a.constrain(&free);
        let spectrum_bound = gershgorin_bound(&a, &mass, &free);
        let shift = SHIFT * spectrum_bound;
        let shifted: Vec<f64> = mass.iter().map(|m| shift * m).collect();
        a.add_diagonal(&shifted);
        let rigid = rigid_modes(body, &mass, &free)?;
        let amg = Amg::new(&a, rest, &free, &AmgParams::default());
        log::info!(
            "modes: K assembled, {} rigid-body mode(s), multigrid of {} levels, λ̄ = {spectrum_bound:.3e} 1/s²",
            rigid.len(),
            amg.info().levels.len()
        );
        Ok(VibrationProblem {
            a,
            amg,
            mass,
            free,
            shift,
            spectrum_bound,
            rigid,
            setup_seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// How many of the lowest modes are rigid-body motions.
    pub fn rigid_count(&self) -> usize {
        self.rigid.len()
    }

    /// Free DOFs.
    pub fn free_dofs(&self) -> usize {
        self.free.iter().map(|m| m.sum() as usize).sum()
    }

    /// The `params.count` lowest modes.
    pub fn solve(&mut self, params: &ModesParams) -> Result<Modes, ModesError> {
        let available = self.free_dofs();
        if params.count > available {
            return Err(ModesError::TooFewDofs {
                wanted: params.count,
                available,
            });
        }
        let mut modes: Vec<Mode> = Vec::with_capacity(params.count);
        for y in self.rigid.iter().take(params.count) {
            let lambda = self.rayleigh_quotient(y) - self.shift;
            modes.push(mode(lambda, y.clone(), true));
        }
        let elastic = params.count - modes.len();
        let mut result = Modes::default();
        if elastic > 0 {
            let started = Instant::now();
            let lobpcg_params = LobpcgParams {
                count: elastic,
                tolerance: params.tolerance,
                max_iterations: params.max_iterations,
                spectrum_bound: self.spectrum_bound,
                ..Default::default()
            };
            let pairs = lobpcg::lobpcg(
                &mut Operator(&self.a),
                &self.mass,
                &self.free,
                &mut self.amg,
                &self.rigid,
                &lobpcg_params,
            )
            .map_err(|e| match e {
                LobpcgError::TooFewDofs { .. } => ModesError::TooFewDofs {
                    wanted: params.count,
                    available,
                },
                LobpcgError::NonFinite { .. } => ModesError::NonFinite(e.to_string()),
                LobpcgError::NotConverged(_) => ModesError::NotConverged(e.to_string()),
            })?;
            result.solve_seconds = started.elapsed().as_secs_f64();
            for (lambda, shape) in pairs.values.iter().zip(pairs.vectors) {
                modes.push(mode(lambda - self.shift, shape, false));
            }
            result.info = Some(pairs.info);
        }
        result.modes = modes;
        Ok(result)
    }

    /// `yᵀ·A·y` (y mass-normalised).
    fn rayleigh_quotient(&self, y: &[Vec3]) -> f64 {
        let mut ay = vec![Vec3::zeros(); y.len()];
        self.a.multiply(y, &mut ay);
        y.iter()
            .zip(&ay)
            .zip(&self.free)
            .map(|((y, ay), m)| y.component_mul(m).dot(ay))
            .sum()
    }
}

/// A mode from its eigenvalue and shape: the frequency, and the sign that makes the largest
/// component positive (so the same run writes the same shapes).
fn mode(eigenvalue: f64, mut shape: Vec<Vec3>, rigid: bool) -> Mode {
    let mut largest = 0.0_f64;
    for c in shape.iter().flat_map(|v| v.iter()) {
        if c.abs() > largest.abs() {
            largest = *c;
        }
    }
    if largest < 0.0 {
        shape.iter_mut().for_each(|v| *v = -*v);
    }
    Mode {
        frequency_hz: if rigid {
            0.0
        } else {
            eigenvalue.max(0.0).sqrt() / (2.0 * std::f64::consts::PI)
        },
        eigenvalue,
        shape,
        rigid,
    }
}

/// The assembled matrix as the eigensolver's operator.
struct Operator<'a>(&'a BlockCsr);

impl LinearOperator for Operator<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

/// Gershgorin's bound on the largest eigenvalue of M⁻¹K over the free DOFs:
/// `max_i Σ_j |K_ij| / m_i`.
fn gershgorin_bound(a: &BlockCsr, mass: &[f64], free: &[Vec3]) -> f64 {
    let p = &a.pattern;
    (0..a.rows())
        .map(|i| {
            if mass[i] <= 0.0 {
                return 0.0;
            }
            let mut rows = Vec3::zeros();
            for k in p.row(i) {
                let j = p.cols[k] as usize;
                let block = &a.block(k);
                for r in 0..3 {
                    for c in 0..3 {
                        rows[r] += block[(r, c)].abs() * free[j][c];
                    }
                }
            }
            rows.component_mul(&free[i]).max() / mass[i]
        })
        .fold(0.0, f64::max)
}

/// The mass-normalised rigid-body motions the constraints allow, piece by piece of the mesh
/// (see the module docs).
fn rigid_modes(
    body: &ElasticBody,
    mass: &[f64],
    free: &[Vec3],
) -> Result<Vec<Vec<Vec3>>, ModesError> {
    use nalgebra::{DMatrix, SymmetricEigen};
    let n = body.vertex_count();
    let pieces = connected_pieces(n, &body.mesh.tets);
    let rest = &body.mesh.positions;
    let mut modes = Vec::new();
    let count = pieces.len();
    for vertices in &pieces {
        let total: f64 = vertices.iter().map(|&v| mass[v]).sum();
        if total <= 0.0 {
            continue;
        }
        let centre = vertices
            .iter()
            .fold(Vec3::zeros(), |s, &v| s + rest[v] * mass[v])
            / total;
        let extent = vertices
            .iter()
            .map(|&v| (rest[v] - centre).amax())
            .fold(0.0, f64::max);
        let scale = if extent > 0.0 { 1.0 / extent } else { 1.0 };
        // The six motions at vertex v: translations e_k, rotations e_k × (x − c)/L.
        let motion = |k: usize, v: usize| -> Vec3 {
            if k < 3 {
                Vec3::ith(k, 1.0)
            } else {
                Vec3::ith(k - 3, 1.0).cross(&((rest[v] - centre) * scale))
            }
        };
        // Mass-weighted Gram matrices over the whole piece and over its constrained components.
        let mut whole = DMatrix::<f64>::zeros(6, 6);
        let mut held = DMatrix::<f64>::zeros(6, 6);
        for &v in vertices {
            let m: [Vec3; 6] = std::array::from_fn(|k| motion(k, v));
            for a in 0..6 {
                for b in a..6 {
                    let full = mass[v] * m[a].dot(&m[b]);
                    let fixed = mass[v]
                        * m[a]
                            .component_mul(&(Vec3::repeat(1.0) - free[v]))
                            .dot(&m[b]);
                    whole[(a, b)] += full;
                    held[(a, b)] += fixed;
                }
            }
        }
        whole.fill_lower_triangle_with_upper_triangle();
        held.fill_lower_triangle_with_upper_triangle();
        // Orthonormalise the six motions in mass (whole = L·Lᵀ), then the motions with no mass
        // on constrained components are the null space of L⁻¹·held·L⁻ᵀ.
        let Some(l_inv) = whole.cholesky().and_then(|c| c.l().try_inverse()) else {
            continue;
        };
        let reduced = &l_inv * held * l_inv.transpose();
        let eigen = SymmetricEigen::new((&reduced + reduced.transpose()) * 0.5);
        let mut null: Vec<usize> = (0..6)
            .filter(|&i| eigen.eigenvalues[i] <= RIGID_NULL)
            .collect();
        null.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
        for i in null {
            let coefficients = l_inv.transpose() * eigen.eigenvectors.column(i);
            let mut y = vec![Vec3::zeros(); n];
            for &v in vertices {
                y[v] = (0..6)
                    .map(|k| motion(k, v) * coefficients[k])
                    .sum::<Vec3>()
                    .component_mul(&free[v]);
            }
            modes.push(y);
            if modes.len() > MAX_RIGID_MODES {
                return Err(ModesError::TooManyPieces {
                    pieces: count,
                    modes: modes.len(),
                });
            }
        }
    }
    Ok(modes)
}

/// The vertex sets of the mesh's connected pieces (vertices sharing a tet), each sorted, in
/// order of their smallest vertex; vertices of no tet are left out.
fn connected_pieces(n: usize, tets: &[[usize; 4]]) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    let mut used = vec![false; n];
    for tet in tets {
        let r0 = root(&mut parent, tet[0]);
        used[tet[0]] = true;
        for &v in &tet[1..] {
            used[v] = true;
            let r = root(&mut parent, v);
            if r != r0 {
                let (lo, hi) = (r.min(r0), r.max(r0));
                parent[hi] = lo;
            }
        }
    }
    let mut index = vec![usize::MAX; n];
    let mut pieces: Vec<Vec<usize>> = Vec::new();
    for (v, &used) in used.iter().enumerate() {
        if !used {
            continue;
        }
        let r = root(&mut parent, v);
        if index[r] == usize::MAX {
            index[r] = pieces.len();
            pieces.push(Vec::new());
        }
        pieces[index[r]].push(v);
    }
    pieces
}

/// Rayleigh coefficients `(α, γ)` (1/s and s: `rayleigh_mass`, `rayleigh_stiffness`) whose
/// modal damping ratio is ζ at f₁ and f₂ (Hz): `α = 2ζω₁ω₂/(ω₁+ω₂)`, `γ = 2ζ/(ω₁+ω₂)`,
/// ω = 2πf. Between f₁ and f₂ the ratio is a little below ζ, outside it rises.
pub fn rayleigh_from_ratio(zeta: f64, f1: f64, f2: f64) -> (f64, f64) {
    let (w1, w2) = (
        2.0 * std::f64::consts::PI * f1,
        2.0 * std::f64::consts::PI * f2,
    );
    (2.0 * zeta * w1 * w2 / (w1 + w2), 2.0 * zeta / (w1 + w2))
}

/// Damping resolved from `[solver] damping_ratio`: what a run uses and its manifest records.
#[derive(Clone, Debug, PartialEq)]
pub struct DampingResolution {
    /// ζ.
    pub ratio: f64,
    /// f₁, f₂ (Hz).
    pub frequencies_hz: [f64; 2],
    /// True when f₁ is the body's lowest elastic mode (no `damping_frequencies` given).
    pub from_modes: bool,
    /// α = `rayleigh_mass` (1/s).
    pub rayleigh_mass: f64,
    /// γ = `rayleigh_stiffness` (s).
    pub rayleigh_stiffness: f64,
}

impl DampingResolution {
    /// ζ at f₁ and f₂.
    pub fn new(ratio: f64, frequencies_hz: [f64; 2], from_modes: bool) -> Self {
        let (alpha, gamma) = rayleigh_from_ratio(ratio, frequencies_hz[0], frequencies_hz[1]);
        DampingResolution {
            ratio,
            frequencies_hz,
            from_modes,
            rayleigh_mass: alpha,
            rayleigh_stiffness: gamma,
        }
    }

    /// ζ at the body's lowest elastic mode and ten times its frequency.
    pub fn from_lowest_mode(
        ratio: f64,
        body: &ElasticBody,
        free: &[Vec3],
    ) -> Result<Self, ModesError> {
        let mut problem = VibrationProblem::new(body, free)?;
        let params = ModesParams {
            count: problem.rigid_count() + 1,
            ..Default::default()
        };
        let modes = problem.solve(&params)?;
        let lowest = modes.modes.last().map_or(0.0, |m| m.frequency_hz);
        if lowest.is_nan() || lowest <= 0.0 {
            return Err(ModesError::NonFinite(format!(
                "the lowest elastic mode has no positive frequency ({lowest} Hz)"
            )));
        }
        Ok(Self::new(ratio, [lowest, 10.0 * lowest], true))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Lame, Model, ModelKind};
    use crate::mesh::generate::box_mesh;

    fn beam(cells: [usize; 3]) -> ElasticBody {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), cells);
        let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
        ElasticBody::new(mesh, model, 1000.0).unwrap()
    }

    #[test]
    fn rayleigh_coefficients_give_the_ratio_at_both_frequencies() {
        let (zeta, f1, f2) = (0.03, 2.0, 17.0);
        let (alpha, gamma) = rayleigh_from_ratio(zeta, f1, f2);
        for f in [f1, f2] {
            let w = 2.0 * std::f64::consts::PI * f;
            assert!((alpha / (2.0 * w) + gamma * w / 2.0 - zeta).abs() < 1e-15);
        }
    }

    #[test]
    fn a_free_body_has_six_rigid_modes_then_elastic_ones() {
        let body = beam([4, 1, 1]);
        let free = vec![Vec3::repeat(1.0); body.vertex_count()];
        let mut problem = VibrationProblem::new(&body, &free).unwrap();
        assert_eq!(problem.rigid_count(), 6);
        let modes = problem
            .solve(&ModesParams {
                count: 8,
                ..Default::default()
            })
            .unwrap();
        let f: Vec<f64> = modes.modes.iter().map(|m| m.frequency_hz).collect();
        assert!(f[..6].iter().all(|&r| r == 0.0), "{f:?}");
        // The rigid motions are null vectors of K: their ω² is rounding.
        for m in &modes.modes[..6] {
            assert!(m.rigid && m.eigenvalue.abs() < 1e-8 * modes.modes[6].eigenvalue);
        }
        assert!(f[6] > 0.0 && f[7] >= f[6]);
    }

    #[test]
    fn constraints_leave_only_the_rigid_motions_they_allow() {
        let body = beam([4, 1, 1]);
        let n = body.vertex_count();
        // One vertex fixed: the three rotations about it remain.
        let mut free = vec![Vec3::repeat(1.0); n];
        free[0] = Vec3::zeros();
        assert_eq!(
            VibrationProblem::new(&body, &free).unwrap().rigid_count(),
            3
        );
        // Only x fixed on the x = 0 face: y and z translations and the rotation about x remain.
        let mut free = vec![Vec3::repeat(1.0); n];
        for (v, p) in body.mesh.positions.iter().enumerate() {
            if p.x == 0.0 {
                free[v].x = 0.0;
            }
        }
        assert_eq!(
            VibrationProblem::new(&body, &free).unwrap().rigid_count(),
            3
        );
        // Clamped face: none.
        let free: Vec<Vec3> = crate::boundary::mask_holding(&body.mesh.positions, |p| p.x == 0.0);
        assert_eq!(
            VibrationProblem::new(&body, &free).unwrap().rigid_count(),
            0
        );
    }
}
