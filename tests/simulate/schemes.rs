//! The time schemes (`[solver] integrator`): each one's order of accuracy on a large nonlinear
//! swing, Newmark keeping a cantilever's first-mode swing with its known period elongation, the
//! energy audit's balance per scheme, and contact holding under each.

use std::path::Path;

use tetsim::modes::{ModesParams, VibrationProblem};
use tetsim::{Scene, Simulation, Vec3};

const SCHEMES: [&str; 3] = ["backward-euler", "bdf2", "newmark"];

fn parse(text: &str) -> Scene {
    Scene::parse(
        text,
        Path::new("schemes.toml"),
        Path::new(env!("CARGO_MANIFEST_DIR")),
    )
    .unwrap()
}

/// A soft 1 m cantilever released from rest under gravity: its tip swings down by tens of
/// centimetres in 0.5 s (rotations far beyond small strain). Positions of every frame (0.01 s) with `substeps` steps per
/// frame. A little stiffness damping (1.6 % at the swing's frequency) calms the mesh's
/// unresolved modes, which no step here resolves and whose errors would otherwise not be in
/// the asymptotic range.
fn swing(scheme: &str, substeps: usize) -> Vec<Vec<Vec3>> {
    let scene = parse(&format!(
        r#"
        gravity = [0.0, 0.0, -9.81]
        [mesh]
        generator = {{ box = {{ min = [0, 0, 0], max = [1, 0.1, 0.1], cells = [8, 1, 1] }} }}
        [material]
        model = "neo-hookean"
        youngs_modulus = 1e6
        poisson_ratio = 0.3
        density = 1000
        [[fixed]]
        region = {{ physical = "xmin" }}
        [solver]
        integrator = "{scheme}"
        dt = 0.01
        frames = 50
        rayleigh_stiffness = 0.01
        substeps = {substeps}
        newton_tolerance = 1e-11
        cg_tolerance = 1e-12
        newton_max_iterations = 50
        on_failure = "stop"
        "#
    ));
    let mut sim = Simulation::from_scene(&scene).unwrap();
    let mut frames = Vec::new();
    while !sim.is_finished() {
        let stats = sim.step().unwrap();
        frames.push(sim.state.x.clone());
        assert!(stats.converged, "{scheme}: {:?}", stats.failure);
        assert_eq!(
            stats.energy.injected(),
            0.0,
            "{scheme}, {substeps} substeps, frame {}: {:?}",
            stats.frame,
            stats.energy
        );
    }
    frames
}

/// The largest distance between the same vertex in the same frame of two runs.
fn max_distance(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(a, b)| (a - b).norm()))
        .fold(0.0, f64::max)
}

/// Errors (largest over vertices and frames) against a run of the same scheme with 32 times
/// smaller steps fall by about 2 per halving of h for backward Euler (first order: measured
/// 2.00, 2.11) and by about 4 for BDF2 and Newmark (second order: 3.88, 3.99 and 4.01, 4.05):
/// at least 1.8 and 3.
#[test]
fn each_scheme_converges_at_its_order_on_a_large_nonlinear_swing() {
    let mut report = String::new();
    for scheme in SCHEMES {
        let reference = swing(scheme, 32);
        let errors: Vec<f64> = [1, 2, 4]
            .iter()
            .map(|&s| max_distance(&swing(scheme, s), &reference))
            .collect();
        let ratios = [errors[0] / errors[1], errors[1] / errors[2]];
        report += &format!("{scheme}: errors {errors:.4?}, ratios {ratios:.2?}\n");
        let least = if scheme == "backward-euler" { 1.8 } else { 3.0 };
        assert!(
            ratios.iter().all(|&r| r >= least),
            "{scheme}: ratios {ratios:?} below {least}\n{report}"
        );
    }
    eprintln!("{report}");
}

