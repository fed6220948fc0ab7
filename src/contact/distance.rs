//! Squared distances between surface primitives, with the closest-feature classification and
//! exact gradients and Hessians.
//!
//! Every distance here is a minimum of a quadratic over the primitives' parameters:
//!
//! ```text
//! d(x) = min_β ‖r(x, β)‖²,   r = Σₖ cₖ(β) xₖ,   cₖ affine in β ∈ ℝᵐ (m ≤ 2),
//! ```
//!
//! e.g. point–triangle interior: r = p − (t₀ + β₁(t₁ − t₀) + β₂(t₂ − t₀)), m = 2. The
//! classification ([`point_triangle_distance_type`], [`edge_edge_distance_type`],
//! [`point_edge_distance_type`]) finds which feature is closest (a vertex, an edge, the interior),
//! so that at the optimum the active parameters are free and the constraint set is fixed; the
//! distance is then the unconstrained minimum of that sub-case (point–point, point–line,
//! point–plane, line–line), which is smooth, and is differentiated by the envelope theorem:
//!
//! ```text
//! ∂d/∂xₖ = 2 cₖ r,
//! ∂²d/∂x² = f_xx − f_xβ f_ββ⁻¹ f_βx,   f = ‖r‖²,
//! (f_xx)ₖₗ = 2 cₖ cₗ I₃,  (f_xβ)ₖⱼ = 2 (aₖⱼ r + cₖ tⱼ),  f_ββ = 2 TᵀT,
//! ```
//!
//! with aₖⱼ = ∂cₖ/∂βⱼ (constants) and T = [t₁ … tₘ], tⱼ = ∂r/∂βⱼ = Σₖ aₖⱼ xₖ. This is the
//! same per-case Hessian as ipc-toolkit's `point_line`, `point_plane`, `line_line` functions,
//! written once instead of per case. When f_ββ is singular (a zero-length edge, a zero-area
//! triangle, parallel edges) the classification never picks that sub-case; if rounding does, the
//! correction term is dropped so the result stays finite.
//!
//! The dofs of a pair are its vertices stacked in argument order: point–triangle
//! `[p, t₀, t₁, t₂]`, edge–edge `[a₀, a₁, b₀, b₁]`, point–edge `[p, e₀, e₁]`.

use nalgebra::{Matrix2, SMatrix, SVector};

use crate::math::{Mat3, Vec3};

/// Value, gradient and Hessian of a scalar function of N dofs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derivatives<const N: usize> {
    /// The value.
    pub value: f64,
    /// ∂/∂x, N entries.
    pub gradient: SVector<f64, N>,
    /// ∂²/∂x², N × N, symmetric (not projected: it may be indefinite).
    pub hessian: SMatrix<f64, N, N>,
}

/// Which feature of a segment is closest to a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PointEdgeCase {
    /// The edge's vertex 0 or 1: the distance is point–point.
    Vertex(usize),
    /// A point inside the edge: the distance is to the infinite line.
    Interior,
}

/// Which feature of a triangle is closest to a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PointTriangleCase {
    /// Triangle vertex 0, 1 or 2 (point–point).
    Vertex(usize),
    /// Triangle edge 0 (t₀t₁), 1 (t₁t₂) or 2 (t₂t₀), inside it (point–line).
    Edge(usize),
    /// The triangle's interior (point–plane).
    Interior,
}

/// Which features of two segments a = a₀a₁ and b = b₀b₁ are closest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EdgeEdgeCase {
    /// Vertex `a` of edge a and vertex `b` of edge b (point–point).
    VertexVertex {
        /// 0 or 1.
        a: usize,
        /// 0 or 1.
        b: usize,
    },
    /// Vertex `a` of edge a and the inside of edge b (point–line).
    VertexOfA {
        /// 0 or 1.
        a: usize,
    },
    /// Vertex `b` of edge b and the inside of edge a (point–line).
    VertexOfB {
        /// 0 or 1.
        b: usize,
    },
    /// Inside both edges (line–line).
    Interior,
}

