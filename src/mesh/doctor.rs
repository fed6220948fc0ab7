//! The mesh doctor: everything worth knowing about a tet mesh before simulating it, run on every
//! load and by `tetsim mesh check`.
//!
//! [`diagnose`] measures counts, bounding box and volume, orientation, degenerate tets (by
//! volume, as [`TetMesh::degenerate_tets`]) and slivers (by dihedral angle), a quality histogram
//! (dihedral angles, aspect ratio), connected pieces, duplicate vertices and tets, faces shared by
//! more than two tets, whether the boundary surface is closed, its Euler characteristic, and a
//! time step for the default material. [`Diagnosis::problems`] grades the findings: an
//! [`Severity::Error`] makes loading refuse the mesh unless forced.

use std::fmt;

use rayon::prelude::*;

use super::TetMesh;
use crate::error::MeshProblem;
use crate::material::Lame;
use crate::math::Vec3;

/// A tet whose smallest dihedral angle is below this (degrees) is a sliver. Gmsh and TetGen
/// meshes of reasonable quality stay above ~10°; below 1° the element stiffness has a condition
/// number above ~1e4 and CG slows down markedly.
pub const SLIVER_ANGLE_DEGREES: f64 = 1.0;

/// Vertices closer than this fraction of the bounding-box diagonal are duplicates. Far below any
/// meaningful mesh size, far above round-off of coordinates written with 8+ digits.
pub const DUPLICATE_RELATIVE_DISTANCE: f64 = 1e-10;

/// Edges of the minimum-dihedral-angle histogram, in degrees (70.53° is a regular tet's angle,
/// the largest possible minimum).
pub const ANGLE_BINS: [f64; 9] = [0.0, 1.0, 5.0, 10.0, 20.0, 30.0, 40.0, 50.0, 70.53];

/// The material the suggested time step is computed for: the scene defaults of SPEC §10.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DoctorParams {
    /// Young's modulus E in Pa. Default 1e5 (the scene default).
    pub youngs_modulus: f64,
    /// Poisson ratio ν. Default 0.3.
    pub poisson_ratio: f64,
    /// Density ρ in kg/m³. Default 1000.
    pub density: f64,
}

impl Default for DoctorParams {
    fn default() -> Self {
        DoctorParams {
            youngs_modulus: 1e5,
            poisson_ratio: 0.3,
            density: 1000.0,
        }
    }
}

/// How serious a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// Worth knowing; the run goes on.
    Warning,
    /// The mesh is refused unless forced (`--force`).
    Error,
}

/// Smallest, largest and mean of a per-tet measure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Mean value.
    pub mean: f64,
}

impl Summary {
    fn of(values: impl Iterator<Item = f64>) -> Summary {
        let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
        for v in values {
            min = min.min(v);
            max = max.max(v);
            sum += v;
            n += 1;
        }
        if n == 0 {
            return Summary::default();
        }
        Summary {
            min,
            max,
            mean: sum / n as f64,
        }
    }
}

