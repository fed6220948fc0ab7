//! The fields a picture can be coloured by, computed from an elastic body and positions, and
//! the colour range over a whole run.

use super::FieldKind;
use crate::elastic::ElasticBody;
use crate::math::Vec3;

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
