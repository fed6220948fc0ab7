//! Rayleigh stiffness damping in a backward-Euler step: the damping force is one function of
//! (F, v) whatever the definiteness strategy, and Newton's tangent of the damped step (shifted
//! to F + θ·dF_v, see `integrator::DampingTangent`) is the Jacobian of the damped stress to
//! second order in θ·dF_v, checked against finite differences on random and near-inverted F.

use super::*;
use tetsim::elastic::Damping;
use tetsim::material::{DampedTangent, DampingStiffness};

/// The bench workload's step and damping: h = 1/30 s, γ = 0.01 s.
const H: f64 = 1.0 / 30.0;
const GAMMA: f64 = 0.01;

/// w = γ/h and θ = γh/(h + γ), as `integrator::terms::Elasticity` sets them.
fn weight_and_shift() -> (f64, f64) {
    (GAMMA / H, GAMMA * H / (H + GAMMA))
}

/// The stress of a damped step with the exact damping stiffness as a function of F alone
/// (Fₙ fixed, dF_v = (F − Fₙ)/h): `Σ(F) = P(F) + γ·(∂P/∂F)(F):(F − Fₙ)/h`. Its Jacobian is what
/// Newton's tangent approximates.
fn damped_stress(model: &Model, f: &Mat3, f_n: &Mat3) -> Mat3 {
    model.stress(f) + GAMMA * model.stress_differential(f, &((f - f_n) / H))
}

/// ‖N:dF − (∂Σ/∂F):dF‖ / ‖(∂Σ/∂F):dF‖ for Newton's tangent N made with `shift`, the Jacobian by
/// central differences (best over a sweep of steps).
fn tangent_error(model: &Model, f: &Mat3, df_v: &Mat3, df: &Mat3, shift: f64) -> f64 {
    let (weight, _) = weight_and_shift();
    let how = DampedTangent {
        definiteness: Definiteness::Exact,
        damping: DampingStiffness::Exact,
        shift,
        weight,
    };
    let newton = model.evaluate_damped(f, df_v, &how).tangent.apply(df);
    let f_n = f - H * df_v;
    [1e-4, 1e-5, 1e-6, 1e-7]
        .iter()
        .map(|&eps| {
            let fd = (damped_stress(model, &(f + eps * df), &f_n)
                - damped_stress(model, &(f - eps * df), &f_n))
                / (2.0 * eps);
            (newton - fd).norm() / fd.norm().max(1e-12 * stress_scale(lame()))
        })
        .fold(f64::INFINITY, f64::min)
}

/// The shifted tangent is consistent to second order: its error falls with the square of the
/// velocity gradient (the frozen one's only linearly), and at a small one it is far below the
/// frozen tangent's.
pub fn check_shifted_tangent(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let (_, shift) = weight_and_shift();
    for family in [Family::Random, Family::NearInverted] {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df = random_matrix(&mut rng);
            let direction = random_matrix(&mut rng);
            // θ·|dF_v| a small fraction of the smallest stretch, so that F + θ·dF_v stays in
            // the same smooth piece of every model (thresholds, clamps).
            let sigma_min = tetsim::math::svd_rv(&f).sigma.amin();
            let unit = direction * (sigma_min / (shift * direction.norm()));
            let (large, small) = (0.02 * unit, 0.002 * unit);
            let shifted = [large, small].map(|v| tangent_error(model, &f, &v, &df, shift));
            let frozen = [large, small].map(|v| tangent_error(model, &f, &v, &df, 0.0));
            if frozen[1] < 1e-9 {
                // A constant tangent (linear elasticity): nothing to be consistent with.
                assert!(shifted[1] < 1e-9, "{family:?} at {f}: {shifted:?}");
                continue;
            }
            assert!(
                shifted[1] <= 0.05 * shifted[0] + 1e-9,
                "{:?} {family:?}: the shifted tangent's error {shifted:?} does not fall \
                 quadratically (frozen {frozen:?}) at F = {f}",
                model.kind()
            );
            assert!(
                shifted[1] <= 0.1 * frozen[1] + 1e-9,
                "{:?} {family:?}: shifted {shifted:?} not far below frozen {frozen:?} at {f}",
                model.kind()
            );
        }
    }
}

