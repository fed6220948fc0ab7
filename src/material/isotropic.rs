//! The one adaptor that turns a model written in principal stretches into a [`Material`] on F:
//! the rotation-variant SVD (Irving et al. 2004), the diagonal-space stress, the diagonal-space
//! tangent and its definiteness fix (Teran et al. 2005), and the lift back with U and V.
//!
//! With `F = U·diag(σ)·Vᵀ` (det U = det V = +1, σ₃ < 0 when inverted):
//! - `Ψ(F) = Ψ̂(σ)`, `P(F) = U·diag(p)·Vᵀ` with `p = ∂Ψ̂/∂σ`;
//! - in the rotated frame `dF̂ = Uᵀ·dF·V`, `dP̂ = Uᵀ·dP·V` splits into a 3×3 block on the
//!   diagonal, `dP̂ᵢᵢ = Σⱼ (∂²Ψ̂/∂σᵢ∂σⱼ) dF̂ⱼⱼ`, and one 2×2 block per pair i < j acting on
//!   (dF̂ᵢⱼ, dF̂ⱼᵢ), whose eigenvectors are the symmetric and antisymmetric combinations with
//!   eigenvalues `(pᵢ − pⱼ)/(σᵢ − σⱼ)` and `(pᵢ + pⱼ)/(σᵢ + σⱼ)`.
//!
//! Definiteness is fixed per element by clamping (or flipping, see [`Definiteness`]) the negative
//! eigenvalues of these four blocks, which makes the tangent (and so K) positive semi-definite.

use super::{DampedEvaluation, DampedTangent, Definiteness, DiagonalPieces, Material, Tangent};
use crate::math::{Mat3, Svd, Vec3, abs_psd3, clamp_psd3, is_psd3, map_eigenvalues, svd_rv};

/// The index pairs (i, j), i < j, of the three 2×2 blocks, in the order [`Tangent`] stores them.
pub const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

/// A hyperelastic isotropic model written in principal stretches σ (σ₃ may be negative: the
/// rotation-variant SVD carries inversion on it). Units: Ψ̂ in J/m³, p in Pa.
///
/// Models that are singular at σ = 0 (Neo-Hookean's log J) extend themselves below an inversion
/// threshold with the C² helpers in this module, so that Ψ̂, p and ∂p/∂σ are finite for every σ
/// and consistent (each is the exact derivative of the one before).
pub trait Isotropic: Sync + Send {
    /// Ψ̂(σ), energy density.
    fn psi(&self, s: &Vec3) -> f64;
    /// p = ∂Ψ̂/∂σ, the diagonal of the rotated stress.
    fn dpsi(&self, s: &Vec3) -> Vec3;
    /// ∂²Ψ̂/∂σ², symmetric.
    fn d2psi(&self, s: &Vec3) -> Mat3;
    /// The two eigenvalues of the (i, j) block: `((pᵢ − pⱼ)/(σᵢ − σⱼ), (pᵢ + pⱼ)/(σᵢ + σⱼ))`,
    /// given p and ∂p/∂σ at σ. The default divides with care; override with a closed form that
    /// stays accurate at σᵢ ≈ σⱼ.
    fn pair_eigenvalues(&self, s: &Vec3, p: &Vec3, h: &Mat3, i: usize, j: usize) -> (f64, f64) {
        default_pair_eigenvalues(s, p, h, i, j)
    }
    /// The eigensystem `(λ, Q)` of the 3×3 block `h = ∂²Ψ̂/∂σ²` at σ in closed form
    /// (`h = Q·diag(λ)·Qᵀ`, Q orthonormal), for the `analytic` strategy (Smith et al. 2019).
    /// `None` (the default) means the model has no closed form worth having and the numerical
    /// eigensolver is used instead.
    fn block_eigensystem(&self, s: &Vec3, h: &Mat3) -> Option<(Vec3, Mat3)> {
        let _ = (s, h);
        None
    }
    /// Ψ̂, p, ∂²Ψ̂/∂σ² and the pair eigenvalues at σ in one call, what the adaptor needs per
    /// Newton iterate. The default calls the methods above; a model whose terms share costly work
    /// (logarithms, powers) overrides it to compute that work once. It must return exactly
    /// (bit for bit) what the separate methods return.
    #[inline]
    fn derivatives(&self, s: &Vec3) -> Derivatives {
        let p = self.dpsi(s);
        let h = self.d2psi(s);
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (k, &(i, j)) in PAIRS.iter().enumerate() {
            (pair_sym[k], pair_skew[k]) = self.pair_eigenvalues(s, &p, &h, i, j);
        }
        Derivatives {
            psi: self.psi(s),
            p,
            h,
            pair_sym,
            pair_skew,
        }
    }
}

