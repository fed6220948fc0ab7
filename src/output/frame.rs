//! One frame's output taken from a simulation as owned data ([`FrameData`]), so that the files
//! can be written while the simulation goes on to the next frame (see [`crate::runner`]).
//!
//! Taking a frame reads the simulation (positions, velocities, the per-tet fields in the input
//! numbering, the steps.csv row, the probes and reactions); writing it needs nothing else. What
//! does not change from frame to frame (the tets in the input numbering, the body of each vertex
//! and tet) is made once by [`FrameTaker::new`] and shared.

use std::sync::Arc;

use crate::contact::term::ContactCosts;
use crate::integrator::StepStats;
use crate::math::Vec3;
use crate::sim::Simulation;

/// Everything one frame's files are made of, in the input mesh's numbering.
pub struct FrameData {
    /// Frame number.
    pub frame: usize,
    /// Time (s; quasistatic: the load factor).
    pub time: f64,
    pub(super) x: Vec<Vec3>,
    pub(super) v: Vec<Vec3>,
    pub(super) displacement: Vec<Vec3>,
    /// Prescribed components of each vertex (0–3).
    pub(super) fixed: Vec<f64>,
    pub(super) j: Vec<f64>,
    pub(super) psi: Vec<f64>,
    pub(super) von_mises: Vec<f64>,
    pub(super) tets: Arc<Vec<[usize; 4]>>,
    /// Quadratic tets: each tet's mid-edge nodes (empty for linear tets).
    pub(super) edge_nodes: Arc<Vec<[usize; 6]>>,
    /// Per point and per cell: the body (several bodies only).
    pub(super) tags: Option<Arc<(Vec<f64>, Vec<f64>)>>,
    /// With contact: each vertex's contact force (N).
    pub(super) contact_force: Option<Vec<Vec3>>,
    /// With contact: each obstacle's motion ramp at the frame's time.
    pub(super) obstacle_ramps: Vec<f64>,
    /// The steps.csv row (wall_seconds as measured).
    pub(super) row: StepStats,
    /// With contact: its running cost totals, for timings.csv.
    pub(super) contact_costs: Option<ContactCosts>,
    /// Each probe's displacement (m), each named constraint's reaction (N): empty without them.
    pub(super) probes: Vec<Vec3>,
    pub(super) reactions: Vec<Vec3>,
    /// Each render surface's positions (empty without render surfaces).
    pub(super) render: Vec<Vec<Vec3>>,
}

/// Takes frames from one simulation; holds what stays the same from frame to frame.
pub struct FrameTaker {
    tets: Arc<Vec<[usize; 4]>>,
    edge_nodes: Arc<Vec<[usize; 6]>>,
    rest: Vec<Vec3>,
    tags: Option<Arc<(Vec<f64>, Vec<f64>)>>,
}

impl FrameTaker {
    /// For the frames of `sim` (its mesh and bodies do not change during a run).
    pub fn new(sim: &Simulation) -> Self {
        let mesh = &sim.body.mesh;
        let (tets, edge_nodes, rest) = match sim.renumbering() {
            Some(r) => (
                r.tets_to_old_mesh(&mesh.tets),
                if mesh.is_quadratic() {
                    r.tets_to_old_mesh(&mesh.edge_nodes)
                } else {
                    Vec::new()
                },
                r.vertices_to_old(&mesh.positions),
            ),
            None => (
                mesh.tets.clone(),
                mesh.edge_nodes.clone(),
                mesh.positions.clone(),
            ),
        };
        let bodies = sim.bodies();
        let tags = (bodies.count() > 1).then(|| {
            let as_f64 = |b: Vec<u32>| b.into_iter().map(f64::from).collect::<Vec<f64>>();
            Arc::new((as_f64(bodies.vertex_body()), as_f64(bodies.tet_body())))
        });
        FrameTaker {
            tets: Arc::new(tets),
            edge_nodes: Arc::new(edge_nodes),
            rest,
            tags,
        }
    }

    /// The tets in the input numbering.
    pub fn tets(&self) -> &[[usize; 4]] {
        &self.tets
    }

    /// The mesh in the input numbering (rest positions, corners, mid-edge nodes).
    pub fn mesh(&self) -> crate::mesh::TetMesh {
        let mut mesh = crate::mesh::TetMesh::new(self.rest.clone(), self.tets.to_vec());
        mesh.edge_nodes = self.edge_nodes.to_vec();
        mesh
    }

    /// The rest positions in the input numbering.
    pub fn rest(&self) -> &[Vec3] {
        &self.rest
    }

    /// The current frame of `sim`; `stats` is None for frame 0 (the initial state: its row is
    /// made here).
    pub fn take(&self, sim: &Simulation, stats: Option<&StepStats>) -> FrameData {
        let body = &sim.body;
        let state_x = &sim.state.x;
        let mut x = state_x.clone();
        let mut v = sim.state.v.clone();
        let (mut j, mut psi, mut von_mises) = super::fields::tet_fields(body, state_x);
        // How many components of each vertex are prescribed (0–3): lets `tetsim render` mark
        // fixed vertices from the frames alone.
        let mut fixed: Vec<f64> = sim.free_mask().iter().map(|m| 3.0 - m.sum()).collect();
        let row = match stats {
            Some(s) => s.clone(),
            None => StepStats {
                frame: sim.frame(),
                time: sim.state.t,
                converged: true,
                elastic_energy: body.energy(state_x),
                kinetic_energy: sim.kinetic_energy(),
                min_j: j.iter().copied().fold(f64::INFINITY, f64::min),
                inverted_elements: j.iter().filter(|&&j| j <= 0.0).count(),
                energy: crate::audit::EnergyAudit {
                    gravitational: sim.gravitational_energy(),
                    ..Default::default()
                },
                ..Default::default()
            },
        };
        // A simulation on a renumbered mesh writes in the input mesh's numbering.
        if let Some(r) = sim.renumbering() {
            for field in [&mut x, &mut v] {
                *field = r.vertices_to_old(field);
            }
            fixed = r.vertices_to_old(&fixed);
            for field in [&mut j, &mut psi, &mut von_mises] {
                *field = r.tets_to_old(field);
            }
        }
        let displacement = x.iter().zip(&self.rest).map(|(x, r)| x - r).collect();
        let setup = sim.contact_setup();
        let contact_force = setup.map(|_| {
            let f = sim.contact_forces();
            let f = if f.len() == x.len() {
                f.to_vec()
            } else {
                vec![Vec3::zeros(); x.len()]
            };
            match sim.renumbering() {
                Some(r) => r.vertices_to_old(&f),
                None => f,
            }
        });
        let obstacle_ramps = setup.map_or_else(Vec::new, |setup| {
            setup
                .obstacles
                .iter()
                .map(|o| sim.motion_ramp(o.duration))
                .collect()
        });
        FrameData {
            frame: sim.frame(),
            time: sim.state.t,
            x,
            v,
            displacement,
            fixed,
            j,
            psi,
            von_mises,
            tets: Arc::clone(&self.tets),
            edge_nodes: Arc::clone(&self.edge_nodes),
            tags: self.tags.clone(),
            contact_force,
            obstacle_ramps,
            row,
            contact_costs: sim.contact().map(|c| c.costs()),
            probes: sim.probe_displacements(),
            reactions: sim.reaction_forces(),
            render: (0..sim.render_bodies().len())
                .map(|i| sim.render_positions(i))
                .collect(),
        }
    }
}
