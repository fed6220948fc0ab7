use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::material::{Lame, ModelKind, shifted_deformation};
use crate::mesh::generate::box_mesh;

/// The element loops make their SVDs four at a time; every tet must still get exactly what
/// the per-tet kernels give (the same bits), over two chunks with a short last group, with
/// inverted tets and a linear-elastic region (no SVD) among Neo-Hookean tets.
#[test]
fn batched_loops_match_the_per_tet_kernels() {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(7.0, 5.0, 3.0), [7, 5, 3]);
    assert!(mesh.tets.len() > CHUNK && !mesh.tets.len().is_multiple_of(LANES));
    let lame = Lame::from_young_poisson(1e6, 0.3);
    let linear = MaterialRegion {
        model: Model::new(ModelKind::Linear, lame),
        density: 1000.0,
        tets: (0..mesh.tets.len()).step_by(7).collect(),
    };
    let model = Model::new(ModelKind::NeoHookean, lame);
    let body = ElasticBody::with_regions(mesh, model, 1000.0, vec![linear]).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let mut next = move || rng.random_range(-0.5..0.5);
    let x: Vec<Vec3> = body
        .mesh
        .positions
        .iter()
        .map(|p| p + 1.2 * Vec3::new(next(), next(), next()))
        .collect();
    let v: Vec<Vec3> = x
        .iter()
        .map(|_| Vec3::new(next(), next(), next()))
        .collect();
    assert!(body.deformation_stats(&x).inverted > 0);
    let n = body.vertex_count();
    let (mut forces, mut kv) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);

    let mut lin = Linearization::new(&body, Definiteness::Projected);
    let energy = body.linearize_into(&x, &mut lin, &mut forces);
    let mut expected = 0.0;
    for chunk in (0..body.tet_count()).collect::<Vec<_>>().chunks(CHUNK) {
        let mut sum = 0.0;
        for &t in chunk {
            let f = body.deformation_gradient(&x, t);
            let (psi, _, tangent) = body.model_of(t).evaluate(&f, Definiteness::Projected);
            assert_eq!(lin.tangents()[t], tangent, "tet {t}");
            sum += body.volume[t] * psi;
        }
        expected += sum;
    }
    assert_eq!(energy.to_bits(), expected.to_bits());

    for shift in [0.0, 0.05] {
        let damping = Damping {
            velocities: &v,
            stiffness: DampingStiffness::Projected,
            shift,
            weight: 0.3,
        };
        let how = damping.tangent(Definiteness::Adaptive);
        let mut lin = Linearization::new(&body, Definiteness::Adaptive);
        body.linearize_damped_into(&x, &damping, &mut lin, &mut forces, &mut kv);
        for t in 0..body.tet_count() {
            let f = body.deformation_gradient(&x, t);
            let df_v = TetMesh::edge_matrix(&v, &body.mesh.tets[t]) * body.bm[t];
            let g = shifted_deformation(&f, &df_v, shift);
            let (tangent, _) = body.model_of(t).damped_tangent(&g, &how);
            assert_eq!(lin.tangents()[t], tangent, "tet {t}, shift {shift}");
        }
    }
    // The forces are those of the per-tet stresses.
    let mut reference = vec![Vec3::zeros(); n];
    body.add_forces(&x, &mut reference);
    let mut lin = Linearization::new(&body, Definiteness::Projected);
    body.linearize_into(&x, &mut lin, &mut forces);
    assert_eq!(forces, reference);
}
