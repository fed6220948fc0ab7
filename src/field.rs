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

/// What colours the surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FieldKind {
    /// |x − X|, the displacement magnitude per vertex (m), interpolated smoothly.
    Displacement,
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
    pub const ALL: [FieldKind; 4] = [
        FieldKind::Displacement,
        FieldKind::J,
        FieldKind::VonMises,
        FieldKind::EnergyDensity,
    ];

    /// Per vertex or per tet.
    pub fn location(self) -> FieldLocation {
        match self {
            FieldKind::Displacement => FieldLocation::Vertex,
            _ => FieldLocation::Cell,
        }
    }

    /// The colour bar's label (without the unit).
    pub fn label(self) -> &'static str {
        match self {
            FieldKind::Displacement => "displacement |u|",
            FieldKind::J => "volume ratio J",
            FieldKind::VonMises => "von Mises stress",
            FieldKind::EnergyDensity => "energy density Ψ",
        }
    }

    /// The SI unit of the values ("" for dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            FieldKind::Displacement => "m",
            FieldKind::J => "",
            FieldKind::VonMises => "Pa",
            FieldKind::EnergyDensity => "J/m³",
        }
    }

    /// The name used on the command line and in scene files.
    pub fn name(self) -> &'static str {
        match self {
            FieldKind::Displacement => "displacement",
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

/// The values of `kind` at positions `x`: one per vertex for [`FieldKind::Displacement`]
/// (against the body's rest positions), one per tet otherwise.
pub fn field_values(kind: FieldKind, body: &ElasticBody, x: &[Vec3]) -> Vec<f64> {
    match kind {
        FieldKind::Displacement => displacement_magnitudes(&body.mesh.positions, x),
        FieldKind::J => body.jacobians(x),
        FieldKind::EnergyDensity => body.energy_densities(x),
        FieldKind::VonMises => body.von_mises_stresses(x),
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
