//! The perspective camera and its fit to the bounding box of a whole run.

use super::raster::Layout;
use super::{Plane, RenderParams};
use crate::math::Vec3;

/// An axis-aligned bounding box; the union over every frame of a run fixes the camera and the
/// floor, so that all frames line up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest coordinates (m).
    pub min: Vec3,
    /// Largest coordinates (m).
    pub max: Vec3,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds::empty()
    }
}

impl Bounds {
    /// The empty box (includes nothing; min = +∞, max = −∞).
    pub fn empty() -> Self {
        Bounds {
            min: Vec3::repeat(f64::INFINITY),
            max: Vec3::repeat(f64::NEG_INFINITY),
        }
    }

    /// The box around `points` (non-finite points are skipped).
    pub fn of(points: &[Vec3]) -> Self {
        let mut b = Bounds::empty();
        b.include(points);
        b
    }

    /// Grow the box to contain `points` (non-finite points are skipped).
    pub fn include(&mut self, points: &[Vec3]) {
        for p in points.iter().filter(|p| p.iter().all(|c| c.is_finite())) {
            self.min = self.min.inf(p);
            self.max = self.max.sup(p);
        }
    }

    /// The box containing both.
    pub fn union(&self, other: &Bounds) -> Bounds {
        Bounds {
            min: self.min.inf(&other.min),
            max: self.max.sup(&other.max),
        }
    }

    /// True when nothing was included.
    pub fn is_empty(&self) -> bool {
        (0..3).any(|i| self.min[i] > self.max[i])
    }

    /// Centre of the box.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).norm()
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    /// A usable box: an empty one becomes the unit cube, and a flat or point-like one is padded
    /// to a tenth of its largest side (or to 1 m when it is a single point).
    fn padded(&self) -> Bounds {
        if self.is_empty() {
            return Bounds {
                min: Vec3::zeros(),
                max: Vec3::repeat(1.0),
            };
        }
        let size = (self.max - self.min).max();
        let pad = if size > 0.0 { 0.05 * size } else { 0.5 };
        let mut b = *self;
        for i in 0..3 {
            if b.max[i] - b.min[i] < 2.0 * pad {
                b.min[i] -= pad;
                b.max[i] += pad;
            }
        }
        b
    }
}

/// A perspective camera: an eye, an orthonormal basis and a vertical field of view, plus the
/// scene box it was fitted to (the floor lies under that box).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (m).
    pub eye: Vec3,
    /// Screen right, in world coordinates (unit).
    pub right: Vec3,
    /// Screen up, in world coordinates (unit).
    pub up: Vec3,
    /// Viewing direction (unit); depth is measured along it.
    pub forward: Vec3,
    /// tan(vertical field of view / 2).
    pub tan_half_fov: f64,
    /// The world's up direction (unit); the floor is perpendicular to it.
    pub world_up: Vec3,
    /// The box the camera was fitted to (already padded when it was flat).
    pub bounds: Bounds,
}

impl Camera {
    /// `p` in camera coordinates: (right, up, depth along the view direction).
    pub fn to_view(&self, p: &Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(&self.right), d.dot(&self.up), d.dot(&self.forward))
    }

    /// Where `p` lands in a picture rendered with `params` (output pixels, (0, 0) at the
    /// top-left corner of the image, pixel centres at +0.5), or None when it is behind the
    /// camera.
    pub fn project_to_pixel(&self, params: &RenderParams, p: &Vec3) -> Option<[f64; 2]> {
        let vp = Layout::new(params, params.field.is_some()).viewport;
        let v = self.to_view(p);
        if v.z.is_nan() || v.z <= 0.0 {
            return None;
        }
        let focal = 0.5 * vp.h / self.tan_half_fov;
        Some([
            vp.x + 0.5 * vp.w + v.x / v.z * focal,
            vp.y + 0.5 * vp.h - v.y / v.z * focal,
        ])
    }

    /// Two unit vectors spanning the floor: `h1` points towards the azimuth-0 camera (+z for
    /// up = +y) and `h2 = up × h1` (+x for up = +y).
    pub(crate) fn floor_axes(world_up: &Vec3) -> (Vec3, Vec3) {
        let u = world_up.normalize();
        let mut h1 = Vec3::z() - u * u.z;
        if h1.norm() < 1e-6 {
            h1 = Vec3::x() - u * u.x;
        }
        let h1 = h1.normalize();
        (h1, u.cross(&h1))
    }
}

/// `params` with the camera on the side a tilted ground faces (a slope seen from downhill, its
/// face towards the camera, rather than from uphill, where it falls away out of sight): the
/// azimuth mirrored when the camera would look at the slope's back. Unchanged for a ground
/// within 5° of level with the up direction.
pub(crate) fn facing_ground(params: &RenderParams, ground: &Plane) -> RenderParams {
    let (Some(up), Some(n)) = (
        params.up.try_normalize(1e-300),
        ground.normal.try_normalize(1e-300),
    ) else {
        return params.clone();
    };
    let level = n - up * n.dot(&up);
    if level.norm() < 5f64.to_radians().sin() {
        return params.clone();
    }
    let (h1, h2) = Camera::floor_axes(&up);
    let az = params.azimuth_deg.to_radians();
    let back = h1 * az.cos() + h2 * az.sin();
    if back.dot(&level) >= 0.0 {
        return params.clone();
    }
    // Mirror about the vertical plane through the slope's fall line.
    let fall = level.normalize();
    let mirrored = back - fall * (2.0 * back.dot(&fall));
    RenderParams {
        azimuth_deg: mirrored.dot(&h2).atan2(mirrored.dot(&h1)).to_degrees(),
        ..params.clone()
    }
}

