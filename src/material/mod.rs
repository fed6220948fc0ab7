//! Constitutive models: F ↦ Ψ(F), P(F) = ∂Ψ/∂F and the stress differential dP = (∂P/∂F):dF.
//!
//! Every isotropic model is written in principal stretches ([`Isotropic`]) and made a
//! [`Material`] on F by the one shared adaptor [`Invertible`], which handles the SVD, inversion
//! and definiteness. Adding a model is one file with Ψ̂, ∂Ψ̂/∂σ and ∂²Ψ̂/∂σ² (and closed-form
//! pair eigenvalues), plus one arm in [`Model`], [`ModelKind`] and `with_model!`.
//!
//! | scene name | model | below the inversion threshold (0.1) | tangled elements |
//! |---|---|---|---|
//! | `neo-hookean` | [`NeoHookean`], SPEC §2 | Taylor-extended log, growing resistance | [`NeoHookean::recovery`] |
//! | `neo-hookean-clamped` | [`NeoHookean`], Irving et al. 2004 | clamped stretches, matched spring ([`Clamped::matching`]) | [`NeoHookean::recovery`] |
//! | `corotated` | [`Corotated`], SPEC §2 | (none: polynomial, restoring) | itself |
//! | `stable-neo-hookean` | [`StableNeoHookean`], Smith et al. 2018 | (none: polynomial; F = 0 is critical) | itself |
//! | `st-venant-kirchhoff` | [`StVenantKirchhoff`] | (none: finite, but reflections cost nothing) | itself |
//! | `mooney-rivlin` | [`MooneyRivlin`], compressible | clamped stretches, matched spring ([`Clamped::matching`]) | [`MooneyRivlin::recovery`] |
//! | `linear` | [`LinearElastic`], small strain | (none: finite; not rotation invariant) | itself |
//!
//! Every model is exactly its formula wherever every principal stretch is at least its inversion
//! threshold ([`DEFAULT_INVERSION_THRESHOLD`], `[material] inversion_threshold`). Below it an
//! extension keeps forces finite and the compressive resistance growing. Elements that are
//! *tangled* (inverted, or in a body that overlaps itself) are evaluated with the model's
//! recovery form, Irving's clamp at [`DEFAULT_RECOVERY_THRESHOLD`], until they are untangled (see
//! [`crate::elastic::recovery`]).
//!
//! ```
//! use tetsim::material::{Lame, Material, Model, ModelKind};
//! use tetsim::math::Mat3;
//! let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
//! let stretched = Mat3::from_diagonal(&tetsim::math::Vec3::new(1.1, 1.0, 1.0));
//! assert!(model.energy_density(&Mat3::identity()).abs() < 1e-12);
//! assert!(model.stress(&stretched)[(0, 0)] > 0.0);
//! ```

pub mod clamp;
pub mod corotated;
pub mod isotropic;
pub mod levelled;
pub mod linear;
pub mod mooney_rivlin;
pub mod neo_hookean;
pub mod st_venant_kirchhoff;
pub mod stable_neo_hookean;
pub mod tangent;

pub use clamp::{Clamped, StretchClamp};
pub use corotated::Corotated;
pub use isotropic::{Derivatives, ExtendedLog, Invertible, Isotropic};
pub use levelled::LevelledNeoHookean;
pub use linear::LinearElastic;
pub use mooney_rivlin::MooneyRivlin;
pub use neo_hookean::NeoHookean;
pub use st_venant_kirchhoff::StVenantKirchhoff;
pub use stable_neo_hookean::StableNeoHookean;
pub use tangent::{
    DampedEvaluation, DampedTangent, DampingStiffness, Definiteness, DiagonalPieces, MAX_SHIFT,
    STRONG_CLAMP, Tangent, shifted_deformation,
};

use crate::math::{Mat3, Svd};

/// The default inversion threshold: every model is exactly its formula wherever every principal
/// stretch is at least 0.1 (90 % compression along one axis); below it the model's extension
/// acts (SPEC §3).
pub const DEFAULT_INVERSION_THRESHOLD: f64 = 0.1;

/// The default recovery threshold: a tangled element is evaluated with Irving's clamp of the
/// stretches below 0.6 (see [`crate::elastic::recovery`]). Measured on 172 collapsed and
/// scrambled starts: 0.6 brings every one back.
pub const DEFAULT_RECOVERY_THRESHOLD: f64 = 0.6;

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

