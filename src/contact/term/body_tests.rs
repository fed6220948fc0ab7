//! Body–body and self-contact pairs of the contact term: derivatives against finite
//! differences, CCD, the held pattern, the initial-intersection check, the body rules and
//! determinism.

use super::*;
use crate::contact::ContactParams;
use crate::integrator::{SolverParams, StepKind};
use crate::linear::sparse::BlockPattern;
use crate::mesh::TetMesh;
use crate::mesh::generate::box_mesh;

/// Boxes (min, max, cells, body) as one mesh with the body of every vertex.
pub(super) fn boxes(parts: &[(Vec3, Vec3, [usize; 3], u32)]) -> (TetMesh, Vec<u32>) {
    let mut positions = Vec::new();
    let mut tets = Vec::new();
    let mut body = Vec::new();
    for &(min, max, cells, b) in parts {
        let m = box_mesh(min, max, cells);
        let offset = positions.len();
        tets.extend(m.tets.iter().map(|t| t.map(|v| v + offset)));
        body.extend(std::iter::repeat_n(b, m.positions.len()));
        positions.extend(m.positions);
    }
    (TetMesh::new(positions, tets), body)
}

/// The setup for bodies named "left", "right", ... with d̂ = `distance`.
fn setup(vertex_body: Vec<u32>, distance: f64, friction: f64, self_contact: bool) -> ContactSetup {
    ContactSetup {
        params: ContactParams {
            distance: Some(distance),
            friction,
            self_contact,
        },
        body_names: vec!["left".into(), "right".into(), "third".into()],
        vertex_body,
        ..Default::default()
    }
}

/// Two 0.2 m cubes, the second above the first with a gap `gap` and turned by `angle` (rad)
/// about y (so that their horizontal edges are nearly parallel), x shifted by `shift`.
fn stacked(gap: f64, angle: f64, shift: f64) -> (TetMesh, Vec<u32>) {
    let (mut mesh, body) = boxes(&[
        (Vec3::zeros(), Vec3::repeat(0.2), [2, 2, 2], 0),
        (
            Vec3::new(0.0, 0.2 + gap, 0.0),
            Vec3::new(0.2, 0.4 + gap, 0.2),
            [2, 2, 2],
            1,
        ),
    ]);
    let r = nalgebra::Rotation3::from_axis_angle(&Vec3::y_axis(), angle);
    let c = Vec3::new(0.1, 0.0, 0.1);
    for (p, &b) in mesh.positions.iter_mut().zip(&body) {
        if b == 1 {
            *p = c + r * (*p - c) + Vec3::new(shift, 0.0, 0.0);
        }
    }
    (mesh, body)
}

/// A soft Neo-Hookean body (E = 1e5 Pa, ν = 0.3, 1000 kg/m³) on `mesh`.
pub(super) fn elastic(mesh: &TetMesh) -> crate::elastic::ElasticBody {
    crate::elastic::ElasticBody::new(
        mesh.clone(),
        crate::Model::new(
            crate::ModelKind::NeoHookean,
            crate::Lame::from_young_poisson(1e5, 0.3),
        ),
        1000.0,
    )
    .unwrap()
}

/// Energy, force and the term at x.
fn evaluate(
    term: &mut ContactTerm,
    body: &crate::elastic::ElasticBody,
    x: &[Vec3],
) -> (f64, Vec<Vec3>) {
    let n = x.len();
    let params = SolverParams::default();
    let zeros = vec![Vec3::zeros(); n];
    let ctx = StepContext {
        body,
        kind: StepKind::Static,
        f_ext: &zeros,
        free: &zeros,
        params: &params,
    };
    let mut f = vec![Vec3::zeros(); n];
    let e = term.evaluate(&ctx, x, &zeros, &mut f, &mut [0.0; 8]);
    (e, f)
}

fn hessian_product(
    term: &mut ContactTerm,
    body: &crate::elastic::ElasticBody,
    u: &[Vec3],
) -> Vec<Vec3> {
    let n = u.len();
    let params = SolverParams::default();
    let zeros = vec![Vec3::zeros(); n];
    let ctx = StepContext {
        body,
        kind: StepKind::Static,
        f_ext: &zeros,
        free: &zeros,
        params: &params,
    };
    let mut hu = vec![Vec3::zeros(); n];
    term.add_hessian_product(&ctx, u, &mut hu);
    hu
}

