//! Quadratic (10-node) tets: shape functions, the quadrature rule and the per-point kernels.
//!
//! F is linear over a straight-sided quadratic tet, so the integrand of the linearised
//! stiffness is quadratic: the 4-point rule of degree 2 integrates it exactly (no spurious
//! zero-energy mode: 4 points × 6 strains ≥ 30 − 6 rigid modes), as Abaqus' C3D10 does. Each
//! quadrature point is evaluated like a linear tet (the same materials, SVD lanes and
//! definiteness fix, per point) with F = Σₐ xₐ ⊗ Gₐ over the ten nodes. Elements are
//! isoparametric: the rest gradients Gₐ come from the rest positions of all ten nodes, so curved
//! elements from Gmsh are integrated on their own shape.
//!
//! The lumped mass is the row-sum-free "HRZ" lumping of the consistent mass (its diagonal
//! scaled to the element's mass): 1/36 of the element's mass at each corner and 4/27 at each
//! mid-edge node. Row sums would give the corners negative masses (−1/20); HRZ keeps every mass
//! positive and the element's centre of mass where it is.

use super::*;
use crate::mesh::quadratic::EDGES;

/// Quadrature points per quadratic tet.
pub const POINTS: usize = 4;

/// The 4-point rule of degree 2: barycentric coordinates (a, b, b, b) and permutations with
/// a = (5 + 3√5)/20 and b = (5 − √5)/20, equal weights.
const RULE_A: f64 = 0.585_410_196_624_968_5;
const RULE_B: f64 = 0.138_196_601_125_010_5;

/// Mass fractions of a quadratic tet (HRZ lumping): a corner's and a mid-edge node's.
pub const CORNER_MASS: f64 = 1.0 / 36.0;
/// See [`CORNER_MASS`].
pub const EDGE_MASS: f64 = 4.0 / 27.0;

/// A force (or force-differential) contribution of one quadratic tet to its nodes 1–9 (node 0
/// gets minus their sum: the shape gradients sum to zero).
pub(super) type Slot10 = [Vec3; 9];

/// The barycentric coordinates of the quadrature points.
pub fn quadrature_points() -> [[f64; 4]; POINTS] {
    let (a, b) = (RULE_A, RULE_B);
    [[a, b, b, b], [b, a, b, b], [b, b, a, b], [b, b, b, a]]
}

/// The ten shape functions at barycentric coordinates `l` (corners λᵢ(2λᵢ − 1), then 4λᵢλⱼ on
/// each edge of [`EDGES`]).
pub fn shape_values(l: [f64; 4]) -> [f64; 10] {
    let mut n = [0.0; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
    }
    for (k, [i, j]) in EDGES.iter().enumerate() {
        n[4 + k] = 4.0 * l[*i] * l[*j];
    }
    n
}

