//! The rigid part of a motion and what is left when it is taken away, and the default colour
//! field chosen from them.
//!
//! A body that falls, slides or rolls moves mostly rigidly: its displacement |x − X| is nearly
//! the same everywhere and colours it in one flat colour. Taking away the best-fit rigid motion
//! (the rotation R and translation c that bring the rest shape closest to the current one in the
//! least-squares sense, the orthogonal Procrustes problem) leaves the deformation, which is
//! what a picture should show.

use super::FieldKind;
use crate::math::{Mat3, Vec3, svd_rv};

/// The rigid motion x ≈ c + R (X − C) closest to a body's current positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidFit {
    /// Centroid of the rest positions C (m).
    pub rest_centroid: Vec3,
    /// Centroid of the current positions c (m).
    pub centroid: Vec3,
    /// The proper rotation R (det R = +1).
    pub rotation: Mat3,
}

impl RigidFit {
    /// The best fit of `x` by a rigid motion of `rest` (same length; non-finite pairs are
    /// skipped): centroids, then R = U Vᵀ from the SVD of the cross-covariance
    /// Σ (xᵢ − c)(Xᵢ − C)ᵀ with the sign of the smallest singular value taken so that det R = +1
    /// (Kabsch). The identity when fewer than one finite pair is left.
    pub fn of(rest: &[Vec3], x: &[Vec3]) -> RigidFit {
        let finite = |p: &Vec3| p.iter().all(|c| c.is_finite());
        let pairs = || rest.iter().zip(x).filter(|(r, p)| finite(r) && finite(p));
        let n = pairs().count();
        if n == 0 {
            return RigidFit {
                rest_centroid: Vec3::zeros(),
                centroid: Vec3::zeros(),
                rotation: Mat3::identity(),
            };
        }
        let (sr, sx) = pairs().fold((Vec3::zeros(), Vec3::zeros()), |(a, b), (r, p)| {
            (a + r, b + p)
        });
        let (rest_centroid, centroid) = (sr / n as f64, sx / n as f64);
        let mut h = Mat3::zeros();
        for (r, p) in pairs() {
            h += (p - centroid) * (r - rest_centroid).transpose();
        }
        // Scale-free: the rotation does not depend on the size of H, the SVD's accuracy does.
        let scale = h.abs().max();
        let rotation = if scale > 0.0 && scale.is_finite() {
            let svd = svd_rv(&(h / scale));
            svd.u * svd.v.transpose()
        } else {
            Mat3::identity()
        };
        RigidFit {
            rest_centroid,
            centroid,
            rotation,
        }
    }

    /// Where the rigid motion takes rest point `r`.
    pub fn apply(&self, r: &Vec3) -> Vec3 {
        self.centroid + self.rotation * (r - self.rest_centroid)
    }
}

/// |x − (c + R (X − C))| per vertex, with the rigid fit made separately for every body
/// (`body[v]` is vertex v's body; empty: one body): the displacement left when each body's
/// best-fit rigid motion is taken away (m).
pub fn relative_displacements(rest: &[Vec3], x: &[Vec3], body: &[usize]) -> Vec<f64> {
    let mut out = vec![f64::NAN; rest.len().min(x.len())];
    for members in groups(body, out.len()) {
        let r: Vec<Vec3> = members.iter().map(|&v| rest[v]).collect();
        let p: Vec<Vec3> = members.iter().map(|&v| x[v]).collect();
        let fit = RigidFit::of(&r, &p);
        for (k, &v) in members.iter().enumerate() {
            out[v] = (p[k] - fit.apply(&r[k])).norm();
        }
    }
    out
}

/// The bounding-box diagonal of the finite points (0 without any).
fn diagonal(points: &[Vec3]) -> f64 {
    let finite = points.iter().filter(|p| p.iter().all(|c| c.is_finite()));
    let (lo, hi) = finite.fold(
        (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    );
    if lo.x <= hi.x { (hi - lo).norm() } else { 0.0 }
}

/// The vertices of each body, in order (`body` empty: all `n` vertices are one body).
fn groups(body: &[usize], n: usize) -> Vec<Vec<usize>> {
    if body.len() != n {
        return vec![(0..n).collect()];
    }
    let count = body.iter().max().map_or(0, |&b| b + 1);
    let mut out = vec![Vec::new(); count];
    for (v, &b) in body.iter().enumerate() {
        out[b].push(v);
    }
    out.retain(|g| !g.is_empty());
    out
}

/// A run's motion summed up over its frames, to choose the colour field of its pictures when
/// the user names none (`field = "auto"`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MotionSummary {
    /// Some body has no fixed vertex (it can move as a whole).
    pub free_body: bool,
    /// Largest rest bounding-box diagonal of a free body (m).
    pub size: f64,
    /// Largest displacement |x − X| of a free body's vertex over the frames (m).
    pub displacement: f64,
    /// Largest displacement left after the body's rigid motion is taken away (m).
    pub deformation: f64,
}

/// A free body that deforms by less than this fraction of its size looks rigid: the
/// displacement left after its rigid motion is then mostly noise next to its stresses.
const RIGID_LOOKING: f64 = 0.01;

