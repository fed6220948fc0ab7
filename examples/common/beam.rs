//! The bench beam of the cost examples: the benchmark cantilever (4n×n×n Kuhn cubes, Neo-Hookean
//! E = 1e6 Pa, ν = 0.3, 1000 kg/m³) and a bent state like its sag.

use tetsim::Vec3;
use tetsim::elastic::ElasticBody;
use tetsim::material::{Lame, Model, ModelKind};
use tetsim::mesh::generate::box_mesh;

/// The beam at mesh size `n` and its vertices bent down by 0.3 m at the tip, quadratically.
pub fn bent_beam(n: usize) -> (ElasticBody, Vec<Vec3>) {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [4 * n, n, n]);
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e6, 0.3));
    let body = ElasticBody::new(mesh, model, 1000.0).unwrap();
    let x = body
        .mesh
        .positions
        .iter()
        .map(|p| p - Vec3::new(0.0, 0.3 * (p.x / 4.0).powi(2), 0.0))
        .collect();
    (body, x)
}
