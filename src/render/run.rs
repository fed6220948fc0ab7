//! The pictures of a whole run: `preview.png` (the last frame, framed and coloured on its own)
//! and `animation.gif` (every frame given, with one camera and one colour range for all).

use std::path::{Path, PathBuf};

use super::camera::facing_ground;
use super::{
    Bounds, FieldLocation, GifStream, Histogram, Plane, RenderMesh, RenderParams, SceneView,
    field_range, fit_camera, render_with_obstacles,
};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// One frame of a run, as saved.
#[derive(Clone, Copy, Debug)]
pub struct RunFrame<'a> {
    /// Frame number (0 is the initial state).
    pub frame: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Vertex positions (m).
    pub positions: &'a [Vec3],
    /// Values of the field the pictures are coloured by (see [`RenderParams::field`]); empty
    /// when the field is `None`.
    pub field: &'a [f64],
    /// Rigid obstacles at this frame as world triangles (m), drawn as shaded surfaces; empty
    /// without obstacles. The camera is fitted to them too.
    pub obstacles: &'a [[Vec3; 3]],
    /// A ground plane at this frame, drawn as the floor (see [`RenderParams::ground`]); None
    /// keeps `params`' own.
    pub ground: Option<Plane>,
}

/// How the pictures of a run look and how big they are (the `[output]` settings).
#[derive(Clone, Debug, PartialEq)]
pub struct RunPictureParams {
    /// Look and size of `preview.png`; the GIF frames share its look. Default: the
    /// [`RenderParams`] defaults (800×600, coloured by displacement).
    pub preview: RenderParams,
    /// Width of the GIF frames in pixels. Default 480.
    pub gif_width: u32,
    /// Height of the GIF frames in pixels. Default 360.
    pub gif_height: u32,
    /// Hundredths of a second each GIF frame shows (see [`gif_delay_cs`]). Default 4.
    pub gif_delay_cs: u16,
}

impl Default for RunPictureParams {
    fn default() -> Self {
        RunPictureParams {
            preview: RenderParams::default(),
            gif_width: 480,
            gif_height: 360,
            gif_delay_cs: 4,
        }
    }
}

/// The GIF delay that plays `seconds_per_frame` of simulated time per GIF frame in real
/// time, within what viewers honour: at least 2 (browsers slow anything faster down to 10) and
/// at most 100 hundredths of a second.
pub fn gif_delay_cs(seconds_per_frame: f64) -> u16 {
    if !seconds_per_frame.is_finite() {
        return 4;
    }
    (seconds_per_frame * 100.0).round().clamp(2.0, 100.0) as u16
}

/// The GIF's stride for frames 0..=`last`: `stride`, or the least larger one that keeps the GIF
/// (every stride-th frame and the last) within `budget` frames (0: no budget; a budget below 2
/// counts as 2, the first and the last frame).
pub fn gif_stride(last: usize, stride: usize, budget: usize) -> usize {
    let count = |s: usize| last / s + 1 + usize::from(!last.is_multiple_of(s));
    let mut s = stride.max(1);
    if budget == 0 {
        return s;
    }
    let budget = budget.max(2);
    // The least stride whose every-stride-th frames alone fit, then up to one more for the last.
    s = s.max(last.div_ceil(budget.saturating_sub(1).max(1)));
    while count(s) > budget {
        s += 1;
    }
    s
}

/// One frame of a run, owned (as a [`FrameSource`] loads it).
#[derive(Clone, Debug, Default)]
pub struct OwnedFrame {
    /// Frame number (0 is the initial state).
    pub frame: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Vertex positions (m).
    pub positions: Vec<Vec3>,
    /// Values of the field the pictures are coloured by; empty without a field.
    pub field: Vec<f64>,
    /// Obstacles as world triangles (m).
    pub obstacles: Vec<[Vec3; 3]>,
    /// A ground plane drawn as the floor.
    pub ground: Option<Plane>,
}

impl OwnedFrame {
    fn as_run_frame(&self) -> RunFrame<'_> {
        RunFrame {
            frame: self.frame,
            time: self.time,
            positions: &self.positions,
            field: &self.field,
            obstacles: &self.obstacles,
            ground: self.ground,
        }
    }
}