/// A camera that looks at `bounds` (the union over every frame of the run) from the direction
/// given by `params.azimuth_deg` / `params.elevation_deg`, as close as the field of view allows
/// while every corner of the box stays inside the picture's 3D viewport (the area left by the
/// caption and the colour bar) with a small margin, centred in it.
pub fn fit_camera(bounds: &Bounds, params: &RenderParams) -> Camera {
    let bounds = bounds.padded();
    let world_up = if params.up.norm() > 0.0 {
        params.up.normalize()
    } else {
        Vec3::y()
    };
    let (h1, h2) = Camera::floor_axes(&world_up);
    let (az, el) = (
        params.azimuth_deg.to_radians(),
        params.elevation_deg.clamp(-89.0, 89.0).to_radians(),
    );
    // From the target towards the eye.
    let back = (h1 * az.cos() + h2 * az.sin()) * el.cos() + world_up * el.sin();
    let forward = -back.normalize();
    let right = forward.cross(&world_up).normalize();
    let up = right.cross(&forward);

    let fov = params.fov_deg.clamp(1.0, 150.0).to_radians();
    let tan_half_fov = (0.5 * fov).tan();
    let layout = Layout::new(params, params.field.is_some());
    let aspect = layout.viewport.w / layout.viewport.h;
    // Keep 6% of the viewport free on every side.
    let fill = 0.94;
    let (tx, ty) = (tan_half_fov * aspect * fill, tan_half_fov * fill);

    let center = bounds.center();
    let local: Vec<Vec3> = bounds
        .corners()
        .iter()
        .map(|p| {
            let d = p - center;
            Vec3::new(d.dot(&right), d.dot(&up), d.dot(&forward))
        })
        .collect();
    // With the eye at distance d behind the centre, shifted by s across the screen, corner i
    // projects inside when |x_i − s| ≤ t·(z_i + d). Feasible shifts form an interval that grows
    // with d, so bisect on d for the smallest feasible distance and centre s in the interval.
    let interval = |d: f64, axis: usize, t: f64| {
        let lo = local
            .iter()
            .map(|q| q[axis] - t * (q.z + d))
            .fold(f64::NEG_INFINITY, f64::max);
        let hi = local
            .iter()
            .map(|q| q[axis] + t * (q.z + d))
            .fold(f64::INFINITY, f64::min);
        (lo, hi)
    };
    let feasible = |d: f64| {
        let (xl, xh) = interval(d, 0, tx);
        let (yl, yh) = interval(d, 1, ty);
        xl <= xh && yl <= yh
    };
    let radius = 0.5 * bounds.diagonal();
    let mut near = local.iter().map(|q| -q.z).fold(0.0, f64::max);
    let mut far = radius / tx.min(ty) + 2.0 * radius + near;
    while !feasible(far) {
        far *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (near + far);
        if feasible(mid) {
            far = mid;
        } else {
            near = mid;
        }
    }
    let d = far;
    let (xl, xh) = interval(d, 0, tx);
    let (yl, yh) = interval(d, 1, ty);
    let shift = right * (0.5 * (xl + xh)) + up * (0.5 * (yl + yh));
    Camera {
        eye: center + shift - forward * d,
        right,
        up,
        forward,
        tan_half_fov,
        world_up,
        bounds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_camera_looks_down_minus_z() {
        let params = RenderParams {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            ..RenderParams::default()
        };
        let b = Bounds::of(&[Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0)]);
        let cam = fit_camera(&b, &params);
        assert!((cam.forward + Vec3::z()).norm() < 1e-12);
        assert!((cam.right - Vec3::x()).norm() < 1e-12);
        assert!((cam.up - Vec3::y()).norm() < 1e-12);
        assert!(cam.eye.z > 1.0);
        // Symmetric box seen head-on: centred.
        assert!((cam.eye.x - 0.5).abs() < 1e-9 && (cam.eye.y - 0.5).abs() < 1e-9);
    }

    #[test]
    fn a_slope_is_seen_from_the_side_it_faces() {
        let up = Vec3::new(-0.5, 0.75f64.sqrt(), 0.0);
        let params = RenderParams {
            up,
            ..RenderParams::default()
        };
        let slope = Plane::new(Vec3::zeros(), Vec3::y());
        let turned = facing_ground(&params, &slope);
        // The default (−35°) looks from uphill; mirrored to +35°, downhill.
        assert!(
            (turned.azimuth_deg - 35.0).abs() < 1e-9,
            "{}",
            turned.azimuth_deg
        );
        let cam = fit_camera(&Bounds::of(&[Vec3::zeros(), Vec3::repeat(1.0)]), &turned);
        assert!(
            -cam.forward.dot(&slope.normal) > 0.5,
            "the slope's face looks away"
        );
        // Already facing it, or a level ground: unchanged.
        assert_eq!(facing_ground(&turned, &slope), turned);
        let level = RenderParams::default();
        assert_eq!(facing_ground(&level, &slope), level);
    }

    #[test]
    fn flat_and_empty_boxes_are_padded() {
        let flat = Bounds::of(&[Vec3::zeros(), Vec3::new(2.0, 0.0, 1.0)]).padded();
        assert!(flat.max.y - flat.min.y > 0.1);
        assert!(!Bounds::empty().padded().is_empty());
        let cam = fit_camera(&Bounds::empty(), &RenderParams::default());
        assert!(cam.eye.iter().all(|c| c.is_finite()));
    }
}