/// The optimum of one sub-case: r = Σₖ cₖ xₖ, aₖⱼ = ∂cₖ/∂βⱼ, m free parameters.
#[derive(Clone, Copy, Debug)]
struct Closest {
    c: [f64; 4],
    a: [[f64; 2]; 4],
    m: usize,
}

impl Closest {
    /// r = x_i − x_j.
    fn point_point(i: usize, j: usize) -> Self {
        let mut c = [0.0; 4];
        c[i] = 1.0;
        c[j] = -1.0;
        Closest {
            c,
            a: [[0.0; 2]; 4],
            m: 0,
        }
    }

    /// r = x_p − ((1 − t) x_e0 + t x_e1).
    fn point_line(p: usize, e0: usize, e1: usize, t: f64) -> Self {
        let mut c = [0.0; 4];
        let mut a = [[0.0; 2]; 4];
        c[p] = 1.0;
        c[e0] = t - 1.0;
        c[e1] = -t;
        a[e0][0] = 1.0;
        a[e1][0] = -1.0;
        Closest { c, a, m: 1 }
    }

    /// r = p − (t₀ + β₁(t₁ − t₀) + β₂(t₂ − t₀)) with p, t₀, t₁, t₂ at dofs 0..4.
    fn point_plane(b1: f64, b2: f64) -> Self {
        Closest {
            c: [1.0, b1 + b2 - 1.0, -b1, -b2],
            a: [[0.0, 0.0], [1.0, 1.0], [-1.0, 0.0], [0.0, -1.0]],
            m: 2,
        }
    }

    /// r = (a₀ + s(a₁ − a₀)) − (b₀ + t(b₁ − b₀)) with a₀, a₁, b₀, b₁ at dofs 0..4.
    fn line_line(s: f64, t: f64) -> Self {
        Closest {
            c: [1.0 - s, s, t - 1.0, -t],
            a: [[-1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, -1.0]],
            m: 2,
        }
    }

    /// r = Σ cₖ xₖ.
    fn residual(&self, x: &[Vec3]) -> Vec3 {
        x.iter().zip(&self.c).map(|(xk, ck)| xk * *ck).sum()
    }

    /// The squared distance, its gradient and its Hessian by the envelope theorem (module doc).
    fn derivatives<const N: usize>(&self, x: &[Vec3]) -> Derivatives<N> {
        let nv = N / 3;
        let x = &x[..nv];
        let r = self.residual(x);
        let mut gradient = SVector::<f64, N>::zeros();
        let mut hessian = SMatrix::<f64, N, N>::zeros();
        for k in 0..nv {
            gradient
                .fixed_rows_mut::<3>(3 * k)
                .copy_from(&(2.0 * self.c[k] * r));
            for l in 0..nv {
                let w = 2.0 * self.c[k] * self.c[l];
                for i in 0..3 {
                    hessian[(3 * k + i, 3 * l + i)] = w;
                }
            }
        }
        if self.m > 0 {
            let t: [Vec3; 2] = [0, 1].map(|j| {
                x.iter()
                    .zip(&self.a)
                    .map(|(xk, ak)| xk * ak[j])
                    .sum::<Vec3>()
            });
            // f_ββ = 2 TᵀT, restricted to the m free parameters, and its inverse.
            let inverse = if self.m == 1 {
                let f = 2.0 * t[0].norm_squared();
                (f > 0.0).then(|| Matrix2::new(1.0 / f, 0.0, 0.0, 0.0))
            } else {
                let fbb = Matrix2::new(
                    2.0 * t[0].dot(&t[0]),
                    2.0 * t[0].dot(&t[1]),
                    2.0 * t[1].dot(&t[0]),
                    2.0 * t[1].dot(&t[1]),
                );
                let scale = fbb[(0, 0)] * fbb[(1, 1)];
                // Singular: a degenerate sub-case the classification avoids; stay finite.
                if fbb.determinant() > 1e-20 * scale {
                    fbb.try_inverse()
                } else {
                    None
                }
            };
            if let Some(inv) = inverse {
                let mut g = SMatrix::<f64, N, 2>::zeros();
                for k in 0..nv {
                    for (j, tj) in t.iter().enumerate().take(self.m) {
                        g.fixed_view_mut::<3, 1>(3 * k, j)
                            .copy_from(&(2.0 * (self.a[k][j] * r + self.c[k] * tj)));
                    }
                }
                let correction = g * inv * g.transpose();
                if correction.iter().all(|v| v.is_finite()) {
                    hessian -= correction;
                }
            }
        }
        Derivatives {
            value: r.norm_squared(),
            gradient,
            hessian,
        }
    }
}

