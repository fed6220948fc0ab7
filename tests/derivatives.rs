//! Tier 1: every derivative against finite differences (Ψ → P, P → dP, E → f, f → K·dx) at
//! random, near-inverted, inverted and flat F, with a sweep of step sizes; the definiteness fix;
//! the invariants of the discrete forces; determinism across thread counts; the damped step's
//! damping force and tangent.

mod common;
#[path = "derivatives/damping.rs"]
mod damping;
#[path = "derivatives/formulas.rs"]
mod formulas;
#[path = "derivatives/quadratic.rs"]
mod quadratic;
#[path = "derivatives/strategies.rs"]
mod strategies;
#[path = "derivatives/uniaxial.rs"]
mod uniaxial;

use common::*;
use tetsim::elastic::tet_forces;
use tetsim::material::{
    Corotated, Invertible, Isotropic, MooneyRivlin, NeoHookean, StVenantKirchhoff, StableNeoHookean,
};
use tetsim::{Definiteness, ElasticBody, Lame, Mat3, Material, Model, ModelKind, TetMesh, Vec3};

/// Samples per F family and check.
const SAMPLES: usize = 25;
/// Relative error the best step of the sweep must reach.
const FD_TOLERANCE: f64 = 1e-6;

fn lame() -> Lame {
    Lame::from_young_poisson(1e6, 0.3)
}

/// Stress scale, as the floor of relative errors for values that are nearly zero.
fn stress_scale(l: Lame) -> f64 {
    l.mu + l.lambda
}

/// The 9×9 matrix of a tangent, column k = dP for the k-th unit dF (column-major vec).
fn tangent_matrix(apply: impl Fn(&Mat3) -> Mat3) -> nalgebra::SMatrix<f64, 9, 9> {
    let mut m = nalgebra::SMatrix::<f64, 9, 9>::zeros();
    for k in 0..9 {
        let mut df = Mat3::zeros();
        df[k] = 1.0;
        let dp = apply(&df);
        for r in 0..9 {
            m[(r, k)] = dp[r];
        }
    }
    m
}

fn check_psi_to_p(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df = random_matrix(&mut rng);
            let analytic = [model.stress(&f).dot(&df)];
            let (err, h) = best_relative_error(&analytic, stress_scale(lame()), |h| {
                vec![
                    (model.energy_density(&(f + h * df)) - model.energy_density(&(f - h * df)))
                        / (2.0 * h),
                ]
            });
            assert!(
                err < FD_TOLERANCE,
                "{:?} Ψ→P {family:?}: error {err:e} (best h {h:e}) at F = {f}",
                model.kind()
            );
        }
    }
}

fn check_p_to_dp(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df = random_matrix(&mut rng);
            let analytic = flat(&model.stress_differential(&f, &df));
            let (err, h) = best_relative_error(&analytic, stress_scale(lame()), |h| {
                flat(&((model.stress(&(f + h * df)) - model.stress(&(f - h * df))) / (2.0 * h)))
            });
            assert!(
                err < FD_TOLERANCE,
                "{:?} P→dP {family:?}: error {err:e} (best h {h:e}) at F = {f}",
                model.kind()
            );
        }
    }
}

fn check_tangent_consistency(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            let f = sample_f(&mut rng, family);
            let df = random_matrix(&mut rng);
            let (psi, p, tangent) = model.evaluate(&f, Definiteness::Exact);
            assert_eq!(psi, model.energy_density(&f));
            assert_eq!(p, model.stress(&f));
            assert_eq!(tangent.apply(&df), model.stress_differential(&f, &df));
            // The exact tangent is symmetric (it is a Hessian), and so is every fixed one.
            for d in Definiteness::ALL {
                let m = tangent_matrix(|x| model.tangent(&f, d).apply(x));
                // (A fully clamped tangent is zero: compare without dividing.)
                let asym = (m - m.transpose()).norm();
                assert!(
                    asym <= 1e-12 * m.norm(),
                    "{d:?} tangent not symmetric ({asym:e}) at {f}"
                );
            }
        }
    }
}

fn check_projected_psd(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    for family in FAMILIES {
        for _ in 0..SAMPLES {
            // Heavily deformed: large stretches and shears on top of the family's F.
            let f = sample_f(&mut rng, family)
                + 0.5 * random_matrix(&mut rng) * (family == Family::Random) as u8 as f64;
            for d in Definiteness::ALL.into_iter().filter(|d| d.is_psd()) {
                let m = tangent_matrix(|x| model.tangent(&f, d).apply(x));
                let eig = nalgebra::SymmetricEigen::new(0.5 * (m + m.transpose())).eigenvalues;
                let min = eig.min();
                assert!(
                    min >= -1e-9 * eig.amax(),
                    "{family:?} {d}: tangent eigenvalue {min:e} at {f}"
                );
            }
        }
    }
}

