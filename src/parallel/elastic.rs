//! Elasticity evaluated by parts: each rank linearizes its own tets (its [`Part`] of the body,
//! with the same material code), then every rank's per-vertex contributions are summed in rank
//! order ([`sum_in_rank_order`]), so that every rank holds the same bits of the whole body's
//! forces, energy and counts and its replicated Newton takes the same decisions. Element
//! matrices go to an [`ElementSink`] (the distributed PETSc matrix), not to a local matrix.

use std::sync::{Arc, Mutex};

use super::partition::{Part, sum_in_rank_order};
use crate::elastic::{Damping, ElasticBody, Linearization, element_stiffness};
use crate::math::{Mat3, Vec3};

/// The collective operation the parts need: an all-gather (MPI_Allgatherv on a communicator;
/// one rank needs no MPI).
pub trait Gather: Send {
    /// This rank.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Every rank's `local` (rank r sends `counts[r]` numbers), one after another in rank
    /// order, into `out` on every rank.
    fn all_gather(&mut self, local: &[f64], counts: &[usize], out: &mut [f64]);
}

/// One rank, no communication.
#[derive(Debug, Default)]
pub struct Alone;

impl Gather for Alone {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn all_gather(&mut self, local: &[f64], _counts: &[usize], out: &mut [f64]) {
        out.copy_from_slice(local);
    }
}

/// Where the element stiffness matrices go.
pub trait ElementSink: Send {
    /// Start a new matrix (zero it).
    fn begin(&mut self);
    /// Add one tet's 12×12 matrix (row-major, rows and columns in corner order, x y z per
    /// corner) at the rows and columns of its (whole-mesh) vertices.
    fn add_element(&mut self, vertices: [usize; 4], values: &[f64; 144]);
}

/// The elasticity of one rank's part, with the exchange that makes whole-body sums of it.
pub struct PartitionedElasticity {
    rank: usize,
    parts: Vec<Part>,
    body: ElasticBody,
    gather: Box<dyn Gather>,
    sink: Arc<Mutex<dyn ElementSink>>,
    xl: Vec<Vec3>,
    fl: Vec<Vec3>,
    /// Damped steps: the local velocities and K_d·v.
    vl: Vec<Vec3>,
    kvl: Vec<Vec3>,
    blocks: Vec<Mat3>,
    send: Vec<f64>,
    recv: Vec<f64>,
    flat: Vec<f64>,
    bytes_sent: u64,
}

impl PartitionedElasticity {
    /// Rank `gather.rank()`'s part of `body`, given every rank's [`Part`].
    pub fn new(
        body: &ElasticBody,
        parts: Vec<Part>,
        gather: Box<dyn Gather>,
        sink: Arc<Mutex<dyn ElementSink>>,
    ) -> Self {
        let rank = gather.rank();
        assert_eq!(parts.len(), gather.size());
        let part = &parts[rank];
        let local = body.part(&part.tets, &part.vertices);
        let n = part.vertices.len();
        PartitionedElasticity {
            rank,
            body: local,
            gather,
            sink,
            xl: vec![Vec3::zeros(); n],
            fl: vec![Vec3::zeros(); n],
            vl: Vec::new(),
            kvl: Vec::new(),
            blocks: vec![Mat3::zeros(); n],
            send: Vec::new(),
            recv: Vec::new(),
            flat: vec![0.0; 9 * body.vertex_count()],
            bytes_sent: 0,
            parts,
        }
    }

    /// This rank's part of the body (local vertex numbering).
    pub fn body(&self) -> &ElasticBody {
        &self.body
    }

    /// Bytes this rank has sent in the exchanges so far.
    pub fn bytes_sent(&self) -> u64 {
        self.bytes_sent
    }

    fn local_of(&mut self, global: &[Vec3]) {
        let part = &self.parts[self.rank];
        for (l, &v) in self.xl.iter_mut().zip(&part.vertices) {
            *l = global[v];
        }
    }