/// Parameter t ∈ [0, 1] of the point of segment e₀e₁ closest to p, unclamped (0 for a
/// zero-length segment).
fn segment_parameter(p: &Vec3, e0: &Vec3, e1: &Vec3) -> f64 {
    let e = e1 - e0;
    let l2 = e.norm_squared();
    if l2 > 0.0 { (p - e0).dot(&e) / l2 } else { 0.0 }
}

/// Classification and optimum for point p (dof `ip`) against segment (dofs `i0`, `i1`).
fn closest_point_edge(
    x: &[Vec3],
    ip: usize,
    i0: usize,
    i1: usize,
) -> (PointEdgeCase, Closest, f64) {
    let t = segment_parameter(&x[ip], &x[i0], &x[i1]);
    let (case, closest) = if t <= 0.0 {
        (PointEdgeCase::Vertex(0), Closest::point_point(ip, i0))
    } else if t >= 1.0 {
        (PointEdgeCase::Vertex(1), Closest::point_point(ip, i1))
    } else {
        (PointEdgeCase::Interior, Closest::point_line(ip, i0, i1, t))
    };
    let d = closest.residual(x).norm_squared();
    (case, closest, d)
}

fn closest_point_triangle(x: &[Vec3; 4]) -> (PointTriangleCase, Closest) {
    let [p, t0, t1, t2] = x;
    let e0 = t1 - t0;
    let e1 = t2 - t0;
    let q = p - t0;
    let (a, b, c) = (e0.dot(&e0), e0.dot(&e1), e1.dot(&e1));
    let det = a * c - b * b; // = ‖e₀ × e₁‖²
    if det > 1e-20 * a * c {
        let (u, v) = (q.dot(&e0), q.dot(&e1));
        let b1 = (c * u - b * v) / det;
        let b2 = (a * v - b * u) / det;
        if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
            return (PointTriangleCase::Interior, Closest::point_plane(b1, b2));
        }
    }
    // Outside (or degenerate): the closest point is on the boundary, the nearest of three edges.
    let mut best: Option<(PointTriangleCase, Closest, f64)> = None;
    for (edge, (i0, i1)) in [(1, 2), (2, 3), (3, 1)].into_iter().enumerate() {
        let (case, closest, d) = closest_point_edge(x, 0, i0, i1);
        let case = match case {
            PointEdgeCase::Vertex(0) => PointTriangleCase::Vertex(i0 - 1),
            PointEdgeCase::Vertex(_) => PointTriangleCase::Vertex(i1 - 1),
            PointEdgeCase::Interior => PointTriangleCase::Edge(edge),
        };
        if best.as_ref().is_none_or(|b| d < b.2) {
            best = Some((case, closest, d));
        }
    }
    let (case, closest, _) = best.expect("three edges");
    (case, closest)
}

