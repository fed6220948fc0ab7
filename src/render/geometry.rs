//! What gets drawn: the boundary triangles (with the tet behind each), their normals, and the
//! cut-away by a plane that exposes the cut faces of the tets it crosses.

use super::{CREASE_ANGLE_DEG, FieldLocation, Plane, RenderParams, SceneView, Shading};
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// The boundary surface of a tet mesh, prepared once for rendering many frames: the boundary
/// triangles (outward in the rest configuration), the tet behind each triangle (for per-tet
/// fields) and the vertex → triangle incidence (for smooth normals).
#[derive(Clone, Debug, Default)]
pub struct RenderMesh {
    vertex_count: usize,
    tets: Vec<[usize; 4]>,
    faces: Vec<[usize; 3]>,
    face_tet: Vec<usize>,
    on_surface: Vec<bool>,
    incidence_offsets: Vec<usize>,
    incidence: Vec<usize>,
    /// The face across edge k (corner k → k+1) of each face; `usize::MAX` when there is none
    /// or more than one (an open or non-manifold edge).
    neighbours: Vec<[usize; 3]>,
}

impl RenderMesh {
    /// Find the boundary triangles of `mesh` (faces used by exactly one tet), oriented outward
    /// in the rest configuration, sorted by their vertex sets like
    /// [`TetMesh::boundary_faces`]. Tets with out-of-range indices are skipped.
    pub fn new(mesh: &TetMesh) -> Self {
        let n = mesh.positions.len();
        let (boundary, face_tet): (Vec<[usize; 3]>, Vec<usize>) =
            mesh.boundary_faces_with_tets().into_iter().unzip();
        let mut on_surface = vec![false; n];
        let mut offsets = vec![0usize; n + 1];
        for f in &boundary {
            for &v in f {
                on_surface[v] = true;
                offsets[v + 1] += 1;
            }
        }
        for v in 0..n {
            offsets[v + 1] += offsets[v];
        }
        let mut fill = offsets.clone();
        let mut incidence = vec![0; offsets[n]];
        for (fi, f) in boundary.iter().enumerate() {
            for &v in f {
                incidence[fill[v]] = fi;
                fill[v] += 1;
            }
        }
        let neighbours = face_neighbours(&boundary);
        RenderMesh {
            vertex_count: n,
            tets: mesh.tets.clone(),
            faces: boundary,
            face_tet,
            on_surface,
            incidence_offsets: offsets,
            incidence,
            neighbours,
        }
    }

    /// Number of vertices of the mesh.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// The tets.
    pub fn tets(&self) -> &[[usize; 4]] {
        &self.tets
    }

    /// The boundary triangles, outward in the rest configuration.
    pub fn faces(&self) -> &[[usize; 3]] {
        &self.faces
    }

    /// The tet behind each boundary triangle.
    pub fn face_tets(&self) -> &[usize] {
        &self.face_tet
    }

    /// Whether each vertex lies on the boundary surface.
    pub fn on_surface(&self) -> &[bool] {
        &self.on_surface
    }

    fn faces_at(&self, v: usize) -> &[usize] {
        &self.incidence[self.incidence_offsets[v]..self.incidence_offsets[v + 1]]
    }
}

/// For each face, the face across each of its edges (`usize::MAX`: none, or several).
fn face_neighbours(faces: &[[usize; 3]]) -> Vec<[usize; 3]> {
    let mut edges: Vec<((usize, usize), usize, usize)> = Vec::with_capacity(3 * faces.len());
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            edges.push(((a.min(b), a.max(b)), fi, k));
        }
    }
    edges.sort_unstable();
    let mut out = vec![[usize::MAX; 3]; faces.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let ((_, f0, k0), (_, f1, k1)) = (edges[i], edges[i + 1]);
            out[f0][k0] = f1;
            out[f1][k1] = f0;
        }
        i = j;
    }
    out
}

