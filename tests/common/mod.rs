//! Shared test helpers: seeded randomness, deformation-gradient generators, finite differences
//! with a sweep of step sizes, small meshes.
#![allow(dead_code)]

pub mod beam24;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tetsim::mesh::generate::box_mesh;
use tetsim::{Mat3, TetMesh, Vec3};

/// A seeded generator, so every failure reproduces.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Uniform in [lo, hi).
pub fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// A random rotation (uniform axis-angle, good enough for tests).
pub fn rotation(rng: &mut ChaCha8Rng) -> Mat3 {
    let axis = Vec3::new(
        uniform(rng, -1.0, 1.0),
        uniform(rng, -1.0, 1.0),
        uniform(rng, -1.0, 1.0),
    );
    let angle = uniform(rng, -3.1, 3.1);
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle).into_inner()
}

/// A random matrix with entries in [-1, 1).
pub fn random_matrix(rng: &mut ChaCha8Rng) -> Mat3 {
    Mat3::from_fn(|_, _| uniform(rng, -1.0, 1.0))
}

/// `R₁·diag(σ)·R₂` with random rotations.
pub fn with_stretches(rng: &mut ChaCha8Rng, s: Vec3) -> Mat3 {
    rotation(rng) * Mat3::from_diagonal(&s) * rotation(rng)
}

/// The families of F every derivative is checked on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Moderate random deformation, det F > 0.
    Random,
    /// det F ≈ 1e-3.
    NearInverted,
    /// det F < 0.
    Inverted,
    /// Rank 2: det F = 0.
    Flat,
}

pub const FAMILIES: [Family; 4] = [
    Family::Random,
    Family::NearInverted,
    Family::Inverted,
    Family::Flat,
];

/// A random F of the given family. Stretches are kept apart from the rotation-variant energy's
/// kink at σ₂ = −σ₃ (see `material::isotropic::POLE_GUARD`).
pub fn sample_f(rng: &mut ChaCha8Rng, family: Family) -> Mat3 {
    let s1 = uniform(rng, 0.5, 2.0);
    let s2 = uniform(rng, 0.4, 1.6);
    match family {
        Family::Random => {
            let s3 = uniform(rng, 0.4, 1.5);
            with_stretches(rng, Vec3::new(s1, s2, s3))
        }
        Family::NearInverted => with_stretches(rng, Vec3::new(s1, s2, 1e-3 / (s1 * s2))),
        Family::Inverted => {
            let s3 = -uniform(rng, 0.05, 0.6) * s1.min(s2);
            with_stretches(rng, Vec3::new(s1, s2, s3))
        }
        Family::Flat => with_stretches(rng, Vec3::new(s1, s2, 0.0)),
    }
}

/// Step sizes swept by the finite-difference checks (HOBAK's habit: trust the best, not one ε).
pub const STEPS: [f64; 7] = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8];

/// The smallest relative error between `analytic` and central differences `fd(h)` over the step
/// sweep. Relative to the larger of the two norms and `floor` (for values that should be ~0).
pub fn best_relative_error<T>(analytic: &[f64], floor: f64, fd: T) -> (f64, f64)
where
    T: Fn(f64) -> Vec<f64>,
{
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    STEPS
        .iter()
        .map(|&h| {
            let approx = fd(h);
            let diff: Vec<f64> = approx.iter().zip(analytic).map(|(a, b)| a - b).collect();
            let scale = norm(analytic).max(norm(&approx)).max(floor);
            (norm(&diff) / scale, h)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap()
}

/// Mat3 entries as a slice-friendly Vec.
pub fn flat(m: &Mat3) -> Vec<f64> {
    m.iter().copied().collect()
}

/// Flatten vertex vectors.
pub fn flat_vecs(v: &[Vec3]) -> Vec<f64> {
    v.iter().flat_map(|p| p.iter().copied()).collect()
}

/// Σ a·b over vertex vectors.
pub fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

/// A small beam mesh [0,2]×[0,1]×[0,1] of 2×1×1 cubes with jittered interior-free vertices.
pub fn small_mesh(rng: &mut ChaCha8Rng) -> TetMesh {
    let mut mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
    for p in &mut mesh.positions {
        *p += 0.05
            * Vec3::new(
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
            );
    }
    mesh
}

/// A quadratic mesh with each mid-edge node moved off its edge by up to 4 % of the edge's
/// length: curved elements, still sound.
pub fn curved(rng: &mut ChaCha8Rng, mesh: &TetMesh) -> TetMesh {
    let mut mesh = mesh.clone();
    let mut moved = vec![false; mesh.positions.len()];
    for t in 0..mesh.tets.len() {
        for (k, [i, j]) in tetsim::mesh::quadratic::EDGES.iter().enumerate() {
            let n = mesh.edge_nodes[t][k];
            if moved[n] {
                continue;
            }
            moved[n] = true;
            let length =
                (mesh.positions[mesh.tets[t][*i]] - mesh.positions[mesh.tets[t][*j]]).norm();
            mesh.positions[n] += 0.04
                * length
                * Vec3::new(
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                );
        }
    }
    mesh
}

/// Positions: rest plus a random displacement of size `amount` (relative to edge length 1).
pub fn perturbed(rng: &mut ChaCha8Rng, rest: &[Vec3], amount: f64) -> Vec<Vec3> {
    rest.iter()
        .map(|p| {
            p + amount
                * Vec3::new(
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                )
        })
        .collect()
}

/// A random vector field.
pub fn random_field(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|_| {
            Vec3::new(
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
            )
        })
        .collect()
}

/// `a + t·b` over vertex vectors.
pub fn axpy(a: &[Vec3], t: f64, b: &[Vec3]) -> Vec<Vec3> {
    a.iter().zip(b).map(|(x, y)| x + t * y).collect()
}

/// A coarse ball: the tets of a box mesh of `cells`³ cubes over [−r, r]³ whose centroid lies
/// within r, unused vertices dropped.
pub fn carved_ball(radius: f64, cells: usize) -> TetMesh {
    let mut mesh = box_mesh(Vec3::repeat(-radius), Vec3::repeat(radius), [cells; 3]);
    let x = mesh.positions.clone();
    mesh.tets.retain(|t| {
        let c = t.iter().map(|&v| x[v]).sum::<Vec3>() / 4.0;
        c.norm() < radius
    });
    mesh.groups.clear();
    mesh.drop_unreferenced_vertices();
    mesh.vertex_ids = None;
    mesh
}

/// The collapsed or scrambled starts of the Irving et al. 2004 recovery demonstrations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Collapse {
    /// Every vertex projected onto one plane through the centroid.
    Plane,
    /// Every vertex projected onto one line through the centroid.
    Line,
    /// Every vertex at the centroid.
    Point,
    /// Every vertex at a random place in a box a quarter of the body's size.
    Scrambled,
}