/// Everything a model in principal stretches gives at one σ (see [`Isotropic::derivatives`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derivatives {
    /// Ψ̂(σ).
    pub psi: f64,
    /// p = ∂Ψ̂/∂σ.
    pub p: Vec3,
    /// ∂²Ψ̂/∂σ².
    pub h: Mat3,
    /// `(pᵢ − pⱼ)/(σᵢ − σⱼ)` for the pairs in [`PAIRS`] order.
    pub pair_sym: Vec3,
    /// `(pᵢ + pⱼ)/(σᵢ + σⱼ)` for the same pairs.
    pub pair_skew: Vec3,
}

impl Derivatives {
    /// `(pair_sym, pair_skew)` of the pair (i, j), i ≠ j, in either order.
    pub fn pair(&self, i: usize, j: usize) -> (f64, f64) {
        let n = PAIRS
            .iter()
            .position(|&p| p == (i.min(j), i.max(j)))
            .expect("a pair of distinct indices");
        (self.pair_sym[n], self.pair_skew[n])
    }
}

/// [`Isotropic`] for a model whose `all(σ) -> Derivatives` computes everything at once: each
/// method reads its part of that one evaluation.
macro_rules! isotropic_from_all {
    ($model:ty) => {
        impl $crate::material::isotropic::Isotropic for $model {
            fn psi(&self, s: &Vec3) -> f64 {
                self.all(s).psi
            }

            fn dpsi(&self, s: &Vec3) -> Vec3 {
                self.all(s).p
            }

            fn d2psi(&self, s: &Vec3) -> Mat3 {
                self.all(s).h
            }

            fn pair_eigenvalues(
                &self,
                s: &Vec3,
                _: &Vec3,
                _: &Mat3,
                i: usize,
                j: usize,
            ) -> (f64, f64) {
                self.all(s).pair(i, j)
            }

            fn derivatives(&self, s: &Vec3) -> $crate::material::isotropic::Derivatives {
                self.all(s)
            }
        }
    };
}
pub(crate) use isotropic_from_all;

/// Relative gap below which `(pᵢ − pⱼ)/(σᵢ − σⱼ)` is replaced by its limit `Hᵢᵢ − Hᵢⱼ`. At 1e-6
/// the two choices differ by O(1e-6) relative, about the cancellation error of the quotient.
const REPEATED_GAP: f64 = 1e-6;

/// `((pᵢ − pⱼ)/(σᵢ − σⱼ), (pᵢ + pⱼ)/(σᵢ + σⱼ))` from p and H alone: the quotient away from
/// repeated values, the limit `Hᵢᵢ − Hᵢⱼ` at them. Closed forms in the models are better.
pub fn default_pair_eigenvalues(s: &Vec3, p: &Vec3, h: &Mat3, i: usize, j: usize) -> (f64, f64) {
    let scale = s[i].abs() + s[j].abs() + f64::MIN_POSITIVE;
    let gap = s[i] - s[j];
    let sym = if gap.abs() > REPEATED_GAP * scale {
        (p[i] - p[j]) / gap
    } else {
        h[(i, i)] - h[(i, j)]
    };
    (sym, guarded_quotient(p[i] + p[j], s[i] + s[j]))
}

/// Smallest |σᵢ + σⱼ| divided by. The rotation-variant energy really has a kink where an
/// inverted σ₃ = −σ₂ (the SVD is ambiguous there), so the antisymmetric eigenvalue has a pole;
/// we keep it finite (and huge), and the projection clamps it if negative.
pub const POLE_GUARD: f64 = 1e-8;

/// `num / den` with |den| kept at least [`POLE_GUARD`] (sign kept, +0 counts as positive).
pub fn guarded_quotient(num: f64, den: f64) -> f64 {
    let den = if den.abs() < POLE_GUARD {
        POLE_GUARD.copysign(den)
    } else {
        den
    };
    num / den
}

