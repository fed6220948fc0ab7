//! The three steps of isosurface stuffing after the lattice is classified (Labelle & Shewchuk
//! 2007, §3): cut points on the edges whose ends lie on opposite sides of the surface, warping of
//! the lattice vertices that a cut point comes too close to, and the stencils that fill each
//! lattice tet's inside part with one to three tets.
//!
//! A quadrilateral face of a stencil (on a lattice face with two inside vertices and one outside)
//! is split by the diagonal from its deeper inside vertex (larger winding number, ties by vertex
//! id): both lattice tets sharing the face see the same three vertices and so split it the same
//! way, and a prism's three quadrilaterals never form the cyclic pattern that cannot be cut into
//! three tets.

use rayon::prelude::*;

use super::bvh::TriangleBvh;
use super::lattice::{DIRECTIONS, Lattice, is_axis};
use crate::math::Vec3;

/// Labelle & Shewchuk's warp thresholds for the uniform BCC lattice (their §5): a cut point
/// closer than this fraction of its edge to an end vertex snaps that vertex onto the surface.
/// These two values give the paper's proven dihedral bounds.
pub const ALPHA_LONG: f64 = 0.24744;
/// The threshold for the short (black–red, diagonal) edges.
pub const ALPHA_SHORT: f64 = 0.41189;

/// Bisection steps when a lattice edge does not cross the surface exactly once (a hole lets the
/// winding number change without a crossing; a fold crosses several times): 2⁻³⁰ of an edge.
const BISECTION_STEPS: usize = 30;

/// Where the surface cuts a lattice edge.
#[derive(Clone, Copy, Debug)]
pub struct Cut {
    /// Edge id (owner · 7 + direction).
    pub edge: usize,
    /// Fraction of the way from the owner to the other end.
    pub t: f64,
    /// The point.
    pub position: Vec3,
}

/// The side of the surface a lattice vertex is on after warping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Winding number ≥ ½.
    Inside,
    /// Snapped onto the surface.
    On,
    /// Winding number < ½.
    Outside,
}

/// The lattice and everything the stencils need from it.
pub struct Classified<'a> {
    /// The lattice.
    pub lattice: &'a Lattice,
    /// φ = w − ½ per lattice vertex (inside ≥ 0).
    pub phi: Vec<f64>,
    /// Side per lattice vertex.
    pub side: Vec<Side>,
    /// Current position per lattice vertex (warped ones moved onto the surface).
    pub position: Vec<Vec3>,
}

