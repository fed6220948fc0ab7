//! Irving et al. 2004's clamped stretches (§5), written as an energy for any model in principal
//! stretches: `Ψ̂(σ) = Ψ̂_M(c(σ₁), c(σ₂), c(σ₃)) + Σ R(σₖ)`, `pₖ = c′(σₖ)·qₖ(c) + R′(σₖ)` with
//! `q = ∂Ψ̂_M/∂σ` at the clamped stretches.
//!
//! - c is a smooth clamp of one stretch: c(σ) = σ at and above the threshold ε; over the window
//!   [ε − w, ε] below it (w = ε/2) a C² easing (c′ = 1 − 3u² + 2u³, u = (ε − σ)/w) takes it onto
//!   the floor ε − w/2 = ¾ε, where it stays for every smaller or negative σ. The model never sees
//!   a stretch below ¾ε, so every term stays finite and bounded however flat or inverted a tet is.
//! - R restores what the clamp takes away, with g = c − σ ≥ 0 the depth below the clamp:
//!   `R = k∫g + Q·g`, `R′ = −k·g − Q·(1 − c′)`, `R″ = k·(1 − c′) + Q·c″`, zero above ε and C²
//!   across it. The spring k·g pulls a stretch back in proportion to its depth, for collapsed
//!   (σ = 0) and inverted (σ < 0) tets alike. The push Q hands the model's compressive stress,
//!   which c′ → 0 switches off across the window, over to a constant: without it the stress
//!   fell from q(ε) to almost nothing as a tet was crushed through the window (a softening
//!   material, and Newton retried 31 steps of a block crushed under a plate), and its curvature
//!   Q·c″ offsets the window's negative c″·q.
//!
//! Two uses, two choices of k and Q:
//! - **Recovery** ([`StretchClamp::with_shear_modulus`], at a stretch of 0.6): what tangled
//!   elements are evaluated with ([`crate::elastic::recovery`]). k = Q = 2μ (2μ is the stiffness
//!   of corotated's deviatoric term) brings every one of 172 collapsed, scrambled and inverted
//!   starts back (`cargo run --release --example recovery_diag -- model=nhc start=all
//!   meshes=beam,beam4,beam8,beam632 seeds=7,1,2,3,4,5,6,8`; Q = 0 left 1 folded for
//!   Neo-Hookean, 4 for Mooney-Rivlin).
//! - **An inversion extension** ([`Clamped::matching`], at the inversion threshold 0.1): k and Q
//!   are the model's own stiffness and stress at ε, so the resistance of a crushed stretch keeps
//!   growing (`neo-hookean-clamped`, `mooney-rivlin`).
//!
//! Where every σ ≥ ε the model is the wrapped one, bit for bit the same code path.

use super::isotropic::{Derivatives, Isotropic, PAIRS, guarded_quotient};
use crate::math::{Mat3, Vec3};

/// Relative gap below which divided differences of c and c′ use the midpoint derivative (error
/// ~gap², below rounding) instead of the quotient (error ~ε_machine/gap).
const NEAR: f64 = 1e-4;

/// The clamp of one stretch and its spring: threshold ε and spring stiffness k.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StretchClamp {
    /// ε: stretches below it are clamped.
    pub threshold: f64,
    /// k of the restoring spring, Pa.
    pub stiffness: f64,
    /// Q, the constant push, Pa.
    pub push: f64,
}

/// c, R and their derivatives at one stretch.
#[derive(Clone, Copy, Debug)]
pub struct ClampedStretch {
    /// c(σ).
    pub c: f64,
    /// c′(σ).
    pub c1: f64,
    /// c″(σ).
    pub c2: f64,
    /// R(σ).
    pub r: f64,
    /// R′(σ) = −k(c − σ).
    pub r1: f64,
    /// R″(σ) = k(1 − c′).
    pub r2: f64,
}

impl StretchClamp {
    /// The clamp of Neo-Hookean and Mooney-Rivlin: k = Q = 2μ (2μ is the stiffness of
    /// corotated's deviatoric term; see the module docs for the measurements).
    pub fn with_shear_modulus(threshold: f64, mu: f64) -> Self {
        StretchClamp {
            threshold,
            stiffness: 2.0 * mu,
            push: 2.0 * mu,
        }
    }