/// An undamped clamped beam started in its first mode (a small velocity along the mode shape):
/// the modal coordinate's swing after six periods, its mean period, and the audit's remainder.
struct Swing {
    /// Largest |q| in the seventh period over largest |q| in the first.
    kept: f64,
    /// Mean period between the first and the seventh upward zero crossing, s.
    period: f64,
    /// The first mode's period, s.
    mode_period: f64,
    /// The step, s.
    h: f64,
    /// Σ over frames of the audit's remainder (numerical dissipation), J, and the energy, J.
    dissipated: f64,
    energy: f64,
    injected: bool,
}

fn first_mode_swing(scheme: &str) -> Swing {
    let text = |dt: f64, frames: usize| {
        format!(
            r#"
            gravity = [0.0, 0.0, 0.0]
            [mesh]
            generator = {{ box = {{ min = [0, 0, 0], max = [1, 0.1, 0.1], cells = [10, 1, 1] }} }}
            [material]
            model = "neo-hookean"
            youngs_modulus = 1e6
            poisson_ratio = 0.3
            density = 1000
            [[fixed]]
            region = {{ physical = "xmin" }}
            [solver]
            integrator = "{scheme}"
            dt = {dt}
            frames = {frames}
            newton_tolerance = 1e-12
            cg_tolerance = 1e-12
            "#
        )
    };
    let probe = Simulation::from_scene(&parse(&text(0.01, 1))).unwrap();
    let modes = VibrationProblem::new(&probe.body, probe.free_mask())
        .unwrap()
        .solve(&ModesParams {
            count: 1,
            tolerance: 1e-10,
            ..Default::default()
        })
        .unwrap();
    let mode = &modes.modes[0];
    let mode_period = 1.0 / mode.frequency_hz;
    let h = mode_period / 20.0;
    let mut sim = Simulation::from_scene(&parse(&text(h, 7 * 20 + 5))).unwrap();
    let n = sim.body.vertex_count();
    let rest = sim.body.mesh.positions.clone();
    // A tip speed of 1 mm/s: amplitudes of a few tenths of a millimetre, linear to 1e-6.
    let tip = mode.shape.iter().map(|v| v.norm()).fold(0.0, f64::max);
    sim.state.v = mode.shape.iter().map(|v| v * (1e-3 / tip)).collect();
    let masses = sim.body.masses().to_vec();
    let modal = |x: &[Vec3]| -> f64 {
        (0..n)
            .map(|i| masses[i] * mode.shape[i].dot(&(x[i] - rest[i])))
            .sum()
    };
    let energy = sim.kinetic_energy();
    let (mut q, mut t) = (vec![0.0], vec![0.0]);
    let (mut dissipated, mut injected) = (0.0, false);
    while !sim.is_finished() {
        let stats = sim.step().unwrap();
        assert!(stats.converged, "{scheme}: {:?}", stats.failure);
        dissipated += stats.energy.numerical_dissipation;
        injected |= stats.energy.injected() > 0.0;
        q.push(modal(&sim.state.x));
        t.push(sim.state.t);
    }
    // Upward zero crossings, linearly interpolated (q starts at 0 moving up).
    let crossings: Vec<f64> = (1..q.len())
        .filter(|&k| q[k - 1] < 0.0 && q[k] >= 0.0)
        .map(|k| t[k - 1] + (t[k] - t[k - 1]) * (-q[k - 1]) / (q[k] - q[k - 1]))
        .collect();
    let in_period = |k: usize| -> f64 {
        let (lo, hi) = (k as f64 * mode_period, (k + 1) as f64 * mode_period);
        (0..q.len())
            .filter(|&j| t[j] >= lo && t[j] < hi)
            .map(|j| q[j].abs())
            .fold(0.0, f64::max)
    };
    let period = if crossings.len() >= 6 {
        (crossings[5] - crossings[0]) / 5.0
    } else {
        f64::NAN
    };
    Swing {
        kept: in_period(6) / in_period(0),
        period,
        mode_period,
        h,
        dissipated,
        energy,
        injected,
    }
}

