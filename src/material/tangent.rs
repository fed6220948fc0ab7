//! What a model hands the element kernels besides Ψ and P: the tangent ∂P/∂F frozen at one F
//! in its diagonal-space form, the definiteness strategies that make it positive semi-definite,
//! and the damped step's tangent (where it is taken, what it adds).

use super::isotropic;
use crate::math::{Mat3, Vec3};

/// How the stress differential treats the indefinite parts of ∂P/∂F, per element.
///
/// In the diagonal space of the rotation-variant SVD, ∂P/∂F is one symmetric 3×3 block (∂²Ψ̂/∂σ²,
/// the "scaling" modes) and six scalar eigenvalues, two per pair of stretches (the "flip" and
/// "twist" modes, `(pᵢ − pⱼ)/(σᵢ − σⱼ)` and `(pᵢ + pⱼ)/(σᵢ + σⱼ)`). These nine are exactly the
/// eigenvalues of the 9×9 tangent (Teran et al. 2005 §4, Smith et al. 2019), so every
/// strategy below acts on them and then rotates back with U and V. Every strategy but `Exact`
/// yields a positive semi-definite tangent, and leaves it untouched (bit for bit) where it is
/// already PSD.
///
/// Scene names ([`Definiteness::from_name`]): `adaptive` (the default), `teran`, `analytic`, `abs`,
/// `none`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Definiteness {
    /// `none`: the exact derivative, for derivative tests and exact-Newton experiments. K may be
    /// indefinite far from rest, and CG may then break down.
    Exact,
    /// `teran`: Teran et al. 2005, negative eigenvalues of the 3×3 block (found by a Jacobi
    /// eigensolver, skipped when an exact minors test shows the block PSD) and of the pairs
    /// clamped to zero. Equal to `Exact` where that is already PSD.
    Projected,
    /// `abs`: negative eigenvalues replaced by their absolute values instead of zero, so a
    /// direction of negative curvature keeps its stiffness (with the opposite sign) rather than
    /// becoming free. Often fewer Newton iterations under heavy compression; a larger change to
    /// the Hessian where it is indefinite.
    Abs,
    /// `analytic`: the same clamp as `teran`, with the 3×3 block's eigensystem in closed form
    /// (Smith et al. 2019) where the model provides one ([`Isotropic::block_eigensystem`]);
    /// models without one fall back to the numerical eigensolver, so the result equals `teran`
    /// up to rounding either way. The pair eigenvalues are closed forms for every model.
    Analytic,
    /// `adaptive`: the exact tangent while it works, `teran` where it does not (after Longva et
    /// al. 2023, "Pitfalls of projection"). Per element it is `teran` (so every material-level
    /// call returns the projected tangent); the Newton solver keeps the exact pieces beside the
    /// projected ones, solves with the exact K (in damped steps from the first iterate, in
    /// undamped ones once projected Newton stalls; see `integrator::policy`) and falls back to
    /// the projected K for that iterate when CG meets negative curvature, the direction is not a
    /// descent direction or the line search fails. Projection makes Newton linear wherever it
    /// clamps (compressed, nearly incompressible bodies: 240 Newton iterations per frame against
    /// 12 on the ν = 0.49 cantilever at dt = 1 s; a bending beam's compressed side: 3.67 against
    /// 2.13 on the 41,472-tet bench beam), the fallback keeps the exact tangent's breakdowns
    /// harmless. The default: in undamped steps identical to `teran` wherever projected Newton
    /// converges well.
    #[default]
    Adaptive,
}

impl Definiteness {
    /// Every strategy, the default first.
    pub const ALL: [Definiteness; 5] = [
        Definiteness::Adaptive,
        Definiteness::Projected,
        Definiteness::Analytic,
        Definiteness::Abs,
        Definiteness::Exact,
    ];

    /// `teran`, the scene name of [`Definiteness::Projected`].
    pub const TERAN: Definiteness = Definiteness::Projected;

    /// `none`, the scene name of [`Definiteness::Exact`].
    pub const NONE: Definiteness = Definiteness::Exact;