fn closest_edge_edge(x: &[Vec3; 4]) -> (EdgeEdgeCase, Closest) {
    let [a0, a1, b0, b1] = x;
    let ea = a1 - a0;
    let eb = b1 - b0;
    let w = a0 - b0;
    let (a, b, c) = (ea.dot(&ea), ea.dot(&eb), eb.dot(&eb));
    let (d, e) = (ea.dot(&w), eb.dot(&w));
    let det = a * c - b * b; // = ‖ea × eb‖²
    let mut best: Option<(EdgeEdgeCase, Closest, f64)> = None;
    // Not (nearly) parallel: the unconstrained minimum, if inside the unit square, is the
    // minimum (the squared distance is convex in (s, t)).
    if det > 1e-20 * a * c {
        let s = (b * e - c * d) / det;
        let t = (a * e - b * d) / det;
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            let closest = Closest::line_line(s, t);
            let dist = closest.residual(x).norm_squared();
            best = Some((EdgeEdgeCase::Interior, closest, dist));
        }
    }
    // Else on the square's boundary: one endpoint against the other segment. Also compared when
    // the interior was found, so that rounding near parallel edges cannot pick a worse case.
    let sides = [
        (0, 2, 3, true),
        (1, 2, 3, true),
        (2, 0, 1, false),
        (3, 0, 1, false),
    ];
    for (ip, i0, i1, of_a) in sides {
        let (case, closest, dist) = closest_point_edge(x, ip, i0, i1);
        let case = match (case, of_a) {
            (PointEdgeCase::Vertex(v), true) => EdgeEdgeCase::VertexVertex { a: ip, b: v },
            (PointEdgeCase::Vertex(v), false) => EdgeEdgeCase::VertexVertex { a: v, b: ip - 2 },
            (PointEdgeCase::Interior, true) => EdgeEdgeCase::VertexOfA { a: ip },
            (PointEdgeCase::Interior, false) => EdgeEdgeCase::VertexOfB { b: ip - 2 },
        };
        if best.as_ref().is_none_or(|bst| dist < bst.2) {
            best = Some((case, closest, dist));
        }
    }
    let (case, closest, _) = best.expect("four sides");
    (case, closest)
}

/// d = ‖p − q‖².
pub fn point_point_distance(p: &Vec3, q: &Vec3) -> f64 {
    (p - q).norm_squared()
}

/// d = ‖p − q‖² over dofs [p, q]: ∇d = 2[r; −r], ∇²d = 2[I −I; −I I], r = p − q.
pub fn point_point_distance_derivatives(p: &Vec3, q: &Vec3) -> Derivatives<6> {
    Closest::point_point(0, 1).derivatives(&[*p, *q])
}

/// Which feature of segment e₀e₁ is closest to p (a zero-length segment: vertex 0).
pub fn point_edge_distance_type(p: &Vec3, e0: &Vec3, e1: &Vec3) -> PointEdgeCase {
    closest_point_edge(&[*p, *e0, *e1], 0, 1, 2).0
}

/// Squared distance from p to the segment e₀e₁: with t = (p − e₀)·e / ‖e‖² clamped to [0, 1],
/// d = ‖p − e₀ − t e‖², e = e₁ − e₀.
pub fn point_edge_distance(p: &Vec3, e0: &Vec3, e1: &Vec3) -> f64 {
    closest_point_edge(&[*p, *e0, *e1], 0, 1, 2).2
}

/// [`point_edge_distance`] with gradient and Hessian over [p, e₀, e₁], of the sub-case
/// (point–point or point–line, d = ‖(p − e₀) × e‖² / ‖e‖²) that is active.
pub fn point_edge_distance_derivatives(p: &Vec3, e0: &Vec3, e1: &Vec3) -> Derivatives<9> {
    let x = [*p, *e0, *e1];
    closest_point_edge(&x, 0, 1, 2).1.derivatives(&x)
}

/// Which feature of triangle t₀t₁t₂ is closest to p. Interior when p projects inside the
/// triangle (barycentric coordinates ≥ 0); otherwise the nearest of the three edges, refined to
/// an end vertex when the projection on that edge clamps. Zero-area triangles are edges.
pub fn point_triangle_distance_type(
    p: &Vec3,
    t0: &Vec3,
    t1: &Vec3,
    t2: &Vec3,
) -> PointTriangleCase {
    closest_point_triangle(&[*p, *t0, *t1, *t2]).0
}

/// Squared distance from p to the (closed, solid) triangle t₀t₁t₂.
pub fn point_triangle_distance(p: &Vec3, t0: &Vec3, t1: &Vec3, t2: &Vec3) -> f64 {
    let x = [*p, *t0, *t1, *t2];
    closest_point_triangle(&x).1.residual(&x).norm_squared()
}