    /// Sum every rank's `width` numbers per local vertex (in `self.send`) into `self.flat`.
    fn exchange(&mut self, width: usize) {
        let counts: Vec<usize> = self
            .parts
            .iter()
            .map(|p| width * p.vertices.len())
            .collect();
        let total: usize = counts.iter().sum();
        self.recv.resize(total, 0.0);
        self.gather.all_gather(&self.send, &counts, &mut self.recv);
        // An all-gather sends the local block to every other rank (the replicated state's
        // price; a ghosted state would send only the interface to its owners).
        self.bytes_sent += (8 * self.send.len() * (self.parts.len() - 1)) as u64;
        let n = self.flat.len() / 9;
        sum_in_rank_order(&self.parts, &self.recv, width, &mut self.flat[..width * n]);
    }

    fn exchange_vectors(&mut self, out: &mut [Vec3]) {
        self.send.clear();
        self.send
            .extend(self.fl.iter().flat_map(|v| [v.x, v.y, v.z]));
        self.exchange(3);
        for (i, o) in out.iter_mut().enumerate() {
            *o = Vec3::new(self.flat[3 * i], self.flat[3 * i + 1], self.flat[3 * i + 2]);
        }
    }

    /// Linearize this rank's tets at x (whole-mesh positions); `f_el` gets the whole body's
    /// elastic forces, `kv` (when damped) the whole body's K_d·v, `lin` this rank's tangents
    /// with the whole body's counts. Returns the whole body's elastic energy.
    pub fn evaluate(
        &mut self,
        x: &[Vec3],
        damping: Option<&Damping<'_>>,
        lin: &mut Linearization,
        f_el: &mut [Vec3],
        kv: &mut [Vec3],
    ) -> f64 {
        #[cfg(feature = "mpi")]
        super::setup::record(|s| s.evaluations += 1);
        self.local_of(x);
        let energy = match damping {
            None => self.body.linearize_into(&self.xl, lin, &mut self.fl),
            Some(damping) => {
                let mut vl = std::mem::take(&mut self.vl);
                vl.clear();
                vl.extend(
                    self.parts[self.rank]
                        .vertices
                        .iter()
                        .map(|&i| damping.velocities[i]),
                );
                let mut kvl = std::mem::take(&mut self.kvl);
                kvl.resize(vl.len(), Vec3::zeros());
                let local = Damping {
                    velocities: &vl,
                    ..*damping
                };
                let energy =
                    self.body
                        .linearize_damped_into(&self.xl, &local, lin, &mut self.fl, &mut kvl);
                self.vl = vl;
                self.kvl = kvl;
                energy
            }
        };
        self.exchange_vectors(f_el);
        if damping.is_some() {
            std::mem::swap(&mut self.fl, &mut self.kvl);
            self.exchange_vectors(kv);
            std::mem::swap(&mut self.fl, &mut self.kvl);
        }
        let counts = vec![3; self.parts.len()];
        let mine = [
            energy,
            lin.clamped_tets() as f64,
            lin.inverted_tets() as f64,
        ];
        self.recv.resize(3 * self.parts.len(), 0.0);
        self.gather.all_gather(&mine, &counts, &mut self.recv);
        self.bytes_sent += (24 * (self.parts.len() - 1)) as u64;
        let mut sums = [0.0; 3];
        for r in self.recv.chunks(3) {
            for k in 0..3 {
                sums[k] += r[k];
            }
        }
        lin.set_counts(sums[1] as usize, sums[2] as usize);
        sums[0]
    }

    /// `out = K·p` over the whole body.
    pub fn product(&mut self, lin: &mut Linearization, p: &[Vec3], out: &mut [Vec3]) {
        self.local_of(p);
        self.body.apply_stiffness(lin, &self.xl, &mut self.fl);
        self.exchange_vectors(out);
    }

    /// The whole body's 3×3 diagonal blocks of K.
    pub fn diagonal_blocks(&mut self, lin: &Linearization, out: &mut [Mat3]) {
        self.body.stiffness_diagonal_blocks(lin, &mut self.blocks);
        self.send.clear();
        self.send
            .extend(self.blocks.iter().flat_map(|b| b.iter().copied()));
        self.exchange(9);
        for (i, o) in out.iter_mut().enumerate() {
            *o = Mat3::from_column_slice(&self.flat[9 * i..9 * i + 9]);
        }
    }

