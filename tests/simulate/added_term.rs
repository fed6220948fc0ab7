//! A term added from outside the crate ([`Simulation::add_term`]): a spring holding the tip of a
//! clamped beam. It acts (the tip sags far less), the solve balances it (the spring force equals
//! the beam's elastic force and weight at the tip), and the energy audit counts its energy.

use std::path::Path;

use tetsim::integrator::{HessianShape, StepContext, Term, ordered_sum};
use tetsim::{Scene, Simulation, Vec3};

/// ½k‖x_v − anchor‖² on one vertex: force −k(x_v − anchor), Hessian k·I on that vertex.
struct Spring {
    vertex: usize,
    anchor: Vec3,
    stiffness: f64,
}

impl Term for Spring {
    fn name(&self) -> &'static str {
        "tip spring"
    }

    fn evaluate(
        &mut self,
        _ctx: &StepContext<'_>,
        x: &[Vec3],
        _v: &[Vec3],
        force: &mut [Vec3],
        partials: &mut [f64],
    ) -> f64 {
        let stretch = x[self.vertex] - self.anchor;
        force[self.vertex] -= self.stiffness * stretch;
        let (vertex, k) = (self.vertex, self.stiffness);
        ordered_sum(partials, x.len(), |i| {
            if i == vertex {
                0.5 * k * stretch.norm_squared()
            } else {
                0.0
            }
        })
    }

    fn hessian_shape(&self, _ctx: &StepContext<'_>) -> HessianShape {
        HessianShape::LumpedDiagonal
    }

    fn add_lumped_diagonal(&self, _ctx: &StepContext<'_>, d: &mut [f64]) {
        d[self.vertex] += self.stiffness;
    }
}

fn beam(integrator: &str) -> Simulation {
    let scene = Scene::parse(
        &format!(
            r#"
            gravity = [0.0, -9.81, 0.0]
            [mesh]
            generator = {{ box = {{ min = [0, 0, 0], max = [2, 0.2, 0.2], cells = [10, 1, 1] }} }}
            [material]
            youngs_modulus = 1e6
            density = 1000
            [[fixed]]
            region = {{ physical = "xmin" }}
            [solver]
            integrator = "{integrator}"
            frames = 20
            dt = 0.01
            newton_tolerance = 1e-10
            cg_tolerance = 1e-12
            "#
        ),
        Path::new("spring.toml"),
        Path::new("."),
    )
    .unwrap();
    Simulation::from_scene(&scene).unwrap()
}

/// The vertex at the tip's top far corner.
fn tip(sim: &Simulation) -> usize {
    let rest = &sim.body.mesh.positions;
    (0..rest.len())
        .max_by(|&a, &b| (rest[a].x + rest[a].y).total_cmp(&(rest[b].x + rest[b].y)))
        .unwrap()
}

#[test]
fn a_spring_added_from_outside_holds_the_tip_and_is_balanced() {
    let mut free = beam("quasistatic");
    while !free.is_finished() {
        free.step().unwrap();
    }
    let mut held = beam("quasistatic");
    let v = tip(&held);
    let anchor = held.body.mesh.positions[v];
    let k = 2e4;
    held.add_term(Box::new(Spring {
        vertex: v,
        anchor,
        stiffness: k,
    }))
    .unwrap();
    while !held.is_finished() {
        let stats = held.step().unwrap();
        assert!(stats.converged);
    }
    let sag = |sim: &Simulation| anchor.y - sim.state.x[v].y;
    assert!(
        sag(&held) < 0.5 * sag(&free),
        "held {} m, free {} m",
        sag(&held),
        sag(&free)
    );
    // At equilibrium the tip's forces cancel: elastic + weight + spring.
    let mut elastic = vec![Vec3::zeros(); held.body.vertex_count()];
    held.body.add_forces(&held.state.x, &mut elastic);
    let weight = held.body.masses()[v] * Vec3::new(0.0, -9.81, 0.0);
    let spring = -k * (held.state.x[v] - anchor);
    let total = elastic[v] + weight + spring;
    assert!(
        total.norm() < 1e-6 * spring.norm(),
        "{total:?} left of a {} N spring force",
        spring.norm()
    );
}

#[test]
fn the_audit_counts_an_added_terms_energy() {
    let mut sim = beam("newmark");
    let v = tip(&sim);
    let anchor = sim.body.mesh.positions[v] + Vec3::new(0.0, 0.05, 0.0);
    sim.add_term(Box::new(Spring {
        vertex: v,
        anchor,
        stiffness: 2e4,
    }))
    .unwrap();
    let mut remainder = 0.0;
    let mut level = 0.0_f64;
    while !sim.is_finished() {
        let stats = sim.step().unwrap();
        assert_eq!(stats.energy.injected(), 0.0, "{:?}", stats.energy);
        remainder += stats.energy.numerical_dissipation;
        level = level.max(stats.kinetic_energy);
    }
    // Undamped Newmark with the spring's energy counted: nothing created or lost beyond the
    // trapezoid's error.
    assert!(remainder.abs() < 1e-3 * level, "{remainder} J of {level} J");
}
