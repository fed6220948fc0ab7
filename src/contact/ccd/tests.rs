//! CCD against brute force: the oracle finds every zero of the coplanarity volume along the
//! trajectory by sampling and bisection, and keeps those where the distance vanishes. A CCD that
//! reports a time past the first such contact (or "no impact") is a bug.

use super::*;
use crate::contact::testutil::{point, rng, uniform};

#[derive(Clone, Copy)]
enum Kind {
    PointTriangle,
    EdgeEdge,
}

fn at(start: &[Vec3; 4], end: &[Vec3; 4], t: f64) -> [Vec3; 4] {
    std::array::from_fn(|i| start[i] + t * (end[i] - start[i]))
}

fn dist(kind: Kind, x: &[Vec3; 4]) -> f64 {
    match kind {
        Kind::PointTriangle => point_triangle_distance(&x[0], &x[1], &x[2], &x[3]),
        Kind::EdgeEdge => edge_edge_distance(&x[0], &x[1], &x[2], &x[3]),
    }
}

fn ccd(kind: Kind, start: &[Vec3; 4], end: &[Vec3; 4], params: &CcdParams) -> f64 {
    match kind {
        Kind::PointTriangle => point_triangle_ccd(start, end, params),
        Kind::EdgeEdge => edge_edge_ccd(start, end, params),
    }
}

/// The first time the primitives touch, by brute force (None: they never do).
fn first_contact(kind: Kind, start: &[Vec3; 4], end: &[Vec3; 4]) -> Option<f64> {
    let volume = |t: f64| {
        let x = at(start, end, t);
        (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&(x[3] - x[0]))
    };
    // Contact: a distance of 1e-12 on geometry of unit size (the tests' scale).
    let n = 4000;
    let mut prev = volume(0.0);
    for k in 0..n {
        let (mut lo, mut hi) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
        if dist(kind, &at(start, end, lo)) <= 1e-24 {
            return Some(lo);
        }
        let next = volume(hi);
        if prev * next <= 0.0 {
            let mut vlo = prev;
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                let vm = volume(mid);
                if vlo * vm <= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                    vlo = vm;
                }
            }
            if dist(kind, &at(start, end, hi)) <= 1e-24 {
                return Some(lo);
            }
        }
        prev = next;
    }
    None
}

/// Sampled distance on [0, toi] stays above ξ; toi is before the first contact.
fn assert_safe(kind: Kind, start: &[Vec3; 4], end: &[Vec3; 4], params: &CcdParams, what: &str) {
    let toi = ccd(kind, start, end, params);
    assert!((0.0..=params.max_time).contains(&toi), "{what}: toi {toi}");
    if let Some(hit) = first_contact(kind, start, end) {
        assert!(
            toi < hit,
            "{what}: toi {toi} at or past the contact at {hit}"
        );
    }
    let xi2 = params.min_distance * params.min_distance;
    for k in 0..=1000 {
        let t = toi * k as f64 / 1000.0;
        let d = dist(kind, &at(start, end, t));
        assert!(
            d > xi2 || d == 0.0 && t == 0.0,
            "{what}: d({t}) = {d} within ξ, toi {toi}"
        );
    }
}

#[test]
fn ccd_never_misses_a_contact_on_random_trajectories() {
    let mut rng = rng(21);
    for kind in [Kind::PointTriangle, Kind::EdgeEdge] {
        let mut hits = 0;
        for case in 0..600 {
            let start = [0; 4].map(|_| point(&mut rng));
            let end = start.map(|x| x + 2.5 * point(&mut rng));
            hits += usize::from(first_contact(kind, &start, &end).is_some());
            assert_safe(
                kind,
                &start,
                &end,
                &CcdParams::default(),
                &format!("random {case}"),
            );
        }
        // Enough of them really collide for the test to mean something.
        assert!(hits > 20, "only {hits} colliding trajectories");
    }
}

#[test]
fn ccd_respects_a_minimum_separation() {
    let mut rng = rng(22);
    let params = CcdParams {
        min_distance: 0.05,
        ..CcdParams::default()
    };
    for kind in [Kind::PointTriangle, Kind::EdgeEdge] {
        for case in 0..200 {
            let start = [0; 4].map(|_| point(&mut rng));
            let end = start.map(|x| x + point(&mut rng));
            if dist(kind, &start) <= 0.05 * 0.05 {
                assert_eq!(ccd(kind, &start, &end, &params), 0.0);
                continue;
            }
            assert_safe(kind, &start, &end, &params, &format!("separation {case}"));
        }
    }
}

