//! IPC's lagged, smoothed Coulomb friction (Li et al. 2020, §5).
//!
//! For a contact pair, at the *lagged* state (the start of the step, or the last outer
//! iteration) fix:
//! - the closest-point coefficients c (r = Σₖ cₖ xₖ is the vector between the closest points,
//!   from the classified distance: point–point, point–line, point–plane or line–line), and
//! - an orthonormal basis T (3×2) of the tangent plane, orthogonal to the contact normal;
//! - the normal force magnitude λ = −2κ √d b′(d) (see [`normal_force_magnitude`]).
//!
//! The relative tangential displacement over the step is then linear in the dofs:
//!
//! ```text
//! u = Tᵀ Σₖ cₖ Δxₖ = Γ Δx,   Γ = [c₀Tᵀ c₁Tᵀ …] (2 × N),   Δx = x − xᵗ,
//! ```
//!
//! and friction is the potential D(x) = μ λ f₀(‖u‖) with the C¹ smoothing (ε = ε_v h, metres:
//! the sliding speed ε_v below which friction is treated as static, times the time step)
//!
//! ```text
//! f₀(y) = −y³/(3ε²) + y²/ε + ε/3,   f₁(y) = f₀′(y) = −y²/ε² + 2y/ε   for y < ε,
//! f₀(y) = y,                          f₁(y) = 1                        for y ≥ ε,
//! ```
//!
//! so the force has magnitude μλ f₁(‖u‖) → μλ (Coulomb sliding) for ‖u‖ ≥ ε. Derivatives:
//!
//! ```text
//! ∇D = μλ Γᵀ (f₁(y)/y) u,
//! ∇²D = μλ Γᵀ [ (f₁/y) I + ((f₁/y)′ / y) u uᵀ ] Γ,   y = ‖u‖,
//! ```
//!
//! where (f₁/y)′ = −1/ε² below ε and −1/y² above. The bracket has eigenvalues f₁/y > 0 (across
//! u) and f₁′(y) = 2(ε − y)/ε² ≥ 0 or 0 (along u), so this exact Hessian is already positive
//! semi-definite: no projection needed. At y = 0 it is (2/ε) I.

use nalgebra::{Matrix2, Matrix3x2, SMatrix, SVector, Vector2};

use super::barrier::barrier_first_derivative;
use super::distance::{
    EdgeEdgeCase, PointEdgeCase, PointTriangleCase, edge_edge_distance_type,
    point_edge_distance_type, point_triangle_distance_type,
};
use crate::math::Vec3;

/// The lagged tangent frame of a pair with N dofs (N/3 vertices).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentFrame<const N: usize> {
    /// Orthonormal basis of the tangent plane, as columns (3 × 2).
    pub basis: Matrix3x2<f64>,
    /// cₖ: the closest-point difference is r = Σₖ cₖ xₖ (Σₖ cₖ = 0, so rigid translations
    /// give u = 0). Entries past N/3 are 0.
    pub coefficients: [f64; 4],
}

impl<const N: usize> TangentFrame<N> {
    /// Γ (2 × N): u = Γ Δx.
    pub fn jacobian(&self) -> SMatrix<f64, 2, N> {
        let mut g = SMatrix::<f64, 2, N>::zeros();
        let tt = self.basis.transpose();
        for k in 0..N / 3 {
            g.fixed_view_mut::<2, 3>(0, 3 * k)
                .copy_from(&(self.coefficients[k] * tt));
        }
        g
    }

    /// u = Tᵀ Σₖ cₖ Δxₖ for the vertices' displacements Δx (N/3 of them).
    pub fn relative_displacement(&self, dx: &[Vec3]) -> Vector2<f64> {
        let r: Vec3 = dx
            .iter()
            .take(N / 3)
            .zip(&self.coefficients)
            .map(|(d, c)| d * *c)
            .sum();
        self.basis.transpose() * r
    }
}

/// An orthonormal tangent basis orthogonal to `normal`, whose first column follows `hint`
/// (projected) when it can. Degenerate normals or hints fall back to a fixed choice, so the
/// result is always orthonormal and finite.
fn tangent_basis(normal: &Vec3, hint: Option<&Vec3>) -> Matrix3x2<f64> {
    let n = normal.try_normalize(1e-300).unwrap_or_else(|| {
        // No normal: any plane containing the hint, else the xy-plane.
        hint.and_then(|h| h.try_normalize(1e-300))
            .map(|h| {
                let a = if h.x.abs() < 0.5 {
                    Vec3::x()
                } else {
                    Vec3::y()
                };
                h.cross(&a).normalize()
            })
            .unwrap_or_else(Vec3::z)
    });
    let t1 = hint
        .and_then(|h| (h - n * n.dot(h)).try_normalize(1e-12 * h.norm().max(1e-300)))
        .unwrap_or_else(|| {
            let a = if n.x.abs() < 0.5 {
                Vec3::x()
            } else {
                Vec3::y()
            };
            n.cross(&a).normalize()
        });
    let t2 = n.cross(&t1);
    Matrix3x2::from_columns(&[t1, t2])
}

