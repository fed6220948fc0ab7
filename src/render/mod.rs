//! Pictures without a GPU, an X server or ffmpeg: a software renderer for the deformed boundary
//! surface, PNG and GIF writers, and plots of the per-step statistics.
//!
//! The pipeline for one frame:
//! 1. [`RenderMesh`] (built once per mesh) holds the boundary triangles, the tet behind each of
//!    them and the vertex → triangle incidence.
//! 2. [`fit_camera`] places a perspective camera so that the bounding box of the *whole run*
//!    fills the frame: every frame of a run uses the same camera, so frames line up.
//! 3. [`render`] builds the triangles (crease-aware smooth normals, optional cut-away by a
//!    [`Plane`] that exposes the cut faces of the tets), rasterises them into a supersampled
//!    z-buffer band of rows by band (so memory never holds the whole supersampled frame),
//!    shades every sample (key and fill light, hemisphere ambient, wireframe edges),
//!    draws a floor with a grid and a soft contact shadow behind the object, filters down to the
//!    output size and draws the overlays: fixed-vertex markers, the colour bar with its label,
//!    units and ticks, and a caption (frame, time). [`render_with_obstacles`] adds rigid
//!    obstacles as shaded surfaces, and [`RenderParams::ground`] puts the floor on a ground
//!    plane obstacle ([`ObstacleView`] picks it).
//! 4. [`Image::write_png`] and [`write_gif`] write the results atomically (temp file + rename).
//!
//! [`render_run`] does all of this for a run: `preview.png` (the last frame) and
//! `animation.gif` (every frame given), one camera and one colour range for all frames.
//! [`plot_steps`] draws `steps.csv`.
//!
//! Colours are computed in linear light and encoded as sRGB at the end, so the anti-aliasing
//! average is right. Everything is deterministic: the same input gives the same bytes, on any
//! number of threads.

mod animation;
mod camera;
mod colormap;
mod floor;
mod geometry;
mod image;
mod obstacles;
pub mod plot;
mod raster;
mod run;
mod text;

use crate::error::{Error, Result};
use crate::math::Vec3;

pub use crate::elastic::{VON_MISES_MIN_J, von_mises};
pub use animation::{GifPalette, GifStream, Histogram, encode_gif, write_gif};
pub use camera::{Bounds, Camera, fit_camera};
pub use colormap::viridis;
// The fields live outside the renderer (scene validation needs them without pictures);
// re-exported so `render::FieldKind` keeps working.
pub use crate::field::{
    FieldChoice, FieldKind, FieldLocation, MotionSummary, displacement_magnitudes, field_range,
    field_values, relative_displacements,
};
pub use geometry::RenderMesh;
pub use image::Image;
pub use obstacles::ObstacleView;
pub use plot::{plot_series, plot_steps};
pub use run::{
    FrameSource, OwnedFrame, RunFrame, RunPictureParams, gif_delay_cs, gif_stride, render_run,
    render_run_from,
};

/// How triangles are lit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// One normal per triangle: facets show, good for judging mesh resolution.
    Flat,
    /// Normals averaged over neighbouring faces, except across creases sharper than
    /// [`CREASE_ANGLE_DEG`] (so a box keeps its edges while a bent beam looks smooth).
    #[default]
    Smooth,
    /// No lighting: every pixel shows exactly the colour map's colour (for reading values).
    Unlit,
}

/// Faces meeting at a sharper angle than this keep separate normals in [`Shading::Smooth`]:
/// a box's 90° edges stay crisp while the few-degree kinks of a bent, finely meshed beam vanish.
pub const CREASE_ANGLE_DEG: f64 = 40.0;

/// A cut-away plane: everything on the side `normal` points to is removed, and the cut faces of
/// the tets crossing the plane close the remaining volume, coloured by the field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane (m).
    pub point: Vec3,
    /// Points towards the removed half-space; need not be unit length.
    pub normal: Vec3,
}

impl Plane {
    /// The plane through `point` with `normal` (towards the removed side).
    pub fn new(point: Vec3, normal: Vec3) -> Self {
        Plane { point, normal }
    }
}