/// The models a scene can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModelKind {
    /// [`NeoHookean`], `neo-hookean`.
    NeoHookean,
    /// [`NeoHookean`] behind a [`Clamped`] ([`NeoHookean::clamped`]), `neo-hookean-clamped`.
    NeoHookeanClamped,
    /// [`Corotated`], `corotated`.
    Corotated,
    /// [`StableNeoHookean`], `stable-neo-hookean`.
    StableNeoHookean,
    /// [`StVenantKirchhoff`], `st-venant-kirchhoff`.
    StVenantKirchhoff,
    /// [`MooneyRivlin`], `mooney-rivlin`.
    MooneyRivlin,
    /// [`LinearElastic`], `linear`.
    Linear,
}

impl ModelKind {
    /// Every model, in the order the docs list them.
    pub const ALL: [ModelKind; 7] = [
        ModelKind::NeoHookean,
        ModelKind::NeoHookeanClamped,
        ModelKind::Corotated,
        ModelKind::StableNeoHookean,
        ModelKind::StVenantKirchhoff,
        ModelKind::MooneyRivlin,
        ModelKind::Linear,
    ];

    /// The scene name of the model (`model = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::NeoHookean => "neo-hookean",
            ModelKind::NeoHookeanClamped => "neo-hookean-clamped",
            ModelKind::Corotated => "corotated",
            ModelKind::StableNeoHookean => "stable-neo-hookean",
            ModelKind::StVenantKirchhoff => "st-venant-kirchhoff",
            ModelKind::MooneyRivlin => "mooney-rivlin",
            ModelKind::Linear => "linear",
        }
    }

    /// The model of a scene name or alias (`nh-clamped`; `snh`; `stvk`, `saint-venant-kirchhoff`;
    /// `linear-elastic`, `linear-elasticity`); case-insensitive, `_` and ` ` read as `-`.
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.trim().to_ascii_lowercase().replace(['_', ' '], "-");
        let kind = match name.as_str() {
            "snh" => ModelKind::StableNeoHookean,
            "nh-clamped" => ModelKind::NeoHookeanClamped,
            "stvk" | "saint-venant-kirchhoff" => ModelKind::StVenantKirchhoff,
            "linear-elastic" | "linear-elasticity" => ModelKind::Linear,
            other => return ModelKind::ALL.into_iter().find(|k| k.name() == other),
        };
        Some(kind)
    }

    /// False for linear elasticity, whose small strain makes rigid rotations cost energy.
    pub fn is_rotation_invariant(self) -> bool {
        self != ModelKind::Linear
    }
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A material model ready for the element kernels: one arm per model, each the shared adaptor
/// around a model in principal stretches (linear elasticity, not rotation invariant, is a
/// [`Material`] on F directly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// Neo-Hookean with the extended log (see [`NeoHookean`]).
    NeoHookean(Invertible<NeoHookean>),
    /// Neo-Hookean behind the clamp (see [`NeoHookean::clamped`]).
    NeoHookeanClamped(Invertible<Clamped<NeoHookean>>),
    /// Corotated (see [`Corotated`]).
    Corotated(Invertible<Corotated>),
    /// Stable Neo-Hookean (see [`StableNeoHookean`]).
    StableNeoHookean(Invertible<StableNeoHookean>),
    /// St. Venant-Kirchhoff (see [`StVenantKirchhoff`]).
    StVenantKirchhoff(Invertible<StVenantKirchhoff>),
    /// Compressible Mooney-Rivlin (see [`MooneyRivlin`]).
    MooneyRivlin(Invertible<Clamped<MooneyRivlin>>),
    /// Linear elasticity (see [`LinearElastic`]).
    Linear(LinearElastic),
    /// Neo-Hookean with a levelled log: the form of collapsed tangled elements of a Neo-Hookean
    /// material (see [`LevelledNeoHookean`]); no scene names it.
    NeoHookeanLevelled(Invertible<LevelledNeoHookean>),
}

/// The two forms a model's tangled elements are evaluated with (see [`Model::recovery`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecoveryForms {
    /// While the body has a collapsed or inverted tet.
    pub collapsed: Model,
    /// Once no tet is inverted but the body still overlaps itself.
    pub overlapping: Model,
}

