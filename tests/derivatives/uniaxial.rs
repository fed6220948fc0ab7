//! Uniaxial stress at the material level: F = R₁·diag(λ₁, t, t)·R₂ with the lateral stretch t
//! solved numerically (bisection on the model's own P₂₂ = 0), then P₁₁ compared with each model's
//! uniaxial formula derived by hand, the hand-derived lateral condition checked at that t, and
//! the small-strain slopes dP₁₁/dλ₁ = E and dt/dλ₁ = −ν checked at λ₁ = 1.
//!
//! The formulas (with Kirchhoff stresses τₖ = σₖpₖ; P₁₁ = τ₁/λ₁):
//! - linear and corotated: `t = 1 − ν(λ₁ − 1)`, `P₁₁ = E(λ₁ − 1)`;
//! - St. Venant-Kirchhoff: `t² = 1 − ν(λ₁² − 1)`, `P₁₁ = E λ₁(λ₁² − 1)/2` (S₁₁ = E·E₁₁);
//! - Neo-Hookean: `μ(t² − 1) + λ ln(λ₁t²) = 0`, `P₁₁ = μ(λ₁² − t²)/λ₁`;
//! - Stable Neo-Hookean (μ′, λ′, α as in its docs, I = λ₁² + 2t²):
//!   `μ′I/(I + 1) + λ′λ₁(λ₁t² − α) = 0`, `P₁₁ = μ′I/(I + 1)·(λ₁ − t²/λ₁)`;
//! - Mooney-Rivlin (J = λ₁t², a = J^(−1/3)λ₁, b = J^(−1/3)t):
//!   `κ ln J = ⅔(a² − b²)(C₁₀ + C₀₁b²)`, `P₁₁ = 2(a² − b²)(C₁₀ + C₀₁b²)/λ₁`, which for J = 1
//!   is the classic incompressible `2(λ₁ − λ₁⁻²)(C₁₀ + C₀₁/λ₁)`.

use super::*;

/// Stretches along the load, from compression to stretch, above every inversion threshold (0.1).
const STRETCHES: [f64; 8] = [0.12, 0.3, 0.6, 0.8, 0.95, 1.05, 1.3, 1.8];

/// The diagonal of `R₁ᵀ·P·R₂ᵀ` at `F = R₁·diag(λ₁, t, t)·R₂`, checking that P has no shear there.
fn principal_stress(model: &Model, r: &(Mat3, Mat3), l1: f64, t: f64) -> Vec3 {
    let f = r.0 * Mat3::from_diagonal(&Vec3::new(l1, t, t)) * r.1;
    let p = r.0.transpose() * model.stress(&f) * r.1.transpose();
    let off = (p - Mat3::from_diagonal(&p.diagonal())).norm();
    assert!(off <= 1e-9 * stress_scale(lame()), "shear {off:e} in {p}");
    p.diagonal()
}