impl MotionSummary {
    /// Add one frame: rest and current positions, the body of every vertex (empty: one body)
    /// and the fixed vertices (empty: none).
    pub fn add_frame(&mut self, rest: &[Vec3], x: &[Vec3], body: &[usize], fixed: &[bool]) {
        let n = rest.len().min(x.len());
        for members in groups(body, n) {
            if members
                .iter()
                .any(|&v| fixed.get(v).copied().unwrap_or(false))
            {
                continue;
            }
            self.free_body = true;
            let r: Vec<Vec3> = members.iter().map(|&v| rest[v]).collect();
            let p: Vec<Vec3> = members.iter().map(|&v| x[v]).collect();
            self.size = self.size.max(diagonal(&r));
            let fit = RigidFit::of(&r, &p);
            for (a, b) in r.iter().zip(&p) {
                let (u, d) = ((b - a).norm(), (b - fit.apply(a)).norm());
                if u.is_finite() && d.is_finite() {
                    self.displacement = self.displacement.max(u);
                    self.deformation = self.deformation.max(d);
                }
            }
        }
    }

    /// The field that shows what happened, and why, in a few words:
    /// - nothing moves freely (every body is held somewhere): the displacement, which is then
    ///   measured from where the body is held;
    /// - a free body's displacement is mostly deformation (it does not travel): the displacement;
    /// - a free body travels and visibly deforms: the displacement relative to its rigid motion;
    /// - a free body travels and barely deforms (less than 1% of its size): the von Mises
    ///   stress, which shows where the loads go.
    pub fn choose(&self) -> (FieldKind, &'static str) {
        if !self.free_body {
            (FieldKind::Displacement, "bodies are held")
        } else if self.deformation >= 0.5 * self.displacement {
            (FieldKind::Displacement, "bodies deform in place")
        } else if self.deformation >= RIGID_LOOKING * self.size {
            (
                FieldKind::RelativeDisplacement,
                "bodies travel, their rigid motion taken away",
            )
        } else {
            (FieldKind::VonMises, "bodies move almost rigidly")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn cube() -> Vec<Vec3> {
        (0..27)
            .map(|i| Vec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 0.1)
            .collect()
    }

    #[test]
    fn a_rigid_motion_leaves_no_residual() {
        let rest = cube();
        let axis = Unit::new_normalize(Vec3::new(1.0, 2.0, -0.5));
        let r = Rotation3::from_axis_angle(&axis, 2.5).into_inner();
        let t = Vec3::new(3.0, -7.0, 0.25);
        let x: Vec<Vec3> = rest.iter().map(|p| r * p + t).collect();
        let fit = RigidFit::of(&rest, &x);
        assert!((fit.rotation - r).abs().max() < 1e-12);
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
        let d = relative_displacements(&rest, &x, &[]);
        assert!(d.iter().all(|&d| d < 1e-12), "{d:?}");
    }

    #[test]
    fn a_reflection_is_not_taken_for_a_rotation() {
        let rest = cube();
        let x: Vec<Vec3> = rest.iter().map(|p| Vec3::new(p.x, p.y, -p.z)).collect();
        let fit = RigidFit::of(&rest, &x);
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
        assert!(
            relative_displacements(&rest, &x, &[])
                .iter()
                .any(|&d| d > 0.01)
        );
    }

    #[test]
    fn each_body_is_fitted_on_its_own() {
        let rest: Vec<Vec3> = cube().into_iter().chain(cube()).collect();
        let body: Vec<usize> = (0..54).map(|v| v / 27).collect();
        // Body 0 translates, body 1 rotates a quarter turn: both rigid.
        let r =
            Rotation3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::FRAC_PI_2).into_inner();
        let x: Vec<Vec3> = rest
            .iter()
            .enumerate()
            .map(|(v, p)| {
                if v < 27 {
                    p + Vec3::new(1.0, 0.0, 0.0)
                } else {
                    r * p
                }
            })
            .collect();
        assert!(
            relative_displacements(&rest, &x, &body)
                .iter()
                .all(|&d| d < 1e-12)
        );
        // As one body they are not rigid.
        assert!(
            relative_displacements(&rest, &x, &[])
                .iter()
                .any(|&d| d > 0.1)
        );
    }

    #[test]
    fn the_field_is_chosen_by_what_varies() {
        let rest = cube();
        // Falling without deforming: a translation of 2 m.
        let fall: Vec<Vec3> = rest.iter().map(|p| p - Vec3::new(0.0, 2.0, 0.0)).collect();
        let mut s = MotionSummary::default();
        s.add_frame(&rest, &fall, &[], &[]);
        assert_eq!(s.choose().0, FieldKind::VonMises);
        // Falling and squashed by 20% in y: the deformation without the fall.
        let squash: Vec<Vec3> = fall
            .iter()
            .map(|p| Vec3::new(p.x, 0.8 * p.y, p.z))
            .collect();
        let mut s = MotionSummary::default();
        s.add_frame(&rest, &squash, &[], &[]);
        assert_eq!(s.choose().0, FieldKind::RelativeDisplacement);
        // A beam held at x = 0 that droops: the displacement.
        let fixed: Vec<bool> = rest.iter().map(|p| p.x == 0.0).collect();
        let droop: Vec<Vec3> = rest
            .iter()
            .map(|p| p - Vec3::new(0.0, 3.0 * p.x * p.x, 0.0))
            .collect();
        let mut s = MotionSummary::default();
        s.add_frame(&rest, &droop, &[], &fixed);
        assert_eq!(s.choose().0, FieldKind::Displacement);
        // Free, squashed in place (it does not travel): the displacement.
        let mut s = MotionSummary::default();
        let in_place: Vec<Vec3> = rest
            .iter()
            .map(|p| Vec3::new(p.x, 0.5 * p.y, p.z))
            .collect();
        s.add_frame(&rest, &in_place, &[], &[]);
        assert_eq!(s.choose().0, FieldKind::Displacement);
    }
}
