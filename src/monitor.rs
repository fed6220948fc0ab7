//! Probes and reactions (SPEC §13): numbers a run records every frame besides its frames, for
//! force-displacement curves without post-processing the VTU files.
//!
//! - A [`Probe`] is a rest position inside the mesh: its displacement is interpolated with the
//!   tets' own shape functions (linear over four vertices, quadratic over ten nodes) in the tet
//!   that holds it, so a probe on a node reports that node's displacement. It goes to `probes.csv`.
//! - A [`ReactionGroup`] is a named `[[fixed]]` entry: the total force its constraint exerts on
//!   the body, Σ −f over its constrained components, where f is the sum of every force of the
//!   step's equation there (inertia `M(vⁿ − v)/h − αMv`, elasticity with its damping `−γKv`,
//!   gravity and loads, contact) at the converged state. The constraint supplies what keeps
//!   those components on their path, so in static equilibrium a clamp holding a hanging beam
//!   pulls up with the beam's weight (+m·g upward). It goes to `reactions.csv`. A vertex held by
//!   two named constraints counts in both; a component only while its constraint holds it.

use crate::elastic::ElasticBody;
use crate::math::Vec3;

/// How far outside its tet a probe point may lie and still count as inside, as a fraction of
/// the tet's height over the face it is beyond (a barycentric coordinate of −1e-3): points on
/// the surface, typed with fewer digits than the mesh file holds, are found; points a visible
/// distance away are refused.
pub const OUTSIDE_TOLERANCE: f64 = 1e-3;

/// A rest position and the tet that holds it, with its barycentric weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// Column prefix in probes.csv (`tip` → `tip_x,tip_y,tip_z`).
    pub name: String,
    /// The point at rest, m.
    pub point: Vec3,
    /// The tet holding it (the simulation's numbering).
    pub tet: usize,
    /// Barycentric weights of the tet's four vertices (sum 1).
    pub weights: [f64; 4],
}

impl Probe {
    /// Find the tet of `body` that holds `point` among `tets` (None: every tet): the one whose
    /// smallest barycentric coordinate is largest, accepted when that is at least
    /// −[`OUTSIDE_TOLERANCE`]. Refused with the distance to the nearest vertex otherwise.
    pub fn locate(
        name: &str,
        body: &ElasticBody,
        point: Vec3,
        tets: Option<&[usize]>,
    ) -> Result<Probe, String> {
        let mesh = &body.mesh;
        let bm = body.rest_inverses();
        let weights = |t: usize| -> [f64; 4] {
            let tet = mesh.tets[t];
            // Dm·(λ₁, λ₂, λ₃) = p − X₀ with Dm the rest edge matrix, and Bm = Dm⁻¹.
            let l = bm[t] * (point - mesh.positions[tet[0]]);
            [1.0 - l[0] - l[1] - l[2], l[0], l[1], l[2]]
        };
        let mut best: Option<(f64, usize)> = None;
        let mut consider = |t: usize| {
            let w = weights(t);
            let worst = w.iter().copied().fold(f64::INFINITY, f64::min);
            if best.is_none_or(|(b, _)| worst > b) {
                best = Some((worst, t));
            }
        };
        match tets {
            Some(list) => list.iter().for_each(|&t| consider(t)),
            None => (0..mesh.tets.len()).for_each(&mut consider),
        }
        match best {
            Some((worst, tet)) if worst >= -OUTSIDE_TOLERANCE => Ok(Probe {
                name: name.to_string(),
                point,
                tet,
                weights: weights(tet),
            }),
            Some((worst, tet)) => {
                // How far beyond the face of the closest tet: −λ / |∇λ| for its smallest λ.
                let w = weights(tet);
                let i = (0..4).min_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
                let b = bm[tet];
                let gradient = match i {
                    0 => -(b.row(0) + b.row(1) + b.row(2)),
                    i => b.row(i - 1).into_owned(),
                };
                let distance = -worst / gradient.norm();
                Err(outside(
                    point,
                    &format!("{distance:.3e} m beyond the closest tet's face"),
                ))
            }
            None => Err(outside(point, "the region holds no tets")),
        }
    }

    /// The displacement at the probe, m: Σ λᵢ (xᵢ − Xᵢ) over its tet's vertices, or over the
    /// ten nodes of a quadratic tet with its shape functions at λ (λ located in the straight
    /// tet of its corners).
    pub fn displacement(&self, body: &ElasticBody, x: &[Vec3]) -> Vec3 {
        let tet = body.mesh.tets[self.tet];
        let rest = &body.mesh.positions;
        if body.mesh.is_quadratic() {
            let n = crate::elastic::quadratic::shape_values(self.weights);
            return body
                .mesh
                .quadratic_nodes(self.tet)
                .iter()
                .zip(n)
                .fold(Vec3::zeros(), |u, (&v, w)| u + w * (x[v] - rest[v]));
        }
        tet.iter()
            .zip(self.weights)
            .fold(Vec3::zeros(), |u, (&v, w)| u + w * (x[v] - rest[v]))
    }
}