/// Near rest the exact tangent is already PSD under stretching, so the projection leaves it
/// untouched (bit for bit). Under small compression the exact Hessian has genuinely negative
/// rotational eigenvalues of size O(‖F − I‖·λ), so there the two differ by that much and agree
/// in the limit F → I.
fn check_projected_equals_exact_near_rest(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let scale = stress_scale(lame());
    for _ in 0..SAMPLES {
        let stretch = Vec3::from_fn(|_, _| uniform(&mut rng, 1.0, 1.02));
        let f = with_stretches(&mut rng, stretch);
        let exact = model.tangent(&f, Definiteness::Exact);
        assert_eq!(exact.indefinite_pieces(), 0, "indefinite near rest at {f}");
        let sizes = [1e-2, 1e-4, 1e-6];
        let near: Vec<Mat3> = sizes
            .iter()
            .map(|size| Mat3::identity() + *size * random_matrix(&mut rng))
            .collect();
        for d in Definiteness::ALL {
            let fixed = model.tangent(&f, d);
            assert_eq!(
                fixed.clamped_pieces(),
                0,
                "{d} changed the tangent near rest at {f}"
            );
            assert_eq!(exact, fixed, "{d}");
            for (size, f) in sizes.iter().zip(&near) {
                let exact = tangent_matrix(|x| model.tangent(f, Definiteness::Exact).apply(x));
                let fixed = tangent_matrix(|x| model.tangent(f, d).apply(x));
                let gap = (exact - fixed).norm();
                assert!(
                    gap <= 10.0 * size * scale,
                    "{d}: ‖exact − fixed‖ = {gap:e} at ‖F − I‖ ~ {size:e}"
                );
            }
        }
    }
}

fn check_finite_everywhere(model: &Model, seed: u64) {
    let mut rng = rng(seed);
    let r = rotation(&mut rng);
    let cases = [
        ("rank-0", Mat3::zeros()),
        ("rank-1", with_stretches(&mut rng, Vec3::new(1.3, 0.0, 0.0))),
        ("rank-2", with_stretches(&mut rng, Vec3::new(1.3, 0.7, 0.0))),
        (
            "reflected",
            r * Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0)),
        ),
        ("point-reflected", -Mat3::identity()),
        ("huge", 1e3 * r),
        ("tiny", 1e-12 * r),
    ];
    let rest = TetMesh::new(
        vec![Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()],
        vec![[0, 1, 2, 3]],
    );
    let body = ElasticBody::new(rest.clone(), *model, 1000.0).unwrap();
    for (name, f) in cases {
        let (psi, p, _) = model.evaluate(&f, Definiteness::Exact);
        for d in Definiteness::ALL {
            let dp = model.tangent(&f, d).apply(&random_matrix(&mut rng));
            assert!(
                psi.is_finite() && tetsim::math::all_finite(&p) && tetsim::math::all_finite(&dp),
                "{name} {d}: non-finite"
            );
        }
        if !restores_from(model.kind(), name) {
            continue;
        }
        // The tet deformed by F: forces are finite, non-zero, and a small step along them lowers
        // the energy (they push back toward the rest shape).
        let x: Vec<Vec3> = rest.positions.iter().map(|p| f * p).collect();
        let mut force = vec![Vec3::zeros(); 4];
        body.add_forces(&x, &mut force);
        let norm = flat_vecs(&force).iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!(norm.is_finite() && norm > 0.0, "{name}: force {norm}");
        let e0 = body.energy(&x);
        let step = 1e-4 / norm.max(1.0) * (1.0 + f.norm());
        let e1 = body.energy(&axpy(&x, step, &force));
        assert!(
            e1 < e0,
            "{name}: energy {e0} does not fall along the force ({e1})"
        );
    }
}

/// Whether a model pushes the given degenerate state back. The documented exceptions: every
/// energy of (I₁, I₂, J) alone has a zero gradient at F = 0 and a vanishing one near it (Stable
/// Neo-Hookean, St. Venant-Kirchhoff; Mooney-Rivlin escapes through its per-stretch log), and St.
/// Venant-Kirchhoff sees F only through FᵀF, so reflections are stress-free rest states for it.
fn restores_from(kind: ModelKind, case: &str) -> bool {
    match kind {
        ModelKind::StableNeoHookean => !matches!(case, "rank-0" | "tiny"),
        ModelKind::StVenantKirchhoff => {
            !matches!(case, "rank-0" | "tiny" | "reflected" | "point-reflected")
        }
        _ => true,
    }
}

