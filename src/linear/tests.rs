//! Every strategy on a system whose pattern grows and shrinks between solves, as contact
//! makes it: the answers stay right, and the assembled strategies rebuild exactly when the
//! pattern changed.

use super::*;

/// Vertices on a 3D lattice coupled to their lattice neighbours (springs along every axis),
/// a mass on the diagonal, and extra springs between far-apart pairs (the "contacts").
struct Springs {
    positions: Vec<Vec3>,
    edges: Vec<(usize, usize)>,
    extra: Vec<(usize, usize)>,
    pattern: BlockPattern,
    generation: u64,
    /// Scales every spring (the mass stays [`MASS`]).
    stiffness: f64,
    /// What [`System::needs_f64`] says.
    needs_f64: bool,
    /// What [`System::may_need_f64`] says.
    may_need_f64: bool,
}

impl Springs {
    fn new(side: usize) -> Self {
        let index = |i: usize, j: usize, k: usize| (i * side + j) * side + k;
        let mut positions = Vec::new();
        let mut edges = Vec::new();
        for i in 0..side {
            for j in 0..side {
                for k in 0..side {
                    positions.push(Vec3::new(i as f64, j as f64, k as f64));
                    if i + 1 < side {
                        edges.push((index(i, j, k), index(i + 1, j, k)));
                    }
                    if j + 1 < side {
                        edges.push((index(i, j, k), index(i, j + 1, k)));
                    }
                    if k + 1 < side {
                        edges.push((index(i, j, k), index(i, j, k + 1)));
                    }
                }
            }
        }
        let mut s = Springs {
            positions,
            edges,
            extra: Vec::new(),
            pattern: BlockPattern::default(),
            generation: 0,
            stiffness: 1.0,
            needs_f64: false,
            may_need_f64: false,
        };
        s.set_extra(Vec::new());
        s
    }

    fn set_extra(&mut self, extra: Vec<(usize, usize)>) {
        self.extra = extra;
        let n = self.positions.len();
        let mut rows: Vec<Vec<u32>> = (0..n).map(|i| vec![i as u32]).collect();
        for &(i, j) in self.edges.iter().chain(&self.extra) {
            rows[i].push(j as u32);
            rows[j].push(i as u32);
        }
        rows.iter_mut().for_each(|r| {
            r.sort_unstable();
            r.dedup()
        });
        self.pattern = BlockPattern::from_rows(&rows);
        self.generation += 1;
    }

    /// The block of spring (i, j): stiff along the spring, soft across it.
    fn block(&self, i: usize, j: usize, stiffness: f64) -> Mat3 {
        let d = (self.positions[j] - self.positions[i]).normalize();
        self.stiffness * stiffness * (d * d.transpose() + 0.1 * Mat3::identity())
    }

    fn springs(&self) -> impl Iterator<Item = (usize, usize, Mat3)> + '_ {
        let edges = self
            .edges
            .iter()
            .map(|&(i, j)| (i, j, self.block(i, j, 1.0)));
        let extra = self
            .extra
            .iter()
            .map(|&(i, j)| (i, j, self.block(i, j, 5.0)));
        edges.chain(extra)
    }
}

const MASS: f64 = 0.01;

impl System for Springs {
    fn len(&self) -> usize {
        self.positions.len()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        for (o, p) in out.iter_mut().zip(p) {
            *o = MASS * p;
        }
        for (i, j, k) in self.springs() {
            let f = k * (p[i] - p[j]);
            out[i] += f;
            out[j] -= f;
        }
    }

    fn diagonal_blocks(&mut self, out: &mut [Mat3]) {
        out.iter_mut()
            .for_each(|b| *b = Mat3::from_diagonal_element(MASS));
        for (i, j, k) in self.springs() {
            out[i] += k;
            out[j] += k;
        }
    }

    fn pattern(&self) -> SystemPattern<'_> {
        SystemPattern {
            pattern: &self.pattern,
            generation: self.generation,
        }
    }

    fn assemble(&mut self, a: &mut BlockCsr) {
        assert_eq!(a.pattern, self.pattern);
        a.blocks_mut().fill_zero();
        a.add_diagonal(&vec![MASS; self.len()]);
        for (i, j, k) in self.springs() {
            let at = |r, c| a.pattern.find(r, c).expect("in the pattern");
            let (ii, jj, ij, ji) = (at(i, i), at(j, j), at(i, j), at(j, i));
            let mut blocks = a.blocks_mut();
            blocks.add(ii, &k);
            blocks.add(jj, &k);
            blocks.add(ij, &-k);
            blocks.add(ji, &-k);
        }
    }

    fn rest_positions(&self) -> &[Vec3] {
        &self.positions
    }

    fn is_projected(&self) -> bool {
        true
    }

    fn needs_f64(&self) -> bool {
        self.needs_f64
    }

    fn may_need_f64(&self) -> bool {
        self.may_need_f64
    }
}

