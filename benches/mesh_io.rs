//! Mesh reading speed: a 1,008,000-tet box (100×40×42 Kuhn cubes, 177,023 vertices) written to
//! a temp dir in every format, then read back. Each iteration reads one file, so the reported
//! time per iteration is ≈ seconds per million tets (criterion's throughput line gives tets/s).
//!
//! `cargo bench --bench mesh_io`. `read/*` is the format reader alone; `read_mesh/*` adds the
//! common steps (unused-vertex check, reorientation, the mesh doctor); `diagnose` is the doctor
//! alone.

use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use tetsim::Vec3;
use tetsim::io::gmsh::{self, Version};
use tetsim::io::vtu::{VtuOptions, write_vtu_with};
use tetsim::io::{self, parse_mesh, read_mesh};
use tetsim::mesh::doctor::diagnose;
use tetsim::mesh::generate::box_mesh;

fn mesh_io(c: &mut Criterion) {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.6, 1.68), [100, 40, 42]);
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name);
    gmsh::write(&at("ascii41.msh"), &mesh, Version::V41, false).unwrap();
    gmsh::write(&at("binary41.msh"), &mesh, Version::V41, true).unwrap();
    gmsh::write(&at("ascii22.msh"), &mesh, Version::V22, false).unwrap();
    io::vtk::write(&at("ascii.vtk"), &mesh, false).unwrap();
    io::vtk::write(&at("binary.vtk"), &mesh, true).unwrap();
    let vtu = |name: &str, options| {
        write_vtu_with(&at(name), &mesh.positions, &mesh.tets, &[], &[], options).unwrap()
    };
    vtu("raw.vtu", VtuOptions::default());
    vtu(
        "base64_zlib.vtu",
        VtuOptions {
            base64: true,
            zlib: true,
        },
    );
    io::tetgen::write(&at("mesh.node"), &mesh).unwrap();
    io::medit::write(&at("mesh.mesh"), &mesh).unwrap();

    let mut group = c.benchmark_group("mesh_io");
    group.sample_size(10);
    group.throughput(Throughput::Elements(mesh.tets.len() as u64));
    for name in [
        "ascii41.msh",
        "binary41.msh",
        "ascii22.msh",
        "ascii.vtk",
        "binary.vtk",
        "raw.vtu",
        "base64_zlib.vtu",
        "mesh.node",
        "mesh.mesh",
    ] {
        let path = at(name);
        let mb = std::fs::metadata(&path).unwrap().len() as f64 / 1e6;
        eprintln!("{name}: {mb:.0} MB");
        group.bench_function(format!("read/{name}"), |b| {
            b.iter(|| parse_mesh(Path::new(&path)).unwrap())
        });
    }
    for name in ["binary41.msh", "raw.vtu"] {
        let path = at(name);
        group.bench_function(format!("read_mesh/{name}"), |b| {
            b.iter(|| read_mesh(Path::new(&path)).unwrap())
        });
    }
    group.bench_function("diagnose", |b| b.iter(|| diagnose(&mesh)));
    group.finish();
}

criterion_group!(benches, mesh_io);
criterion_main!(benches);
