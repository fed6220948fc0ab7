//! IPC's log barrier on squared distances, the edge–edge mollifier, and the barrier stiffness.
//!
//! With d a squared distance and d̂ the (squared) activation distance, Li et al. 2020 eq. (6):
//!
//! ```text
//! b(d) = −(d − d̂)² ln(d / d̂)   for 0 < d < d̂,   0 for d ≥ d̂,
//! ```
//!
//! C² at d = d̂ (b, b′ and b″ all vanish there) and → +∞ as d → 0. A pair's contact energy is
//! κ m(x) b(d(x)), with m the mollifier (1 except for nearly parallel edge–edge pairs) and κ
//! the barrier stiffness (IPC supplement, §3; ipc-toolkit's `adaptive_stiffness`).

use nalgebra::{SMatrix, SVector};

use super::distance::Derivatives;
use crate::math::{Mat3, Vec3};

/// b(d) = −(d − d̂)² ln(d/d̂) for 0 < d < d̂; 0 for d ≥ d̂; +∞ for d ≤ 0.
pub fn barrier(d: f64, dhat: f64) -> f64 {
    if d >= dhat {
        0.0
    } else if d <= 0.0 {
        f64::INFINITY
    } else {
        -(d - dhat) * (d - dhat) * (d / dhat).ln()
    }
}

/// b′(d) = (d̂ − d)(2 ln(d/d̂) − d̂/d + 1) for 0 < d < d̂ (≤ 0: the barrier pushes apart); 0 beyond.
pub fn barrier_first_derivative(d: f64, dhat: f64) -> f64 {
    if d >= dhat {
        0.0
    } else if d <= 0.0 {
        f64::NEG_INFINITY
    } else {
        (dhat - d) * (2.0 * (d / dhat).ln() - dhat / d + 1.0)
    }
}

/// b″(d) = (d̂ − d)(3d + d̂)/d² − 2 ln(d/d̂) for 0 < d < d̂ (> 0: b is convex in d); 0 beyond.
pub fn barrier_second_derivative(d: f64, dhat: f64) -> f64 {
    if d >= dhat {
        0.0
    } else if d <= 0.0 {
        f64::INFINITY
    } else {
        (dhat - d) * (3.0 * d + dhat) / (d * d) - 2.0 * (d / dhat).ln()
    }
}

/// The barrier of a distance function by the chain rule: with d = d(x),
///
/// ```text
/// ∇b = b′(d) ∇d,   ∇²b = b″(d) ∇d ∇dᵀ + b′(d) ∇²d.
/// ```
///
/// Zero (value, gradient and Hessian) when d ≥ d̂.
pub fn barrier_derivatives<const N: usize>(distance: &Derivatives<N>, dhat: f64) -> Derivatives<N> {
    let d = distance.value;
    if d >= dhat {
        return Derivatives {
            value: 0.0,
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        };
    }
    let (b1, b2) = (
        barrier_first_derivative(d, dhat),
        barrier_second_derivative(d, dhat),
    );
    let g = &distance.gradient;
    Derivatives {
        value: barrier(d, dhat),
        gradient: b1 * g,
        hessian: b2 * g * g.transpose() + b1 * distance.hessian,
    }
}

/// The nearest positive semi-definite matrix to a symmetric `m` (negative eigenvalues set to
/// zero), as Newton needs for every contact Hessian block (IPC §4.3).
pub fn project_psd<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    // Through a dynamic matrix: nalgebra's fixed-size eigensolver needs typenum bounds that
    // would leak into every generic caller; at N ≤ 12 the allocation is noise.
    let eigen =
        nalgebra::SymmetricEigen::new(nalgebra::DMatrix::from_column_slice(N, N, m.as_slice()));
    if eigen.eigenvalues.iter().all(|&l| l >= 0.0) {
        return *m;
    }
    let clamped = eigen.eigenvalues.map(|l| l.max(0.0));
    let p = &eigen.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&clamped)
        * eigen.eigenvectors.transpose();
    SMatrix::from_column_slice(p.as_slice())
}