/// The small body of linear tets, or of quadratic ones (`quadratic`: elevated, with its
/// mid-edge nodes moved off their edges, so the elements are curved), and states to check at:
/// a random deformation and a scramble (inverted and flat elements).
fn body_states(seed: u64, quadratic: bool) -> (ElasticBody, Vec<(&'static str, Vec<Vec3>)>) {
    let mut rng = rng(seed);
    let mut mesh = small_mesh(&mut rng);
    if quadratic {
        mesh = curved(&mut rng, &tetsim::mesh::quadratic::elevate(&mesh));
    }
    let rest = mesh.positions.clone();
    let (lo, hi) = mesh.bounding_box();
    let scrambled: Vec<Vec3> = rest
        .iter()
        .map(|_| {
            Vec3::new(
                uniform(&mut rng, lo.x, hi.x),
                uniform(&mut rng, lo.y, hi.y),
                uniform(&mut rng, lo.z, hi.z),
            )
        })
        .collect();
    let deformed = perturbed(&mut rng, &rest, 0.25);
    let body = ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap();
    (body, vec![("deformed", deformed), ("scrambled", scrambled)])
}

fn check_body_energy_to_forces(model: &Model, seed: u64, quadratic: bool) {
    let (mut body, states) = body_states(seed, quadratic);
    body.model = *model;
    let mut rng = rng(seed + 1);
    for (name, x) in states {
        let mut f = vec![Vec3::zeros(); x.len()];
        body.add_forces(&x, &mut f);
        for _ in 0..5 {
            let dx = random_field(&mut rng, x.len());
            let analytic = [-dot(&f, &dx)];
            let (err, h) = best_relative_error(&analytic, 1e-6 * stress_scale(lame()), |h| {
                vec![(body.energy(&axpy(&x, h, &dx)) - body.energy(&axpy(&x, -h, &dx))) / (2.0 * h)]
            });
            assert!(err < FD_TOLERANCE, "{name}: E→f error {err:e} (h {h:e})");
        }
    }
}

fn check_body_forces_to_stiffness(model: &Model, seed: u64, quadratic: bool) {
    let (mut body, states) = body_states(seed, quadratic);
    body.model = *model;
    let mut rng = rng(seed + 2);
    for (name, x) in states {
        let mut lin = body.linearize(&x, Definiteness::Exact);
        let forces_at = |x: &[Vec3]| {
            let mut f = vec![Vec3::zeros(); x.len()];
            body.add_forces(x, &mut f);
            f
        };
        for _ in 0..5 {
            let dx = random_field(&mut rng, x.len());
            let mut kdx = vec![Vec3::zeros(); x.len()];
            body.apply_stiffness(&mut lin, &dx, &mut kdx);
            let analytic = flat_vecs(&kdx);
            let (err, h) = best_relative_error(&analytic, 1e-6 * stress_scale(lame()), |h| {
                let fp = forces_at(&axpy(&x, h, &dx));
                let fm = forces_at(&axpy(&x, -h, &dx));
                // K·dx = −df
                fp.iter()
                    .zip(&fm)
                    .flat_map(|(a, b)| ((b - a) / (2.0 * h)).iter().copied().collect::<Vec<_>>())
                    .collect()
            });
            assert!(err < FD_TOLERANCE, "{name}: f→K·dx error {err:e} (h {h:e})");
        }
    }
}

/// Dense K of a body (3n × 3n) by applying the stiffness product to unit vectors.
fn dense_stiffness(body: &ElasticBody, x: &[Vec3], d: Definiteness) -> nalgebra::DMatrix<f64> {
    let n = x.len();
    let mut lin = body.linearize(x, d);
    let mut k = nalgebra::DMatrix::zeros(3 * n, 3 * n);
    let mut e = vec![Vec3::zeros(); n];
    let mut out = vec![Vec3::zeros(); n];
    for col in 0..3 * n {
        e.iter_mut().for_each(|v| *v = Vec3::zeros());
        e[col / 3][col % 3] = 1.0;
        body.apply_stiffness(&mut lin, &e, &mut out);
        for (r, v) in flat_vecs(&out).into_iter().enumerate() {
            k[(r, col)] = v;
        }
    }
    k
}

fn check_stiffness_symmetric_and_projected_psd(model: &Model, seed: u64, quadratic: bool) {
    let (mut body, states) = body_states(seed, quadratic);
    body.model = *model;
    let mut rng = rng(seed + 3);
    for (name, x) in states {
        for d in [Definiteness::Exact, Definiteness::Projected] {
            let mut lin = body.linearize(&x, d);
            for _ in 0..5 {
                let p = random_field(&mut rng, x.len());
                let q = random_field(&mut rng, x.len());
                let mut kp = vec![Vec3::zeros(); x.len()];
                let mut kq = vec![Vec3::zeros(); x.len()];
                body.apply_stiffness(&mut lin, &p, &mut kp);
                body.apply_stiffness(&mut lin, &q, &mut kq);
                let (a, b) = (dot(&q, &kp), dot(&p, &kq));
                assert!(
                    (a - b).abs() <= 1e-10 * (a.abs() + b.abs() + 1.0),
                    "{name} {d:?}: q·Kp {a} ≠ p·Kq {b}"
                );
            }
        }
        for d in Definiteness::ALL.into_iter().filter(|d| d.is_psd()) {
            let k = dense_stiffness(&body, &x, d);
            let eig = nalgebra::SymmetricEigen::new(0.5 * (&k + k.transpose())).eigenvalues;
            assert!(
                eig.min() >= -1e-9 * eig.amax(),
                "{name} {d}: K has eigenvalue {:e}",
                eig.min()
            );
        }
    }
}

/// One module of derivative tests per model, stamped from a list that must name every
/// [`ModelKind`]: the list also expands to an exhaustive `match` (so a new variant does not compile
/// until it has a line here) and to a test that the list is exactly [`ModelKind::ALL`].
macro_rules! material_tests {
    ($($name:ident: $kind:ident, $seed:expr;)+) => {
        /// The derivative-test module of each model; exhaustive on purpose (no `_` arm).
        fn derivative_tests_of(kind: ModelKind) -> &'static str {
            match kind {
                $(ModelKind::$kind => stringify!($name),)+
            }
        }

        #[test]
        fn every_model_has_derivative_tests() {
            // The list names every variant (the match above), so these make ALL the same set.
            let listed = [$(ModelKind::$kind),+];
            for kind in listed {
                assert!(ModelKind::ALL.contains(&kind), "ModelKind::ALL misses {kind}");
            }
            for kind in ModelKind::ALL {
                assert!(listed.contains(&kind), "{kind} has no derivative tests");
                assert!(!derivative_tests_of(kind).is_empty());
            }
        }

        $(
            mod $name {
                use super::*;
                fn model() -> Model {
                    Model::new(ModelKind::$kind, lame())
                }
                #[test]
                fn energy_to_stress_matches_finite_differences() {
                    check_psi_to_p(&model(), $seed);
                }
                #[test]
                fn stress_to_differential_matches_finite_differences() {
                    check_p_to_dp(&model(), $seed + 10);
                }
                #[test]
                fn tangent_is_consistent_and_symmetric() {
                    check_tangent_consistency(&model(), $seed + 20);
                }
                #[test]
                fn projected_tangent_is_psd() {
                    check_projected_psd(&model(), $seed + 30);
                }
                #[test]
                fn projected_equals_exact_near_rest() {
                    check_projected_equals_exact_near_rest(&model(), $seed + 40);
                }
                #[test]
                fn finite_and_restoring_for_every_f() {
                    check_finite_everywhere(&model(), $seed + 50);
                }
                #[test]
                fn equals_analytic_model_above_threshold() {
                    formulas::check_matches_analytic(&model(), $seed + 60);
                }
                #[test]
                fn body_energy_to_forces_matches_finite_differences() {
                    check_body_energy_to_forces(&model(), $seed + 70, false);
                }
                #[test]
                fn quadratic_body_energy_to_forces_matches_finite_differences() {
                    check_body_energy_to_forces(&model(), $seed + 75, true);
                }
                #[test]
                fn body_forces_to_stiffness_matches_finite_differences() {
                    check_body_forces_to_stiffness(&model(), $seed + 80, false);
                }
                #[test]
                fn quadratic_body_forces_to_stiffness_matches_finite_differences() {
                    check_body_forces_to_stiffness(&model(), $seed + 85, true);
                }
                #[test]
                fn stiffness_symmetric_and_projected_psd() {
                    check_stiffness_symmetric_and_projected_psd(&model(), $seed + 90, false);
                }
                #[test]
                fn quadratic_stiffness_symmetric_and_projected_psd() {
                    check_stiffness_symmetric_and_projected_psd(&model(), $seed + 95, true);
                }
                #[test]
                fn uniaxial_stress_matches_analytic() {
                    uniaxial::check_uniaxial(&model());
                }
                #[test]
                fn definiteness_strategies_agree_where_they_must() {
                    strategies::check_strategies(&model(), $seed + 100);
                }
                #[test]
                fn damped_tangent_is_consistent_to_second_order() {
                    damping::check_shifted_tangent(&model(), $seed + 110);
                }
                #[test]
                fn damping_force_is_the_same_for_every_strategy() {
                    damping::check_damping_is_strategy_free(&model(), $seed + 120);
                }
            }
        )+
    };
}

