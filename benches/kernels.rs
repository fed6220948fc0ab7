//! Kernel benchmarks: per-model P and dP, `evaluate` per definiteness strategy, and the mesh-level force evaluation, linearization and
//! stiffness product on a beam of 4n×n×n Kuhn cubes (n = 20: 192,000 tets).
//!
//! `cargo bench --bench kernels`; per-tet figures are the reported time divided by the tet count
//! (criterion prints throughput in elements/s).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use tetsim::mesh::generate::box_mesh;
use tetsim::{
    Definiteness, ElasticBody, Lame, Linearization, Mat3, Material, Model, ModelKind, Vec3,
};

fn deformed(positions: &[Vec3]) -> Vec<Vec3> {
    // A smooth bend and twist, so SVDs see generic F.
    positions
        .iter()
        .map(|p| {
            let a = 0.2 * p.x;
            Vec3::new(
                p.x,
                p.y * a.cos() - p.z * a.sin() - 0.05 * p.x * p.x,
                p.y * a.sin() + p.z * a.cos(),
            )
        })
        .collect()
}

fn material(c: &mut Criterion) {
    let lame = Lame::from_young_poisson(1e6, 0.3);
    let f = Mat3::new(1.1, 0.2, -0.1, 0.05, 0.9, 0.3, -0.2, 0.1, 1.2);
    let df = Mat3::new(0.3, -0.1, 0.2, 0.4, 0.1, -0.3, 0.2, 0.5, 0.1);
    let mut group = c.benchmark_group("material");
    for kind in ModelKind::ALL {
        let model = Model::new(kind, lame);
        group.bench_function(format!("{}/stress", kind.name()), |b| {
            b.iter(|| model.stress(black_box(&f)))
        });
        group.bench_function(format!("{}/evaluate", kind.name()), |b| {
            b.iter(|| model.evaluate(black_box(&f), Definiteness::Projected))
        });
        let tangent = model.tangent(&f, Definiteness::Projected);
        group.bench_function(format!("{}/tangent_apply", kind.name()), |b| {
            b.iter(|| tangent.apply(black_box(&df)))
        });
    }
    group.bench_function("svd_rv", |b| b.iter(|| tetsim::math::svd_rv(black_box(&f))));
    group.finish();
}

/// `evaluate` per definiteness strategy at a compressed, sheared F where the exact tangent is
/// indefinite (so the fixes do work), for a model with and one without a closed-form block.
fn definiteness(c: &mut Criterion) {
    let lame = Lame::from_young_poisson(1e6, 0.45);
    let f = Mat3::new(0.6, 0.3, -0.1, 0.05, 0.5, 0.3, -0.2, 0.1, 0.7);
    let mut group = c.benchmark_group("definiteness");
    for kind in [ModelKind::Corotated, ModelKind::StableNeoHookean] {
        let model = Model::new(kind, lame);
        for d in Definiteness::ALL {
            group.bench_function(format!("{}/{}", kind.name(), d.name()), |b| {
                b.iter(|| model.evaluate(black_box(&f), d))
            });
        }
    }
    group.finish();
}

fn mesh_kernels(c: &mut Criterion) {
    let n = 20;
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [4 * n, n, n]);
    let x = deformed(&mesh.positions);
    let body = ElasticBody::new(
        mesh,
        Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e6, 0.3)),
        1000.0,
    )
    .unwrap();
    let tets = body.tet_count() as u64;
    let mut forces = vec![Vec3::zeros(); x.len()];
    let mut lin = Linearization::new(&body, Definiteness::Projected);
    let mut group = c.benchmark_group(format!("mesh_{tets}_tets"));
    group.throughput(Throughput::Elements(tets));
    group.sample_size(20);
    group.bench_function("add_forces", |b| {
        b.iter(|| {
            forces.iter_mut().for_each(|f| *f = Vec3::zeros());
            body.add_forces(&x, &mut forces)
        })
    });
    group.bench_function("linearize", |b| {
        b.iter(|| body.linearize_into(&x, &mut lin, &mut forces))
    });
    let dx = deformed(&body.mesh.positions);
    let mut out = vec![Vec3::zeros(); x.len()];
    group.bench_function("apply_stiffness", |b| {
        b.iter(|| body.apply_stiffness(&mut lin, &dx, &mut out))
    });
    group.finish();
}

criterion_group!(benches, material, definiteness, mesh_kernels);
criterion_main!(benches);
