//! The fields a picture can be coloured by (`[output] field`, `tetsim render --field`),
//! computed from an elastic body and positions, and the colour range over a whole run.
//!
//! Not behind the `render` feature: scene validation parses the field's name whether or not
//! this build can draw pictures; `render` re-exports everything here.

use std::fmt;
use std::str::FromStr;

use crate::elastic::ElasticBody;
use crate::error::{Error, Result};
use crate::math::Vec3;

mod rigid;
pub use rigid::{MotionSummary, RigidFit, relative_displacements};

/// What colours the surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FieldKind {
    /// |x − X|, the displacement magnitude per vertex (m), interpolated smoothly.
    Displacement,
    /// The displacement left when each body's best-fit rigid motion is taken away, per vertex
    /// (m): the deformation of a body that falls, slides or rolls (see [`RigidFit`]).
    RelativeDisplacement,
    /// |v|, the speed per vertex (m/s).
    Velocity,
    /// |f_c|, the contact force per vertex (N); zero without contact.
    ContactForce,
    /// J = det F per tet (dimensionless): < 1 compressed, > 1 stretched, ≤ 0 inverted.
    J,
    /// Von Mises equivalent of the Cauchy stress per tet (Pa).
    VonMises,
    /// Strain energy density Ψ(F) per tet (J/m³).
    EnergyDensity,
}

/// Where a field's values live.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldLocation {
    /// One value per vertex; smoothly interpolated across triangles.
    Vertex,
    /// One value per tet; every boundary face shows its tet's value (flat).
    Cell,
}

impl FieldKind {
    /// All kinds, in the order the command line lists them.
    pub const ALL: [FieldKind; 7] = [
        FieldKind::Displacement,
        FieldKind::RelativeDisplacement,
        FieldKind::Velocity,
        FieldKind::ContactForce,
        FieldKind::J,
        FieldKind::VonMises,
        FieldKind::EnergyDensity,
    ];

    /// Per vertex or per tet.
    pub fn location(self) -> FieldLocation {
        match self {
            FieldKind::Displacement
            | FieldKind::RelativeDisplacement
            | FieldKind::Velocity
            | FieldKind::ContactForce => FieldLocation::Vertex,
            _ => FieldLocation::Cell,
        }
    }

    /// The colour bar's label (without the unit).
    pub fn label(self) -> &'static str {
        match self {
            FieldKind::Displacement => "displacement |u|",
            FieldKind::RelativeDisplacement => "|u| less rigid motion",
            FieldKind::Velocity => "speed |v|",
            FieldKind::ContactForce => "contact force",
            FieldKind::J => "volume ratio J",
            FieldKind::VonMises => "von Mises stress",
            FieldKind::EnergyDensity => "energy density Ψ",
        }
    }

    /// The SI unit of the values ("" for dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            FieldKind::Displacement | FieldKind::RelativeDisplacement => "m",
            FieldKind::Velocity => "m/s",
            FieldKind::ContactForce => "N",
            FieldKind::J => "",
            FieldKind::VonMises => "Pa",
            FieldKind::EnergyDensity => "J/m³",
        }
    }

    /// The name used on the command line and in scene files.
    pub fn name(self) -> &'static str {
        match self {
            FieldKind::Displacement => "displacement",
            FieldKind::RelativeDisplacement => "relative-displacement",
            FieldKind::Velocity => "velocity",
            FieldKind::ContactForce => "contact-force",
            FieldKind::J => "J",
            FieldKind::VonMises => "von-mises",
            FieldKind::EnergyDensity => "energy-density",
        }
    }
}

impl fmt::Display for FieldKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for FieldKind {
    type Err = Error;

    /// Parses [`FieldKind::name`], case-insensitively, with `_` accepted for `-`.
    fn from_str(s: &str) -> Result<Self> {
        let wanted = s.trim().to_ascii_lowercase().replace('_', "-");
        FieldKind::ALL
            .into_iter()
            .find(|k| k.name().to_ascii_lowercase() == wanted)
            .ok_or_else(|| {
                let names: Vec<&str> = FieldKind::ALL.iter().map(|k| k.name()).collect();
                Error::parameter(
                    "render.field",
                    format!(
                        "unknown field \"{}\"; expected one of {}",
                        crate::error::clip(s),
                        names.join(", ")
                    ),
                )
            })
    }
}