    /// The scene name (`[solver] definiteness = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            Definiteness::Projected => "teran",
            Definiteness::Analytic => "analytic",
            Definiteness::Abs => "abs",
            Definiteness::Exact => "none",
            Definiteness::Adaptive => "adaptive",
        }
    }

    /// The strategy of a scene name, or of an alias (`projected`, `clamp` for `teran`;
    /// `exact` for `none`; `absolute` for `abs`). Names are case-insensitive.
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "teran" | "projected" | "clamp" => Some(Definiteness::Projected),
            "analytic" => Some(Definiteness::Analytic),
            "abs" | "absolute" => Some(Definiteness::Abs),
            "none" | "exact" => Some(Definiteness::Exact),
            "adaptive" => Some(Definiteness::Adaptive),
            _ => None,
        }
    }

    /// True for every strategy that guarantees a positive semi-definite tangent (all but
    /// `Exact`, with which CG may meet negative curvature and break down).
    pub fn is_psd(self) -> bool {
        self != Definiteness::Exact
    }
}

impl std::fmt::Display for Definiteness {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which stiffness the Rayleigh damping force `f_d = −γ·K(x)·v` uses: a choice of physics,
/// made once per scene, and the same function of (x, v) whatever [`Definiteness`] strategy and
/// tangent policy Newton uses (those only shape Newton's matrix, never the forces).
///
/// Scene names ([`DampingStiffness::from_name`]): `projected` (the default), `exact`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DampingStiffness {
    /// `projected`: K with Teran et al. 2005's clamp (negative diagonal-space eigenvalues set to
    /// zero per element, as `definiteness = "teran"` makes it). K is then positive
    /// semi-definite, so the damping power `−γ·vᵀK·v` is never positive: damping only
    /// dissipates, also where elements are compressed or inverted (where the exact K is
    /// indefinite and `exact` damping would feed energy in). VegaFEM damps with its SPD-fixed K
    /// too. Identical to `exact` wherever the exact K is already positive semi-definite.
    #[default]
    Projected,
    /// `exact`: K(x) = ∂²E/∂x², SPEC §4 as written (and what FEniCSx's UFL derivative gives). It
    /// may be indefinite far from rest, where the damping force can then do positive work.
    Exact,
}

impl DampingStiffness {
    /// Every choice, the default first.
    pub const ALL: [DampingStiffness; 2] = [DampingStiffness::Projected, DampingStiffness::Exact];

    /// The scene name (`[solver] damping_stiffness = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            DampingStiffness::Projected => "projected",
            DampingStiffness::Exact => "exact",
        }
    }

    /// The choice of a scene name (`teran` is an alias of `projected`, `none` of `exact`);
    /// case-insensitive.
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "projected" | "teran" => Some(DampingStiffness::Projected),
            "exact" | "none" => Some(DampingStiffness::Exact),
            _ => None,
        }
    }

    /// The per-element treatment of the tangent that makes this K.
    pub fn definiteness(self) -> Definiteness {
        match self {
            DampingStiffness::Projected => Definiteness::Projected,
            DampingStiffness::Exact => Definiteness::Exact,
        }
    }

    /// True for the default (scene files and manifests leave it out then).
    pub fn is_default(&self) -> bool {
        *self == DampingStiffness::default()
    }
}

