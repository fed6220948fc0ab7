//! The contact term against finite differences, for every obstacle shape.

use super::body_tests::elastic;
use super::*;
use crate::boundary::Motion;
use crate::contact::ObstacleSpec;
use crate::contact::obstacle::Obstacle;
use crate::integrator::{SolverParams, StepKind};
use crate::mesh::generate::box_mesh;

/// Energy → force and force → Hessian of the contact term against each obstacle shape, by
/// central differences, at a state where a block sits inside d̂ of the obstacle.
#[test]
fn contact_term_derivatives_match_finite_differences_for_every_shape() {
    let mesh = box_mesh(
        Vec3::new(0.0, 1e-4, 0.0),
        Vec3::new(0.2, 0.2001, 0.2),
        [2, 2, 2],
    );
    let n = mesh.positions.len();
    let masses = vec![1.0; n];
    let shapes = [
        Shape::Plane {
            point: Vec3::zeros(),
            normal: Vec3::y(),
        },
        Shape::Box {
            min: Vec3::new(-0.05, -0.1, -0.05),
            max: Vec3::new(0.25, 0.0, 0.25),
        },
        Shape::Box {
            min: Vec3::new(0.03, -0.1, 0.04),
            max: Vec3::new(0.15, 0.0, 0.13),
        },
        Shape::Sphere {
            center: Vec3::new(0.1, -0.5, 0.1),
            radius: 0.4999,
        },
    ];
    for shape in shapes {
        let setup = ContactSetup {
            obstacles: vec![ObstacleSpec {
                name: "o".into(),
                obstacle: Obstacle::new(shape.clone(), Motion::default()).unwrap(),
                friction: None,
                duration: None,
            }],
            ..Default::default()
        };
        let mut term = ContactTerm::new(setup, &mesh, &masses);
        term.kappa = 1.0;
        // A small jitter so that no pair sits at a classification boundary.
        let x: Vec<Vec3> = mesh
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                p + Vec3::new(
                    1e-3 * (i as f64).sin(),
                    2e-5 * (i as f64).cos().abs(),
                    1e-3 * (i as f64 * 0.7).cos(),
                )
            })
            .collect();
        let params = SolverParams::default();
        let body = elastic(&mesh);
        let zeros = vec![Vec3::zeros(); n];
        let ctx = StepContext {
            body: &body,
            kind: StepKind::Static,
            f_ext: &zeros,
            free: &zeros,
            params: &params,
        };
        let mut partials = vec![0.0; 8];
        let mut eval = |term: &mut ContactTerm, y: &[Vec3]| {
            let mut f = vec![Vec3::zeros(); n];
            let e = term.evaluate(&ctx, y, &zeros, &mut f, &mut partials);
            (e, f)
        };
        let (_, f) = eval(&mut term, &x);
        assert!(term.active_pairs() > 0, "{shape:?}: no pairs");
        let u: Vec<Vec3> = (0..n)
            .map(|i| {
                Vec3::new(
                    (i as f64 * 1.3).sin(),
                    (i as f64 * 0.9).cos(),
                    (i as f64 * 2.1).sin(),
                )
            })
            .collect();
        let slope: f64 = -f.iter().zip(&u).map(|(f, u)| f.dot(u)).sum::<f64>();
        let mut hu = vec![Vec3::zeros(); n];
        term.use_exact(true);
        term.add_hessian_product(&ctx, &u, &mut hu);
        let mut best_e = f64::INFINITY;
        let mut best_h = f64::INFINITY;
        for k in 4..12 {
            let t = 10f64.powi(-k);
            let plus: Vec<Vec3> = x.iter().zip(&u).map(|(x, u)| x + t * u).collect();
            let minus: Vec<Vec3> = x.iter().zip(&u).map(|(x, u)| x - t * u).collect();
            let (ep, fp) = eval(&mut term, &plus);
            let (em, fm) = eval(&mut term, &minus);
            let fd = (ep - em) / (2.0 * t);
            best_e = best_e.min((fd - slope).abs() / slope.abs().max(1e-30));
            let err: f64 = (0..n)
                .map(|i| ((fm[i] - fp[i]) / (2.0 * t) - hu[i]).norm_squared())
                .sum::<f64>()
                .sqrt();
            let norm: f64 = hu.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt();
            best_h = best_h.min(err / norm.max(1e-30));
        }
        assert!(best_e < 1e-5, "{shape:?}: energy → force error {best_e:e}");
        assert!(best_h < 1e-4, "{shape:?}: force → Hessian error {best_h:e}");
    }
}

