//! The part of a body one MPI rank evaluates: some of its tets over the vertices they touch
//! (the rank's own vertices and its ghost layer), with the rest data copied, not recomputed, so
//! that every tet's forces and stiffness are the same bits as in the whole body.

use super::{ElasticBody, Incidence, Linearization};
use crate::mesh::TetMesh;

impl ElasticBody {
    /// The sub-body of `tets` (indices into this body's tets) over `vertices` (this body's
    /// indices; every vertex of those tets must be listed, and vertex k of the sub-body is
    /// `vertices[k]`). Materials, Bm and volumes are copied; the lumped masses are zero: a
    /// part's inertia is its owner's business (see [`crate::parallel`]).
    pub fn part(&self, tets: &[usize], vertices: &[usize]) -> ElasticBody {
        let mut local = vec![usize::MAX; self.vertex_count()];
        for (k, &v) in vertices.iter().enumerate() {
            local[v] = k;
        }
        let part_tets: Vec<[usize; 4]> = tets
            .iter()
            .map(|&t| {
                self.mesh.tets[t].map(|v| {
                    assert!(
                        local[v] != usize::MAX,
                        "vertex {v} of tet {t} is not listed"
                    );
                    local[v]
                })
            })
            .collect();
        let positions = vertices.iter().map(|&v| self.mesh.positions[v]).collect();
        let incidence = Incidence::new(vertices.len(), &part_tets);
        ElasticBody {
            mesh: TetMesh::new(positions, part_tets),
            model: self.model,
            density: self.density,
            regions: self.regions.clone(),
            tet_material: if self.tet_material.is_empty() {
                Vec::new()
            } else {
                tets.iter().map(|&t| self.tet_material[t]).collect()
            },
            bm: tets.iter().map(|&t| self.bm[t]).collect(),
            volume: tets.iter().map(|&t| self.volume[t]).collect(),
            mass: vec![0.0; vertices.len()],
            incidence,
        }
    }
}

impl Linearization {
    /// Replace the counts of clamped and inverted tets (a rank's linearization reports the
    /// counts over every rank's tets, so that every rank's Newton decides alike).
    pub fn set_counts(&mut self, clamped: usize, inverted: usize) {
        self.clamped_tets = clamped;
        self.inverted_tets = inverted;
    }
}