fn jitter(x: &[Vec3], scale: f64) -> Vec<Vec3> {
    x.iter()
        .enumerate()
        .map(|(i, p)| {
            let i = i as f64;
            p + scale * Vec3::new((1.7 * i).sin(), (0.3 * i).cos(), (0.7 * i).cos())
        })
        .collect()
}

/// Energy → force and force → Hessian of body–body pairs (point–triangle both ways, edge–edge
/// with nearly parallel, mollified edges) and their lagged friction, by central differences.
#[test]
fn body_pair_derivatives_match_finite_differences_including_near_parallel_edges() {
    for (angle, friction) in [(0.3, 0.0), (1e-3, 0.0), (0.3, 0.4), (1e-3, 0.4)] {
        let (mesh, body) = stacked(0.004, angle, 0.013);
        let n = mesh.positions.len();
        let elastic = elastic(&mesh);
        let mut term = ContactTerm::new(setup(body, 0.01, friction, true), &mesh, &vec![1.0; n]);
        term.kappa = 1.0;
        let xn = jitter(&mesh.positions, 2e-4);
        term.begin_step(&xn, 0.01, |_| 0.0, |_| 0.0);
        // Slid a little since the lag, so friction acts.
        let x: Vec<Vec3> = xn
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vec3::new(1e-5 * (i as f64).sin(), 0.0, 3e-6 * (i as f64).cos()))
            .collect();
        let (_, f) = evaluate(&mut term, &elastic, &x);
        let active = term.active_pairs();
        assert!(active > 10, "angle {angle}: only {active} pairs");
        if friction > 0.0 {
            assert!(term.pairs.len() > active, "no friction pairs");
        }
        let u: Vec<Vec3> = (0..n)
            .map(|i| {
                let i = i as f64;
                Vec3::new((1.3 * i).sin(), (0.9 * i).cos(), (2.1 * i).sin())
            })
            .collect();
        let slope: f64 = -f.iter().zip(&u).map(|(f, u)| f.dot(u)).sum::<f64>();
        term.use_exact(true);
        let hu = hessian_product(&mut term, &elastic, &u);
        let (mut best_e, mut best_h) = (f64::INFINITY, f64::INFINITY);
        for k in 5..12 {
            let t = 10f64.powi(-k);
            let plus: Vec<Vec3> = x.iter().zip(&u).map(|(x, u)| x + t * u).collect();
            let minus: Vec<Vec3> = x.iter().zip(&u).map(|(x, u)| x - t * u).collect();
            let (ep, fp) = evaluate(&mut term, &elastic, &plus);
            let (em, fm) = evaluate(&mut term, &elastic, &minus);
            best_e = best_e.min(((ep - em) / (2.0 * t) - slope).abs() / slope.abs());
            let err: f64 = (0..n)
                .map(|i| ((fm[i] - fp[i]) / (2.0 * t) - hu[i]).norm_squared())
                .sum::<f64>()
                .sqrt();
            let norm: f64 = hu.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt();
            best_h = best_h.min(err / norm);
        }
        assert!(
            best_e < 1e-6,
            "angle {angle}, μ {friction}: energy → force {best_e:e}"
        );
        assert!(
            best_h < 1e-5,
            "angle {angle}, μ {friction}: force → Hessian {best_h:e}"
        );
    }
}

/// The mollifier is in play for the nearly parallel pair: some edge–edge pair has
/// ‖ea × eb‖² under εₓ.
#[test]
fn nearly_parallel_edges_are_mollified() {
    let (mesh, body) = stacked(0.004, 1e-3, 0.013);
    let term = ContactTerm::new(
        setup(body, 0.01, 0.0, true),
        &mesh,
        &vec![1.0; mesh.positions.len()],
    );
    let x = &mesh.positions;
    let mollified = term
        .body_candidates(x, x, 0.01)
        .iter()
        .filter(|c| c.split == 2 && c.distance(x) < 1e-4)
        .filter(|c| {
            let [a, b, cc, d] = c.vertices.map(|v| x[v]);
            let eps = edge_edge_mollifier_threshold(&a, &b, &cc, &d);
            (b - a).cross(&(d - cc)).norm_squared() < eps
        })
        .count();
    assert!(mollified > 0);
}