/// The doctor's findings. Tet and vertex lists hold 0-based indices into the mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnosis {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of tets.
    pub tets: usize,
    /// Number of named groups.
    pub groups: usize,
    /// Axis-aligned bounding box (min, max), m.
    pub bounding_box: (Vec3, Vec3),
    /// Total volume Σ|V|, m³.
    pub volume: f64,
    /// Negatively oriented tets (0 after loading, which reorients).
    pub negative: usize,
    /// Tets of zero or near-zero volume.
    pub degenerate: Vec<usize>,
    /// Non-degenerate tets with a dihedral angle below [`SLIVER_ANGLE_DEGREES`].
    pub slivers: Vec<usize>,
    /// Per-tet smallest dihedral angle, degrees.
    pub min_dihedral: Summary,
    /// Per-tet largest dihedral angle, degrees.
    pub max_dihedral: Summary,
    /// Per-tet aspect ratio ℓ_max / (2√6·r_in): 1 for a regular tet, ∞ for a flat one.
    pub aspect_ratio: Summary,
    /// Tets per bin of [`ANGLE_BINS`] by smallest dihedral angle.
    pub angle_histogram: Vec<usize>,
    /// Tets per connected piece (sharing vertices), largest first.
    pub components: Vec<usize>,
    /// (earlier, later) vertex pairs at the same position.
    pub duplicate_vertices: Vec<(usize, usize)>,
    /// (earlier, later) tet pairs with the same four vertices.
    pub duplicate_tets: Vec<(usize, usize)>,
    /// Tets around faces shared by more than two tets.
    pub non_manifold_tets: Vec<usize>,
    /// Boundary triangles (faces of exactly one tet).
    pub boundary_faces: usize,
    /// Boundary edges not shared by exactly two boundary triangles (0: closed surface).
    pub open_edges: usize,
    /// V − E + F of the boundary surface (2 per closed sphere-like piece, 0 for a torus).
    pub euler_characteristic: i64,
    /// Smallest altitude 3V/A_max of a non-degenerate tet, m (∞ when there is none).
    pub min_altitude: f64,
    /// P-wave speed √((λ+2μ)/ρ) of the default material, m/s.
    pub wave_speed: f64,
    /// Suggested time step: the time a pressure wave needs to cross the thinnest tet, s.
    pub suggested_dt: f64,
    /// File ids of tets and vertices, for messages.
    tet_ids: Option<Vec<u64>>,
    vertex_ids: Option<Vec<u64>>,
}

/// Diagnose `mesh` with the default material (see [`DoctorParams`]).
pub fn diagnose(mesh: &TetMesh) -> Diagnosis {
    diagnose_with(mesh, &DoctorParams::default())
}

/// Per-tet measures computed in one parallel pass.
#[derive(Clone, Copy)]
struct TetQuality {
    volume: f64,
    min_angle: f64,
    max_angle: f64,
    aspect: f64,
    altitude: f64,
}

fn tet_quality(x: &[Vec3], tet: &[usize; 4]) -> TetQuality {
    let p = tet.map(|v| x[v]);
    let volume = (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0])) / 6.0;
    // Outward normal of the face opposite each vertex (area-weighted).
    let normal = |i: usize| {
        let [a, b, c] = match i {
            0 => [1, 2, 3],
            1 => [0, 2, 3],
            2 => [0, 1, 3],
            _ => [0, 1, 2],
        };
        let n = (p[b] - p[a]).cross(&(p[c] - p[a]));
        if n.dot(&(p[a] - p[i])) < 0.0 { -n } else { n }
    };
    let normals = [normal(0), normal(1), normal(2), normal(3)];
    let areas = normals.map(|n| 0.5 * n.norm());
    let (mut min_angle, mut max_angle) = (f64::INFINITY, 0.0f64);
    for k in 0..4 {
        for l in k + 1..4 {
            // The edge shared by the faces opposite k and l; its dihedral angle is π minus the
            // angle between their outward normals.
            let denom = normals[k].norm() * normals[l].norm();
            let angle = if denom > 0.0 {
                let c = (-normals[k].dot(&normals[l]) / denom).clamp(-1.0, 1.0);
                c.acos().to_degrees()
            } else {
                0.0
            };
            min_angle = min_angle.min(angle);
            max_angle = max_angle.max(angle);
        }
    }
    let longest = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        .iter()
        .map(|&(i, j)| (p[i] - p[j]).norm())
        .fold(0.0, f64::max);
    let area_sum: f64 = areas.iter().sum();
    let max_area = areas.iter().copied().fold(0.0, f64::max);
    let v = volume.abs();
    let inradius = if area_sum > 0.0 {
        3.0 * v / area_sum
    } else {
        0.0
    };
    let aspect = if inradius > 0.0 {
        longest / (2.0 * 6f64.sqrt() * inradius)
    } else {
        f64::INFINITY
    };
    let altitude = if max_area > 0.0 {
        3.0 * v / max_area
    } else {
        0.0
    };
    // NaN coordinates give NaN measures: count them as the worst value.
    let or = |x: f64, bad: f64| if x.is_nan() { bad } else { x };
    TetQuality {
        volume: or(volume, 0.0),
        min_angle: or(min_angle, 0.0),
        max_angle: or(max_angle, 180.0),
        aspect: or(aspect, f64::INFINITY),
        altitude: or(altitude, 0.0),
    }
}