/// t with P₂₂(λ₁, t, t) = 0, by bisection on [0.1, 3] to machine precision.
fn lateral_stretch(model: &Model, r: &(Mat3, Mat3), l1: f64) -> f64 {
    let lateral = |t: f64| principal_stress(model, r, l1, t)[1];
    let (mut lo, mut hi) = (0.1, 3.0);
    assert!(
        lateral(lo) < 0.0 && lateral(hi) > 0.0,
        "no bracket at λ₁ = {l1}"
    );
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if lateral(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The hand-derived `(lateral residual, P₁₁)` at (λ₁, t); the residual (dimensionless: stresses
/// are divided by the stress scale) is zero at the true t.
fn formula(kind: ModelKind, l1: f64, t: f64) -> (f64, f64) {
    let Lame { mu, lambda } = lame();
    let scale = stress_scale(lame());
    let (e, nu) = (lame().youngs_modulus(), lame().poisson_ratio());
    match kind {
        ModelKind::Linear | ModelKind::Corotated => (t - (1.0 - nu * (l1 - 1.0)), e * (l1 - 1.0)),
        ModelKind::StVenantKirchhoff => (
            t * t - (1.0 - nu * (l1 * l1 - 1.0)),
            0.5 * e * l1 * (l1 * l1 - 1.0),
        ),
        ModelKind::NeoHookean | ModelKind::NeoHookeanClamped => (
            (mu * (t * t - 1.0) + lambda * (l1 * t * t).ln()) / scale,
            mu * (l1 * l1 - t * t) / l1,
        ),
        ModelKind::StableNeoHookean => {
            let (m, l) = (4.0 * mu / 3.0, lambda + 5.0 * mu / 6.0);
            let alpha = 1.0 + mu / l;
            let i = l1 * l1 + 2.0 * t * t;
            let shear = m * i / (i + 1.0);
            (
                (shear + l * l1 * (l1 * t * t - alpha)) / scale,
                shear * (l1 - t * t / l1),
            )
        }
        ModelKind::MooneyRivlin => {
            let (c10, c01, kappa) = (0.375 * mu, 0.125 * mu, lambda + 2.0 * mu / 3.0);
            let j = l1 * t * t;
            let (a, b) = (j.powf(-1.0 / 3.0) * l1, j.powf(-1.0 / 3.0) * t);
            let dev = (a * a - b * b) * (c10 + c01 * b * b);
            ((kappa * j.ln() - 2.0 / 3.0 * dev) / scale, 2.0 * dev / l1)
        }
    }
}

pub fn check_uniaxial(model: &Model) {
    let kind = model.kind();
    let mut rng = rng(31);
    let scale = stress_scale(lame());
    // Linear elasticity is not rotation invariant: load it along the axes.
    let r = if kind.is_rotation_invariant() {
        (rotation(&mut rng), rotation(&mut rng))
    } else {
        (Mat3::identity(), Mat3::identity())
    };
    for l1 in STRETCHES {
        let t = lateral_stretch(model, &r, l1);
        let p = principal_stress(model, &r, l1, t);
        assert!(
            p[2].abs() <= 1e-9 * scale,
            "{kind:?}: P₃₃ = {} at λ₁ = {l1}",
            p[2]
        );
        let (residual, p11) = formula(kind, l1, t);
        assert!(
            residual.abs() <= 1e-10,
            "{kind:?}: lateral condition off by {residual:e} at λ₁ = {l1}, t = {t}"
        );
        assert!(
            (p[0] - p11).abs() <= 1e-9 * scale,
            "{kind:?}: P₁₁ = {} but the formula gives {p11} at λ₁ = {l1}, t = {t}",
            p[0]
        );
        // Compression shortens and bulges, stretch the other way (stable Neo-Hookean's own
        // formula pulls in again under deep compression: its t is 0.89 at λ₁ = 0.3).
        assert_eq!(p[0] > 0.0, l1 > 1.0);
        if l1 >= 0.6 {
            assert_eq!(t < 1.0, l1 > 1.0, "lateral stretch {t} at λ₁ = {l1}");
        }
    }
    // Small strain: every model reduces to linear elasticity with the user's E and ν.
    let h = 1e-5;
    let (tp, tm) = (
        lateral_stretch(model, &r, 1.0 + h),
        lateral_stretch(model, &r, 1.0 - h),
    );
    let (pp, pm) = (
        principal_stress(model, &r, 1.0 + h, tp)[0],
        principal_stress(model, &r, 1.0 - h, tm)[0],
    );
    let (e, nu) = (lame().youngs_modulus(), lame().poisson_ratio());
    let young = (pp - pm) / (2.0 * h);
    assert!((young - e).abs() <= 1e-6 * e, "{kind:?}: E = {young} ≠ {e}");
    let poisson = -(tp - tm) / (2.0 * h);
    assert!(
        (poisson - nu).abs() <= 1e-6,
        "{kind:?}: ν = {poisson} ≠ {nu}"
    );
}

/// St. Venant-Kirchhoff's documented weakness: under uniaxial compression its resistance peaks
/// at λ₁ = 1/√3 and then falls to zero, and a reflected F costs no energy at all.
#[test]
fn st_venant_kirchhoff_softens_under_compression_and_ignores_reflection() {
    let model = Model::new(ModelKind::StVenantKirchhoff, lame());
    let r = (Mat3::identity(), Mat3::identity());
    let resistance =
        |l1: f64| -principal_stress(&model, &r, l1, lateral_stretch(&model, &r, l1))[0];
    let peak = 1.0 / 3f64.sqrt();
    assert!(resistance(peak) > resistance(peak + 0.05));
    assert!(resistance(peak) > resistance(peak - 0.05));
    assert!(resistance(0.2) < 0.5 * resistance(peak));
    let e = lame().youngs_modulus();
    assert!((resistance(peak) - e / 3f64.powf(1.5)).abs() < 1e-9 * e);
    let reflected = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0));
    assert!(model.energy_density(&reflected).abs() < 1e-12 * e);
    assert!(model.stress(&reflected).norm() < 1e-9 * e);
    // The robust models push the same reflection back.
    for kind in [
        ModelKind::NeoHookean,
        ModelKind::NeoHookeanClamped,
        ModelKind::StableNeoHookean,
        ModelKind::MooneyRivlin,
    ] {
        let other = Model::new(kind, lame());
        assert!(other.energy_density(&reflected) > 0.01 * e, "{kind:?}");
    }
}