/// Newmark's average-acceleration rule keeps the first mode's swing (≥ 0.98 after six periods;
/// exactly 1 for a linear system) with the period lengthened as the theory says,
/// T̄ = πh / atan(ωh/2) (0.8 % at 20 steps per period); its audit finds no energy created or
/// lost beyond Newton's depth. At the same step backward Euler keeps almost nothing and BDF2
/// keeps part.
#[test]
fn newmark_keeps_a_cantilevers_first_mode_swing_with_its_known_period() {
    let newmark = first_mode_swing("newmark");
    let omega_h = 2.0 * std::f64::consts::PI / newmark.mode_period * newmark.h;
    let expected = std::f64::consts::PI * newmark.h / (0.5 * omega_h).atan();
    eprintln!(
        "newmark: kept {:.5}, period {:.6} s against {:.6} s expected ({:.6} s the mode's), \
         remainder {:.3e} J of {:.3e} J",
        newmark.kept,
        newmark.period,
        expected,
        newmark.mode_period,
        newmark.dissipated,
        newmark.energy
    );
    assert!(newmark.kept >= 0.98, "{}", newmark.kept);
    assert!(
        (newmark.period / expected - 1.0).abs() < 2e-3,
        "period {} against {expected}",
        newmark.period
    );
    assert!(!newmark.injected);
    assert!(
        newmark.dissipated.abs() < 1e-4 * newmark.energy,
        "remainder {} J of {} J",
        newmark.dissipated,
        newmark.energy
    );
    let be = first_mode_swing("backward-euler");
    let bdf2 = first_mode_swing("bdf2");
    eprintln!(
        "kept after six periods: backward-euler {:.4}, bdf2 {:.4}",
        be.kept, bdf2.kept
    );
    assert!(be.kept < 0.05, "{}", be.kept);
    assert!(
        bdf2.kept > be.kept && bdf2.kept < newmark.kept,
        "{}",
        bdf2.kept
    );
    // Their audits report the lost energy as numerical dissipation (about 1 − kept² of it), and
    // none created.
    for (name, s) in [("backward-euler", &be), ("bdf2", &bdf2)] {
        assert!(!s.injected, "{name}");
        let lost = s.energy * (1.0 - s.kept * s.kept);
        assert!(
            (s.dissipated - lost).abs() < 0.1 * s.energy,
            "{name}: {} J reported, about {lost} J lost of {} J",
            s.dissipated,
            s.energy
        );
    }
}

/// A ball (TetGen's) thrown down at 2 m/s onto the ground with each scheme: no vertex ever
/// below the plane, the contact holds, and it bounces back up.
#[test]
fn a_ball_thrown_at_the_ground_stays_above_it_with_every_scheme() {
    for scheme in SCHEMES {
        let scene = parse(&format!(
            r#"
            gravity = [0.0, -9.81, 0.0]
            [mesh]
            file = "tests/fixtures/ball.node"
            [material]
            model = "neo-hookean"
            youngs_modulus = 5e5
            poisson_ratio = 0.4
            density = 1000
            [[obstacle]]
            name = "ground"
            plane = {{ point = [0.0, -1.1, 0.0], normal = [0.0, 1.0, 0.0] }}
            [initial]
            velocity = [0.0, -2.0, 0.0]
            [solver]
            integrator = "{scheme}"
            dt = 0.01
            frames = 40
            "#
        ));
        let mut sim = Simulation::from_scene(&scene).unwrap();
        let (mut touched, mut lowest) = (false, f64::INFINITY);
        while !sim.is_finished() {
            let stats = sim.step().unwrap();
            assert!(stats.converged, "{scheme}: {:?}", stats.failure);
            let low = sim
                .state
                .x
                .iter()
                .map(|p| p.y)
                .fold(f64::INFINITY, f64::min);
            assert!(
                low > -1.1,
                "{scheme}, frame {}: a vertex at y = {low}",
                stats.frame
            );
            lowest = lowest.min(low);
            touched |= stats.contacts > 0;
        }
        let rising: f64 = sim
            .state
            .v
            .iter()
            .zip(sim.body.masses())
            .map(|(v, m)| m * v.y)
            .sum();
        eprintln!("{scheme}: lowest vertex {lowest:.5} m, momentum at the end {rising:.3} kg·m/s");
        assert!(touched, "{scheme}: never touched");
    }
}