/// Everything about how a picture looks. Plain fields with sensible defaults (800×600,
/// supersampled 3×3, camera from the front left and a little above, smooth shading, floor and
/// colour bar on).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderParams {
    /// Output width in pixels. Default 800.
    pub width: u32,
    /// Output height in pixels. Default 600.
    pub height: u32,
    /// Samples per pixel along each axis (anti-aliasing); 1 turns it off, 3 (default) gives
    /// smooth edges, 4 is marginally better and 16/9 slower.
    pub supersample: u32,
    /// Camera azimuth in degrees about the up axis; 0 looks at the model from +z (x to the
    /// right, for up = +y), negative values swing the camera towards −x. Default −35. A run's
    /// pictures mirror it across a tilted ground's fall line when it would look at the slope
    /// from uphill, where the slope falls away out of sight.
    pub azimuth_deg: f64,
    /// Camera elevation above the floor plane in degrees (90 looks straight down). Default 22.
    pub elevation_deg: f64,
    /// Vertical field of view in degrees. Smaller is flatter (more like an orthographic
    /// drawing), larger exaggerates depth. Default 30.
    pub fov_deg: f64,
    /// The world's up direction (the floor is perpendicular to it). Default +y, the opposite
    /// of the default gravity; [`up_from_gravity`] gives a scene's.
    pub up: Vec3,
    /// What colours the surface; `None` paints it a neutral colour and drops the colour bar.
    pub field: Option<FieldKind>,
    /// How triangles are lit. Default [`Shading::Smooth`].
    pub shading: Shading,
    /// Draw the mesh's triangle edges. Default false.
    pub wireframe: bool,
    /// Outline feature edges with thin dark lines: creases sharper than
    /// [`CREASE_ANGLE_DEG`], open edges, and where a cut meets the surface. Default true
    /// (shapes read better, especially in the dark end of the colour map).
    pub outline: bool,
    /// Cut the model open with this plane. Default none.
    pub clip: Option<Plane>,
    /// A floor under the whole run's bounding box, with a metric grid and a soft contact
    /// shadow. Default true.
    pub show_floor: bool,
    /// A ground plane (a plane obstacle): the floor is drawn there, in its orientation, instead
    /// of under the bounding box; `normal` points to the free side. Default none.
    pub ground: Option<Plane>,
    /// Cut away the near half of obstacles that surround the body (a bowl, a box around it),
    /// upright through the body's centre, so that the body shows. Default true.
    pub cut_obstacles: bool,
    /// Mark fixed (Dirichlet) vertices with red dots (thinned where they crowd). Default true.
    pub show_fixed: bool,
    /// A caption line at the top: the title, frame number and time. Default true.
    pub show_caption: bool,
    /// Text before the frame number in the caption (e.g. the scene name). Default empty.
    pub title: String,
}

impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            width: 800,
            height: 600,
            supersample: 3,
            azimuth_deg: -35.0,
            elevation_deg: 22.0,
            fov_deg: 30.0,
            up: Vec3::y(),
            field: Some(FieldKind::Displacement),
            shading: Shading::Smooth,
            wireframe: false,
            outline: true,
            clip: None,
            show_floor: true,
            ground: None,
            cut_obstacles: true,
            show_fixed: true,
            show_caption: true,
            title: String::new(),
        }
    }
}

impl RenderParams {
    /// Reject sizes and angles that cannot make a picture.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, message: String| Err(Error::parameter(name, message));
        if self.width < 16 || self.height < 16 || self.width > 16384 || self.height > 16384 {
            return bad(
                "render.size",
                format!(
                    "{}x{} pixels: width and height must lie in 16..=16384",
                    self.width, self.height
                ),
            );
        }
        if !(1..=8).contains(&self.supersample) {
            return bad(
                "render.supersample",
                format!("{}: must lie in 1..=8", self.supersample),
            );
        }
        if !(self.fov_deg > 1.0 && self.fov_deg < 150.0) {
            return bad(
                "render.fov",
                format!("{} degrees: must lie in (1, 150)", self.fov_deg),
            );
        }
        if !(self.azimuth_deg.is_finite() && self.elevation_deg.is_finite()) {
            return bad(
                "render.camera",
                "azimuth and elevation must be finite".into(),
            );
        }
        if !(self.up.norm() > 0.0 && self.up.iter().all(|c| c.is_finite())) {
            return bad("render.up", "must be a finite, non-zero vector".into());
        }
        for (key, plane) in [("render.ground", &self.ground), ("render.clip", &self.clip)] {
            if let Some(plane) = plane
                && !(plane.normal.norm() > 0.0
                    && plane
                        .normal
                        .iter()
                        .chain(plane.point.iter())
                        .all(|c| c.is_finite()))
            {
                return bad(
                    key,
                    "the plane needs a finite point and a non-zero normal".into(),
                );
            }
        }
        Ok(())
    }
}

/// One frame to draw: the mesh, where its vertices are now, and what to colour by.
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    /// Boundary triangles and their tets, prepared once per mesh.
    pub mesh: &'a RenderMesh,
    /// Current vertex positions (m).
    pub positions: &'a [Vec3],
    /// The values of [`RenderParams::field`]: one per vertex or one per tet, as its
    /// [`FieldKind::location`] says (see [`field_values`]). Ignored when the field is `None`.
    pub field: &'a [f64],
    /// Fixed (Dirichlet) vertices; empty when nothing is fixed.
    pub fixed: &'a [bool],
    /// Simulated time (s), for the caption.
    pub time: f64,
    /// Frame number, for the caption.
    pub frame: usize,
}