    /// The floor ¾ε: the smallest stretch the wrapped model sees.
    #[inline]
    pub fn floor(&self) -> f64 {
        Self::floor_of(self.threshold)
    }

    /// The floor ¾ε of a clamp at `threshold` ε.
    #[inline]
    pub fn floor_of(threshold: f64) -> f64 {
        threshold - 0.25 * threshold
    }

    /// c, R and their derivatives at σ (identity, no spring, at and above ε).
    #[inline]
    pub fn at(&self, s: f64) -> ClampedStretch {
        if s >= self.threshold {
            return ClampedStretch {
                c: s,
                c1: 1.0,
                c2: 0.0,
                r: 0.0,
                r1: 0.0,
                r2: 0.0,
            };
        }
        let e = self.threshold;
        let w = 0.5 * e;
        let k = self.stiffness;
        let q = self.push;
        let d = e - s;
        let u = d / w;
        if u >= 1.0 {
            // On the floor: c = ε − w/2, the spring is linear with force k·(c − σ).
            let a = d - 0.5 * w;
            return ClampedStretch {
                c: self.floor(),
                c1: 0.0,
                c2: 0.0,
                r: k * (0.5 * a * a + 0.025 * w * w) + q * a,
                r1: -k * a - q,
                r2: k,
            };
        }
        let (u2, u3) = (u * u, u * u * u);
        // c − σ = w(u³ − u⁴/2); R = k∫(c − σ) = k w²(u⁴/4 − u⁵/10).
        let gap = w * (u3 - 0.5 * u2 * u2);
        let c1 = 1.0 - 3.0 * u2 + 2.0 * u3;
        let c2 = 6.0 * u * (1.0 - u) / w;
        ClampedStretch {
            c: s + gap,
            c1,
            c2,
            r: k * w * w * (0.25 * u2 * u2 - 0.1 * u2 * u3) + q * gap,
            r1: -k * gap - q * (1.0 - c1),
            r2: k * (3.0 * u2 - 2.0 * u3) + q * c2,
        }
    }

    /// (R′ᵢ − R′ⱼ)/(σᵢ − σⱼ) from the divided differences of c and c′.
    #[inline]
    pub fn spring_divided_difference(&self, dd_c: f64, dd_c1: f64) -> f64 {
        -self.stiffness * (dd_c - 1.0) + self.push * dd_c1
    }

    /// The divided differences `((cᵢ − cⱼ), (c′ᵢ − c′ⱼ))/(σᵢ − σⱼ)`, by the quotient or, at a
    /// tiny gap, the midpoint derivatives.
    #[inline]
    pub fn divided_differences(
        &self,
        (si, sj): (f64, f64),
        (mi, mj): (&ClampedStretch, &ClampedStretch),
    ) -> (f64, f64) {
        if (si - sj).abs() <= NEAR * self.threshold {
            let mid = self.at(0.5 * (si + sj));
            (mid.c1, mid.c2)
        } else {
            let gap = si - sj;
            ((mi.c - mj.c) / gap, (mi.c1 - mj.c1) / gap)
        }
    }
}

/// A model in principal stretches with its stretches clamped below a threshold (see the module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clamped<M> {
    /// The wrapped model, which only ever sees stretches of at least ¾ε.
    pub model: M,
    /// The clamp and its spring.
    pub clamp: StretchClamp,
}

impl<M: Isotropic> Clamped<M> {
    /// `model` clamped at `threshold` with a spring and push matched to the model where one
    /// stretch reaches the floor ¾ε and the others are at rest, σ = (1, 1, ¾ε): Q = −p₃ and
    /// k = ∂p₃/∂σ₃ there. The push then takes over the model's compressive stress across the
    /// window (with Q the stress at the floor, the window's curvature c″·(q + Q) is not negative
    /// for that state) and the spring continues it with the model's own stiffness, Irving et al.
    /// 2004's linear extrapolation, so a crushed stretch meets a resistance that keeps growing
    /// instead of falling to 2μ (what [`StretchClamp::with_shear_modulus`] gives, for tangled
    /// starts).
    pub fn matching(model: M, threshold: f64) -> Self {
        let floor = StretchClamp::floor_of(threshold);
        let at = model.derivatives(&Vec3::new(1.0, 1.0, floor));
        Clamped {
            model,
            clamp: StretchClamp {
                threshold,
                stiffness: at.h[(2, 2)].max(0.0),
                push: (-at.p[2]).max(0.0),
            },
        }
    }

