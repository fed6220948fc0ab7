//! What rank 0 sends each rank: its part of the body, of the boundary and of the initial state,
//! and how its vertices map to the matrix and to the other ranks ([`RankSetup`], postcard
//! bytes); and how a rank makes its [`Simulation`] from it ([`RankSetup::simulation`]). Plain
//! Rust: tested without MPI.

use serde::{Deserialize, Serialize};

use super::partition::{Layout, Part, Partition};
use crate::boundary::{Boundary, Constraint, Load, Motion};
use crate::elastic::ElasticBody;
use crate::elastic::part::RawPieces;
use crate::integrator::SolverParams;
use crate::material::{Lame, Model, ModelKind};
use crate::math::{Mat3, Vec3};
use crate::mesh::TetMesh;
use crate::sim::{Simulation, State};

type V3 = [f64; 3];

/// A load's (vertex, force) pairs and its ramp duration.
pub type WireLoad = (Vec<(u32, V3)>, Option<f64>);

fn v3(v: &Vec3) -> V3 {
    [v.x, v.y, v.z]
}

fn vec3(v: &V3) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

/// One rank's part of a simulation, as rank 0 sends it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RankSetup {
    /// The receiving rank and the number of ranks.
    pub rank: u32,
    /// Number of ranks.
    pub ranks: u32,
    /// Vertices of the whole body.
    pub total_vertices: u64,
    /// The whole mesh's mean edge length, m.
    pub mean_edge_length: f64,
    /// How many of the vertices below the rank owns (the first ones).
    pub owned: u64,
    /// The matrix block row of each vertex.
    pub rows: Vec<u64>,
    /// The first row the rank owns.
    pub first_row: u64,
    /// (rank, local ghosts it owns, local owned vertices that are its ghosts), rank order.
    pub neighbours: Vec<(u32, Vec<u32>, Vec<u32>)>,
    /// Per owned row: blocks in the rank's own columns and in other ranks' (preallocation).
    pub diagonal: Vec<u32>,
    /// See `diagonal`.
    pub off: Vec<u32>,
    /// Rest positions of the rank's vertices, m.
    pub positions: Vec<V3>,
    /// The rank's tets, in local vertex indices.
    pub tets: Vec<[u32; 4]>,
    /// Bm of each tet (column-major).
    pub bm: Vec<[f64; 9]>,
    /// Rest volume of each tet, m³.
    pub volume: Vec<f64>,
    /// The whole body's lumped mass of each owned vertex, zero on ghosts, kg.
    pub mass: Vec<f64>,
    /// Material index of each tet (empty: one material).
    pub tet_material: Vec<u8>,
    /// (model, μ, λ, density): the base material, then the regions'.
    pub materials: Vec<WireMaterial>,
    /// The constraints on the rank's vertices (owned and ghosts).
    pub constraints: Vec<WireConstraint>,
    /// The loads on its owned vertices: (vertex, force) and ramp duration per load.
    pub loads: Vec<WireLoad>,
    /// Gravity, m/s².
    pub gravity: V3,
    /// Initial positions and velocities of the rank's vertices.
    pub x: Vec<V3>,
    /// See `x`.
    pub v: Vec<V3>,
    /// The Rayleigh coefficients (α, γ) as rank 0 resolved them (a damping ratio needs the
    /// whole body's modes).
    pub rayleigh: [f64; 2],
    /// Rank 0's solver settings, printed: every rank must run the same ones.
    pub params: String,
}

/// A [`Constraint`] on a rank's vertices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WireConstraint {
    /// Local vertex indices.
    pub vertices: Vec<u32>,
    /// Constrained components.
    pub components: [bool; 3],
    /// translate, axis, center of the motion.
    pub motion: [V3; 3],
    /// Rotation at full ramp, degrees.
    pub rotate_degrees: f64,
    /// Ramp duration.
    pub duration: Option<f64>,
    /// Release time.
    pub until: Option<f64>,
    /// Explicit targets of the listed vertices.
    pub targets: Option<Vec<V3>>,
}

