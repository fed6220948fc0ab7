//! The rasteriser: projection, a supersampled z-buffer filled band by band in parallel, deferred
//! shading of every sample (key and fill light, hemisphere ambient, wireframe, floor with grid
//! and contact shadow, background gradient), the box filter down to the output size, and the
//! overlays.
//!
//! The picture is made in horizontal bands of output rows: each band's supersampled z-buffer is
//! filled, shaded and filtered down into the output image, and its buffers are reused for the
//! next band. Memory holds a band per thread, never the whole supersampled frame (an 800×600
//! picture at 3×3 would need 35 MB for it).
//!
//! Deterministic by construction: each band is rasterised by one thread with the triangles in a
//! fixed order (the nearer sample wins, the earlier triangle on a tie), and each output pixel is
//! shaded from its own samples only, so neither the thread count nor the band height changes a
//! byte.

use rayon::prelude::*;

use super::camera::Camera;
use super::colormap::{LinearViridis, SrgbEncoder, srgb_to_linear};
use super::floor::Floor;
use super::geometry::{Tri, build_triangles, obstacle_triangles};
use super::image::Image;
use super::text::{self, Align, INK, MARKER_EDGE, MARKER_FILL};
use super::{RenderParams, SceneView, Shading};
use crate::math::Vec3;

mod markers;
use markers::MarkerCandidates;

/// Output rows per band (one parallel work item; its z-buffer holds this many rows times the
/// supersampling factor, squared, times the width: 8 × 9 × 800 samples, 460 kB, by default).
const BAND_ROWS: usize = 8;

/// Colours (sRGB) of the scene.
const PLAIN: [u8; 3] = [142, 170, 204];
const CAP_PLAIN: [u8; 3] = [214, 168, 134];
const NO_VALUE: [u8; 3] = [150, 150, 150];
/// Rigid obstacles: a warm grey, apart from the body's colours and the floor.
const OBSTACLE: [u8; 3] = [176, 168, 158];
const SKY_TOP: [u8; 3] = [252, 252, 253];
const SKY_BOTTOM: [u8; 3] = [208, 213, 221];

/// A rectangle in output pixels.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rect {
    pub x: f64,
    pub y: f64,
    pub w: f64,
    pub h: f64,
}

/// Where things go in the picture: the 3D viewport, the colour bar, the text size.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    pub viewport: Rect,
    /// (x, y, w, h) of the gradient, in pixels.
    pub colorbar: Option<(i64, i64, i64, i64)>,
    pub font_px: f32,
    pub margin: f64,
    pub top: f64,
}

impl Layout {
    pub(crate) fn new(params: &RenderParams, has_field: bool) -> Layout {
        let (w, h) = (params.width as f64, params.height as f64);
        let font = (h * 0.026).clamp(9.0, 30.0).round();
        let margin = (0.8 * font).round();
        let top = if params.show_caption {
            (2.0 * font).round()
        } else {
            margin
        };
        let bottom = if params.show_floor || params.show_fixed {
            (1.9 * font).round()
        } else {
            margin
        };
        let mut right = w - margin;
        let colorbar = has_field.then(|| {
            let tick_text = 3.6 * font;
            let bar_w = font.max(6.0).round();
            let x = (w - margin - tick_text - 0.7 * font - bar_w).round();
            let label = 2.9 * font;
            let avail = h - top - bottom;
            let bar_h = (0.62 * avail).round().max(8.0);
            let y = (top + 0.5 * (avail - bar_h - label) + label).round();
            right = x - 1.2 * font;
            (x as i64, y as i64, bar_w as i64, bar_h as i64)
        });
        let right = right.max(margin + 0.3 * w);
        Layout {
            viewport: Rect {
                x: margin,
                y: top,
                w: right - margin,
                h: (h - top - bottom).max(8.0),
            },
            colorbar,
            font_px: font as f32,
            margin,
            top,
        }
    }
}

/// World → supersampled screen.
struct Projection {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    focal: f64,
    cx: f64,
    cy: f64,
    near: f64,
    /// Diagonal of the scene box (m), the scale for depth tolerances.
    scale: f64,
}

