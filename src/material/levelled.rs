//! Neo-Hookean with a levelled logarithm: the form a *collapsed* tangled element (flat,
//! inverted, or in a body with such tets) is evaluated with while its body unfolds (see
//! [`crate::elastic::recovery`]). Exactly Neo-Hookean where every stretch is at least the
//! threshold ε (the recovery threshold, 0.6); below it:
//!
//! `L = Σ ℓ(σₖ)` stands in for log J, `Ψ̂ = μ/2 (Σσₖ² − 3) − μL + λ/2 L² + Σ R(σₖ)`,
//! `pₖ = μσₖ + (λL − μ) ℓ'(σₖ) + R'(σₖ)`.
//! - ℓ = ln above ε and, below it, a C² continuation that levels off:
//!   ℓ(σ) = ln ε − 3 + (3 + 2t)e^{−t}, t = (ε − σ)/ε, bounded below by ln ε − 3. A collapsed or
//!   inverted stretch no longer drives L (and through λL/σᵢ the other stretches) without bound,
//!   so a body squeezed onto a plane, a line or a point opens up in a few Newton iterations (the
//!   TetGen ball on a line: 15 in its first frame, against 259 and no convergence with the clamp).
//! - R(σ) = k/(3ε)·(ε − σ)³ below ε (zero above; C²), k = λ + 2μ: Irving's linear extrapolation
//!   of the stress below the threshold, as an energy.
//!
//! Its price is folds: it leaves a flattened tet's drive to stretch in its plane almost intact,
//! so alone it lets 106 of 172 tangled starts settle folded (every tet positive, the mesh over
//! itself). The body therefore switches its tangled elements to the clamp
//! ([`super::NeoHookean::recovery`]) as soon as no tet is inverted, which undoes every one of
//! those folds.

use super::Lame;
use super::isotropic::{Derivatives, PAIRS, guarded_quotient, isotropic_from_all};
use crate::math::{Mat3, Vec3};

/// Relative gap below which divided differences of ℓ' use the midpoint derivative (error
/// ~gap², below rounding) instead of the quotient (error ~ε_machine/gap).
const NEAR: f64 = 1e-4;

/// Neo-Hookean with the levelled log below ε (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelledNeoHookean {
    /// Lamé parameters.
    pub lame: Lame,
    /// The stretch threshold ε of the continuation.
    pub threshold: f64,
}

impl LevelledNeoHookean {
    /// With the continuation below `threshold`.
    pub fn new(lame: Lame, threshold: f64) -> Self {
        LevelledNeoHookean { lame, threshold }
    }

    /// ℓ(σ), ℓ'(σ), ℓ''(σ).
    fn log(&self, s: f64) -> (f64, f64, f64) {
        let e = self.threshold;
        if s >= e {
            return (s.ln(), 1.0 / s, -1.0 / (s * s));
        }
        let t = (e - s) / e;
        let x = (-t).exp();
        (
            e.ln() - 3.0 + (3.0 + 2.0 * t) * x,
            (1.0 + 2.0 * t) * x / e,
            (2.0 * t - 1.0) * x / (e * e),
        )
    }

    /// (ℓ'(a) − ℓ'(b))/(a − b), accurate when a ≈ b.
    fn log_divided_difference(&self, a: f64, b: f64) -> f64 {
        let e = self.threshold;
        if a >= e && b >= e {
            return -1.0 / (a * b);
        }
        if (a - b).abs() <= NEAR * e {
            return self.log(0.5 * (a + b)).2;
        }
        (self.log(a).1 - self.log(b).1) / (a - b)
    }

    /// R(σ), R'(σ), R''(σ).
    fn collapse(&self, s: f64) -> (f64, f64, f64) {
        let e = self.threshold;
        if s >= e {
            return (0.0, 0.0, 0.0);
        }
        let (k, d) = (self.restoring(), e - s);
        (k * d * d * d / (3.0 * e), -k * d * d / e, 2.0 * k * d / e)
    }

    /// (R'(a) − R'(b))/(a − b), in closed form per branch (exact at a = b).
    fn collapse_divided_difference(&self, a: f64, b: f64) -> f64 {
        let (a, b) = if a >= b { (a, b) } else { (b, a) };
        let (e, k) = (self.threshold, self.restoring());
        if b >= e {
            0.0
        } else if a < e {
            k * (2.0 * e - a - b) / e
        } else {
            // R'(a) = 0; −R'(b)/(a − b) with a − b ≥ e − b > 0.
            k * (e - b) * (e - b) / (e * (a - b))
        }
    }

    /// k of the restoring term: the P-wave modulus λ + 2μ.
    fn restoring(&self) -> f64 {
        self.lame.lambda + 2.0 * self.lame.mu
    }

    /// Ψ̂, p, H and the pair eigenvalues at σ, sharing L and the logarithms.
    fn all(&self, s: &Vec3) -> Derivatives {
        let Lame { mu, lambda } = self.lame;
        let logs = [self.log(s[0]), self.log(s[1]), self.log(s[2])];
        let r = [
            self.collapse(s[0]),
            self.collapse(s[1]),
            self.collapse(s[2]),
        ];
        let l: f64 = logs.iter().map(|g| g.0).sum();
        let c = lambda * l - mu;
        let psi = 0.5 * mu * (s.norm_squared() - 3.0) - mu * l
            + 0.5 * lambda * l * l
            + r.iter().map(|r| r.0).sum::<f64>();
        let d1 = Vec3::new(logs[0].1, logs[1].1, logs[2].1);
        let p = Vec3::from_fn(|k, _| mu * s[k] + c * d1[k] + r[k].1);
        let mut h = lambda * d1 * d1.transpose();
        for k in 0..3 {
            h[(k, k)] += mu + c * logs[k].2 + r[k].2;
        }
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (n, &(a, b)) in PAIRS.iter().enumerate() {
            let (sa, sb) = (s[a], s[b]);
            pair_sym[n] = mu
                + c * self.log_divided_difference(sa, sb)
                + self.collapse_divided_difference(sa, sb);
            // (ℓ'(a) + ℓ'(b))/(a + b) is exactly 1/(ab) above the threshold (no division by a + b);
            // below it the rotation-variant energy has its genuine pole at σₐ = −σ_b, guarded.
            let log_sum = if sa >= self.threshold && sb >= self.threshold {
                1.0 / (sa * sb)
            } else {
                guarded_quotient(d1[a] + d1[b], sa + sb)
            };
            pair_skew[n] = mu + c * log_sum + guarded_quotient(r[a].1 + r[b].1, sa + sb);
        }
        Derivatives {
            psi,
            p,
            h,
            pair_sym,
            pair_skew,
        }
    }
}

isotropic_from_all!(LevelledNeoHookean);