material_tests! {
    neo_hookean: NeoHookean, 100;
    neo_hookean_clamped: NeoHookeanClamped, 700;
    corotated: Corotated, 200;
    stable_neo_hookean: StableNeoHookean, 300;
    st_venant_kirchhoff: StVenantKirchhoff, 400;
    mooney_rivlin: MooneyRivlin, 500;
    linear: Linear, 600;
}

/// The forms tangled elements are evaluated with (the levelled log and the clamp at the recovery
/// threshold, see `tetsim::elastic::recovery`): the same checks as every model.
#[test]
fn recovery_forms_match_finite_differences() {
    let mut seed = 800;
    for kind in [ModelKind::NeoHookean, ModelKind::MooneyRivlin] {
        let forms = Model::new(kind, lame())
            .recovery(tetsim::material::DEFAULT_RECOVERY_THRESHOLD)
            .expect("a recovery form");
        for model in [forms.collapsed, forms.overlapping] {
            check_psi_to_p(&model, seed);
            check_p_to_dp(&model, seed + 1);
            check_tangent_consistency(&model, seed + 2);
            check_projected_psd(&model, seed + 3);
            check_projected_equals_exact_near_rest(&model, seed + 4);
            check_finite_everywhere(&model, seed + 5);
            check_body_energy_to_forces(&model, seed + 6, false);
            check_body_forces_to_stiffness(&model, seed + 7, false);
            seed += 10;
        }
    }
}

/// SPEC §3: below the inversion threshold a crushed stretch meets a resistance that keeps
/// growing (∂p₃/∂σ₃ > 0 all the way into inversion), whatever the other stretches; never the
/// softening that lets a load of the order of E crush a body flat.
#[test]
fn crushed_stretches_resist_more_and_more() {
    let e = lame().youngs_modulus();
    for kind in [
        ModelKind::NeoHookean,
        ModelKind::NeoHookeanClamped,
        ModelKind::MooneyRivlin,
    ] {
        let model = Model::new(kind, lame());
        let threshold = model.inversion_threshold().unwrap();
        assert_eq!(threshold, tetsim::material::DEFAULT_INVERSION_THRESHOLD);
        for lateral in [0.5, 1.0, 1.05, 1.5, 2.0] {
            let stress = |s3: f64| {
                model.stress(&Mat3::from_diagonal(&Vec3::new(lateral, lateral, s3)))[(2, 2)]
            };
            // Down to −0.9 of the lateral stretches: deeper, the rotation-variant SVD carries the
            // inversion on a lateral axis instead (Irving et al. 2004's σ₃ = −σ₂ kink).
            let mut last = stress(2.0 * threshold);
            for k in 1.. {
                let s3 = 2.0 * threshold - k as f64 * 0.01;
                if s3 < -0.9 * lateral {
                    break;
                }
                let p = stress(s3);
                assert!(
                    p < last,
                    "{kind:?}, lateral {lateral}: P₃₃ {p:e} at σ₃ = {s3:.2} is not below {last:e}"
                );
                last = p;
            }
            // At σ₃ = 0 the push is many times E (a tet is crushed flat only by loads ≫ E).
            assert!(stress(0.0) < -10.0 * e, "{kind:?}: {:e}", stress(0.0));
        }
    }
}

