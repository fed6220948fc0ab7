//! AMG on the benchmark cantilever: a beam [0,4]×[0,1]×[0,1] of 4n×n×n cubes, Neo-Hookean
//! E = 1e6, ν = 0.3, ρ = 1000, clamped at x = 0, backward-Euler system with h = 1/30, γ = 0.01,
//! linearized at a bent (not rest) state.

use super::level::pseudo_random;
use super::*;
use crate::elastic::{AssemblyWork, ElasticBody};
use crate::linear::cg::{CgParams, CgWorkspace, Jacobi, LinearOperator, conjugate_gradient};
use crate::material::{Definiteness, Lame, Model, ModelKind};
use crate::mesh::generate::box_mesh;

struct System {
    a: BlockCsr,
    positions: Vec<Vec3>,
    free: Vec<Vec3>,
    rhs: Vec<Vec3>,
}

struct Assembled<'a>(&'a BlockCsr);

impl LinearOperator for Assembled<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }
    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

/// The Newton system at a bent state of the beam; `bend` scales the tip deflection (m).
fn beam(n: usize, bend: f64) -> System {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [4 * n, n, n]);
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e6, 0.3));
    let body = ElasticBody::new(mesh, model, 1000.0).unwrap();
    let positions = body.mesh.positions.clone();
    let free: Vec<Vec3> = crate::boundary::mask_holding(&positions, |p| p.x == 0.0);
    let x: Vec<Vec3> = positions
        .iter()
        .map(|p| p - Vec3::new(0.0, bend * (p.x / 4.0).powi(2), 0.0))
        .collect();
    let lin = body.linearize(&x, Definiteness::Projected);
    let h = 1.0 / 30.0;
    let mut a = BlockCsr::zeros(body.stiffness_pattern());
    body.assemble_system(
        &lin,
        1.0 + 0.01 / h,
        1.0 / (h * h),
        &mut a,
        &mut AssemblyWork::default(),
    );
    a.constrain(&free);
    let rhs = body
        .masses()
        .iter()
        .zip(&free)
        .map(|(m, f)| Vec3::new(0.1, -9.81, 0.5).component_mul(f) * *m)
        .collect();
    System {
        a,
        positions,
        free,
        rhs,
    }
}

fn solve(s: &System, m: &mut dyn Preconditioner, tolerance: f64) -> (Vec<Vec3>, usize) {
    let n = s.a.rows();
    let mut x = vec![Vec3::zeros(); n];
    let params = CgParams {
        tolerance,
        max_iterations: 5000,
    };
    let info = conjugate_gradient(
        &mut Assembled(&s.a),
        m,
        &s.rhs,
        &mut x,
        &s.free,
        &params,
        &mut CgWorkspace::new(n),
    )
    .unwrap();
    assert!(info.converged, "{info:?}");
    (x, info.iterations)
}

fn jacobi(a: &BlockCsr) -> Jacobi {
    let blocks: Vec<_> = (0..a.rows()).map(|i| a.diagonal(i)).collect();
    let mut j = Jacobi::default();
    j.set_from_blocks(&blocks);
    j
}

fn test_vector(n: usize, seed: usize, free: &[Vec3]) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            Vec3::from_fn(|c, _| pseudo_random(3 * i + c + 7919 * seed) - 1.0)
                .component_mul(&free[i])
        })
        .collect()
}

#[test]
fn amg_pcg_reaches_the_jacobi_pcg_solution() {
    let s = beam(3, 0.3);
    let (x_jacobi, _) = solve(&s, &mut jacobi(&s.a), 1e-11);
    let mut amg = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
    let (x_amg, _) = solve(&s, &mut amg, 1e-11);
    let scale = x_jacobi.iter().map(|v| v.norm()).fold(0.0, f64::max);
    for (a, b) in x_amg.iter().zip(&x_jacobi) {
        assert!((a - b).norm() <= 1e-8 * scale, "{a} vs {b}");
    }
}

#[test]
fn amg_iterations_are_few_and_grow_slowly_with_the_mesh() {
    let mut counts = Vec::new();
    for n in [3, 6] {
        let s = beam(n, 0.3);
        let mut amg = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
        assert!(amg.info().levels.len() >= 2, "{:?}", amg.info());
        let (_, amg_iterations) = solve(&s, &mut amg, 1e-6);
        let (_, jacobi_iterations) = solve(&s, &mut jacobi(&s.a), 1e-6);
        assert!(amg_iterations < 40, "n = {n}: {amg_iterations} iterations");
        assert!(
            3 * amg_iterations < jacobi_iterations,
            "{amg_iterations} vs {jacobi_iterations}"
        );
        counts.push(amg_iterations);
    }
    // Twice the resolution (8× the DOFs): at most 1.5× the iterations.
    assert!(2 * counts[1] <= 3 * counts[0], "{counts:?}");
}

