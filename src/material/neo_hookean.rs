//! Neo-Hookean, SPEC §2: `Ψ = μ/2 (tr(FᵀF) − 3) − μ log J + λ/2 (log J)²`,
//! `P = μ(F − F⁻ᵀ) + λ log J F⁻ᵀ`.
//!
//! In principal stretches, with `L = Σ ln σₖ = log J`:
//! `Ψ̂_NH(σ) = μ/2 (Σσₖ² − 3) − μL + λ/2 L²`, `qₖ = ∂Ψ̂_NH/∂σₖ = μσₖ + (λL − μ)/σₖ`.
//!
//! **Inversion** (Irving et al. 2004, §5) is handled by one of two extensions below the stretch
//! threshold ε, each written as an energy so that Ψ̂, p and ∂p/∂σ stay exact derivatives of each
//! other for every σ. Where every σ ≥ ε both are exactly the analytic model.
//!
//! **Continuation** (`neo-hookean`, the default): `L = Σ ℓ(σₖ)` stands in for log J,
//! `Ψ̂ = μ/2 (Σσₖ² − 3) − μL + λ/2 L² + Σ R(σₖ)`, `pₖ = μσₖ + (λL − μ) ℓ'(σₖ) + R'(σₖ)`.
//! - ℓ = ln above ε and, below it, a C² continuation that levels off:
//!   ℓ(σ) = ln ε − 3 + (3 + 2t)e^{−t}, t = (ε − σ)/ε, bounded below by ln ε − 3. A collapsed or
//!   inverted stretch no longer drives L (and through λL/σᵢ the other stretches) without bound.
//!   An unbounded continuation (a Taylor expansion of ln) made inverted tets expand in their
//!   plane without limit and left tangled bodies stuck in wrong shapes.
//! - R(σ) = k/(3ε)·(ε − σ)³ below ε (zero above; C²), k = λ + 2μ: Irving's linear extrapolation
//!   of the stress below the threshold, as an energy.
//!
//! **Clamp** (`neo-hookean-clamped`): Irving's clamped stretches as an energy (see
//! [`super::clamp`]): `Ψ̂(σ) = Ψ̂_NH(c(σ₁), c(σ₂), c(σ₃)) + Σ R(σₖ)`. c clamps each stretch onto
//! the floor ¾ε through a C² window, so the whole Neo-Hookean energy, its volume term included,
//! sees a collapsed or inverted stretch as ¾ε; R (a spring k = 2μ and a push Q = 2μ) restores
//! what the clamp takes away. It is [`NeoHookean::clamped`]: this model inside the generic
//! [`Clamped`], with the continuation's threshold at the clamp's floor so that the wrapped
//! model is the analytic one for every stretch it sees.
//!
//! **Why two** (issue 6). A tet flattened onto a plane keeps stretching in its plane until its
//! volume term balances: with L fed by the collapsed stretch, a flat tet wants σ₁σ₂ ≈ 1/σ₃. The
//! continuation leaves that drive almost intact: from a jittered line or point the 6×2×2 beam
//! settles in a genuine local minimum (2.06e4 J, zero velocity after 1,200 frames, every J > 0,
//! vertices inside other tets) where the beam's end cubes are everted and held by flattened,
//! in-plane stretched tets (σ ≈ (1.65, 1.18, 0.06)), 1.34 edge lengths from rest. The analytic
//! model (threshold 0.01) holds the same fold with σ₃ ≈ 0.25, so only the energy below the
//! threshold can remove it. With the clamp a flat tet's volume term sees ¾ε and its in-plane
//! equilibrium stretch is about 1.3, as for corotated, and the spring restores the collapsed
//! stretch like corotated's. Measured over 172 starts (every start on the 6×2×2 beam, plus line,
//! point and scrambled with eight seeds, on beams 4×2×2, 6×2×2, 8×2×2 and 6×3×2; ν = 0.3) with
//! `cargo run --release --example recovery_diag -- model=nhc start=all
//! meshes=beam,beam4,beam8,beam632 seeds=7,1,2,3,4,5,6,8`: none stays folded with the clamp,
//! 103 with the continuation (`model=nh`; corotated, `model=co`: 13). For the spring k = λ + 2μ
//! did as well at ν = 0.3 but not at ν = 0.45, and 2(λ + 2μ) badly, so it is the shear
//! stiffness alone.
//!
//! The price of the clamp is Newton's work where many tets are crushed flat. Across the window
//! the clamp switches the model's compressive stress off (c′ → 0) and the energy curves the
//! wrong way (c″·q < 0); the push Q hands that stress over and offsets the curvature, but not
//! entirely. Crushing a block under a plate (`scenes/squash_release.toml`) retried 11 steps
//! (31 without the push), left one frame unconverged and gained 9 J in one frame, against 2
//! retries with the continuation; a flattened cube (`scenes/squash_recover.toml`) 5 retries
//! and one unconverged frame against none. Without the push, a wider window (w = ε), a lower
//! threshold (0.3, 0.45), a stiffer spring (k = 2μ + λ, 2μ + 4λ), the `abs` or `analytic`
//! definiteness fix and 50 Newton iterations did not cure it either. So the continuation stays
//! the default and the clamp is the model for tangled starts.

use super::Lame;
use super::clamp::{Clamped, StretchClamp};
use super::isotropic::{Derivatives, Isotropic, PAIRS, guarded_quotient};
use crate::math::{Mat3, Vec3};

/// Default inversion threshold of both extensions: stretches below 0.6 are extended. Chosen by
/// measurement on the Irving recovery cases (flattened, line- and point-collapsed, scrambled
/// beams and balls): with the continuation, 0.3 left half of the tangled starts folded, 0.5 four,
/// 0.6 three; with the clamp, 0.5–0.8 all recover most. A lower threshold keeps the analytic
/// model further into compression.
pub const DEFAULT_INVERSION_THRESHOLD: f64 = 0.6;

/// Relative gap below which divided differences of ℓ' use the midpoint derivative (error
/// ~gap², below rounding) instead of the quotient (error ~ε_machine/gap).
const NEAR: f64 = 1e-4;

/// Neo-Hookean in principal stretches (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// Lamé parameters.
    pub lame: Lame,
    /// The stretch threshold ε of the continuation.
    pub threshold: f64,
}

impl NeoHookean {
    /// With the default inversion threshold (`neo-hookean`).
    pub fn new(lame: Lame) -> Self {
        Self::with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// With a given inversion threshold (a stretch in (0, 1)).
    pub fn with_threshold(lame: Lame, threshold: f64) -> Self {
        NeoHookean { lame, threshold }
    }

    /// `neo-hookean-clamped`: the model behind a clamp at the default threshold.
    pub fn clamped(lame: Lame) -> Clamped<Self> {
        Self::clamped_with_threshold(lame, DEFAULT_INVERSION_THRESHOLD)
    }

    /// The model behind a clamp of the stretches below `threshold`, with a 2μ spring and push.
    /// The continuation's own threshold sits at the clamp's floor, so the wrapped model is the
    /// analytic one for every stretch the clamp lets through.
    pub fn clamped_with_threshold(lame: Lame, threshold: f64) -> Clamped<Self> {
        let clamp = StretchClamp::with_shear_modulus(threshold, lame.mu);
        Clamped {
            model: Self::with_threshold(lame, clamp.floor()),
            clamp,
        }
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