fn residual(x: &[Vec3], c: &[f64; 4]) -> Vec3 {
    x.iter().zip(c).map(|(xk, ck)| xk * *ck).sum()
}

/// Point–point frame: normal along p − q, c = [1, −1].
pub fn point_point_frame(p: &Vec3, q: &Vec3) -> TangentFrame<6> {
    TangentFrame {
        basis: tangent_basis(&(p - q), None),
        coefficients: [1.0, -1.0, 0.0, 0.0],
    }
}

/// Point p (dof `ip`) against the segment (`i0`, `i1`): coefficients and basis by case.
fn point_edge_parts(x: &[Vec3], ip: usize, i0: usize, i1: usize) -> (Matrix3x2<f64>, [f64; 4]) {
    let mut c = [0.0; 4];
    c[ip] = 1.0;
    match point_edge_distance_type(&x[ip], &x[i0], &x[i1]) {
        PointEdgeCase::Vertex(v) => {
            c[if v == 0 { i0 } else { i1 }] = -1.0;
        }
        PointEdgeCase::Interior => {
            let e = x[i1] - x[i0];
            let t = (x[ip] - x[i0]).dot(&e) / e.norm_squared();
            c[i0] = t - 1.0;
            c[i1] = -t;
            // Tangent plane ⟂ r: spanned by the edge and r × edge.
            let r = residual(x, &c);
            let normal = if r.norm() > 0.0 { r } else { Vec3::zeros() };
            return (tangent_basis(&normal, Some(&e)), c);
        }
    }
    (tangent_basis(&residual(x, &c), None), c)
}

/// Point–edge frame over [p, e₀, e₁] (point–point when the closest point is an end vertex).
pub fn point_edge_frame(p: &Vec3, e0: &Vec3, e1: &Vec3) -> TangentFrame<9> {
    let (basis, coefficients) = point_edge_parts(&[*p, *e0, *e1], 0, 1, 2);
    TangentFrame {
        basis,
        coefficients,
    }
}

/// Point–triangle frame over [p, t₀, t₁, t₂], of the classified sub-case; in the interior
/// the basis is [ê₀, n̂ × ê₀] with n = e₀ × e₁ and c = [1, −(1 − β₁ − β₂), −β₁, −β₂].
pub fn point_triangle_frame(p: &Vec3, t0: &Vec3, t1: &Vec3, t2: &Vec3) -> TangentFrame<12> {
    let x = [*p, *t0, *t1, *t2];
    let (basis, coefficients) = match point_triangle_distance_type(p, t0, t1, t2) {
        PointTriangleCase::Interior => {
            let (e0, e1) = (t1 - t0, t2 - t0);
            let q = p - t0;
            let (a, b, c) = (e0.dot(&e0), e0.dot(&e1), e1.dot(&e1));
            let det = a * c - b * b;
            let b1 = (c * q.dot(&e0) - b * q.dot(&e1)) / det;
            let b2 = (a * q.dot(&e1) - b * q.dot(&e0)) / det;
            (
                tangent_basis(&e0.cross(&e1), Some(&e0)),
                [1.0, b1 + b2 - 1.0, -b1, -b2],
            )
        }
        PointTriangleCase::Edge(k) => point_edge_parts(&x, 0, 1 + k, 1 + (k + 1) % 3),
        PointTriangleCase::Vertex(k) => {
            let mut c = [1.0, 0.0, 0.0, 0.0];
            c[1 + k] = -1.0;
            (tangent_basis(&residual(&x, &c), None), c)
        }
    };
    TangentFrame {
        basis,
        coefficients,
    }
}