impl Projection {
    fn new(camera: &Camera, viewport: &Rect, ss: f64) -> Self {
        Projection {
            eye: camera.eye,
            right: camera.right,
            up: camera.up,
            forward: camera.forward,
            focal: 0.5 * viewport.h * ss / camera.tan_half_fov,
            cx: (viewport.x + 0.5 * viewport.w) * ss,
            cy: (viewport.y + 0.5 * viewport.h) * ss,
            near: 1e-6 * camera.bounds.diagonal().max(1e-300),
            scale: camera.bounds.diagonal(),
        }
    }

    /// (x, y, depth) or None behind the near plane.
    fn project(&self, p: &Vec3) -> Option<[f64; 3]> {
        let d = p - self.eye;
        let z = d.dot(&self.forward);
        if z.is_nan() || z <= self.near {
            return None;
        }
        Some([
            self.cx + d.dot(&self.right) / z * self.focal,
            self.cy - d.dot(&self.up) / z * self.focal,
            z,
        ])
    }

    /// The ray through a screen point, scaled so that its component along `forward` is 1 (so
    /// the ray parameter is the depth).
    fn ray(&self, sx: f64, sy: f64) -> Vec3 {
        self.forward + self.right * ((sx - self.cx) / self.focal)
            - self.up * ((sy - self.cy) / self.focal)
    }
}

/// A projected triangle ready for scan conversion and for barycentrics at any sample.
struct Setup {
    tri: u32,
    x: [f64; 3],
    y: [f64; 3],
    inv_z: [f64; 3],
    inv_area2: f64,
    /// 1 / screen length of edge k (from corner k to k+1).
    inv_len: [f64; 3],
    rows: (usize, usize),
    cols: (usize, usize),
}

impl Setup {
    fn new(tri: &Tri, index: usize, proj: &Projection, w: usize, h: usize) -> Option<Setup> {
        let s = [
            proj.project(&tri.p[0])?,
            proj.project(&tri.p[1])?,
            proj.project(&tri.p[2])?,
        ];
        let x = [s[0][0], s[1][0], s[2][0]];
        let y = [s[0][1], s[1][1], s[2][1]];
        let area2 = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        if area2.is_nan() || area2.abs() <= 1e-12 {
            return None;
        }
        let min = |v: &[f64; 3]| v[0].min(v[1]).min(v[2]);
        let max = |v: &[f64; 3]| v[0].max(v[1]).max(v[2]);
        let (x0, x1, y0, y1) = (min(&x), max(&x), min(&y), max(&y));
        if x1 < 0.0 || y1 < 0.0 || x0 >= w as f64 || y0 >= h as f64 {
            return None;
        }
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        let len = |k: usize| {
            let j = (k + 1) % 3;
            1.0 / (x[j] - x[k]).hypot(y[j] - y[k]).max(1e-12)
        };
        Some(Setup {
            tri: index as u32,
            x,
            y,
            inv_z: [1.0 / s[0][2], 1.0 / s[1][2], 1.0 / s[2][2]],
            inv_area2: 1.0 / area2,
            inv_len: [len(0), len(1), len(2)],
            rows: (clamp(y0.floor(), h), clamp(y1.ceil(), h)),
            cols: (clamp(x0.floor(), w), clamp(x1.ceil(), w)),
        })
    }

    /// Signed edge function of edge k (corner k → k+1) at (px, py).
    fn edge(&self, k: usize, px: f64, py: f64) -> f64 {
        let j = (k + 1) % 3;
        (self.x[j] - self.x[k]) * (py - self.y[k]) - (self.y[j] - self.y[k]) * (px - self.x[k])
    }

    /// Screen-space barycentric coordinates of (px, py).
    fn lambdas(&self, px: f64, py: f64) -> [f64; 3] {
        [
            self.edge(1, px, py) * self.inv_area2,
            self.edge(2, px, py) * self.inv_area2,
            self.edge(0, px, py) * self.inv_area2,
        ]
    }