#[test]
fn v_cycle_is_symmetric_and_positive() {
    let s = beam(3, 0.3);
    let n = s.a.rows();
    let mut amg = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
    let apply = |amg: &mut Amg, r: &[Vec3]| {
        let mut z = vec![Vec3::zeros(); n];
        amg.apply(r, &mut z);
        z
    };
    let dot = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).map(|(x, y)| x.dot(y)).sum::<f64>();
    for seed in 0..4 {
        let u = test_vector(n, 2 * seed, &s.free);
        let v = test_vector(n, 2 * seed + 1, &s.free);
        let (mu, mv) = (apply(&mut amg, &u), apply(&mut amg, &v));
        let (uv, vu) = (dot(&u, &mv), dot(&v, &mu));
        let size = (dot(&u, &mu) * dot(&v, &mv)).sqrt();
        assert!((uv - vu).abs() <= 1e-10 * size, "{uv} vs {vu}");
        assert!(dot(&u, &mu) > 0.0 && dot(&v, &mv) > 0.0);
    }
}

#[test]
fn refresh_matches_a_fresh_build() {
    // Also when A's storage changed since the build (contact holds A in f64 while pairs are
    // present): the coarse levels follow it.
    use Precision::{F32, F64};
    for (built, refreshed) in [(F64, F64), (F32, F32), (F32, F64), (F64, F32)] {
        refresh_case(built, refreshed);
    }
}

fn refresh_case(built: Precision, refreshed_with: Precision) {
    let s = beam(3, 0.0);
    let bent = beam(3, 0.5);
    let (a, bent_a) = (stored_in(&s.a, built), stored_in(&bent.a, refreshed_with));
    let params = AmgParams::default();
    let mut refreshed = Amg::new(&a, &s.positions, &s.free, &params);
    assert_eq!(refreshed.coarse_f32(), built == Precision::F32);
    refreshed.refresh(&bent_a);
    assert_eq!(refreshed.coarse_f32(), refreshed_with == Precision::F32);
    let mut fresh = Amg::new(&bent_a, &s.positions, &s.free, &params);
    assert_eq!(refreshed.info().levels.len(), fresh.info().levels.len());
    let n = s.a.rows();
    let r = test_vector(n, 3, &s.free);
    let (mut z1, mut z2) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
    refreshed.apply(&r, &mut z1);
    fresh.apply(&r, &mut z2);
    // Same aggregates (strength depends on the values, but the bent and straight beams give the
    // same strong graph here), same arithmetic: same bits.
    assert_eq!(z1, z2);
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let s = beam(6, 0.3);
    let bent = beam(6, 0.6);
    let n = s.a.rows();
    assert!(n > 2 * bsr::ROW_CHUNK, "several chunks: {n}");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let mut amg = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
                let r = test_vector(n, 5, &s.free);
                let mut z = vec![Vec3::zeros(); n];
                amg.apply(&r, &mut z);
                amg.refresh(&bent.a);
                let mut z2 = vec![Vec3::zeros(); n];
                amg.apply(&r, &mut z2);
                (z, z2)
            })
    };
    assert_eq!(run(1), run(2));
}

/// The solver's hierarchy keeps no copy of A: applied with the A it was built on it is the
/// hierarchy [`Amg::new`] makes, bit for bit; and what a checkpoint stores of it (aggregates and
/// the finest level's numbers) rebuilds it bit for bit after a refresh, without that A.
#[test]
fn a_shared_hierarchy_matches_a_copying_one_and_is_restored_from_its_numbers() {
    for precision in [Precision::F64, Precision::F32] {
        shared_hierarchy_case(precision);
    }
}

/// `a` stored in `precision`.
fn stored_in(a: &BlockCsr, precision: Precision) -> BlockCsr {
    let mut out = BlockCsr::zeros_in(a.pattern.clone(), precision);
    for k in 0..a.pattern.blocks() {
        out.blocks_mut().set(k, &a.block(k));
    }
    out
}

/// The shared and copying hierarchies agree and a restore gives the same bits, with A (and so
/// the coarse matrices) in `precision`.
fn shared_hierarchy_case(precision: Precision) {
    let [s, bent, more] = [0.0, 0.5, 0.7].map(|bend| {
        let mut system = beam(3, bend);
        system.a = stored_in(&system.a, precision);
        system
    });
    let params = AmgParams::default();
    let n = s.a.rows();
    let r = test_vector(n, 4, &s.free);
    let cycle = |amg: &mut Amg, a: &BlockCsr| {
        let mut z = vec![Vec3::zeros(); n];
        amg.with_matrix(a).apply(&r, &mut z);
        z
    };
    let mut copying = Amg::new(&s.a, &s.positions, &s.free, &params);
    let mut shared = Amg::new_shared(&s.a, &s.positions, &s.free, &params);
    assert!(shared.fine_values().is_none() && copying.fine_values().is_some());
    assert_eq!(cycle(&mut shared, &s.a), cycle(&mut copying, &s.a));
    shared.refresh(&bent.a);
    let numbers = shared.fine_numbers().expect("several levels");
    assert_eq!(numbers.coarse_f32, precision == Precision::F32);
    let mut restored = Amg::restored(
        &s.a.pattern,
        &s.positions,
        &s.free,
        &params,
        &shared.aggregates(),
        &numbers,
    )
    .expect("fits");
    // Applied with a later A (Newton moved on since the refresh): the same bits.
    assert_eq!(cycle(&mut restored, &more.a), cycle(&mut shared, &more.a));
    assert_eq!(restored.info().levels, shared.info().levels);
    // Numbers that do not fit the pattern are refused.
    let mut short = numbers.clone();
    short.prolongator.pop();
    let aggregates = shared.aggregates();
    assert!(
        Amg::restored(
            &s.a.pattern,
            &s.positions,
            &s.free,
            &params,
            &aggregates,
            &short
        )
        .is_none()
    );
}

