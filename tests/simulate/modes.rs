//! Vibration modes (SPEC §13) against an independent dense reference on the same mesh, and the
//! first bending frequency of a slender cantilever against Euler-Bernoulli beam theory.

use nalgebra::{DMatrix, SMatrix, SymmetricEigen};

use super::common::beam24::box_mesh_24;
use tetsim::modes::{ModesParams, VibrationProblem};
use tetsim::{ElasticBody, Lame, Model, ModelKind, TetMesh, Vec3};

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;

/// `mesh` as a body, clamped at x = 0 (every component of the x = 0 face).
fn clamped(mesh: TetMesh, e: f64, nu: f64, rho: f64) -> (ElasticBody, Vec<Vec3>) {
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(e, nu));
    let body = ElasticBody::new(mesh, model, rho).unwrap();
    let free = tetsim::boundary::mask_holding(&body.mesh.positions, |p| p.x == 0.0);
    (body, free)
}

/// The textbook small-strain stiffness of linear tets, `K = Σₑ V·Bᵀ·D·B` with the 6×12
/// strain-displacement matrix B (Voigt, engineering shear strains) and the isotropic D of
/// (E, ν), and the lumped mass ρV/4 per vertex: assembled densely here, sharing no code with
/// tetsim's tangents and assembly.
fn dense_reference(mesh: &TetMesh, e: f64, nu: f64, rho: f64) -> (DMatrix<f64>, Vec<f64>) {
    let n = mesh.positions.len();
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let mut d = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..3 {
        for j in 0..3 {
            d[(i, j)] = lambda;
        }
        d[(i, i)] = lambda + 2.0 * mu;
        d[(i + 3, i + 3)] = mu;
    }
    let mut k = DMatrix::<f64>::zeros(3 * n, 3 * n);
    let mut mass = vec![0.0; n];
    for tet in &mesh.tets {
        let x: [Vec3; 4] = tet.map(|v| mesh.positions[v]);
        // Shape-function gradients: rows 1..3 of the inverse of [[1, x_a]] (4×4).
        let mut c = nalgebra::Matrix4::<f64>::zeros();
        for a in 0..4 {
            c[(a, 0)] = 1.0;
            for k in 0..3 {
                c[(a, k + 1)] = x[a][k];
            }
        }
        let volume = c.determinant().abs() / 6.0;
        let inv = c.try_inverse().unwrap();
        let mut b = SMatrix::<f64, 6, 12>::zeros();
        for a in 0..4 {
            let g = Vec3::new(inv[(1, a)], inv[(2, a)], inv[(3, a)]);
            // ε = [εxx, εyy, εzz, γyz, γxz, γxy].
            b[(0, 3 * a)] = g.x;
            b[(1, 3 * a + 1)] = g.y;
            b[(2, 3 * a + 2)] = g.z;
            b[(3, 3 * a + 1)] = g.z;
            b[(3, 3 * a + 2)] = g.y;
            b[(4, 3 * a)] = g.z;
            b[(4, 3 * a + 2)] = g.x;
            b[(5, 3 * a)] = g.y;
            b[(5, 3 * a + 1)] = g.x;
        }
        let ke = b.transpose() * d * b * volume;
        for a in 0..4 {
            mass[tet[a]] += rho * volume / 4.0;
            for bb in 0..4 {
                for r in 0..3 {
                    for s in 0..3 {
                        k[(3 * tet[a] + r, 3 * tet[bb] + s)] += ke[(3 * a + r, 3 * bb + s)];
                    }
                }
            }
        }
    }
    (k, mass)
}

/// Generalised eigenpairs of (K, M) on the free DOFs by a dense symmetric eigen-decomposition of
/// `M^{-1/2}·K·M^{-1/2}`: ascending eigenvalues and the M-normalised vectors (full length).
fn dense_modes(k: &DMatrix<f64>, mass: &[f64], free: &[Vec3]) -> (Vec<f64>, Vec<Vec<Vec3>>) {
    let dofs: Vec<usize> = (0..3 * mass.len())
        .filter(|&i| free[i / 3][i % 3] == 1.0)
        .collect();
    let s: Vec<f64> = dofs.iter().map(|&i| 1.0 / mass[i / 3].sqrt()).collect();
    let m = dofs.len();
    let a = DMatrix::from_fn(m, m, |i, j| s[i] * k[(dofs[i], dofs[j])] * s[j]);
    let eigen = SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
    let values = order.iter().map(|&i| eigen.eigenvalues[i]).collect();
    let vectors = order
        .iter()
        .map(|&c| {
            let mut v = vec![Vec3::zeros(); mass.len()];
            for (row, &dof) in dofs.iter().enumerate() {
                v[dof / 3][dof % 3] = s[row] * eigen.eigenvectors[(row, c)];
            }
            v
        })
        .collect();
    (values, vectors)
}

