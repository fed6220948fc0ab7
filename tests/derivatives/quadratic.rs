//! Quadratic tets: the patch test (a homogeneous deformation reproduced exactly), the assembled matrix and diagonal blocks against the matrix-free product, and
//! the lumped masses.

use super::*;
use tetsim::linear::sparse::BlockCsr;
use tetsim::mesh::quadratic::elevate;

fn curved_body(seed: u64, kind: ModelKind) -> ElasticBody {
    let mut rng = rng(seed);
    let linear = small_mesh(&mut rng);
    let mesh = curved(&mut rng, &elevate(&linear));
    ElasticBody::new(mesh, Model::new(kind, lame()), 1000.0).unwrap()
}

/// Nodes on the boundary of the mesh (corners and mid-edge nodes of boundary faces).
fn boundary_nodes(mesh: &TetMesh) -> Vec<bool> {
    let mut on = vec![false; mesh.positions.len()];
    for f in mesh.boundary_faces() {
        for v in f {
            on[v] = true;
        }
    }
    on
}

/// x = A·X + c on every node of quadratic tets (of an irregular mesh): F = A at every
/// quadrature point, so the energy is V·Ψ(A), and the forces on the nodes inside the body
/// vanish (they balance to rounding); the nodes on the boundary carry the traction P(A)·N.
/// Every model, a stretch with shear and rotation. (Curved elements reproduce F = A too, but
/// their ∫∇Nₐ has a cubic integrand that the 4-point rule of degree 2 integrates only
/// approximately, as in every C3D10-type element: their balance is not to rounding.)
#[test]
fn a_homogeneous_deformation_is_reproduced_exactly() {
    let a = Mat3::new(1.2, 0.1, -0.05, 0.02, 0.9, 0.1, -0.08, 0.04, 1.05);
    let c = Vec3::new(0.3, -0.2, 0.1);
    for kind in ModelKind::ALL {
        let mesh = elevate(&small_mesh(&mut rng(11)));
        let body = ElasticBody::new(mesh, Model::new(kind, lame()), 1000.0).unwrap();
        let x: Vec<Vec3> = body.mesh.positions.iter().map(|p| a * p + c).collect();
        let volume: f64 = (0..body.tet_count())
            .map(|t| body.quadratic().unwrap().volume(t))
            .sum();
        let expected = volume * body.model.energy_density(&a);
        let energy = body.energy(&x);
        assert!(
            (energy - expected).abs() <= 1e-12 * expected.abs(),
            "{kind}: energy {energy} against V·Ψ(A) {expected}"
        );
        let mut f = vec![Vec3::zeros(); x.len()];
        body.add_forces(&x, &mut f);
        let on = boundary_nodes(&body.mesh);
        let scale = body.model.stress(&a).norm() * volume.powf(2.0 / 3.0);
        let inside = (0..x.len()).filter(|&v| !on[v]).collect::<Vec<_>>();
        assert!(!inside.is_empty());
        for v in inside {
            assert!(
                f[v].norm() <= 1e-12 * scale,
                "{kind}: node {v} force {}",
                f[v]
            );
        }
        // Equilibrium: the forces sum to zero.
        let total: Vec3 = f.iter().sum();
        assert!(total.norm() <= 1e-12 * scale, "{kind}: net force {total}");
        for j in body.jacobians(&x) {
            assert!((j - a.determinant()).abs() < 1e-12);
        }
    }
}

/// The assembled K (what the AMG and the direct solver get) equals the matrix-free product, and
/// its diagonal blocks are the Jacobi blocks, at a deformed state with inverted elements.
#[test]
fn assembled_stiffness_and_diagonal_blocks_match_the_product() {
    let body = curved_body(12, ModelKind::NeoHookean);
    let mut rng = rng(13);
    let x = perturbed(&mut rng, &body.mesh.positions, 0.3);
    let n = x.len();
    let mut lin = body.linearize(&x, Definiteness::Projected);
    let pattern = body.stiffness_pattern();
    let mut a = BlockCsr::zeros(pattern);
    let mut work = tetsim::elastic::AssemblyWork::default();
    body.assemble_system(&lin, 1.0, 0.0, &mut a, &mut work);
    for _ in 0..3 {
        let dx = random_field(&mut rng, n);
        let mut product = vec![Vec3::zeros(); n];
        body.apply_stiffness(&mut lin, &dx, &mut product);
        let mut assembled = vec![Vec3::zeros(); n];
        a.multiply(&dx, &mut assembled);
        let scale = product.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for v in 0..n {
            assert!((product[v] - assembled[v]).norm() <= 1e-12 * scale);
        }
    }
    let mut blocks = vec![Mat3::zeros(); n];
    body.stiffness_diagonal_blocks(&lin, &mut blocks);
    for (v, block) in blocks.iter().enumerate() {
        let d = a.diagonal(v);
        assert!((block - d).norm() <= 1e-12 * d.norm().max(1.0), "node {v}");
    }
}

/// Lumped masses: every one positive, corners 1/36 and mid-edge nodes 4/27 of each element's
/// mass (HRZ), summing to ρ·V; the centre of mass is the body's (the same as the consistent
/// mass's).
#[test]
fn lumped_masses_are_positive_and_keep_mass_and_centre() {
    let mesh = elevate(&small_mesh(&mut rng(14)));
    let body = ElasticBody::new(mesh, Model::new(ModelKind::Linear, lame()), 800.0).unwrap();
    let q = body.quadratic().unwrap();
    let volume: f64 = (0..body.tet_count()).map(|t| q.volume(t)).sum();
    let straight: f64 = (0..body.tet_count())
        .map(|t| body.mesh.signed_volume(t).abs())
        .sum();
    assert!((volume - straight).abs() < 1e-12 * straight);
    let m = body.masses();
    assert!(m.iter().all(|&m| m > 0.0));
    let total: f64 = m.iter().sum();
    assert!((total - 800.0 * volume).abs() < 1e-12 * total);
    let centre: Vec3 = m
        .iter()
        .zip(&body.mesh.positions)
        .map(|(m, p)| *m * p)
        .sum::<Vec3>()
        / total;
    let centroid: Vec3 = (0..body.tet_count())
        .map(|t| {
            let c: Vec3 = body.mesh.tets[t]
                .iter()
                .map(|&v| body.mesh.positions[v])
                .sum();
            body.mesh.signed_volume(t).abs() * c / 4.0
        })
        .sum::<Vec3>()
        / straight;
    assert!((centre - centroid).norm() < 1e-12);
}