/// With the current A in its finest level the V-cycle stays symmetric and positive on a matrix
/// it was not refreshed with.
#[test]
fn a_shared_v_cycle_with_a_later_matrix_is_symmetric_and_positive() {
    for precision in [Precision::F64, Precision::F32] {
        symmetric_case(precision);
    }
}

/// [`a_shared_v_cycle_with_a_later_matrix_is_symmetric_and_positive`] with A and the coarse
/// matrices in `precision`.
fn symmetric_case(precision: Precision) {
    let s = beam(3, 0.3);
    let s = System {
        a: stored_in(&s.a, precision),
        ..s
    };
    let later = beam(3, 0.6);
    let later = System {
        a: stored_in(&later.a, precision),
        ..later
    };
    let n = s.a.rows();
    let mut amg = Amg::new_shared(&s.a, &s.positions, &s.free, &AmgParams::default());
    let mut apply = |r: &[Vec3]| {
        let mut z = vec![Vec3::zeros(); n];
        amg.with_matrix(&later.a).apply(r, &mut z);
        z
    };
    let dot = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).map(|(x, y)| x.dot(y)).sum::<f64>();
    for seed in 0..4 {
        let u = test_vector(n, 2 * seed, &s.free);
        let v = test_vector(n, 2 * seed + 1, &s.free);
        let (mu, mv) = (apply(&u), apply(&v));
        let (uv, vu) = (dot(&u, &mv), dot(&v, &mu));
        let size = (dot(&u, &mu) * dot(&v, &mv)).sqrt();
        assert!((uv - vu).abs() <= 1e-10 * size, "{uv} vs {vu}");
        assert!(dot(&u, &mu) > 0.0 && dot(&v, &mv) > 0.0);
    }
}

/// Contact stiffens a few diagonal blocks by orders of magnitude between Newton iterates: the
/// growth the multigrid solver watches sees it, a stale hierarchy then preconditions badly, and
/// a refresh brings the growth back to 1 and the iterations back down.
#[test]
fn diagonal_growth_sees_stiffened_blocks_and_a_refresh_clears_it() {
    let s = beam(3, 0.3);
    let mut amg = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
    let g = amg
        .diagonal_growth(&s.a)
        .expect("a multilevel hierarchy keeps D⁻¹");
    assert!((g - 1.0).abs() < 1e-9, "{g}");
    // A barrier block κ·n·nᵀ, 1000 times the elastic diagonal, on a few free vertices.
    let mut stiff = s.a.clone();
    let touching: Vec<usize> = (0..s.a.rows())
        .filter(|&i| s.free[i] == Vec3::repeat(1.0))
        .step_by(7)
        .take(4)
        .collect();
    for &i in &touching {
        let k = stiff.pattern.find(i, i).unwrap();
        let kappa = 1e3 * s.a.diagonal(i).norm();
        stiff
            .blocks_mut()
            .add(k, &(kappa * Vec3::y() * Vec3::y().transpose()));
    }
    let g = amg.diagonal_growth(&stiff).unwrap();
    assert!(g > 100.0, "{g}");
    let stiff_system = System {
        a: stiff.clone(),
        positions: s.positions.clone(),
        free: s.free.clone(),
        rhs: s.rhs.clone(),
    };
    let mut stale = Amg::new(&s.a, &s.positions, &s.free, &AmgParams::default());
    let stale_iterations = {
        let params = CgParams {
            tolerance: 1e-6,
            max_iterations: 5000,
        };
        let n = stiff.rows();
        let mut x = vec![Vec3::zeros(); n];
        let info = conjugate_gradient(
            &mut Assembled(&stiff),
            &mut stale,
            &stiff_system.rhs,
            &mut x,
            &stiff_system.free,
            &params,
            &mut CgWorkspace::new(n),
        );
        super::super::info_of(&info).iterations
    };
    amg.refresh(&stiff);
    let g = amg.diagonal_growth(&stiff).unwrap();
    assert!((g - 1.0).abs() < 1e-9, "{g}");
    let (_, fresh_iterations) = solve(&stiff_system, &mut amg, 1e-6);
    assert!(
        3 * fresh_iterations <= 2 * stale_iterations,
        "refreshed {fresh_iterations} against stale {stale_iterations}"
    );
}
