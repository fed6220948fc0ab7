//! Discretised elasticity on a tet mesh (SPEC §1): energy, forces and the force differential.
//!
//! For tet e: `Ds = [x₁−x₀, x₂−x₀, x₃−x₀]`, `F = Ds·Bm`, `H = −W·P(F)·Bmᵀ`; the forces on
//! x₁, x₂, x₃ are the columns of H and x₀ gets minus their sum. The force differential is the
//! same with `dF = dDs·Bm` and `dP = (∂P/∂F):dF`, and `K·dx = −df`.
//!
//! Parallel and deterministic: every tet writes its four contributions into its own slot of a
//! per-tet buffer, then every vertex sums its incident slots in a fixed order (tet index). No
//! atomics, no races, and the same bits for any number of threads. Sums of energies go over
//! fixed-size chunks added in order.

// Kernels index small fixed arrays (corners, components) by position: clearer than iterators.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use crate::error::MeshProblem;
use crate::error::{Error, Result};
use crate::linear::sparse::{BlockCsr, BlockPattern};
use crate::material::{
    DampedTangent, DampingStiffness, Definiteness, DiagonalPieces, Model, Tangent,
};
use crate::math::{LANES, Mat3, Svd, Vec3, svd_rv_lanes_into};
use crate::mesh::TetMesh;

mod assembly;
mod damped;
mod element;
mod linearization;
pub mod part;
pub mod quadratic;
mod quadratic_body;
pub mod recovery;
pub use assembly::AssemblyWork;
use element::upper_index;
pub use element::{VON_MISES_MIN_J, corner_gradients, element_stiffness, tet_forces, von_mises};
pub use linearization::Linearization;

/// Tets per parallel work item. Fixed (not derived from the thread count) so that chunked sums
/// are the same on any machine.
const CHUNK: usize = 512;

/// The four per-vertex contributions of one tet.
pub type TetVectors = [Vec3; 4];

/// What the per-tet buffers keep of a tet's [`TetVectors`]: those of corners 1–3 (corner 0's is
/// minus their sum, recomputed where it is gathered, with the same bits as [`tet_forces`]).
type TetSlot = [Vec3; 3];

/// The slot of `v`, whose corner 0 is minus the sum of the others.
#[inline]
fn slot_of(v: TetVectors) -> TetSlot {
    [v[1], v[2], v[3]]
}

/// Vertex → incident (tet, corner) slots, in increasing tet order (compressed rows).
#[derive(Clone, Debug, Default)]
struct Incidence {
    offsets: Vec<u32>,
    slots: Vec<u32>,
}

impl Incidence {
    /// Slot `N·t + corner` for each corner of each element of N nodes.
    fn new<const N: usize>(vertex_count: usize, tets: &[[usize; N]]) -> Self {
        let mut offsets = vec![0u32; vertex_count + 1];
        for tet in tets {
            for &v in tet {
                offsets[v + 1] += 1;
            }
        }
        for v in 0..vertex_count {
            offsets[v + 1] += offsets[v];
        }
        let mut fill = offsets.clone();
        let mut slots = vec![0u32; N * tets.len()];
        for (t, tet) in tets.iter().enumerate() {
            for (corner, &v) in tet.iter().enumerate() {
                slots[fill[v] as usize] = (N * t + corner) as u32;
                fill[v] += 1;
            }
        }
        Incidence { offsets, slots }
    }

    /// `out[v] (+)= Σ buffer[slot]` over v's slots, in slot order.
    fn gather(&self, buffer: &[TetSlot], out: &mut [Vec3], accumulate: bool) {
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(v, o)| {
                let range = self.offsets[v] as usize..self.offsets[v + 1] as usize;
                let mut sum = if accumulate { *o } else { Vec3::zeros() };
                for &slot in &self.slots[range] {
                    let s = &buffer[slot as usize / 4];
                    sum += match slot % 4 {
                        0 => -(s[0] + s[1] + s[2]),
                        c => s[c as usize - 1],
                    };
                }
                *o = sum;
            });
    }
}

