//! The README's library snippet: run ten frames of the sample cantilever and write its frames.
//! `cargo run --release --example cantilever` (from the repository root).

use tetsim::output::Recorder;
use tetsim::{Scene, Simulation};

fn main() -> Result<(), tetsim::Error> {
    let mut scene = Scene::load("scenes/cantilever.toml".as_ref())?;
    scene.solver.frames = 10;
    let mut sim = Simulation::from_scene(&scene)?;
    let mut recorder = Recorder::create("out/example".as_ref(), &sim.body, true)?;
    // Frame 0, then every frame: Newton iterations, CG iterations, residual, min J …
    sim.run_with(&mut recorder, |_, stats| {
        println!(
            "frame {}: {} Newton, {} CG",
            stats.frame, stats.newton_iterations, stats.cg_iterations
        )
    })
}