/// The damping stress K_d(F):dF_v depends on the damping stiffness only, never on Newton's
/// definiteness strategy or the shift; Newton's tangent is the strategy's plus w·K_d, at the
/// shifted F (and written in place, as the element loop does, the same bits).
pub fn check_damping_is_strategy_free(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let (weight, shift) = weight_and_shift();
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df_v = 5.0 * random_matrix(&mut rng);
            let df = random_matrix(&mut rng);
            for damping in DampingStiffness::ALL {
                let expected = model.tangent(&f, damping.definiteness()).apply(&df_v);
                for definiteness in Definiteness::ALL {
                    for s in [0.0, shift] {
                        let how = DampedTangent {
                            definiteness,
                            damping,
                            shift: s,
                            weight,
                        };
                        let e = model.evaluate_damped(&f, &df_v, &how);
                        assert_eq!(e.damping, expected, "{definiteness} {damping} at {f}");
                        assert_eq!(e.stress, model.stress(&f));
                        // `adaptive` is `teran` per element (the exact pieces go aside).
                        let newton_def = match definiteness {
                            Definiteness::Adaptive => Definiteness::Projected,
                            d => d,
                        };
                        let g = tetsim::material::shifted_deformation(&f, &df_v, s);
                        let want = model.tangent(&g, newton_def).apply(&df)
                            + weight * model.tangent(&g, damping.definiteness()).apply(&df);
                        let got = e.tangent.apply(&df);
                        // The element loop's in-place form gives the same bits as by value.
                        let svd = tetsim::math::svd_rv(&g);
                        let (tangent, exact) = model.damped_tangent_svd(&g, &svd, &how);
                        let mut into = (model.tangent(&f, Definiteness::Exact), Default::default());
                        model.damped_tangent_svd_into(
                            &g,
                            &svd,
                            &how,
                            &mut into.0,
                            Some(&mut into.1),
                        );
                        assert_eq!(into, (tangent, exact), "{definiteness} {damping} θ = {s}");
                        let scale = want.norm().max(stress_scale(lame()));
                        assert!(
                            (got - want).norm() <= 1e-10 * scale,
                            "{definiteness} {damping} θ = {s}: {got} ≠ {want} at {f}"
                        );
                    }
                }
            }
        }
    }
}

/// On a body: K_d·v is the stiffness product of the damping stiffness's own linearization, the
/// same under every strategy, and Newton's tangent product matches the finite-difference
/// Jacobian of the damped step's residual `f_el(x) − γ·K_d(x)·(x − xₙ)/h` to second order.
#[test]
fn body_damping_force_and_tangent_match_finite_differences() {
    check_body_damping(false);
}

/// The same on curved quadratic tets.
#[test]
fn quadratic_body_damping_force_and_tangent_match_finite_differences() {
    check_body_damping(true);
}