/// A material as sent: kind, the small-strain Lamé parameters (μ, λ), density, inversion
/// threshold and recovery threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WireMaterial {
    kind: u8,
    mu: f64,
    lambda: f64,
    density: f64,
    threshold: f64,
    recovery: f64,
}

fn material_wire(model: &Model, density: f64, recovery: f64) -> Result<WireMaterial, String> {
    let lame = model.lame();
    let threshold = model
        .inversion_threshold()
        .unwrap_or(crate::material::DEFAULT_INVERSION_THRESHOLD);
    if Model::with_threshold(model.kind(), lame, threshold) != *model {
        return Err(format!(
            "the {:?} material's parameters cannot be sent to the MPI ranks yet",
            model.kind()
        ));
    }
    let kind = ModelKind::ALL
        .iter()
        .position(|k| *k == model.kind())
        .expect("every kind is listed") as u8;
    Ok(WireMaterial {
        kind,
        mu: lame.mu,
        lambda: lame.lambda,
        density,
        threshold,
        recovery,
    })
}

fn material_of(wire: &WireMaterial) -> Result<(Model, f64, f64), String> {
    let kind = *ModelKind::ALL
        .get(wire.kind as usize)
        .ok_or_else(|| format!("unknown material kind {}", wire.kind))?;
    let lame = Lame {
        mu: wire.mu,
        lambda: wire.lambda,
    };
    Ok((
        Model::with_threshold(kind, lame, wire.threshold),
        wire.density,
        wire.recovery,
    ))
}

/// Everything rank 0 knows that the parts are cut from.
pub struct Whole<'a> {
    /// The whole body.
    pub body: &'a ElasticBody,
    /// Its boundary.
    pub boundary: &'a Boundary,
    /// The initial state.
    pub state: &'a State,
    /// The solver settings (rank 0's resolved Rayleigh coefficients).
    pub params: &'a SolverParams,
}

/// Cut `whole` into the parts of `partition` (each with its [`Layout`]): one [`RankSetup`]
/// per rank. Fails on a material whose parameters cannot be sent.
pub fn setups(whole: &Whole<'_>, partition: &Partition) -> Result<Vec<RankSetup>, String> {
    let cutter = Cutter::new(whole, partition)?;
    Ok((0..partition.parts).map(|r| cutter.setup(r)).collect())
}

/// What every rank's [`RankSetup`] is cut from, made once; [`Cutter::setup`] makes one rank's
/// at a time, so that rank 0 holds one set-up besides the whole, not all of them.
pub struct Cutter<'w, 'a> {
    whole: &'w Whole<'a>,
    partition: &'w Partition,
    parts: Vec<Part>,
    layouts: Vec<Layout>,
    pattern: crate::linear::sparse::BlockPattern,
    materials: Vec<WireMaterial>,
    mean_edge_length: f64,
}

impl<'w, 'a> Cutter<'w, 'a> {
    /// Ready to cut `whole` by `partition`. Fails on a material whose parameters cannot be
    /// sent.
    pub fn new(whole: &'w Whole<'a>, partition: &'w Partition) -> Result<Self, String> {
        let body = whole.body;
        let mesh = &body.mesh;
        let (model, density, regions, _) = body.materials();
        let mut materials = vec![material_wire(&model, density, body.recovery_threshold(0))?];
        for (k, (m, d)) in regions.iter().enumerate() {
            materials.push(material_wire(m, *d, body.recovery_threshold(k + 1))?);
        }
        let parts = partition.parts(mesh);
        let layouts = partition.layouts(&parts);
        Ok(Cutter {
            whole,
            partition,
            layouts,
            parts,
            pattern: crate::linear::sparse::BlockPattern::from_tets(
                mesh.positions.len(),
                &mesh.tets,
            ),
            materials,
            mean_edge_length: mesh.mean_edge_length(),
        })
    }

