//! The body's kernels for quadratic tets: the linear-tet passes of `elastic.rs`, `damped.rs`
//! and `assembly.rs` with a quadrature point in place of a tet (see [`quadratic`]). Chunks
//! hold [`CHUNK`] points (a whole number of tets), so the sums keep a fixed order and the
//! results are the same bits for any thread count.

use super::quadratic::{POINTS, QuadraticElements, Slot10, upper_index10};
use super::*;

/// Tets per chunk of [`CHUNK`] points.
const TETS_PER_CHUNK: usize = CHUNK / POINTS;

impl ElasticBody {
    /// The quadratic rest data, if the tets are quadratic.
    pub fn quadratic(&self) -> Option<&QuadraticElements> {
        self.quadratic.as_deref()
    }

    /// Quadrature points (one per linear tet, [`POINTS`] per quadratic one): the unit of the
    /// tangents a [`Linearization`] keeps and of its counts of clamped and inverted elements.
    pub fn point_count(&self) -> usize {
        match &self.quadratic {
            Some(_) => POINTS * self.tet_count(),
            None => self.tet_count(),
        }
    }

    /// Per-point values `each(t, F)` of a quadratic body, reduced per tet by `reduce` over its
    /// points (weights given).
    pub(super) fn per_tet_of_points<T: Send + Copy>(
        &self,
        q: &QuadraticElements,
        x: &[Vec3],
        each: impl Fn(usize, &Mat3) -> T + Sync,
        reduce: impl Fn(&[(f64, T)]) -> T + Sync,
    ) -> Vec<T> {
        (0..self.tet_count())
            .into_par_iter()
            .with_min_len(TETS_PER_CHUNK)
            .map(|t| {
                let values: [(f64, T); POINTS] = std::array::from_fn(|k| {
                    let p = POINTS * t + k;
                    (q.weights[p], each(t, &q.deformation_gradient(x, p)))
                });
                reduce(&values)
            })
            .collect()
    }

    /// Elastic energy Σ_points w Ψ(F) of a quadratic body.
    pub(super) fn quadratic_energy(&self, q: &QuadraticElements, x: &[Vec3]) -> f64 {
        use crate::material::Material;
        let chunks: Vec<f64> = (0..self.point_count())
            .into_par_iter()
            .chunks(CHUNK)
            .map(|ps| {
                ps.iter()
                    .map(|&p| {
                        q.weights[p]
                            * self
                                .model_of(p / POINTS)
                                .energy_density(&q.deformation_gradient(x, p))
                    })
                    .sum::<f64>()
            })
            .collect();
        chunks.iter().sum()
    }

    /// `f += f_el(x)` for a quadratic body.
    pub(super) fn quadratic_add_forces(&self, q: &QuadraticElements, x: &[Vec3], f: &mut [Vec3]) {
        let mut buffer = vec![[Vec3::zeros(); 9]; self.tet_count()];
        buffer
            .par_iter_mut()
            .enumerate()
            .with_min_len(TETS_PER_CHUNK)
            .for_each(|(t, slot)| {
                for k in 0..POINTS {
                    let p = POINTS * t + k;
                    let stress = crate::material::Material::stress(
                        self.model_of(t),
                        &q.deformation_gradient(x, p),
                    );
                    q.add_point_forces(p, &stress, slot);
                }
            });
        q.gather(&buffer, f, true);
    }

    /// [`ElasticBody::linearize_into`] for a quadratic body: one SVD per point.
    pub(super) fn quadratic_linearize_into(
        &self,
        q: &QuadraticElements,
        x: &[Vec3],
        definiteness: Definiteness,
        lin: &mut Linearization,
        forces: &mut [Vec3],
    ) {
        let svd = self.uses_svd();
        lin.tangents
            .par_chunks_mut(CHUNK)
            .zip(lin.buffer10.par_chunks_mut(TETS_PER_CHUNK))
            .zip(lin.chunk_energy.par_iter_mut())
            .enumerate()
            .for_each(|(c, ((tangents, buffer), energy))| {
                let first = c * CHUNK;
                let mut sum = 0.0;
                let f_of = |k: usize| q.deformation_gradient(x, first + k);
                self.with_svds(svd, tangents.len(), f_of, |k, f, s| {
                    let p = first + k;
                    let (psi, stress, tan) =
                        self.model_of(p / POINTS).evaluate_svd(f, s, definiteness);
                    sum += q.weights[p] * psi;
                    let slot = &mut buffer[k / POINTS];
                    if k % POINTS == 0 {
                        *slot = [Vec3::zeros(); 9];
                    }
                    q.add_point_forces(p, &stress, slot);
                    tangents[k] = tan;
                });
                *energy = sum;
            });
        q.gather(&lin.buffer10, forces, false);
    }