/// Diagnose `mesh`, computing the suggested time step for the material in `params`. Tet indices
/// must be in range (readers guarantee it); a mesh with bad indices gets an empty diagnosis
/// apart from its counts.
pub fn diagnose_with(mesh: &TetMesh, params: &DoctorParams) -> Diagnosis {
    let x = &mesh.positions;
    let mut d = Diagnosis {
        vertices: x.len(),
        tets: mesh.tets.len(),
        groups: mesh.groups.len(),
        bounding_box: mesh.bounding_box(),
        tet_ids: mesh.tet_ids.clone(),
        vertex_ids: mesh.vertex_ids.clone(),
        ..Default::default()
    };
    if mesh.tets.iter().flatten().any(|&v| v >= x.len()) {
        return d;
    }
    let quality: Vec<TetQuality> = mesh
        .tets
        .par_iter()
        .with_min_len(1024)
        .map(|t| tet_quality(x, t))
        .collect();
    d.volume = quality.iter().map(|q| q.volume.abs()).sum();
    d.negative = quality.iter().filter(|q| q.volume < 0.0).count();
    d.degenerate = mesh.degenerate_tets();
    let is_degenerate = {
        let mut flags = vec![false; mesh.tets.len()];
        for &t in &d.degenerate {
            flags[t] = true;
        }
        flags
    };
    d.slivers = (0..quality.len())
        .filter(|&t| !is_degenerate[t] && quality[t].min_angle < SLIVER_ANGLE_DEGREES)
        .collect();
    d.min_dihedral = Summary::of(quality.iter().map(|q| q.min_angle));
    d.max_dihedral = Summary::of(quality.iter().map(|q| q.max_angle));
    d.aspect_ratio = Summary::of(quality.iter().map(|q| q.aspect));
    d.angle_histogram = vec![0; ANGLE_BINS.len() - 1];
    for q in &quality {
        let bin = ANGLE_BINS[1..]
            .iter()
            .position(|&hi| q.min_angle < hi)
            .unwrap_or(ANGLE_BINS.len() - 2);
        d.angle_histogram[bin] += 1;
    }
    d.components = components(x.len(), &mesh.tets);
    d.duplicate_vertices = duplicate_vertices(x);
    d.duplicate_tets = duplicate_tets(&mesh.tets);
    surface(mesh, &mut d);
    // Degenerate tets are reported on their own; the time step is for the tets that can run.
    d.min_altitude = quality
        .iter()
        .zip(&is_degenerate)
        .filter(|(_, bad)| !**bad)
        .map(|(q, _)| q.altitude)
        .fold(f64::INFINITY, f64::min);
    let lame = Lame::from_young_poisson(params.youngs_modulus, params.poisson_ratio);
    d.wave_speed = ((lame.lambda + 2.0 * lame.mu) / params.density).sqrt();
    d.suggested_dt = d.min_altitude / d.wave_speed;
    d
}

/// Tets per connected piece (union-find over vertices), largest first.
fn components(n: usize, tets: &[[usize; 4]]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for tet in tets {
        let r0 = root(&mut parent, tet[0]);
        for &v in &tet[1..] {
            let r = root(&mut parent, v);
            if r != r0 {
                parent[r] = r0;
            }
        }
    }
    let mut count = vec![0usize; n];
    for tet in tets {
        count[root(&mut parent, tet[0])] += 1;
    }
    let mut sizes: Vec<usize> = count.into_iter().filter(|&c| c > 0).collect();
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    sizes
}