fn strategies() -> Vec<PreconditionerKind> {
    vec![
        PreconditionerKind::Identity,
        PreconditionerKind::Jacobi,
        PreconditionerKind::BlockJacobi,
        PreconditionerKind::Amg,
        #[cfg(feature = "direct")]
        PreconditionerKind::Cholesky,
    ]
}

#[test]
fn every_strategy_follows_a_pattern_that_grows_and_shrinks() {
    let side = 8;
    let n = side * side * side;
    // Contacts between opposite faces of the lattice: new blocks far from the diagonal.
    let far = |count: usize, offset: usize| -> Vec<(usize, usize)> {
        (0..count)
            .map(|c| (c + offset, n - 1 - c - offset))
            .collect()
    };
    let steps = [
        Vec::new(),
        far(20, 0),
        far(40, 3),
        far(5, 1),
        far(5, 1),
        Vec::new(),
    ];
    for kind in strategies() {
        let params = LinearSolverParams {
            kind,
            amg: amg::AmgParams::default(),
            f32_matrix: false,
            // f64: the true residual is checked to 1e-8.
            matrix_precision: sparse::Precision::F64,
            cholesky_reuse: true,
        };
        let mut solver = make_solver(&params, n);
        let mut system = Springs::new(side);
        let mut free = vec![Vec3::repeat(1.0); n];
        free[0] = Vec3::zeros();
        let cg = CgParams {
            tolerance: 1e-10,
            max_iterations: 5000,
        };
        let mut changes = 0;
        let mut last = None;
        for (step, extra) in steps.iter().enumerate() {
            if last.as_ref() != Some(extra) {
                system.set_extra(extra.clone());
                changes += usize::from(step > 0);
            }
            last = Some(extra.clone());
            let b: Vec<Vec3> = (0..n)
                .map(|i| Vec3::new((i % 7) as f64, 1.0, -((i % 3) as f64)).component_mul(&free[i]))
                .collect();
            solver.prepare(&mut system, &free);
            let mut x = vec![Vec3::zeros(); n];
            let info = solver
                .solve(&mut system, &b, &mut x, &free, &cg)
                .unwrap_or_else(|e| panic!("{kind:?}, step {step}: {e}"));
            assert!(info.converged, "{kind:?}, step {step}: {info:?}");
            // The true residual of the constrained system, by the matrix-free product.
            let mut ax = vec![Vec3::zeros(); n];
            system.apply(&x, &mut ax);
            let residual: f64 = (0..n)
                .map(|i| (b[i] - ax[i]).component_mul(&free[i]).norm_squared())
                .sum::<f64>()
                .sqrt();
            let norm: f64 = b.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt();
            assert!(
                residual <= 1e-8 * norm,
                "{kind:?}, step {step}: residual {residual:e} of {norm:e}"
            );
        }
        let report = solver.report();
        if matches!(kind, PreconditionerKind::Amg) {
            assert_eq!(report.pattern_changes, changes, "{kind:?}: {report:?}");
        }
        #[cfg(feature = "direct")]
        if matches!(kind, PreconditionerKind::Cholesky) {
            assert_eq!(report.pattern_changes, changes, "{kind:?}: {report:?}");
        }
    }
}

/// The f32 multigrid strategy, every DOF free, a right-hand side and CG to `tolerance`, for
/// `n` vertices.
fn multigrid_case(
    n: usize,
    tolerance: f64,
) -> (LinearSolverParams, Vec<Vec3>, Vec<Vec3>, CgParams) {
    let params = LinearSolverParams {
        kind: PreconditionerKind::Amg,
        amg: amg::AmgParams::default(),
        f32_matrix: false,
        matrix_precision: sparse::Precision::F32,
        cholesky_reuse: true,
    };
    let b = (0..n)
        .map(|i| Vec3::new(1.0, (i % 5) as f64, 0.5))
        .collect();
    let cg = CgParams {
        tolerance,
        max_iterations: 5000,
    };
    (params, vec![Vec3::repeat(1.0); n], b, cg)
}

/// A resumed run numbers its first pattern with the checkpoint's generation: the multigrid
/// strategy must see whether the pattern behind that number is still the one it stored
/// (contact pairs may have changed it at the step's start), and rebuild exactly when not.
#[test]
fn a_restored_multigrid_rebuilds_when_the_pattern_behind_its_generation_changed() {
    let side = 6;
    let n = side * side * side;
    let (params, free, b, cg) = multigrid_case(n, 1e-10);
    let mut system = Springs::new(side);
    system.set_extra(vec![(0, n - 1), (1, n - 2)]);
    let mut solver = make_solver(&params, n);
    solver.prepare(&mut system, &free);
    let mut x = vec![Vec3::zeros(); n];
    solver.solve(&mut system, &b, &mut x, &free, &cg).unwrap();
    let saved = solver.save_state();
    let generation = system.generation;
    for (extra, rebuilt) in [(vec![(0, n - 1), (1, n - 2)], 0), (vec![(2, n - 3)], 1)] {
        let mut resumed = make_solver(&params, n);
        resumed.restore_state(&saved, &system.positions).unwrap();
        let before = resumed.report().pattern_changes;
        system.set_extra(extra);
        system.generation = generation;
        resumed.prepare(&mut system, &free);
        let mut x = vec![Vec3::zeros(); n];
        let info = resumed.solve(&mut system, &b, &mut x, &free, &cg).unwrap();
        assert!(info.converged, "{info:?}");
        assert_eq!(resumed.report().pattern_changes - before, rebuilt);
    }
}

