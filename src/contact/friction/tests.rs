//! Friction: frames, the smoothing, and the potential's derivatives by finite differences.

use nalgebra::SVector;

use super::*;
use crate::contact::testutil::{fd_gradient_error, fd_hessian_error, point, rng, stack, unstack};

fn check_frame<const N: usize>(frame: &TangentFrame<N>, x: &[Vec3]) {
    let t = frame.basis;
    assert!(
        (t.transpose() * t - Matrix2::identity()).norm() < 1e-10,
        "{t}"
    );
    // Rigid translations slide nothing.
    let shift = vec![Vec3::new(0.3, -1.0, 2.0); N / 3];
    assert!(frame.relative_displacement(&shift).norm() < 1e-12);
    // The basis is orthogonal to the closest-point direction (when there is one).
    let r = residual(x, &frame.coefficients);
    if r.norm() > 1e-9 {
        assert!((t.transpose() * r).norm() < 1e-8 * r.norm(), "{r} {t}");
    }
}

fn check_pair<const N: usize>(
    frame: TangentFrame<N>,
    x: &[Vec3],
    rng: &mut rand_chacha::ChaCha8Rng,
) {
    check_frame(&frame, x);
    let pair = FrictionPair {
        frame,
        mu: 0.4,
        normal_force: 2.5,
    };
    let eps = 1e-2;
    // Slips from well below to well above ε.
    for scale in [1e-4, 3e-3, 2e-2, 0.5] {
        let dx: Vec<Vec3> = (0..N / 3).map(|_| scale * point(rng)).collect();
        let x0: SVector<f64, N> = stack(&dx);
        let g = pair.gradient(&dx, eps);
        let h = pair.hessian(&dx, eps);
        let eg = fd_gradient_error(|y| pair.potential(&unstack(y), eps), &x0, &g, 1e-10);
        let eh = fd_hessian_error(|y| pair.gradient(&unstack(y), eps), &x0, &h, 1e-10);
        assert!(eg < 1e-6 && eh < 1e-6, "slip {scale}: {eg:e} {eh:e}");
        let eig = nalgebra::DMatrix::from_column_slice(N, N, h.as_slice()).symmetric_eigenvalues();
        assert!(
            eig.min() > -1e-9 * h.norm().max(1.0),
            "not PSD: {}",
            eig.min()
        );
    }
}

#[test]
fn friction_derivatives_match_finite_differences_for_every_pair_type() {
    let mut rng = rng(41);
    for _ in 0..100 {
        let x = [0; 4].map(|_| point(&mut rng));
        check_pair(
            point_triangle_frame(&x[0], &x[1], &x[2], &x[3]),
            &x,
            &mut rng,
        );
        check_pair(edge_edge_frame(&x[0], &x[1], &x[2], &x[3]), &x, &mut rng);
        check_pair(point_edge_frame(&x[0], &x[1], &x[2]), &x[..3], &mut rng);
        check_pair(point_point_frame(&x[0], &x[1]), &x[..2], &mut rng);
    }
}

#[test]
fn sliding_friction_is_coulomb_and_static_friction_is_smooth() {
    let eps = 1e-3;
    assert_eq!(f1(10.0 * eps, eps), 1.0);
    assert!((f1(eps * (1.0 - 1e-9), eps) - 1.0).abs() < 1e-8);
    assert!((f0(eps * (1.0 - 1e-9), eps) - eps).abs() < 1e-11);
    assert_eq!(f1(0.0, eps), 0.0);
    assert_eq!(f1_over_y(0.0, eps), 2.0 / eps);
    // A point sliding on a triangle: force magnitude μλ once the slip exceeds ε.
    let frame = point_triangle_frame(
        &Vec3::new(0.2, 0.2, 1e-3),
        &Vec3::zeros(),
        &Vec3::x(),
        &Vec3::y(),
    );
    let pair = FrictionPair {
        frame,
        mu: 0.5,
        normal_force: 3.0,
    };
    for slip in [2.0 * eps, 1.0, 100.0] {
        let dx = [
            Vec3::new(slip, 0.0, 0.0),
            Vec3::zeros(),
            Vec3::zeros(),
            Vec3::zeros(),
        ];
        let f = pair.gradient(&dx, eps);
        assert!((f.fixed_rows::<3>(0).norm() - 1.5).abs() < 1e-12);
        // Opposes the slip, and the triangle gets the reaction.
        assert!(f[0] > 0.0 && f.fixed_rows::<3>(3).norm() > 0.0);
        let total: Vec3 = (0..4).map(|k| Vec3::from(f.fixed_rows::<3>(3 * k))).sum();
        assert!(total.norm() < 1e-12);
    }
    // Normal motion slides nothing.
    let dx = [
        Vec3::new(0.0, 0.0, -5.0),
        Vec3::zeros(),
        Vec3::zeros(),
        Vec3::zeros(),
    ];
    assert!(frame.relative_displacement(&dx).norm() < 1e-15);
    // No slip: zero force, finite Hessian (2/ε) μλ ΓᵀΓ.
    let zero = [Vec3::zeros(); 4];
    assert_eq!(pair.gradient(&zero, eps).norm(), 0.0);
    assert!(pair.hessian(&zero, eps).iter().all(|v| v.is_finite()));
}

#[test]
fn normal_force_matches_the_barrier_force() {
    let (dhat, kappa) = (1e-4, 10.0);
    for d in [1e-8f64, 1e-6, 5e-5] {
        // κ ∂b/∂g with g = √d, by central differences in g.
        let g = d.sqrt();
        let h = 1e-6 * g;
        let fd = kappa
            * (super::super::barrier::barrier((g + h).powi(2), dhat)
                - super::super::barrier::barrier((g - h).powi(2), dhat))
            / (2.0 * h);
        let lambda = normal_force_magnitude(d, dhat, kappa);
        assert!(
            lambda > 0.0 && (lambda + fd).abs() < 1e-5 * lambda,
            "{lambda} {fd}"
        );
    }
    assert_eq!(normal_force_magnitude(2e-4, dhat, kappa), 0.0);
}

#[test]
fn degenerate_frames_are_orthonormal() {
    let o = Vec3::zeros();
    let x = Vec3::x();
    for f in [
        point_point_frame(&o, &o).basis,
        point_edge_frame(&o, &o, &o).basis,
        point_edge_frame(&(0.5 * x), &o, &x).basis,
        point_triangle_frame(&o, &o, &x, &(2.0 * x)).basis,
        edge_edge_frame(&o, &x, &o, &x).basis,
        edge_edge_frame(&o, &o, &o, &o).basis,
    ] {
        assert!(
            (f.transpose() * f - Matrix2::identity()).norm() < 1e-12,
            "{f}"
        );
    }
}