/// (earlier, later) pairs of vertices within [`DUPLICATE_RELATIVE_DISTANCE`] of the diagonal,
/// found by hashing into a grid of that cell size and checking the 27 neighbouring cells.
fn duplicate_vertices(x: &[Vec3]) -> Vec<(usize, usize)> {
    let (lo, hi) = super::bounding_box(x);
    let diagonal = (hi - lo).norm();
    if x.len() < 2 || !diagonal.is_finite() {
        return Vec::new();
    }
    let tol = DUPLICATE_RELATIVE_DISTANCE * diagonal;
    let cell_of = |p: &Vec3| -> [i64; 3] {
        if tol > 0.0 {
            let c = (p - lo) / tol;
            [c.x as i64, c.y as i64, c.z as i64]
        } else {
            [0, 0, 0]
        }
    };
    let mut cells: Vec<([i64; 3], usize)> =
        x.iter().enumerate().map(|(i, p)| (cell_of(p), i)).collect();
    cells.sort_unstable();
    // Bounds the work on pathological inputs (millions of coincident points): a vertex with
    // this many earlier neighbours within a cell has certainly been seen as a duplicate.
    const MAX_CANDIDATES: usize = 64;
    let mut pairs = Vec::new();
    for &(cell, j) in &cells {
        let mut found = None;
        let mut seen = 0;
        'cells: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [cell[0] + dx, cell[1] + dy, cell[2] + dz];
                    let start = cells.partition_point(|c| c.0 < key);
                    for &(c, i) in &cells[start..] {
                        if c != key || i >= j || seen >= MAX_CANDIDATES {
                            break;
                        }
                        seen += 1;
                        if (x[i] - x[j]).norm() <= tol {
                            found = Some(i);
                            break 'cells;
                        }
                    }
                }
            }
        }
        if let Some(i) = found {
            pairs.push((i, j));
        }
    }
    pairs.sort_unstable_by_key(|p| p.1);
    pairs
}

/// (earlier, later) pairs of tets with the same vertex set.
fn duplicate_tets(tets: &[[usize; 4]]) -> Vec<(usize, usize)> {
    let mut keys: Vec<([usize; 4], usize)> = tets
        .iter()
        .enumerate()
        .map(|(t, tet)| {
            let mut k = *tet;
            k.sort_unstable();
            (k, t)
        })
        .collect();
    keys.sort_unstable();
    let mut pairs: Vec<(usize, usize)> = keys
        .windows(2)
        .filter(|w| w[0].0 == w[1].0)
        .map(|w| (w[0].1, w[1].1))
        .collect();
    pairs.sort_unstable_by_key(|p| p.1);
    pairs
}

/// Face incidences: boundary faces, faces of more than two tets, boundary edges and χ.
fn surface(mesh: &TetMesh, d: &mut Diagnosis) {
    // u32 keys halve the bytes the sort moves (a mesh with 2³² vertices would not fit in
    // memory anyway).
    let mut faces: Vec<([u32; 3], u32)> = Vec::with_capacity(4 * mesh.tets.len());
    for (t, tet) in mesh.tets.iter().enumerate() {
        let [a, b, c, e] = tet.map(|v| v as u32);
        for mut f in [[b, c, e], [a, c, e], [a, b, e], [a, b, c]] {
            f.sort_unstable();
            faces.push((f, t as u32));
        }
    }
    faces.par_sort_unstable();
    let mut boundary = Vec::new();
    let mut non_manifold = Vec::new();
    let mut i = 0;
    while i < faces.len() {
        let mut j = i + 1;
        while j < faces.len() && faces[j].0 == faces[i].0 {
            j += 1;
        }
        match j - i {
            1 => boundary.push(faces[i].0),
            2 => {}
            _ => non_manifold.extend(faces[i..j].iter().map(|f| f.1 as usize)),
        }
        i = j;
    }
    non_manifold.sort_unstable();
    non_manifold.dedup();
    d.non_manifold_tets = non_manifold;
    d.boundary_faces = boundary.len();
    let mut edges: Vec<[u32; 2]> = boundary
        .iter()
        .flat_map(|f| [[f[0], f[1]], [f[0], f[2]], [f[1], f[2]]])
        .collect();
    edges.par_sort_unstable();
    let mut distinct_edges = 0i64;
    let mut open = 0;
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        distinct_edges += 1;
        if j - i != 2 {
            open += 1;
        }
        i = j;
    }
    d.open_edges = open;
    let mut vertices: Vec<u32> = boundary.iter().flatten().copied().collect();
    vertices.par_sort_unstable();
    vertices.dedup();
    d.euler_characteristic = vertices.len() as i64 - distinct_edges + boundary.len() as i64;
}