impl std::fmt::Display for DampingStiffness {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What the element loop needs per tet in a damped step (see [`super::Model::evaluate_damped`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DampedEvaluation {
    /// Ψ(F), J/m³.
    pub psi: f64,
    /// P(F), Pa.
    pub stress: Mat3,
    /// The damping stress differential `K_d(F) : dF_v` (the tangent of the
    /// [`DampingStiffness`] at F applied to the velocity gradient dF_v), Pa/s.
    pub damping: Mat3,
    /// Newton's tangent of elasticity and damping together: the strategy's tangent plus
    /// `weight` × the damping stiffness's, both at `F + shift·dF_v`.
    pub tangent: Tangent,
    /// `adaptive` only: the same with the exact elastic pieces (what
    /// [`Tangent::swap_pieces`] puts in use when Newton tries the exact tangent).
    pub exact: DiagonalPieces,
}

/// The largest shift of a damped step's tangent point, relative to F's smallest stretch (see
/// [`shifted_deformation`]).
pub const MAX_SHIFT: f64 = 0.1;

/// The F at which a damped step's Newton tangent is taken: `F + θ·dF_v`, with θ cut for this
/// tet so that the shift stays within [`MAX_SHIFT`] of F's smallest stretch (bounded below by
/// `1/‖F⁻¹‖_F`; a flat or inverted F is not shifted at all). The shift stands in for the
/// tangent's first-order change along v, which is only a model of it while the shift is small:
/// near inversion the tangent changes faster, and a shifted F beyond σ₃ = 0 is no model of the
/// step (on `scenes/squash_release.toml`, tets reaching J = 0.02 made Newton crawl at a rate of
/// 0.5 for 20 iterations, then land on another stationary point than without the shift).
#[inline]
pub fn shifted_deformation(f: &Mat3, df_v: &Mat3, shift: f64) -> Mat3 {
    let size = shift * df_v.norm();
    if size == 0.0 {
        return *f;
    }
    let det = f.determinant();
    if det <= 0.0 {
        return *f;
    }
    // ‖F⁻¹‖_F = ‖cof F‖_F / det F, the cofactors being the columns' cross products.
    let (c0, c1, c2) = (f.column(0), f.column(1), f.column(2));
    let cofactor = (c1.cross(&c2).norm_squared()
        + c2.cross(&c0).norm_squared()
        + c0.cross(&c1).norm_squared())
    .sqrt();
    let allowed = MAX_SHIFT * det / cofactor;
    let theta = if size <= allowed {
        shift
    } else {
        shift * allowed / size
    };
    f + theta * df_v
}

/// Where and how a damped step's Newton tangent is made (see [`super::Model::evaluate_damped`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DampedTangent {
    /// The definiteness strategy of the elastic part.
    pub definiteness: Definiteness,
    /// The damping stiffness (physics).
    pub damping: DampingStiffness,
    /// θ: the tangent is taken at `F + θ·dF_v` (0: at F; θ is cut per tet, see
    /// [`shifted_deformation`]).
    pub shift: f64,
    /// w: the damping stiffness's weight in the tangent (γ/h in a backward-Euler step).
    pub weight: f64,
}

/// ∂P/∂F frozen at one F in its diagonal-space form: U, V, the symmetric 3×3 block of
/// ∂²Ψ̂/∂σ² and the two eigenvalues of each of the three 2×2 blocks (39 numbers in all, against
/// 81 for a full 9×9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tangent {
    pub(crate) u: Mat3,
    pub(crate) v: Mat3,
    pub(crate) diag: Mat3,
    /// Eigenvalue on (dF̂ᵢⱼ + dF̂ⱼᵢ) for the pairs (0,1), (0,2), (1,2).
    pub(crate) pair_sym: Vec3,
    /// Eigenvalue on (dF̂ᵢⱼ − dF̂ⱼᵢ) for the same pairs.
    pub(crate) pair_skew: Vec3,
    /// How many of the seven diagonal-space pieces (the 3×3 block, six pair eigenvalues) the
    /// definiteness strategy changed; 0 for `Exact`.
    pub(crate) clamped: u8,
    /// How many of the seven pieces were indefinite before any fix, for every strategy
    /// (including `Exact`, where nothing is changed).
    pub(crate) indefinite: u8,
    /// Whether F was inverted or flat (σ₃ ≤ 0) here; false for models without an SVD.
    pub(crate) inverted: bool,
    /// Whether the fix changed a piece by more than [`STRONG_CLAMP`] of the tangent's scale
    /// (not a rounding-level negative eigenvalue, as a body in rigid motion has).
    pub(crate) strongly_clamped: bool,
}

/// A clamp counts as strong (see [`Tangent::strongly_clamped`]) beyond this share of the
/// tangent's largest diagonal entry (≈ λ + 2μ): a pair eigenvalue at rest is exactly 0 for
/// Neo-Hookean and comes out ±1e-12 of that by rounding under any rigid motion, while 1 % is
/// about what 1 % of compressive strain gives.
pub const STRONG_CLAMP: f64 = 0.01;

/// The diagonal-space pieces of a [`Tangent`] (its 3×3 block and six pair eigenvalues): what a
/// definiteness strategy changes, kept aside by the `adaptive` strategy.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiagonalPieces {
    pub(super) diag: Mat3,
    pub(super) pair_sym: Vec3,
    pub(super) pair_skew: Vec3,
}

