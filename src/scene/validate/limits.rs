//! The caps every value meets, whatever path it comes by: a scene key, a mesh or positions
//! file after its unit, a value derived from others, or a setter between frames.

/// The largest magnitude a value of this unit may have: far beyond any physical scene, and low
/// enough that products of a few such values (ρ·v²·V, E·ℓ², m·x/h²) stay far from f64's 1.8e308,
/// so that a typo like `1e308` is refused at its key instead of running to inf or NaN.
pub(super) fn limit(unit: &str) -> f64 {
    match unit {
        "m" => 1e9,
        "m/s" => 1e8,
        "m/s²" => 1e9,
        "Pa" => 1e15,
        "N" => 1e20,
        "kg/m³" => 1e8,
        "s" | "s, or a load factor" => 1e12,
        "1/s" => 1e9,
        "degrees" => 1e9,
        "a Coulomb coefficient" => 1e3,
        _ => 1e15,
    }
}

/// The first point (index, position) beyond the length cap (1e9 m, as for every length in a
/// scene): a mesh file or a positions file in `unit = "Tm"`, or a body scaled far beyond any
/// scene, is refused before its numbers overflow during the run.
pub(crate) fn beyond_length_cap(points: &[crate::math::Vec3]) -> Option<String> {
    let max = limit("m");
    let (i, p) = points
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|c| c.abs() <= max))?;
    Some(format!(
        "vertex {} is at [{:e}, {:e}, {:e}] m, beyond the {max:.0e} m any length in a scene \
         may have (is the unit or scale right?)",
        i + 1,
        p.x,
        p.y,
        p.z
    ))
}

/// Rayleigh coefficients derived from a damping ratio, against the caps of the keys they fill
/// (`rayleigh_mass`, 1/s; `rayleigh_stiffness`, s): a ratio at absurd frequencies must not
/// give what those keys would refuse. The problem in words, if any.
pub(crate) fn derived_damping_problem(zeta: f64, f1: f64, f2: f64) -> Option<String> {
    let (alpha, gamma) = crate::modes::rayleigh_from_ratio(zeta, f1, f2);
    [
        ("rayleigh_mass", alpha, "1/s"),
        ("rayleigh_stiffness", gamma, "s"),
    ]
    .into_iter()
    .find(|(_, value, unit)| value.is_nan() || value.abs() > limit(unit))
    .map(|(name, value, unit)| {
        format!(
            "damping ratio {zeta} at [{f1:e}, {f2:e}] Hz gives {name} = {value:.3e} {unit}, \
                 beyond the {:.0e} {unit} that key accepts: choose frequencies the body can \
                 vibrate at",
            limit(unit)
        )
    })
}

/// Why `value` is refused when its magnitude is beyond its unit's [`limit`] (NaN and inf are
/// left to the callers' own checks). The library's setters between frames (`sim::control`) use
/// it too, so a value set from code meets the cap and the words of the same key in a scene.
pub(crate) fn beyond_limit(value: f64, unit: &str) -> Option<String> {
    let max = limit(unit);
    (value.is_finite() && value.abs() > max).then(|| {
        format!(
            "{value:e} is beyond any physical value: at most {max:.0e} ({unit}) is accepted, as \
             larger values overflow double precision during the run"
        )
    })
}

/// Whether `v` can be normalised: its length neither zero, nor underflowing to zero
/// (`[1e-320, 0, 0]`), nor overflowing.
pub(super) fn has_direction(v: [f64; 3]) -> bool {
    let length = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    length > 0.0 && length.is_finite()
}
