//! Distances against brute force, derivatives against central differences, degenerate input.

use nalgebra::SVector;

use super::*;
use crate::contact::testutil::{fd_gradient_error, fd_hessian_error, point, rng, stack, unstack};

const TOL: f64 = 1e-6;

/// Minimum of ‖p − x(u, v)‖² over a (n+1)² grid of the triangle (brute force).
fn brute_point_triangle(p: &Vec3, t: [Vec3; 3], n: usize) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=n {
        for j in 0..=(n - i) {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let x = t[0] + u * (t[1] - t[0]) + v * (t[2] - t[0]);
            best = best.min((p - x).norm_squared());
        }
    }
    best
}

fn brute_edge_edge(x: [Vec3; 4], n: usize) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=n {
        for j in 0..=n {
            let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
            let pa = x[0] + s * (x[1] - x[0]);
            let pb = x[2] + t * (x[3] - x[2]);
            best = best.min((pa - pb).norm_squared());
        }
    }
    best
}

#[test]
fn point_triangle_distance_matches_brute_force() {
    let mut rng = rng(1);
    for _ in 0..300 {
        let (p, t0, t1, t2) = (
            point(&mut rng),
            point(&mut rng),
            point(&mut rng),
            point(&mut rng),
        );
        let d = point_triangle_distance(&p, &t0, &t1, &t2);
        let brute = brute_point_triangle(&p, [t0, t1, t2], 200);
        // The grid only over-estimates; its resolution is ~2/200 per coordinate.
        assert!(d <= brute + 1e-12, "exact {d} > brute {brute}");
        assert!(
            brute - d < 0.05 * brute.sqrt() + 1e-3,
            "exact {d} ≪ brute {brute}"
        );
        let der = point_triangle_distance_derivatives(&p, &t0, &t1, &t2);
        assert!((der.value - d).abs() <= 1e-12 * (1.0 + d));
    }
}

#[test]
fn edge_edge_distance_matches_brute_force() {
    let mut rng = rng(2);
    for _ in 0..300 {
        let x = [0; 4].map(|_| point(&mut rng));
        let d = edge_edge_distance(&x[0], &x[1], &x[2], &x[3]);
        let brute = brute_edge_edge(x, 300);
        assert!(d <= brute + 1e-12, "exact {d} > brute {brute}");
        assert!(
            brute - d < 0.05 * brute.sqrt() + 1e-3,
            "exact {d} ≪ brute {brute}"
        );
        let der = edge_edge_distance_derivatives(&x[0], &x[1], &x[2], &x[3]);
        assert!((der.value - d).abs() <= 1e-12 * (1.0 + d));
    }
}

#[test]
fn parallel_and_crossing_edges_have_exact_distances() {
    // Parallel, overlapping in projection: the distance is the lines' separation.
    let (a0, a1) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0));
    let (b0, b1) = (Vec3::new(0.5, 0.3, 0.0), Vec3::new(1.5, 0.3, 0.0));
    assert!((edge_edge_distance(&a0, &a1, &b0, &b1) - 0.09).abs() < 1e-15);
    // Parallel, collinear and apart.
    let (c0, c1) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(3.0, 0.0, 0.0));
    assert!((edge_edge_distance(&a0, &a1, &c0, &c1) - 1.0).abs() < 1e-15);
    // Crossing: zero.
    let (d0, d1) = (Vec3::new(0.5, -1.0, 0.0), Vec3::new(0.5, 1.0, 0.0));
    assert_eq!(edge_edge_distance(&a0, &a1, &d0, &d1), 0.0);
    assert_eq!(
        edge_edge_distance_type(&a0, &a1, &d0, &d1),
        EdgeEdgeCase::Interior
    );
    // Skew, closest inside both: the z offset.
    let (e0, e1) = (Vec3::new(0.5, -1.0, 0.2), Vec3::new(0.5, 1.0, 0.2));
    assert!((edge_edge_distance(&a0, &a1, &e0, &e1) - 0.04).abs() < 1e-15);
}