fn check_body_damping(quadratic: bool) {
    let mut rng = rng(77);
    let mut mesh = small_mesh(&mut rng);
    if quadratic {
        mesh = curved(&mut rng, &tetsim::mesh::quadratic::elevate(&mesh));
    }
    let body = ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap();
    let n = body.vertex_count();
    let x = perturbed(&mut rng, &body.mesh.positions, 0.15);
    let direction = random_field(&mut rng, n);
    let dx = random_field(&mut rng, n);
    let (weight, shift) = weight_and_shift();
    // The residual's damped part with the exact damping stiffness, as a function of x.
    let residual = |x: &[Vec3], xn: &[Vec3]| {
        let v: Vec<Vec3> = x.iter().zip(xn).map(|(a, b)| (a - b) / H).collect();
        let damping = Damping {
            velocities: &v,
            stiffness: DampingStiffness::Exact,
            shift: 0.0,
            weight,
        };
        let mut lin = tetsim::Linearization::new(&body, Definiteness::Exact);
        let (mut f, mut kv) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
        body.linearize_damped_into(x, &damping, &mut lin, &mut f, &mut kv);
        let r: Vec<Vec3> = f.iter().zip(&kv).map(|(f, kv)| f - GAMMA * kv).collect();
        (r, kv, v)
    };
    let mut errors = Vec::new();
    for speed in [1.0, 0.1] {
        // xₙ such that v = speed · direction.
        let xn: Vec<Vec3> = x
            .iter()
            .zip(&direction)
            .map(|(p, d)| p - H * speed * d)
            .collect();
        let (_, kv, v) = residual(&x, &xn);
        // K_d·v: the exact stiffness product, whatever Newton's strategy.
        let mut exact = body.linearize(&x, Definiteness::Exact);
        let mut k_v = vec![Vec3::zeros(); n];
        body.apply_stiffness(&mut exact, &v, &mut k_v);
        for i in 0..n {
            assert!((kv[i] - k_v[i]).norm() <= 1e-9 * (1.0 + k_v[i].norm()));
        }
        for definiteness in Definiteness::ALL {
            let damping = Damping {
                velocities: &v,
                stiffness: DampingStiffness::Exact,
                shift,
                weight,
            };
            let mut lin = tetsim::Linearization::new(&body, definiteness);
            let (mut f, mut kv2) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
            body.linearize_damped_into(&x, &damping, &mut lin, &mut f, &mut kv2);
            assert_eq!(kv, kv2, "K_d·v changed with {definiteness}");
        }
        // Newton's product (exact strategy, shifted) against −d(residual) along dx.
        let damping = Damping {
            velocities: &v,
            stiffness: DampingStiffness::Exact,
            shift,
            weight,
        };
        let mut lin = tetsim::Linearization::new(&body, Definiteness::Exact);
        let (mut f, mut kv2) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
        body.linearize_damped_into(&x, &damping, &mut lin, &mut f, &mut kv2);
        let mut newton = vec![Vec3::zeros(); n];
        body.apply_stiffness(&mut lin, &dx, &mut newton);
        let (err, _) = best_relative_error(&flat_vecs(&newton), 1e-9, |eps| {
            let plus: Vec<Vec3> = x.iter().zip(&dx).map(|(p, d)| p + eps * d).collect();
            let minus: Vec<Vec3> = x.iter().zip(&dx).map(|(p, d)| p - eps * d).collect();
            let (rp, _, _) = residual(&plus, &xn);
            let (rm, _, _) = residual(&minus, &xn);
            rp.iter()
                .zip(&rm)
                .flat_map(|(a, b)| (-(a - b) / (2.0 * eps)).iter().copied().collect::<Vec<_>>())
                .collect()
        });
        errors.push(err);
    }
    // θ·|v| shrinks tenfold: a second-order error shrinks about a hundredfold. (A random
    // velocity field varies faster over quadratic tets, whose shape gradients at mid-edge nodes
    // are up to four times a corner's, so the shift θ·dF_v is larger there.)
    let first = if quadratic { 0.1 } else { 1e-2 };
    assert!(errors[0] < first, "{errors:?}");
    assert!(
        errors[1] <= 0.05 * errors[0],
        "not second order: {errors:?}"
    );
}

/// The tangent point moves by θ·dF_v while that is small against F's smallest stretch, by at
/// most `MAX_SHIFT / ‖F⁻¹‖_F` beyond, and not at all from a flat or inverted F.
#[test]
fn shifted_deformation_stays_near_f() {
    use tetsim::material::{MAX_SHIFT, shifted_deformation};
    let mut rng = rng(78);
    let (_, shift) = weight_and_shift();
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df_v = random_matrix(&mut rng);
            for scale in [1e-3, 1.0, 1e3] {
                let g = shifted_deformation(&f, &(scale * df_v), shift);
                let moved = (g - f).norm();
                if f.determinant() <= 0.0 {
                    assert_eq!(g, f, "{family:?}");
                    continue;
                }
                let bound = MAX_SHIFT / f.try_inverse().unwrap().norm();
                let wanted = shift * scale * df_v.norm();
                assert!(
                    moved <= bound * (1.0 + 1e-12) + 1e-15 * f.norm(),
                    "{moved} > {bound} at {f}"
                );
                assert!(
                    // F + θ·dF_v − F loses the digits of F's size.
                    (moved - wanted.min(bound)).abs() <= 1e-12 * wanted + 1e-15 * f.norm(),
                    "{moved} ≠ min({wanted}, {bound}) at {f}"
                );
                // Along dF_v, never against it.
                assert!((g - f).dot(&df_v) >= 0.0);
            }
        }
    }
}

#[test]
fn damping_stiffness_names_round_trip() {
    for d in DampingStiffness::ALL {
        assert_eq!(DampingStiffness::from_name(d.name()), Some(d));
        assert_eq!(d.to_string(), d.name());
    }
    assert_eq!(DampingStiffness::default(), DampingStiffness::Projected);
    assert_eq!(
        DampingStiffness::from_name("Teran"),
        Some(DampingStiffness::Projected)
    );
    assert_eq!(
        DampingStiffness::from_name("none"),
        Some(DampingStiffness::Exact)
    );
    assert_eq!(DampingStiffness::from_name("abs"), None);
    assert_eq!(
        DampingStiffness::Projected.definiteness(),
        Definiteness::Projected
    );
}