/// Two cubes moving into each other: CCD stops the move before any surface edge passes
/// through the other's faces; the whole move would have.
#[test]
fn max_step_stops_two_boxes_before_they_intersect() {
    for angle in [0.0, 0.4] {
        let (mesh, body) = stacked(0.05, angle, 0.03);
        let n = mesh.positions.len();
        let term = ContactTerm::new(setup(body.clone(), 0.001, 0.0, true), &mesh, &vec![1.0; n]);
        let x = &mesh.positions;
        assert_eq!(term.intersection(x), None);
        // Each moves 6 cm toward the other, a little sideways.
        let dx: Vec<Vec3> = body
            .iter()
            .map(|&b| {
                if b == 0 {
                    Vec3::new(0.01, 0.06, 0.0)
                } else {
                    Vec3::new(-0.01, -0.06, 0.005)
                }
            })
            .collect();
        let end: Vec<Vec3> = x.iter().zip(&dx).map(|(x, d)| x + d).collect();
        assert!(term.intersection(&end).is_some(), "the full move overlaps");
        let t = term.max_step(x, &dx);
        assert!(t > 0.3 && t < 0.42, "t = {t}");
        let at: Vec<Vec3> = x.iter().zip(&dx).map(|(x, d)| x + t * d).collect();
        assert_eq!(term.intersection(&at), None, "t = {t}");
        let costs = term.costs();
        assert!(costs.body_ccd_pairs > 0 && costs.ccd_calls == 1);
    }
}

/// The held pattern: nothing while the bodies are apart; the near pairs' blocks once they are
/// close; no new generation while the contacts stay among the held ones; growth when a new
/// pair comes into reach; every block `add_to_matrix` fills is in the pattern.
#[test]
fn pattern_grows_only_when_a_new_pair_needs_it() {
    let (mesh, body) = stacked(0.05, 0.0, 0.03);
    let n = mesh.positions.len();
    let elastic = elastic(&mesh);
    let mut term = ContactTerm::new(setup(body.clone(), 0.01, 0.0, true), &mesh, &vec![1.0; n]);
    let lift = |dy: f64| -> Vec<Vec3> {
        mesh.positions
            .iter()
            .zip(&body)
            .map(|(p, &b)| {
                if b == 1 {
                    p - Vec3::new(0.0, dy, 0.0)
                } else {
                    *p
                }
            })
            .collect()
    };
    let blocks = |term: &ContactTerm| {
        let mut out = Vec::new();
        term.extra_blocks(&mut out);
        out
    };
    let far = lift(0.0);
    term.begin_step(&far, 0.01, |_| 0.0, |_| 0.0);
    evaluate(&mut term, &elastic, &far);
    assert_eq!((term.pattern_generation(), blocks(&term).len()), (0, 0));
    // 5 mm apart: inside the hold radius (2 cm), outside d̂ (1 cm).
    let near = lift(0.045);
    term.begin_step(&near, 0.01, |_| 0.0, |_| 0.0);
    let g = term.pattern_generation();
    let held = blocks(&term);
    assert!(g == 1 && !held.is_empty());
    assert!(
        held.iter()
            .all(|&(i, j)| body[i as usize] != body[j as usize])
    );
    // Iterates moving within the held set: no new pattern.
    for dy in [0.046, 0.0465, 0.047] {
        evaluate(&mut term, &elastic, &lift(dy));
        assert!(term.active_pairs() > 0);
        assert_eq!(term.pattern_generation(), g, "dy {dy}");
    }
    // Slid sideways by a cell: pairs not held come into reach.
    let slid: Vec<Vec3> = lift(0.047)
        .iter()
        .zip(&body)
        .map(|(p, &b)| {
            if b == 1 {
                p + Vec3::new(0.1, 0.0, 0.0)
            } else {
                *p
            }
        })
        .collect();
    evaluate(&mut term, &elastic, &slid);
    assert_eq!(term.pattern_generation(), g + 1);
    let grown = blocks(&term);
    assert!(grown.len() > held.len());
    // The assembled Hessian (adjacency + held blocks) is the product's.
    let pattern = BlockPattern::from_tets(n, &mesh.tets).with_blocks(&grown);
    let params = SolverParams::default();
    let zeros = vec![Vec3::zeros(); n];
    let ctx = StepContext {
        body: &elastic,
        kind: StepKind::Static,
        f_ext: &zeros,
        free: &zeros,
        params: &params,
    };
    let mut a = BlockCsr::zeros(pattern);
    term.add_to_matrix(&ctx, &mut a);
    let u = jitter(&vec![Vec3::zeros(); n], 1.0);
    let mut au = vec![Vec3::zeros(); n];
    a.multiply(&u, &mut au);
    let hu = hessian_product(&mut term, &elastic, &u);
    let err: f64 = au.iter().zip(&hu).map(|(a, h)| (a - h).norm()).sum();
    let norm: f64 = hu.iter().map(Vec3::norm).sum();
    assert!(norm > 0.0 && err <= 1e-12 * norm, "{err:e} of {norm:e}");
    // The next step far apart again: the held set is small, so it is kept (no rebuild).
    term.begin_step(&far, 0.01, |_| 0.0, |_| 0.0);
    assert_eq!(term.pattern_generation(), g + 1);
}

