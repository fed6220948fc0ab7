//! Forces and tangents of a step with Rayleigh stiffness damping: the damping force −γ K_d(x) v from the same SVD as the stress, and Newton's tangents of K_n + w·K_d, shifted along v.

use super::*;

impl ElasticBody {
    /// [`ElasticBody::linearize_into`] with Rayleigh stiffness damping: also write
    /// `kv = K_d(x)·v` (overwrite), K_d the damping stiffness of `damping` at x. The tangents
    /// `lin` keeps for Newton are those of `K_n + w·K_d` (K_n by `lin`'s definiteness strategy,
    /// w = `damping.weight`) at `x + damping.shift·v`, so the stiffness products and matrices
    /// made from `lin` are Newton's whole (elastic + damping) tangent. One SVD per tet, two with
    /// a shift: [`ElasticBody::damped_forces_into`], then [`ElasticBody::damped_tangents_into`].
    pub fn linearize_damped_into(
        &self,
        x: &[Vec3],
        damping: &Damping<'_>,
        lin: &mut Linearization,
        forces: &mut [Vec3],
        kv: &mut [Vec3],
    ) -> f64 {
        let energy = self.damped_forces_into(x, damping, lin, forces, kv);
        self.damped_tangents_into(x, damping, lin);
        energy
    }

    /// The forces half of [`ElasticBody::linearize_damped_into`]: energy, `forces` and `kv`
    /// (overwritten). Without a shift Newton's tangents come from the same SVD and are filled
    /// too; with one they are left for [`ElasticBody::damped_tangents_into`] (an iterate that
    /// turns out converged, or a rejected line-search trial, never needs them).
    pub fn damped_forces_into(
        &self,
        x: &[Vec3],
        damping: &Damping<'_>,
        lin: &mut Linearization,
        forces: &mut [Vec3],
        kv: &mut [Vec3],
    ) -> f64 {
        assert_eq!(x.len(), self.vertex_count());
        assert_eq!(damping.velocities.len(), self.vertex_count());
        assert_eq!(kv.len(), self.vertex_count());
        assert_eq!(lin.tangents.len(), self.point_count());
        match self.quadratic() {
            Some(q) => self.quadratic_damped_forces_into(q, x, damping, lin, forces, kv),
            None => self.linear_damped_forces_into(x, damping, lin, forces, kv),
        }
        let shifted = damping.shift != 0.0;
        lin.tangents_pending = shifted;
        if !shifted {
            lin.exact_active = false;
            lin.count_tets();
        }
        lin.chunk_energy.iter().sum()
    }

    /// The linear tets' pass of [`ElasticBody::damped_forces_into`].
    fn linear_damped_forces_into(
        &self,
        x: &[Vec3],
        damping: &Damping<'_>,
        lin: &mut Linearization,
        forces: &mut [Vec3],
        kv: &mut [Vec3],
    ) {
        if lin.damping.len() != self.tet_count() {
            lin.damping = vec![[Vec3::zeros(); 3]; self.tet_count()];
        }
        let how = damping.tangent(lin.definiteness);
        let shifted = damping.shift != 0.0;
        // One tet, given F and its SVD: its force and K_d·v slots, and without a shift Newton's
        // tangent and `adaptive`'s exact pieces (written in place: returned by value they were
        // copied); returns W·Ψ.
        let kernel = |t: usize,
                      f: &Mat3,
                      svd: &Svd,
                      slot: &mut TetSlot,
                      kv: &mut TetSlot,
                      tangent: &mut Tangent,
                      exact: Option<&mut DiagonalPieces>| {
            let (bm, w) = (&self.bm[t], self.volume[t]);
            let df_v = TetMesh::edge_matrix(damping.velocities, &self.mesh.tets[t]) * bm;
            let model = self.model_of(t);
            let (psi, stress, dp) = if shifted {
                model.damping_stress_svd(f, svd, &df_v, how.damping)
            } else {
                let e = model.evaluate_damped_unshifted(f, svd, &df_v, &how);
                *tangent = e.tangent;
                if let Some(exact) = exact {
                    *exact = e.exact;
                }
                (e.psi, e.stress, e.damping)
            };
            *slot = slot_of(tet_forces(&stress, bm, w));
            // K_d·v = −(the force differential along v), as in `apply_stiffness`.
            *kv = slot_of(tet_forces(&(-dp), bm, w));
            w * psi
        };
        let svd = self.uses_svd();
        let alternate = alternate_chunks(&mut lin.alternate, lin.tangents.len());
        lin.tangents
            .par_chunks_mut(CHUNK)
            .zip(lin.buffer.par_chunks_mut(CHUNK))
            .zip(lin.damping.par_chunks_mut(CHUNK))
            .zip(lin.chunk_energy.par_iter_mut())
            .zip(alternate)
            .enumerate()
            .for_each(|(c, ((((tangents, buffer), kv), energy), mut alternate))| {
                let first = c * CHUNK;
                let mut sum = 0.0;
                let f_of = |k: usize| self.deformation_gradient(x, first + k);
                self.with_svds(svd, tangents.len(), f_of, |k, f, s| {
                    let exact = alternate.as_deref_mut().map(|a| &mut a[k]);
                    sum += kernel(
                        first + k,
                        f,
                        s,
                        &mut buffer[k],
                        &mut kv[k],
                        &mut tangents[k],
                        exact,
                    );
                });
                *energy = sum;
            });
        self.incidence.gather(&lin.buffer, forces, false);
        self.incidence.gather(&lin.damping, kv, false);
    }