/// The element kernel: tet energy W Ψ(Ds Bm) → tet_forces, on a single tet.
#[test]
fn tet_forces_match_energy_gradient() {
    let mut rng = rng(7);
    let rest = vec![
        Vec3::zeros(),
        Vec3::new(1.0, 0.1, 0.0),
        Vec3::new(0.2, 0.9, 0.1),
        Vec3::new(0.1, 0.2, 1.1),
    ];
    let dm = TetMesh::edge_matrix(&rest, &[0, 1, 2, 3]);
    let (bm, w) = (dm.try_inverse().unwrap(), dm.determinant().abs() / 6.0);
    let model = Model::new(ModelKind::NeoHookean, lame());
    for family in FAMILIES {
        let f = sample_f(&mut rng, family);
        let x: Vec<Vec3> = rest.iter().map(|p| f * p).collect();
        let energy =
            |x: &[Vec3]| w * model.energy_density(&(TetMesh::edge_matrix(x, &[0, 1, 2, 3]) * bm));
        let forces = tet_forces(&model.stress(&f), &bm, w);
        let dx = random_field(&mut rng, 4);
        let analytic = [-dot(&forces, &dx)];
        let (err, _) = best_relative_error(&analytic, 1e-6 * stress_scale(lame()), |h| {
            vec![(energy(&axpy(&x, h, &dx)) - energy(&axpy(&x, -h, &dx))) / (2.0 * h)]
        });
        assert!(err < FD_TOLERANCE, "{family:?}: {err:e}");
    }
}

/// Every model written in principal stretches, with the default parameters.
fn isotropic_models() -> Vec<Box<dyn Isotropic>> {
    vec![
        Box::new(NeoHookean::new(lame())),
        Box::new(NeoHookean::clamped(lame())),
        Box::new(Corotated::new(lame())),
        Box::new(StableNeoHookean::new(lame())),
        Box::new(StVenantKirchhoff::new(lame())),
        Box::new(MooneyRivlin::new(lame())),
        Box::new(MooneyRivlin::clamped(lame())),
        Box::new(NeoHookean::recovery(lame(), 0.6)),
        Box::new(MooneyRivlin::recovery(lame(), 0.6)),
        Box::new(tetsim::material::LevelledNeoHookean::new(lame(), 0.6)),
    ]
}

/// Models in principal stretches: ∂Ψ̂/∂σ and ∂²Ψ̂/∂σ² against differences of Ψ̂, including
/// stretches below the inversion threshold and negative ones.
#[test]
fn principal_stretch_derivatives_match_finite_differences() {
    let mut rng = rng(8);
    for model in isotropic_models() {
        for _ in 0..200 {
            let s = Vec3::new(
                uniform(&mut rng, 0.0, 2.0),
                uniform(&mut rng, 0.0, 2.0),
                uniform(&mut rng, -1.0, 2.0),
            );
            let d = random_field(&mut rng, 1)[0];
            let (err, _) =
                best_relative_error(&[model.dpsi(&s).dot(&d)], stress_scale(lame()), |h| {
                    vec![(model.psi(&(s + h * d)) - model.psi(&(s - h * d))) / (2.0 * h)]
                });
            assert!(err < FD_TOLERANCE, "∂Ψ̂/∂σ at {s}: {err:e}");
            let (err, _) = best_relative_error(
                &(model.d2psi(&s) * d).iter().copied().collect::<Vec<_>>(),
                stress_scale(lame()),
                |h| {
                    ((model.dpsi(&(s + h * d)) - model.dpsi(&(s - h * d))) / (2.0 * h))
                        .iter()
                        .copied()
                        .collect()
                },
            );
            assert!(err < FD_TOLERANCE, "∂²Ψ̂/∂σ² at {s}: {err:e}");
        }
    }
}

/// `Isotropic::derivatives` (what the element loop calls) returns exactly what the separate
/// methods return, also where a model shares work between them.
#[test]
fn all_at_once_derivatives_equal_the_separate_ones() {
    let mut rng = rng(9);
    for model in isotropic_models() {
        for _ in 0..100 {
            let s = Vec3::new(
                uniform(&mut rng, 0.0, 2.0),
                uniform(&mut rng, 0.0, 2.0),
                uniform(&mut rng, -1.0, 2.0),
            );
            let d = model.derivatives(&s);
            let (p, h) = (model.dpsi(&s), model.d2psi(&s));
            assert_eq!((d.psi, d.p, d.h), (model.psi(&s), p, h));
            for (k, &(i, j)) in tetsim::material::isotropic::PAIRS.iter().enumerate() {
                let pair = model.pair_eigenvalues(&s, &p, &h, i, j);
                assert_eq!((d.pair_sym[k], d.pair_skew[k]), pair);
            }
        }
    }
}

/// SPEC §9, never NaN: every model and strategy stays finite on wild F (entries spanning 15
/// orders of magnitude, random signs, rank-deficient and exactly repeated stretches).
#[test]
fn every_model_and_strategy_is_finite_on_wild_f() {
    let mut rng = rng(10);
    for kind in ModelKind::ALL {
        let model = Model::new(kind, lame());
        for n in 0..400 {
            let size = 10f64.powf(uniform(&mut rng, -12.0, 3.0));
            let f = match n % 4 {
                0 => size * random_matrix(&mut rng),
                1 => {
                    size * Vec3::from_fn(|_, _| uniform(&mut rng, -1.0, 1.0))
                        * Vec3::from_fn(|_, _| uniform(&mut rng, -1.0, 1.0)).transpose()
                }
                2 => with_stretches(&mut rng, Vec3::new(size, size, -size)),
                _ => with_stretches(&mut rng, Vec3::new(1.0, size, 0.0)),
            };
            for d in Definiteness::ALL {
                let (psi, p, t) = model.evaluate(&f, d);
                let dp = t.apply(&random_matrix(&mut rng));
                assert!(
                    psi.is_finite()
                        && tetsim::math::all_finite(&p)
                        && tetsim::math::all_finite(&dp),
                    "{kind:?} {d}: non-finite at {f}"
                );
            }
        }
    }
}