/// Mollifier threshold for edge–edge pair a₀a₁, b₀b₁ from their *rest* positions:
/// εₓ = 1e-3 ‖ea‖² ‖eb‖² (Li et al. 2020, §4.3; ea = a₁ − a₀, eb = b₁ − b₀).
pub fn edge_edge_mollifier_threshold(a0: &Vec3, a1: &Vec3, b0: &Vec3, b1: &Vec3) -> f64 {
    1e-3 * (a1 - a0).norm_squared() * (b1 - b0).norm_squared()
}

/// c(x) = ‖ea × eb‖² with its gradient and Hessian over [a₀, a₁, b₀, b₁]. With w = ea × eb:
///
/// ```text
/// ∂c/∂ea = 2 eb × w,   ∂c/∂eb = 2 w × ea,
/// ∂²c/∂ea² = 2(‖eb‖² I − eb ebᵀ),   ∂²c/∂eb² = 2(‖ea‖² I − ea eaᵀ),
/// ∂²c/∂ea∂eb = 2(ea ebᵀ − (ea·eb) I − [w]ₓ),
/// ```
///
/// then mapped to the vertices by ea = a₁ − a₀, eb = b₁ − b₀.
pub fn edge_edge_cross_squarednorm_derivatives(
    a0: &Vec3,
    a1: &Vec3,
    b0: &Vec3,
    b1: &Vec3,
) -> Derivatives<12> {
    let ea = a1 - a0;
    let eb = b1 - b0;
    let w = ea.cross(&eb);
    let ga = 2.0 * eb.cross(&w);
    let gb = 2.0 * w.cross(&ea);
    let haa = 2.0 * (eb.norm_squared() * Mat3::identity() - eb * eb.transpose());
    let hbb = 2.0 * (ea.norm_squared() * Mat3::identity() - ea * ea.transpose());
    let hab = 2.0 * (ea * eb.transpose() - ea.dot(&eb) * Mat3::identity() - w.cross_matrix());
    let mut gradient = SVector::<f64, 12>::zeros();
    gradient.fixed_rows_mut::<3>(0).copy_from(&-ga);
    gradient.fixed_rows_mut::<3>(3).copy_from(&ga);
    gradient.fixed_rows_mut::<3>(6).copy_from(&-gb);
    gradient.fixed_rows_mut::<3>(9).copy_from(&gb);
    // Vertex k's sign in its edge vector: a₀ −, a₁ +, b₀ −, b₁ +.
    let sign = [-1.0, 1.0, -1.0, 1.0];
    let mut hessian = SMatrix::<f64, 12, 12>::zeros();
    for k in 0..4 {
        for l in 0..4 {
            let h = match (k < 2, l < 2) {
                (true, true) => haa,
                (false, false) => hbb,
                (true, false) => hab,
                (false, true) => hab.transpose(),
            };
            hessian
                .fixed_view_mut::<3, 3>(3 * k, 3 * l)
                .copy_from(&(sign[k] * sign[l] * h));
        }
    }
    Derivatives {
        value: w.norm_squared(),
        gradient,
        hessian,
    }
}

/// The mollifier as a function of c = ‖ea × eb‖²: m(c) = (2 − c/εₓ) c/εₓ for c < εₓ, else 1;
/// returns (m, m′, m″) with m′ = 2/εₓ − 2c/εₓ², m″ = −2/εₓ² below εₓ (0 above). C¹ at εₓ.
pub fn mollifier(c: f64, eps_x: f64) -> (f64, f64, f64) {
    if c >= eps_x || eps_x <= 0.0 {
        (1.0, 0.0, 0.0)
    } else {
        let r = c / eps_x;
        (
            (2.0 - r) * r,
            2.0 / eps_x - 2.0 * c / (eps_x * eps_x),
            -2.0 / (eps_x * eps_x),
        )
    }
}