#[test]
fn every_closest_feature_is_classified() {
    let t = [Vec3::zeros(), Vec3::x(), Vec3::y()];
    let pt = |p: Vec3| point_triangle_distance_type(&p, &t[0], &t[1], &t[2]);
    assert_eq!(pt(Vec3::new(0.2, 0.2, 1.0)), PointTriangleCase::Interior);
    assert_eq!(pt(Vec3::new(-1.0, -1.0, 0.5)), PointTriangleCase::Vertex(0));
    assert_eq!(pt(Vec3::new(2.0, -0.1, 0.0)), PointTriangleCase::Vertex(1));
    assert_eq!(pt(Vec3::new(-0.1, 2.0, 0.0)), PointTriangleCase::Vertex(2));
    assert_eq!(pt(Vec3::new(0.5, -1.0, 0.3)), PointTriangleCase::Edge(0));
    assert_eq!(pt(Vec3::new(1.0, 1.0, 0.3)), PointTriangleCase::Edge(1));
    assert_eq!(pt(Vec3::new(-1.0, 0.5, 0.3)), PointTriangleCase::Edge(2));
    let (a0, a1) = (Vec3::zeros(), Vec3::x());
    let ee = |b0: Vec3, b1: Vec3| edge_edge_distance_type(&a0, &a1, &b0, &b1);
    let z = Vec3::z();
    assert_eq!(
        ee(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(-1.0, 1.0, 1.0)),
        EdgeEdgeCase::VertexVertex { a: 0, b: 0 }
    );
    assert_eq!(
        ee(Vec3::new(2.0, -1.0, 1.0), Vec3::new(2.0, 1.0, 1.0)),
        EdgeEdgeCase::VertexOfA { a: 1 }
    );
    assert_eq!(
        ee(Vec3::new(0.5, 0.5, 1.0), Vec3::new(0.5, 2.0, 1.0)),
        EdgeEdgeCase::VertexOfB { b: 0 }
    );
    assert_eq!(
        ee(Vec3::new(0.5, -1.0, 0.0) + z, Vec3::new(0.5, 1.0, 0.0) + z),
        EdgeEdgeCase::Interior
    );
    let pe = |p: Vec3| point_edge_distance_type(&p, &a0, &a1);
    assert_eq!(pe(Vec3::new(-1.0, 1.0, 0.0)), PointEdgeCase::Vertex(0));
    assert_eq!(pe(Vec3::new(3.0, 1.0, 0.0)), PointEdgeCase::Vertex(1));
    assert_eq!(pe(Vec3::new(0.3, 1.0, 0.0)), PointEdgeCase::Interior);
}

/// FD-check value → gradient → Hessian of a distance over N dofs at x.
fn check<const N: usize>(name: &str, f: impl Fn(&[Vec3]) -> Derivatives<N>, x: &[Vec3]) {
    let x0: SVector<f64, N> = stack(x);
    let d = f(x);
    let scale = 1e-8 * (1.0 + d.value);
    let eg = fd_gradient_error(|y| f(&unstack(y)).value, &x0, &d.gradient, scale);
    let eh = fd_hessian_error(|y| f(&unstack(y)).gradient, &x0, &d.hessian, scale);
    assert!(
        eg < TOL && eh < TOL,
        "{name} at {x:?}: gradient error {eg:e}, Hessian error {eh:e}"
    );
    assert!(d.hessian.iter().all(|v| v.is_finite()));
    assert!((d.hessian - d.hessian.transpose()).norm() <= 1e-9 * (1.0 + d.hessian.norm()));
}

fn pt(x: &[Vec3]) -> Derivatives<12> {
    point_triangle_distance_derivatives(&x[0], &x[1], &x[2], &x[3])
}
fn ee(x: &[Vec3]) -> Derivatives<12> {
    edge_edge_distance_derivatives(&x[0], &x[1], &x[2], &x[3])
}
fn pe(x: &[Vec3]) -> Derivatives<9> {
    point_edge_distance_derivatives(&x[0], &x[1], &x[2])
}
fn pp(x: &[Vec3]) -> Derivatives<6> {
    point_point_distance_derivatives(&x[0], &x[1])
}

#[test]
fn distance_derivatives_match_finite_differences_on_random_pairs() {
    let mut rng = rng(3);
    let mut pt_cases = std::collections::BTreeSet::new();
    let mut ee_cases = std::collections::BTreeSet::new();
    for _ in 0..400 {
        let x = [0; 4].map(|_| point(&mut rng));
        pt_cases.insert(point_triangle_distance_type(&x[0], &x[1], &x[2], &x[3]));
        ee_cases.insert(edge_edge_distance_type(&x[0], &x[1], &x[2], &x[3]));
        check("point-triangle", pt, &x);
        check("edge-edge", ee, &x);
        check("point-edge", pe, &x[..3]);
        check("point-point", pp, &x[..2]);
    }
    // Every sub-case was exercised.
    assert_eq!(pt_cases.len(), 7, "{pt_cases:?}");
    assert_eq!(ee_cases.len(), 9, "{ee_cases:?}");
}

