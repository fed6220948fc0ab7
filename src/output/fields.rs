//! The per-tet fields a frame writes (J, Ψ and von Mises), in one pass with one SVD of F per
//! tet, the SVDs made [`LANES`] at a time: the same bits as [`ElasticBody::jacobians`],
//! [`ElasticBody::energy_densities`] and [`ElasticBody::von_mises_stresses`], which make the
//! SVD twice, one tet at a time (Ψ and P of an invertible model read only F's SVD).

use rayon::prelude::*;

use crate::elastic::{ElasticBody, von_mises};
use crate::material::Material;
use crate::material::isotropic::{Invertible, Isotropic};
use crate::material::linear::LinearElastic;
use crate::math::{LANES, Mat3, Svd, Vec3, svd_rv, svd_rv_lanes_into};

/// Tets per parallel task.
const CHUNK: usize = 512;

/// Ψ(F) and P(F) of one model, from F's SVD where the model reads one.
trait EnergyAndStress {
    fn energy_and_stress(&self, f: &Mat3, svd: &Svd) -> (f64, Mat3);
}

impl<M: Isotropic> EnergyAndStress for Invertible<M> {
    fn energy_and_stress(&self, _: &Mat3, svd: &Svd) -> (f64, Mat3) {
        let p = svd.u * Mat3::from_diagonal(&self.model.dpsi(&svd.sigma)) * svd.v.transpose();
        (self.model.psi(&svd.sigma), p)
    }
}

impl EnergyAndStress for LinearElastic {
    fn energy_and_stress(&self, f: &Mat3, _: &Svd) -> (f64, Mat3) {
        (self.energy_density(f), self.stress(f))
    }
}

/// (J, Ψ in J/m³, von Mises in Pa) per tet at positions `x` (the body's numbering).
pub(super) fn tet_fields(body: &ElasticBody, x: &[Vec3]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    if body.quadratic().is_some() {
        // Per quadrature point, reduced per tet by the body.
        return (
            body.jacobians(x),
            body.energy_densities(x),
            body.von_mises_stresses(x),
        );
    }
    let n = body.tet_count();
    let (mut j, mut psi, mut vm) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    j.par_chunks_mut(CHUNK)
        .zip(psi.par_chunks_mut(CHUNK))
        .zip(vm.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, ((j, psi), vm))| {
            let start = c * CHUNK;
            let zero = Svd {
                u: Mat3::zeros(),
                sigma: Vec3::zeros(),
                v: Mat3::zeros(),
            };
            let mut svds = [zero; LANES];
            let mut f = [Mat3::zeros(); LANES];
            for group in (0..j.len()).step_by(LANES) {
                let lanes = LANES.min(j.len() - group);
                for (l, f) in f.iter_mut().enumerate().take(lanes) {
                    *f = body.deformation_gradient(x, start + group + l);
                }
                if lanes == LANES {
                    svd_rv_lanes_into(&f, &mut svds);
                } else {
                    for (svd, f) in svds.iter_mut().zip(&f).take(lanes) {
                        *svd = svd_rv(f);
                    }
                }
                for l in 0..lanes {
                    let (k, t) = (group + l, start + group + l);
                    let (e, p) = crate::with_model!(body.model_of(t), m => {
                        m.energy_and_stress(&f[l], &svds[l])
                    });
                    j[k] = f[l].determinant();
                    psi[k] = e;
                    vm[k] = von_mises(&p, &f[l]);
                }
            }
        });
    (j, psi, vm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::sim::Simulation;

    /// Every model, on a beam bent, squashed and with a tet turned inside out: the bits of the
    /// body's own per-field functions.
    #[test]
    fn one_svd_per_tet_gives_the_bits_of_the_field_functions() {
        for model in [
            "neo-hookean",
            "corotated",
            "stable-neo-hookean",
            "st-venant-kirchhoff",
            "mooney-rivlin",
            "linear",
        ] {
            let text = format!(
                "[mesh]\ngenerator = {{ box = {{ min = [0, 0, 0], max = [2, 1, 1], cells = [5, 2, 3] }} }}\n\
                 [material]\nmodel = \"{model}\"\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\n"
            );
            let scene = Scene::parse(
                &text,
                std::path::Path::new("t.toml"),
                std::path::Path::new("."),
            )
            .unwrap();
            let sim = Simulation::from_scene(&scene).unwrap();
            let body = &sim.body;
            let x: Vec<Vec3> = body
                .mesh
                .positions
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let s = (i as f64 * 0.37).sin();
                    Vec3::new(
                        p.x * (1.0 + 0.3 * s),
                        p.y * (0.4 - 0.7 * p.x),
                        p.z + 0.2 * s,
                    )
                })
                .collect();
            let (j, psi, vm) = tet_fields(body, &x);
            assert!(j.iter().any(|&j| j < 0.0), "{model}: no inverted tet");
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&j), bits(&body.jacobians(&x)), "{model}: J");
            assert_eq!(bits(&psi), bits(&body.energy_densities(&x)), "{model}: Ψ");
            assert_eq!(
                bits(&vm),
                bits(&body.von_mises_stresses(&x)),
                "{model}: von Mises"
            );
        }
    }
}