#[test]
fn ccd_catches_adversarial_contacts() {
    let tri = [Vec3::zeros(), Vec3::x(), Vec3::y()];
    let params = CcdParams::default();
    // A vertex through the triangle's interior ever closer to edge 0, to a vertex, and just
    // outside the edge; from both sides; fast and slow.
    for eps in [1e-2, 1e-5, 1e-9, 0.0, -1e-9, -1e-5] {
        for (z0, z1) in [(1.0, -1.0), (-1e-3, 1e-3), (1e-8, -1e3)] {
            let start = [Vec3::new(0.3, eps, z0), tri[0], tri[1], tri[2]];
            let end = [Vec3::new(0.3, eps, z1), tri[0], tri[1], tri[2]];
            assert_safe(Kind::PointTriangle, &start, &end, &params, "near edge");
            let toi = point_triangle_ccd(&start, &end, &params);
            let hit = z0 / (z0 - z1);
            if eps >= 0.0 {
                assert!(
                    toi < hit && toi > 0.5 * hit,
                    "eps {eps}: toi {toi}, hit {hit}"
                );
            }
            let start = [Vec3::new(eps, eps, z0), tri[0], tri[1], tri[2]];
            let end = [Vec3::new(eps, eps, z1), tri[0], tri[1], tri[2]];
            assert_safe(Kind::PointTriangle, &start, &end, &params, "near vertex");
        }
    }
    // The triangle moves onto a fixed vertex.
    let start = [
        Vec3::new(0.2, 0.2, 0.0),
        tri[0] + Vec3::z(),
        tri[1] + Vec3::z(),
        tri[2] + Vec3::z(),
    ];
    let end = [
        start[0],
        tri[0] - Vec3::z(),
        tri[1] - Vec3::z(),
        tri[2] - Vec3::z(),
    ];
    let toi = point_triangle_ccd(&start, &end, &params);
    assert!(toi < 0.5 && toi > 0.4, "moving triangle: {toi}");
    // Crossing edges, skew.
    let a = [Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)];
    let b = [Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let down = Vec3::new(0.0, 0.0, -2.0);
    let start = [a[0], a[1], b[0], b[1]];
    let end = [a[0] + down, a[1] + down, b[0], b[1]];
    let toi = edge_edge_ccd(&start, &end, &params);
    assert!(toi < 0.5 && toi > 0.4, "crossing edges: {toi}");
    assert_safe(Kind::EdgeEdge, &start, &end, &params, "crossing edges");
    // Parallel edges, one dropping onto the other.
    let b = [Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.5, 0.0, 0.0)];
    let start = [a[0], a[1], b[0], b[1]];
    let end = [a[0] + down, a[1] + down, b[0], b[1]];
    let toi = edge_edge_ccd(&start, &end, &params);
    assert!(toi < 0.5 && toi > 0.4, "parallel edges: {toi}");
    // Collinear edges sliding into each other: b₀ reaches a₁ = (1, 0, 1) at t = 2/3.
    let b = [Vec3::new(2.0, 0.0, 1.0), Vec3::new(3.0, 0.0, 1.0)];
    let left = Vec3::new(-1.5, 0.0, 0.0);
    let start = [a[0], a[1], b[0], b[1]];
    let end = [a[0], a[1], b[0] + left, b[1] + left];
    let toi = edge_edge_ccd(&start, &end, &params);
    assert!(toi < 2.0 / 3.0 && toi > 0.5, "collinear edges: {toi}");
    // Zero motion and common translation: the whole step is free.
    let still = [a[0], a[1], b[0], b[1]];
    assert_eq!(edge_edge_ccd(&still, &still, &params), 1.0);
    let moved = still.map(|x| x + Vec3::new(3.0, -2.0, 1.0));
    assert_eq!(edge_edge_ccd(&still, &moved, &params), 1.0);
    // Tiny separations: approaching gives a tiny but positive step, receding the whole step.
    for gap in [1e-6, 1e-9, 1e-12] {
        let start = [Vec3::new(0.2, 0.2, gap), tri[0], tri[1], tri[2]];
        let mut end = start;
        end[0].z = -1.0;
        let toi = point_triangle_ccd(&start, &end, &params);
        assert!(toi > 0.0 && toi < gap, "gap {gap}: toi {toi}");
        end[0].z = 1.0;
        assert_eq!(point_triangle_ccd(&start, &end, &params), 1.0);
    }
    // Touching already (exactly zero distance: the point is a vertex of the triangle): no
    // step at all, unless nothing moves. (A distance at round-off level, 1e-17, is not
    // "touching": which side the point is on is then decided by rounding.)
    let start = [tri[1], tri[0], tri[1], tri[2]];
    let mut end = start;
    end[0].z = -1.0;
    assert_eq!(point_triangle_ccd(&start, &end, &params), 0.0);
    assert_eq!(point_triangle_ccd(&start, &start, &params), 1.0);
}