/// The cut point on the edge from `a` (φa) to `b` (φb), whose signs differ.
fn cut_parameter(bvh: &TriangleBvh, flip: f64, a: &Vec3, b: &Vec3, phi_a: f64) -> f64 {
    let inside_a = phi_a >= 0.0;
    let crossings = bvh.segment_crossings(a, b);
    if crossings.len() == 1 {
        return crossings[0];
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..BISECTION_STEPS {
        let inner: Vec<f64> = crossings
            .iter()
            .copied()
            .filter(|&s| s >= lo && s <= hi)
            .collect();
        if inner.len() == 1 {
            return inner[0];
        }
        let mid = 0.5 * (lo + hi);
        let w = flip * bvh.winding_number(&(a + (b - a) * mid));
        if (w >= 0.5) == inside_a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// All cut points, sorted by edge id (computed in parallel, in vertex order).
pub fn cut_points(lattice: &Lattice, phi: &[f64], bvh: &TriangleBvh, flip: f64) -> Vec<Cut> {
    let n = phi.len();
    let chunks: Vec<Vec<Cut>> = (0..n.div_ceil(1024))
        .into_par_iter()
        .map(|c| {
            let mut out = Vec::new();
            for v in c * 1024..((c + 1) * 1024).min(n) {
                for d in 0..DIRECTIONS.len() {
                    let Some(u) = lattice.neighbour(v, d) else {
                        continue;
                    };
                    if (phi[v] >= 0.0) == (phi[u] >= 0.0) {
                        continue;
                    }
                    let (a, b) = (lattice.position(v), lattice.position(u));
                    let t = cut_parameter(bvh, flip, &a, &b, phi[v]);
                    out.push(Cut {
                        edge: v * 7 + d,
                        t,
                        position: a + (b - a) * t,
                    });
                }
            }
            out
        })
        .collect();
    chunks.concat()
}

/// Snap every lattice vertex that a cut point violates (closer than α of the edge) onto the
/// nearest violating cut point; returns the number of warped vertices.
pub fn warp(classified: &mut Classified<'_>, cuts: &[Cut]) -> usize {
    let lattice = classified.lattice;
    let n = classified.phi.len();
    // Best violating cut per vertex: (distance, cut index); ties go to the lower cut index.
    let mut best: Vec<Option<(f64, usize)>> = vec![None; n];
    let h = lattice.spacing;
    for (i, cut) in cuts.iter().enumerate() {
        let (owner, d) = (cut.edge / 7, cut.edge % 7);
        let Some(other) = lattice.neighbour(owner, d) else {
            continue;
        };
        let (alpha, length) = if is_axis(d) {
            (ALPHA_LONG, h)
        } else {
            (ALPHA_SHORT, h * 3f64.sqrt() / 2.0)
        };
        for (v, frac) in [(owner, cut.t), (other, 1.0 - cut.t)] {
            if frac < alpha {
                let dist = frac * length;
                if best[v].is_none_or(|(bd, _)| dist < bd) {
                    best[v] = Some((dist, i));
                }
            }
        }
    }
    let mut warped = 0;
    for (v, b) in best.iter().enumerate() {
        if let Some((_, i)) = b {
            classified.position[v] = cuts[*i].position;
            classified.side[v] = Side::On;
            warped += 1;
        }
    }
    warped
}

/// A vertex of the output before renumbering: a lattice vertex or a surviving cut point.
pub type Key = usize;

/// The surviving cut points (both edge ends still off the surface), as keys: lattice vertex
/// count + index in the returned list.
pub fn surviving(classified: &Classified<'_>, cuts: &[Cut]) -> Vec<Cut> {
    cuts.iter()
        .filter(|c| {
            let owner = c.edge / 7;
            let other = classified.lattice.neighbour(owner, c.edge % 7);
            classified.side[owner] != Side::On
                && other.is_some_and(|o| classified.side[o] != Side::On)
        })
        .copied()
        .collect()
}

/// The output tets (as keys) of every lattice tet, in face order; the winding-number test
/// decides the tets whose four vertices all lie on the surface.
pub fn fill(
    classified: &Classified<'_>,
    cuts: &[Cut],
    bvh: &TriangleBvh,
    flip: f64,
) -> Vec<[Key; 4]> {
    let lattice = classified.lattice;
    let faces = lattice.interior_face_count();
    let n = classified.phi.len();
    let cut_key = |a: usize, b: usize| -> Key {
        let edge = lattice.edge_id(a, b).unwrap_or(usize::MAX);
        match cuts.binary_search_by_key(&edge, |c| c.edge) {
            Ok(i) => n + i,
            Err(_) => usize::MAX,
        }
    };
    let chunks: Vec<Vec<[Key; 4]>> = (0..faces.div_ceil(512))
        .into_par_iter()
        .map(|c| {
            let mut out = Vec::new();
            for f in c * 512..((c + 1) * 512).min(faces) {
                for tet in lattice.face_tets(f) {
                    stencil(classified, tet, &cut_key, bvh, flip, &mut out);
                }
            }
            out
        })
        .collect();
    chunks.concat()
}

/// The inside part of one lattice tet (see the module doc for the diagonal rule).
fn stencil(
    classified: &Classified<'_>,
    tet: [usize; 4],
    cut: &impl Fn(usize, usize) -> Key,
    bvh: &TriangleBvh,
    flip: f64,
    out: &mut Vec<[Key; 4]>,
) {
    let side = |v: usize| classified.side[v];
    if tet.iter().all(|&v| side(v) != Side::Inside) {
        if tet.iter().all(|&v| side(v) == Side::On) {
            let centre = tet
                .iter()
                .fold(Vec3::zeros(), |s, &v| s + classified.position[v])
                / 4.0;
            if flip * bvh.winding_number(&centre) >= 0.5 {
                out.push(tet);
            }
        }
        return;
    }
    let sign = |v: usize| match side(v) {
        Side::Inside => 1,
        Side::On => 0,
        Side::Outside => -1,
    };
    // Ascending by (side, φ, id): outside first, deepest inside last.
    let mut s = tet;
    s.sort_by(|&x, &y| {
        sign(x)
            .cmp(&sign(y))
            .then(classified.phi[x].total_cmp(&classified.phi[y]))
            .then(x.cmp(&y))
    });
    let [a, b, c, d] = s;
    match (sign(a), sign(b), sign(c)) {
        (sa, _, _) if sa >= 0 => out.push(tet),
        (_, -1, -1) => out.push([d, cut(a, d), cut(b, d), cut(c, d)]),
        (_, -1, 0) => out.push([d, c, cut(a, d), cut(b, d)]),
        (_, 0, 0) => out.push([d, b, c, cut(a, d)]),
        (_, -1, _) => {
            // Two inside (c, d), two outside (a, b): a prism.
            let (ac, ad, bc, bd) = (cut(a, c), cut(a, d), cut(b, c), cut(b, d));
            out.push([ac, bc, c, d]);
            out.push([ac, bd, bc, d]);
            out.push([ac, ad, bd, d]);
        }
        (_, 0, _) => {
            // b on the surface, c and d inside: a pyramid with apex b.
            let (ac, ad) = (cut(a, c), cut(a, d));
            out.push([ac, b, c, d]);
            out.push([ad, b, ac, d]);
        }
        _ => {
            // Three inside: the tet minus the corner at a, a prism.
            let (ab, ac, ad) = (cut(a, b), cut(a, c), cut(a, d));
            out.push([ab, b, c, d]);
            out.push([c, ab, ac, d]);
            out.push([d, ab, ac, ad]);
        }
    }
}
