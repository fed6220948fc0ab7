//! Constitutive models: F ↦ Ψ(F), P(F) = ∂Ψ/∂F and the stress differential dP = (∂P/∂F):dF.
//!
//! Every model is written in principal stretches ([`Isotropic`]) and made a [`Material`] on F by
//! the one shared adaptor [`Invertible`], which handles the SVD, inversion and definiteness.
//! Adding a model is one file with Ψ̂, ∂Ψ̂/∂σ and ∂²Ψ̂/∂σ², plus one arm in [`Model`].
//!
//! ```
//! use tetsim::material::{Lame, Material, Model, ModelKind};
//! use tetsim::math::Mat3;
//! let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
//! let stretched = Mat3::from_diagonal(&tetsim::math::Vec3::new(1.1, 1.0, 1.0));
//! assert!(model.energy_density(&Mat3::identity()).abs() < 1e-12);
//! assert!(model.stress(&stretched)[(0, 0)] > 0.0);
//! ```

pub mod corotated;
pub mod isotropic;
pub mod neo_hookean;

pub use corotated::Corotated;
pub use isotropic::{ExtendedLog, Invertible, Isotropic};
pub use neo_hookean::NeoHookean;

use crate::math::{Mat3, Vec3};

/// How the stress differential treats the indefinite parts of ∂P/∂F. Scene names: "projected"
/// (alias "teran") and "exact" (alias "none").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Definiteness {
    /// The exact derivative: for derivative tests and exact-Newton experiments. K may be
    /// indefinite far from rest, and CG may then break down.
    #[serde(alias = "none")]
    Exact,
    /// Teran et al. 2005: negative eigenvalues of the diagonal-space blocks clamped to zero per
    /// element, so K is positive semi-definite. Equal to `Exact` where that is already PSD.
    #[default]
    #[serde(alias = "teran")]
    Projected,
}

/// The contract the element kernels use. Units: Ψ in J/m³, P in Pa.
pub trait Material: Sync {
    /// Ψ(F), energy density.
    fn energy_density(&self, f: &Mat3) -> f64;
    /// P(F) = ∂Ψ/∂F, first Piola-Kirchhoff stress.
    fn stress(&self, f: &Mat3) -> Mat3;
    /// (∂P/∂F):dF, exact.
    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3;
    /// ∂P/∂F frozen at F, to apply many times.
    fn tangent(&self, f: &Mat3, definiteness: Definiteness) -> Tangent;
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
    /// projection changed; 0 for `Exact`.
    pub(crate) clamped: u8,
}

impl Tangent {
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

    /// How many diagonal-space pieces the definiteness fix clamped (0 to 7).
    pub fn clamped_pieces(&self) -> u8 {
        self.clamped
    }
}

/// Lamé parameters, in Pa.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lame {
    /// Shear modulus μ, Pa.
    pub mu: f64,
    /// First Lamé parameter λ, Pa.
    pub lambda: f64,
}

impl Lame {
    /// From Young's modulus E (Pa) and Poisson ratio ν: μ = E/(2(1+ν)), λ = Eν/((1+ν)(1−2ν)).
    pub fn from_young_poisson(youngs_modulus: f64, poisson_ratio: f64) -> Self {
        let (e, nu) = (youngs_modulus, poisson_ratio);
        Lame {
            mu: e / (2.0 * (1.0 + nu)),
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        }
    }

    /// Young's modulus E = μ(3λ + 2μ)/(λ + μ), Pa.
    pub fn youngs_modulus(&self) -> f64 {
        self.mu * (3.0 * self.lambda + 2.0 * self.mu) / (self.lambda + self.mu)
    }

    /// Poisson ratio ν = λ/(2(λ + μ)).
    pub fn poisson_ratio(&self) -> f64 {
        self.lambda / (2.0 * (self.lambda + self.mu))
    }
}

/// The models a scene can name (`model = "neo-hookean"`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// [`NeoHookean`].
    NeoHookean,
    /// [`Corotated`].
    Corotated,
}

impl ModelKind {
    /// The scene name of the model (`model = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::NeoHookean => "neo-hookean",
            ModelKind::Corotated => "corotated",
        }
    }

    /// Every model, in the order the docs list them.
    pub const ALL: [ModelKind; 2] = [ModelKind::NeoHookean, ModelKind::Corotated];
}

/// A material model ready for the element kernels: one arm per model, each the shared adaptor
/// around a model in principal stretches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// Neo-Hookean with the extended log (see [`NeoHookean`]).
    NeoHookean(Invertible<NeoHookean>),
    /// Corotated (see [`Corotated`]).
    Corotated(Invertible<Corotated>),
}

/// Run `$body` with `$m` bound to the concrete `Invertible<_>` inside a [`Model`], so that element
/// loops are compiled once per model with no dispatch per tet.
#[macro_export]
macro_rules! with_model {
    ($model:expr, $m:ident => $body:expr) => {
        match $model {
            $crate::material::Model::NeoHookean($m) => $body,
            $crate::material::Model::Corotated($m) => $body,
        }
    };
}

impl Model {
    /// A model of the given kind with default inversion handling.
    pub fn new(kind: ModelKind, lame: Lame) -> Self {
        match kind {
            ModelKind::NeoHookean => Model::NeoHookean(Invertible::new(NeoHookean::new(lame))),
            ModelKind::Corotated => Model::Corotated(Invertible::new(Corotated::new(lame))),
        }
    }

    /// Which model this is.
    pub fn kind(&self) -> ModelKind {
        match self {
            Model::NeoHookean(_) => ModelKind::NeoHookean,
            Model::Corotated(_) => ModelKind::Corotated,
        }
    }

    /// Ψ, P and the tangent from one SVD.
    pub fn evaluate(&self, f: &Mat3, definiteness: Definiteness) -> (f64, Mat3, Tangent) {
        with_model!(self, m => m.evaluate(f, definiteness))
    }
}

impl Material for Model {
    fn energy_density(&self, f: &Mat3) -> f64 {
        with_model!(self, m => m.energy_density(f))
    }
    fn stress(&self, f: &Mat3) -> Mat3 {
        with_model!(self, m => m.stress(f))
    }
    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3 {
        with_model!(self, m => m.stress_differential(f, df))
    }
    fn tangent(&self, f: &Mat3, definiteness: Definiteness) -> Tangent {
        with_model!(self, m => m.tangent(f, definiteness))
    }
}