/// One triangle to rasterise, in world coordinates.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tri {
    /// Corners (m).
    pub p: [Vec3; 3],
    /// Unit normals at the corners.
    pub n: [Vec3; 3],
    /// Field values at the corners (NaN: no field).
    pub value: [f64; 3],
    /// Bit k set: draw the edge from corner k to corner k+1 (mod 3) in wireframe mode.
    pub edges: u8,
    /// Bit k set: the edge from corner k to k+1 is a feature (a crease sharper than
    /// [`CREASE_ANGLE_DEG`], an open edge, or where a cut meets the surface): always outlined.
    pub features: u8,
    /// Part of the cut face of a clipping plane.
    pub cap: bool,
    /// Part of a rigid obstacle (drawn in its own plain colour, never by the field).
    pub obstacle: bool,
}

/// Obstacle triangles (world coordinates) to draw beside the body: flat-shaded, in the obstacle
/// colour, outlined at their creases like the body. With `cut` (a point and a normal towards the
/// removed side), the part beyond the plane is cut away and the cut's rim outlined.
pub(crate) fn obstacle_triangles(obstacles: &[[Vec3; 3]], cut: Option<&Plane>) -> Vec<Tri> {
    let mut tris = Vec::with_capacity(obstacles.len());
    for p in obstacles {
        let Some(n) = (p[1] - p[0]).cross(&(p[2] - p[0])).try_normalize(1e-300) else {
            continue;
        };
        let d = cut.map_or([-1.0; 3], |c| p.map(|q| (q - c.point).dot(&c.normal)));
        if d.iter().all(|&d| d <= 0.0) {
            tris.push(Tri {
                p: *p,
                n: [n; 3],
                value: [f64::NAN; 3],
                edges: 0b111,
                features: 0,
                cap: false,
                obstacle: true,
            });
        } else if d.iter().any(|&d| d <= 0.0) {
            let corners = p.map(|q| Corner {
                p: q,
                n,
                value: f64::NAN,
                feature_after: false,
            });
            let first = tris.len();
            push_fan(&mut tris, &clip_polygon(&corners, &d), false);
            for t in &mut tris[first..] {
                t.obstacle = true;
            }
        }
    }
    tris
}

/// A polygon corner during clipping.
#[derive(Clone, Copy)]
struct Corner {
    p: Vec3,
    n: Vec3,
    value: f64,
    /// The polygon edge from this corner to the next is a feature edge.
    feature_after: bool,
}

impl Corner {
    fn lerp(&self, other: &Corner, t: f64) -> Corner {
        Corner {
            p: self.p + (other.p - self.p) * t,
            n: (self.n + (other.n - self.n) * t)
                .try_normalize(1e-300)
                .unwrap_or(self.n),
            value: self.value + (other.value - self.value) * t,
            feature_after: self.feature_after,
        }
    }
}