    /// Rank `rank`'s set-up.
    pub fn setup(&self, rank: usize) -> RankSetup {
        setup(
            self.whole,
            self.partition,
            &self.pattern,
            &self.parts[rank],
            &self.layouts[rank],
            (rank, self.parts.len()),
            self.mean_edge_length,
            &self.materials,
            self.whole.body.materials().3,
        )
    }
}

#[allow(clippy::too_many_arguments)]
fn setup(
    whole: &Whole<'_>,
    partition: &Partition,
    pattern: &crate::linear::sparse::BlockPattern,
    part: &Part,
    layout: &Layout,
    (rank, ranks): (usize, usize),
    mean_edge_length: f64,
    materials: &[WireMaterial],
    tet_material: &[u8],
) -> RankSetup {
    let body = whole.body;
    let mesh = &body.mesh;
    let n = mesh.positions.len();
    // Whole-body index → local index (u32::MAX: not on this rank).
    let mut local = vec![u32::MAX; n];
    for (k, &v) in part.vertices.iter().enumerate() {
        local[v] = k as u32;
    }
    let owned = |v: usize| (local[v] as usize) < part.owned;
    let (mut diagonal, mut off) = (Vec::new(), Vec::new());
    for &v in &part.vertices[..part.owned] {
        let cols = &pattern.cols[pattern.row(v)];
        let mine = cols
            .iter()
            .filter(|&&c| partition.vertex_owner[c as usize] as usize == rank)
            .count();
        diagonal.push(mine as u32);
        off.push((cols.len() - mine) as u32);
    }
    let constraints = whole
        .boundary
        .constraints
        .iter()
        .map(|c| {
            let keep: Vec<usize> = (0..c.vertices.len())
                .filter(|&i| local[c.vertices[i]] != u32::MAX)
                .collect();
            WireConstraint {
                vertices: keep.iter().map(|&i| local[c.vertices[i]]).collect(),
                components: c.components,
                motion: [
                    v3(&c.motion.translate),
                    v3(&c.motion.axis),
                    v3(&c.motion.center),
                ],
                rotate_degrees: c.motion.rotate_degrees,
                duration: c.duration,
                until: c.until,
                targets: c
                    .targets
                    .as_ref()
                    .map(|t| keep.iter().map(|&i| v3(&t[i])).collect()),
            }
        })
        .collect();
    let loads = whole
        .boundary
        .loads
        .iter()
        .map(|l| {
            let nodal = l
                .nodal
                .iter()
                .filter(|(v, _)| local[*v] != u32::MAX && owned(*v))
                .map(|(v, f)| (local[*v], v3(f)))
                .collect();
            (nodal, l.duration)
        })
        .collect();
    let masses = body.masses();
    RankSetup {
        rank: rank as u32,
        ranks: ranks as u32,
        total_vertices: n as u64,
        mean_edge_length,
        owned: part.owned as u64,
        rows: layout.rows.iter().map(|&r| r as u64).collect(),
        first_row: layout.first_row as u64,
        neighbours: layout
            .neighbours
            .iter()
            .map(|nb| {
                (
                    nb.rank as u32,
                    nb.ghosts.iter().map(|&k| k as u32).collect(),
                    nb.shared.iter().map(|&k| k as u32).collect(),
                )
            })
            .collect(),
        diagonal,
        off,
        positions: part
            .vertices
            .iter()
            .map(|&v| v3(&mesh.positions[v]))
            .collect(),
        tets: part
            .tets
            .iter()
            .map(|&t| mesh.tets[t].map(|v| local[v]))
            .collect(),
        bm: part
            .tets
            .iter()
            .map(|&t| {
                let b = body.rest_inverses()[t];
                std::array::from_fn(|k| b.as_slice()[k])
            })
            .collect(),
        volume: part.tets.iter().map(|&t| body.volumes()[t]).collect(),
        mass: part
            .vertices
            .iter()
            .enumerate()
            .map(|(k, &v)| if k < part.owned { masses[v] } else { 0.0 })
            .collect(),
        tet_material: if tet_material.is_empty() {
            Vec::new()
        } else {
            part.tets.iter().map(|&t| tet_material[t]).collect()
        },
        materials: materials.to_vec(),
        constraints,
        loads,
        gravity: v3(&whole.boundary.gravity),
        x: part
            .vertices
            .iter()
            .map(|&v| v3(&whole.state.x[v]))
            .collect(),
        v: part
            .vertices
            .iter()
            .map(|&v| v3(&whole.state.v[v]))
            .collect(),
        rayleigh: [whole.params.rayleigh_mass, whole.params.rayleigh_stiffness],
        params: format!("{:?}", whole.params),
    }
}

