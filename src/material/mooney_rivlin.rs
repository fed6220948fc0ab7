//! Compressible Mooney-Rivlin in the decoupled (isochoric + volumetric) form of Simo & Taylor
//! 1991 and FEBio's "Mooney-Rivlin" material:
//! `Ψ = C₁₀(Ī₁ − 3) + C₀₁(Ī₂ − 3) + κ/2 (ln J)²`, `Ī₁ = J^(−2/3) I₁`, `Ī₂ = J^(−4/3) I₂`, with
//! `I₁ = tr C`, `I₂ = ½(I₁² − tr C²)`, `C = FᵀF`, `J = det F`;
//! `P = C₁₀ J^(−2/3)(2F − ⅔I₁F⁻ᵀ) + C₀₁ J^(−4/3)(2(I₁F − FFᵀF) − ⁴⁄₃I₂F⁻ᵀ) + κ ln J F⁻ᵀ`.
//!
//! Parameters from the small-strain (μ, λ): `μ = 2(C₁₀ + C₀₁)` and the bulk modulus
//! `κ = λ + 2μ/3`, so that small strains give linear elasticity (checked by the uniaxial test).
//! The split between the two terms is `C₀₁ = r μ/2`, `C₁₀ = (1 − r) μ/2` with r =
//! [`DEFAULT_C01_FRACTION`] (a quarter of the shear stiffness from Ī₂, i.e. C₀₁/C₁₀ = 1/3; fit r to data where it
//! matters, [`MooneyRivlin::with_split`]); r = 0 is the decoupled compressible Neo-Hookean.
//!
//! Inversion (the deviation from the analytic model): `J^(−2/3)` is singular at J = 0 and
//! undefined for an inverted J < 0, and `ln J` too. Below a threshold both are extended:
//! - `g(J) = J^(−2/3)` by its second-order Taylor expansion at J = `volume_threshold` (C², positive,
//!   decreasing, so the isochoric terms push an inverted or flat element towards J > 0), and
//!   `J^(−4/3) = g²`;
//! - `ln J = Σ ln σₖ` stretch by stretch through [`ExtendedLog`], as Neo-Hookean does. Per stretch
//!   rather than on J because then F = 0 (a tet collapsed to a point) still feels a restoring
//!   force: every function of (I₁, I₂, J) alone has a zero gradient there.
//!
//! **The clamp** (`mooney-rivlin` is [`MooneyRivlin::clamped`]): the model is wrapped in
//! [`Clamped`] at the inversion threshold ε (default 0.1), with the spring and push matched to
//! the model at ε ([`Clamped::matching`]), and the wrapped model's own thresholds at the clamp's
//! floor ¾ε (the stretches) and its cube (J): it only ever sees stretches of at least ¾ε, where it
//! is the formula, so `mooney-rivlin` is exactly its formula wherever every stretch is at least
//! ε, and below ε the compressive resistance keeps growing at the formula's stiffness at ε. The
//! Taylor-extended J^(−2/3) alone grows so fast with the depth of an inversion that a ball
//! scrambled inside a small box flew apart (1.35e7 J of kinetic energy in its first frame);
//! tangled elements are evaluated with [`MooneyRivlin::recovery`] instead (the clamp at a
//! stretch of 0.6 with a 2μ spring and push, see [`crate::elastic::recovery`]).
//!
//! Above both thresholds (every σₖ ≥ the stretch threshold and J ≥ the volume threshold) the model
//! is exactly the analytic one. In principal stretches, with `I₂ = Σᵢ<ⱼ σᵢ²σⱼ²`, `cₖ = ∂J/∂σₖ`,
//! `L = Σ ℓ(σₖ)`, `A = C₁₀g`, `B = C₀₁g²`, `D = C₁₀I₁g′ + 2C₀₁I₂gg′`:
//! `pₖ = 2Aσₖ + 2Bσₖ(I₁ − σₖ²) + D cₖ + κL ℓ′(σₖ)`, and the pair eigenvalues are
//! `2A + 2B(σₘ² ∓ σᵢσⱼ) ∓ Dσₘ + κL·{(ℓ′ᵢ − ℓ′ⱼ)/(σᵢ − σⱼ), (ℓ′ᵢ + ℓ′ⱼ)/(σᵢ + σⱼ)}`, closed forms.
//! The 3×3 block has no simple closed-form eigensystem (`analytic` uses the eigensolver).

