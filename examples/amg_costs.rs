//! Costs of the AMG preconditioner on the benchmark cantilever beam (4n×n×n cubes): setup,
//! refresh, one V-cycle, one assembled product, and PCG iterations against Jacobi.
//!
//! `cargo run --release --example amg_costs -- 12` (n = 12), optionally followed by AMG settings
//! `theta=0.05 degree=3 fraction=0.1 coarse=300`; the thread count is RAYON_NUM_THREADS.

use std::time::Instant;

#[path = "common/beam.rs"]
mod beam;

use tetsim::Vec3;
use tetsim::elastic::AssemblyWork;
use tetsim::linear::amg::{Amg, AmgParams};
use tetsim::linear::cg::{
    CgParams, CgWorkspace, Jacobi, LinearOperator, Preconditioner, conjugate_gradient,
};
use tetsim::linear::sparse::{BlockCsr, Precision};
use tetsim::material::Definiteness;

struct Assembled<'a>(&'a BlockCsr);

impl LinearOperator for Assembled<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }
    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let n: usize = std::env::args().nth(1).map_or(6, |s| s.parse().expect("n"));
    // A bent state like the cantilever's sag.
    let (body, x) = beam::bent_beam(n);
    let free: Vec<Vec3> = tetsim::boundary::mask_holding(&body.mesh.positions, |p| p.x == 0.0);
    let started = Instant::now();
    let lin = body.linearize(&x, Definiteness::Projected);
    let t_linearize = started.elapsed().as_secs_f64();
    let h = 1.0 / 30.0;
    // Stored as the solver stores its A.
    let mut a = BlockCsr::zeros_in(body.stiffness_pattern(), Precision::F32);
    let mut work = AssemblyWork::default();
    let mut t_assemble = Vec::new();
    for _ in 0..3 {
        let started = Instant::now();
        body.assemble_system(&lin, 1.0 + 0.01 / h, 1.0 / (h * h), &mut a, &mut work);
        a.constrain(&free);
        t_assemble.push(started.elapsed().as_secs_f64());
    }
    let rhs: Vec<Vec3> = body
        .masses()
        .iter()
        .zip(&free)
        .map(|(m, f)| Vec3::new(0.0, -9.81, 0.0).component_mul(f) * *m)
        .collect();
    let mut params = AmgParams::default();
    for arg in std::env::args().skip(2) {
        let (key, value) = arg.split_once('=').expect("key=value");
        match key {
            "theta" => params.strength_threshold = value.parse().expect("θ"),
            "degree" => params.smoother_degree = value.parse().expect("degree"),
            "fraction" => params.smoother_lower_fraction = value.parse().expect("fraction"),
            "coarse" => params.max_coarse_dofs = value.parse().expect("DOFs"),
            "damping" => params.prolongator_damping = value.parse().expect("ω·λ̄"),
            _ => panic!("unknown setting {key}"),
        }
    }
    let started = Instant::now();
    let mut amg = Amg::new(&a, &body.mesh.positions, &free, &params);
    let t_setup = started.elapsed().as_secs_f64();
    let t_refresh = median(
        (0..3)
            .map(|_| {
                amg.refresh(&a);
                amg.info().refresh_seconds
            })
            .collect(),
    );
    let nv = a.rows();
    let mut z = vec![Vec3::zeros(); nv];
    let t_cycle = median(
        (0..7)
            .map(|_| {
                let started = Instant::now();
                amg.apply(&rhs, &mut z);
                started.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let t_spmv = median(
        (0..7)
            .map(|_| {
                let started = Instant::now();
                a.multiply(&rhs, &mut z);
                started.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let info = amg.info();
    println!(
        "n = {n}: {nv} vertices, {} tets; linearize {:.1} ms, assemble+constrain {:.1} ms",
        body.tet_count(),
        1e3 * t_linearize,
        1e3 * median(t_assemble)
    );
    for (l, level) in info.levels.iter().enumerate() {
        println!(
            "  level {l}: {} rows × {} DOFs, {} nonzeros, λ̄ {:.3}",
            level.rows, level.block_size, level.nonzeros, level.spectral_bound
        );
    }
    println!(
        "  operator complexity {:.2}, coarsest direct {}; setup {:.1} ms, refresh {:.1} ms, V-cycle {:.2} ms, product {:.2} ms",
        info.operator_complexity,
        info.coarsest_direct,
        1e3 * t_setup,
        1e3 * t_refresh,
        1e3 * t_cycle,
        1e3 * t_spmv
    );
    let cg = CgParams {
        tolerance: 1e-6,
        max_iterations: 5000,
    };
    let solve = |m: &mut dyn Preconditioner, name: &str| {
        let mut x = vec![Vec3::zeros(); nv];
        let started = Instant::now();
        let result = conjugate_gradient(
            &mut Assembled(&a),
            m,
            &rhs,
            &mut x,
            &free,
            &cg,
            &mut CgWorkspace::new(nv),
        )
        .unwrap();
        println!(
            "  {name}: {} iterations to 1e-6 in {:.1} ms",
            result.iterations,
            1e3 * started.elapsed().as_secs_f64()
        );
    };
    solve(&mut amg, "AMG-PCG");
    let blocks: Vec<_> = (0..nv).map(|i| a.diagonal(i)).collect();
    let mut jacobi = Jacobi::default();
    jacobi.set_from_blocks(&blocks);
    solve(&mut jacobi, "Jacobi-PCG (assembled)");
}