/// A logarithm extended below `eps` by its second-order Taylor expansion at `eps`: C² at `eps`,
/// finite (→ −∞ quadratically) for every argument, concave everywhere. Used for log J terms so
/// that inverted and flat elements have finite energy and stress that push them back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtendedLog {
    /// The threshold stretch; at or above it the function is exactly `ln`.
    pub eps: f64,
}

impl ExtendedLog {
    /// ℓ(s).
    pub fn value(&self, s: f64) -> f64 {
        if s >= self.eps {
            s.ln()
        } else {
            let d = (s - self.eps) / self.eps;
            self.eps.ln() + d - 0.5 * d * d
        }
    }

    /// ℓ'(s) (positive everywhere).
    pub fn d1(&self, s: f64) -> f64 {
        if s >= self.eps {
            1.0 / s
        } else {
            (2.0 * self.eps - s) / (self.eps * self.eps)
        }
    }

    /// ℓ''(s) (negative everywhere).
    pub fn d2(&self, s: f64) -> f64 {
        if s >= self.eps {
            -1.0 / (s * s)
        } else {
            -1.0 / (self.eps * self.eps)
        }
    }

    /// The divided difference `(ℓ'(a) − ℓ'(b))/(a − b)`, accurate when a ≈ b (its limit ℓ''
    /// included): each branch is a closed form, and straddling the threshold is a positive blend.
    pub fn d1_divided_difference(&self, a: f64, b: f64) -> f64 {
        let (a, b) = if a >= b { (a, b) } else { (b, a) };
        let e = self.eps;
        if b >= e {
            -1.0 / (a * b)
        } else if a < e {
            -1.0 / (e * e)
        } else {
            // (ℓ'(a) − ℓ'(e)) + (ℓ'(e) − ℓ'(b)), both pieces in closed form.
            ((a - e) * (-1.0 / (a * e)) + (e - b) * (-1.0 / (e * e))) / (a - b)
        }
    }

    /// `(ℓ'(a) + ℓ'(b))/(a + b)`: exactly `1/(ab)` above the threshold (no division by a + b).
    pub fn d1_sum_quotient(&self, a: f64, b: f64) -> f64 {
        if a >= self.eps && b >= self.eps {
            1.0 / (a * b)
        } else {
            guarded_quotient(self.d1(a) + self.d1(b), a + b)
        }
    }
}

/// A model in principal stretches, made a [`Material`] on F.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Invertible<M> {
    /// The model in principal stretches.
    pub model: M,
}

impl<M: Isotropic> Invertible<M> {
    /// Wrap a model.
    pub fn new(model: M) -> Self {
        Invertible { model }
    }

    /// Ψ, P and the tangent from one SVD: what the element loop needs per Newton iterate.
    #[inline]
    pub fn evaluate(&self, f: &Mat3, definiteness: Definiteness) -> (f64, Mat3, Tangent) {
        self.evaluate_svd(&svd_rv(f), definiteness)
    }