/// Overlapping cubes are refused naming both bodies and an element of each; a body whose two
/// pieces overlap is refused as passing through itself, unless self-contact is off.
#[test]
fn intersection_names_both_bodies_and_an_element_of_each() {
    let (mesh, body) = stacked(-0.03, 0.2, 0.05);
    let n = mesh.positions.len();
    let term = ContactTerm::new(setup(body.clone(), 0.001, 0.0, true), &mesh, &vec![1.0; n]);
    let message = term.intersection(&mesh.positions).expect("they overlap");
    assert!(
        message.contains("\"left\"") && message.contains("\"right\""),
        "{message}"
    );
    assert!(
        message.contains("edge of vertices") && message.contains("face of vertices"),
        "{message}"
    );
    // The same two pieces as one body.
    let one = vec![0; n];
    let term = ContactTerm::new(setup(one.clone(), 0.001, 0.0, true), &mesh, &vec![1.0; n]);
    let message = term.intersection(&mesh.positions).expect("itself");
    assert!(message.contains("\"left\" through itself"), "{message}");
    let term = ContactTerm::new(setup(one, 0.001, 0.0, false), &mesh, &vec![1.0; n]);
    assert_eq!(term.intersection(&mesh.positions), None);
    // Apart: fine.
    let (mesh, body) = stacked(0.001, 0.2, 0.05);
    let term = ContactTerm::new(setup(body, 0.001, 0.0, true), &mesh, &vec![1.0; n]);
    assert_eq!(term.intersection(&mesh.positions), None);
}

/// `self_contact = false`: pairs inside one body (here two pieces of body "left") are ignored,
/// pairs between bodies kept; with it on, both.
#[test]
fn self_contact_off_ignores_pairs_inside_a_body_but_keeps_body_body() {
    let c = [2, 1, 2];
    let (mesh, body) = boxes(&[
        (Vec3::zeros(), Vec3::new(0.2, 0.1, 0.2), c, 0),
        (Vec3::new(0.0, 0.104, 0.0), Vec3::new(0.2, 0.204, 0.2), c, 0),
        (Vec3::new(0.0, 0.208, 0.0), Vec3::new(0.2, 0.308, 0.2), c, 1),
    ]);
    let n = mesh.positions.len();
    let elastic = elastic(&mesh);
    let x = jitter(&mesh.positions, 1e-4);
    let count = |self_contact| {
        let mut term = ContactTerm::new(
            setup(body.clone(), 0.01, 0.0, self_contact),
            &mesh,
            &vec![1.0; n],
        );
        evaluate(&mut term, &elastic, &x);
        let pairs = &term.pairs[..term.active_pairs()];
        let between = pairs
            .iter()
            .filter(|p| p.vertices.iter().any(|&v| body[v] == 1))
            .count();
        (pairs.len() - between, between)
    };
    let (inside_on, between_on) = count(true);
    let (inside_off, between_off) = count(false);
    assert!(inside_on > 0 && between_on > 0);
    assert_eq!((inside_off, between_off), (0, between_on));
}

