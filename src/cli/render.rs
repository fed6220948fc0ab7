//! `tetsim render OUT_DIR`: re-render a saved run from its VTU frames (frames.pvd), with a
//! different field, camera, size or frame range, without re-simulating.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use tetsim::io::vtu::read_pvd;
use tetsim::math::Vec3;
use tetsim::render::{self, FieldChoice, FrameSource, RenderParams, RunPictureParams};

use super::saved::{SavedRun, render_saved, saved_up};

/// Arguments of `tetsim render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// A run's output folder (holding frames.pvd and its frame_NNNN.vtu).
    pub dir: PathBuf,
    /// Where to write preview.png and animation.gif (default: the run's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Colour field: auto (chosen from what the bodies did: displacement for held bodies,
    /// relative-displacement for free bodies that travel and deform, von-mises for free bodies
    /// that barely deform), displacement, relative-displacement (displacement less each body's
    /// best-fit rigid motion), velocity, contact-force, J, von-mises, energy-density or none.
    #[arg(long, default_value = "auto")]
    pub field: String,
    /// Camera azimuth about +y, degrees.
    #[arg(long, default_value_t = -35.0, allow_hyphen_values = true)]
    pub azimuth: f64,
    /// Camera elevation, degrees.
    #[arg(long, default_value_t = 22.0, allow_hyphen_values = true)]
    pub elevation: f64,
    /// Preview width and height in pixels.
    #[arg(long, default_value_t = 800)]
    pub width: u32,
    /// See --width.
    #[arg(long, default_value_t = 600)]
    pub height: u32,
    /// GIF frame width and height in pixels.
    #[arg(long, default_value_t = 480)]
    pub gif_width: u32,
    /// See --gif-width.
    #[arg(long, default_value_t = 360)]
    pub gif_height: u32,
    /// Frames to draw: FIRST..LAST (inclusive) or a single frame; default all.
    #[arg(long)]
    pub frames: Option<String>,
    /// Draw every k-th frame (the last one always).
    #[arg(long, default_value_t = 1)]
    pub stride: usize,
    /// Draw tet edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Cut the body open along a plane through the centre of the run with this normal (x, y or
    /// z), to see inside.
    #[arg(long)]
    pub cut: Option<char>,
}

pub fn run(args: RenderArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(args.stride > 0, "--stride must be at least 1");
    let pvd = args.dir.join("frames.pvd");
    let count = read_pvd(&pvd)?.len();
    anyhow::ensure!(count > 0, "{}: lists no frames", pvd.display());
    let (first, last) = frame_range(args.frames.as_deref(), count)?;
    let field = args.field.parse::<FieldChoice>()?;
    let stride = args.stride;
    let choose =
        |i: usize| (first..=last).contains(&i) && ((i - first).is_multiple_of(stride) || i == last);
    let up = saved_up(&args.dir);
    let mut run = SavedRun::open(&args.dir, None, up, choose)?;
    let (t0, t1) = run.time_span();
    let step = if run.len() > 1 {
        (t1 - t0) / (run.len() - 1) as f64
    } else {
        0.04
    };
    let clip = match args.cut {
        None => None,
        Some(axis) => {
            let normal = match axis {
                'x' => Vec3::x(),
                'y' => Vec3::y(),
                'z' => Vec3::z(),
                other => bail!("--cut takes x, y or z, not {other}"),
            };
            let mut bounds = render::Bounds::empty();
            for i in 0..run.len() {
                bounds.include(&run.load(i)?.positions);
            }
            Some(render::Plane::new(bounds.center(), normal))
        }
    };
    let params = RunPictureParams {
        preview: RenderParams {
            width: args.width,
            height: args.height,
            azimuth_deg: args.azimuth,
            elevation_deg: args.elevation,
            up,
            wireframe: args.wireframe,
            clip,
            ..Default::default()
        },
        gif_width: args.gif_width,
        gif_height: args.gif_height,
        gif_delay_cs: render::gif_delay_cs(step),
    };
    params.preview.validate()?;
    let out = args.out.clone().unwrap_or_else(|| args.dir.clone());
    std::fs::create_dir_all(&out).map_err(|e| tetsim::Error::io(&out, e))?;
    drop(run);
    let (written, colour) = render_saved(&args.dir, &out, &params, field, choose)?;
    if !quiet {
        eprintln!("{colour}");
        for path in &written {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Parse `FIRST..LAST` or `N` into an inclusive index range within `count` frames.
fn frame_range(spec: Option<&str>, count: usize) -> anyhow::Result<(usize, usize)> {
    let parse = |s: &str| {
        s.trim()
            .parse::<usize>()
            .with_context(|| format!("--frames: not a frame number: {s:?}"))
    };
    let (first, last) = match spec {
        None => (0, count - 1),
        Some(s) => match s.split_once("..") {
            Some((a, b)) => (
                if a.is_empty() { 0 } else { parse(a)? },
                if b.is_empty() { count - 1 } else { parse(b)? },
            ),
            None => {
                let n = parse(s)?;
                (n, n)
            }
        },
    };
    anyhow::ensure!(
        first <= last && last < count,
        "--frames {first}..{last} is outside the run's {count} frames (0..{})",
        count - 1
    );
    Ok((first, last))
}