    /// Perspective-correct barycentric coordinates of (px, py).
    fn perspective(&self, px: f64, py: f64) -> [f64; 3] {
        let l = self.lambdas(px, py);
        let w = [
            l[0] * self.inv_z[0],
            l[1] * self.inv_z[1],
            l[2] * self.inv_z[2],
        ];
        let s = w[0] + w[1] + w[2];
        [w[0] / s, w[1] / s, w[2] / s]
    }

    /// Scan-convert rows [row0, row0 + rows) into the band's depth and id buffers.
    fn rasterize(&self, row0: usize, w: usize, depth: &mut [f32], ids: &mut [u32]) {
        const EPS: f64 = -1e-9;
        let rows = depth.len() / w;
        let first = self.rows.0.max(row0);
        let last = self.rows.1.min(row0 + rows - 1);
        // λ_i(px) = slope_i·px + offset_i(py) along a row.
        let slope = [
            -(self.y[2] - self.y[1]) * self.inv_area2,
            -(self.y[0] - self.y[2]) * self.inv_area2,
            -(self.y[1] - self.y[0]) * self.inv_area2,
        ];
        for row in first..=last {
            let py = row as f64 + 0.5;
            let offset = self.lambdas(0.0, py);
            let (mut lo, mut hi) = (self.cols.0 as f64, self.cols.1 as f64 + 1.0);
            for k in 0..3 {
                if slope[k] > 0.0 {
                    lo = lo.max((EPS - offset[k]) / slope[k]);
                } else if slope[k] < 0.0 {
                    hi = hi.min((EPS - offset[k]) / slope[k]);
                } else if offset[k] < EPS {
                    hi = lo - 1.0;
                }
            }
            if hi < lo {
                continue;
            }
            let c0 = ((lo - 0.5).ceil().max(0.0)) as usize;
            let c1 = ((hi - 0.5).floor().min((w - 1) as f64)) as i64;
            let base = (row - row0) * w;
            for col in c0 as i64..=c1 {
                let px = col as f64 + 0.5;
                let mut iz = 0.0;
                for k in 0..3 {
                    iz += (slope[k] * px + offset[k]) * self.inv_z[k];
                }
                let z = (1.0 / iz) as f32;
                let i = base + col as usize;
                if z < depth[i] {
                    depth[i] = z;
                    ids[i] = self.tri;
                }
            }
        }
    }
}

/// The supersampled z-buffer (view depth) and triangle-id buffer (u32::MAX: empty) of one band,
/// reused from band to band.
#[derive(Default)]
struct BandBuffers {
    depth: Vec<f32>,
    ids: Vec<u32>,
}

impl BandBuffers {
    /// Clear to `len` empty samples.
    fn reset(&mut self, len: usize) {
        self.depth.clear();
        self.depth.resize(len, f32::INFINITY);
        self.ids.clear();
        self.ids.resize(len, u32::MAX);
    }
}

/// For each band of `band_h` sample rows (of `h` in all), the setups that reach into it, in
/// setup order.
fn bin_setups(setups: &[Setup], band_h: usize, h: usize) -> Vec<Vec<u32>> {
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); h.div_ceil(band_h)];
    for (i, s) in setups.iter().enumerate() {
        for bin in &mut bins[s.rows.0 / band_h..=s.rows.1 / band_h] {
            bin.push(i as u32);
        }
    }
    bins
}

/// Everything needed to shade one sample.
struct Shader<'a> {
    tris: &'a [Tri],
    setups: &'a [Setup],
    /// The setup of each triangle (sample ids are triangle indices).
    setup_of: &'a [u32],
    /// Samples per pixel along each axis.
    ss: usize,
    proj: Projection,
    cmap: LinearViridis,
    range: (f64, f64),
    has_field: bool,
    shading: Shading,
    wire_half_width: Option<f64>,
    feature_half_width: Option<f64>,
    key: Vec3,
    fill: Vec3,
    world_up: Vec3,
    floor: Option<Floor>,
    sky: ([f32; 3], [f32; 3]),
    plain: [f32; 3],
    cap_plain: [f32; 3],
    no_value: [f32; 3],
    obstacle: [f32; 3],
    height: f64,
}

