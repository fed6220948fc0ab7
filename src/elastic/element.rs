//! One tet's kernels: its forces from a stress, its 12×12 stiffness from a tangent, the von
//! Mises equivalent of its stress.

// Kernels index small fixed arrays (corners, components) by position: clearer than iterators.
#![allow(clippy::needless_range_loop)]

use super::TetVectors;
use crate::material::Tangent;
use crate::math::{Mat3, Vec3};

/// The gradient vectors bₐ of a tet's four barycentric coordinates (dF = Σₐ dxₐ ⊗ bₐ):
/// b₁..b₃ are the rows of Bm, b₀ = −(b₁ + b₂ + b₃).
#[inline]
pub fn corner_gradients(bm: &Mat3) -> [Vec3; 4] {
    let (r0, r1, r2) = (
        bm.row(0).transpose(),
        bm.row(1).transpose(),
        bm.row(2).transpose(),
    );
    [-(r0 + r1 + r2), r0, r1, r2]
}

/// The upper blocks (a ≤ b, row-major: (0,0), (0,1), …, (3,3)) of one tet's 12×12 stiffness
/// `K_e[(a,i),(b,j)] = W·⟨∂P/∂F : (eⱼ ⊗ b_b), eᵢ ⊗ bₐ⟩`, from its tangent.
///
/// Computed in the tangent's diagonal space as a Gram form: the unit displacement (a, i) is
/// dF̂ = uᵢ cₐᵀ there (uᵢ = row i of U, cₐ = Vᵀbₐ); its coordinates z = (diagonal of dF̂, the
/// symmetric and the antisymmetric combination of each off-diagonal pair) make
/// `K_e = W·Zᵀ D Z` with D = diag(∂²Ψ̂/∂σ², sym/2, skew/2). About half the work of applying the
/// tangent to twelve unit dF. Only corners 1–3 take the Gram form: corner 0's gradient is minus
/// the sum of theirs, so its blocks are sums, `K₀ᵦ = −Σₐ Kₐᵦ` and `K₀₀ = −Σᵦ K₀ᵦ` (made exactly
/// symmetric), 6 Gram blocks instead of 10.
pub fn element_stiffness(tangent: &Tangent, bm: &Mat3, w: f64) -> [Mat3; 10] {
    let grads = corner_gradients(bm);
    let vt = tangent.v.transpose();
    // Row 3(a − 1) + i of z, column 3(a − 1) + i of dzᵀ: the unit displacement (a, i) of
    // corner a = 1, 2, 3.
    let mut z = [[0.0f64; 9]; 9];
    let mut dzt = [[0.0f64; 9]; 9];
    for (a, g) in grads[1..].iter().enumerate() {
        let c = vt * g;
        for i in 0..3 {
            let u = tangent.u.row(i);
            let d = &mut z[3 * a + i];
            for l in 0..3 {
                d[l] = u[l] * c[l];
            }
            for (n, &(k, l)) in crate::material::isotropic::PAIRS.iter().enumerate() {
                let (x, y) = (u[k] * c[l], u[l] * c[k]);
                d[3 + n] = x + y;
                d[6 + n] = x - y;
            }
            let hd = tangent.diag * Vec3::new(d[0], d[1], d[2]);
            let col = 3 * a + i;
            for m in 0..3 {
                dzt[m][col] = hd[m];
            }
            for n in 0..3 {
                dzt[3 + n][col] = 0.5 * tangent.pair_sym[n] * z[col][3 + n];
                dzt[6 + n][col] = 0.5 * tangent.pair_skew[n] * z[col][6 + n];
            }
        }
    }
    // Z·Dᵀ…: row r of the 9×9 Gram matrix as a sum of rows of dzᵀ, each a multiply-add over
    // the row's columns (vectorised; a dot product per entry is not), summed over m in order.
    // Only the blocks at or right of the diagonal are used: block row a from column 3(a − 1).
    let mut gram = [[0.0f64; 9]; 9];
    for r in 0..9 {
        match r / 3 {
            0 => gram_row::<9>(&mut gram[r], &z[r], &dzt),
            1 => gram_row::<6>(&mut gram[r], &z[r], &dzt),
            _ => gram_row::<3>(&mut gram[r], &z[r], &dzt),
        }
    }
    // Blocks (a, b), 1 ≤ a ≤ b ≤ 3.
    let gram =
        |a: usize, b: usize| Mat3::from_fn(|i, j| w * gram[3 * (a - 1) + i][3 * (b - 1) + j]);
    let (k11, k12, k13) = (gram(1, 1), gram(1, 2), gram(1, 3));
    let (k22, k23, k33) = (gram(2, 2), gram(2, 3), gram(3, 3));
    let k01 = -(k11 + k12.transpose() + k13.transpose());
    let k02 = -(k12 + k22 + k23.transpose());
    let k03 = -(k13 + k23 + k33);
    let k00 = -(k01 + k02 + k03);
    let k00 = 0.5 * (k00 + k00.transpose());
    [k00, k01, k02, k03, k11, k12, k13, k22, k23, k33]
}

/// The last `W` entries of a Gram row: `row += Σₘ zᵣₘ·(dzᵀ)ₘ` over them, in m's order (a width
/// known at compile time, so the multiply-adds vectorise).
#[inline(always)]
fn gram_row<const W: usize>(row: &mut [f64; 9], z: &[f64; 9], dzt: &[[f64; 9]; 9]) {
    let row: &mut [f64; W] = (&mut row[9 - W..]).try_into().expect("W ≤ 9");
    for (&s, dm) in z.iter().zip(dzt) {
        let dm: &[f64; W] = dm[9 - W..].try_into().expect("W ≤ 9");
        for (g, &d) in row.iter_mut().zip(dm) {
            *g += s * d;
        }
    }
}

/// Index of block (a, b), a ≤ b, in [`element_stiffness`]'s output.
#[inline]
pub(super) fn upper_index(a: usize, b: usize) -> usize {
    // Rows of the upper triangle hold 4, 3, 2, 1 blocks.
    [0, 4, 7, 9][a] + b - a
}

/// Below this J, [`von_mises`] divides by it instead of J: a crushed or inverted tet shows a
/// large but finite stress rather than one that swamps every colour range or changes sign.
pub const VON_MISES_MIN_J: f64 = 0.05;

/// The von Mises equivalent (Pa) of the Cauchy stress σ = P·Fᵀ/J: with the deviator
/// s = σ − tr(σ)/3·I, σ_vM = √(3/2 s:s). J is floored at [`VON_MISES_MIN_J`].
pub fn von_mises(p: &Mat3, f: &Mat3) -> f64 {
    let j = f.determinant().max(VON_MISES_MIN_J);
    let sigma = p * f.transpose() / j;
    let s = sigma - Mat3::identity() * (sigma.trace() / 3.0);
    (1.5 * s.norm_squared()).sqrt()
}

/// The elastic forces of one tet from its stress: `H = −W·P·Bmᵀ`, columns on vertices 1–3,
/// minus their sum on vertex 0. With `dP` in place of P it is the force differential.
#[inline]
pub fn tet_forces(p: &Mat3, bm: &Mat3, w: f64) -> TetVectors {
    let h = -w * p * bm.transpose();
    let (f1, f2, f3) = (
        h.column(0).into_owned(),
        h.column(1).into_owned(),
        h.column(2).into_owned(),
    );
    [-(f1 + f2 + f3), f1, f2, f3]
}