/// An elastic body: a validated mesh with its rest data (Bm, W, lumped masses) and a material.
#[derive(Clone, Debug)]
pub struct ElasticBody {
    /// The mesh (rest positions, tets, groups).
    pub mesh: TetMesh,
    /// The material of every tet outside the material regions.
    pub model: Model,
    /// Density ρ in kg/m³ of every tet outside the material regions.
    pub density: f64,
    /// Materials and densities of the regions (material index k ≥ 1 is `regions[k − 1]`).
    regions: Vec<(Model, f64)>,
    /// Material index per tet (0: `model`); empty when the body has one material.
    tet_material: Vec<u8>,
    bm: Vec<Mat3>,
    volume: Vec<f64>,
    mass: Vec<f64>,
    incidence: Incidence,
    /// Tangled elements and the forms they are evaluated with.
    recovery: recovery::Recovery,
    /// Quadratic tets: their nodes and per-point rest data (`bm` and `volume` then describe
    /// the straight tet of the corners, for probes and geometric checks).
    quadratic: Option<Box<quadratic::QuadraticElements>>,
}

/// A set of tets with their own material and density.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialRegion {
    /// The material.
    pub model: Model,
    /// Density, kg/m³.
    pub density: f64,
    /// The tets (indices).
    pub tets: Vec<usize>,
}

/// Min J and how many tets are inverted, for the steps table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformationStats {
    /// Smallest det F over the tets.
    pub min_j: f64,
    /// Tets with det F ≤ 0.
    pub inverted: usize,
}

impl ElasticBody {
    /// Precompute Bm = Dm⁻¹, W = |det Dm|/6 and the lumped masses (ρW/4 to each vertex of each
    /// tet). The mesh is validated: every degenerate tet is listed in the error. A negatively
    /// oriented tet is fine (its Bm carries the sign, its F is right).
    pub fn new(mesh: TetMesh, model: Model, density: f64) -> Result<Self> {
        Self::with_regions(mesh, model, density, Vec::new())
    }

    /// Like [`ElasticBody::new`], with other materials and densities on sets of tets (Gmsh
    /// physical volumes, say). Later regions win where they overlap; at most 255 regions.
    pub fn with_regions(
        mesh: TetMesh,
        model: Model,
        density: f64,
        regions: Vec<MaterialRegion>,
    ) -> Result<Self> {
        mesh.validate().map_err(|problem| Error::Mesh {
            path: None,
            problem,
        })?;
        for (name, rho) in std::iter::once(("material.density".to_string(), density)).chain(
            regions
                .iter()
                .enumerate()
                .map(|(i, r)| (format!("volume #{} density", i + 1), r.density)),
        ) {
            if !(rho > 0.0 && rho.is_finite()) {
                return Err(Error::parameter(
                    name,
                    format!("must be positive and finite (kg/m³), got {rho}"),
                ));
            }
        }
        if regions.len() > u8::MAX as usize {
            return Err(Error::parameter("volume", "at most 255 material regions"));
        }
        let mut tet_material = Vec::new();
        if !regions.is_empty() {
            tet_material = vec![0u8; mesh.tets.len()];
            for (k, region) in regions.iter().enumerate() {
                for &t in &region.tets {
                    if t >= mesh.tets.len() {
                        return Err(Error::parameter(
                            "volume",
                            format!("tet {t} does not exist"),
                        ));
                    }
                    tet_material[t] = (k + 1) as u8;
                }
            }
        }
        let regions: Vec<(Model, f64)> =
            regions.into_iter().map(|r| (r.model, r.density)).collect();
        let density_of = |t: usize| match tet_material.get(t) {
            Some(&k) if k > 0 => regions[k as usize - 1].1,
            _ => density,
        };
        let mut bm = Vec::with_capacity(mesh.tets.len());
        let mut volume = Vec::with_capacity(mesh.tets.len());
        let mut mass = vec![0.0; mesh.positions.len()];
        for (t, tet) in mesh.tets.iter().enumerate() {
            let dm = TetMesh::edge_matrix(&mesh.positions, tet);
            // Validation guarantees a non-degenerate Dm, so the inverse exists.
            let inv = dm.try_inverse().unwrap_or_else(Mat3::zeros);
            let w = dm.determinant().abs() / 6.0;
            bm.push(inv);
            volume.push(w);
            if !mesh.is_quadratic() {
                for &v in tet {
                    mass[v] += 0.25 * density_of(t) * w;
                }
            }
        }
        let quadratic = if mesh.is_quadratic() {
            let q = quadratic::QuadraticElements::new(&mesh).map_err(|bad| Error::Mesh {
                path: None,
                problem: MeshProblem::Degenerate {
                    tets: bad.into_iter().map(|t| mesh.tet_id(t)).collect(),
                },
            })?;
            for t in 0..mesh.tets.len() {
                let m = density_of(t) * q.volume(t);
                let nodes = &q.nodes[t];
                for (a, &v) in nodes.iter().enumerate() {
                    let share = if a < 4 {
                        quadratic::CORNER_MASS
                    } else {
                        quadratic::EDGE_MASS
                    };
                    mass[v] += share * m;
                }
            }
            Some(Box::new(q))
        } else {
            None
        };
        let incidence = Incidence::new(mesh.positions.len(), &mesh.tets);
        let recovery =
            recovery::Recovery::new(std::iter::once(&model).chain(regions.iter().map(|(m, _)| m)));
        Ok(ElasticBody {
            recovery,
            mesh,
            model,
            density,
            regions,
            tet_material,
            bm,
            volume,
            mass,
            incidence,
            quadratic,
        })
    }

