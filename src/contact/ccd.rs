//! Continuous collision detection: a conservative time of impact for linear trajectories.
//!
//! Every vertex moves on a straight line xᵢ(t) = xᵢ⁰ + t (xᵢ¹ − xᵢ⁰), t ∈ [0, 1]. The functions
//! return t* ∈ [0, t_max] such that the pair stays farther apart than the minimum separation ξ
//! on all of [0, t*]; t* = t_max (1 by default) means the whole step is free. The line search
//! takes the smallest t* over all candidate pairs as its largest step.
//!
//! Pairs of primitives use additive CCD (ACCD; Li, Kaufman & Jiang 2021, "Codimensional
//! Incremental Potential Contact", Alg. 1). Subtract the mean displacement (the distance is
//! translation invariant), and bound the relative speed of any two points of the primitives by
//!
//! ```text
//! l_p = maxᵢ∈A ‖pᵢ‖ + maxⱼ∈B ‖pⱼ‖.
//! ```
//!
//! Then along the trajectory the gap g(t) = d(t) − ξ cannot shrink faster than l_p, so a step
//! Δt = c·g/l_p (c = 0.9, the conservative rescaling) is always safe. ACCD advances by such steps
//! and stops as soon as a step would bring g under (1 − c)·g(0), returning the time before that
//! step (at which g ≥ (1 − c)·g(0) > 0). With squared distances, g = (d² − ξ²)/(d + ξ). It never
//! misses a collision, is exact up to its conservative margin, and needs only distances.
//!
//! Analytic obstacles: a point against a translating plane solves the linear signed gap; a sphere
//! against a triangle is ACCD point–triangle with the separation raised by the radius.

use super::distance::{
    edge_edge_distance, point_edge_distance, point_point_distance, point_triangle_distance,
};
use crate::math::Vec3;

/// Parameters of [`point_triangle_ccd`] and friends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdParams {
    /// c ∈ (0, 1): each step covers c of the current gap, and the search stops when the gap
    /// falls under (1 − c) of the initial one. Default 0.9 (ACCD's choice); smaller is more
    /// conservative and cheaper.
    pub conservative_rescaling: f64,
    /// ξ (m, unsquared): the separation that counts as impact. Default 0 (touching).
    pub min_distance: f64,
    /// t_max: the largest time looked for, default 1 (the whole step).
    pub max_time: f64,
    /// Cap on ACCD steps (a gap tiny against the motion can need many); when reached, the
    /// current, still safe, time is returned. Default 10⁶.
    pub max_iterations: usize,
}

impl Default for CcdParams {
    fn default() -> Self {
        CcdParams {
            conservative_rescaling: 0.9,
            min_distance: 0.0,
            max_time: 1.0,
            max_iterations: 1_000_000,
        }
    }
}

/// ACCD on the vertices `start` moving to `end`; the first `split` vertices are primitive A,
/// the others primitive B; `distance_sq` maps positions to the pair's squared distance.
fn additive_ccd<const N: usize>(
    start: &[Vec3; N],
    end: &[Vec3; N],
    split: usize,
    distance_sq: impl Fn(&[Vec3; N]) -> f64,
    params: &CcdParams,
) -> f64 {
    let c = params.conservative_rescaling.clamp(1e-6, 1.0 - 1e-6);
    let xi = params.min_distance.max(0.0);
    let t_max = params.max_time;
    let mut p: [Vec3; N] = std::array::from_fn(|i| end[i] - start[i]);
    let mean = p.iter().sum::<Vec3>() / N as f64;
    for pi in &mut p {
        *pi -= mean;
    }
    let max_norm = |s: &[Vec3]| s.iter().map(Vec3::norm).fold(0.0, f64::max);
    let lp = max_norm(&p[..split]) + max_norm(&p[split..]);
    let x0: [Vec3; N] = std::array::from_fn(|i| start[i] - start[0]);
    let gap = |t: f64| {
        let x: [Vec3; N] = std::array::from_fn(|i| x0[i] + t * p[i]);
        let d2 = distance_sq(&x);
        let d = d2.sqrt();
        if d + xi > 0.0 {
            (d2 - xi * xi) / (d + xi)
        } else {
            0.0
        }
    };
    if lp == 0.0 {
        return t_max; // no relative motion: nothing changes
    }
    let g0 = gap(0.0);
    if g0.is_nan() || g0 <= 0.0 || !lp.is_finite() {
        return 0.0; // already within the minimum separation (or non-finite input)
    }
    let target = (1.0 - c) * g0;
    let mut t = 0.0;
    let mut step = c * g0 / lp;
    if step >= t_max {
        // The first step covers the whole interval (the loop would return t_max after one more
        // distance): most pairs of a slowly moving surface end here.
        return t_max;
    }
    for _ in 0..params.max_iterations {
        let g = gap(t + step);
        if t > 0.0 && g < target {
            return t;
        }
        t += step;
        if t >= t_max {
            return t_max;
        }
        step = c * g / lp;
    }
    t
}