fn outside(point: Vec3, how_far: &str) -> String {
    format!(
        "[{}, {}, {}] m lies outside the mesh ({how_far}); a probe must be a rest position \
         inside a body or on its surface",
        point[0], point[1], point[2]
    )
}

/// A named `[[fixed]]` entry whose reaction goes to reactions.csv.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReactionGroup {
    /// Column prefix (`clamp` → `clamp_fx,clamp_fy,clamp_fz`).
    pub name: String,
    /// Index of its constraint in `Boundary::constraints`.
    pub constraint: usize,
}

/// Everything a run records besides frames: probes and reaction groups.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Monitors {
    /// Probes, in scene order.
    pub probes: Vec<Probe>,
    /// Named constraints, in scene order.
    pub reactions: Vec<ReactionGroup>,
}

impl Monitors {
    /// True when there is nothing to record (then no probes.csv or reactions.csv is written).
    pub fn is_empty(&self) -> bool {
        self.probes.is_empty() && self.reactions.is_empty()
    }

    /// probes.csv's header: `frame,time,tip_x,tip_y,tip_z,...`.
    pub fn probes_header(&self) -> String {
        header(self.probes.iter().map(|p| p.name.as_str()), ["x", "y", "z"])
    }

    /// reactions.csv's header: `frame,time,clamp_fx,clamp_fy,clamp_fz,...`.
    pub fn reactions_header(&self) -> String {
        header(
            self.reactions.iter().map(|r| r.name.as_str()),
            ["fx", "fy", "fz"],
        )
    }
}

fn header<'a>(names: impl Iterator<Item = &'a str>, suffixes: [&str; 3]) -> String {
    let mut columns = vec!["frame".to_string(), "time".to_string()];
    for name in names {
        columns.extend(suffixes.iter().map(|s| format!("{name}_{s}")));
    }
    columns.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Lame, Model, ModelKind};
    use crate::mesh::generate::box_mesh;

    fn cube() -> ElasticBody {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
        let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
        ElasticBody::new(mesh, model, 1000.0).unwrap()
    }

    #[test]
    fn a_probe_interpolates_a_linear_field_exactly() {
        let body = cube();
        let p = Probe::locate("a", &body, Vec3::new(1.3, 0.2, 0.7), None).unwrap();
        assert!((p.weights.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        // x = X + A·X + b: the displacement at the point is A·p + b wherever it is.
        let a = crate::math::Mat3::new(0.1, 0.2, 0.0, -0.3, 0.05, 0.1, 0.0, 0.4, -0.2);
        let b = Vec3::new(0.5, -1.0, 2.0);
        let x: Vec<Vec3> = body.mesh.positions.iter().map(|x| x + a * x + b).collect();
        let u = p.displacement(&body, &x);
        assert!((u - (a * p.point + b)).norm() < 1e-14, "{u}");
    }

    #[test]
    fn points_on_the_surface_are_in_and_points_outside_are_refused() {
        let body = cube();
        for on in [
            Vec3::new(2.0, 1.0, 1.0),
            Vec3::new(2.0, 0.5, 0.5),
            Vec3::zeros(),
        ] {
            assert!(Probe::locate("a", &body, on, None).is_ok(), "{on}");
        }
        let just = Vec3::new(2.0 + 1e-6, 0.5, 0.5);
        assert!(Probe::locate("a", &body, just, None).is_ok());
        let e = Probe::locate("a", &body, Vec3::new(2.1, 0.5, 0.5), None).unwrap_err();
        assert!(
            e.contains("outside the mesh") && e.contains("1.000e-1 m"),
            "{e}"
        );
    }

    #[test]
    fn headers_name_every_column() {
        let m = Monitors {
            probes: vec![],
            reactions: vec![
                ReactionGroup {
                    name: "clamp".into(),
                    constraint: 0,
                },
                ReactionGroup {
                    name: "pin".into(),
                    constraint: 2,
                },
            ],
        };
        assert_eq!(
            m.reactions_header(),
            "frame,time,clamp_fx,clamp_fy,clamp_fz,pin_fx,pin_fy,pin_fz"
        );
        assert_eq!(m.probes_header(), "frame,time");
    }
}
