//! From a triangle surface to a tet mesh of the solid it bounds: isosurface stuffing (Labelle &
//! Shewchuk 2007, "Isosurface Stuffing: Fast Tetrahedral Meshes with Good Dihedral Angles") on a
//! uniform body-centred cubic lattice of spacing h.
//!
//! 1. Every lattice vertex is classified inside or outside by the surface's generalized winding
//!    number w (Jacobson et al. 2013) with w ≥ ½ inside, evaluated fast with a tree and far-field
//!    dipoles (Barill et al. 2018). Winding numbers tolerate small holes and self-intersections,
//!    and do not care about the surface's orientation (an inward-facing surface is flipped).
//! 2. Each lattice edge with ends on opposite sides gets a cut point where it crosses the surface.
//! 3. A lattice vertex closer to a cut point than α of that edge (α = 0.24744 on axis edges,
//!    0.41189 on diagonal ones, the paper's uniform-lattice values) is moved onto it.
//! 4. Each lattice tet's inside part is filled by one of the paper's stencils (1 to 3 tets).
//!
//! The mesh's boundary approximates the surface to within about h; features thinner than about
//! h are lost (no grading). Output is the same bytes on any number of threads: every parallel
//! pass writes per-chunk lists that are joined in order.

pub mod bvh;
mod lattice;
pub mod measure;
mod stencil;

use std::path::Path;

use rayon::prelude::*;

use self::bvh::TriangleBvh;
use self::lattice::Lattice;
use self::stencil::{Classified, Side};
use super::TetMesh;
use crate::error::Error;
use crate::io::obj::TriangleSurface;
use crate::math::Vec3;

/// Inputs of [`tetrahedralize`].
#[derive(Clone, Debug, PartialEq)]
pub struct StuffParams {
    /// Lattice spacing h, m (the length of the lattice's axis edges; tets have edges of about
    /// 0.87 h to h inside and shorter ones at the boundary). No default: must be positive.
    pub size: f64,
    /// Smallest accepted closure of the surface, 0..1 (default 0.8): the area-weighted mean of
    /// |w₋ + w₊| just either side of each triangle, 1 for a closed surface and 0 for an open
    /// sheet. Small holes lower it a little; a surface below it is refused as too open.
    pub min_closure: f64,
    /// Refuse when the estimated memory exceeds this many bytes (default None: the memory the
    /// system has available, when known).
    pub memory_limit: Option<f64>,
}

impl Default for StuffParams {
    fn default() -> Self {
        StuffParams {
            size: 0.0,
            min_closure: 0.8,
            memory_limit: None,
        }
    }
}

impl StuffParams {
    /// Default parameters at lattice spacing `size`.
    pub fn with_size(size: f64) -> Self {
        StuffParams {
            size,
            ..Default::default()
        }
    }
}

/// What [`tetrahedralize`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StuffInfo {
    /// Lattice vertices classified.
    pub lattice_vertices: usize,
    /// Lattice vertices inside the surface.
    pub inside_vertices: usize,
    /// Cut points computed (before warping).
    pub cut_points: usize,
    /// Lattice vertices moved onto the surface.
    pub warped: usize,
    /// The surface's closure (see [`StuffParams::min_closure`]).
    pub closure: f64,
    /// Whether the surface faced inward and was read with its orientation reversed.
    pub flipped: bool,
    /// The estimate made before meshing (tets, bytes).
    pub estimate: Estimate,
}

/// The up-front size estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// Lattice vertices to classify.
    pub lattice_vertices: f64,
    /// Tets expected.
    pub tets: f64,
    /// Peak bytes expected while meshing.
    pub bytes: f64,
}

/// Why a surface cannot be meshed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StuffError {
    /// The size is zero, negative or not a number.
    #[error("size must be a positive length, got {size}")]
    NonPositiveSize {
        /// The size given.
        size: f64,
    },
    /// The surface has no triangle of non-zero area.
    #[error("the surface has no triangle of non-zero area")]
    NoTriangles,
    /// A face names a vertex that does not exist, or a vertex is not finite.
    #[error("{0}")]
    BadSurface(String),
    /// The surface bounds no solid: winding numbers beside it stay far from 1.
    #[error(
        "the surface is too open to bound a solid: its closure is {closure:.3} (1 for a closed \
         surface, 0 for an open sheet; at least {tolerance} needed). Close its holes, or lower \
         the tolerance"
    )]
    TooOpen {
        /// The measured closure.
        closure: f64,
        /// The tolerance.
        tolerance: f64,
    },
    /// No lattice vertex falls inside at this size.
    #[error(
        "no lattice point lies inside the surface at size {size}: the solid is thinner than \
         the lattice; try a size below {suggestion:.3e}"
    )]
    EmptyInside {
        /// The size given.
        size: f64,
        /// A size that would put lattice points inside (a quarter of the thinnest extent).
        suggestion: f64,
    },
    /// The mesh would not fit in memory.
    #[error(
        "size {size} would make about {tets:.3e} tets over {lattice:.3e} lattice points, \
         needing about {need} of memory while meshing, but {have} is available; use a larger size"
    )]
    TooLarge {
        /// The size given.
        size: f64,
        /// Estimated tets.
        tets: f64,
        /// Estimated lattice vertices.
        lattice: f64,
        /// Estimated bytes, in words.
        need: String,
        /// Available bytes, in words.
        have: String,
    },
}

