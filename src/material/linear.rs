//! Linear (small-strain) elasticity: `Ψ = μ ε:ε + λ/2 tr(ε)²` with `ε = sym(F) − I`,
//! `P = 2μ ε + λ tr(ε) I`, `dP = 2μ sym(dF) + λ tr(dF) I` (constant).
//!
//! Not rotation invariant: ε is the linearised strain, so a rigid rotation costs energy and
//! large rotations give spurious stress (the reason corotated elasticity exists). It cannot be
//! written in principal stretches, so it is a [`Material`] on F directly, with no SVD.
//!
//! Its constant tangent is exactly a [`Tangent`] with U = V = I: the 3×3 block `2μI + λ11ᵀ` on
//! the diagonal of dF, and per pair (i, j) the eigenvalue 2μ on `dFᵢⱼ + dFⱼᵢ` and 0 on the
//! rotation `dFᵢⱼ − dFⱼᵢ`. It is PSD whenever the bulk modulus λ + 2μ/3 and μ are non-negative,
//! so every definiteness strategy leaves it unchanged for physical parameters. Finite for every F,
//! inverted and flat included, and convex: forces always point back to the rest shape.

use super::{
    DampedEvaluation, DampedTangent, Definiteness, DiagonalPieces, Lame, Material, Tangent,
};
use crate::math::{Mat3, Vec3};

/// Linear elasticity on F (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearElastic {
    /// Lamé parameters.
    pub lame: Lame,
}

impl LinearElastic {
    /// From Lamé parameters.
    pub fn new(lame: Lame) -> Self {
        LinearElastic { lame }
    }

    /// The small strain ε = sym(F) − I.
    #[inline]
    pub fn strain(f: &Mat3) -> Mat3 {
        0.5 * (f + f.transpose()) - Mat3::identity()
    }

    #[inline]
    fn energy_of(&self, e: &Mat3) -> f64 {
        let Lame { mu, lambda } = self.lame;
        let tr = e.trace();
        mu * e.norm_squared() + 0.5 * lambda * tr * tr
    }

    #[inline]
    fn stress_of(&self, e: &Mat3) -> Mat3 {
        let Lame { mu, lambda } = self.lame;
        2.0 * mu * e + Mat3::from_diagonal_element(lambda * e.trace())
    }

    /// Ψ, P and the (constant) tangent, like [`super::Invertible::evaluate`].
    #[inline]
    pub fn evaluate(&self, f: &Mat3, definiteness: Definiteness) -> (f64, Mat3, Tangent) {
        let e = Self::strain(f);
        (
            self.energy_of(&e),
            self.stress_of(&e),
            self.tangent(f, definiteness),
        )
    }

    /// One tet of a damped step, like [`super::Invertible::evaluate_damped`] (the tangent is
    /// constant and positive semi-definite: every strategy and the shift give the same one).
    #[inline]
    pub fn evaluate_damped(&self, f: &Mat3, df_v: &Mat3, how: &DampedTangent) -> DampedEvaluation {
        let (psi, stress, damping) = self.damping_stress(f, df_v, how.damping);
        let (tangent, exact) = self.damped_tangent(f, how);
        DampedEvaluation {
            psi,
            stress,
            damping,
            tangent,
            exact,
        }
    }

    /// Ψ, P and the damping stress, like [`super::Invertible::damping_stress`].
    #[inline]
    pub fn damping_stress(
        &self,
        f: &Mat3,
        df_v: &Mat3,
        damping: super::DampingStiffness,
    ) -> (f64, Mat3, Mat3) {
        let e = Self::strain(f);
        let dp = self.tangent(f, damping.definiteness()).apply(df_v);
        (self.energy_of(&e), self.stress_of(&e), dp)
    }

    /// Newton's tangent of a damped step, like [`super::Invertible::damped_tangent`].
    #[inline]
    pub fn damped_tangent(&self, g: &Mat3, how: &DampedTangent) -> (Tangent, DiagonalPieces) {
        let mut tangent = self.tangent(g, how.definiteness);
        tangent.add_pieces(
            &self.tangent(g, how.damping.definiteness()).pieces(),
            how.weight,
        );
        (tangent, tangent.pieces())
    }
}

impl Material for LinearElastic {
    fn energy_density(&self, f: &Mat3) -> f64 {
        self.energy_of(&Self::strain(f))
    }

    fn stress(&self, f: &Mat3) -> Mat3 {
        self.stress_of(&Self::strain(f))
    }

    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3 {
        self.tangent(f, Definiteness::Exact).apply(df)
    }

    fn tangent(&self, _: &Mat3, definiteness: Definiteness) -> Tangent {
        let Lame { mu, lambda } = self.lame;
        let mut tangent = Tangent {
            u: Mat3::identity(),
            v: Mat3::identity(),
            diag: Mat3::repeat(lambda) + Mat3::from_diagonal_element(2.0 * mu),
            pair_sym: Vec3::repeat(2.0 * mu),
            pair_skew: Vec3::zeros(),
            clamped: 0,
            indefinite: 0,
            inverted: false,
            strongly_clamped: false,
        };
        // Corotated's block, and the same closed form: (2μ + 3λ, 1/√3 (1,1,1)) and 2μ twice.
        tangent.make_definite(definiteness, || {
            Some(super::corotated::block_eigensystem(mu, lambda))
        });
        tangent
    }
}