/// Edge–edge frame over [a₀, a₁, b₀, b₁], of the classified sub-case; inside both edges the
/// basis is [êa, n̂ × êa] with n = ea × eb and c = [1 − s, s, −(1 − t), −t].
pub fn edge_edge_frame(a0: &Vec3, a1: &Vec3, b0: &Vec3, b1: &Vec3) -> TangentFrame<12> {
    let x = [*a0, *a1, *b0, *b1];
    let (basis, coefficients) = match edge_edge_distance_type(a0, a1, b0, b1) {
        EdgeEdgeCase::Interior => {
            let (ea, eb, w) = (a1 - a0, b1 - b0, a0 - b0);
            let (a, b, c) = (ea.dot(&ea), ea.dot(&eb), eb.dot(&eb));
            let (d, e) = (ea.dot(&w), eb.dot(&w));
            let det = a * c - b * b;
            let s = (b * e - c * d) / det;
            let t = (a * e - b * d) / det;
            (
                tangent_basis(&ea.cross(&eb), Some(&ea)),
                [1.0 - s, s, t - 1.0, -t],
            )
        }
        EdgeEdgeCase::VertexOfA { a } => point_edge_parts(&x, a, 2, 3),
        EdgeEdgeCase::VertexOfB { b } => point_edge_parts(&x, 2 + b, 0, 1),
        EdgeEdgeCase::VertexVertex { a, b } => {
            let mut c = [0.0; 4];
            c[a] = 1.0;
            c[2 + b] = -1.0;
            (tangent_basis(&residual(&x, &c), None), c)
        }
    };
    TangentFrame {
        basis,
        coefficients,
    }
}

/// λ = −2κ √d b′(d): the magnitude of the barrier's contact force κ ∂b/∂√d at squared distance
/// d (0 beyond d̂), lagged into the friction potential.
pub fn normal_force_magnitude(d: f64, dhat: f64, kappa: f64) -> f64 {
    if d <= 0.0 {
        return 0.0;
    }
    -2.0 * kappa * d.sqrt() * barrier_first_derivative(d, dhat)
}

/// f₀(y) of the module doc (ε = ε_v h > 0, m).
pub fn f0(y: f64, eps: f64) -> f64 {
    if y >= eps {
        y
    } else {
        -y * y * y / (3.0 * eps * eps) + y * y / eps + eps / 3.0
    }
}

/// f₁(y) = f₀′(y): the fraction of μλ the friction force has at slip y.
pub fn f1(y: f64, eps: f64) -> f64 {
    if y >= eps {
        1.0
    } else {
        -y * y / (eps * eps) + 2.0 * y / eps
    }
}

/// f₁(y)/y, finite at y = 0 (where it is 2/ε).
pub fn f1_over_y(y: f64, eps: f64) -> f64 {
    if y >= eps {
        1.0 / y
    } else {
        2.0 / eps - y / (eps * eps)
    }
}

/// (f₁(y)/y)′ / y, the coefficient of u uᵀ in the Hessian: −1/(ε² y) below ε, −1/y³ above.
/// At y = 0 the term (coefficient × u uᵀ, of size y/ε²) vanishes, so 0 is returned.
fn f1_over_y_derivative_over_y(y: f64, eps: f64) -> f64 {
    if y >= eps {
        -1.0 / (y * y * y)
    } else if y > 0.0 {
        -1.0 / (eps * eps * y)
    } else {
        0.0
    }
}

/// One pair's friction: its lagged frame, μ and λ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionPair<const N: usize> {
    /// The lagged tangent frame.
    pub frame: TangentFrame<N>,
    /// Coulomb coefficient μ (dimensionless).
    pub mu: f64,
    /// Lagged normal force magnitude λ (N).
    pub normal_force: f64,
}

impl<const N: usize> FrictionPair<N> {
    /// D = μλ f₀(‖u‖), Δx the vertices' displacements since the lagged state (J).
    pub fn potential(&self, dx: &[Vec3], eps: f64) -> f64 {
        let u = self.frame.relative_displacement(dx);
        self.mu * self.normal_force * f0(u.norm(), eps)
    }

    /// ∇D = μλ Γᵀ (f₁(y)/y) u (N; the negative is the friction force).
    pub fn gradient(&self, dx: &[Vec3], eps: f64) -> SVector<f64, N> {
        let u = self.frame.relative_displacement(dx);
        self.frame.jacobian().transpose()
            * (self.mu * self.normal_force * f1_over_y(u.norm(), eps) * u)
    }

    /// ∇²D = μλ Γᵀ [(f₁/y) I + ((f₁/y)′/y) u uᵀ] Γ, positive semi-definite (module doc).
    pub fn hessian(&self, dx: &[Vec3], eps: f64) -> SMatrix<f64, N, N> {
        let u = self.frame.relative_displacement(dx);
        let y = u.norm();
        let hu = f1_over_y(y, eps) * Matrix2::identity()
            + f1_over_y_derivative_over_y(y, eps) * u * u.transpose();
        let g = self.frame.jacobian();
        self.mu * self.normal_force * g.transpose() * hu * g
    }
}

#[cfg(test)]
mod tests;