impl Tangent {
    /// Whether F was inverted or flat (σ₃ ≤ 0).
    pub fn is_inverted(&self) -> bool {
        self.inverted
    }

    /// Exchange this tangent's diagonal-space pieces with `other` (U, V and the counts stay).
    #[inline]
    pub fn swap_pieces(&mut self, other: &mut DiagonalPieces) {
        std::mem::swap(&mut self.diag, &mut other.diag);
        std::mem::swap(&mut self.pair_sym, &mut other.pair_sym);
        std::mem::swap(&mut self.pair_skew, &mut other.pair_skew);
    }

    /// `self += w·other` piece by piece; `other` must be of a tangent with the same U and V
    /// (made at the same F).
    #[inline]
    pub(crate) fn add_pieces(&mut self, other: &DiagonalPieces, w: f64) {
        self.diag += w * other.diag;
        self.pair_sym += w * other.pair_sym;
        self.pair_skew += w * other.pair_skew;
    }

    /// This tangent's diagonal-space pieces.
    #[inline]
    pub(crate) fn pieces(&self) -> DiagonalPieces {
        DiagonalPieces {
            diag: self.diag,
            pair_sym: self.pair_sym,
            pair_skew: self.pair_skew,
        }
    }

    /// Project an exact tangent in place with the `teran` clamp, keeping its exact pieces in
    /// `exact` (the `adaptive` strategy).
    #[inline]
    pub fn project_keeping_exact(&mut self, exact: &mut DiagonalPieces) {
        *exact = DiagonalPieces {
            diag: self.diag,
            pair_sym: self.pair_sym,
            pair_skew: self.pair_skew,
        };
        self.make_definite(Definiteness::Projected, || None);
    }

    /// dP = (∂P/∂F):dF.
    #[inline]
    pub fn apply(&self, df: &Mat3) -> Mat3 {
        let dfh = self.u.transpose() * df * self.v;
        let diag = self.diag * dfh.diagonal();
        let mut dph = Mat3::from_diagonal(&diag);
        for (k, &(i, j)) in isotropic::PAIRS.iter().enumerate() {
            let sym = 0.5 * self.pair_sym[k] * (dfh[(i, j)] + dfh[(j, i)]);
            let skew = 0.5 * self.pair_skew[k] * (dfh[(i, j)] - dfh[(j, i)]);
            dph[(i, j)] = sym + skew;
            dph[(j, i)] = sym - skew;
        }
        self.u * dph * self.v.transpose()
    }

    /// How many diagonal-space pieces (the 3×3 block and six pair eigenvalues, 0 to 7) the
    /// definiteness strategy changed: clamped to zero (`teran`, `analytic`) or flipped (`abs`).
    /// Always 0 for `Exact`.
    pub fn clamped_pieces(&self) -> u8 {
        self.clamped
    }

    /// Whether the definiteness fix changed a piece by more than [`STRONG_CLAMP`] of the
    /// tangent's scale: a clamp that changes Newton's model, not one of rounding.
    pub fn strongly_clamped(&self) -> bool {
        self.strongly_clamped
    }

    /// How many diagonal-space pieces (0 to 7) were indefinite at this F before any fix, whatever
    /// the strategy: with `Exact`, a non-zero count means K may be indefinite here.
    pub fn indefinite_pieces(&self) -> u8 {
        self.indefinite
    }
}