/// The gradients of the ten shape functions with respect to the reference coordinates
/// ξ = (λ₁, λ₂, λ₃) (λ₀ = 1 − ξ₁ − ξ₂ − ξ₃) at barycentric coordinates `l`.
pub fn reference_gradients(l: [f64; 4]) -> [Vec3; 10] {
    let dl = [
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    let mut g = [Vec3::zeros(); 10];
    for i in 0..4 {
        g[i] = dl[i] * (4.0 * l[i] - 1.0);
    }
    for (k, [i, j]) in EDGES.iter().enumerate() {
        g[4 + k] = (dl[*i] * l[*j] + dl[*j] * l[*i]) * 4.0;
    }
    g
}

/// The rest data of a body's quadratic tets: nodes, and per quadrature point the rest
/// gradients of the shape functions and the point's share of the volume.
#[derive(Clone, Debug)]
pub struct QuadraticElements {
    /// Each tet's ten nodes.
    pub(super) nodes: Vec<[usize; 10]>,
    /// Per point (tet t's are 4t … 4t + 3): ∇Gₐ at rest, so that F = Σₐ xₐ ⊗ Gₐ.
    pub(super) grads: Vec<[Vec3; 10]>,
    /// Per point: its weight times |det J| (the rest volume it stands for), m³.
    pub(super) weights: Vec<f64>,
    /// Node → incident (tet, node) slots, slot = 10·t + node.
    pub(super) incidence: Incidence,
}

impl QuadraticElements {
    /// The rest data of `mesh`'s quadratic tets, or the tets (indices) whose shape is folded
    /// or flat at a quadrature point (det J of the rest map not of one sign, or negligible
    /// against its straight-sided volume).
    pub fn new(mesh: &TetMesh) -> std::result::Result<Self, Vec<usize>> {
        let reference: Vec<[Vec3; 10]> = quadrature_points()
            .iter()
            .map(|&l| reference_gradients(l))
            .collect();
        let nodes: Vec<[usize; 10]> = (0..mesh.tets.len())
            .map(|t| mesh.quadratic_nodes(t))
            .collect();
        let mut grads = Vec::with_capacity(POINTS * nodes.len());
        let mut weights = Vec::with_capacity(POINTS * nodes.len());
        let mut bad = Vec::new();
        for (t, n) in nodes.iter().enumerate() {
            let straight = mesh.signed_volume(t);
            let mut sound = true;
            for g in &reference {
                let mut j = Mat3::zeros();
                for a in 0..10 {
                    j += mesh.positions[n[a]] * g[a].transpose();
                }
                let det = j.determinant();
                // det J is 6 × the local volume scale; it must keep the corners' sign.
                sound &= det * straight.signum() > 1e-3 * 6.0 * straight.abs();
                let inv_t = j.try_inverse().unwrap_or_else(Mat3::zeros).transpose();
                grads.push(g.map(|ga| inv_t * ga));
                weights.push(det.abs() / (6.0 * POINTS as f64));
            }
            if !sound {
                bad.push(t);
            }
        }
        if !bad.is_empty() {
            return Err(bad);
        }
        let incidence = Incidence::new(mesh.positions.len(), &nodes);
        Ok(QuadraticElements {
            nodes,
            grads,
            weights,
            incidence,
        })
    }

    /// Rest volume of tet t (the sum of its points' weights), m³.
    pub fn volume(&self, t: usize) -> f64 {
        self.weights[POINTS * t..POINTS * (t + 1)].iter().sum()
    }

    /// F at quadrature point p (of tet p / 4) at positions x.
    #[inline]
    pub fn deformation_gradient(&self, x: &[Vec3], p: usize) -> Mat3 {
        let (n, g) = (&self.nodes[p / POINTS], &self.grads[p]);
        let mut f = Mat3::zeros();
        for a in 0..10 {
            f += x[n[a]] * g[a].transpose();
        }
        f
    }

    /// `slot += −w·P·Gₐ` for nodes 1–9 of point p: its forces from its stress P (with dP in
    /// place of P and the sign flipped by the caller, the force differential).
    #[inline]
    pub(super) fn add_point_forces(&self, p: usize, stress: &Mat3, slot: &mut Slot10) {
        let h = -self.weights[p] * stress;
        let g = &self.grads[p];
        for a in 1..10 {
            slot[a - 1] += h * g[a];
        }
    }

    /// `out[v] (+)= Σ` of v's slots in `buffer`, in slot order (node 0's is minus the others').
    pub(super) fn gather(&self, buffer: &[Slot10], out: &mut [Vec3], accumulate: bool) {
        let inc = &self.incidence;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(v, o)| {
                let range = inc.offsets[v] as usize..inc.offsets[v + 1] as usize;
                let mut sum = if accumulate { *o } else { Vec3::zeros() };
                for &slot in &inc.slots[range] {
                    let s = &buffer[slot as usize / 10];
                    sum += match slot % 10 {
                        0 => -s.iter().fold(Vec3::zeros(), |acc, f| acc + f),
                        a => s[a as usize - 1],
                    };
                }
                *o = sum;
            });
    }

    /// The upper blocks (a ≤ b, row-major) of tet t's 30×30 stiffness,
    /// `K[(a,i),(b,j)] = Σ_q w_q ⟨∂P/∂F : (eⱼ ⊗ G_b), eᵢ ⊗ Gₐ⟩`, from its points' tangents.
    pub(super) fn element_stiffness(&self, t: usize, tangents: &[Tangent]) -> [Mat3; 55] {
        let mut blocks = [Mat3::zeros(); 55];
        for q in 0..POINTS {
            let p = POINTS * t + q;
            let (g, w) = (&self.grads[p], self.weights[p]);
            for b in 0..10 {
                for j in 0..3 {
                    let mut df = Mat3::zeros();
                    df.set_row(j, &g[b].transpose());
                    let dp = w * tangents[p].apply(&df);
                    for a in 0..=b {
                        let column = dp * g[a];
                        let k = upper_index10(a, b);
                        let block = &mut blocks[k];
                        block.set_column(j, &(block.column(j) + column));
                    }
                }
            }
        }
        blocks
    }
}

/// Index of block (a, b), a ≤ b, in [`QuadraticElements::element_stiffness`]'s output.
#[inline]
pub(super) fn upper_index10(a: usize, b: usize) -> usize {
    // Row r of the upper triangle holds 10 − r blocks.
    10 * a - a * a.saturating_sub(1) / 2 + (b - a)
}
