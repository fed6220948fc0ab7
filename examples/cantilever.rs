//! The README's library snippet: run ten frames of the sample cantilever and write its frames.
//! `cargo run --release --example cantilever` (from the repository root).

use tetsim::output::Recorder;
use tetsim::runner::Runner;
use tetsim::{Scene, Simulation};

fn main() -> Result<(), tetsim::Error> {
    let mut scene = Scene::load("scenes/cantilever.toml".as_ref())?;
    scene.solver.frames = 10;
    let mut sim = Simulation::from_scene(&scene)?;
    let recorder = Recorder::create("out/example".as_ref(), &sim.body, true)?;
    let mut runner = Runner::new(recorder);
    // Frame 0, then every frame: Newton iterations, CG iterations, residual, min J …
    let ending = runner.run(&mut sim, |_, stats| {
        println!(
            "frame {}: {} Newton, {} CG",
            stats.frame, stats.newton_iterations, stats.cg_iterations
        )
    })?;
    runner.finish(&scene, &sim, &ending)
}