    /// The smallest Young's modulus among the body's materials (Pa), read off each model's
    /// tangent at rest: μ = ∂P₁₂/∂F₁₂, λ = ∂P₂₂/∂F₁₁, E = μ(3λ + 2μ)/(λ + μ).
    pub fn softest_youngs_modulus(&self) -> f64 {
        use crate::material::Material;
        let at_rest = |model: &Model| {
            let (mut shear, mut stretch) = (Mat3::zeros(), Mat3::zeros());
            shear[(0, 1)] = 1.0;
            stretch[(0, 0)] = 1.0;
            let mu = model.stress_differential(&Mat3::identity(), &shear)[(0, 1)];
            let lambda = model.stress_differential(&Mat3::identity(), &stretch)[(1, 1)];
            crate::material::Lame { mu, lambda }.youngs_modulus()
        };
        std::iter::once(&self.model)
            .chain(self.regions.iter().map(|(m, _)| m))
            .map(at_rest)
            .fold(f64::INFINITY, f64::min)
    }

    /// The material tet t is evaluated with: its model, or the model's recovery form while the
    /// tet is tangled (see [`recovery`]).
    #[inline]
    pub fn model_of(&self, t: usize) -> &Model {
        let k = self.material_index(t);
        if let Some(form) = self.recovery.form(t, k) {
            return form;
        }
        match k {
            0 => &self.model,
            k => &self.regions[k - 1].0,
        }
    }

    /// The material index of tet t: 0 for the body's own, k ≥ 1 for region k − 1.
    #[inline]
    pub fn material_index(&self, t: usize) -> usize {
        self.tet_material.get(t).map_or(0, |&k| k as usize)
    }

    /// Material k (see [`ElasticBody::material_index`]) and its density, kg/m³.
    pub fn material(&self, k: usize) -> (&Model, f64) {
        match k {
            0 => (&self.model, self.density),
            k => (&self.regions[k - 1].0, self.regions[k - 1].1),
        }
    }

