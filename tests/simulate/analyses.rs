//! SPEC §13 against physics: the reaction of a named constraint balances the body's weight at
//! rest and its momentum change in a dynamic step; probes interpolate the displacement field.

use super::scene;
use tetsim::{Simulation, Vec3};

/// A beam [0,4]×[0,1]×[0,1] m of density 1000 kg/m³, clamped at x = 0 by `[[fixed]]` "clamp".
fn hanging_beam(solver: &str) -> String {
    format!(
        r#"
gravity = [0.0, -9.81, 0.0]
[mesh]
generator = {{ box = {{ min = [0, 0, 0], max = [4, 1, 1], cells = [8, 2, 2] }} }}
[material]
youngs_modulus = "2 MPa"
poisson_ratio = 0.3
density = "1000 kg/m^3"
[[fixed]]
name = "clamp"
region = {{ physical = "xmin" }}
[[probe]]
name = "tip"
point = [4, 0.5, 0.5]
[solver]
{solver}
"#
    )
}

fn run(sim: &mut Simulation) {
    while !sim.is_finished() {
        assert!(sim.step().unwrap().converged);
    }
}

#[test]
fn a_clamp_holds_a_hanging_beam_with_its_weight() {
    let mut sim = Simulation::from_scene(&scene(&hanging_beam(
        "integrator = \"quasistatic\"\nframes = 3\nnewton_tolerance = 1e-9",
    )))
    .unwrap();
    run(&mut sim);
    let weight = sim.body.masses().iter().sum::<f64>() * 9.81;
    assert!((weight - 4.0 * 1000.0 * 9.81).abs() < 1e-8 * weight);
    let clamp = sim.reaction_forces()[0];
    // The constraint pulls up (+y) with the weight; nothing sideways.
    assert!(
        (clamp - Vec3::new(0.0, weight, 0.0)).norm() < 1e-6 * weight,
        "reaction {clamp}, weight {weight}"
    );
    // The tip sags, and the probe says so.
    assert!(sim.probe_displacements()[0][1] < -0.1);
}

#[test]
fn reactions_balance_momentum_in_every_dynamic_frame() {
    // Σ R = Σ m(v − vⁿ)/h + α Σ m v − M g over the body (stiffness damping and elastic forces sum
    // to zero): the reaction carries inertia and damping, not just the static load.
    let mut sim = Simulation::from_scene(&scene(&hanging_beam(
        "dt = 0.02\nframes = 8\nrayleigh_mass = 0.7\nrayleigh_stiffness = 0.01\nnewton_tolerance = 1e-10",
    )))
    .unwrap();
    let masses = sim.body.masses().to_vec();
    let total: f64 = masses.iter().sum();
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let mut dynamic = 0.0_f64;
    while !sim.is_finished() {
        let vn = sim.state.v.clone();
        let stats = sim.step().unwrap();
        assert!(stats.converged && stats.substeps == 1);
        let h = 0.02;
        let mut expected = -total * gravity;
        for (i, &m) in masses.iter().enumerate() {
            expected += m * (sim.state.v[i] - vn[i]) / h + 0.7 * m * sim.state.v[i];
        }
        let clamp = sim.reaction_forces()[0];
        let weight = total * 9.81;
        assert!(
            (clamp - expected).norm() < 1e-6 * weight,
            "frame {}: reaction {clamp}, momentum balance {expected}",
            stats.frame
        );
        dynamic = dynamic.max((clamp[1] - weight).abs() / weight);
    }
    // The beam swings: the reaction is far from the static weight, so inertia was tested.
    assert!(dynamic > 0.05, "{dynamic}");
}

#[test]
fn reactions_of_two_bodies_and_of_one_component() {
    // Two beams side by side (no contact between them: far apart), each clamped by its own
    // named constraint with `body = ...`; the second one held in y only on its whole bottom, and
    // at one top corner in every component (so that it cannot slide).
    let text = r#"
gravity = [0.0, -9.81, 0.0]
[mesh]
name = "left"
generator = { box = { min = [0, 0, 0], max = [2, 0.5, 0.5], cells = [4, 1, 1] } }
[material]
youngs_modulus = 1e6
density = 1000
[[body]]
name = "right"
mesh = { generator = { box = { min = [0, 0, 0], max = [1, 0.5, 0.5], cells = [2, 1, 1] } } }
material = { youngs_modulus = 1e6, density = 2000 }
translate = [0, 0, 5]
[[fixed]]
name = "left_clamp"
body = "left"
region = { box = { min = [-0.01, -1, -1], max = [0.01, 1, 10] } }
[[fixed]]
name = "floor"
body = "right"
region = { box = { min = [-1, -0.01, -1], max = [2, 0.01, 10] } }
components = ["y"]
[[fixed]]
name = "hold"
body = "right"
region = { box = { min = [-0.01, 0.49, 4.99], max = [0.01, 0.51, 5.01] } }
[contact]
self = false
[solver]
integrator = "quasistatic"
frames = 2
newton_tolerance = 1e-10
"#;
    let mut sim = Simulation::from_scene(&scene(text)).unwrap();
    run(&mut sim);
    let [left, floor, hold] = sim.reaction_forces()[..] else {
        panic!("three named constraints")
    };
    let g = 9.81;
    let left_weight = 2.0 * 0.5 * 0.5 * 1000.0 * g;
    let right_weight = 1.0 * 0.5 * 0.5 * 2000.0 * g;
    assert!(
        (left - Vec3::new(0.0, left_weight, 0.0)).norm() < 1e-6 * left_weight,
        "{left}"
    );
    // The floor holds y only; "hold" takes no sideways force (nothing else does: Σ R_x = 0),
    // and the two share the weight.
    assert_eq!((floor[0], floor[2]), (0.0, 0.0));
    assert!(
        hold[0].abs() + hold[2].abs() < 1e-6 * right_weight,
        "{hold}"
    );
    assert!(
        (floor[1] + hold[1] - right_weight).abs() < 1e-6 * right_weight,
        "{floor} + {hold} vs {right_weight}"
    );
}