impl Diagnosis {
    fn tet_id(&self, t: usize) -> u64 {
        self.tet_ids.as_ref().map_or(t as u64, |ids| ids[t])
    }

    fn vertex_id(&self, v: usize) -> u64 {
        self.vertex_ids.as_ref().map_or(v as u64, |ids| ids[v])
    }

    fn tet_list(&self, tets: impl Iterator<Item = usize>) -> Vec<u64> {
        tets.map(|t| self.tet_id(t)).collect()
    }

    /// The findings graded by severity, errors first. Elements and nodes are named by their ids
    /// in the source file.
    pub fn problems(&self) -> Vec<(Severity, MeshProblem)> {
        let mut out = Vec::new();
        if self.tets == 0 {
            out.push((Severity::Error, MeshProblem::NoTetrahedra));
        }
        if !self.degenerate.is_empty() {
            let tets = self.tet_list(self.degenerate.iter().copied());
            out.push((Severity::Error, MeshProblem::Degenerate { tets }));
        }
        if !self.duplicate_tets.is_empty() {
            let tets = self.tet_list(self.duplicate_tets.iter().map(|p| p.1));
            out.push((Severity::Error, MeshProblem::DuplicateTets { tets }));
        }
        if !self.non_manifold_tets.is_empty() {
            let tets = self.tet_list(self.non_manifold_tets.iter().copied());
            out.push((Severity::Error, MeshProblem::NonManifoldFaces { tets }));
        }
        if !self.duplicate_vertices.is_empty() {
            let vertices = self
                .duplicate_vertices
                .iter()
                .map(|p| self.vertex_id(p.1))
                .collect();
            out.push((Severity::Error, MeshProblem::DuplicateVertices { vertices }));
        }
        if !self.slivers.is_empty() {
            out.push((
                Severity::Warning,
                MeshProblem::Slivers {
                    tets: self.tet_list(self.slivers.iter().copied()),
                    min_angle_degrees: self.min_dihedral.min,
                },
            ));
        }
        if self.open_edges > 0 {
            out.push((
                Severity::Warning,
                MeshProblem::OpenSurface {
                    edges: self.open_edges,
                },
            ));
        }
        if self.components.len() > 1 {
            out.push((
                Severity::Warning,
                MeshProblem::Disconnected {
                    components: self.components.clone(),
                },
            ));
        }
        out
    }

    /// The reason to refuse the mesh (every error-level problem), or None when it can be run.
    pub fn refusal(&self) -> Option<MeshProblem> {
        let mut errors: Vec<MeshProblem> = self
            .problems()
            .into_iter()
            .filter(|p| p.0 == Severity::Error)
            .map(|p| p.1)
            .collect();
        match errors.len() {
            0 => None,
            1 => errors.pop(),
            _ => Some(MeshProblem::Many(errors)),
        }
    }

    /// True when nothing is graded [`Severity::Error`].
    pub fn is_ok(&self) -> bool {
        self.refusal().is_none()
    }
}