use super::clamp::{Clamped, StretchClamp};
use super::isotropic::{Derivatives, ExtendedLog, Isotropic, PAIRS};
use super::stable_neo_hookean::cofactors;
use super::{DEFAULT_INVERSION_THRESHOLD, Lame};
use crate::math::{Mat3, Vec3};

/// Default share r of the shear modulus carried by the Ī₂ term: C₀₁ = rμ/2, C₁₀ = (1 − r)μ/2.
pub const DEFAULT_C01_FRACTION: f64 = 0.25;

/// Default stretch threshold of the per-stretch extended ln J (below it ln σ is extended
/// quadratically; lower is stiffer).
pub const DEFAULT_STRETCH_THRESHOLD: f64 = 0.3;

/// Default volume threshold below which J^(−2/3) is extended: compression to under 30 % of the
/// rest volume. Lower keeps the analytic model longer but makes the extension much stiffer
/// (g″ ~ J^(−8/3)), which slows Newton on badly inverted starts.
pub const DEFAULT_VOLUME_THRESHOLD: f64 = 0.3;

/// Compressible Mooney-Rivlin in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MooneyRivlin {
    /// C₁₀, Pa.
    pub c10: f64,
    /// C₀₁, Pa.
    pub c01: f64,
    /// Bulk modulus κ, Pa.
    pub kappa: f64,
    /// The extended ln of each stretch.
    pub log: ExtendedLog,
    /// J below which J^(−2/3) is extended.
    pub volume_threshold: f64,
}

impl MooneyRivlin {
    /// From the small-strain Lamé parameters, with the default split and thresholds.
    pub fn new(lame: Lame) -> Self {
        Self::with_split(lame, DEFAULT_C01_FRACTION)
    }

    /// The model of `mooney-rivlin`: the default split, the stretches clamped below the default
    /// inversion threshold (see the module docs).
    pub fn clamped(lame: Lame) -> Clamped<Self> {
        Self::clamped_with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// `mooney-rivlin` with the clamp at `threshold`: the wrapped model's stretch threshold at
    /// the floor ¾ε and its volume threshold at the floor's cube, so it is the formula for every
    /// stretch the clamp lets through.
    pub fn clamped_with_threshold(lame: Lame, threshold: f64) -> Clamped<Self> {
        let floor = StretchClamp::floor_of(threshold);
        let mut model = Self::new(lame);
        model.log = ExtendedLog { eps: floor };
        model.volume_threshold = floor * floor * floor;
        Clamped::matching(model, threshold)
    }

    /// What tangled elements are evaluated with: the default thresholds behind the clamp at
    /// `threshold` (default 0.6) with a 2μ spring and push (see [`super::clamp`]).
    pub fn recovery(lame: Lame, threshold: f64) -> Clamped<Self> {
        Clamped {
            model: Self::new(lame),
            clamp: StretchClamp::with_shear_modulus(threshold, lame.mu),
        }
    }

    /// From the small-strain Lamé parameters with C₀₁ = rμ/2, C₁₀ = (1 − r)μ/2, r in [0, 1].
    pub fn with_split(lame: Lame, r: f64) -> Self {
        MooneyRivlin {
            c10: 0.5 * (1.0 - r) * lame.mu,
            c01: 0.5 * r * lame.mu,
            kappa: lame.lambda + 2.0 * lame.mu / 3.0,
            log: ExtendedLog {
                eps: DEFAULT_STRETCH_THRESHOLD,
            },
            volume_threshold: DEFAULT_VOLUME_THRESHOLD,
        }
    }

    /// `(g, g′, g″)` at J: J^(−2/3) and its derivatives, the quadratic Taylor expansion below
    /// the volume threshold.
    fn g(&self, j: f64) -> (f64, f64, f64) {
        let e = self.volume_threshold;
        let at = |x: f64| {
            let g = x.powf(-2.0 / 3.0);
            (g, -2.0 / 3.0 * g / x, 10.0 / 9.0 * g / (x * x))
        };
        if j >= e {
            at(j)
        } else {
            let (g, d1, d2) = at(e);
            let d = j - e;
            (g + d1 * d + 0.5 * d2 * d * d, d1 + d2 * d, d2)
        }
    }

    /// Everything p, H and the pairs share at σ.
    fn terms(&self, s: &Vec3) -> Terms {
        let sq = s.component_mul(s);
        let i1 = sq.sum();
        let i2 = sq[0] * sq[1] + sq[0] * sq[2] + sq[1] * sq[2];
        let (g, g1, g2) = self.g(s.product());
        Terms {
            i1,
            i2,
            g,
            g1,
            g2,
            a: self.c10 * g,
            b: self.c01 * g * g,
            d: self.c10 * i1 * g1 + 2.0 * self.c01 * i2 * g * g1,
            l: s.iter().map(|&x| self.log.value(x)).sum(),
        }
    }
}

/// The invariants at σ and the coefficients built from them (see the module docs).
struct Terms {
    i1: f64,
    i2: f64,
    g: f64,
    g1: f64,
    g2: f64,
    a: f64,
    b: f64,
    d: f64,
    l: f64,
}

/// ∂I₂/∂σₖ = 2σₖ(I₁ − σₖ²).
fn grad_i2(s: &Vec3, i1: f64) -> Vec3 {
    s.map(|x| 2.0 * x * (i1 - x * x))
}

impl MooneyRivlin {
    fn psi_at(&self, t: &Terms) -> f64 {
        self.c10 * (t.i1 * t.g - 3.0)
            + self.c01 * (t.i2 * t.g * t.g - 3.0)
            + 0.5 * self.kappa * t.l * t.l
    }

