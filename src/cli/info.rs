//! `tetsim info [SCENE]`: what a scene is before running it (see [`tetsim::info`]): mass, volume,
//! bounding box, moduli and wave speeds, the lowest frequency (estimated) and the time steps
//! that follow, and the resolved parameters.

use std::path::PathBuf;

use tetsim::{Scene, Simulation};

/// Arguments of `tetsim info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// Scene file (TOML). Without it, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Print JSON: `info` (the object manifest.json holds) and `parameters` (every resolved
    /// parameter, as in manifest.json).
    #[arg(long)]
    pub json: bool,
    /// Describe a mesh the mesh doctor refuses (sets [mesh] force).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    scene.mesh.force |= args.force;
    let sim = Simulation::from_scene(&scene)?;
    let info = tetsim::info::describe(&scene, &sim);
    if args.json {
        let value = serde_json::json!({
            "info": info.to_json(),
            "parameters": tetsim::manifest::resolved_parameters(&scene, &sim)?,
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        println!("scene: {}", scene.path.display());
        print!("{}", tetsim::info::report(&info, &sim));
    }
    Ok(())
}