pub(crate) fn lin(c: [u8; 3]) -> [f32; 3] {
    c.map(srgb_to_linear)
}

pub(crate) fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

/// The fraction of a box filter of width `filter`, centred at distance `d` from the middle of a
/// line of half-width `half`, that the line covers.
pub(crate) fn box_coverage(d: f64, half: f64, filter: f64) -> f64 {
    let lo = (d - 0.5 * filter).max(-half);
    let hi = (d + 0.5 * filter).min(half);
    ((hi - lo) / filter).clamp(0.0, 1.0)
}

pub(crate) fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Shader<'_> {
    /// The linear colour of output pixel (x, y), from its samples in `ids`: the triangle ids of
    /// a band of supersampled rows from `row0`, `w` samples wide.
    ///
    /// A pixel whose samples all see the same triangle (or all see the background) is shaded
    /// once at its centre, with lines filtered analytically over the pixel; only pixels on
    /// silhouettes and triangle borders are shaded sample by sample.
    fn pixel(&self, ids: &[u32], row0: usize, w: usize, x: usize, y: usize) -> [f32; 3] {
        let ss = self.ss;
        let at = |sx: usize, sy: usize| ids[(sy - row0) * w + sx];
        let first = at(x * ss, y * ss);
        let uniform =
            (y * ss..(y + 1) * ss).all(|sy| (x * ss..(x + 1) * ss).all(|sx| at(sx, sy) == first));
        let shade = |id: u32, px: f64, py: f64, filter: f64| {
            if id == u32::MAX {
                self.background(px, py, filter)
            } else {
                self.object(
                    &self.setups[self.setup_of[id as usize] as usize],
                    px,
                    py,
                    filter,
                )
            }
        };
        if uniform {
            let centre = |v: usize| (v as f64 + 0.5) * ss as f64;
            return shade(first, centre(x), centre(y), ss as f64);
        }
        let mut sum = [0f32; 3];
        for sy in y * ss..(y + 1) * ss {
            for sx in x * ss..(x + 1) * ss {
                let c = shade(at(sx, sy), sx as f64 + 0.5, sy as f64 + 0.5, 1.0);
                for i in 0..3 {
                    sum[i] += c[i];
                }
            }
        }
        let norm = 1.0 / (ss * ss) as f32;
        sum.map(|v| v * norm)
    }

    /// The colour of the object at (px, py), with wireframe lines box-filtered over a square
    /// of `filter` samples (1 when shading one sample, the supersampling factor when shading
    /// a whole pixel at once).
    fn object(&self, s: &Setup, px: f64, py: f64, filter: f64) -> [f32; 3] {
        let tri = &self.tris[s.tri as usize];
        let mu = s.perspective(px, py);
        let value = mu[0] * tri.value[0] + mu[1] * tri.value[1] + mu[2] * tri.value[2];
        let base = if tri.obstacle {
            self.obstacle
        } else if self.has_field {
            if value.is_finite() {
                self.cmap
                    .sample((value - self.range.0) / (self.range.1 - self.range.0))
            } else {
                self.no_value
            }
        } else if tri.cap {
            self.cap_plain
        } else {
            self.plain
        };
        let mut c = if self.shading == Shading::Unlit {
            base
        } else {
            let n = if self.shading == Shading::Flat || tri.cap {
                tri.n[0]
            } else {
                (tri.n[0] * mu[0] + tri.n[1] * mu[1] + tri.n[2] * mu[2])
                    .try_normalize(1e-300)
                    .unwrap_or(tri.n[0])
            };
            let view = -self.proj.ray(px, py).normalize();
            let n = if n.dot(&view) < 0.0 { -n } else { n };
            let hemi = 0.5 + 0.5 * n.dot(&self.world_up);
            let ambient = 0.2 + 0.14 * hemi;
            let diffuse = 0.66 * n.dot(&self.key).max(0.0) + 0.26 * n.dot(&self.fill).max(0.0);
            let half = (self.key + view).normalize();
            // (n·h)⁴⁸ by squaring: powi would be a library call per sample.
            let h = n.dot(&half).max(0.0);
            let h3 = h * h * h;
            let h12 = (h3 * h3) * (h3 * h3);
            let spec = 0.16 * (h12 * h12) * (h12 * h12);
            let k = (ambient + diffuse) as f32;
            base.map(|b| b * k + spec as f32)
        };
        // Lines: every edge in wireframe mode, feature edges (creases, the cut's rim) always.
        let mut dark = 0.0f64;
        for k in 0..3 {
            let wire = self.wire_half_width.filter(|_| tri.edges & (1 << k) != 0);
            let feature = self
                .feature_half_width
                .filter(|_| tri.features & (1 << k) != 0);
            if wire.is_some() || feature.is_some() {
                let d = s.edge(k, px, py).abs() * s.inv_len[k];
                if let Some(hw) = wire {
                    dark = dark.max(0.6 * box_coverage(d, hw, filter));
                }
                if let Some(hw) = feature {
                    dark = dark.max(0.7 * box_coverage(d, hw, filter));
                }
            }
        }
        if dark > 0.0 {
            c = c.map(|v| v * (1.0 - dark) as f32);
        }
        c
    }

    /// Sky or floor at (px, py), with grid lines box-filtered over `filter` samples.
    fn background(&self, px: f64, py: f64, filter: f64) -> [f32; 3] {
        let sky = mix(self.sky.0, self.sky.1, (py / self.height) as f32);
        let Some(floor) = &self.floor else {
            return sky;
        };
        let ray = self.proj.ray(px, py);
        let down = -ray.dot(&floor.up);
        if down.is_nan() || down <= 0.0 {
            return sky;
        }
        let t = floor.eye_height / down;
        // World size of the filter at the hit, stretched by the grazing angle.
        let cos = down / ray.norm();
        let footprint = filter * t * ray.norm() / self.proj.focal / cos.max(0.08);
        let (c, alpha) = floor.colour(&(self.proj.eye + ray * t), footprint);
        mix(sky, c, alpha)
    }
}