    /// How many tets use each material: the body's own first, then each region's.
    pub fn material_counts(&self) -> Vec<usize> {
        let mut counts = vec![0; 1 + self.regions.len()];
        if self.tet_material.is_empty() {
            counts[0] = self.tet_count();
        } else {
            for &k in &self.tet_material {
                counts[k as usize] += 1;
            }
        }
        counts
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.mesh.positions.len()
    }

    /// Number of tets.
    pub fn tet_count(&self) -> usize {
        self.mesh.tets.len()
    }

    /// Lumped vertex masses, kg.
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// Rest volumes W of the tets, m³.
    pub fn volumes(&self) -> &[f64] {
        &self.volume
    }

    /// Bm = Dm⁻¹ of the tets.
    pub fn rest_inverses(&self) -> &[Mat3] {
        &self.bm
    }

    /// The mesh and the rest data, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        inventory.add(
            "mesh: rest positions and tets",
            vec_bytes(&self.mesh.positions) + vec_bytes(&self.mesh.tets),
        );
        inventory.add(
            "rest data: Bm, W, masses, vertex-to-tet incidence",
            vec_bytes(&self.bm)
                + vec_bytes(&self.volume)
                + vec_bytes(&self.mass)
                + vec_bytes(&self.incidence.offsets)
                + vec_bytes(&self.incidence.slots),
        );
    }

    /// F of tet t at positions x.
    #[inline]
    pub fn deformation_gradient(&self, x: &[Vec3], t: usize) -> Mat3 {
        TetMesh::edge_matrix(x, &self.mesh.tets[t]) * self.bm[t]
    }

    /// Elastic energy E(x) = Σ W Ψ(F), in J.
    pub fn energy(&self, x: &[Vec3]) -> f64 {
        assert_eq!(x.len(), self.vertex_count());
        use crate::material::Material;
        if let Some(q) = self.quadratic() {
            return self.quadratic_energy(q, x);
        }
        let chunks: Vec<f64> = (0..self.tet_count())
            .into_par_iter()
            .chunks(CHUNK)
            .map(|ts| {
                ts.iter()
                    .map(|&t| {
                        self.volume[t]
                            * self
                                .model_of(t)
                                .energy_density(&self.deformation_gradient(x, t))
                    })
                    .sum::<f64>()
            })
            .collect();
        chunks.iter().sum()
    }

    /// Per-tet energy densities Ψ(F), J/m³ (for output fields; a quadratic tet's mean over its
    /// points).
    pub fn energy_densities(&self, x: &[Vec3]) -> Vec<f64> {
        use crate::material::Material;
        if let Some(q) = self.quadratic() {
            let psi = |t: usize, f: &Mat3| self.model_of(t).energy_density(f);
            return self.per_tet_of_points(q, x, psi, weighted_mean);
        }
        (0..self.tet_count())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|t| {
                self.model_of(t)
                    .energy_density(&self.deformation_gradient(x, t))
            })
            .collect()
    }

    /// Per-tet first Piola-Kirchhoff stresses P(F), Pa (for output fields; a quadratic tet's
    /// mean over its points).
    pub fn stresses(&self, x: &[Vec3]) -> Vec<Mat3> {
        use crate::material::Material;
        if let Some(q) = self.quadratic() {
            let p = |t: usize, f: &Mat3| self.model_of(t).stress(f);
            return self.per_tet_of_points(q, x, p, |v| {
                let w: f64 = v.iter().map(|(w, _)| w).sum();
                v.iter()
                    .fold(Mat3::zeros(), |acc, (wi, p)| acc + p * (wi / w))
            });
        }
        (0..self.tet_count())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|t| self.model_of(t).stress(&self.deformation_gradient(x, t)))
            .collect()
    }

    /// Per-tet von Mises stress of the Cauchy stress, Pa (see [`von_mises`]; a quadratic tet's
    /// mean over its points).
    pub fn von_mises_stresses(&self, x: &[Vec3]) -> Vec<f64> {
        use crate::material::Material;
        if let Some(q) = self.quadratic() {
            let vm = |t: usize, f: &Mat3| von_mises(&self.model_of(t).stress(f), f);
            return self.per_tet_of_points(q, x, vm, weighted_mean);
        }
        (0..self.tet_count())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|t| {
                let f = self.deformation_gradient(x, t);
                von_mises(&self.model_of(t).stress(&f), &f)
            })
            .collect()
    }

    /// Per-tet J = det F (a quadratic tet's smallest over its points: it is inverted where
    /// any point is).
    pub fn jacobians(&self, x: &[Vec3]) -> Vec<f64> {
        if let Some(q) = self.quadratic() {
            let j = |_: usize, f: &Mat3| f.determinant();
            return self.per_tet_of_points(q, x, j, |v| {
                v.iter().map(|(_, j)| *j).fold(f64::INFINITY, f64::min)
            });
        }
        (0..self.tet_count())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|t| self.deformation_gradient(x, t).determinant())
            .collect()
    }

    /// Min J and the number of inverted tets.
    pub fn deformation_stats(&self, x: &[Vec3]) -> DeformationStats {
        let j = self.jacobians(x);
        DeformationStats {
            min_j: j.iter().copied().fold(f64::INFINITY, f64::min),
            inverted: j.iter().filter(|&&j| j <= 0.0).count(),
        }
    }

    /// `f += f_el(x)`, the elastic forces (N), f = −∂E/∂x.
    pub fn add_forces(&self, x: &[Vec3], f: &mut [Vec3]) {
        assert_eq!(x.len(), self.vertex_count());
        assert_eq!(f.len(), self.vertex_count());
        if let Some(q) = self.quadratic() {
            return self.quadratic_add_forces(q, x, f);
        }
        let mut buffer = vec![[Vec3::zeros(); 3]; self.tet_count()];
        buffer
            .par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(t, slot)| {
                let stress = crate::material::Material::stress(
                    self.model_of(t),
                    &self.deformation_gradient(x, t),
                );
                *slot = slot_of(tet_forces(&stress, &self.bm[t], self.volume[t]));
            });
        self.incidence.gather(&buffer, f, true);
    }

    /// Linearize at x: what CG needs, prepared once per Newton iterate (see [`Linearization`]).
    pub fn linearize(&self, x: &[Vec3], definiteness: Definiteness) -> Linearization {
        let mut lin = Linearization::new(self, definiteness);
        let mut forces = vec![Vec3::zeros(); self.vertex_count()];
        self.linearize_into(x, &mut lin, &mut forces);
        lin
    }

    /// Refill `lin` at x with one SVD per tet, write the elastic forces into `forces` (overwrite)
    /// and return the elastic energy. Allocation-free: the Newton loop's entry point.
    pub fn linearize_into(&self, x: &[Vec3], lin: &mut Linearization, forces: &mut [Vec3]) -> f64 {
        assert_eq!(x.len(), self.vertex_count());
        assert_eq!(lin.tangents.len(), self.point_count());
        // `adaptive` evaluates the exact tangent and projects it below, keeping the exact pieces.
        let definiteness = match lin.definiteness {
            Definiteness::Adaptive => Definiteness::Exact,
            d => d,
        };
        if let Some(q) = self.quadratic() {
            self.quadratic_linearize_into(q, x, definiteness, lin, forces);
        } else {
            self.linear_linearize_into(x, definiteness, lin, forces);
        }
        if !lin.alternate.is_empty() {
            lin.tangents
                .par_iter_mut()
                .zip(lin.alternate.par_iter_mut())
                .with_min_len(CHUNK)
                .for_each(|(t, a)| t.project_keeping_exact(a));
            lin.exact_active = false;
        }
        lin.tangents_pending = false;
        lin.count_tets();
        lin.chunk_energy.iter().sum()
    }

    /// The linear tets' pass of [`ElasticBody::linearize_into`].
    fn linear_linearize_into(
        &self,
        x: &[Vec3],
        definiteness: Definiteness,
        lin: &mut Linearization,
        forces: &mut [Vec3],
    ) {
        let svd = self.uses_svd();
        lin.tangents
            .par_chunks_mut(CHUNK)
            .zip(lin.buffer.par_chunks_mut(CHUNK))
            .zip(lin.chunk_energy.par_iter_mut())
            .enumerate()
            .for_each(|(c, ((tangents, buffer), energy))| {
                let first = c * CHUNK;
                let mut sum = 0.0;
                let f_of = |k: usize| self.deformation_gradient(x, first + k);
                self.with_svds(svd, tangents.len(), f_of, |k, f, s| {
                    let t = first + k;
                    // A per-tet match on the model: a predictable branch next to an SVD.
                    let (psi, stress, tan) = self.model_of(t).evaluate_svd(f, s, definiteness);
                    sum += self.volume[t] * psi;
                    buffer[k] = slot_of(tet_forces(&stress, &self.bm[t], self.volume[t]));
                    tangents[k] = tan;
                });
                *energy = sum;
            });
        self.incidence.gather(&lin.buffer, forces, false);
    }

    /// Whether any of the body's materials needs the SVD of F (all but linear elasticity).
    fn uses_svd(&self) -> bool {
        self.model.uses_svd() || self.regions.iter().any(|(m, _)| m.uses_svd())
    }

    /// Call `each(k, &F, &svd_rv(F))` for k = 0, 1, … `count − 1` in order, with F = `f_of(k)`:
    /// the SVDs are made [`LANES`] at a time by [`svd_rv_lanes_into`](crate::math::svd_rv_lanes_into) (the same bits as one at a
    /// time, in about half the time; a short last group is padded with identities). With
    /// `svd = false` (no material needs one) `each` gets a placeholder.
    #[inline]
    fn with_svds(
        &self,
        svd: bool,
        count: usize,
        f_of: impl Fn(usize) -> Mat3,
        mut each: impl FnMut(usize, &Mat3, &Svd),
    ) {
        // One buffer for every group: four SVDs returned by value were copied twice.
        let mut svds = [Svd {
            u: Mat3::identity(),
            sigma: Vec3::repeat(1.0),
            v: Mat3::identity(),
        }; LANES];
        let mut f = [Mat3::identity(); LANES];
        let mut start = 0;
        while start < count {
            let n = (count - start).min(LANES);
            for (l, f) in f.iter_mut().enumerate() {
                *f = if l < n {
                    f_of(start + l)
                } else {
                    Mat3::identity()
                };
            }
            if svd {
                svd_rv_lanes_into(&f, &mut svds);
            }
            for l in 0..n {
                each(start + l, &f[l], &svds[l]);
            }
            start += n;
        }
    }

    /// Bytes one matrix-free stiffness product moves (a traffic model for roofline figures): per
    /// tet its tangent, Bm, W and vertex indices, the per-tet buffer written then read, and the
    /// incidence slots; per vertex the input read, the output written and the incidence offsets.
    pub fn matrix_free_bytes_per_product(&self) -> f64 {
        if self.quadratic.is_some() {
            // Per point its tangent, gradients and weight; per tet its nodes, its slot buffer
            // written then read, and the incidence slots.
            let per_point = std::mem::size_of::<Tangent>() + 240 + 8;
            let per_tet = quadratic::POINTS * per_point + 80 + 2 * 216 + 40;
            let per_vertex = 24 + 24 + 4;
            return (per_tet * self.tet_count() + per_vertex * self.vertex_count()) as f64;
        }
        let per_tet = std::mem::size_of::<Tangent>() + 72 + 8 + 32 + 2 * 72 + 16;
        let per_vertex = 24 + 24 + 4;
        (per_tet * self.tet_count() + per_vertex * self.vertex_count()) as f64
    }

    /// `out = K·dx` with K = ∂²E/∂x² frozen in `lin` (the force differential is −K·dx).
    pub fn apply_stiffness(&self, lin: &mut Linearization, dx: &[Vec3], out: &mut [Vec3]) {
        debug_assert!(!lin.tangents_pending, "tangents used before they were made");
        assert_eq!(dx.len(), self.vertex_count());
        assert_eq!(out.len(), self.vertex_count());
        if let Some(q) = self.quadratic() {
            return self.quadratic_apply_stiffness(q, lin, dx, out);
        }
        let tangents = &lin.tangents;
        lin.buffer
            .par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, buffer)| {
                for (k, slot) in buffer.iter_mut().enumerate() {
                    let t = c * CHUNK + k;
                    let tet = &self.mesh.tets[t];
                    let dds = TetMesh::edge_matrix(dx, tet);
                    let dp = tangents[t].apply(&(dds * self.bm[t]));
                    // K·dx = −df: the force kernel with the sign flipped.
                    *slot = slot_of(tet_forces(&(-dp), &self.bm[t], self.volume[t]));
                }
            });
        self.incidence.gather(&lin.buffer, out, false);
    }
}

