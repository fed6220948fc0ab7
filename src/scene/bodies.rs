//! Building a scene of several bodies (SPEC §11 `[[body]]`): each body's mesh read or generated,
//! checked with its own file ids, placed, and merged with the others into one mesh
//! ([`Bodies::merge`]); regions with `body = "..."` filtered to that body.

use crate::error::{Error, MeshProblem, Result};
use crate::math::Vec3;
use crate::mesh::TetMesh;
use crate::mesh::bodies::{Bodies, Placement};
use crate::mesh::ordering::Renumbering;
use crate::mesh::quadratic::elevate;

use super::locate::{Seg, key};
use super::schema::{MaterialSpec, MeshSpec, Scene};
use super::validate::body_names;

/// Each body's placement and the pivot it rotated about.
pub(super) type Placements = Vec<(Placement, Vec3)>;

/// Which body each vertex and tet of the (possibly renumbered) simulation mesh belongs to.
pub(crate) struct Membership {
    names: Vec<String>,
    /// Body of every vertex, internal order.
    pub vertex_body: Vec<u32>,
    /// Body of every tet, internal order.
    pub tet_body: Vec<u32>,
}

impl Membership {
    /// Membership on the mesh `renumbering` made of the merged mesh of `bodies`.
    pub fn new(bodies: &Bodies, renumbering: Option<&Renumbering>) -> Self {
        let (vertex_body, tet_body) = (bodies.vertex_body(), bodies.tet_body());
        let (vertex_body, tet_body) = match renumbering {
            Some(r) => (
                r.to_new(&vertex_body),
                r.tet_old.iter().map(|&t| tet_body[t]).collect(),
            ),
            None => (vertex_body, tet_body),
        };
        Membership {
            names: bodies.names.clone(),
            vertex_body,
            tet_body,
        }
    }

    fn index(&self, body: &str) -> std::result::Result<u32, String> {
        self.names
            .iter()
            .position(|n| n == body)
            .map(|b| b as u32)
            .ok_or_else(|| format!("no body is named \"{body}\""))
    }

    /// The vertices of `selected` in `body` (all of them without a body), refused when none is.
    pub fn keep_vertices(
        membership: Option<&Self>,
        body: Option<&str>,
        mut selected: Vec<usize>,
    ) -> std::result::Result<Vec<usize>, String> {
        let (Some(m), Some(body)) = (membership, body) else {
            return Ok(selected);
        };
        let b = m.index(body)?;
        selected.retain(|&v| m.vertex_body[v] == b);
        if selected.is_empty() {
            return Err(format!("the region selects no vertex of body \"{body}\""));
        }
        Ok(selected)
    }

    /// The tets of `selected` in `body` (all of them without a body), refused when none is.
    pub fn keep_tets(
        &self,
        body: Option<&str>,
        mut selected: Vec<usize>,
    ) -> std::result::Result<Vec<usize>, String> {
        let Some(body) = body else {
            return Ok(selected);
        };
        let b = self.index(body)?;
        selected.retain(|&t| self.tet_body[t] == b);
        if selected.is_empty() {
            return Err(format!("the region selects no tet of body \"{body}\""));
        }
        Ok(selected)
    }

    /// The tets of body `b` (ascending).
    pub fn tets_of(&self, b: u32) -> Vec<usize> {
        (0..self.tet_body.len())
            .filter(|&t| self.tet_body[t] == b)
            .collect()
    }
}

impl Scene {
    /// Every body's mesh, placed and merged (body 0, the `[mesh]`, first), with where each
    /// body's vertices and tets went and each body's placement with its pivot (for what is
    /// placed with the body: its render surface). One body: the `[mesh]` as it was read.
    pub(super) fn build_bodies(&self) -> Result<(TetMesh, Bodies, Placements)> {
        let names = body_names(self);
        let first = self.build_mesh()?;
        // Elements are checked per body, in the body's own numbering, and blamed on what made
        // them: the mesh file, the generator, or the body's scale and rotation.
        let blame = |spec: &MeshSpec, at: &[Seg], problem: MeshProblem| match &spec.file {
            Some(f) => Error::Mesh {
                path: Some(self.resolve(f)),
                problem,
            },
            None => self.error_at(&[at, &key!["generator"]].concat(), problem),
        };
        let first = match first.validate() {
            Ok(()) => first,
            Err(problem) => return Err(blame(&self.mesh, &key!["mesh"], problem)),
        };
        if self.body.is_empty() {
            let first = if self.mesh.element_order() == 2 {
                elevate(&first)
            } else {
                first
            };
            let bodies = Bodies::single(names[0].clone(), &first);
            return Ok((first, bodies, vec![(Placement::default(), Vec3::zeros())]));
        }
        let mut parts = vec![(names[0].clone(), first)];
        let mut placements = vec![(Placement::default(), Vec3::zeros())];
        for (i, spec) in self.body.iter().enumerate() {
            let at = key!["body", i, "mesh"];
            let mut mesh = self.build_mesh_spec(&spec.mesh, &at)?;
            mesh.validate()
                .map_err(|problem| blame(&spec.mesh, &at, problem))?;
            let placement = Placement {
                scale: spec.scale,
                rotate_degrees: spec.rotate_degrees,
                axis: Vec3::from(spec.axis),
                translate: Vec3::from(spec.translate),
            };
            placements.push((placement, placement.pivot(&mesh.positions)));
            placement.apply(&mut mesh);
            if let Err(problem) = mesh.validate() {
                let key = if spec.scale != 1.0 {
                    "scale"
                } else {
                    "rotate_degrees"
                };
                return Err(self.error_at(
                    &key!["body", i, key],
                    format!("body \"{}\" once placed: {problem}", names[i + 1]),
                ));
            }
            if let Some(problem) = super::validate::beyond_length_cap(&mesh.positions) {
                return Err(self.error_at(
                    &key!["body", i, "scale"],
                    format!("body \"{}\" placed: {problem}", names[i + 1]),
                ));
            }
            parts.push((names[i + 1].clone(), mesh));
        }
        // Each body fitted alone; together they must fit too.
        let tets: usize = parts.iter().map(|(_, m)| m.tets.len()).sum();
        if let Some(why) = crate::resources::memory_shortfall(tets as f64) {
            return Err(self.error_at(
                &key!["body"],
                format!("the scene's {} bodies together: {why}", parts.len()),
            ));
        }
        // One order for the whole mesh: quadratic when asked or when any file is.
        if self.mesh.element_order() == 2 || parts.iter().any(|(_, m)| m.is_quadratic()) {
            for (_, mesh) in &mut parts {
                *mesh = elevate(mesh);
            }
        }
        let (mesh, bodies) = Bodies::merge(parts);
        Ok((mesh, bodies, placements))
    }

    /// The `[material]` of body `b` (0: the top-level one).
    pub(super) fn body_material(&self, b: usize) -> &MaterialSpec {
        match b {
            0 => &self.material,
            b => &self.body[b - 1].material,
        }
    }

    /// The index of the body named `name` (0 when None or unknown: `validate` refuses unknown
    /// names).
    pub(super) fn body_index(&self, name: Option<&str>) -> usize {
        name.and_then(|n| body_names(self).iter().position(|m| m == n))
            .unwrap_or(0)
    }

    /// The initial velocity of body `b`, m/s.
    pub(super) fn body_velocity(&self, b: usize) -> Vec3 {
        Vec3::from(match b {
            0 => self.initial.velocity,
            b => self.body[b - 1].velocity,
        })
    }
}