impl fmt::Display for Diagnosis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (lo, hi) = self.bounding_box;
        writeln!(
            f,
            "{} vertices, {} tets, {} boundary faces, {} groups",
            self.vertices, self.tets, self.boundary_faces, self.groups
        )?;
        writeln!(
            f,
            "bounding box: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        )?;
        writeln!(f, "volume: {:.6e} m³", self.volume)?;
        writeln!(
            f,
            "orientation: {} negatively oriented tet(s)",
            self.negative
        )?;
        writeln!(
            f,
            "dihedral angles: smallest per tet {:.2}°..{:.2}° (mean {:.2}°), largest per tet {:.2}°..{:.2}°",
            self.min_dihedral.min,
            self.min_dihedral.max,
            self.min_dihedral.mean,
            self.max_dihedral.min,
            self.max_dihedral.max
        )?;
        writeln!(
            f,
            "aspect ratio (1 = regular): {:.3}..{:.3} (mean {:.3})",
            self.aspect_ratio.min, self.aspect_ratio.max, self.aspect_ratio.mean
        )?;
        writeln!(f, "tets by smallest dihedral angle:")?;
        let most = self
            .angle_histogram
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(1);
        for (i, &n) in self.angle_histogram.iter().enumerate() {
            let bar = "#".repeat((40 * n).div_ceil(most));
            writeln!(
                f,
                "  {:>5.1}°..{:>5.1}° {n:>9} {bar}",
                ANGLE_BINS[i],
                ANGLE_BINS[i + 1]
            )?;
        }
        writeln!(
            f,
            "degenerate: {}, slivers (< {SLIVER_ANGLE_DEGREES}°): {}, duplicate vertices: {}, duplicate tets: {}",
            self.degenerate.len(),
            self.slivers.len(),
            self.duplicate_vertices.len(),
            self.duplicate_tets.len()
        )?;
        writeln!(f, "connected pieces: {}", self.components.len())?;
        let closed = if self.open_edges == 0 && self.non_manifold_tets.is_empty() {
            "closed".to_string()
        } else {
            format!(
                "NOT closed ({} open or non-manifold edges)",
                self.open_edges
            )
        };
        writeln!(
            f,
            "boundary surface: {closed}, Euler characteristic {}",
            self.euler_characteristic
        )?;
        writeln!(
            f,
            "suggested dt: {:.3e} s (a pressure wave at {:.3} m/s of the default material crossing the thinnest tet, altitude {:.3e} m)",
            self.suggested_dt, self.wave_speed, self.min_altitude
        )?;
        let problems = self.problems();
        if problems.is_empty() {
            writeln!(f, "verdict: OK")?;
        }
        for (severity, problem) in problems {
            let label = match severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            };
            writeln!(f, "{label}: {problem}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn box_is_healthy_closed_and_sphere_like() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [4, 2, 2]);
        let d = diagnose(&mesh);
        assert!((d.volume - 2.0).abs() < 1e-12);
        assert_eq!(d.negative, 0);
        assert!(d.problems().is_empty(), "{d}");
        assert_eq!(d.euler_characteristic, 2);
        assert_eq!(d.open_edges, 0);
        assert_eq!(d.components, vec![6 * 16]);
        assert_eq!(d.angle_histogram.iter().sum::<usize>(), 6 * 16);
        // Kuhn tets of a cube have dihedral angles of 45°, 60° and 90°.
        assert!((d.min_dihedral.min - 45.0).abs() < 1e-9);
        assert!((d.max_dihedral.max - 90.0).abs() < 1e-9);
        assert!(d.suggested_dt > 0.0 && d.suggested_dt.is_finite());
    }

    #[test]
    fn regular_tet_has_aspect_one() {
        let s = 1.0 / 2f64.sqrt();
        let x = [
            Vec3::new(1.0, 0.0, -s),
            Vec3::new(-1.0, 0.0, -s),
            Vec3::new(0.0, 1.0, s),
            Vec3::new(0.0, -1.0, s),
        ];
        let q = tet_quality(&x, &[0, 1, 2, 3]);
        assert!((q.aspect - 1.0).abs() < 1e-12);
        assert!((q.min_angle - 70.528779).abs() < 1e-5);
    }

    #[test]
    fn duplicates_and_pieces_are_found() {
        let mut mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [1, 1, 1]);
        let n = mesh.positions.len();
        // A second, separate copy of the cube's vertices and a duplicate tet.
        let copy: Vec<Vec3> = mesh.positions.clone();
        mesh.positions.extend(copy);
        let first = mesh.tets[0];
        mesh.tets.push(first.map(|v| v + n));
        mesh.tets.push(first);
        let d = diagnose(&mesh);
        assert_eq!(d.components, vec![7, 1]);
        assert_eq!(d.duplicate_tets, vec![(0, 7)]);
        assert_eq!(d.duplicate_vertices.len(), n);
        let refusal = d.refusal().unwrap().to_string();
        assert!(refusal.contains("duplicate element(s)"), "{refusal}");
        assert!(refusal.contains("duplicate node(s)"), "{refusal}");
    }
}