/// IPC's balanced κ: a block inside d̂ of the ground under a downward load gets the κ whose
/// barrier forces best balance the load (the least-squares κ, computed here directly), once a
/// step and never lowered; a block beyond d̂ keeps κ.
#[test]
fn barrier_stiffness_is_balanced_against_the_load_once_a_step() {
    let mesh = box_mesh(
        Vec3::new(0.0, 2e-4, 0.0),
        Vec3::new(0.2, 0.2002, 0.2),
        [2, 2, 2],
    );
    let n = mesh.positions.len();
    let setup = ContactSetup {
        obstacles: vec![ObstacleSpec {
            name: "ground".into(),
            obstacle: Obstacle::new(
                Shape::Plane {
                    point: Vec3::zeros(),
                    normal: Vec3::y(),
                },
                Motion::default(),
            )
            .unwrap(),
            friction: None,
            duration: None,
        }],
        params: crate::contact::ContactParams {
            distance: Some(1e-3),
            friction: 0.0,
            self_contact: false,
        },
        ..Default::default()
    };
    let body = elastic(&mesh);
    let params = SolverParams::default();
    let zeros = vec![Vec3::zeros(); n];
    let free = vec![Vec3::repeat(1.0); n];
    let ctx = StepContext {
        body: &body,
        kind: StepKind::Static,
        f_ext: &zeros,
        free: &free,
        params: &params,
    };
    let x = &mesh.positions;
    let mut term = ContactTerm::new(setup, &mesh, &vec![1.0; n]);
    term.begin_step(x, 1.0, |_| 0.0, |_| 0.0);
    let kappa_min = term.saved_state().kappa;
    let mut barrier = vec![Vec3::zeros(); n];
    term.evaluate(&ctx, x, &zeros, &mut barrier, &mut [0.0; 8]);
    assert!(term.active_pairs() > 0);
    // A load of 30 N down on every vertex, plus the barrier: the evaluation's total force.
    let load = Vec3::new(0.0, -30.0, 0.0);
    let total: Vec<Vec3> = barrier.iter().map(|b| b + load).collect();
    assert!(term.balance_stiffness(&total, &free));
    let kappa = term.saved_state().kappa;
    // Least squares: κ* minimises ‖load + κ*·(barrier/κ)‖.
    let unit: Vec<Vec3> = barrier.iter().map(|b| b / kappa_min).collect();
    let dot: f64 = unit.iter().map(|u| u.dot(&load)).sum();
    let norm: f64 = unit.iter().map(|u| u.norm_squared()).sum();
    let expected = (-dot / norm).clamp(kappa_min, 100.0 * kappa_min);
    assert!(kappa > kappa_min);
    assert!(
        (kappa - expected).abs() <= 1e-12 * expected,
        "{kappa} vs {expected}"
    );
    // Once a step: a second call changes nothing, even under a larger load.
    let heavier: Vec<Vec3> = barrier.iter().map(|b| b + 10.0 * load).collect();
    assert!(!term.balance_stiffness(&heavier, &free));
    assert_eq!(term.saved_state().kappa, kappa);
    // The next step balances again but never lowers κ.
    term.begin_step(x, 1.0, |_| 0.0, |_| 0.0);
    term.evaluate(&ctx, x, &zeros, &mut vec![Vec3::zeros(); n], &mut [0.0; 8]);
    let light: Vec<Vec3> = barrier.iter().map(|b| b + 1e-3 * load).collect();
    assert!(!term.balance_stiffness(&light, &free));
    assert_eq!(term.saved_state().kappa, kappa);
}
