//! The floor under the model: a plane at the bottom of the run's bounding box, a metric grid
//! (so sizes can be read off), a soft contact shadow (so the model sits somewhere), fading out
//! with distance into the background.

use super::Plane;
use super::camera::Camera;
use super::geometry::Tri;
use super::raster::{box_coverage, lin, mix, smoothstep};
use super::text;
use crate::math::Vec3;

/// Floor and grid colours (sRGB).
const FLOOR: [u8; 3] = [238, 240, 243];
const GRID: [u8; 3] = [198, 203, 211];

/// A soft shadow on the floor: the occlusion of the model seen from straight above (stronger
/// for parts close to the floor), blurred.
struct ShadowMap {
    origin: (f64, f64),
    cell: f64,
    n: (usize, usize),
    data: Vec<f32>,
}

impl ShadowMap {
    fn new(tris: &[Tri], floor: &Floor, extent: (f64, f64, f64, f64)) -> Self {
        const CELLS: f64 = 160.0;
        let (a0, a1, b0, b1) = extent;
        let size = (a1 - a0).max(b1 - b0).max(1e-300);
        let blur_cells = 6usize;
        let pad = size * 0.12;
        let cell = (size + 2.0 * pad) / CELLS;
        let origin = (a0 - pad, b0 - pad);
        let n = (
            ((a1 - a0 + 2.0 * pad) / cell).ceil() as usize + 1,
            ((b1 - b0 + 2.0 * pad) / cell).ceil() as usize + 1,
        );
        let mut data = vec![0f32; n.0 * n.1];
        let falloff = 0.6 * floor.size;
        for t in tris {
            let ab = t.p.map(|p| {
                (
                    (p.dot(&floor.h1) - origin.0) / cell - 0.5,
                    (p.dot(&floor.h2) - origin.1) / cell - 0.5,
                )
            });
            let height =
                t.p.iter()
                    .map(|p| p.dot(&floor.up) - floor.height)
                    .fold(f64::INFINITY, f64::min)
                    .max(0.0);
            let strength = (-height / falloff).exp() as f32;
            fill_triangle_2d(&ab, n, |i, j| {
                let v = &mut data[j * n.0 + i];
                *v = v.max(strength);
            });
        }
        for _ in 0..3 {
            box_blur(&mut data, n, blur_cells / 2);
        }
        ShadowMap {
            origin,
            cell,
            n,
            data,
        }
    }

    /// Bilinear lookup at floor coordinates (a, b); 0 outside.
    fn sample(&self, a: f64, b: f64) -> f32 {
        let u = (a - self.origin.0) / self.cell - 0.5;
        let v = (b - self.origin.1) / self.cell - 0.5;
        if !(u >= 0.0 && v >= 0.0) {
            return 0.0;
        }
        // u, v ≥ 0 here, so truncation is floor (and much cheaper than a libm call).
        let (i, j) = (u as usize, v as usize);
        if i + 1 >= self.n.0 || j + 1 >= self.n.1 {
            return 0.0;
        }
        let (fu, fv) = ((u - i as f64) as f32, (v - j as f64) as f32);
        let at = |i: usize, j: usize| self.data[j * self.n.0 + i];
        let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fu;
        let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fu;
        top + (bottom - top) * fv
    }
}

/// Call `visit(i, j)` for every grid cell whose centre (i, j) lies in the 2D triangle.
fn fill_triangle_2d(p: &[(f64, f64); 3], n: (usize, usize), mut visit: impl FnMut(usize, usize)) {
    let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[1].1 - p[0].1) * (p[2].0 - p[0].0);
    if area.is_nan() || area.abs() <= 1e-12 {
        return;
    }
    let lo = |f: fn(&(f64, f64)) -> f64, m: usize| {
        (p.iter()
            .map(f)
            .fold(f64::INFINITY, f64::min)
            .ceil()
            .max(0.0) as usize)
            .min(m)
    };
    let hi = |f: fn(&(f64, f64)) -> f64, m: usize| {
        (p.iter().map(f).fold(f64::NEG_INFINITY, f64::max).floor()).clamp(-1.0, m as f64 - 1.0)
    };
    let (i0, i1) = (lo(|q| q.0, n.0), hi(|q| q.0, n.0));
    let (j0, j1) = (lo(|q| q.1, n.1), hi(|q| q.1, n.1));
    for j in j0 as i64..=j1 as i64 {
        for i in i0 as i64..=i1 as i64 {
            let (x, y) = (i as f64, j as f64);
            let inside = (0..3).all(|k| {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                ((b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0)) * area.signum() >= 0.0
            });
            if inside {
                visit(i as usize, j as usize);
            }
        }
    }
}