impl StuffError {
    /// As a crate error: size problems name the parameter `key`, surface problems the file.
    pub fn into_error(self, surface: Option<&Path>, key: &str) -> Error {
        match (&self, surface) {
            (
                StuffError::NonPositiveSize { .. }
                | StuffError::EmptyInside { .. }
                | StuffError::TooLarge { .. },
                _,
            )
            | (_, None) => Error::parameter(key, self.to_string()),
            (_, Some(path)) => Error::parse(path, None, self.to_string()),
        }
    }
}

/// Bytes per lattice vertex while meshing: φ (8), side (1), position (24), cut bookkeeping.
const BYTES_PER_LATTICE_VERTEX: f64 = 48.0;
/// Bytes per output tet while meshing: keys (32), the final tets (32), positions and slack.
const BYTES_PER_TET: f64 = 120.0;

/// The size of the job before any of it is done: lattice vertices over the surface's bounding
/// box; tets from the enclosed volume (12 lattice tets per h³, plus a boundary layer of
/// thickness h/2 where stencils split tets).
pub fn estimate(surface: &TriangleSurface, size: f64) -> Estimate {
    let (min, max) = bounds(&surface.positions);
    let extent = max - min;
    let cells = [0, 1, 2].map(|k| (extent[k] / size).ceil().max(1.0) + 2.0);
    let lattice_vertices =
        (cells[0] + 1.0) * (cells[1] + 1.0) * (cells[2] + 1.0) + cells[0] * cells[1] * cells[2];
    let volume = measure::enclosed_volume(surface).abs();
    let area = measure::surface_area(surface);
    let tets = 12.0 * (volume + 0.5 * area * size) / size.powi(3);
    Estimate {
        lattice_vertices,
        tets,
        bytes: lattice_vertices * BYTES_PER_LATTICE_VERTEX + tets * BYTES_PER_TET,
    }
}

fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold(
        (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    )
}

fn check_surface(surface: &TriangleSurface) -> Result<Vec<[Vec3; 3]>, StuffError> {
    let n = surface.positions.len();
    if let Some(v) = surface
        .positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(StuffError::BadSurface(format!(
            "vertex {} has a non-finite coordinate",
            v + 1
        )));
    }
    if let Some(f) = surface.faces.iter().position(|f| f.iter().any(|&v| v >= n)) {
        return Err(StuffError::BadSurface(format!(
            "face {} names a vertex beyond the {n} vertices",
            f + 1
        )));
    }
    let triangles: Vec<[Vec3; 3]> = surface
        .faces
        .iter()
        .map(|f| f.map(|v| surface.positions[v]))
        .filter(|t| (t[1] - t[0]).cross(&(t[2] - t[0])).norm() > 0.0)
        .collect();
    if triangles.is_empty() {
        return Err(StuffError::NoTriangles);
    }
    Ok(triangles)
}

/// The closure of the surface and whether it faces inward: winding numbers just either side of
/// up to 4096 triangles (an even stride over the list, so the same ones on every run).
fn closure(bvh: &TriangleBvh, diagonal: f64) -> (f64, bool) {
    let triangles = bvh.triangles();
    let stride = triangles.len().div_ceil(4096).max(1);
    let eps = 1e-7 * diagonal;
    let samples: Vec<(f64, f64)> = (0..triangles.len())
        .step_by(stride)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&i| {
            let t = &triangles[i];
            let m = (t[1] - t[0]).cross(&(t[2] - t[0]));
            let area = 0.5 * m.norm();
            let n = m / m.norm();
            let c = (t[0] + t[1] + t[2]) / 3.0;
            let sum = bvh.winding_number(&(c - n * eps)) + bvh.winding_number(&(c + n * eps));
            (area, sum)
        })
        .collect();
    let total: f64 = samples.iter().map(|s| s.0).sum();
    let closed: f64 = samples.iter().map(|s| s.0 * s.1.abs().min(1.0)).sum();
    let signed: f64 = samples.iter().map(|s| s.0 * s.1).sum();
    (closed / total, signed < 0.0)
}