impl ElasticBody {
    /// The 3×3 diagonal blocks of K (one per vertex) from the tangents in `lin`, for Jacobi-type
    /// preconditioners. Vertex a of a tet contributes `W·(∂P/∂F : (eⱼ ⊗ bₐ))·bₐ` to column j,
    /// with bₐ = row a−1 of Bm (b₀ = −Σ rows). Gathered per vertex in tet order: deterministic.
    pub fn stiffness_diagonal_blocks(&self, lin: &Linearization, out: &mut [Mat3]) {
        assert_eq!(out.len(), self.vertex_count());
        if let Some(q) = self.quadratic() {
            return self.quadratic_diagonal_blocks(q, lin, out);
        }
        let inc = &self.incidence;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(v, block)| {
                let mut sum = Mat3::zeros();
                for &slot in &inc.slots[inc.offsets[v] as usize..inc.offsets[v + 1] as usize] {
                    let (t, corner) = (slot as usize / 4, slot as usize % 4);
                    let bm = &self.bm[t];
                    let b: Vec3 = if corner == 0 {
                        -(bm.row(0) + bm.row(1) + bm.row(2)).transpose()
                    } else {
                        bm.row(corner - 1).transpose()
                    };
                    for j in 0..3 {
                        let mut df = Mat3::zeros();
                        df.set_row(j, &b.transpose());
                        let column = self.volume[t] * (lin.tangents[t].apply(&df) * b);
                        sum.set_column(j, &(sum.column(j) + column));
                    }
                }
                *block = sum;
            });
    }
}