/// Time of impact of point p against triangle t₀t₁t₂, both moving linearly from `start` to
/// `end` (vertex order [p, t₀, t₁, t₂]). See the module doc.
pub fn point_triangle_ccd(start: &[Vec3; 4], end: &[Vec3; 4], params: &CcdParams) -> f64 {
    additive_ccd(
        start,
        end,
        1,
        |x| point_triangle_distance(&x[0], &x[1], &x[2], &x[3]),
        params,
    )
}

/// Time of impact of segments a₀a₁ and b₀b₁ (vertex order [a₀, a₁, b₀, b₁]).
pub fn edge_edge_ccd(start: &[Vec3; 4], end: &[Vec3; 4], params: &CcdParams) -> f64 {
    additive_ccd(
        start,
        end,
        2,
        |x| edge_edge_distance(&x[0], &x[1], &x[2], &x[3]),
        params,
    )
}

/// Time of impact of point p against segment e₀e₁ (vertex order [p, e₀, e₁]).
pub fn point_edge_ccd(start: &[Vec3; 3], end: &[Vec3; 3], params: &CcdParams) -> f64 {
    additive_ccd(
        start,
        end,
        1,
        |x| point_edge_distance(&x[0], &x[1], &x[2]),
        params,
    )
}

/// Time of impact of two points.
pub fn point_point_ccd(start: &[Vec3; 2], end: &[Vec3; 2], params: &CcdParams) -> f64 {
    additive_ccd(
        start,
        end,
        1,
        |x| point_point_distance(&x[0], &x[1]),
        params,
    )
}

/// Time of impact of a point moving p⁰ → p¹ against a plane with fixed unit-or-not `normal`
/// whose reference point moves o⁰ → o¹ (a translating plane). The signed gap
/// g(t) = n̂·(p(t) − o(t)) − ξ is linear; with g(0) > 0 the impact is at t₁ = g(0)/(g(0) − g(1))
/// and the conservative answer is c·t₁ (the gap is then (1 − c) g(0)). A point already at or
/// behind the plane (g(0) ≤ 0) gets 0; a point not approaching gets `max_time`.
pub fn point_plane_ccd(
    p0: &Vec3,
    p1: &Vec3,
    origin0: &Vec3,
    origin1: &Vec3,
    normal: &Vec3,
    params: &CcdParams,
) -> f64 {
    let n = normal.try_normalize(0.0).unwrap_or_else(Vec3::zeros);
    let xi = params.min_distance.max(0.0);
    let g0 = n.dot(&(p0 - origin0)) - xi;
    let g1 = n.dot(&(p1 - origin1)) - xi;
    if g0.is_nan() || g0 <= 0.0 {
        return 0.0;
    }
    if g1 >= g0 || !g1.is_finite() {
        return params.max_time;
    }
    let c = params.conservative_rescaling.clamp(1e-6, 1.0 - 1e-6);
    let t = c * g0 / (g0 - g1);
    t.min(params.max_time)
}

/// Time of impact of a rigid sphere (radius ρ, center c⁰ → c¹) against triangle t₀t₁t₂
/// moving `face_start` → `face_end`: ACCD point–triangle on the center with the minimum
/// separation ρ + ξ, exact for faces, edges and vertices alike.
pub fn sphere_triangle_ccd(
    center0: &Vec3,
    center1: &Vec3,
    radius: f64,
    face_start: &[Vec3; 3],
    face_end: &[Vec3; 3],
    params: &CcdParams,
) -> f64 {
    let start = [*center0, face_start[0], face_start[1], face_start[2]];
    let end = [*center1, face_end[0], face_end[1], face_end[2]];
    let params = CcdParams {
        min_distance: params.min_distance.max(0.0) + radius.max(0.0),
        ..*params
    };
    point_triangle_ccd(&start, &end, &params)
}

#[cfg(test)]
mod tests;
