//! Render surfaces in the output folder: `render_NNNN.obj` every frame (every body's surface,
//! deformed, normals recomputed, texture coordinates, groups and materials kept) and, at the
//! end of a run, `render.glb`, the whole animation in one file (see [`crate::io::gltf`]).
//!
//! Several bodies with render surfaces share one `render_NNNN.obj`: each body's part starts
//! with `o <body name>` (its own objects become `o <body name>.<object>`), so that Blender
//! imports one object per body. The `.mtl` files a surface names are copied beside the frames,
//! their texture paths made absolute, so that the frames open with their materials.
//!
//! The animation is assembled from the `render_NNNN.obj` files on disk when the run ends, so a
//! resumed run's animation covers the frames written before the stop as well.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::io::atomic_write;
use crate::io::gltf::{AnimatedSurface, mtl_colours, write_glb};
use crate::io::render_obj::{RenderSurface, read_obj_positions, write_render_obj};
use crate::math::Vec3;
use crate::sim::Simulation;

/// The animation's file name.
pub const ANIMATION_FILE: &str = "render.glb";

/// The name of frame `frame`'s render surfaces.
pub fn render_file(frame: usize) -> String {
    format!("render_{frame:04}.obj")
}

/// What the recorder keeps to write render surfaces.
pub(super) struct RenderOutput {
    bodies: Vec<Part>,
}

struct Part {
    name: String,
    surface: Arc<RenderSurface>,
    /// The `mtllib` names as written (copied files' names).
    mtllibs: Vec<String>,
    /// Material colours from the `.mtl` files.
    colours: Vec<(String, [f64; 4])>,
}

impl RenderOutput {
    /// For `sim`'s render surfaces (None without any): copies their `.mtl` files into `dir`.
    pub fn new(sim: &Simulation, dir: &Path) -> Result<Option<RenderOutput>> {
        let render = sim.render_bodies();
        if render.is_empty() {
            return Ok(None);
        }
        let mut bodies = Vec::new();
        for r in render {
            let folder = r.source.parent().unwrap_or(Path::new("."));
            let mut mtllibs = Vec::new();
            let mut colours = Vec::new();
            for lib in &r.surface.mtllibs {
                let source = folder.join(lib);
                let Some(name) = source.file_name().map(|n| n.to_string_lossy().into_owned())
                else {
                    continue;
                };
                if source.is_file() {
                    copy_mtl(&source, &dir.join(&name))?;
                    colours.extend(mtl_colours(&source));
                } else {
                    log::warn!(
                        "{}: names the material file {lib}, which is not there",
                        r.source.display()
                    );
                }
                mtllibs.push(name);
            }
            bodies.push(Part {
                name: r.name.clone(),
                surface: Arc::clone(&r.surface),
                mtllibs,
                colours,
            });
        }
        Ok(Some(RenderOutput { bodies }))
    }

    /// Write frame `frame`'s `render_NNNN.obj` into `dir` with every surface's `positions`.
    pub fn write_frame(
        &self,
        dir: &Path,
        frame: usize,
        positions: &[Vec<Vec3>],
    ) -> Result<PathBuf> {
        let path = dir.join(render_file(frame));
        let several = self.bodies.len() > 1;
        atomic_write(&path, |w| {
            let total: usize = self.bodies.iter().map(|b| b.surface.positions.len()).sum();
            writeln!(
                w,
                "# tetsim render surfaces, frame {frame}: {total} vertices"
            )?;
            let mut offsets = [0, 0];
            for (part, p) in self.bodies.iter().zip(positions) {
                let object = several.then_some(part.name.as_str());
                write_render_obj(w, &part.surface, p, &part.mtllibs, object, offsets)?;
                offsets[0] += part.surface.positions.len();
                offsets[1] += part.surface.texcoords.len();
            }
            Ok(())
        })?;
        Ok(path)
    }

    /// Write `render.glb` into `dir` from the `render_NNNN.obj` of `frames` (frame, time).
    pub fn write_animation(&self, dir: &Path, frames: &[(usize, f64)]) -> Result<Option<PathBuf>> {
        if frames.is_empty() {
            return Ok(None);
        }
        let surfaces: Vec<AnimatedSurface> = self
            .bodies
            .iter()
            .map(|b| AnimatedSurface {
                name: &b.name,
                surface: &b.surface,
                colours: b.colours.clone(),
            })
            .collect();
        // Times as the frames have them; a run without increasing times (quasistatic load
        // factors that repeat) plays at 24 frames per second.
        let increasing = frames.windows(2).all(|w| w[1].1 > w[0].1);
        let times: Vec<f64> = frames
            .iter()
            .map(|&(k, t)| if increasing { t } else { k as f64 / 24.0 })
            .collect();
        let path = dir.join(ANIMATION_FILE);
        write_glb(&path, &surfaces, &times, |k| {
            read_obj_positions(&dir.join(render_file(frames[k].0)))
        })
        .map_err(|e| match e {
            Error::Parameter { message, .. } => Error::parameter("render", message),
            e => e,
        })?;
        Ok(Some(path))
    }
}

/// Copy a `.mtl` file, its texture paths made absolute where they name a file beside it.
fn copy_mtl(source: &Path, target: &Path) -> Result<()> {
    let text = crate::io::read_text(source)?;
    let folder = source.parent().unwrap_or(Path::new("."));
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let trimmed = line.trim();
        let texture = ["map_", "bump", "disp", "decal", "refl", "norm"]
            .iter()
            .any(|k| trimmed.starts_with(k));
        let last = trimmed.split_whitespace().last().unwrap_or("");
        let file = folder.join(last);
        if texture && Path::new(last).is_relative() && file.is_file() {
            let absolute = std::path::absolute(&file).unwrap_or(file);
            let head = &trimmed[..trimmed.len() - last.len()];
            out.push_str(head);
            out.push_str(&absolute.display().to_string());
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    atomic_write(target, |w| w.write_all(out.as_bytes()))
}