/// Body pairs' energy, forces, Hessian product, CCD bound and costs' counts are the same bits
/// on one and two threads.
#[test]
fn body_pairs_give_the_same_bits_on_one_and_two_threads() {
    let (mesh, body) = stacked(0.004, 0.3, 0.013);
    let n = mesh.positions.len();
    let elastic = elastic(&mesh);
    let x = jitter(&mesh.positions, 2e-4);
    let dx: Vec<Vec3> = body
        .iter()
        .map(|&b| Vec3::new(0.0, if b == 0 { 0.01 } else { -0.01 }, 0.0))
        .collect();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let mut term =
                    ContactTerm::new(setup(body.clone(), 0.01, 0.3, true), &mesh, &vec![1.0; n]);
                term.begin_step(&x, 0.01, |_| 0.0, |_| 0.0);
                let y: Vec<Vec3> = x.iter().map(|p| p + Vec3::new(1e-5, 0.0, 0.0)).collect();
                let (e, f) = evaluate(&mut term, &elastic, &y);
                let hu = hessian_product(&mut term, &elastic, &jitter(&x, 1.0));
                let t = term.max_step(&y, &dx);
                let bits = |v: &[Vec3]| {
                    v.iter()
                        .flat_map(|p| p.iter().map(|c| c.to_bits()))
                        .collect::<Vec<_>>()
                };
                (
                    e.to_bits(),
                    bits(&f),
                    bits(&hu),
                    t.to_bits(),
                    term.active_pairs(),
                    term.intersection(&y),
                )
            })
    };
    let one = run(1);
    assert!(one.4 > 0);
    assert_eq!(one, run(2));
}

/// The kept candidate list gives exactly a fresh search's candidates, static and swept, over a
/// random walk of the vertices (small moves reuse it, large ones search again).
#[test]
fn kept_candidates_are_a_fresh_searchs() {
    use rand::{RngExt, SeedableRng};
    let (mesh, body) = stacked(0.004, 0.3, 0.02);
    let term = ContactTerm::new(
        setup(body, 0.01, 0.0, true),
        &mesh,
        &vec![1.0; mesh.positions.len()],
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut x = mesh.positions.clone();
    let mut jiggle = |x: &[Vec3], size: f64| -> Vec<Vec3> {
        x.iter()
            .map(|p| p + size * Vec3::from_fn(|_, _| rng.random_range(-1.0..1.0)))
            .collect()
    };
    for k in 0..40 {
        let size = if k % 10 == 9 { 0.05 } else { 0.003 };
        x = jiggle(&x, size);
        let end = jiggle(&x, size);
        for r in [0.0, 0.01, term.hold_radius()] {
            assert_eq!(
                term.body_candidates(&x, &x, r),
                term.search_body_candidates(&x, &x, r),
                "static, move {k}, r {r}"
            );
            assert_eq!(
                term.body_candidates(&x, &end, r),
                term.search_body_candidates(&x, &end, r),
                "swept, move {k}, r {r}"
            );
        }
    }
    let searches = term.costs().body_searches;
    assert!(
        (2..=60).contains(&searches),
        "the list was searched {searches} times for 240 queries"
    );
}

/// A body wholly inside another crosses no surface, yet is refused, naming both bodies; the
/// same small body beside the big one is not.
#[test]
fn a_body_inside_another_is_refused() {
    for (offset, inside) in [(Vec3::repeat(0.4), true), (Vec3::new(1.5, 0.0, 0.0), false)] {
        let (mesh, body) = boxes(&[
            (Vec3::zeros(), Vec3::repeat(1.0), [2, 2, 2], 0),
            (offset, offset + Vec3::repeat(0.2), [1, 1, 1], 1),
        ]);
        let term = ContactTerm::new(
            setup(body, 0.01, 0.0, false),
            &mesh,
            &vec![1.0; mesh.positions.len()],
        );
        let found = term.intersection(&mesh.positions);
        if inside {
            let message = found.expect("nested bodies refused");
            assert!(
                message.contains("body \"right\" inside body \"left\""),
                "{message}"
            );
        } else {
            assert_eq!(found, None);
        }
    }
}