fn mass_dot(a: &[Vec3], b: &[Vec3], mass: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(mass)
        .map(|((a, b), m)| m * a.dot(b))
        .sum()
}

#[test]
fn lowest_modes_match_a_dense_reference_on_the_same_mesh_pairs_included() {
    // A square cross-section meshed with the cube's symmetry in every cell: bending in y and
    // in z have one frequency, and both must be found.
    let (e, nu, rho) = (1e5, 0.3, 1000.0);
    let mesh = box_mesh_24(Vec3::new(3.0, 1.0, 1.0), [6, 2, 2]);
    let (body, free) = clamped(mesh, e, nu, rho);
    let (k, mass) = dense_reference(&body.mesh, e, nu, rho);
    for (mine, reference) in body.masses().iter().zip(&mass) {
        assert!((mine - reference).abs() <= 1e-12 * reference);
    }
    let (values, vectors) = dense_modes(&k, &mass, &free);
    let count = 8;
    let mut problem = VibrationProblem::new(&body, &free).unwrap();
    assert_eq!(problem.rigid_count(), 0);
    let modes = problem
        .solve(&ModesParams {
            count,
            ..Default::default()
        })
        .unwrap();
    assert_eq!(modes.modes.len(), count);
    let reference_hz: Vec<f64> = values[..count].iter().map(|l| l.sqrt() / TWO_PI).collect();
    for (i, (mode, want)) in modes.modes.iter().zip(&reference_hz).enumerate() {
        let got = mode.frequency_hz;
        assert!(
            (got - want).abs() <= 1e-4 * want,
            "mode {i}: {got} Hz against the reference {want} Hz\n{reference_hz:?}"
        );
    }
    // The first bending pair: two equal frequencies, both found.
    assert!(
        (reference_hz[1] - reference_hz[0]).abs() <= 1e-9 * reference_hz[0],
        "the reference has no pair: {reference_hz:?}"
    );
    let f = &modes.modes;
    assert!((f[1].frequency_hz - f[0].frequency_hz).abs() <= 1e-6 * f[0].frequency_hz);
    // Shapes: every mode lies in the reference eigenspace of its eigenvalue (for a pair, any
    // basis of the pair's plane is right), M-normalised.
    for (i, mode) in f.iter().enumerate() {
        assert!((mass_dot(&mode.shape, &mode.shape, &mass) - 1.0).abs() < 1e-9);
        let cluster: Vec<usize> = (0..values.len())
            .filter(|&j| (values[j] - values[i]).abs() <= 1e-6 * values[i])
            .collect();
        let inside: f64 = cluster
            .iter()
            .map(|&j| mass_dot(&mode.shape, &vectors[j], &mass).powi(2))
            .sum();
        assert!(
            (inside - 1.0).abs() < 1e-6,
            "mode {i}: only {inside} of its M-norm² lies in the reference eigenspace {cluster:?}"
        );
    }
    // The pair's two shapes are M-orthogonal: two different bending directions.
    assert!(mass_dot(&f[0].shape, &f[1].shape, &mass).abs() < 1e-8);
}

#[test]
fn first_bending_frequency_of_a_slender_cantilever_is_euler_bernoulli_s() {
    // L/h = 10, ν = 0 (no Poisson stiffening at the clamp), 4 cells of 24 tets across. Linear
    // tets are stiff in bending and Euler-Bernoulli ignores shear (about −1 % at L/h = 10): the
    // mesh gives 1.9 % above the formula here (3.8 % with 3 cells across); a loose check.
    let (length, side, e, rho) = (10.0, 1.0, 1e6, 1000.0);
    let mesh = box_mesh_24(Vec3::new(length, side, side), [40, 4, 4]);
    let (body, free) = clamped(mesh, e, 0.0, rho);
    let mut problem = VibrationProblem::new(&body, &free).unwrap();
    let modes = problem
        .solve(&ModesParams {
            count: 2,
            ..Default::default()
        })
        .unwrap();
    let inertia = side.powi(4) / 12.0;
    let area = side * side;
    let euler_bernoulli =
        1.875_f64.powi(2) / TWO_PI * (e * inertia / (rho * area * length.powi(4))).sqrt();
    // Both of the pair: bending in y and in z.
    for mode in &modes.modes {
        let ratio = mode.frequency_hz / euler_bernoulli;
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{} Hz against Euler-Bernoulli's {euler_bernoulli} Hz (ratio {ratio})",
            mode.frequency_hz
        );
    }
}