    /// The composite at σ, some σ < ε.
    fn below(&self, s: &Vec3) -> Derivatives {
        let m = [
            self.clamp.at(s[0]),
            self.clamp.at(s[1]),
            self.clamp.at(s[2]),
        ];
        let c = Vec3::new(m[0].c, m[1].c, m[2].c);
        let inner = self.model.derivatives(&c);
        let q = inner.p;
        let p = Vec3::from_fn(|i, _| m[i].c1 * q[i] + m[i].r1);
        let mut h = Mat3::from_fn(|i, j| m[i].c1 * m[j].c1 * inner.h[(i, j)]);
        for i in 0..3 {
            h[(i, i)] += m[i].c2 * q[i] + m[i].r2;
        }
        let e = self.clamp.threshold;
        let mut pair_sym = Vec3::zeros();
        let mut pair_skew = Vec3::zeros();
        for (n, &(i, j)) in PAIRS.iter().enumerate() {
            if s[i] >= e && s[j] >= e {
                // c = σ, c′ = 1 and no spring on both: the wrapped model's own closed forms.
                pair_sym[n] = inner.pair_sym[n];
                pair_skew[n] = inner.pair_skew[n];
                continue;
            }
            // pᵢ − pⱼ = c′ᵢ(qᵢ − qⱼ) + (c′ᵢ − c′ⱼ)qⱼ + R′ᵢ − R′ⱼ, with qᵢ − qⱼ the wrapped pair
            // eigenvalue times cᵢ − cⱼ: no quotient of p itself, so nothing cancels at σᵢ ≈ σⱼ.
            let (dd_c, dd_c1) = self.clamp.divided_differences((s[i], s[j]), (&m[i], &m[j]));
            pair_sym[n] = m[i].c1 * inner.pair_sym[n] * dd_c
                + dd_c1 * q[j]
                + self.clamp.spring_divided_difference(dd_c, dd_c1);
            // The rotation-variant energy has its genuine pole at σᵢ = −σⱼ, guarded.
            pair_skew[n] = guarded_quotient(p[i] + p[j], s[i] + s[j]);
        }
        Derivatives {
            psi: inner.psi + m.iter().map(|m| m.r).sum::<f64>(),
            p,
            h,
            pair_sym,
            pair_skew,
        }
    }

    #[inline]
    fn all(&self, s: &Vec3) -> Derivatives {
        if s.min() >= self.clamp.threshold {
            self.model.derivatives(s)
        } else {
            self.below(s)
        }
    }
}

impl<M: Isotropic> Isotropic for Clamped<M> {
    fn psi(&self, s: &Vec3) -> f64 {
        if s.min() >= self.clamp.threshold {
            self.model.psi(s)
        } else {
            self.below(s).psi
        }
    }

    fn dpsi(&self, s: &Vec3) -> Vec3 {
        if s.min() >= self.clamp.threshold {
            self.model.dpsi(s)
        } else {
            self.below(s).p
        }
    }

    fn d2psi(&self, s: &Vec3) -> Mat3 {
        if s.min() >= self.clamp.threshold {
            self.model.d2psi(s)
        } else {
            self.below(s).h
        }
    }

    fn pair_eigenvalues(&self, s: &Vec3, p: &Vec3, h: &Mat3, i: usize, j: usize) -> (f64, f64) {
        if s.min() >= self.clamp.threshold {
            return self.model.pair_eigenvalues(s, p, h, i, j);
        }
        self.below(s).pair(i, j)
    }

    fn derivatives(&self, s: &Vec3) -> Derivatives {
        self.all(s)
    }
}