/// The edge–edge mollifier m(x) = m(c(x)) over [a₀, a₁, b₀, b₁]:
/// ∇m = m′ ∇c, ∇²m = m″ ∇c ∇cᵀ + m′ ∇²c. It vanishes (with the barrier energy) when the
/// edges are parallel, where the edge–edge distance is not smooth.
pub fn edge_edge_mollifier_derivatives(
    a0: &Vec3,
    a1: &Vec3,
    b0: &Vec3,
    b1: &Vec3,
    eps_x: f64,
) -> Derivatives<12> {
    let c = edge_edge_cross_squarednorm_derivatives(a0, a1, b0, b1);
    let (m, m1, m2) = mollifier(c.value, eps_x);
    Derivatives {
        value: m,
        gradient: m1 * c.gradient,
        hessian: m2 * c.gradient * c.gradient.transpose() + m1 * c.hessian,
    }
}

/// Product rule for e = m·b: ∇e = m∇b + b∇m, ∇²e = m∇²b + b∇²m + ∇m∇bᵀ + ∇b∇mᵀ.
pub fn product<const N: usize>(m: &Derivatives<N>, b: &Derivatives<N>) -> Derivatives<N> {
    let cross = m.gradient * b.gradient.transpose();
    Derivatives {
        value: m.value * b.value,
        gradient: m.value * b.gradient + b.value * m.gradient,
        hessian: m.value * b.hessian + b.value * m.hessian + cross + cross.transpose(),
    }
}

/// The mollified edge–edge barrier m(x)·b(d(x)) over [a₀, a₁, b₀, b₁] (without κ), with the
/// exact (unprojected) Hessian. Zero when d ≥ d̂.
pub fn edge_edge_mollified_barrier(x: &[Vec3; 4], dhat: f64, eps_x: f64) -> Derivatives<12> {
    let [a0, a1, b0, b1] = x;
    let d = super::distance::edge_edge_distance_derivatives(a0, a1, b0, b1);
    let b = barrier_derivatives(&d, dhat);
    if b.value == 0.0 {
        return b;
    }
    product(&edge_edge_mollifier_derivatives(a0, a1, b0, b1, eps_x), &b)
}

/// The smallest barrier stiffness IPC allows (supplement §3):
///
/// ```text
/// d₀ = (1e-8 · L)²  (or d̂/2 if that is not below d̂),   κ_min = s · m̄ / (4 d₀ b″(d₀)),
/// ```
///
/// with L the bounding-box diagonal (m), m̄ the average vertex mass (kg) and s = 1e11
/// (`scale`): the stiffness at which the barrier's curvature at a tiny gap is comparable to
/// the mass matrix.
pub fn min_barrier_stiffness(dhat: f64, bbox_diagonal: f64, average_mass: f64, scale: f64) -> f64 {
    let mut d0 = (1e-8 * bbox_diagonal).powi(2);
    if d0 >= dhat {
        d0 = 0.5 * dhat;
    }
    scale * average_mass / (4.0 * d0 * barrier_second_derivative(d0, dhat))
}

/// The barrier stiffness whose pair stiffness across the gap, at half of d̂, equals `stiffness`
/// (N/m): with s the unsquared gap and d = s², ∂²(κ b(s²))/∂s² = κ (4 d b″(d) + 2 b′(d)) at
/// s = √d̂ / 2.
///
/// [`min_barrier_stiffness`] scales κ to the vertex masses, which is right for bodies pressed by
/// their weight and inertia but far too soft for stiff bodies pressed by their own elastic
/// forces: a twisted beam (E = 1 MPa, 2,700 tets) coiling onto itself drove its turns to gaps of
/// 1e-9 m under κ_min, every Newton step was cut by CCD to under 1 %, and the frame never
/// converged. Given the stiffness of a surface vertex (E · edge length), the barrier meets the
/// elastic forces at gaps near d̂ instead. (Matched at d̂/10 instead, κ is 13 times lower and
/// the three-block stack took 694 Newton iterations over 60 frames against 386.)
pub fn stiffness_matched_barrier_stiffness(dhat: f64, stiffness: f64) -> f64 {
    let d = 0.25 * dhat;
    let per_kappa =
        4.0 * d * barrier_second_derivative(d, dhat) + 2.0 * barrier_first_derivative(d, dhat);
    stiffness / per_kappa
}