/// One pass of a separable box blur of radius `r` (clamped at the borders).
fn box_blur(data: &mut [f32], n: (usize, usize), r: usize) {
    let mut tmp = vec![0f32; data.len()];
    let norm = 1.0 / (2 * r + 1) as f32;
    for j in 0..n.1 {
        for i in 0..n.0 {
            let s: f32 = (i.saturating_sub(r)..=(i + r).min(n.0 - 1))
                .map(|k| data[j * n.0 + k])
                .sum();
            tmp[j * n.0 + i] = s * norm;
        }
    }
    for j in 0..n.1 {
        for i in 0..n.0 {
            let s: f32 = (j.saturating_sub(r)..=(j + r).min(n.1 - 1))
                .map(|k| tmp[k * n.0 + i])
                .sum();
            data[j * n.0 + i] = s * norm;
        }
    }
}

/// The floor: a plane under the run's bounding box, a metric grid fading out with distance,
/// and the contact shadow.
pub(crate) struct Floor {
    pub(crate) up: Vec3,
    h1: Vec3,
    h2: Vec3,
    height: f64,
    centre: (f64, f64),
    radius: f64,
    size: f64,
    pub(crate) spacing: f64,
    pub(crate) eye_height: f64,
    shadow: Option<ShadowMap>,
}

impl Floor {
    /// The floor under the camera's bounds, or on `ground` (a ground plane obstacle, normal
    /// to the free side) at its place and in its orientation.
    pub(crate) fn new(camera: &Camera, tris: &[Tri], ground: Option<&Plane>) -> Option<Floor> {
        let up = match ground {
            Some(g) => g.normal.try_normalize(1e-300)?,
            None => camera.world_up,
        };
        let (h1, h2) = Camera::floor_axes(&up);
        let corners = camera.bounds.corners();
        let along = |v: &Vec3| corners.map(|c| c.dot(v)).into_iter();
        let min = |v: &Vec3| along(v).fold(f64::INFINITY, f64::min);
        let max = |v: &Vec3| along(v).fold(f64::NEG_INFINITY, f64::max);
        let height = ground.map_or_else(|| min(&up), |g| g.point.dot(&up));
        let eye_height = camera.eye.dot(&up) - height;
        if eye_height.is_nan() || eye_height <= 0.0 {
            return None;
        }
        let extent = (min(&h1), max(&h1), min(&h2), max(&h2));
        let size = (extent.1 - extent.0)
            .max(extent.3 - extent.2)
            .max(max(&up) - height);
        let mut floor = Floor {
            up,
            h1,
            h2,
            height,
            centre: (0.5 * (extent.0 + extent.1), 0.5 * (extent.2 + extent.3)),
            radius: 0.5 * (extent.1 - extent.0).hypot(extent.3 - extent.2) + 0.45 * size,
            size,
            spacing: text::nice_step(size / 8.0),
            eye_height,
            shadow: None,
        };
        floor.shadow = Some(ShadowMap::new(tris, &floor, extent));
        Some(floor)
    }

    /// Linear colour and opacity of the floor at world point `hit`, grid lines filtered over
    /// `footprint` metres.
    pub(crate) fn colour(&self, hit: &Vec3, footprint: f64) -> ([f32; 3], f32) {
        let (a, b) = (hit.dot(&self.h1), hit.dot(&self.h2));
        let r = ((a - self.centre.0).powi(2) + (b - self.centre.1).powi(2)).sqrt();
        let alpha = 1.0 - smoothstep(0.45 * self.radius, self.radius, r);
        if alpha <= 0.0 {
            return ([0.0; 3], 0.0);
        }
        let half_line = 0.006 * self.spacing;
        let (fa, fb) = (a / self.spacing, b / self.spacing);
        let da = (fa - round_fast(fa)).abs() * self.spacing;
        let db = (fb - round_fast(fb)).abs() * self.spacing;
        let (ca, cb) = (
            box_coverage(da / footprint, half_line / footprint, 1.0),
            box_coverage(db / footprint, half_line / footprint, 1.0),
        );
        let on_line = 1.0 - (1.0 - ca) * (1.0 - cb);
        let mut c = mix(lin(FLOOR), lin(GRID), on_line as f32);
        if let Some(shadow) = &self.shadow {
            let s = shadow.sample(a, b);
            c = c.map(|v| v * (1.0 - 0.5 * s));
        }
        (c, alpha as f32)
    }
}

/// `x` rounded to the nearest integer (ties either way) with a truncating conversion: without
/// SSE4.1 (the baseline x86-64 target) `f64::round` is a library call, and this runs for every
/// floor pixel.
fn round_fast(x: f64) -> f64 {
    let t = x as i64 as f64;
    let d = x - t;
    if d > 0.5 {
        t + 1.0
    } else if d < -0.5 {
        t - 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_fast_rounds() {
        for (x, r) in [
            (0.2, 0.0),
            (0.7, 1.0),
            (-0.7, -1.0),
            (-0.2, 0.0),
            (12.6, 13.0),
        ] {
            assert_eq!(round_fast(x), r, "{x}");
        }
    }
}