/// The triangles of one frame: the boundary surface (clipped when a plane is given) and the cut
/// faces of the tets that cross the plane.
pub(crate) fn build_triangles(view: &SceneView<'_>, params: &RenderParams) -> Vec<Tri> {
    let mesh = view.mesh;
    let x = view.positions;
    let vertex_field = matches!(
        params.field.map(|k| k.location()),
        Some(FieldLocation::Vertex)
    );
    let cell_field = matches!(
        params.field.map(|k| k.location()),
        Some(FieldLocation::Cell)
    );
    let vertex_value = |v: usize| {
        if vertex_field {
            view.field[v]
        } else {
            f64::NAN
        }
    };
    let cell_value = |t: usize| if cell_field { view.field[t] } else { f64::NAN };

    let face_normals: Vec<Vec3> = mesh
        .faces
        .iter()
        .map(|f| {
            (x[f[1]] - x[f[0]])
                .cross(&(x[f[2]] - x[f[0]]))
                .try_normalize(1e-300)
                .unwrap_or_else(Vec3::zeros)
        })
        .collect();
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let corner_normal = |fi: usize, v: usize| -> Vec3 {
        let nf = face_normals[fi];
        if params.shading == Shading::Flat {
            return nf;
        }
        // Area weighting through the unnormalised cross product.
        let mut sum = Vec3::zeros();
        for &g in mesh.faces_at(v) {
            if face_normals[g].dot(&nf) >= cos_crease {
                let f = mesh.faces[g];
                sum += (x[f[1]] - x[f[0]]).cross(&(x[f[2]] - x[f[0]]));
            }
        }
        sum.try_normalize(1e-300).unwrap_or(nf)
    };

    // Shift the plane a hair towards the kept side: a plane through mesh vertices (z = 0.5 on
    // a box mesh, say) then cuts the kept tets that touch it, so the cap shows their values
    // rather than those of the removed tets beyond.
    let diagonal = super::Bounds::of(x).diagonal();
    let hair = if diagonal.is_finite() {
        1e-9 * diagonal
    } else {
        0.0
    };
    let plane = params.clip.map(|p| {
        let m = p.normal.normalize();
        (p.point - m * hair, m)
    });
    let side = |p: &Vec3| plane.map_or(-1.0, |(q, m)| (p - q).dot(&m));
    let is_feature = |fi: usize, k: usize| {
        let g = mesh.neighbours[fi][k];
        g == usize::MAX || face_normals[g].dot(&face_normals[fi]) < cos_crease
    };
    let mut tris = Vec::with_capacity(mesh.faces.len() + 64);
    for (fi, f) in mesh.faces.iter().enumerate() {
        if f.iter().any(|&v| !x[v].iter().all(|c| c.is_finite())) {
            continue;
        }
        let corners: [Corner; 3] = std::array::from_fn(|k| Corner {
            feature_after: is_feature(fi, k),
            p: x[f[k]],
            n: corner_normal(fi, f[k]),
            value: if cell_field {
                cell_value(mesh.face_tet[fi])
            } else {
                vertex_value(f[k])
            },
        });
        let d = corners.map(|c| side(&c.p));
        if d.iter().all(|&d| d <= 0.0) {
            tris.push(Tri {
                p: corners.map(|c| c.p),
                n: corners.map(|c| c.n),
                value: corners.map(|c| c.value),
                edges: 0b111,
                features: corners
                    .iter()
                    .enumerate()
                    .map(|(k, c)| (c.feature_after as u8) << k)
                    .sum(),
                cap: false,
                obstacle: false,
            });
        } else if d.iter().any(|&d| d <= 0.0) {
            let poly = clip_polygon(&corners, &d);
            push_fan(&mut tris, &poly, false);
        }
    }

    if let Some((q, m)) = plane {
        let (b1, b2) = plane_basis(&m);
        for (t, tet) in mesh.tets.iter().enumerate() {
            let d: [f64; 4] = std::array::from_fn(|k| (x[tet[k]] - q).dot(&m));
            let removed = d.iter().filter(|&&d| d > 0.0).count();
            if removed == 0 || removed == 4 || !d.iter().all(|d| d.is_finite()) {
                continue;
            }
            let mut poly: Vec<Corner> = Vec::with_capacity(4);
            for (i, j) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                if (d[i] > 0.0) != (d[j] > 0.0) {
                    let s = d[i] / (d[i] - d[j]);
                    let (vi, vj) = (tet[i], tet[j]);
                    poly.push(Corner {
                        p: x[vi] + (x[vj] - x[vi]) * s,
                        n: m,
                        // The cut's outline is drawn by the clipped surface triangles.
                        feature_after: false,
                        value: if cell_field {
                            cell_value(t)
                        } else {
                            vertex_value(vi) + (vertex_value(vj) - vertex_value(vi)) * s
                        },
                    });
                }
            }
            // Order the 3 or 4 points counter-clockwise seen from the removed side.
            let c = poly.iter().fold(Vec3::zeros(), |s, k| s + k.p) / poly.len() as f64;
            let angle = |k: &Corner| {
                let r = k.p - c;
                r.dot(&b2).atan2(r.dot(&b1))
            };
            poly.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
            push_fan(&mut tris, &poly, true);
        }
    }
    tris
}

