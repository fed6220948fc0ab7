//! Isosurface stuffing on surfaces made here (sphere, cube, torus) and on the boundary of a
//! fixture mesh: no inverted tet, dihedral angles inside the bound of Labelle & Shewchuk's
//! uniform lattice, volume within a tolerance that shrinks with the size, the boundary within a
//! size of the surface; holes tolerated, open sheets and impossible sizes refused.

use std::f64::consts::PI;

use tetsim::io::obj::TriangleSurface;
use tetsim::mesh::stuff::measure::{Quality, assess};
use tetsim::mesh::stuff::{StuffError, StuffParams, tetrahedralize};
use tetsim::{TetMesh, Vec3};

/// The paper's proven dihedral bounds for the uniform BCC lattice with its α values, degrees.
const MIN_ANGLE: f64 = 10.7;
const MAX_ANGLE: f64 = 164.8;

/// A unit sphere: an icosahedron subdivided `levels` times, projected, outward oriented.
pub fn icosphere(levels: usize) -> TriangleSurface {
    let (positions, faces) = tetsim::mesh::generate::icosphere(levels);
    TriangleSurface { positions, faces }
}

/// An axis-aligned box with its corner at `min`, outward oriented.
pub fn cube(min: Vec3, side: f64) -> TriangleSurface {
    let positions = (0..8)
        .map(|c| {
            min + Vec3::new(
                (c & 1) as f64 * side,
                ((c >> 1) & 1) as f64 * side,
                ((c >> 2) & 1) as f64 * side,
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let faces = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    TriangleSurface { positions, faces }
}

/// A torus of radii `big` and `small` about z, `n` × `m` quads split in two.
pub fn torus(big: f64, small: f64, n: usize, m: usize) -> TriangleSurface {
    let mut positions = Vec::new();
    for i in 0..n {
        let u = 2.0 * PI * i as f64 / n as f64;
        for j in 0..m {
            let v = 2.0 * PI * j as f64 / m as f64;
            let r = big + small * v.cos();
            positions.push(Vec3::new(r * u.cos(), r * u.sin(), small * v.sin()));
        }
    }
    let id = |i: usize, j: usize| (i % n) * m + (j % m);
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    TriangleSurface { positions, faces }
}

fn mesh(surface: &TriangleSurface, size: f64) -> (TetMesh, Quality) {
    let (mesh, _) = tetrahedralize(surface, &StuffParams::with_size(size)).unwrap();
    let quality = assess(&mesh, surface);
    (mesh, quality)
}

/// The checks every stuffed mesh passes.
fn assert_sound(name: &str, q: &Quality, size: f64, volume_tolerance: f64) {
    assert_eq!(q.inverted, 0, "{name}: inverted tets");
    assert!(
        q.min_dihedral > MIN_ANGLE && q.max_dihedral < MAX_ANGLE,
        "{name} at {size}: dihedral angles {:.2}..{:.2}",
        q.min_dihedral,
        q.max_dihedral
    );
    assert!(
        q.volume_error() < volume_tolerance,
        "{name} at {size}: volume error {:.4}",
        q.volume_error()
    );
    assert!(
        q.hausdorff() < size,
        "{name} at {size}: Hausdorff {:.4} ≥ h",
        q.hausdorff()
    );
}

#[test]
fn sphere_meshes_within_the_bounds_and_converges_in_volume() {
    let sphere = icosphere(3);
    let (_, coarse) = mesh(&sphere, 0.25);
    let (fine_mesh, fine) = mesh(&sphere, 0.125);
    assert_sound("sphere", &coarse, 0.25, 0.05);
    assert_sound("sphere", &fine, 0.125, 0.02);
    assert!(fine.volume_error() < coarse.volume_error());
    assert!(fine.hausdorff() < coarse.hausdorff());
    // Every tet uses existing vertices, and every vertex a tet.
    let mut used = vec![false; fine_mesh.positions.len()];
    for t in &fine_mesh.tets {
        for &v in t {
            used[v] = true;
        }
    }
    assert!(used.iter().all(|&u| u));
}

#[test]
fn cube_aligned_with_the_lattice_meshes_within_the_bounds() {
    // Faces on lattice planes put lattice points exactly on the surface.
    let c = cube(Vec3::zeros(), 1.0);
    for size in [0.25, 0.125] {
        let (_, q) = mesh(&c, size);
        assert_sound("cube", &q, size, 0.06);
    }
}

#[test]
fn torus_meshes_within_the_bounds_and_keeps_its_hole() {
    let t = torus(1.0, 0.4, 48, 24);
    let (m, q) = mesh(&t, 0.12);
    assert_sound("torus", &q, 0.12, 0.06);
    // No tet crosses the hole: no vertex near the axis.
    assert!(
        m.positions
            .iter()
            .all(|p| (p.x * p.x + p.y * p.y).sqrt() > 0.5)
    );
}

#[test]
fn an_inward_facing_surface_gives_the_same_mesh() {
    let sphere = icosphere(2);
    let mut inward = sphere.clone();
    for f in &mut inward.faces {
        f.swap(1, 2);
    }
    let (a, _) = tetrahedralize(&sphere, &StuffParams::with_size(0.3)).unwrap();
    let (b, info) = tetrahedralize(&inward, &StuffParams::with_size(0.3)).unwrap();
    assert!(info.flipped);
    // The same classification; winding numbers differ only in the last bits (a reversed
    // triangle's moment is computed with its edges in the other order).
    assert_eq!(a.tets.len(), b.tets.len());
    assert_eq!(a.positions.len(), b.positions.len());
    let volume = |m: &TetMesh| (0..m.tets.len()).map(|t| m.signed_volume(t)).sum::<f64>();
    assert!((volume(&a) - volume(&b)).abs() < 1e-9 * volume(&a));
}

#[test]
fn a_fixture_mesh_boundary_remeshes_to_its_volume() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/torus.vtu");
    let source = tetsim::io::read_mesh(&path).unwrap().mesh;
    let surface = TriangleSurface {
        faces: source.boundary_faces(),
        positions: source.positions.clone(),
    };
    let extent = surface
        .positions
        .iter()
        .fold(0.0f64, |m, p| m.max(p.amax()));
    let size = extent / 8.0;
    let (_, q) = mesh(&surface, size);
    assert_sound("torus.vtu boundary", &q, size, 0.1);
}

#[test]
fn a_surface_with_a_small_hole_still_meshes() {
    let mut sphere = icosphere(3);
    // Remove the triangles around one vertex: a hole of about 0.3 % of the area.
    sphere.faces.retain(|f| !f.contains(&0));
    let (_, q) = mesh(&sphere, 0.2);
    assert_eq!(q.inverted, 0);
    assert!(q.min_dihedral > MIN_ANGLE);
    assert!(q.volume_error() < 0.05, "{}", q.volume_error());
}

#[test]
fn an_open_sheet_is_refused_as_too_open() {
    let sheet = TriangleSurface {
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.2),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        faces: vec![[0, 1, 2], [0, 2, 3]],
    };
    let err = tetrahedralize(&sheet, &StuffParams::with_size(0.1)).unwrap_err();
    assert!(
        matches!(err, StuffError::TooOpen { closure, .. } if closure < 0.5),
        "{err}"
    );
    // A hemisphere (half the sphere's triangles) is too open as well.
    let mut bowl = icosphere(2);
    let p = bowl.positions.clone();
    bowl.faces.retain(|f| f.iter().all(|&v| p[v].z > -0.1));
    let err = tetrahedralize(&bowl, &StuffParams::with_size(0.2)).unwrap_err();
    assert!(matches!(err, StuffError::TooOpen { .. }), "{err}");
}

#[test]
fn impossible_sizes_are_refused_with_the_reason() {
    let sphere = icosphere(1);
    for bad in [0.0, -1.0, f64::NAN] {
        let err = tetrahedralize(&sphere, &StuffParams::with_size(bad)).unwrap_err();
        assert!(matches!(err, StuffError::NonPositiveSize { .. }), "{err}");
    }
    // Far coarser than the sphere: no lattice point falls inside.
    let err = tetrahedralize(&sphere, &StuffParams::with_size(50.0)).unwrap_err();
    assert!(matches!(err, StuffError::EmptyInside { .. }), "{err}");
    assert!(err.to_string().contains("try a size below"));
    // Too fine for the memory given: refused before any work, with the estimate.
    let params = StuffParams {
        size: 1e-4,
        memory_limit: Some(1e9),
        ..Default::default()
    };
    let err = tetrahedralize(&sphere, &params).unwrap_err();
    let StuffError::TooLarge { tets, .. } = &err else {
        panic!("{err}")
    };
    assert!(*tets > 1e12, "{err}");
    assert!(err.to_string().contains("tets"));
}

#[test]
fn same_mesh_on_one_and_two_threads() {
    let t = torus(1.0, 0.4, 32, 16);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| tetrahedralize(&t, &StuffParams::with_size(0.15)).unwrap().0)
    };
    let (one, two) = (run(1), run(2));
    assert!(one == two, "the meshes on 1 and 2 threads differ");
}

/// About a million tets on the torus; prints the time (`cargo test --release --test mesh_io
/// million -- --ignored --nocapture`).
#[test]
#[ignore]
fn a_million_tets_in_seconds() {
    let t = torus(1.0, 0.4, 256, 128);
    let start = std::time::Instant::now();
    let (m, info) = tetrahedralize(&t, &StuffParams::with_size(0.0265)).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let q = assess(&m, &t);
    println!(
        "{} tets, {} vertices, {} lattice points in {seconds:.2} s; dihedral {:.2}..{:.2}, \
         volume error {:.4} %, Hausdorff {:.4}",
        m.tets.len(),
        m.positions.len(),
        info.lattice_vertices,
        q.min_dihedral,
        q.max_dihedral,
        100.0 * q.volume_error(),
        q.hausdorff()
    );
    assert!(m.tets.len() > 900_000);
    assert_sound("torus", &q, 0.0265, 0.01);
}
