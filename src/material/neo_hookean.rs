//! Neo-Hookean, SPEC §2: `Ψ = μ/2 (tr(FᵀF) − 3) − μ log J + λ/2 (log J)²`,
//! `P = μ(F − F⁻ᵀ) + λ log J F⁻ᵀ`.
//!
//! In principal stretches, with `L = Σ ℓ(σₖ)` standing in for log J:
//! `Ψ̂ = μ/2 (Σσₖ² − 3) − μL + λ/2 L² + Σ R(σₖ)`, `pₖ = μσₖ + (λL − μ) ℓ'(σₖ) + R'(σₖ)`.
//!
//! **Inversion** (Irving et al. 2004, §5), written as an energy so that Ψ̂, p and ∂p/∂σ stay exact
//! derivatives of each other for every σ:
//! - ℓ = ln above the stretch threshold ε and, below it, a C² continuation that levels off:
//!   ℓ(σ) = ln ε − 3 + (3 + 2t)e^{−t}, t = (ε − σ)/ε, bounded below by ln ε − 3. This is the
//!   energy form of Irving's "evaluate the stress at the clamped stretch": a collapsed or inverted
//!   stretch no longer drives L (and through λL/σᵢ the other stretches) without bound. An
//!   unbounded continuation (a Taylor expansion of ln) made inverted tets expand in their plane
//!   without limit and left tangled bodies stuck in wrong shapes.
//! - R(σ) = k/(3ε)·(ε − σ)³ below ε (zero above; C²), k = λ + 2μ: Irving's linear extrapolation
//!   of the stress below the threshold, as an energy — the restoring force grows with the depth
//!   of the collapse or inversion, and reopens tets squeezed onto a plane, a line or a point.
//!
//! Where every σ ≥ ε the model is exactly the analytic one.

use super::Lame;
use super::isotropic::{Derivatives, Isotropic, PAIRS, guarded_quotient};
use crate::math::{Mat3, Vec3};

/// Default inversion threshold: stretches below 0.6 use the continuation (ℓ differs from ln by
/// 0.6 % at σ = 0.5 and 10 % at σ = 0.3). Chosen by measurement on the Irving recovery cases
/// (flattened, line-collapsed, point-collapsed with jitter and scrambled beams and balls, 10 s
/// each): at 0.3 half of the tangled starts stayed folded in a wrong shape, at 0.5 four, at 0.6
/// three (all from a jittered line or point); a lower threshold keeps the analytic model further
/// into compression but raises the energy barrier a folded body must cross to unfold.
pub const DEFAULT_INVERSION_THRESHOLD: f64 = 0.6;

/// Relative gap below which divided differences of ℓ' use the midpoint derivative (error
/// ~gap², below rounding) instead of the quotient (error ~ε_machine/gap).
const NEAR: f64 = 1e-4;

/// Neo-Hookean in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// Lamé parameters.
    pub lame: Lame,
    /// The stretch threshold ε of the inversion handling.
    pub threshold: f64,
}

impl NeoHookean {
    /// With the default inversion threshold.
    pub fn new(lame: Lame) -> Self {
        Self::with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// With a given inversion threshold (a stretch in (0, 1)).
    pub fn with_threshold(lame: Lame, threshold: f64) -> Self {
        NeoHookean { lame, threshold }
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

impl Isotropic for NeoHookean {
    fn psi(&self, s: &Vec3) -> f64 {
        self.all(s).psi
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        self.all(s).p
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        self.all(s).h
    }

    fn pair_eigenvalues(&self, s: &Vec3, _: &Vec3, _: &Mat3, i: usize, j: usize) -> (f64, f64) {
        let d = self.all(s);
        let n = PAIRS
            .iter()
            .position(|&p| p == (i.min(j), i.max(j)))
            .expect("a pair of distinct indices");
        (d.pair_sym[n], d.pair_skew[n])
    }

    fn derivatives(&self, s: &Vec3) -> Derivatives {
        self.all(s)
    }
}