    fn dpsi_at(&self, s: &Vec3, t: &Terms) -> Vec3 {
        let dl = s.map(|x| self.log.d1(x));
        2.0 * t.a * s + t.b * grad_i2(s, t.i1) + t.d * cofactors(s) + self.kappa * t.l * dl
    }

    fn d2psi_at(&self, s: &Vec3, t: &Terms) -> Mat3 {
        let gi1 = 2.0 * s;
        let gi2 = grad_i2(s, t.i1);
        let c = cofactors(s);
        let dl = s.map(|x| self.log.d1(x));
        // Second derivatives of the isochoric part in (I₁, I₂, J): only the J-mixed ones are
        // non-zero.
        let f1j = self.c10 * t.g1;
        let f2j = 2.0 * self.c01 * t.g * t.g1;
        let fjj = self.c10 * t.i1 * t.g2 + 2.0 * self.c01 * t.i2 * (t.g1 * t.g1 + t.g * t.g2);
        let mut h = f1j * (gi1 * c.transpose() + c * gi1.transpose())
            + f2j * (gi2 * c.transpose() + c * gi2.transpose())
            + fjj * c * c.transpose()
            + self.kappa * dl * dl.transpose();
        for k in 0..3 {
            // A ∇²I₁ + B ∇²I₂ (diagonal) + κL ℓ″.
            h[(k, k)] +=
                2.0 * t.a + 2.0 * t.b * (t.i1 - s[k] * s[k]) + self.kappa * t.l * self.log.d2(s[k]);
        }
        for (k, l, m) in [(0, 1, 2), (0, 2, 1), (1, 2, 0)] {
            // B ∇²I₂ and D ∇²J off the diagonal.
            let off = 4.0 * t.b * s[k] * s[l] + t.d * s[m];
            h[(k, l)] += off;
            h[(l, k)] += off;
        }
        h
    }

    fn pair_at(&self, s: &Vec3, t: &Terms, i: usize, j: usize) -> (f64, f64) {
        let m = 3 - i - j;
        let (sm2, sij) = (s[m] * s[m], s[i] * s[j]);
        let kl = self.kappa * t.l;
        (
            2.0 * t.a + 2.0 * t.b * (sm2 - sij) - t.d * s[m]
                + kl * self.log.d1_divided_difference(s[i], s[j]),
            2.0 * t.a
                + 2.0 * t.b * (sm2 + sij)
                + t.d * s[m]
                + kl * self.log.d1_sum_quotient(s[i], s[j]),
        )
    }
}

impl Isotropic for MooneyRivlin {
    fn psi(&self, s: &Vec3) -> f64 {
        self.psi_at(&self.terms(s))
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        self.dpsi_at(s, &self.terms(s))
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        self.d2psi_at(s, &self.terms(s))
    }

    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        self.pair_at(s, &self.terms(s), i, j)
    }

    /// The same as the separate methods with the invariants, the power and the logarithms
    /// computed once.
    fn derivatives(&self, s: &Vec3) -> Derivatives {
        let t = self.terms(s);
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (k, &(i, j)) in PAIRS.iter().enumerate() {
            (pair_sym[k], pair_skew[k]) = self.pair_at(s, &t, i, j);
        }
        Derivatives {
            psi: self.psi_at(&t),
            p: self.dpsi_at(s, &t),
            h: self.d2psi_at(s, &t),
            pair_sym,
            pair_skew,
        }
    }
}
