//! `tetsim check [SCENE] [--all-models]`: the derivative self-check on a scene's material and
//! body, as a table; exit code 1 when any check fails.

use std::path::PathBuf;
use std::process::ExitCode;

use tetsim::check::{CheckParams, check_simulation, check_terms};
use tetsim::material::{Model, ModelKind};
use tetsim::{Scene, Simulation};

/// Arguments of `tetsim check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// Scene file (TOML). Without it, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Check every model at the scene's parameters, not only the scene's model.
    #[arg(long)]
    pub all_models: bool,
    /// Random F per family (and 2× that many F of the initial state).
    #[arg(long, default_value_t = 8)]
    pub samples: usize,
    /// Seed of the random inputs.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Largest relative error a finite-difference check may show.
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
}

pub fn run(args: CheckArgs) -> anyhow::Result<ExitCode> {
    let scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    let sim = Simulation::from_scene(&scene)?;
    let params = CheckParams {
        fd_tolerance: args.tolerance,
        samples: args.samples.max(1),
        seed: args.seed,
        ..Default::default()
    };
    let lame = scene.lame().map_err(|m| anyhow::anyhow!("material: {m}"))?;
    let kinds: Vec<ModelKind> = if args.all_models {
        ModelKind::ALL.to_vec()
    } else {
        vec![sim.body.model.kind()]
    };
    let mut body = sim.body.clone();
    let mut passed = true;
    for kind in kinds {
        body.model = Model::new(kind, lame);
        println!(
            "{} (μ = {:.4e} Pa, λ = {:.4e} Pa) on {} vertices, {} tets:",
            kind.name(),
            lame.mu,
            lame.lambda,
            body.vertex_count(),
            body.tet_count()
        );
        let mut report = check_simulation(&body, &sim.state.x, &params);
        report.rows.extend(check_terms(
            &body,
            &sim.state.x,
            &sim.params,
            sim.boundary.gravity,
            &params,
        ));
        println!("{report}\n");
        passed &= report.passed();
    }
    Ok(if passed {
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "error: the self-check failed; if you changed a material, its P or dP does not match \
             its Ψ (see the FAIL rows above)"
        );
        ExitCode::FAILURE
    })
}