/// The closed-form pair eigenvalues stay accurate when two stretches (nearly) coincide, where
/// the plain quotient (pᵢ − pⱼ)/(σᵢ − σⱼ) cancels catastrophically.
#[test]
fn pair_eigenvalues_accurate_at_repeated_stretches() {
    let scale = stress_scale(lame());
    for model in isotropic_models() {
        for base in [1.3, 0.25, 0.3, 0.2995] {
            // At a visible gap the closed forms equal the plain quotients.
            let s = Vec3::new(base + 1e-3, base, 0.9);
            let p = model.dpsi(&s);
            let (sym, skew) = model.pair_eigenvalues(&s, &p, &model.d2psi(&s), 0, 1);
            let quotient = (p[0] - p[1]) / (s[0] - s[1]);
            assert!(
                (sym - quotient).abs() <= 1e-8 * scale,
                "base {base}: {sym} vs quotient {quotient}"
            );
            let quotient = (p[0] + p[1]) / (s[0] + s[1]);
            assert!(
                (skew - quotient).abs() <= 1e-10 * scale,
                "base {base}: {skew} vs quotient {quotient}"
            );
            // At tiny or zero gaps it tends to the limit Hᵢᵢ − Hᵢⱼ, where the quotient is noise.
            for gap in [1e-9, 1e-12, 0.0] {
                let s = Vec3::new(base + gap, base, 0.9);
                let h = model.d2psi(&s);
                let (sym, _) = model.pair_eigenvalues(&s, &model.dpsi(&s), &h, 0, 1);
                let limit = h[(1, 1)] - h[(0, 1)];
                assert!(
                    (sym - limit).abs() <= 1e-6 * scale,
                    "base {base} gap {gap}: {sym} vs {limit}"
                );
            }
        }
    }
    // The generic default does no worse than the limit at exact repeats.
    let s = Vec3::new(1.1, 1.1, 1.1);
    let co = Corotated::new(lame());
    let (sym, _) = tetsim::material::isotropic::default_pair_eigenvalues(
        &s,
        &co.dpsi(&s),
        &co.d2psi(&s),
        0,
        1,
    );
    assert!((sym - 2.0 * lame().mu).abs() < 1e-9 * lame().mu);
}

fn mesh_and_rest(seed: u64) -> (ElasticBody, Vec<Vec3>) {
    let mut rng = rng(seed);
    let mesh = small_mesh(&mut rng);
    let rest = mesh.positions.clone();
    (
        ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap(),
        rest,
    )
}

#[test]
fn rest_state_has_zero_energy_and_force() {
    for kind in ModelKind::ALL {
        let (mut body, rest) = mesh_and_rest(11);
        body.model = Model::new(kind, lame());
        let mut f = vec![Vec3::zeros(); rest.len()];
        body.add_forces(&rest, &mut f);
        let scale = stress_scale(lame());
        assert!(body.energy(&rest).abs() < 1e-12 * scale);
        assert!(f.iter().all(|v| v.norm() < 1e-9 * scale), "{kind:?}");
    }
}

#[test]
fn rigid_motions_cost_no_energy_and_give_no_force() {
    let mut rng = rng(12);
    for kind in ModelKind::ALL
        .into_iter()
        .filter(|k| k.is_rotation_invariant())
    {
        let (mut body, rest) = mesh_and_rest(12);
        body.model = Model::new(kind, lame());
        for _ in 0..10 {
            let r = rotation(&mut rng);
            let t = 10.0 * random_field(&mut rng, 1)[0];
            let x: Vec<Vec3> = rest.iter().map(|p| r * p + t).collect();
            let mut f = vec![Vec3::zeros(); x.len()];
            body.add_forces(&x, &mut f);
            let scale = stress_scale(lame());
            assert!(
                body.energy(&x).abs() < 1e-11 * scale,
                "{kind:?}: E = {}",
                body.energy(&x)
            );
            assert!(
                f.iter().all(|v| v.norm() < 1e-8 * scale),
                "{kind:?}: rigid motion gives force"
            );
        }
    }
}

/// Linear elasticity is the one model that is not rotation invariant: a rigid rotation by θ
/// costs energy that grows like θ⁴ for small θ (the small strain of a rotation is
/// `cos θ − 1 ≈ −θ²/2` in the plane of rotation), while translations stay free.
#[test]
fn linear_elasticity_charges_rotations_not_translations() {
    let model = Model::new(ModelKind::Linear, lame());
    let translated = Mat3::identity();
    assert_eq!(model.energy_density(&translated), 0.0);
    let rotated =
        |theta: f64| nalgebra::Rotation3::from_axis_angle(&Vec3::z_axis(), theta).into_inner();
    let (e1, e2) = (
        model.energy_density(&rotated(0.1)),
        model.energy_density(&rotated(0.2)),
    );
    assert!(e1 > 0.0 && (e2 / e1 - 16.0).abs() < 0.2, "{e1} {e2}");
}