/// Render one validated frame.
pub(crate) fn render_frame(
    view: &SceneView<'_>,
    obstacles: &[[Vec3; 3]],
    camera: &Camera,
    params: &RenderParams,
    range: (f64, f64),
) -> Image {
    render_frame_in_bands(view, obstacles, camera, params, range, BAND_ROWS)
}

/// [`render_frame`] in bands of `band_rows` output rows (any height gives the same bytes).
fn render_frame_in_bands(
    view: &SceneView<'_>,
    obstacles: &[[Vec3; 3]],
    camera: &Camera,
    params: &RenderParams,
    range: (f64, f64),
    band_rows: usize,
) -> Image {
    let layout = Layout::new(params, params.field.is_some());
    let ss = params.supersample as usize;
    let (w, h) = (params.width as usize, params.height as usize);
    let (sw, sh) = (w * ss, h * ss);
    let proj = Projection::new(camera, &layout.viewport, ss as f64);
    let mut tris = build_triangles(view, params);
    let cut = if params.cut_obstacles {
        super::obstacles::cut_plane(view.positions, obstacles, camera)
    } else {
        None
    };
    tris.extend(obstacle_triangles(obstacles, cut.as_ref()));
    let setups: Vec<Setup> = tris
        .iter()
        .enumerate()
        .filter_map(|(i, t)| Setup::new(t, i, &proj, sw, sh))
        .collect();
    // Setups are indexed by triangle; map ids back to setups.
    let mut setup_of = vec![u32::MAX; tris.len()];
    for (i, s) in setups.iter().enumerate() {
        setup_of[s.tri as usize] = i as u32;
    }

    let camera_dir = |x: f64, y: f64, z: f64| {
        (camera.right * x + camera.up * y - camera.forward * z).normalize()
    };
    let shader = Shader {
        tris: &tris,
        setups: &setups,
        setup_of: &setup_of,
        ss,
        cmap: LinearViridis::new(),
        range,
        has_field: params.field.is_some(),
        shading: params.shading,
        wire_half_width: params.wireframe.then_some(0.45 * ss as f64),
        feature_half_width: params.outline.then_some(0.5 * ss as f64),
        // Key light from above, a little right of and behind the camera (so the faces turned
        // towards the viewer are lit), fill from the left.
        key: camera_dir(0.25, 0.55, 0.8),
        fill: camera_dir(-0.75, 0.15, 0.45),
        world_up: camera.world_up,
        floor: if params.show_floor {
            Floor::new(camera, &tris, params.ground.as_ref())
        } else {
            None
        },
        sky: (lin(SKY_TOP), lin(SKY_BOTTOM)),
        plain: lin(PLAIN),
        cap_plain: lin(CAP_PLAIN),
        no_value: lin(NO_VALUE),
        obstacle: lin(OBSTACLE),
        height: sh as f64,
        proj,
    };
    let markers = if params.show_fixed {
        MarkerCandidates::new(view, params, &shader.proj, ss)
    } else {
        MarkerCandidates::default()
    };

    let band_rows = band_rows.max(1);
    let band_h = band_rows * ss;
    let bins = bin_setups(&setups, band_h, sh);
    let marker_bins = markers.bin(band_h, sh);
    let encoder = SrgbEncoder::new();
    let mut pixels = vec![0u8; 3 * w * h];
    let seen: Vec<Vec<u32>> = pixels
        .par_chunks_mut(3 * w * band_rows)
        .zip(bins.par_iter().zip(marker_bins.par_iter()))
        .enumerate()
        .map_init(
            BandBuffers::default,
            |band, (b, (out, (bin, marker_bin)))| {
                // Rasterise: sample rows [row0, row0 + rows) of the whole supersampled frame.
                let row0 = b * band_h;
                let rows = out.len() / (3 * w) * ss;
                band.reset(rows * sw);
                for &s in bin {
                    setups[s as usize].rasterize(row0, sw, &mut band.depth, &mut band.ids);
                }
                // Shade and filter down each output pixel of the band from its own samples.
                for (ly, row) in out.chunks_mut(3 * w).enumerate() {
                    let y = b * band_rows + ly;
                    for x in 0..w {
                        let c = shader.pixel(&band.ids, row0, sw, x, y);
                        for i in 0..3 {
                            row[3 * x + i] = encoder.encode(c[i]);
                        }
                    }
                }
                markers.seen_in_band(marker_bin, row0, sw, band)
            },
        )
        .collect();
    let mut img = Image {
        width: params.width,
        height: params.height,
        pixels,
    };

    let font = text::font();
    let px = layout.font_px;
    let markers = markers.draw(&mut img, &seen, px);
    if let (Some(kind), Some(bar)) = (params.field, layout.colorbar) {
        text::draw_colorbar(&mut img, &font, px, bar, range, kind);
    }
    if params.show_caption {
        let mut caption = params.title.clone();
        if !caption.is_empty() {
            caption.push_str("   ");
        }
        caption.push_str(&format!(
            "frame {}   t = {}",
            view.frame,
            format_time(view.time)
        ));
        let baseline = (layout.top * 0.5 + 0.36 * px as f64) as f32;
        text::draw_text(
            &mut img,
            &font,
            px,
            (layout.margin as f32, baseline),
            &caption,
            INK,
            Align::Left,
        );
    }
    let mut legend_x = layout.margin as f32;
    let baseline = h as f32 - 0.7 * px;
    if markers > 0 {
        let r = (0.3 * px) as f64;
        let cy = (baseline - 0.36 * px) as f64;
        text::draw_disc(
            &mut img,
            (legend_x as f64 + r, cy),
            r,
            MARKER_FILL,
            MARKER_EDGE,
        );
        legend_x += 2.0 * r as f32 + 0.4 * px;
        let label = "fixed";
        text::draw_text(
            &mut img,
            &font,
            px,
            (legend_x, baseline),
            label,
            INK,
            Align::Left,
        );
        legend_x += text::text_width(&font, px, label) + 1.2 * px;
    }
    if let Some(floor) = &shader.floor {
        let label = format!("grid {}", format_length(floor.spacing));
        text::draw_text(
            &mut img,
            &font,
            px,
            (legend_x, baseline),
            &label,
            INK,
            Align::Left,
        );
    }
    img
}