/// The frames of a run, loaded one at a time (from disk, say), so that drawing a run's pictures
/// holds one frame in memory whatever their number.
pub trait FrameSource {
    /// How many frames.
    fn len(&self) -> usize;
    /// True without frames.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Frame `i` (0-based among this source's frames).
    fn load(&mut self, i: usize) -> Result<OwnedFrame>;
}

/// Frames already in memory.
struct Slices<'a, 'b>(&'a [RunFrame<'b>]);

impl FrameSource for Slices<'_, '_> {
    fn len(&self) -> usize {
        self.0.len()
    }

    fn load(&mut self, i: usize) -> Result<OwnedFrame> {
        let f = &self.0[i];
        Ok(OwnedFrame {
            frame: f.frame,
            time: f.time,
            positions: f.positions.to_vec(),
            field: f.field.to_vec(),
            obstacles: f.obstacles.to_vec(),
            ground: f.ground,
        })
    }
}

/// Render `frames` (in order; the caller picks the stride and should include the last frame)
/// and write `preview.png` (the last frame at the preview size, with a camera and a colour
/// range of its own) and `animation.gif` (every frame at the GIF size, with one camera fitted to
/// all of them and one colour range over all of them, so that they line up) into `out_dir`.
/// Returns the paths written.
pub fn render_run(
    mesh: &RenderMesh,
    fixed: &[bool],
    frames: &[RunFrame<'_>],
    params: &RunPictureParams,
    out_dir: &Path,
) -> Result<Vec<PathBuf>> {
    render_run_from(mesh, fixed, &mut Slices(frames), params, out_dir)
}

/// [`render_run`] with the frames loaded one at a time: a pass for the camera and colour range,
/// the preview, a pass for the GIF's palette, and a pass that encodes the GIF into its file as
/// it goes. Memory holds one frame and one picture, however many frames there are.
pub fn render_run_from(
    mesh: &RenderMesh,
    fixed: &[bool],
    frames: &mut dyn FrameSource,
    params: &RunPictureParams,
    out_dir: &Path,
) -> Result<Vec<PathBuf>> {
    let count = frames.len();
    if count == 0 {
        return Err(Error::parameter("output", "no frames to render"));
    }
    let expected = params.preview.field.map(|kind| match kind.location() {
        FieldLocation::Vertex => mesh.vertex_count(),
        FieldLocation::Cell => mesh.tets().len(),
    });
    let mut bounds = Bounds::empty();
    let mut range = (f64::INFINITY, f64::NEG_INFINITY);
    let mut last = OwnedFrame::default();
    for i in 0..count {
        let f = frames.load(i)?;
        bounds.include(&f.positions);
        for t in &f.obstacles {
            bounds.include(t);
        }
        if let (Some(kind), Some(expected)) = (params.preview.field, expected) {
            if f.field.len() != expected {
                return Err(Error::parameter(
                    "render.field",
                    format!(
                        "frame {}: {} values of {kind}, expected {expected}",
                        f.frame,
                        f.field.len()
                    ),
                ));
            }
            let r = field_range([f.field.as_slice()]);
            if f.field.iter().any(|v| v.is_finite()) {
                range = (range.0.min(r.0), range.1.max(r.1));
            }
        }
        last = f;
    }
    let range = match params.preview.field {
        Some(_) if range.0 <= range.1 => range,
        Some(_) => (0.0, 0.0),
        None => (0.0, 1.0),
    };
    let draw_in = |f: &RunFrame<'_>, p: &RenderParams, camera, range| {
        let view = SceneView {
            mesh,
            positions: f.positions,
            field: f.field,
            fixed,
            time: f.time,
            frame: f.frame,
        };
        match f.ground {
            Some(ground) => {
                let p = RenderParams {
                    ground: Some(ground),
                    ..p.clone()
                };
                render_with_obstacles(&view, f.obstacles, camera, &p, range)
            }
            None => render_with_obstacles(&view, f.obstacles, camera, p, range),
        }
    };
    let draw = |f: &RunFrame<'_>, p: &RenderParams, camera| draw_in(f, p, camera, range);

    // The preview is one picture: fitted to its own frame (the body, and the obstacles beside
    // it) and coloured over its own values, so that what varies in it spans the colour bar.
    // A margin of a fifth of its size around it keeps the floor and the obstacles in view.
    let mut last_bounds = Bounds::of(&last.positions);
    for t in &last.obstacles {
        last_bounds.include(t);
    }
    if !last_bounds.is_empty() {
        let margin = Vec3::repeat(0.2 * last_bounds.diagonal());
        last_bounds.include(&[last_bounds.min - margin, last_bounds.max + margin]);
    }
    // A tilted ground (a slope) is seen from the side it faces.
    let preview_params = match last.ground {
        Some(g) => facing_ground(&params.preview, &g),
        None => params.preview.clone(),
    };
    let preview_camera = fit_camera(&last_bounds, &preview_params);
    let last_range = match params.preview.field {
        Some(_) if last.field.iter().any(|v| v.is_finite()) => field_range([last.field.as_slice()]),
        _ => range,
    };
    let preview = out_dir.join("preview.png");
    draw_in(
        &last.as_run_frame(),
        &preview_params,
        &preview_camera,
        last_range,
    )?
    .write_png(&preview)?;
    drop(last);

    let gif_params = RenderParams {
        width: params.gif_width,
        height: params.gif_height,
        ..preview_params
    };
    let gif_camera = fit_camera(&bounds, &gif_params);
    let mut histogram = Histogram::new(count, params.gif_width, params.gif_height)?;
    for i in 0..count {
        let f = frames.load(i)?;
        histogram.add(&draw(&f.as_run_frame(), &gif_params, &gif_camera)?)?;
    }
    let palette = histogram.palette();
    drop(histogram);
    let animation = out_dir.join("animation.gif");
    let mut failure = None;
    crate::io::atomic_write(&animation, |w| {
        let mut encode = || -> Result<()> {
            let mut stream = GifStream::new(
                &mut *w,
                &palette,
                params.gif_width,
                params.gif_height,
                params.gif_delay_cs,
            )?;
            for i in 0..count {
                let f = frames.load(i)?;
                stream.push(&draw(&f.as_run_frame(), &gif_params, &gif_camera)?)?;
            }
            Ok(())
        };
        encode().map_err(|e| {
            let message = e.to_string();
            failure = Some(e);
            std::io::Error::other(message)
        })
    })
    .map_err(|e| failure.take().unwrap_or(e))?;
    Ok(vec![preview, animation])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_play_in_real_time_within_limits() {
        assert_eq!(gif_delay_cs(1.0 / 30.0), 3);
        assert_eq!(gif_delay_cs(0.001), 2);
        assert_eq!(gif_delay_cs(5.0), 100);
        assert_eq!(gif_delay_cs(f64::NAN), 4);
    }

    #[test]
    fn the_gif_stride_is_the_least_that_keeps_the_frame_budget() {
        let count = |last: usize, s: usize| (0..=last).filter(|f| f % s == 0 || *f == last).count();
        for last in [0, 1, 2, 59, 299, 300, 301, 3000, 12345] {
            for (stride, budget) in [(1, 300), (1, 0), (4, 300), (1, 2), (1, 1), (7, 50)] {
                let s = gif_stride(last, stride, budget);
                assert!(s >= stride);
                if budget == 0 {
                    assert_eq!(s, stride);
                    continue;
                }
                assert!(
                    count(last, s) <= budget.max(2),
                    "{last} {stride} {budget}: {s}"
                );
                if s > stride {
                    assert!(
                        count(last, s - 1) > budget.max(2),
                        "{last} {stride} {budget}: {s}"
                    );
                }
            }
        }
        assert_eq!(gif_stride(3000, 1, 300), 11);
        assert_eq!(gif_stride(60, 1, 300), 1);
        assert_eq!(gif_stride(3000, 1, 150), 21);
    }
}