#[test]
fn a_breakdown_on_the_f32_matrix_of_a_definite_system_goes_on_in_f64_and_is_kept() {
    // Springs 1e7 times stiffer than their masses: A = M + K is positive definite, but A's
    // f32 rounding (6e-8 of 1e7) swamps the mass term along the rigid translations.
    let side = 6;
    let n = side * side * side;
    let (params, free, b, cg) = multigrid_case(n, 1e-6);
    let mut system = Springs::new(side);
    system.stiffness = 1e7;
    let mut solver = make_solver(&params, n);
    let fell_back = |solver: &dyn LinearSolver| match solver.save_state() {
        state::SolverState::Multigrid(s) => s.f64_fallback,
        other => panic!("{other:?}"),
    };
    assert!(!fell_back(&*solver));
    solver.prepare(&mut system, &free);
    let mut x = vec![Vec3::zeros(); n];
    let info = solver.solve(&mut system, &b, &mut x, &free, &cg).unwrap();
    assert!(info.converged, "{info:?}");
    assert!(
        fell_back(&*solver),
        "the f32 solve broke down and went on in f64"
    );
    // The true residual, by the f64 matrix-free product.
    let mut ax = vec![Vec3::zeros(); n];
    system.apply(&x, &mut ax);
    let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|c| c * c).sum::<f64>().sqrt();
    let residual = norm(
        &mut b
            .iter()
            .zip(&ax)
            .flat_map(|(b, a)| (b - a).iter().copied().collect::<Vec<_>>()),
    );
    let b_norm = norm(&mut b.iter().flat_map(|v| v.iter().copied().collect::<Vec<_>>()));
    assert!(residual <= 1e-5 * b_norm, "{residual:e} of {b_norm:e}");
    // A checkpoint keeps the f64 matrix.
    let mut resumed = make_solver(&params, n);
    resumed
        .restore_state(&solver.save_state(), &system.positions)
        .unwrap();
    assert!(fell_back(&*resumed));
}

#[test]
fn an_f32_matrix_is_stored_in_f64_while_the_system_needs_it_without_a_new_pattern() {
    let mut system = Springs::new(4);
    let n = system.len();
    let free = vec![Vec3::repeat(1.0); n];
    let mut exact = BlockCsr::zeros(system.pattern.clone());
    system.assemble(&mut exact);
    let mut m = AssembledMatrix::new(false, sparse::Precision::F32);
    assert!(
        m.assemble(&mut system, &free),
        "the first assembly is a new pattern"
    );
    let stored = |m: &AssembledMatrix| m.a.as_ref().unwrap().precision();
    assert_eq!(stored(&m), sparse::Precision::F32);
    for (needs_f64, precision) in [
        (true, sparse::Precision::F64),
        (false, sparse::Precision::F32),
    ] {
        system.needs_f64 = needs_f64;
        assert!(!m.assemble(&mut system, &free), "same pattern");
        assert_eq!(stored(&m), precision);
        let a = m.a.as_ref().unwrap();
        for k in 0..a.pattern.blocks() {
            let (got, want) = (a.block(k), exact.block(k));
            match precision {
                sparse::Precision::F64 => assert_eq!(got, want, "block {k}"),
                // Each addition rounded once to f32.
                sparse::Precision::F32 => assert!(
                    (got - want).amax() <= 1e-6 * want.amax(),
                    "block {k}: {got} against {want}"
                ),
            }
        }
    }
    m.use_f64();
    assert!(!m.assemble(&mut system, &free), "same pattern");
    assert_eq!(
        stored(&m),
        sparse::Precision::F64,
        "whatever the system says"
    );
}

/// On an f32 A the multigrid keeps its coarse matrices in f32 only while the system can hold no
/// contact ([`System::may_need_f64`]); its state records which.
#[test]
fn coarse_levels_are_f32_only_for_a_system_without_contact() {
    for may_need_f64 in [false, true] {
        let mut system = Springs::new(9);
        system.may_need_f64 = may_need_f64;
        let n = system.len();
        let (params, ..) = multigrid_case(n, 1e-8);
        let free = vec![Vec3::repeat(1.0); n];
        let mut solver = make_solver(&params, n);
        solver.prepare(&mut system, &free);
        let coarse_f32 = match solver.save_state() {
            state::SolverState::Multigrid(s) => s.hierarchy.expect("built").coarse_f32,
            other => panic!("{other:?}"),
        };
        assert_eq!(coarse_f32, !may_need_f64, "may need f64: {may_need_f64}");
    }
}
