//! Render surfaces of a scene's bodies (`render = "detail.obj"`): read, put in the mesh's unit,
//! placed with their body, and bound to the body's rest tets.

use std::sync::Arc;
use std::time::Instant;

use super::locate::{Seg, key};
use super::schema::{MeshSpec, Scene};
use crate::elastic::ElasticBody;
use crate::error::Result;
use crate::math::Vec3;
use crate::mesh::bodies::Placement;
use crate::mesh::embed::{Embedding, OUTSIDE_FRACTION};
use crate::sim::RenderBody;

impl Scene {
    /// The render file of body `b` and the key that names it.
    fn render_of(&self, b: usize) -> Option<(&std::path::PathBuf, Vec<Seg<'static>>, &MeshSpec)> {
        if b == 0 {
            return self
                .mesh
                .render
                .as_ref()
                .map(|r| (r, key!["mesh", "render"].to_vec(), &self.mesh));
        }
        let spec = &self.body[b - 1];
        match (&spec.render, &spec.mesh.render) {
            (Some(r), _) => Some((r, key!["body", b - 1, "render"].to_vec(), &spec.mesh)),
            (None, Some(r)) => Some((
                r,
                key!["body", b - 1, "mesh", "render"].to_vec(),
                &spec.mesh,
            )),
            (None, None) => None,
        }
    }

    /// Every body's render surface, bound to `body`'s rest tets; `tets_of(b)` lists body b's
    /// tets in the simulation's numbering, `placements` each body's placement and pivot.
    pub(super) fn build_render(
        &self,
        body: &ElasticBody,
        names: &[String],
        tets_of: impl Fn(usize) -> Vec<usize>,
        placements: &[(Placement, Vec3)],
    ) -> Result<Vec<RenderBody>> {
        let mut out = Vec::new();
        for b in 0..names.len() {
            let Some((file, at, mesh_spec)) = self.render_of(b) else {
                continue;
            };
            let path = self.resolve(file);
            let mut surface =
                crate::io::render_obj::read_render_obj(&path).map_err(|e| self.error_at(&at, e))?;
            let unit = mesh_spec
                .unit
                .as_deref()
                .map(super::units::length_unit)
                .transpose()
                .map_err(|e| self.error_at(&at, e))?;
            let (placement, pivot) = placements[b];
            for p in &mut surface.positions {
                if let Some(unit) = &unit {
                    *p = p.map(|c| unit.to_si(c));
                }
                *p = placement.map(*p, pivot);
            }
            let tets = tets_of(b);
            let mesh = &body.mesh;
            let used: Vec<Vec3> = tets
                .iter()
                .flat_map(|&t| mesh.tets[t].map(|v| mesh.positions[v]))
                .collect();
            let (lo, hi) = crate::mesh::bounding_box(&used);
            let tolerance = OUTSIDE_FRACTION * (hi - lo).norm();
            let start = Instant::now();
            let embedding = Embedding::bind(mesh, &tets, &surface.positions, tolerance)
                .map_err(|e| self.error_at(&at, format!("{}: {e}", path.display())))?;
            log::info!(
                "{}: {} vertices, {} faces bound to the tets of {} in {:.3} s ({} outside the \
                 mesh, at most {:.3e} m)",
                path.display(),
                surface.positions.len(),
                surface.face_count(),
                names[b],
                start.elapsed().as_secs_f64(),
                embedding.outside,
                embedding.max_distance
            );
            out.push(RenderBody {
                body: b,
                name: names[b].clone(),
                source: path,
                surface: Arc::new(surface),
                embedding: Arc::new(embedding),
            });
        }
        Ok(out)
    }
}