    /// [`Invertible::evaluate`] given F's SVD (`svd_rv(F)`, perhaps made in a batch).
    #[inline]
    pub fn evaluate_svd(&self, svd: &Svd, definiteness: Definiteness) -> (f64, Mat3, Tangent) {
        let d = self.model.derivatives(&svd.sigma);
        let stress = svd.u * Mat3::from_diagonal(&d.p) * svd.v.transpose();
        let tangent = self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, definiteness);
        (d.psi, stress, tangent)
    }

    /// One tet of a damped step from one SVD (two when `how.shift` ≠ 0): see
    /// [`super::Model::evaluate_damped`].
    #[inline]
    pub fn evaluate_damped(&self, f: &Mat3, df_v: &Mat3, how: &DampedTangent) -> DampedEvaluation {
        if how.shift != 0.0 {
            let (psi, stress, damping) = self.damping_stress(f, df_v, how.damping);
            let g = super::shifted_deformation(f, df_v, how.shift);
            let (tangent, exact) = self.damped_tangent(&g, how);
            return DampedEvaluation {
                psi,
                stress,
                damping,
                tangent,
                exact,
            };
        }
        self.evaluate_damped_unshifted(&svd_rv(f), df_v, how)
    }

    /// [`Invertible::evaluate_damped`] without a shift (`how.shift` is not read), given F's SVD.
    #[inline]
    pub fn evaluate_damped_unshifted(
        &self,
        svd: &Svd,
        df_v: &Mat3,
        how: &DampedTangent,
    ) -> DampedEvaluation {
        let d = self.model.derivatives(&svd.sigma);
        let stress = svd.u * Mat3::from_diagonal(&d.p) * svd.v.transpose();
        let mut tangent =
            self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, how.damping.definiteness());
        let damping = tangent.apply(df_v);
        let mut exact = DiagonalPieces::default();
        self.newton_tangent_into(svd, &d, how, &mut tangent, Some(&mut exact));
        DampedEvaluation {
            psi: d.psi,
            stress,
            damping,
            tangent,
            exact,
        }
    }

    /// Ψ, P and the damping stress `K_d(F):dF_v` from one SVD, without Newton's tangent (see
    /// [`super::Model::damping_stress`]).
    #[inline]
    pub fn damping_stress(
        &self,
        f: &Mat3,
        df_v: &Mat3,
        damping: super::DampingStiffness,
    ) -> (f64, Mat3, Mat3) {
        self.damping_stress_svd(&svd_rv(f), df_v, damping)
    }

    /// [`Invertible::damping_stress`] given F's SVD.
    #[inline]
    pub fn damping_stress_svd(
        &self,
        svd: &Svd,
        df_v: &Mat3,
        damping: super::DampingStiffness,
    ) -> (f64, Mat3, Mat3) {
        let d = self.model.derivatives(&svd.sigma);
        let stress = svd.u * Mat3::from_diagonal(&d.p) * svd.v.transpose();
        let at_f = self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, damping.definiteness());
        (d.psi, stress, at_f.apply(df_v))
    }

    /// Newton's tangent of a damped step at G (the shifted F), with `adaptive`'s exact pieces
    /// (see [`super::Model::damped_tangent`]).
    #[inline]
    pub fn damped_tangent(&self, g: &Mat3, how: &DampedTangent) -> (Tangent, DiagonalPieces) {
        self.damped_tangent_svd(&svd_rv(g), how)
    }

    /// [`Invertible::damped_tangent`] given G's SVD.
    #[inline]
    pub fn damped_tangent_svd(&self, svd: &Svd, how: &DampedTangent) -> (Tangent, DiagonalPieces) {
        let d = self.model.derivatives(&svd.sigma);
        let mut tangent =
            self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, how.damping.definiteness());
        let mut exact = DiagonalPieces::default();
        self.newton_tangent_into(svd, &d, how, &mut tangent, Some(&mut exact));
        (tangent, exact)
    }

    /// [`Invertible::damped_tangent_svd`] written into `out` and, if given, `exact` (the same
    /// bits; the element loop's form: a tangent and its pieces returned by value, 392 bytes,
    /// were copied on their way into the per-tet arrays).
    #[inline]
    pub fn damped_tangent_svd_into(
        &self,
        svd: &Svd,
        how: &DampedTangent,
        out: &mut Tangent,
        exact: Option<&mut DiagonalPieces>,
    ) {
        let d = self.model.derivatives(&svd.sigma);
        *out = self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, how.damping.definiteness());
        self.newton_tangent_into(svd, &d, how, out, exact);
    }

    /// Newton's tangent `N + w·K_d` at one σ (the SVD's U, σ, V; derivatives d) into `tangent`,
    /// which holds the damping stiffness's tangent K_d there on entry; and, if given, `adaptive`'s
    /// exact pieces plus `w·K_d` into `exact` (zero pieces for the other strategies). In place:
    /// the element loops write into their per-tet arrays.
    #[inline]
    fn newton_tangent_into(
        &self,
        svd: &Svd,
        d: &Derivatives,
        how: &DampedTangent,
        tangent: &mut Tangent,
        exact: Option<&mut DiagonalPieces>,
    ) {
        let strategy = match how.definiteness {
            Definiteness::Adaptive => Definiteness::Projected,
            other => other,
        };
        let damping = tangent.pieces();
        if strategy != how.damping.definiteness() {
            *tangent = self.tangent_at(&svd.u, &svd.v, &svd.sigma, d, strategy);
        }
        tangent.add_pieces(&damping, how.weight);
        if let Some(exact) = exact {
            // The exact tangent's pieces are the derivatives themselves (no fix).
            *exact = if how.definiteness == Definiteness::Adaptive {
                DiagonalPieces {
                    diag: d.h + how.weight * damping.diag,
                    pair_sym: d.pair_sym + how.weight * damping.pair_sym,
                    pair_skew: d.pair_skew + how.weight * damping.pair_skew,
                }
            } else {
                DiagonalPieces::default()
            };
        }
    }

    #[inline]
    fn tangent_at(
        &self,
        u: &Mat3,
        v: &Mat3,
        s: &Vec3,
        d: &Derivatives,
        def: Definiteness,
    ) -> Tangent {
        let mut tangent = Tangent {
            u: *u,
            v: *v,
            diag: d.h,
            pair_sym: d.pair_sym,
            pair_skew: d.pair_skew,
            clamped: 0,
            indefinite: 0,
            inverted: s[2] <= 0.0,
            strongly_clamped: false,
        };
        tangent.make_definite(def, || self.model.block_eigensystem(s, &d.h));
        tangent
    }
}