#[test]
fn distance_derivatives_match_finite_differences_near_degenerate() {
    let mut rng = rng(4);
    for k in 0..60 {
        let small = 10f64.powi(-(k % 6) - 1);
        let t = [0; 3].map(|_| point(&mut rng));
        // A point just off an edge of the triangle, inside and outside, above the plane.
        let m = t[0] + 0.4 * (t[1] - t[0]);
        let n = (t[1] - t[0]).cross(&(t[2] - t[0])).normalize();
        let inward = n.cross(&(t[1] - t[0])).normalize();
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let p = m + sign * 10.0 * small * inward + 0.1 * small * n;
        check("point near edge", pt, &[p, t[0], t[1], t[2]]);
        // Nearly parallel edges (angle ~small), crossing in projection.
        let a0 = point(&mut rng);
        let dir = point(&mut rng).normalize();
        let side = dir.cross(&point(&mut rng)).normalize();
        let a1 = a0 + dir;
        let b0 = a0 + 0.3 * dir + 0.2 * side.cross(&dir) - 0.5 * small * side;
        let b1 = b0 + dir + small * side;
        let x = [a0, a1, b0, b1];
        if small >= 1e-3 {
            check("nearly parallel edges", ee, &x);
        } else {
            // Below ~1e-3 rad the line–line optimum moves by O(h/θ) under a step h, so finite
            // differences cannot resolve it (the mollifier switches such pairs off); the value
            // must still be exact and the derivatives finite.
            let d = ee(&x);
            let brute = brute_edge_edge(x, 400);
            assert!(d.value <= brute + 1e-12 && brute - d.value < 1e-2 * brute.sqrt());
            assert!(d.hessian.iter().all(|v| v.is_finite()));
        }
        // A point near the segment's line.
        check("point near line", pe, &[m + small * inward, t[0], t[1]]);
    }
}

#[test]
fn degenerate_primitives_give_finite_results() {
    let p = Vec3::new(0.3, 0.2, 0.1);
    let o = Vec3::zeros();
    let x = Vec3::x();
    let finite = |v: f64| assert!(v.is_finite());
    // Zero-length edges, zero-area triangles, coincident points.
    for t in [[o, o, o], [o, x, 2.0 * x], [o, x, x], [p, p, p]] {
        let d = point_triangle_distance_derivatives(&p, &t[0], &t[1], &t[2]);
        finite(d.value);
        d.gradient.iter().copied().for_each(finite);
        d.hessian.iter().copied().for_each(finite);
        let d = edge_edge_distance_derivatives(&t[0], &t[1], &t[2], &t[0]);
        d.hessian.iter().copied().for_each(finite);
        let d = edge_edge_distance_derivatives(&p, &p, &t[1], &t[2]);
        d.hessian.iter().copied().for_each(finite);
        let d = point_edge_distance_derivatives(&p, &t[0], &t[0]);
        d.hessian.iter().copied().for_each(finite);
    }
    // A zero-area triangle is its longest edge: the distance from p to segment 0..2x.
    let d = point_triangle_distance(&p, &o, &x, &(2.0 * x));
    assert!((d - 0.05).abs() < 1e-15);
}

#[test]
fn plane_and_sphere_derivatives_match_finite_differences() {
    let mut rng = rng(5);
    for _ in 0..100 {
        let (o, n) = (point(&mut rng), point(&mut rng));
        let p = point(&mut rng);
        check(
            "plane",
            |x| point_plane_distance_derivatives(&x[0], &o, &n),
            &[p],
        );
        let c = point(&mut rng);
        let t = [0; 3].map(|_| 2.0 * point(&mut rng));
        let radius = 0.5 * point_triangle_distance(&c, &t[0], &t[1], &t[2]).sqrt();
        check(
            "sphere",
            |x| sphere_triangle_distance_derivatives(&c, radius, &x[0], &x[1], &x[2]),
            &t,
        );
        let g = sphere_triangle_gap(&c, radius, &t[0], &t[1], &t[2]);
        let s = sphere_triangle_distance_derivatives(&c, radius, &t[0], &t[1], &t[2]);
        assert!((g * g - s.value).abs() < 1e-12);
    }
}