/// IPC's initial barrier stiffness: the κ that best balances the contact and the other forces,
///
/// ```text
/// κ = −(∇B·∇E) / ‖∇B‖²,   clamped to [κ_min, κ_max = 100 κ_min],
/// ```
///
/// with ∇E the gradient of the rest of the incremental potential and ∇B = Σ ∇(m b) the
/// unscaled barrier gradient at the start of the step (κ_min when ∇B = 0).
/// Returns (κ, κ_max).
pub fn initial_barrier_stiffness(
    kappa_min: f64,
    grad_energy: &[Vec3],
    grad_barrier: &[Vec3],
) -> (f64, f64) {
    let kappa_max = 100.0 * kappa_min;
    let gb2: f64 = grad_barrier.iter().map(Vec3::norm_squared).sum();
    if gb2 <= 0.0 {
        return (kappa_min, kappa_max);
    }
    let dot: f64 = grad_barrier
        .iter()
        .zip(grad_energy)
        .map(|(b, e)| b.dot(e))
        .sum();
    ((-dot / gb2).clamp(kappa_min, kappa_max), kappa_max)
}

/// IPC's adaptive stiffness update, once per Newton iteration: with ε_d = (1e-9 · L)² (L the
/// bounding-box diagonal; distances squared),
///
/// ```text
/// κ ← min(κ_max, 2κ)   if d_prev < ε_d and d_min < ε_d and d_min < d_prev, else κ,
/// ```
///
/// i.e. double κ when the smallest gap is tiny and still closing.
pub fn update_barrier_stiffness(
    prev_min_distance: f64,
    min_distance: f64,
    kappa_max: f64,
    kappa: f64,
    bbox_diagonal: f64,
) -> f64 {
    let eps_d = (1e-9 * bbox_diagonal).powi(2);
    if prev_min_distance < eps_d && min_distance < eps_d && min_distance < prev_min_distance {
        kappa_max.min(2.0 * kappa)
    } else {
        kappa
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::testutil::{
        fd_gradient_error, fd_hessian_error, point, rng, stack, unstack,
    };

    #[test]
    fn the_matched_stiffness_is_the_barrier_s_curvature_across_the_gap_at_half_dhat() {
        // d̂ = (1 mm)², a surface vertex of E = 1 MPa and 2 cm edges: 2e4 N/m.
        let (dhat, target) = (1e-6, 2e4);
        let kappa = stiffness_matched_barrier_stiffness(dhat, target);
        let energy = |s: f64| kappa * barrier(s * s, dhat);
        let (s, h) = (0.5 * dhat.sqrt(), 1e-7);
        let curvature = (energy(s + h) - 2.0 * energy(s) + energy(s - h)) / (h * h);
        assert!(
            (curvature / target - 1.0).abs() < 1e-4,
            "{curvature} against {target}"
        );
    }

    #[test]
    fn barrier_derivatives_match_finite_differences_and_vanish_at_dhat() {
        let dhat = 1e-2;
        for &d in &[1e-8, 1e-6, 1e-4, 1e-3, 5e-3, 9.9e-3] {
            let h = 1e-6 * d;
            let fd1 = (barrier(d + h, dhat) - barrier(d - h, dhat)) / (2.0 * h);
            let fd2 = (barrier_first_derivative(d + h, dhat)
                - barrier_first_derivative(d - h, dhat))
                / (2.0 * h);
            let b1 = barrier_first_derivative(d, dhat);
            let b2 = barrier_second_derivative(d, dhat);
            assert!((fd1 - b1).abs() <= 1e-6 * b1.abs().max(1e-12), "{d}");
            assert!((fd2 - b2).abs() <= 1e-6 * b2.abs().max(1e-9), "{d}");
            assert!(barrier(d, dhat) > 0.0 && b1 < 0.0 && b2 > 0.0);
        }
        assert_eq!(barrier(dhat, dhat), 0.0);
        assert_eq!(barrier(2.0 * dhat, dhat), 0.0);
        assert!(barrier_first_derivative(dhat * (1.0 - 1e-9), dhat).abs() < 1e-15);
        assert!(barrier(0.0, dhat).is_infinite());
    }

    #[test]
    fn mollified_edge_edge_barrier_matches_finite_differences() {
        let mut rng = rng(11);
        let dhat = 0.05;
        let mut mollified = 0;
        for k in 0..200 {
            let a0 = point(&mut rng);
            let dir = point(&mut rng).normalize();
            let side = dir.cross(&point(&mut rng)).normalize();
            let up = dir.cross(&side);
            // Angles from 1e-4 to 1: many pairs inside the mollifier's band.
            let angle = 10f64.powf(-4.0 * (k as f64 / 200.0));
            let a1 = a0 + dir;
            let b0 = a0 + 0.2 * dir + 0.1 * up - 0.5 * angle * side;
            let b1 = b0 + dir + angle * side;
            let x = [a0, a1, b0, b1];
            let eps_x = edge_edge_mollifier_threshold(&a0, &a1, &b0, &b1) * 10.0;
            let e = edge_edge_mollified_barrier(&x, dhat, eps_x);
            if e.value == 0.0 {
                continue;
            }
            let c = edge_edge_cross_squarednorm_derivatives(&a0, &a1, &b0, &b1).value;
            mollified += usize::from(c < eps_x);
            let x0: SVector<f64, 12> = stack(&x);
            let f = |y: &SVector<f64, 12>| {
                let v = unstack(y);
                edge_edge_mollified_barrier(&[v[0], v[1], v[2], v[3]], dhat, eps_x)
            };
            let eg = fd_gradient_error(|y| f(y).value, &x0, &e.gradient, 1e-12);
            let eh = fd_hessian_error(|y| f(y).gradient, &x0, &e.hessian, 1e-12);
            assert!(eg < 1e-6 && eh < 1e-6, "k {k}: {eg:e} {eh:e}");
            let m = edge_edge_mollifier_derivatives(&a0, &a1, &b0, &b1, eps_x);
            let em = fd_hessian_error(
                |y| {
                    let v = unstack(y);
                    edge_edge_mollifier_derivatives(&v[0], &v[1], &v[2], &v[3], eps_x).gradient
                },
                &x0,
                &m.hessian,
                1e-12,
            );
            assert!(em < 1e-6, "mollifier Hessian {em:e}");
        }
        assert!(mollified > 20, "only {mollified} mollified pairs");
    }

    #[test]
    fn projected_hessian_is_psd_and_exact_when_already_psd() {
        let mut rng = rng(12);
        for _ in 0..20 {
            let x = [0; 4].map(|_| 0.1 * point(&mut rng));
            let d = super::super::distance::point_triangle_distance_derivatives(
                &x[0], &x[1], &x[2], &x[3],
            );
            let p = project_psd(&d.hessian);
            let eig = nalgebra::SymmetricEigen::new(p).eigenvalues;
            assert!(eig.min() > -1e-10 * (1.0 + p.norm()));
        }
        let spd = SMatrix::<f64, 3, 3>::new(2.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(project_psd(&spd), spd);
    }

    #[test]
    fn stiffness_balances_forces_and_doubles_when_gaps_keep_closing() {
        let dhat = 1e-6;
        let kmin = min_barrier_stiffness(dhat, 1.0, 0.01, 1e11);
        assert!(kmin > 0.0 && kmin.is_finite());
        let gb = [Vec3::new(-1.0, 0.0, 0.0)];
        let ge = [Vec3::new(50.0 * kmin, 0.0, 0.0)];
        let (k, kmax) = initial_barrier_stiffness(kmin, &ge, &gb);
        assert!((k - 50.0 * kmin).abs() < 1e-9 * k && kmax == 100.0 * kmin);
        assert_eq!(
            initial_barrier_stiffness(kmin, &ge, &[Vec3::zeros()]).0,
            kmin
        );
        let eps = (1e-9f64).powi(2);
        assert_eq!(
            update_barrier_stiffness(0.5 * eps, 0.4 * eps, kmax, k, 1.0),
            2.0 * k
        );
        assert_eq!(
            update_barrier_stiffness(0.4 * eps, 0.5 * eps, kmax, k, 1.0),
            k
        );
        assert_eq!(
            update_barrier_stiffness(2.0 * eps, 0.5 * eps, kmax, k, 1.0),
            k
        );
        assert_eq!(
            update_barrier_stiffness(0.5 * eps, 0.4 * eps, kmax, 0.9 * kmax, 1.0),
            kmax
        );
    }
}