#[test]
fn forces_sum_to_zero_with_zero_torque() {
    let mut rng = rng(13);
    for kind in ModelKind::ALL {
        let (mut body, rest) = mesh_and_rest(13);
        body.model = Model::new(kind, lame());
        for amount in [0.1, 0.4, 1.0] {
            let x = perturbed(&mut rng, &rest, amount);
            let mut f = vec![Vec3::zeros(); x.len()];
            body.add_forces(&x, &mut f);
            let total: Vec3 = f.iter().sum();
            let torque: Vec3 = x.iter().zip(&f).map(|(p, q)| p.cross(q)).sum();
            let scale: f64 = f.iter().map(|v| v.norm()).sum::<f64>()
                * (1.0 + x.iter().map(|p| p.norm()).fold(0.0, f64::max));
            assert!(total.norm() < 1e-12 * scale, "{kind:?} net force {total}");
            // Zero torque needs P·Fᵀ symmetric, i.e. rotation invariance.
            assert!(
                torque.norm() < 1e-12 * scale || !kind.is_rotation_invariant(),
                "{kind:?} net torque {torque}"
            );
        }
    }
}

#[test]
fn affine_deformation_gives_constant_f() {
    let mut rng = rng(14);
    let (body, rest) = mesh_and_rest(14);
    let a = Mat3::identity() + 0.3 * random_matrix(&mut rng);
    let b = random_field(&mut rng, 1)[0];
    let x: Vec<Vec3> = rest.iter().map(|p| a * p + b).collect();
    for t in 0..body.tet_count() {
        assert!(
            (body.deformation_gradient(&x, t) - a).norm() < 1e-12,
            "tet {t}"
        );
    }
}

/// The convention `F = Ds·Bm`, column-major vec(F), forces as columns of H, pinned on one tet:
/// stretching x by 10 % along x pulls vertex 1 (at X = e₁) back in −x.
#[test]
fn convention_is_pinned_on_one_tet() {
    let rest = TetMesh::new(
        vec![Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()],
        vec![[0, 1, 2, 3]],
    );
    let body = ElasticBody::new(rest, Model::new(ModelKind::Corotated, lame()), 1000.0).unwrap();
    let x = vec![Vec3::zeros(), 1.1 * Vec3::x(), Vec3::y(), Vec3::z()];
    assert!(
        (body.deformation_gradient(&x, 0) - Mat3::from_diagonal(&Vec3::new(1.1, 1.0, 1.0))).norm()
            < 1e-15
    );
    let mut f = vec![Vec3::zeros(); 4];
    body.add_forces(&x, &mut f);
    assert!(f[1].x < 0.0 && f[0].x > 0.0);
    assert_eq!(body.masses().iter().sum::<f64>(), 1000.0 / 6.0);
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let mut rng = rng(15);
    let mesh =
        tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [16, 4, 4]);
    let x = perturbed(&mut rng, &mesh.positions, 0.05);
    let dx = random_field(&mut rng, x.len());
    let body = ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut lin = tetsim::Linearization::new(&body, Definiteness::Projected);
            let mut f = vec![Vec3::zeros(); x.len()];
            let e = body.linearize_into(&x, &mut lin, &mut f);
            let mut kdx = vec![Vec3::zeros(); x.len()];
            body.apply_stiffness(&mut lin, &dx, &mut kdx);
            let mut g = vec![Vec3::zeros(); x.len()];
            body.add_forces(&x, &mut g);
            (e.to_bits(), body.energy(&x).to_bits(), f, g, kdx)
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn degenerate_tets_are_all_listed() {
    let mut mesh =
        tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [1, 1, 1]);
    // Collapse vertex 7 onto vertex 0: every tet has the diagonal 0–7, so all six degenerate.
    mesh.positions[7] = mesh.positions[0];
    let err =
        ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap_err();
    match &err {
        tetsim::Error::Mesh {
            problem: tetsim::MeshProblem::Degenerate { tets },
            ..
        } => assert_eq!(tets, &vec![0, 1, 2, 3, 4, 5]),
        other => panic!("unexpected {other}"),
    }
    assert!(err.to_string().contains("0, 1, 2, 3, 4, 5"));
}

#[test]
fn invertible_adaptor_is_generic() {
    // A model is usable through the adaptor on its own, outside the Model enum.
    let m = Invertible::new(Corotated::new(lame()));
    assert_eq!(m.energy_density(&Mat3::identity()), 0.0);
}

