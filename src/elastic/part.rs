//! The part of a body one MPI rank evaluates: some of its tets over the vertices they touch
//! (the rank's own vertices and its ghost layer), with the rest data copied, not recomputed, so
//! that every tet's forces and stiffness are the same bits as in the whole body.

use super::{ElasticBody, Incidence, Linearization};
use crate::material::Model;
use crate::math::Mat3;
use crate::mesh::TetMesh;

/// The pieces of a body that are not its mesh, as [`ElasticBody::raw_pieces`] gives them and
/// [`ElasticBody::from_raw_pieces`] takes them (the parts a rank receives, see
/// [`crate::parallel`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RawPieces {
    /// The material of every tet outside the regions, and its density.
    pub model: Model,
    /// Density, kg/m³.
    pub density: f64,
    /// Materials and densities of the regions (index k ≥ 1 is `regions[k − 1]`).
    pub regions: Vec<(Model, f64)>,
    /// Material index per tet (empty: one material).
    pub tet_material: Vec<u8>,
    /// Bm per tet.
    pub bm: Vec<Mat3>,
    /// Rest volume per tet, m³.
    pub volume: Vec<f64>,
    /// Lumped mass per vertex, kg.
    pub mass: Vec<f64>,
}

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
            recovery: self.recovery.part(tets),
            quadratic: None,
        }
    }

    /// The body's materials: the base one, its density, the regions' and each tet's index.
    pub fn materials(&self) -> (Model, f64, &[(Model, f64)], &[u8]) {
        (self.model, self.density, &self.regions, &self.tet_material)
    }

    /// A body from its mesh and the pieces another body computed for the same tets (a rank's
    /// part received from rank 0): nothing is recomputed, so its tets' forces are the same bits.
    pub fn from_raw_pieces(mesh: TetMesh, pieces: RawPieces) -> Result<ElasticBody, String> {
        let (n, t) = (mesh.positions.len(), mesh.tets.len());
        let fits = pieces.bm.len() == t
            && pieces.volume.len() == t
            && pieces.mass.len() == n
            && (pieces.tet_material.is_empty() || pieces.tet_material.len() == t)
            && pieces
                .tet_material
                .iter()
                .all(|&k| (k as usize) <= pieces.regions.len())
            && mesh.tets.iter().flatten().all(|&v| v < n);
        if !fits {
            return Err(format!(
                "a part of {t} tets and {n} vertices does not match its pieces"
            ));
        }
        let incidence = Incidence::new(n, &mesh.tets);
        let recovery = super::recovery::Recovery::new(
            std::iter::once(&pieces.model).chain(pieces.regions.iter().map(|(m, _)| m)),
        );
        Ok(ElasticBody {
            recovery,
            mesh,
            model: pieces.model,
            density: pieces.density,
            regions: pieces.regions,
            tet_material: pieces.tet_material,
            bm: pieces.bm,
            volume: pieces.volume,
            mass: pieces.mass,
            incidence,
            quadratic: None,
        })
    }
}

impl Linearization {
    /// Replace the counts of clamped, strongly clamped and inverted tets (a rank's
    /// linearization reports the counts over every rank's tets, so that every rank's Newton
    /// decides alike).
    pub fn set_counts(&mut self, clamped: usize, strongly_clamped: usize, inverted: usize) {
        self.clamped_tets = clamped;
        self.strongly_clamped_tets = strongly_clamped;
        self.inverted_tets = inverted;
    }
}