#[test]
fn point_edge_and_point_point_ccd_stop_before_contact() {
    let params = CcdParams::default();
    let (e0, e1) = (Vec3::zeros(), Vec3::x());
    let start = [Vec3::new(0.5, 1.0, 0.0), e0, e1];
    let end = [Vec3::new(0.5, -1.0, 0.0), e0, e1];
    let toi = point_edge_ccd(&start, &end, &params);
    assert!(toi < 0.5 && toi > 0.4, "{toi}");
    let toi = point_point_ccd(
        &[Vec3::zeros(), Vec3::x()],
        &[Vec3::x(), Vec3::zeros()],
        &params,
    );
    assert!(toi < 0.5 && toi > 0.4, "{toi}");
}

#[test]
fn plane_and_sphere_ccd_stop_before_contact() {
    let mut rng = rng(23);
    let params = CcdParams::default();
    let n = Vec3::new(0.0, 2.0, 0.0);
    let o = Vec3::zeros();
    // Falling through the ground at t = 0.5.
    let toi = point_plane_ccd(
        &Vec3::new(0.3, 1.0, 0.0),
        &Vec3::new(0.0, -1.0, 0.0),
        &o,
        &o,
        &n,
        &params,
    );
    assert!((toi - 0.45).abs() < 1e-12, "{toi}");
    // The ground rising to meet a resting point at t = 0.5.
    let up = Vec3::new(0.0, 2.0, 0.0);
    let toi = point_plane_ccd(&Vec3::y(), &Vec3::y(), &o, &up, &n, &params);
    assert!((toi - 0.45).abs() < 1e-12, "{toi}");
    assert_eq!(
        point_plane_ccd(&Vec3::y(), &(2.0 * Vec3::y()), &o, &o, &n, &params),
        1.0
    );
    assert_eq!(
        point_plane_ccd(&-Vec3::y(), &Vec3::y(), &o, &o, &n, &params),
        0.0
    );
    // A sphere swept against random triangles: the sampled gap stays positive up to toi.
    for _ in 0..200 {
        let face0 = [0; 3].map(|_| point(&mut rng));
        let face1 = face0.map(|x| x + 0.5 * point(&mut rng));
        let c0 = 2.0 * point(&mut rng);
        let c1 = c0 + 2.0 * point(&mut rng);
        let radius = uniform(&mut rng, 0.01, 0.5);
        let gap0 = crate::contact::distance::sphere_triangle_gap(
            &c0, radius, &face0[0], &face0[1], &face0[2],
        );
        let toi = sphere_triangle_ccd(&c0, &c1, radius, &face0, &face1, &params);
        if gap0 <= 0.0 {
            assert_eq!(toi, 0.0);
            continue;
        }
        for k in 0..=2000 {
            let t = toi * k as f64 / 2000.0;
            let c = c0 + t * (c1 - c0);
            let f: [Vec3; 3] = std::array::from_fn(|i| face0[i] + t * (face1[i] - face0[i]));
            let g = crate::contact::distance::sphere_triangle_gap(&c, radius, &f[0], &f[1], &f[2]);
            assert!(g > 0.0, "sphere gap {g} at {t} ≤ toi {toi}");
        }
    }
}
