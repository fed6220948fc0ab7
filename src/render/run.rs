//! The pictures of a whole run: `preview.png` (the last frame) and `animation.gif` (every
//! frame given), with one camera and one colour range for all of them.

use std::path::{Path, PathBuf};

use super::{
    Bounds, FieldLocation, Image, Plane, RenderMesh, RenderParams, SceneView, field_range,
    fit_camera, render_with_obstacles, write_gif,
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

/// Render `frames` (in order; the caller picks the stride and should include the last frame)
/// with one camera fitted to all of them and one colour range over all of them; write
/// `preview.png` (the last frame, at the preview size) and `animation.gif` (every frame, at
/// the GIF size) into `out_dir`. Returns the paths written.
pub fn render_run(
    mesh: &RenderMesh,
    fixed: &[bool],
    frames: &[RunFrame<'_>],
    params: &RunPictureParams,
    out_dir: &Path,
) -> Result<Vec<PathBuf>> {
    let last = frames
        .last()
        .ok_or_else(|| Error::parameter("output", "no frames to render"))?;
    let mut bounds = Bounds::empty();
    for f in frames {
        bounds.include(f.positions);
        for t in f.obstacles {
            bounds.include(t);
        }
    }
    let range = match params.preview.field {
        Some(kind) => {
            let expected = match kind.location() {
                FieldLocation::Vertex => mesh.vertex_count(),
                FieldLocation::Cell => mesh.tets().len(),
            };
            if let Some(f) = frames.iter().find(|f| f.field.len() != expected) {
                return Err(Error::parameter(
                    "render.field",
                    format!(
                        "frame {}: {} values of {kind}, expected {expected}",
                        f.frame,
                        f.field.len()
                    ),
                ));
            }
            field_range(frames.iter().map(|f| f.field))
        }
        None => (0.0, 1.0),
    };
    let draw = |f: &RunFrame<'_>, p: &RenderParams, camera| {
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

    let preview_camera = fit_camera(&bounds, &params.preview);
    let preview = out_dir.join("preview.png");
    draw(last, &params.preview, &preview_camera)?.write_png(&preview)?;

    let gif_params = RenderParams {
        width: params.gif_width,
        height: params.gif_height,
        ..params.preview.clone()
    };
    let gif_camera = fit_camera(&bounds, &gif_params);
    let images = frames
        .iter()
        .map(|f| draw(f, &gif_params, &gif_camera))
        .collect::<Result<Vec<Image>>>()?;
    let animation = out_dir.join("animation.gif");
    write_gif(&animation, &images, params.gif_delay_cs)?;
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
}