    /// `out = K·dx` for a quadratic body.
    pub(super) fn quadratic_apply_stiffness(
        &self,
        q: &QuadraticElements,
        lin: &mut Linearization,
        dx: &[Vec3],
        out: &mut [Vec3],
    ) {
        let tangents = &lin.tangents;
        lin.buffer10
            .par_chunks_mut(TETS_PER_CHUNK)
            .enumerate()
            .for_each(|(c, buffer)| {
                for (k, slot) in buffer.iter_mut().enumerate() {
                    let t = c * TETS_PER_CHUNK + k;
                    *slot = [Vec3::zeros(); 9];
                    for i in 0..POINTS {
                        let p = POINTS * t + i;
                        let dp = tangents[p].apply(&q.deformation_gradient(dx, p));
                        // K·dx = −df: the force kernel with the sign flipped.
                        q.add_point_forces(p, &(-dp), slot);
                    }
                }
            });
        q.gather(&lin.buffer10, out, false);
    }

    /// The 3×3 diagonal blocks of K of a quadratic body.
    pub(super) fn quadratic_diagonal_blocks(
        &self,
        q: &QuadraticElements,
        lin: &Linearization,
        out: &mut [Mat3],
    ) {
        let inc = &q.incidence;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(v, block)| {
                let mut sum = Mat3::zeros();
                for &slot in &inc.slots[inc.offsets[v] as usize..inc.offsets[v + 1] as usize] {
                    let (t, a) = (slot as usize / 10, slot as usize % 10);
                    for i in 0..POINTS {
                        let p = POINTS * t + i;
                        let b = q.grads[p][a];
                        for j in 0..3 {
                            let mut df = Mat3::zeros();
                            df.set_row(j, &b.transpose());
                            let column = q.weights[p] * (lin.tangents[p].apply(&df) * b);
                            sum.set_column(j, &(sum.column(j) + column));
                        }
                    }
                }
                *block = sum;
            });
    }

    /// `a (+)= scale·K` of a quadratic body (see [`ElasticBody::write_stiffness`]).
    pub(super) fn quadratic_write_stiffness(
        &self,
        q: &QuadraticElements,
        lin: &Linearization,
        scale: f64,
        a: &mut BlockCsr,
        work: &mut AssemblyWork,
        overwrite: bool,
    ) {
        let element = |t: usize| q.element_stiffness(t, &lin.tangents);
        assembly::write_elements(&q.nodes, element, upper_index10, scale, a, work, overwrite);
    }

    /// [`ElasticBody::damped_forces_into`] for a quadratic body: the forces, `K_d·v` and (without
    /// a shift) Newton's tangents, per point.
    pub(super) fn quadratic_damped_forces_into(
        &self,
        q: &QuadraticElements,
        x: &[Vec3],
        damping: &Damping<'_>,
        lin: &mut Linearization,
        forces: &mut [Vec3],
        kv: &mut [Vec3],
    ) {
        if lin.damping10.len() != self.tet_count() {
            lin.damping10 = vec![[Vec3::zeros(); 9]; self.tet_count()];
        }
        let how = damping.tangent(lin.definiteness);
        let shifted = damping.shift != 0.0;
        let svd = self.uses_svd();
        let alternate = damped::alternate_chunks(&mut lin.alternate, lin.tangents.len());
        lin.tangents
            .par_chunks_mut(CHUNK)
            .zip(lin.buffer10.par_chunks_mut(TETS_PER_CHUNK))
            .zip(lin.damping10.par_chunks_mut(TETS_PER_CHUNK))
            .zip(lin.chunk_energy.par_iter_mut())
            .zip(alternate)
            .enumerate()
            .for_each(
                |(c, ((((tangents, buffer), kvs), energy), mut alternate))| {
                    let first = c * CHUNK;
                    let mut sum = 0.0;
                    let f_of = |k: usize| q.deformation_gradient(x, first + k);
                    self.with_svds(svd, tangents.len(), f_of, |k, f, s| {
                        let p = first + k;
                        let df_v = q.deformation_gradient(damping.velocities, p);
                        let model = self.model_of(p / POINTS);
                        let (psi, stress, dp) = if shifted {
                            model.damping_stress_svd(f, s, &df_v, how.damping)
                        } else {
                            let e = model.evaluate_damped_unshifted(f, s, &df_v, &how);
                            tangents[k] = e.tangent;
                            if let Some(a) = alternate.as_deref_mut() {
                                a[k] = e.exact;
                            }
                            (e.psi, e.stress, e.damping)
                        };
                        sum += q.weights[p] * psi;
                        let (slot, kv) = (&mut buffer[k / POINTS], &mut kvs[k / POINTS]);
                        if k % POINTS == 0 {
                            *slot = [Vec3::zeros(); 9];
                            *kv = [Vec3::zeros(); 9];
                        }
                        q.add_point_forces(p, &stress, slot);
                        q.add_point_forces(p, &(-dp), kv);
                    });
                    *energy = sum;
                },
            );
        q.gather(&lin.buffer10, forces, false);
        q.gather(&lin.damping10, kv, false);
    }
}

/// Slot buffers of a quadratic body (empty for a linear one).
pub(super) fn slots10(body: &ElasticBody) -> Vec<Slot10> {
    match &body.quadratic {
        Some(_) => vec![[Vec3::zeros(); 9]; body.tet_count()],
        None => Vec::new(),
    }
}