/// Rayleigh stiffness damping `f_d = −γ·K_d(x)·v`, evaluated in the same pass as the forces
/// (see [`ElasticBody::linearize_damped_into`]); γ itself is the caller's.
#[derive(Clone, Copy, Debug)]
pub struct Damping<'a> {
    /// The velocities v, m/s.
    pub velocities: &'a [Vec3],
    /// Which K the damping force uses (physics, independent of Newton's tangents).
    pub stiffness: DampingStiffness,
    /// θ, s: Newton's tangents are taken at `x + θ·v` instead of x (0: at x). See
    /// [`crate::integrator::DampingTangent`].
    pub shift: f64,
    /// w: the weight of K_d in Newton's tangent `K_n + w·K_d` (γ/h in a backward-Euler step).
    pub weight: f64,
}

impl Damping<'_> {
    /// Where and how Newton's tangent is made, with the elastic part by `definiteness`.
    fn tangent(&self, definiteness: Definiteness) -> DampedTangent {
        DampedTangent {
            definiteness,
            damping: self.stiffness,
            shift: self.shift,
            weight: self.weight,
        }
    }
}

/// The weighted mean of per-point values.
fn weighted_mean(values: &[(f64, f64)]) -> f64 {
    let w: f64 = values.iter().map(|(w, _)| w).sum();
    values.iter().map(|(wi, v)| wi * v).sum::<f64>() / w
}

#[cfg(test)]
mod tests;