/// Tet mesh of the solid `surface` bounds (see the module doc). Tets are positively oriented;
/// vertices are numbered lattice vertices first (in lattice order), then surface points.
pub fn tetrahedralize(
    surface: &TriangleSurface,
    params: &StuffParams,
) -> Result<(TetMesh, StuffInfo), StuffError> {
    let h = params.size;
    if !(h.is_finite() && h > 0.0) {
        return Err(StuffError::NonPositiveSize { size: h });
    }
    let triangles = check_surface(surface)?;
    let estimate = estimate(surface, h);
    let limit = params
        .memory_limit
        .or_else(crate::resources::available_memory);
    if let Some(have) = limit
        && (estimate.bytes > have || !estimate.bytes.is_finite())
    {
        return Err(StuffError::TooLarge {
            size: h,
            tets: estimate.tets,
            lattice: estimate.lattice_vertices,
            need: crate::resources::bytes(estimate.bytes),
            have: crate::resources::bytes(have),
        });
    }
    let (min, max) = bounds(&surface.positions);
    let bvh = TriangleBvh::new(triangles);
    let (closure, flipped) = closure(&bvh, (max - min).norm());
    if closure < params.min_closure {
        return Err(StuffError::TooOpen {
            closure,
            tolerance: params.min_closure,
        });
    }
    let flip = if flipped { -1.0 } else { 1.0 };
    let lattice = Lattice::covering(&min, &max, h);
    let n = lattice.vertex_count();
    let phi: Vec<f64> = (0..n)
        .into_par_iter()
        .with_min_len(256)
        .map(|v| flip * bvh.winding_number(&lattice.position(v)) - 0.5)
        .collect();
    let inside_vertices = phi.iter().filter(|&&p| p >= 0.0).count();
    let empty = || StuffError::EmptyInside {
        size: h,
        suggestion: (max - min).min() / 4.0,
    };
    if inside_vertices == 0 {
        return Err(empty());
    }
    let cuts = stencil::cut_points(&lattice, &phi, &bvh, flip);
    let mut classified = Classified {
        lattice: &lattice,
        side: phi
            .iter()
            .map(|&p| {
                if p >= 0.0 {
                    Side::Inside
                } else {
                    Side::Outside
                }
            })
            .collect(),
        position: (0..n).map(|v| lattice.position(v)).collect(),
        phi,
    };
    let warped = stencil::warp(&mut classified, &cuts);
    let kept = stencil::surviving(&classified, &cuts);
    let keyed = stencil::fill(&classified, &kept, &bvh, flip);
    if keyed.is_empty() {
        return Err(empty());
    }
    let mesh = compact(&classified, &kept, keyed);
    let info = StuffInfo {
        lattice_vertices: n,
        inside_vertices,
        cut_points: cuts.len(),
        warped,
        closure,
        flipped,
        estimate,
    };
    Ok((mesh, info))
}

/// Number the used vertices in key order and orient every tet by its reference geometry (lattice
/// vertices at their unwarped places, where every stencil tet is positive), so that warping
/// can never hide an inversion behind a swap.
fn compact(
    classified: &Classified<'_>,
    cuts: &[stencil::Cut],
    mut keyed: Vec<[usize; 4]>,
) -> TetMesh {
    let n = classified.phi.len();
    let total = n + cuts.len();
    // Every cut a stencil asks for survives warping (both its ends are off the surface); a
    // missing one would be a bug, and is dropped rather than indexed.
    keyed.retain(|t| t.iter().all(|&k| k < total));
    let mut index = vec![usize::MAX; total];
    for t in &keyed {
        for &k in t {
            index[k] = 0;
        }
    }
    let mut positions = Vec::new();
    let mut reference = Vec::new();
    for (k, slot) in index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = positions.len();
            if k < n {
                positions.push(classified.position[k]);
                reference.push(classified.lattice.position(k));
            } else {
                positions.push(cuts[k - n].position);
                reference.push(cuts[k - n].position);
            }
        }
    }
    let tets: Vec<[usize; 4]> = keyed
        .par_iter()
        .map(|t| {
            let mut tet = t.map(|k| index[k]);
            let p = tet.map(|v| reference[v]);
            if (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0])) < 0.0 {
                tet.swap(1, 2);
            }
            tet
        })
        .collect();
    TetMesh::new(positions, tets)
}