impl Collapse {
    /// Every start, in table order.
    pub const ALL: [Collapse; 4] = [
        Collapse::Plane,
        Collapse::Line,
        Collapse::Point,
        Collapse::Scrambled,
    ];

    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Collapse::Plane => "plane",
            Collapse::Line => "line",
            Collapse::Point => "point",
            Collapse::Scrambled => "scrambled",
        }
    }

    /// The collapsed positions of `rest`, plus a random jitter of `jitter` (m) per coordinate.
    pub fn apply(self, rest: &[Vec3], jitter: f64, seed: u64) -> Vec<Vec3> {
        let mut rng = rng(seed);
        let c = rest.iter().sum::<Vec3>() / rest.len() as f64;
        let (lo, hi) = tetsim::mesh::bounding_box(rest);
        let size = (hi - lo).norm();
        // Oblique directions, so no mesh plane or axis lines up with the collapse.
        let d = Vec3::new(1.0, 2.0, 3.0).normalize();
        let mut x: Vec<Vec3> = rest
            .iter()
            .map(|p| match self {
                Collapse::Plane => p - d * (p - c).dot(&d),
                Collapse::Line => c + d * (p - c).dot(&d),
                Collapse::Point => c,
                Collapse::Scrambled => {
                    c + 0.125
                        * size
                        * Vec3::new(
                            uniform(&mut rng, -1.0, 1.0),
                            uniform(&mut rng, -1.0, 1.0),
                            uniform(&mut rng, -1.0, 1.0),
                        )
                }
            })
            .collect();
        if jitter > 0.0 {
            for p in &mut x {
                *p += jitter
                    * Vec3::new(
                        uniform(&mut rng, -1.0, 1.0),
                        uniform(&mut rng, -1.0, 1.0),
                        uniform(&mut rng, -1.0, 1.0),
                    );
            }
        }
        x
    }
}

/// Largest vertex distance between `x` and `rest` after the best rigid alignment of `rest` onto
/// `x` (Kabsch: least squares over rotations, reflections excluded, and translations).
pub fn rigid_distance(rest: &[Vec3], x: &[Vec3]) -> f64 {
    let n = rest.len() as f64;
    let (cr, cx) = (rest.iter().sum::<Vec3>() / n, x.iter().sum::<Vec3>() / n);
    let h: Mat3 = rest
        .iter()
        .zip(x)
        .map(|(r, p)| (p - cx) * (r - cr).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
    // nalgebra does not sort singular values: a reflection is undone on the smallest.
    let smallest = svd.singular_values.imin();
    let mut d = Mat3::identity();
    d[(smallest, smallest)] = (u * v_t).determinant().signum();
    let rotation = u * d * v_t;
    rest.iter()
        .zip(x)
        .map(|(r, p)| (cx + rotation * (r - cr) - p).norm())
        .fold(0.0, f64::max)
}