/// Run `$body` with `$m` bound to the concrete material inside a [`Model`] (an `Invertible<_>`,
/// or [`LinearElastic`]; each has `evaluate(f, definiteness) -> (Ψ, P, Tangent)` and implements
/// [`Material`]), so that element loops are compiled once per model with no dispatch per tet.
#[macro_export]
macro_rules! with_model {
    ($model:expr, $m:ident => $body:expr) => {
        match $model {
            $crate::material::Model::NeoHookean($m) => $body,
            $crate::material::Model::NeoHookeanClamped($m) => $body,
            $crate::material::Model::Corotated($m) => $body,
            $crate::material::Model::StableNeoHookean($m) => $body,
            $crate::material::Model::StVenantKirchhoff($m) => $body,
            $crate::material::Model::MooneyRivlin($m) => $body,
            $crate::material::Model::Linear($m) => $body,
            $crate::material::Model::NeoHookeanLevelled($m) => $body,
        }
    };
}

impl Model {
    /// A model of the given kind with its default parameters (inversion threshold, the
    /// Mooney-Rivlin split), from the small-strain Lamé parameters.
    pub fn new(kind: ModelKind, lame: Lame) -> Self {
        Self::with_threshold(kind, lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// A model of the given kind with the inversion threshold ε (a stretch in (0, 1): the model is
    /// its formula wherever every principal stretch is at least ε); models without an extension
    /// ignore it.
    pub fn with_threshold(kind: ModelKind, lame: Lame, threshold: f64) -> Self {
        match kind {
            ModelKind::NeoHookean => {
                Model::NeoHookean(Invertible::new(NeoHookean::with_threshold(lame, threshold)))
            }
            ModelKind::NeoHookeanClamped => Model::NeoHookeanClamped(Invertible::new(
                NeoHookean::clamped_with_threshold(lame, threshold),
            )),
            ModelKind::Corotated => Model::Corotated(Invertible::new(Corotated::new(lame))),
            ModelKind::StableNeoHookean => {
                Model::StableNeoHookean(Invertible::new(StableNeoHookean::new(lame)))
            }
            ModelKind::StVenantKirchhoff => {
                Model::StVenantKirchhoff(Invertible::new(StVenantKirchhoff::new(lame)))
            }
            ModelKind::MooneyRivlin => Model::MooneyRivlin(Invertible::new(
                MooneyRivlin::clamped_with_threshold(lame, threshold),
            )),
            ModelKind::Linear => Model::Linear(LinearElastic::new(lame)),
        }
    }

    /// The small-strain Lamé parameters the model was made from.
    pub fn lame(&self) -> Lame {
        match self {
            Model::NeoHookean(m) => m.model.lame,
            Model::NeoHookeanClamped(m) => m.model.model.lame,
            Model::Corotated(m) => m.model.lame,
            Model::StableNeoHookean(m) => m.model.lame,
            Model::StVenantKirchhoff(m) => m.model.lame,
            Model::MooneyRivlin(m) => {
                let mr = &m.model.model;
                let mu = 2.0 * (mr.c10 + mr.c01);
                Lame {
                    mu,
                    lambda: mr.kappa - 2.0 * mu / 3.0,
                }
            }
            Model::Linear(m) => m.lame,
            Model::NeoHookeanLevelled(m) => m.model.lame,
        }
    }

    /// The inversion threshold ε of a model with an extension below it (None for the others).
    pub fn inversion_threshold(&self) -> Option<f64> {
        match self {
            Model::NeoHookean(m) => Some(m.model.threshold),
            Model::NeoHookeanClamped(m) => Some(m.model.clamp.threshold),
            Model::MooneyRivlin(m) => Some(m.model.clamp.threshold),
            _ => None,
        }
    }

    /// The forms tangled elements of this model are evaluated with (see
    /// [`crate::elastic::recovery`]), both the model itself where every stretch is at least
    /// `threshold`: while the body has collapsed or inverted tets, and once it only overlaps
    /// itself. For Neo-Hookean the first is [`LevelledNeoHookean`] (it opens collapsed bodies
    /// fast), the second Irving's clamp with a 2μ spring and push (it undoes folds); Mooney-Rivlin
    /// uses the clamp for both. None for the models without one (corotated, stable Neo-Hookean,
    /// St. Venant-Kirchhoff, linear: their own formula is used) and for a threshold of 0
    /// (recovery off).
    pub fn recovery(&self, threshold: f64) -> Option<RecoveryForms> {
        if threshold <= 0.0 {
            return None;
        }
        let lame = self.lame();
        match self {
            Model::NeoHookean(_) | Model::NeoHookeanClamped(_) | Model::NeoHookeanLevelled(_) => {
                Some(RecoveryForms {
                    collapsed: Model::NeoHookeanLevelled(Invertible::new(LevelledNeoHookean::new(
                        lame, threshold,
                    ))),
                    overlapping: Model::NeoHookeanClamped(Invertible::new(NeoHookean::recovery(
                        lame, threshold,
                    ))),
                })
            }
            Model::MooneyRivlin(_) => {
                let clamp =
                    Model::MooneyRivlin(Invertible::new(MooneyRivlin::recovery(lame, threshold)));
                Some(RecoveryForms {
                    collapsed: clamp,
                    overlapping: clamp,
                })
            }
            _ => None,
        }
    }

    /// Which model this is.
    pub fn kind(&self) -> ModelKind {
        match self {
            Model::NeoHookean(_) => ModelKind::NeoHookean,
            Model::NeoHookeanClamped(_) => ModelKind::NeoHookeanClamped,
            Model::Corotated(_) => ModelKind::Corotated,
            Model::StableNeoHookean(_) => ModelKind::StableNeoHookean,
            Model::StVenantKirchhoff(_) => ModelKind::StVenantKirchhoff,
            Model::MooneyRivlin(_) => ModelKind::MooneyRivlin,
            Model::Linear(_) => ModelKind::Linear,
            Model::NeoHookeanLevelled(_) => ModelKind::NeoHookean,
        }
    }

    /// Ψ, P and the tangent from one SVD (none for linear elasticity).
    pub fn evaluate(&self, f: &Mat3, definiteness: Definiteness) -> (f64, Mat3, Tangent) {
        with_model!(self, m => m.evaluate(f, definiteness))
    }

    /// One tet of a damped step: Ψ and P at F, the damping stress differential
    /// `K_d(F) : dF_v` with the damping stiffness `how.damping`, and Newton's tangent
    /// `N + w·K_d` (N by `how.definiteness`, w = `how.weight`) at `F + θ·dF_v` (θ = `how.shift`;
    /// at F when θ = 0: one SVD in all, else a second one at the shifted F). See
    /// [`crate::integrator::DampingTangent`] for why the tangent may be shifted.
    pub fn evaluate_damped(&self, f: &Mat3, df_v: &Mat3, how: &DampedTangent) -> DampedEvaluation {
        with_model!(self, m => m.evaluate_damped(f, df_v, how))
    }

    /// The first half of [`Model::evaluate_damped`] with a shift: Ψ, P and `K_d(F):dF_v` at F
    /// (one SVD), for the forces.
    pub fn damping_stress(
        &self,
        f: &Mat3,
        df_v: &Mat3,
        damping: DampingStiffness,
    ) -> (f64, Mat3, Mat3) {
        with_model!(self, m => m.damping_stress(f, df_v, damping))
    }

    /// The second half: Newton's tangent `N + w·K_d` at G = F + θ·dF_v (one SVD), and
    /// `adaptive`'s exact pieces, for when Newton needs them.
    pub fn damped_tangent(&self, g: &Mat3, how: &DampedTangent) -> (Tangent, DiagonalPieces) {
        with_model!(self, m => m.damped_tangent(g, how))
    }
}

/// Run `$body` with `$m` bound to the `Invertible<_>` inside a [`Model`], or `$linear` with
/// `$l` bound to the [`LinearElastic`]: for the kernels that take an SVD made elsewhere.
macro_rules! with_svd_model {
    ($model:expr, $m:ident => $body:expr, $l:ident => $linear:expr) => {
        match $model {
            Model::NeoHookean($m) => $body,
            Model::NeoHookeanClamped($m) => $body,
            Model::Corotated($m) => $body,
            Model::StableNeoHookean($m) => $body,
            Model::StVenantKirchhoff($m) => $body,
            Model::MooneyRivlin($m) => $body,
            Model::NeoHookeanLevelled($m) => $body,
            Model::Linear($l) => $linear,
        }
    };
}

/// The same kernels given the SVD of their F (or G), so that the element loops can make the
/// SVDs of several tets in one batch ([`crate::math::svd_rv_lanes`]). `svd` must be
/// `svd_rv(f)`; linear elasticity, which needs no SVD, ignores it and reads `f`.
impl Model {
    /// False for linear elasticity, whose kernels need no SVD.
    pub fn uses_svd(&self) -> bool {
        !matches!(self, Model::Linear(_))
    }

    /// [`Model::evaluate`] given F's SVD.
    #[inline]
    pub fn evaluate_svd(
        &self,
        f: &Mat3,
        svd: &Svd,
        definiteness: Definiteness,
    ) -> (f64, Mat3, Tangent) {
        with_svd_model!(self, m => m.evaluate_svd(svd, definiteness), l => l.evaluate(f, definiteness))
    }

    /// [`Model::evaluate_damped`] without a shift (`how.shift` is not read), given F's SVD.
    #[inline]
    pub fn evaluate_damped_unshifted(
        &self,
        f: &Mat3,
        svd: &Svd,
        df_v: &Mat3,
        how: &DampedTangent,
    ) -> DampedEvaluation {
        with_svd_model!(
            self,
            m => m.evaluate_damped_unshifted(svd, df_v, how),
            l => l.evaluate_damped(f, df_v, &DampedTangent { shift: 0.0, ..*how })
        )
    }

    /// [`Model::damping_stress`] given F's SVD.
    #[inline]
    pub fn damping_stress_svd(
        &self,
        f: &Mat3,
        svd: &Svd,
        df_v: &Mat3,
        damping: DampingStiffness,
    ) -> (f64, Mat3, Mat3) {
        with_svd_model!(
            self,
            m => m.damping_stress_svd(svd, df_v, damping),
            l => l.damping_stress(f, df_v, damping)
        )
    }

    /// [`Model::damped_tangent`] given G's SVD.
    #[inline]
    pub fn damped_tangent_svd(
        &self,
        g: &Mat3,
        svd: &Svd,
        how: &DampedTangent,
    ) -> (Tangent, DiagonalPieces) {
        with_svd_model!(self, m => m.damped_tangent_svd(svd, how), l => l.damped_tangent(g, how))
    }

    /// [`Model::damped_tangent_svd`] written into `out` and, if given, `exact` (the same bits).
    #[inline]
    pub fn damped_tangent_svd_into(
        &self,
        g: &Mat3,
        svd: &Svd,
        how: &DampedTangent,
        out: &mut Tangent,
        exact: Option<&mut DiagonalPieces>,
    ) {
        with_svd_model!(
            self,
            m => m.damped_tangent_svd_into(svd, how, out, exact),
            l => {
                let (tangent, pieces) = l.damped_tangent(g, how);
                *out = tangent;
                if let Some(exact) = exact {
                    *exact = pieces;
                }
            }
        )
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

/// Scene files name a strategy by [`Definiteness::from_name`]; an unknown name lists the valid
/// ones (toml attaches the line).
impl<'de> serde::Deserialize<'de> for Definiteness {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        Definiteness::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = Definiteness::ALL.iter().map(|d| d.name()).collect();
            serde::de::Error::custom(format!(
                "unknown definiteness strategy \"{}\", expected one of {}",
                crate::error::clip(&name),
                names.join(", ")
            ))
        })
    }
}

/// Scene files name the damping stiffness by [`DampingStiffness::from_name`]; an unknown name
/// lists the valid ones.
impl<'de> serde::Deserialize<'de> for DampingStiffness {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        DampingStiffness::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = DampingStiffness::ALL.iter().map(|d| d.name()).collect();
            serde::de::Error::custom(format!(
                "unknown damping stiffness \"{}\", expected one of {}",
                crate::error::clip(&name),
                names.join(", ")
            ))
        })
    }
}

/// Written as its scene name.
impl serde::Serialize for DampingStiffness {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Scene files name a model by [`ModelKind::from_name`]; an unknown name lists the valid ones.
impl<'de> serde::Deserialize<'de> for ModelKind {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        ModelKind::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = ModelKind::ALL.iter().map(|k| k.name()).collect();
            serde::de::Error::custom(format!(
                "unknown material model \"{}\", expected one of {}",
                crate::error::clip(&name),
                names.join(", ")
            ))
        })
    }
}

/// Written as its scene name.
impl serde::Serialize for Definiteness {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Written as its scene name.
impl serde::Serialize for ModelKind {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}