impl<M: Isotropic> Material for Invertible<M> {
    fn energy_density(&self, f: &Mat3) -> f64 {
        self.model.psi(&svd_rv(f).sigma)
    }

    fn stress(&self, f: &Mat3) -> Mat3 {
        let svd = svd_rv(f);
        svd.u * Mat3::from_diagonal(&self.model.dpsi(&svd.sigma)) * svd.v.transpose()
    }

    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3 {
        self.tangent(f, Definiteness::Exact).apply(df)
    }

    fn tangent(&self, f: &Mat3, definiteness: Definiteness) -> Tangent {
        let svd = svd_rv(f);
        let d = self.model.derivatives(&svd.sigma);
        self.tangent_at(&svd.u, &svd.v, &svd.sigma, &d, definiteness)
    }
}

impl Tangent {
    /// Apply the definiteness strategy `d` to the diagonal-space pieces. `closed_form` gives the
    /// 3×3 block's eigensystem for `Analytic` (called only then; `None` falls back to `teran`).
    #[inline]
    pub(crate) fn make_definite(
        &mut self,
        d: Definiteness,
        closed_form: impl FnOnce() -> Option<(Vec3, Mat3)>,
    ) {
        let clamp = |x: f64| x.max(0.0);
        match d {
            Definiteness::Exact => self.count_indefinite(),
            Definiteness::Projected | Definiteness::Adaptive => self.fix(clamp_psd3, clamp),
            Definiteness::Abs => self.fix(abs_psd3, f64::abs),
            Definiteness::Analytic => match closed_form() {
                Some((lambda, q)) => self.fix(|a| map_eigenvalues(a, &lambda, &q, clamp), clamp),
                None => self.fix(clamp_psd3, clamp),
            },
        }
    }

    /// Apply a definiteness fix: `block` to the 3×3 block (returns the fixed block and whether it
    /// changed), `pair` to each negative pair eigenvalue (Teran et al. 2005 §4 with `max(0, ·)`).
    #[inline]
    fn fix(&mut self, block: impl Fn(&Mat3) -> (Mat3, bool), pair: impl Fn(f64) -> f64) {
        let (diag, changed) = block(&self.diag);
        let strong = super::STRONG_CLAMP * self.diag.amax();
        let mut strongly = changed && (diag - self.diag).amax() > strong;
        self.diag = diag;
        let mut count = changed as u8;
        for k in 0..3 {
            for value in [&mut self.pair_sym[k], &mut self.pair_skew[k]] {
                if *value < 0.0 {
                    strongly |= *value < -strong;
                    *value = pair(*value);
                    count += 1;
                }
            }
        }
        self.strongly_clamped = strongly;
        self.clamped = count;
        self.indefinite = count;
    }

    /// Count the indefinite pieces without changing anything (the `Exact` strategy).
    #[inline]
    fn count_indefinite(&mut self) {
        let negative_pairs = self
            .pair_sym
            .iter()
            .chain(self.pair_skew.iter())
            .filter(|&&x| x < 0.0)
            .count() as u8;
        self.indefinite = negative_pairs + (!is_psd3(&self.diag)) as u8;
    }
}
