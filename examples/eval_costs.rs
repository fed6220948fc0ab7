//! Costs of one Newton iterate's evaluation on the benchmark cantilever beam (4n×n×n cubes):
//! the damped forces (one SVD, stress, K_d·v) and Newton's shifted tangents (one SVD, the
//! projected and the exact pieces), each alone, in ns per tet (medians of 9).
//!
//! `cargo run --release --example eval_costs -- 20`; the thread count is RAYON_NUM_THREADS.

use std::time::Instant;

#[path = "common/beam.rs"]
mod beam;

use tetsim::Vec3;
use tetsim::elastic::{Damping, Linearization};
use tetsim::material::{DampingStiffness, Definiteness};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map_or(12, |s| s.parse().expect("n"));
    // A bent, moving state like the cantilever's sag.
    let (body, x) = beam::bent_beam(n);
    let v: Vec<Vec3> = body
        .mesh
        .positions
        .iter()
        .map(|p| Vec3::new(0.0, -0.5 * (p.x / 4.0).powi(2), 0.0))
        .collect();
    let (h, gamma) = (1.0 / 30.0, 0.01);
    let damping = Damping {
        velocities: &v,
        stiffness: DampingStiffness::Projected,
        shift: gamma * h / (h + gamma),
        weight: gamma / h,
    };
    let mut lin = Linearization::new(&body, Definiteness::Adaptive);
    let mut forces = vec![Vec3::zeros(); body.vertex_count()];
    let mut kv = forces.clone();
    let tets = body.tet_count() as f64;
    let (mut t_forces, mut t_tangents) = (Vec::new(), Vec::new());
    for _ in 0..9 {
        let started = Instant::now();
        body.damped_forces_into(&x, &damping, &mut lin, &mut forces, &mut kv);
        t_forces.push(started.elapsed().as_secs_f64());
        let started = Instant::now();
        body.damped_tangents_into(&x, &damping, &mut lin);
        t_tangents.push(started.elapsed().as_secs_f64());
    }
    println!(
        "n = {n}, {} tets, {} threads: forces {:.0} ns/tet, tangents {:.0} ns/tet",
        body.tet_count(),
        rayon::current_num_threads(),
        1e9 * median(t_forces) / tets,
        1e9 * median(t_tangents) / tets
    );
}