/// Two unit vectors spanning the plane with normal `m`, with `b1 × b2 = m`.
fn plane_basis(m: &Vec3) -> (Vec3, Vec3) {
    let helper = if m.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let b1 = helper.cross(m).normalize();
    (b1, m.cross(&b1))
}

/// Sutherland–Hodgman: the part of a triangle with signed distances `d` that lies on the kept
/// side (d ≤ 0), as a polygon of 3 or 4 corners in the triangle's winding.
fn clip_polygon(corners: &[Corner; 3], d: &[f64; 3]) -> Vec<Corner> {
    let mut out = Vec::with_capacity(4);
    for i in 0..3 {
        let j = (i + 1) % 3;
        let (ki, kj) = (d[i] <= 0.0, d[j] <= 0.0);
        if ki {
            out.push(corners[i]);
        }
        if ki != kj {
            let mut cut = corners[i].lerp(&corners[j], d[i] / (d[i] - d[j]));
            // Leaving the kept side, the next edge runs along the cut: outline it.
            cut.feature_after = ki || corners[i].feature_after;
            out.push(cut);
        }
    }
    out
}

/// Fan-triangulate a convex polygon; only the polygon's own edges are wireframe edges.
fn push_fan(tris: &mut Vec<Tri>, poly: &[Corner], cap: bool) {
    let last = poly.len().saturating_sub(1);
    for i in 1..last {
        let k = [poly[0], poly[i], poly[i + 1]];
        let mut edges = 0b010;
        if i == 1 {
            edges |= 0b001;
        }
        if i + 1 == last {
            edges |= 0b100;
        }
        let features = (0..3)
            .filter(|&j| k[j].feature_after)
            .fold(0, |bits, j| bits | (edges & (1 << j)));
        tris.push(Tri {
            p: k.map(|c| c.p),
            n: k.map(|c| c.n),
            value: k.map(|c| c.value),
            edges,
            features,
            cap,
            obstacle: false,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;
    use crate::render::Plane;

    #[test]
    fn render_mesh_matches_mesh_boundary_and_tets_own_their_faces() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
        let rm = RenderMesh::new(&mesh);
        assert_eq!(rm.faces(), mesh.boundary_faces().as_slice());
        for (f, &t) in rm.faces().iter().zip(rm.face_tets()) {
            assert!(f.iter().all(|v| mesh.tets[t].contains(v)));
        }
        assert!(rm.on_surface().iter().all(|&s| s));
        // A closed surface: every edge has exactly one neighbour across it, symmetrically.
        for (f, ns) in rm.neighbours.iter().enumerate() {
            for &g in ns {
                assert!(g != usize::MAX && rm.neighbours[g].contains(&f));
            }
        }
    }

    #[test]
    fn clipped_cube_is_closed_by_its_cap() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [2, 2, 2]);
        let rm = RenderMesh::new(&mesh);
        let params = RenderParams {
            field: None,
            clip: Some(Plane::new(Vec3::new(0.3, 0.0, 0.0), Vec3::x())),
            ..RenderParams::default()
        };
        let view = SceneView {
            mesh: &rm,
            positions: &mesh.positions,
            field: &[],
            fixed: &[],
            time: 0.0,
            frame: 0,
        };
        let tris = build_triangles(&view, &params);
        let area = |t: &Tri| 0.5 * (t.p[1] - t.p[0]).cross(&(t.p[2] - t.p[0])).norm();
        let cap: f64 = tris.iter().filter(|t| t.cap).map(area).sum();
        let surface: f64 = tris.iter().filter(|t| !t.cap).map(area).sum();
        // Kept box [0, 0.3] × [0, 1]²: the cap is the 1×1 section, the rest 2·0.3·2 + 1.
        assert!((cap - 1.0).abs() < 1e-12, "cap area {cap}");
        assert!(
            // Up to the hair the plane moves towards the kept side.
            (surface - (1.0 + 4.0 * 0.3)).abs() < 1e-8,
            "surface {surface}"
        );
        assert!(tris.iter().all(|t| t.p.iter().all(|p| p.x <= 0.3 + 1e-12)));
    }
}