/// [`point_triangle_distance`] with gradient and Hessian over [p, t₀, t₁, t₂], of the active
/// sub-case: point–point, point–line, or point–plane d = ((p − t₀)·n)² / ‖n‖²,
/// n = (t₁ − t₀) × (t₂ − t₀).
pub fn point_triangle_distance_derivatives(
    p: &Vec3,
    t0: &Vec3,
    t1: &Vec3,
    t2: &Vec3,
) -> Derivatives<12> {
    let x = [*p, *t0, *t1, *t2];
    closest_point_triangle(&x).1.derivatives(&x)
}

/// Which features of segments a₀a₁ and b₀b₁ are closest. Interior when the closest points of
/// the two infinite lines lie inside both segments (and the edges are not parallel to within
/// ‖ea × eb‖² ≤ 1e-20 ‖ea‖²‖eb‖²); otherwise the best of the four endpoint–segment cases.
pub fn edge_edge_distance_type(a0: &Vec3, a1: &Vec3, b0: &Vec3, b1: &Vec3) -> EdgeEdgeCase {
    closest_edge_edge(&[*a0, *a1, *b0, *b1]).0
}

/// Squared distance between the segments a₀a₁ and b₀b₁.
pub fn edge_edge_distance(a0: &Vec3, a1: &Vec3, b0: &Vec3, b1: &Vec3) -> f64 {
    let x = [*a0, *a1, *b0, *b1];
    closest_edge_edge(&x).1.residual(&x).norm_squared()
}

/// [`edge_edge_distance`] with gradient and Hessian over [a₀, a₁, b₀, b₁], of the active
/// sub-case: point–point, point–line, or line–line d = ((a₀ − b₀)·n)² / ‖n‖², n = ea × eb.
pub fn edge_edge_distance_derivatives(
    a0: &Vec3,
    a1: &Vec3,
    b0: &Vec3,
    b1: &Vec3,
) -> Derivatives<12> {
    let x = [*a0, *a1, *b0, *b1];
    closest_edge_edge(&x).1.derivatives(&x)
}

/// Euclidean (unsquared) distance between two segments; a zero-length segment is a point.
/// The robust reference used by tests and diagnostics.
pub fn segment_segment_distance(a0: &Vec3, a1: &Vec3, b0: &Vec3, b1: &Vec3) -> f64 {
    edge_edge_distance(a0, a1, b0, b1).sqrt()
}

/// Signed distance from p to the plane through `origin` with normal `normal` (any nonzero
/// length): g = n̂·(p − o), positive on the side the normal points to.
pub fn point_plane_gap(p: &Vec3, origin: &Vec3, normal: &Vec3) -> f64 {
    let n = normal.try_normalize(0.0).unwrap_or_else(Vec3::zeros);
    n.dot(&(p - origin))
}

/// Squared distance to a fixed plane over the point's 3 dofs: d = g², ∇d = 2 g n̂, ∇²d = 2 n̂n̂ᵀ.
pub fn point_plane_distance_derivatives(p: &Vec3, origin: &Vec3, normal: &Vec3) -> Derivatives<3> {
    let n = normal.try_normalize(0.0).unwrap_or_else(Vec3::zeros);
    let g = n.dot(&(p - origin));
    Derivatives {
        value: g * g,
        gradient: 2.0 * g * n,
        hessian: 2.0 * n * n.transpose(),
    }
}

/// Gap between a sphere (center c, radius ρ) and the triangle t₀t₁t₂:
/// g = √D − ρ, D = point–triangle squared distance (c, t). Exact for a sphere against the
/// triangle's faces, edges and vertices alike (the offset of a closed set by ρ). Negative when
/// the sphere overlaps the triangle.
pub fn sphere_triangle_gap(center: &Vec3, radius: f64, t0: &Vec3, t1: &Vec3, t2: &Vec3) -> f64 {
    point_triangle_distance(center, t0, t1, t2).sqrt() - radius
}