/// Seconds with a precision that suits their size.
fn format_time(t: f64) -> String {
    if !t.is_finite() {
        return "–".into();
    }
    if t.abs() >= 100.0 {
        format!("{t:.1} s")
    } else {
        format!("{t:.3} s")
    }
}

/// A grid spacing as a short length with a suitable unit ("0.5 m", "20 mm").
fn format_length(l: f64) -> String {
    let (div, unit) = if (1e-2..1e4).contains(&l) {
        (1.0, "m".to_string())
    } else {
        text::scaled_unit("m", l)
    };
    let v = l / div;
    let decimals = (-v.log10().floor()).max(0.0) as usize;
    format!("{} {unit}", text::format_number(v, decimals))
}

#[cfg(test)]
mod tests {
    use super::super::camera::{Bounds, fit_camera};
    use super::super::geometry::RenderMesh;
    use super::super::{FieldKind, Plane};
    use super::*;
    use crate::mesh::generate::box_mesh;

    /// Drawing band by band is the same, byte for byte, as drawing the whole supersampled frame
    /// at once (one band of every row), whatever the band height: triangles, lines, the floor,
    /// an obstacle, and fixed-vertex markers whose 3×3 sample neighbourhood straddles bands.
    #[test]
    fn bands_of_any_height_draw_the_whole_frame_s_bytes() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [8, 3, 3]);
        let rm = RenderMesh::new(&mesh);
        // Twisted and sagging, so the surface is curved and partly hides the fixed end.
        let x: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|p| {
                let a = 0.2 * p.x;
                let (y, z) = (p.y - 0.5, p.z - 0.5);
                Vec3::new(
                    p.x,
                    0.5 + y * a.cos() - z * a.sin() - 0.05 * p.x * p.x,
                    0.5 + y * a.sin() + z * a.cos(),
                )
            })
            .collect();
        let field: Vec<f64> = x
            .iter()
            .zip(&mesh.positions)
            .map(|(a, b)| (a - b).norm())
            .collect();
        let fixed: Vec<bool> = mesh.positions.iter().map(|p| p.x < 1e-9).collect();
        let obstacle = [[
            Vec3::new(4.2, -0.5, -0.5),
            Vec3::new(4.2, 1.5, -0.5),
            Vec3::new(4.2, 0.5, 1.5),
        ]];
        let view = SceneView {
            mesh: &rm,
            positions: &x,
            field: &field,
            fixed: &fixed,
            time: 0.25,
            frame: 7,
        };
        for params in [
            RenderParams {
                width: 97,
                height: 61,
                wireframe: true,
                field: Some(FieldKind::Displacement),
                ..RenderParams::default()
            },
            RenderParams {
                width: 64,
                height: 50,
                supersample: 4,
                azimuth_deg: 150.0,
                clip: Some(Plane::new(
                    Vec3::new(2.0, 0.5, 0.5),
                    Vec3::new(0.0, 0.0, 1.0),
                )),
                ..RenderParams::default()
            },
        ] {
            let mut bounds = Bounds::of(&x);
            bounds.include(&obstacle[0]);
            let camera = fit_camera(&bounds, &params);
            let range = (0.0, 0.3);
            let draw =
                |rows| render_frame_in_bands(&view, &obstacle, &camera, &params, range, rows);
            let whole = draw(params.height as usize);
            // The markers are there (so their band-by-band visibility test is exercised).
            assert!(
                whole.pixels.chunks(3).any(|p| p == MARKER_FILL),
                "no fixed-vertex marker drawn"
            );
            for rows in [1, 2, 5, BAND_ROWS, 1000] {
                assert!(
                    draw(rows) == whole,
                    "{}x{}: bands of {rows} rows differ from the whole frame",
                    params.width,
                    params.height
                );
            }
        }
    }
}