/// |x − X| per vertex (m).
pub fn displacement_magnitudes(rest: &[Vec3], x: &[Vec3]) -> Vec<f64> {
    rest.iter().zip(x).map(|(r, p)| (p - r).norm()).collect()
}

/// The values of `kind` at positions `x`: one per vertex for the displacements (against the
/// body's rest positions, the relative one with one rigid fit for the whole body), one per tet
/// for J, Ψ and von Mises. Velocity and contact force are not functions of the positions: they
/// are read from a frame, and asking for them here is an error.
pub fn field_values(kind: FieldKind, body: &ElasticBody, x: &[Vec3]) -> Result<Vec<f64>> {
    Ok(match kind {
        FieldKind::Displacement => displacement_magnitudes(&body.mesh.positions, x),
        FieldKind::RelativeDisplacement => relative_displacements(&body.mesh.positions, x, &[]),
        FieldKind::J => body.jacobians(x),
        FieldKind::EnergyDensity => body.energy_densities(x),
        FieldKind::VonMises => body.von_mises_stresses(x),
        FieldKind::Velocity | FieldKind::ContactForce => {
            return Err(Error::parameter(
                "render.field",
                format!("{kind} is not a function of the positions; read it from a frame"),
            ));
        }
    })
}

/// What colours a run's pictures: a named field, none, or the one [`MotionSummary::choose`]
/// picks from what the run's bodies did (`"auto"`, the default).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FieldChoice {
    /// Chosen from the frames.
    #[default]
    Auto,
    /// No colour field: the surface in a neutral colour.
    None,
    /// This field.
    Kind(FieldKind),
}

impl FromStr for FieldChoice {
    type Err = Error;

    /// `auto`, `none` or a [`FieldKind`] name (as [`FieldKind::from_str`] reads it).
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(FieldChoice::Auto),
            "none" => Ok(FieldChoice::None),
            _ => s.parse::<FieldKind>().map(FieldChoice::Kind).map_err(|_| {
                let names: Vec<&str> = FieldKind::ALL.iter().map(|k| k.name()).collect();
                Error::parameter(
                    "render.field",
                    format!(
                        "unknown field \"{}\"; expected auto, none, {}",
                        crate::error::clip(s),
                        names.join(", ")
                    ),
                )
            }),
        }
    }
}

/// (min, max) over the finite values of every frame, for a colour range shared by the whole
/// run; (0, 0) when there is no finite value.
pub fn field_range<'a>(frames: impl IntoIterator<Item = &'a [f64]>) -> (f64, f64) {
    let mut range = (f64::INFINITY, f64::NEG_INFINITY);
    for values in frames {
        for &v in values.iter().filter(|v| v.is_finite()) {
            range = (range.0.min(v), range.1.max(v));
        }
    }
    if range.0 > range.1 { (0.0, 0.0) } else { range }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elastic::von_mises;
    use crate::math::Mat3;

    #[test]
    fn field_names_round_trip() {
        for kind in FieldKind::ALL {
            assert_eq!(kind.name().parse::<FieldKind>().unwrap(), kind);
        }
        assert_eq!(
            "Von_Mises".parse::<FieldKind>().unwrap(),
            FieldKind::VonMises
        );
        assert!("stress".parse::<FieldKind>().is_err());
    }

    #[test]
    fn von_mises_of_uniaxial_and_hydrostatic_stress() {
        // Uniaxial Cauchy stress σ₁₁ = 3 at F = I: σ_vM = 3.
        let p = Mat3::from_diagonal(&Vec3::new(3.0, 0.0, 0.0));
        assert!((von_mises(&p, &Mat3::identity()) - 3.0).abs() < 1e-12);
        // Pure pressure has no deviator.
        assert!(von_mises(&(Mat3::identity() * 7.0), &Mat3::identity()) < 1e-12);
        // Inverted F stays finite.
        let f = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0));
        assert!(von_mises(&p, &f).is_finite());
    }

    #[test]
    fn range_skips_non_finite() {
        let a = [1.0, f64::NAN, 3.0];
        let b = [-2.0, f64::INFINITY];
        assert_eq!(field_range([&a[..], &b[..]]), (-2.0, 3.0));
        assert_eq!(field_range([&[f64::NAN][..]]), (0.0, 0.0));
    }
}