impl RankSetup {
    /// The bytes sent.
    pub fn to_bytes(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("a setup serializes")
    }

    /// From the bytes sent.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        postcard::from_bytes(bytes).map_err(|e| format!("a rank's set-up did not decode: {e}"))
    }

    /// This rank's body: its tets over its vertices.
    pub fn body(&self) -> Result<ElasticBody, String> {
        let mesh = TetMesh::new(
            self.positions.iter().map(vec3).collect(),
            self.tets.iter().map(|t| t.map(|v| v as usize)).collect(),
        );
        let materials = self
            .materials
            .iter()
            .map(material_of)
            .collect::<Result<Vec<_>, _>>()?;
        let (model, density, _) = materials[0];
        let regions = materials[1..].iter().map(|&(m, d, _)| (m, d)).collect();
        let mut body = ElasticBody::from_raw_pieces(
            mesh,
            RawPieces {
                model,
                density,
                regions,
                tet_material: self.tet_material.clone(),
                bm: self.bm.iter().map(|b| Mat3::from_column_slice(b)).collect(),
                volume: self.volume.clone(),
                mass: self.mass.clone(),
            },
        )?;
        for (k, &(_, _, recovery)) in materials.iter().enumerate() {
            body.set_recovery_threshold(k, recovery);
        }
        Ok(body)
    }

    /// This rank's boundary.
    pub fn boundary(&self) -> Boundary {
        Boundary {
            constraints: self
                .constraints
                .iter()
                .map(|c| Constraint {
                    vertices: c.vertices.iter().map(|&v| v as usize).collect(),
                    components: c.components,
                    motion: Motion {
                        translate: vec3(&c.motion[0]),
                        rotate_degrees: c.rotate_degrees,
                        axis: vec3(&c.motion[1]),
                        center: vec3(&c.motion[2]),
                    },
                    duration: c.duration,
                    until: c.until,
                    targets: c.targets.as_ref().map(|t| t.iter().map(vec3).collect()),
                })
                .collect(),
            loads: self
                .loads
                .iter()
                .map(|(nodal, duration)| Load {
                    nodal: nodal.iter().map(|(v, f)| (*v as usize, vec3(f))).collect(),
                    duration: *duration,
                })
                .collect(),
            gravity: vec3(&self.gravity),
        }
    }

    /// This rank's simulation, with `params` (the scene's; the Rayleigh coefficients are
    /// rank 0's). Its sums are not yet over the ranks: see [`Simulation::set_ranks`].
    pub fn simulation(&self, mut params: SolverParams) -> Result<Simulation, String> {
        [params.rayleigh_mass, params.rayleigh_stiffness] = self.rayleigh;
        if format!("{params:?}") != self.params {
            return Err(format!(
                "rank {} read other solver settings than rank 0 ({params:?} against {})",
                self.rank, self.params
            ));
        }
        let state = State {
            x: self.x.iter().map(vec3).collect(),
            v: self.v.iter().map(vec3).collect(),
            t: 0.0,
        };
        Simulation::new(self.body()?, self.boundary(), params, state).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scene;

    /// The held-out dynamic cantilever of tests/mpi.rs: gravity, a clamp and a tip traction.
    fn whole() -> Simulation {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mpi/cantilever.toml");
        Simulation::from_scene(&Scene::load(&path).unwrap()).unwrap()
    }

    /// Every rank's set-up survives its bytes, and the parts add up to the whole: each tet once
    /// with its rest data, each vertex owned once with the whole body's mass, the loads' total,
    /// the constraints on every copy of a constrained vertex, ghosts with their owners' state.
    #[test]
    fn the_parts_add_up_to_the_whole() {
        let sim = whole();
        let body = &sim.body;
        let n = body.vertex_count();
        for ranks in [1, 2, 3, 4] {
            let partition = Partition::new(&body.mesh, ranks);
            let w = Whole {
                body,
                boundary: &sim.boundary,
                state: &sim.state,
                params: &sim.params,
            };
            let all = setups(&w, &partition).unwrap();
            assert_eq!(all.len(), ranks);
            let (mut tets, mut mass, mut load) = (0, 0.0, Vec3::zeros());
            let mut owned_by = vec![usize::MAX; n];
            let free = sim.free_mask();
            for (r, s) in all.iter().enumerate() {
                let again = RankSetup::from_bytes(&s.to_bytes()).unwrap();
                assert_eq!(&again, s);
                let part = again.simulation(sim.params.clone()).unwrap();
                let local = &part.body;
                tets += local.tet_count();
                mass += local.masses().iter().sum::<f64>();
                let owned = s.owned as usize;
                for (k, &row) in s.rows.iter().enumerate() {
                    // Rows are the global order: this rank's owned rows are consecutive.
                    if k < owned {
                        assert_eq!(row, s.first_row + k as u64);
                    }
                }
                // Map back to whole-body vertices through the positions (the box's are distinct).
                let whole_of: Vec<usize> = local
                    .mesh
                    .positions
                    .iter()
                    .map(|p| body.mesh.positions.iter().position(|q| q == p).unwrap())
                    .collect();
                for (k, &v) in whole_of.iter().enumerate() {
                    assert_eq!(part.state.x[k], sim.state.x[v]);
                    assert_eq!(part.free_mask()[k], free[v], "rank {r}: vertex {v}'s mask");
                    if k < owned {
                        assert_eq!(owned_by[v], usize::MAX, "vertex {v} owned twice");
                        owned_by[v] = r;
                        assert_eq!(local.masses()[k], body.masses()[v]);
                    } else {
                        assert_eq!(local.masses()[k], 0.0, "a ghost has no mass");
                    }
                }
                for l in &part.boundary.loads {
                    for (k, f) in &l.nodal {
                        assert!(*k < owned, "loads only on owned vertices");
                        load += f;
                    }
                }
                // The local tets are the whole body's, with the same rest data.
                for (t, tet) in local.mesh.tets.iter().enumerate() {
                    let global = tet.map(|k| whole_of[k]);
                    let g = body.mesh.tets.iter().position(|u| *u == global).unwrap();
                    assert_eq!(local.rest_inverses()[t], body.rest_inverses()[g]);
                    assert_eq!(local.volumes()[t], body.volumes()[g]);
                }
            }
            assert_eq!(tets, body.tet_count());
            assert!(
                owned_by.iter().all(|&r| r != usize::MAX),
                "every vertex owned"
            );
            let total: f64 = body.masses().iter().sum();
            assert!((mass - total).abs() <= 1e-12 * total);
            let whole_load: Vec3 = sim
                .boundary
                .loads
                .iter()
                .flat_map(|l| l.nodal.iter().map(|(_, f)| *f))
                .sum();
            assert!((load - whole_load).norm() <= 1e-12 * whole_load.norm());
        }
    }

    /// A rank that read other solver settings than rank 0 is refused, not left to diverge.
    #[test]
    fn other_settings_are_refused() {
        let sim = whole();
        let w = Whole {
            body: &sim.body,
            boundary: &sim.boundary,
            state: &sim.state,
            params: &sim.params,
        };
        let s = setups(&w, &Partition::new(&sim.body.mesh, 2)).unwrap();
        let mut other = sim.params.clone();
        other.newton_tolerance *= 2.0;
        let err = s[1].simulation(other).err().unwrap();
        assert!(err.contains("other solver settings"), "{err}");
    }
}
