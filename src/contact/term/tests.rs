//! The contact term against finite differences, for every obstacle shape.

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
        let body = crate::elastic::ElasticBody::new(
            mesh.clone(),
            crate::Model::new(
                crate::ModelKind::NeoHookean,
                crate::Lame::from_young_poisson(1e5, 0.3),
            ),
            1000.0,
        )
        .unwrap();
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