    /// The tangents half of [`ElasticBody::linearize_damped_into`]: Newton's tangents at
    /// `x + damping.shift·v`, if [`ElasticBody::damped_forces_into`] left them (`x` and
    /// `damping` must be the same as there). Nothing to do otherwise.
    pub fn damped_tangents_into(&self, x: &[Vec3], damping: &Damping<'_>, lin: &mut Linearization) {
        if !lin.tangents_pending {
            return;
        }
        assert_eq!(x.len(), self.vertex_count());
        assert_eq!(damping.velocities.len(), self.vertex_count());
        let how = damping.tangent(lin.definiteness);
        let quadratic = self.quadratic();
        // Points per tet: a linear tet is its own one point.
        let per_tet = quadratic.map_or(1, |_| super::quadratic::POINTS);
        // G = F + θ·dF_v at point p; its SVDs are made in batches.
        let g_of = |p: usize| {
            let (f, df_v) = match quadratic {
                Some(q) => (
                    q.deformation_gradient(x, p),
                    q.deformation_gradient(damping.velocities, p),
                ),
                None => (
                    self.deformation_gradient(x, p),
                    TetMesh::edge_matrix(damping.velocities, &self.mesh.tets[p]) * self.bm[p],
                ),
            };
            crate::material::shifted_deformation(&f, &df_v, damping.shift)
        };
        let svd = self.uses_svd();
        let alternate = alternate_chunks(&mut lin.alternate, lin.tangents.len());
        lin.tangents
            .par_chunks_mut(CHUNK)
            .zip(alternate)
            .enumerate()
            .for_each(|(c, (tangents, mut alternate))| {
                let first = c * CHUNK;
                let g_in_chunk = |k: usize| g_of(first + k);
                self.with_svds(svd, tangents.len(), g_in_chunk, |k, g, s| {
                    let exact = alternate.as_deref_mut().map(|a| &mut a[k]);
                    self.model_of((first + k) / per_tet)
                        .damped_tangent_svd_into(g, s, &how, &mut tangents[k], exact);
                });
            });
        lin.tangents_pending = false;
        lin.exact_active = false;
        lin.count_tets();
    }
}

/// `adaptive`'s alternate pieces by chunks of [`CHUNK`] tets, or `None` for every chunk of
/// `tets` when the strategy keeps none (`alternate` empty): one loop serves both.
pub(super) fn alternate_chunks(
    alternate: &mut [DiagonalPieces],
    tets: usize,
) -> impl IndexedParallelIterator<Item = Option<&mut [DiagonalPieces]>> {
    let chunks = tets.div_ceil(CHUNK);
    let kept = alternate.len().div_ceil(CHUNK);
    alternate
        .par_chunks_mut(CHUNK)
        .map(Some)
        .chain(rayon::iter::repeat_n((), chunks - kept).map(|_| None))
}
