//! `[output]`: where a run's files go and what pictures it draws.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::scene::units;

/// `[output]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Output folder, relative to the working directory. Default "out".
    pub dir: PathBuf,
    /// Write a surface OBJ per frame. Default true.
    pub obj: bool,
    /// Render `preview.png` (last frame) and `animation.gif` after the run. Default true.
    pub pictures: bool,
    /// Plot steps.csv into `steps_*.png` after the run. Default true.
    pub plots: bool,
    /// Colour field of the pictures: "auto" (default: chosen from what the bodies did, see
    /// [`crate::field::MotionSummary::choose`]), "displacement", "relative-displacement",
    /// "velocity", "contact-force", "J", "von-mises", "energy-density" or "none".
    pub field: String,
    /// Size of `preview.png` in pixels. Default 800 × 600.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Size of the GIF frames in pixels. Default 480 × 360.
    pub gif_width: u32,
    /// See `gif_width`.
    pub gif_height: u32,
    /// Every k-th frame goes into the GIF (the last frame always does). Default 1.
    pub gif_stride: usize,
    /// The most frames the GIF holds: the stride grows past `gif_stride` as a long run needs
    /// (0: no limit, every `gif_stride`-th frame). Default 150.
    pub gif_frames: usize,
    /// Wall-clock time between checkpoints, s: a frame finished this long after the last
    /// checkpoint writes `checkpoint.bin` (0: every frame). The first frame, the last and a
    /// stopped run's last frame always write one. Default 30 s.
    #[serde(deserialize_with = "units::scalar::<_, units::Time>")]
    pub checkpoint_every: f64,
    /// Also write a checkpoint every this many frames (0: by time only). Default 0.
    pub checkpoint_frames: usize,
    /// Camera azimuth about the up (+y) axis, degrees. Default −35.
    #[serde(deserialize_with = "units::scalar::<_, units::Degrees>")]
    pub azimuth: f64,
    /// Camera elevation above the horizon, degrees. Default 22.
    #[serde(deserialize_with = "units::scalar::<_, units::Degrees>")]
    pub elevation: f64,
    /// Write 0 in steps.csv's wall_seconds column, so that every output file is byte-identical
    /// across runs and thread counts (the times go to timings.csv either way). Default false.
    pub deterministic: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            dir: PathBuf::from("out"),
            obj: true,
            pictures: true,
            plots: true,
            field: "auto".into(),
            width: 800,
            height: 600,
            gif_width: 480,
            gif_height: 360,
            gif_stride: 1,
            gif_frames: 150,
            checkpoint_every: 30.0,
            checkpoint_frames: 0,
            azimuth: -35.0,
            elevation: 22.0,
            deterministic: false,
        }
    }
}
