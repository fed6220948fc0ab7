//! Every model against its closed-form Ψ and P written on F (SPEC §2 and each model's docs),
//! independently of the principal-stretch code.

use super::*;

/// Every model with F above its inversion thresholds equals its formula on F (SPEC §2 and the
/// model docs), computed here from F, not from principal stretches.
pub fn check_matches_analytic(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let Lame { mu, lambda } = lame();
    // Every model is its formula wherever all stretches are at least the inversion threshold
    // (0.1, SPEC §3); the models without one everywhere with J > 0.
    let lowest = 0.1;
    for _ in 0..SAMPLES {
        let s = Vec3::from_fn(|_, _| uniform(&mut rng, lowest, 2.0));
        let f = with_stretches(&mut rng, s);
        let j = f.determinant();
        let f_inv_t = f.try_inverse().unwrap().transpose();
        let c = f.transpose() * f;
        let i1 = c.trace();
        let (psi, p) = match model.kind() {
            ModelKind::NeoHookean | ModelKind::NeoHookeanClamped => {
                let log_j = j.ln();
                (
                    0.5 * mu * (i1 - 3.0) - mu * log_j + 0.5 * lambda * log_j * log_j,
                    mu * (f - f_inv_t) + lambda * log_j * f_inv_t,
                )
            }
            ModelKind::Corotated => {
                let r = f.svd(true, true);
                let rot = r.u.unwrap() * r.v_t.unwrap();
                assert!(rot.determinant() > 0.0, "positive det F expected");
                let tr = (rot.transpose() * f - Mat3::identity()).trace();
                (
                    mu * (f - rot).norm_squared() + 0.5 * lambda * tr * tr,
                    2.0 * mu * (f - rot) + lambda * tr * rot,
                )
            }
            ModelKind::StableNeoHookean => {
                // Smith et al. 2018 with μ′ = 4μ/3, λ′ = λ + 5μ/6, α = 1 + 3μ′/(4λ′).
                let (m, l) = (4.0 * mu / 3.0, lambda + 5.0 * mu / 6.0);
                let alpha = 1.0 + 0.75 * m / l;
                // Shifted by the constant that makes the rest energy zero.
                let rest = 0.5 * l * (1.0 - alpha).powi(2) - 0.5 * m * 4f64.ln();
                (
                    0.5 * m * (i1 - 3.0) + 0.5 * l * (j - alpha).powi(2)
                        - 0.5 * m * (i1 + 1.0).ln()
                        - rest,
                    m * (1.0 - 1.0 / (i1 + 1.0)) * f + l * (j - alpha) * j * f_inv_t,
                )
            }
            ModelKind::StVenantKirchhoff => {
                let e = 0.5 * (c - Mat3::identity());
                let s = 2.0 * mu * e + lambda * e.trace() * Mat3::identity();
                (
                    mu * e.norm_squared() + 0.5 * lambda * e.trace().powi(2),
                    f * s,
                )
            }
            ModelKind::MooneyRivlin => {
                let (c10, c01, kappa) = (0.375 * mu, 0.125 * mu, lambda + 2.0 * mu / 3.0);
                let i2 = 0.5 * (i1 * i1 - (c * c).trace());
                let (g1, g2) = (j.powf(-2.0 / 3.0), j.powf(-4.0 / 3.0));
                (
                    c10 * (g1 * i1 - 3.0) + c01 * (g2 * i2 - 3.0) + 0.5 * kappa * j.ln().powi(2),
                    c10 * g1 * (2.0 * f - 2.0 / 3.0 * i1 * f_inv_t)
                        + c01 * g2 * (2.0 * (i1 * f - f * c) - 4.0 / 3.0 * i2 * f_inv_t)
                        + kappa * j.ln() * f_inv_t,
                )
            }
            ModelKind::Linear => {
                let e = 0.5 * (f + f.transpose()) - Mat3::identity();
                (
                    mu * e.norm_squared() + 0.5 * lambda * e.trace().powi(2),
                    2.0 * mu * e + lambda * e.trace() * Mat3::identity(),
                )
            }
        };
        let scale = stress_scale(lame());
        assert!(
            (psi - model.energy_density(&f)).abs() < 1e-9 * scale,
            "Ψ differs at {f}"
        );
        assert!(
            (p - model.stress(&f)).norm() < 1e-9 * scale,
            "P differs at {f}"
        );
    }
}
