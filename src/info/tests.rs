use super::*;

#[test]
fn rest_moduli_recover_e_and_nu_for_every_model() {
    for kind in crate::material::ModelKind::ALL {
        let lame = crate::material::Lame::from_young_poisson(2e6, 0.35);
        let (mu, lambda) = rest_moduli(&Model::new(kind, lame));
        assert!((mu - lame.mu).abs() < 1e-9 * lame.mu, "{kind}: μ {mu}");
        assert!(
            (lambda - lame.lambda).abs() < 1e-9 * lame.lambda,
            "{kind}: λ {lambda}"
        );
    }
}

/// K at rest (all DOFs) as a dense matrix, and the lumped masses per DOF.
fn dense_stiffness(body: &ElasticBody) -> (nalgebra::DMatrix<f64>, Vec<f64>) {
    let n = body.vertex_count();
    let mut lin = body.linearize(&body.mesh.positions, Definiteness::Projected);
    let mut k = nalgebra::DMatrix::zeros(3 * n, 3 * n);
    let (mut e, mut out) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
    for j in 0..3 * n {
        e[j / 3][j % 3] = 1.0;
        body.apply_stiffness(&mut lin, &e, &mut out);
        e[j / 3][j % 3] = 0.0;
        for i in 0..3 * n {
            k[(i, j)] = out[i / 3][i % 3];
        }
    }
    let m = (0..3 * n).map(|i| body.masses()[i / 3]).collect();
    (k, m)
}

/// Eigenvalues of M^-1/2 K M^-1/2 over the DOFs `keep`, ascending.
fn eigenvalues(k: &nalgebra::DMatrix<f64>, m: &[f64], keep: &[usize]) -> Vec<f64> {
    let b = nalgebra::DMatrix::from_fn(keep.len(), keep.len(), |i, j| {
        k[(keep[i], keep[j])] / (m[keep[i]] * m[keep[j]]).sqrt()
    });
    let mut values: Vec<f64> = b.symmetric_eigenvalues().iter().copied().collect();
    values.sort_by(f64::total_cmp);
    values
}

fn cantilever(extra: &str) -> (Scene, Simulation) {
    let text = format!(
        "gravity = [0, -9.81, 0]\n[mesh]\ngenerator = {{ box = {{ min = [0, 0, 0], max = [4, 1, 0.8], cells = [8, 2, 2] }} }}\n\
         [material]\nyoungs_modulus = 2e6\npoisson_ratio = 0.3\ndensity = 1200\n{extra}"
    );
    let scene = Scene::parse(
        &text,
        std::path::Path::new("t.toml"),
        std::path::Path::new("."),
    )
    .unwrap();
    let sim = Simulation::from_scene(&scene).unwrap();
    (scene, sim)
}

#[test]
fn the_frequency_estimate_matches_the_dense_eigenproblem() {
    let (scene, sim) = cantilever("[[fixed]]\nregion = { physical = \"xmin\" }\n");
    let info = describe(&scene, &sim);
    let (k, m) = dense_stiffness(&sim.body);
    let free = sim.boundary.free_mask(sim.body.vertex_count());
    let keep: Vec<usize> = (0..k.nrows())
        .filter(|&i| free[i / 3][i % 3] == 1.0)
        .collect();
    let lowest = eigenvalues(&k, &m, &keep)[0];
    let exact = lowest.sqrt() / (2.0 * std::f64::consts::PI);
    let hz = info.lowest_frequency.hz.unwrap();
    assert!(!info.lowest_frequency.rigid);
    // An upper bound (Rayleigh quotient), and close.
    assert!(hz >= exact * (1.0 - 1e-9), "{hz} < {exact}");
    assert!(
        (hz - exact) / exact < 1e-6,
        "estimate {hz} Hz, exact {exact} Hz"
    );
    // The explicit limit is below the lumped-mass central-difference limit 2/ω_max.
    let all: Vec<usize> = (0..k.nrows()).collect();
    let largest = *eigenvalues(&k, &m, &all).last().unwrap();
    assert!(info.explicit_stability_dt <= 2.0 / largest.sqrt());
    assert!(info.explicit_stability_dt > 0.2 * 2.0 / largest.sqrt());
    // Mass and volume.
    assert!((info.volume - 3.2).abs() < 1e-12);
    assert!((info.mass - 3.2 * 1200.0).abs() < 1e-9);
    let material = &info.materials[0];
    assert!((material.youngs_modulus() - 2e6).abs() < 1e-6);
    assert!(
        (material.p_wave_speed() - ((material.lambda + 2.0 * material.mu) / 1200.0).sqrt()).abs()
            < 1e-12
    );
}

#[test]
fn an_unconstrained_body_is_rigid() {
    let (scene, sim) = cantilever("");
    assert!(describe(&scene, &sim).lowest_frequency.rigid);
    // Fixed in y only: it can still slide in x and z.
    let (scene, sim) =
        cantilever("[[fixed]]\nregion = { physical = \"ymin\" }\ncomponents = [\"y\"]\n");
    let f = describe(&scene, &sim).lowest_frequency;
    assert!(f.rigid, "{f:?}");
    assert_eq!(f.hz, Some(0.0));
}

#[test]
fn a_regular_tet_s_inradius() {
    let x = [
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(1.0, -1.0, -1.0),
        Vec3::new(-1.0, 1.0, -1.0),
        Vec3::new(-1.0, -1.0, 1.0),
    ];
    // Edge a = 2√2, inradius a/(2√6).
    let a = 2.0 * 2f64.sqrt();
    assert!((inradius(&x, &[0, 1, 2, 3]) - a / (2.0 * 6f64.sqrt())).abs() < 1e-14);
}

#[test]
fn numbers_read_as_people_write_them() {
    use super::num;
    assert_eq!(num(4.0), "4");
    assert_eq!(num(0.008), "0.008");
    assert_eq!(num(36.68997), "36.69");
    assert_eq!(num(10.35098), "10.351");
    assert_eq!(num(1.785714e4), "17857.1");
    assert_eq!(num(5e4), "50000");
    assert_eq!(num(2.1e11), "2.1e11");
    assert_eq!(num(-6.669472e-4), "-6.66947e-4");
    assert_eq!(num(0.0), "0");
    assert_eq!(num(-9.81), "-9.81");
}