    /// Send `scale·K_e` of this rank's tets, with the rows and columns of constrained DOFs
    /// (`free` = 0, whole-mesh mask) zeroed, to the sink.
    pub fn write_matrix(&mut self, lin: &Linearization, scale: f64, free: &[Vec3]) {
        let part = &self.parts[self.rank];
        let mut sink = self.sink.lock().expect("the matrix is not poisoned");
        sink.begin();
        let mut values = [0.0; 144];
        for (t, tet) in self.body.mesh.tets.iter().enumerate() {
            let k = element_stiffness(
                &lin.tangents()[t],
                &self.body.rest_inverses()[t],
                self.body.volumes()[t],
            );
            let global = tet.map(|l| part.vertices[l]);
            for a in 0..4 {
                for b in 0..4 {
                    let block = if a <= b {
                        k[upper(a, b)]
                    } else {
                        k[upper(b, a)].transpose()
                    };
                    for i in 0..3 {
                        for j in 0..3 {
                            let mask = free[global[a]][i] * free[global[b]][j];
                            values[(3 * a + i) * 12 + 3 * b + j] = scale * mask * block[(i, j)];
                        }
                    }
                }
            }
            sink.add_element(global, &values);
        }
    }
}

/// Index of block (a, b), a ≤ b, in [`element_stiffness`]'s upper triangle.
fn upper(a: usize, b: usize) -> usize {
    [0, 4, 7, 9][a] + b - a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Definiteness, Lame, Model, ModelKind};
    use crate::parallel::partition::Partition;

    /// A sink that assembles a dense matrix.
    struct Dense(usize, Vec<f64>);

    impl ElementSink for Dense {
        fn begin(&mut self) {
            self.1.iter_mut().for_each(|v| *v = 0.0);
        }
        fn add_element(&mut self, vertices: [usize; 4], values: &[f64; 144]) {
            let n = 3 * self.0;
            for a in 0..4 {
                for b in 0..4 {
                    for i in 0..3 {
                        for j in 0..3 {
                            self.1[(3 * vertices[a] + i) * n + 3 * vertices[b] + j] +=
                                values[(3 * a + i) * 12 + 3 * b + j];
                        }
                    }
                }
            }
        }
    }

    /// One rank holding the whole body: forces, energy, products and the element matrices sent
    /// to the sink are the serial body's.
    #[test]
    fn one_part_is_the_whole_body() {
        let mesh =
            crate::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [4, 2, 2]);
        let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
        let body = ElasticBody::new(mesh, model, 1000.0).unwrap();
        let n = body.vertex_count();
        let x: Vec<Vec3> = body
            .mesh
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| p + 0.02 * Vec3::new((i % 3) as f64, 0.0, -((i % 5) as f64)))
            .collect();
        let partition = Partition::new(&body.mesh, 1);
        let parts = vec![partition.part(&body.mesh, 0)];
        let sink = Arc::new(Mutex::new(Dense(n, vec![0.0; 9 * n * n])));
        let mut pe = PartitionedElasticity::new(&body, parts, Box::new(Alone), sink.clone());
        let mut lin = Linearization::new(pe.body(), Definiteness::Projected);
        let (mut f, mut kv) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
        let damping = Damping {
            velocities: &x,
            stiffness: crate::material::DampingStiffness::Projected,
            shift: 0.0,
            weight: 0.0,
        };
        let energy = pe.evaluate(&x, Some(&damping), &mut lin, &mut f, &mut kv);
        let mut serial_lin = body.linearize(&x, Definiteness::Projected);
        let mut serial = vec![Vec3::zeros(); n];
        body.add_forces(&x, &mut serial);
        assert!((energy - body.energy(&x)).abs() <= 1e-12 * energy.abs());
        let mut k_x = vec![Vec3::zeros(); n];
        body.apply_stiffness(&mut serial_lin, &x, &mut k_x);
        for i in 0..n {
            assert!((f[i] - serial[i]).norm() <= 1e-9 * (1.0 + serial[i].norm()));
            assert!((kv[i] - k_x[i]).norm() <= 1e-9 * (1.0 + k_x[i].norm()));
        }
        // The sink's matrix times x is K·x.
        let free = vec![Vec3::repeat(1.0); n];
        pe.write_matrix(&lin, 1.0, &free);
        let dense = &sink.lock().unwrap().1;
        for r in 0..3 * n {
            let row: f64 = (0..3 * n)
                .map(|c| dense[r * 3 * n + c] * x[c / 3][c % 3])
                .sum();
            assert!((row - k_x[r / 3][r % 3]).abs() <= 1e-8 * (1.0 + k_x[r / 3].norm()));
        }
    }
}