/// The assembled system matrix applies exactly what the matrix-free product does.
#[test]
fn assembled_stiffness_matches_matrix_free_product() {
    let mut rng = rng(16);
    let mesh = tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [4, 2, 2]);
    let x = perturbed(&mut rng, &mesh.positions, 0.3);
    let body = ElasticBody::new(mesh, Model::new(ModelKind::NeoHookean, lame()), 1000.0).unwrap();
    let mut a = tetsim::linear::sparse::BlockCsr::zeros(body.stiffness_pattern());
    let mut work = tetsim::elastic::AssemblyWork::default();
    for d in [Definiteness::Exact, Definiteness::Projected] {
        let mut lin = body.linearize(&x, d);
        let (k_scale, m_scale) = (1.3, 900.0);
        body.assemble_system(&lin, k_scale, m_scale, &mut a, &mut work);
        let p = random_field(&mut rng, x.len());
        let mut kp = vec![Vec3::zeros(); x.len()];
        body.apply_stiffness(&mut lin, &p, &mut kp);
        let expected: Vec<Vec3> = kp
            .iter()
            .zip(&p)
            .zip(body.masses())
            .map(|((k, p), &m)| k_scale * k + m_scale * m * p)
            .collect();
        let mut got = vec![Vec3::zeros(); x.len()];
        a.multiply(&p, &mut got);
        for (g, e) in got.iter().zip(&expected) {
            assert!(
                (g - e).norm() <= 1e-10 * (1.0 + e.norm()),
                "{d:?}: {g} vs {e}"
            );
        }
        // Symmetric blocks: A(i, j) = A(j, i)ᵀ.
        for i in 0..a.rows() {
            for k in a.pattern.row(i) {
                let j = a.pattern.cols[k] as usize;
                let kt = a.pattern.find(j, i).unwrap();
                assert!(
                    (a.block(k) - a.block(kt).transpose()).norm()
                        <= 1e-9 * a.block(k).norm().max(1.0)
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The library self-check (`tetsim check`): passes on every model, fails loudly on wrong ones.

use tetsim::check::{CheckParams, Discretization, check_body, check_material, check_simulation};

#[test]
fn self_check_passes_on_every_model() {
    let mut rng = rng(40);
    let mesh = small_mesh(&mut rng);
    let start = perturbed(&mut rng, &mesh.positions, 0.2);
    for kind in ModelKind::ALL {
        let body = ElasticBody::new(mesh.clone(), Model::new(kind, lame()), 1000.0).unwrap();
        let report = check_simulation(&body, &start, &CheckParams::default());
        assert!(report.passed(), "{kind:?}:\n{report}");
        assert!(report.rows.len() >= 15, "{report}");
    }
}

/// A test-only material whose stress is 1 % too large: P no longer derives from Ψ.
struct StressOnePercentHigh(Model);

impl Material for StressOnePercentHigh {
    fn energy_density(&self, f: &Mat3) -> f64 {
        self.0.energy_density(f)
    }
    fn stress(&self, f: &Mat3) -> Mat3 {
        1.01 * self.0.stress(f)
    }
    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3 {
        1.01 * self.0.stress_differential(f, df)
    }
    fn tangent(&self, f: &Mat3, d: Definiteness) -> tetsim::material::Tangent {
        self.0.tangent(f, d)
    }
}

/// A test-only material whose differential misses a term (the exact one of another model).
struct WrongDifferential(Model, Model);

impl Material for WrongDifferential {
    fn energy_density(&self, f: &Mat3) -> f64 {
        self.0.energy_density(f)
    }
    fn stress(&self, f: &Mat3) -> Mat3 {
        self.0.stress(f)
    }
    fn stress_differential(&self, f: &Mat3, df: &Mat3) -> Mat3 {
        self.1.stress_differential(f, df)
    }
    fn tangent(&self, f: &Mat3, d: Definiteness) -> tetsim::material::Tangent {
        self.1.tangent(f, d)
    }
}

#[test]
fn self_check_fails_loudly_on_a_wrong_material() {
    let model = Model::new(ModelKind::NeoHookean, lame());
    let params = CheckParams::default();
    let report = tetsim::check::CheckReport {
        rows: check_material(&StressOnePercentHigh(model), &params),
    };
    assert!(!report.passed());
    let psi_rows: Vec<_> = report.rows.iter().filter(|r| r.check == "Ψ → P").collect();
    assert!(
        psi_rows
            .iter()
            .all(|r| !r.passed() && r.relative_error > 1e-3),
        "{report}"
    );
    let text = report.to_string();
    assert!(text.contains("FAIL") && text.contains("Ψ → P"), "{text}");

    let other = Model::new(ModelKind::Corotated, lame());
    let rows = check_material(&WrongDifferential(model, other), &params);
    assert!(
        rows.iter()
            .filter(|r| r.check == "P → dP")
            .all(|r| !r.passed() && r.relative_error > 1e-3),
        "{rows:?}"
    );
}

/// A test-only body whose forces are 1 % too large.
struct ForcesOnePercentHigh(ElasticBody);

impl Discretization for ForcesOnePercentHigh {
    fn vertex_count(&self) -> usize {
        self.0.vertex_count()
    }
    fn length_scale(&self) -> f64 {
        Discretization::length_scale(&self.0)
    }
    fn force_scale(&self) -> f64 {
        Discretization::force_scale(&self.0)
    }
    fn energy(&self, x: &[Vec3]) -> f64 {
        self.0.energy(x)
    }
    fn forces(&self, x: &[Vec3], out: &mut [Vec3]) {
        Discretization::forces(&self.0, x, out);
        out.iter_mut().for_each(|f| *f *= 1.01);
    }
    fn stiffness_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]) {
        self.0.stiffness_product(x, u, d, out)
    }
    fn assembled_product(&self, x: &[Vec3], u: &[Vec3], d: Definiteness, out: &mut [Vec3]) {
        self.0.assembled_product(x, u, d, out)
    }
}

#[test]
fn self_check_fails_loudly_on_wrong_forces() {
    let mut rng = rng(41);
    let mesh = small_mesh(&mut rng);
    let x = perturbed(&mut rng, &mesh.positions, 0.2);
    let body = ElasticBody::new(mesh, Model::new(ModelKind::Corotated, lame()), 1000.0).unwrap();
    let rows = check_body(
        &ForcesOnePercentHigh(body),
        &[("deformed".to_string(), x)],
        &CheckParams::default(),
    );
    let by_name = |name: &str| rows.iter().find(|r| r.check == name).unwrap();
    assert!(!by_name("E → f").passed(), "{rows:?}");
    assert!(!by_name("f → K·u").passed(), "{rows:?}");
    assert!(by_name("K·u vs assembled K").passed(), "{rows:?}");
}