/// The squared gap s = g² of [`sphere_triangle_gap`] (what the barrier takes) over the
/// triangle's 9 dofs (the sphere is rigid: its center is a parameter, not a dof):
///
/// ```text
/// ∇g = ∇D / (2√D),  ∇²g = ∇²D / (2√D) − ∇D∇Dᵀ / (4 D^{3/2}),
/// ∇s = 2 g ∇g,      ∇²s = 2 ∇g∇gᵀ + 2 g ∇²g.
/// ```
///
/// Meaningful for g > 0 (the barrier is only evaluated there). When the center lies on the
/// triangle (D = 0) the gradient and Hessian are returned as zero.
pub fn sphere_triangle_distance_derivatives(
    center: &Vec3,
    radius: f64,
    t0: &Vec3,
    t1: &Vec3,
    t2: &Vec3,
) -> Derivatives<9> {
    let full = point_triangle_distance_derivatives(center, t0, t1, t2);
    let d = full.value;
    if d <= 0.0 {
        return Derivatives {
            value: radius * radius,
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        };
    }
    let sd = d.sqrt();
    let g = sd - radius;
    let dd: SVector<f64, 9> = full.gradient.fixed_rows::<9>(3).into();
    let hd: SMatrix<f64, 9, 9> = full.hessian.fixed_view::<9, 9>(3, 3).into();
    let dg = dd / (2.0 * sd);
    let hg = hd / (2.0 * sd) - dd * dd.transpose() / (4.0 * d * sd);
    Derivatives {
        value: g * g,
        gradient: 2.0 * g * dg,
        hessian: 2.0 * dg * dg.transpose() + 2.0 * g * hg,
    }
}

/// The 3 × 3 block (k, l) of a dof-space matrix.
pub fn block<const N: usize>(m: &SMatrix<f64, N, N>, k: usize, l: usize) -> Mat3 {
    m.fixed_view::<3, 3>(3 * k, 3 * l).into()
}

/// The sign (1, −1) of the orientation of d against the plane through a, b, c, or 0 when it is 0
/// *or too close to 0 to tell* in floating point (Shewchuk's static error bound of orient3d:
/// outside it the sign is exact).
pub fn orient_sign(a: &Vec3, b: &Vec3, c: &Vec3, d: &Vec3) -> i8 {
    let (ad, bd, cd) = (a - d, b - d, c - d);
    let det = ad.x * (bd.y * cd.z - bd.z * cd.y)
        + bd.x * (cd.y * ad.z - cd.z * ad.y)
        + cd.x * (ad.y * bd.z - ad.z * bd.y);
    let permanent = ((bd.y * cd.z).abs() + (bd.z * cd.y).abs()) * ad.x.abs()
        + ((cd.y * ad.z).abs() + (cd.z * ad.y).abs()) * bd.x.abs()
        + ((ad.y * bd.z).abs() + (ad.z * bd.y).abs()) * cd.x.abs();
    let eps = f64::EPSILON / 2.0;
    let bound = (7.0 + 56.0 * eps) * eps * permanent;
    if det > bound {
        1
    } else if det < -bound {
        -1
    } else {
        0
    }
}

/// Whether segment pq crosses triangle abc for certain: p and q strictly on opposite sides of
/// the triangle's plane, and the line through them strictly inside the triangle's three edges
/// (each sign exact, see [`orient_sign`]). Touching and configurations floating point cannot
/// decide (a segment in the triangle's plane) are left to the distance tests.
pub fn segment_crosses_triangle(p: &Vec3, q: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> bool {
    let (sp, sq) = (orient_sign(a, b, c, p), orient_sign(a, b, c, q));
    if sp * sq >= 0 {
        return false;
    }
    let s = [
        orient_sign(p, q, a, b),
        orient_sign(p, q, b, c),
        orient_sign(p, q, c, a),
    ];
    s[0] != 0 && s[0] == s[1] && s[1] == s[2]
}

#[cfg(test)]
mod tests;

/// The signed solid angle (sr) that triangle abc subtends at p (Van Oosterom & Strackee 1983),
/// positive when abc turns counter-clockwise seen from p; Σ over a closed, outward-oriented
/// surface /4π is its winding number about p: 1 inside, 0 outside.
pub fn solid_angle(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let numerator = a.dot(&b.cross(&c));
    let denominator = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
    2.0 * numerator.atan2(denominator)
}