impl SceneView<'_> {
    fn validate(&self, params: &RenderParams) -> Result<()> {
        let n = self.mesh.vertex_count();
        if self.positions.len() != n {
            return Err(Error::parameter(
                "render.positions",
                format!(
                    "{} positions for a mesh of {n} vertices",
                    self.positions.len()
                ),
            ));
        }
        if !self.fixed.is_empty() && self.fixed.len() != n {
            return Err(Error::parameter(
                "render.fixed",
                format!("{} flags for a mesh of {n} vertices", self.fixed.len()),
            ));
        }
        if let Some(kind) = params.field {
            let (expected, what) = match kind.location() {
                FieldLocation::Vertex => (n, "vertices"),
                FieldLocation::Cell => (self.mesh.tets().len(), "tets"),
            };
            if self.field.len() != expected {
                return Err(Error::parameter(
                    "render.field",
                    format!(
                        "{} values of {kind} for a mesh of {expected} {what}",
                        self.field.len()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Render one frame to an RGB image of `params.width × params.height`.
///
/// `camera` comes from [`fit_camera`] on the bounding box of every frame of the run, and
/// `field_range` (from [`field_range`] over every frame) maps values to colours, so colours
/// and positions are comparable between frames. The range's low end gets the colour map's
/// first colour (dark purple), its high end the last (yellow); values outside are clamped.
pub fn render(
    view: &SceneView<'_>,
    camera: &Camera,
    params: &RenderParams,
    field_range: (f64, f64),
) -> Result<Image> {
    render_with_obstacles(view, &[], camera, params, field_range)
}

/// [`render`] with rigid obstacles drawn beside the body as shaded surfaces: `obstacles` are
/// their triangles in world coordinates (a ground plane goes to [`RenderParams::ground`]
/// instead, to be drawn as the floor).
pub fn render_with_obstacles(
    view: &SceneView<'_>,
    obstacles: &[[Vec3; 3]],
    camera: &Camera,
    params: &RenderParams,
    field_range: (f64, f64),
) -> Result<Image> {
    params.validate()?;
    view.validate(params)?;
    Ok(raster::render_frame(
        view,
        obstacles,
        camera,
        params,
        sanitize_range(field_range),
    ))
}

/// The up direction of a scene's pictures: against gravity, so that things fall down the
/// picture and a ground tilted against gravity (a slope) shows tilted; +y without gravity.
pub fn up_from_gravity(gravity: Vec3) -> Vec3 {
    match (-gravity).try_normalize(1e-300) {
        Some(up) if up.iter().all(|c| c.is_finite()) => up,
        _ => Vec3::y(),
    }
}

/// Which of `planes` (point, normal towards the free side) is the ground: the one whose normal
/// is closest to `up`, if it is within 60° of it (a wall is not a floor). Ties: the first.
pub fn ground_plane(planes: &[Plane], up: Vec3) -> Option<usize> {
    let up = up.try_normalize(1e-300)?;
    let mut best: Option<(usize, f64)> = None;
    for (i, p) in planes.iter().enumerate() {
        let Some(n) = p.normal.try_normalize(1e-300) else {
            continue;
        };
        let c = n.dot(&up);
        if c > 0.5 && best.is_none_or(|(_, b)| c > b) {
            best = Some((i, c));
        }
    }
    best.map(|(i, _)| i)
}

/// A usable colour range: finite, ordered and of non-zero width (a constant field shows the
/// low-end colour, and the bar shows ticks around the constant).
fn sanitize_range((lo, hi): (f64, f64)) -> (f64, f64) {
    let (lo, hi) = match (lo.is_finite(), hi.is_finite()) {
        (true, true) => (lo.min(hi), lo.max(hi)),
        (true, false) => (lo, lo),
        (false, true) => (hi, hi),
        (false, false) => (0.0, 1.0),
    };
    if hi - lo > 1e-12 * lo.abs().max(hi.abs()) && hi > lo {
        (lo, hi)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        if lo >= 0.0 && lo - pad < 0.0 {
            (0.0, lo + pad)
        } else {
            (lo - pad, lo + pad)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_ranges_get_width() {
        assert_eq!(sanitize_range((0.0, 0.0)), (0.0, 1.0));
        assert_eq!(sanitize_range((2.0, 1.0)), (1.0, 2.0));
        let (lo, hi) = sanitize_range((1.0, 1.0));
        assert!(lo < 1.0 && hi > 1.0);
        assert_eq!(sanitize_range((f64::NAN, f64::INFINITY)), (0.0, 1.0));
    }
}
