//! Quantities with units in scene files (SPEC §13): every number-valued key also takes a string
//! `"<number> <unit>"` (`"1.2 MPa"`, `"5 mm"`, `"1100 kg/m^3"`, `"45 deg"`), arrays element by
//! element, converted to the key's SI unit when the scene is read. A bare number keeps its SI
//! meaning, untouched.
//!
//! **Why hand-written.** The mature Rust units crate (`uom`) checks dimensions at compile time and
//! cannot parse a unit string at run time; the run-time parsers on crates.io (physical-quantity,
//! iridium-units, dimensional_analyser, const-units) are young (0.0.x–0.2), and the lenient ones
//! accept things this parser must refuse. What a scene needs is small: four base dimensions
//! (m, kg, s, rad: an angle is its own dimension so that `"45 deg"` is refused where a plain
//! ratio is meant), a table of units and prefixes, and products, one quotient and integer
//! powers. Writing it also gives exact conversions: a unit's power of ten is applied to the
//! number's decimal text before it is converted to binary, so `"5 mm"` is the same f64 as
//! `0.005` and `"1.2 MPa"` the same as `1.2e6`, bit for bit.
//!
//! **Grammar.** `number [space] unit`, the unit being terms joined by `*`, `·` or spaces, with at
//! most one `/` (everything after it is the denominator: `"W/m K"` is W/(m·K)). A term is a
//! symbol with an optional SI prefix and an optional integer power (`m^3`, `s^-2`, `m³`, `s⁻¹`);
//! `1` stands for nothing (`"2 1/s"`). Symbols and prefixes are **case-sensitive**, as SI writes
//! them: `M` is mega and `m` milli (`"5 MPa"` ≠ `"5 mPa"`), and `"5 mpa"` or `"5 Mpa"` is an
//! unknown unit. Units: m, g, s, N, Pa, J, W, Hz, rad, deg (also °), bar, L; prefixes from
//! T (10¹²) to p (10⁻¹²) with µ (or u) for micro; none on deg.
//!
//! **What is refused**: an unknown symbol, a unit of another dimension than the key's (a
//! force for a traction, `"1 MPa m"` for a pressure, `"2 rad/s"` for a frequency in Hz: the
//! angle does not cancel), a number that does not parse or is not finite, and a unit string
//! where the key takes a count (`frames`, `cells`: counts have no unit).

use std::f64::consts::PI;
use std::fmt;
use std::marker::PhantomData;

use serde::Deserialize;
use serde::de::{self, Deserializer, Visitor};

/// Exponents of metre, kilogram, second and radian.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dim([i8; 4]);

impl Dim {
    const NONE: Dim = Dim([0, 0, 0, 0]);
    const LENGTH: Dim = Dim([1, 0, 0, 0]);
    const MASS: Dim = Dim([0, 1, 0, 0]);
    const TIME: Dim = Dim([0, 0, 1, 0]);
    const ANGLE: Dim = Dim([0, 0, 0, 1]);

    fn times(self, other: Dim, power: i8) -> Dim {
        let mut d = self.0;
        for (d, o) in d.iter_mut().zip(other.0) {
            *d = d.saturating_add(o.saturating_mul(power));
        }
        Dim(d)
    }
}

impl fmt::Display for Dim {
    /// In base units: `kg m^-1 s^-2`; `1` when dimensionless.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        for (symbol, e) in [
            ("kg", self.0[1]),
            ("m", self.0[0]),
            ("s", self.0[2]),
            ("rad", self.0[3]),
        ] {
            match e {
                0 => {}
                1 => parts.push(symbol.to_string()),
                e => parts.push(format!("{symbol}^{e}")),
            }
        }
        if parts.is_empty() {
            f.write_str("1 (no unit)")
        } else {
            f.write_str(&parts.join(" "))
        }
    }
}

/// A unit: value in SI = number × `factor` × 10^`pow10`. Powers of ten are kept apart from the
/// factor so that they can be applied to the number's decimal text (exact, see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    /// The non-decimal part of the conversion to SI (π/180 for degrees, else 1).
    pub factor: f64,
    /// The decimal part of the conversion to SI.
    pub pow10: i32,
    /// The dimension.
    pub dim: Dim,
}

impl Unit {
    const ONE: Unit = Unit {
        factor: 1.0,
        pow10: 0,
        dim: Dim::NONE,
    };

    fn new(pow10: i32, dim: Dim) -> Unit {
        Unit {
            factor: 1.0,
            pow10,
            dim,
        }
    }

    fn times(self, other: Unit, power: i8) -> Unit {
        Unit {
            factor: self.factor * other.factor.powi(power.into()),
            pow10: self.pow10 + other.pow10 * i32::from(power),
            dim: self.dim.times(other.dim, power),
        }
    }

    /// The SI value of 1 of this unit (`"mm"` → 1e-3).
    pub fn si_value(self) -> f64 {
        scale_decimal("1", 0, self.pow10).unwrap_or(f64::NAN) * self.factor
    }

    /// `value` (in this unit) in SI, rounded once: a decimal unit below 1 divides by its power
    /// of ten (x / 1000 is correctly rounded, x · 0.001 is not always).
    pub fn to_si(self, value: f64) -> f64 {
        if self.factor == 1.0 && (-22..0).contains(&self.pow10) {
            value / 10f64.powi(-self.pow10)
        } else {
            value * self.si_value()
        }
    }
}

/// The unit of `[mesh] unit` (a unit alone: `"mm"`), refused unless it is a length.
pub fn length_unit(text: &str) -> Result<Unit, String> {
    let unit = parse_unit(text)?;
    if text.trim().is_empty() {
        return Err("give a length unit, e.g. \"mm\"".into());
    }
    if unit.dim != Dim::LENGTH {
        return Err(format!(
            "\"{}\" is {}, but the mesh unit must be a length (e.g. \"mm\")",
            crate::error::clip(text),
            name_of(unit.dim)
        ));
    }
    Ok(unit)
}

/// The symbols: (symbol, unit, whether SI prefixes may go before it).
fn symbol(name: &str) -> Option<(Unit, bool)> {
    let force = Dim([1, 1, -2, 0]);
    let (unit, prefixable) = match name {
        "m" => (Unit::new(0, Dim::LENGTH), true),
        "g" => (Unit::new(-3, Dim::MASS), true),
        "s" => (Unit::new(0, Dim::TIME), true),
        "N" => (Unit::new(0, force), true),
        "Pa" => (Unit::new(0, Dim([-1, 1, -2, 0])), true),
        "bar" => (Unit::new(5, Dim([-1, 1, -2, 0])), true),
        "J" => (Unit::new(0, Dim([2, 1, -2, 0])), true),
        "W" => (Unit::new(0, Dim([2, 1, -3, 0])), true),
        "Hz" => (Unit::new(0, Dim([0, 0, -1, 0])), true),
        "L" => (Unit::new(-3, Dim([3, 0, 0, 0])), true),
        "rad" => (Unit::new(0, Dim::ANGLE), true),
        "deg" | "°" => (
            Unit {
                factor: PI / 180.0,
                pow10: 0,
                dim: Dim::ANGLE,
            },
            false,
        ),
        _ => return None,
    };
    Some((unit, prefixable))
}

/// SI prefixes (case-sensitive) and their powers of ten.
const PREFIXES: &[(&str, i32)] = &[
    ("T", 12),
    ("G", 9),
    ("M", 6),
    ("k", 3),
    ("h", 2),
    ("d", -1),
    ("c", -2),
    ("m", -3),
    ("µ", -6),
    ("μ", -6),
    ("u", -6),
    ("n", -9),
    ("p", -12),
];

/// A symbol with an optional prefix: the whole name first (`m` is metre, `Pa` pascal), then a
/// prefix and a prefixable symbol (`mm`, `MPa`, `kg`).
fn prefixed(name: &str) -> Option<Unit> {
    if let Some((unit, _)) = symbol(name) {
        return Some(unit);
    }
    PREFIXES.iter().find_map(|&(p, pow)| {
        let rest = name.strip_prefix(p)?;
        match symbol(rest) {
            Some((unit, true)) => Some(Unit {
                pow10: unit.pow10 + pow,
                ..unit
            }),
            _ => None,
        }
    })
}

/// Unicode superscript digits and minus, as in `m³` or `s⁻¹`, to ASCII.
fn superscript(c: char) -> Option<char> {
    Some(match c {
        '⁻' => '-',
        '⁰' => '0',
        '¹' => '1',
        '²' => '2',
        '³' => '3',
        '⁴' => '4',
        '⁵' => '5',
        '⁶' => '6',
        '⁷' => '7',
        '⁸' => '8',
        '⁹' => '9',
        _ => return None,
    })
}

/// One term: `mm`, `m^3`, `s^-2`, `m³`, `1`.
fn term(text: &str) -> Result<(Unit, i8), String> {
    let (name, power) = if let Some((name, power)) = text.split_once('^') {
        (name, power.to_string())
    } else {
        let start = text
            .char_indices()
            .find(|&(_, c)| superscript(c).is_some())
            .map_or(text.len(), |(i, _)| i);
        let power: Option<String> = text[start..].chars().map(superscript).collect();
        match power {
            Some(p) => (&text[..start], p),
            None => return Err(format!("unknown unit \"{text}\"")),
        }
    };
    let power: i8 = if power.is_empty() {
        1
    } else {
        power
            .parse()
            .ok()
            .filter(|p: &i8| *p != 0 && p.unsigned_abs() <= 9)
            .ok_or_else(|| format!("\"{text}\": a power must be a whole number from -9 to 9"))?
    };
    if name == "1" {
        return Ok((Unit::ONE, 1));
    }
    let unit = prefixed(name).ok_or_else(|| format!("unknown unit \"{name}\""))?;
    Ok((unit, power))
}

/// Parse a unit expression: `kg/m^3`, `N m`, `MPa`, `1/s`, `m s^-2`.
pub fn parse_unit(text: &str) -> Result<Unit, String> {
    let text = text.trim();
    if text.is_empty() {
        return Ok(Unit::ONE);
    }
    let mut parts = text.split('/');
    let numerator = parts.next().unwrap_or("");
    let denominator = parts.next();
    if parts.next().is_some() {
        return Err(format!(
            "\"{text}\": at most one '/' (write \"N/m^2\" or \"kg m^-1 s^-2\")"
        ));
    }
    let terms = |s: &str| -> Vec<String> {
        s.split(|c: char| c == '*' || c == '·' || c == '⋅' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    let mut unit = Unit::ONE;
    let top = terms(numerator);
    if top.is_empty() {
        return Err(format!(
            "\"{text}\": nothing before '/' (write \"1/s\", not \"/s\")"
        ));
    }
    for t in &top {
        let (u, p) = term(t)?;
        unit = unit.times(u, p);
    }
    if let Some(bottom) = denominator {
        let bottom = terms(bottom);
        if bottom.is_empty() {
            return Err(format!("\"{text}\": nothing after '/'"));
        }
        for t in &bottom {
            let (u, p) = term(t)?;
            unit = unit.times(u, -p);
        }
    }
    Ok(unit)
}

/// `digits × 10^(exponent + shift)` from the decimal text, converted once (correctly rounded).
fn scale_decimal(significand: &str, exponent: i32, shift: i32) -> Option<f64> {
    let total = exponent.checked_add(shift)?;
    format!("{significand}e{total}").parse().ok()
}

/// Split a quantity's text into its number (significand text, decimal exponent) and the rest.
fn split_number(text: &str) -> Option<(&str, i32, &str)> {
    let bytes = text.as_bytes();
    let mut i = 0;
    if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
        i += 1;
    }
    let digits_start = i;
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        i += 1;
    }
    let mut digits = i - digits_start;
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        let fraction = i;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
        digits += i - fraction;
    }
    if digits == 0 {
        return None;
    }
    let significand = &text[..i];
    let mut exponent = 0;
    // An exponent only when digits follow the e: "2 eV" is not 2e-something.
    if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
        let mut j = i + 1;
        if j < bytes.len() && (bytes[j] == b'+' || bytes[j] == b'-') {
            j += 1;
        }
        let start = j;
        while j < bytes.len() && bytes[j].is_ascii_digit() {
            j += 1;
        }
        if j > start {
            exponent = text[i + 1..j].parse().ok()?;
            i = j;
        }
    }
    Some((significand, exponent, &text[i..]))
}

/// What a key holds, for converting and for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// m
    Length,
    /// s
    Time,
    /// m/s
    Velocity,
    /// m/s²
    Acceleration,
    /// Pa
    Pressure,
    /// N
    Force,
    /// kg/m³
    Density,
    /// 1/s (Hz)
    Frequency,
    /// An angle the key holds in degrees.
    Degrees,
    /// A plain number (ratio, coefficient, direction).
    Ratio,
}

impl Kind {
    /// The key's own unit (what a bare number means).
    fn unit(self) -> Unit {
        match self {
            Kind::Length => Unit::new(0, Dim::LENGTH),
            Kind::Time => Unit::new(0, Dim::TIME),
            Kind::Velocity => Unit::new(0, Dim([1, 0, -1, 0])),
            Kind::Acceleration => Unit::new(0, Dim([1, 0, -2, 0])),
            Kind::Pressure => Unit::new(0, Dim([-1, 1, -2, 0])),
            Kind::Force => Unit::new(0, Dim([1, 1, -2, 0])),
            Kind::Density => Unit::new(0, Dim([-3, 1, 0, 0])),
            Kind::Frequency => Unit::new(0, Dim([0, 0, -1, 0])),
            Kind::Degrees => symbol("deg").map(|(u, _)| u).unwrap_or(Unit::ONE),
            Kind::Ratio => Unit::ONE,
        }
    }

    /// How a message names it: `a pressure (Pa, e.g. "1.2 MPa")`.
    fn describe(self) -> &'static str {
        match self {
            Kind::Length => "a length (m, e.g. \"5 mm\")",
            Kind::Time => "a time (s, e.g. \"2 ms\")",
            Kind::Velocity => "a velocity (m/s, e.g. \"30 mm/s\")",
            Kind::Acceleration => "an acceleration (m/s^2, e.g. \"9.81 m/s^2\")",
            Kind::Pressure => "a pressure or stress (Pa, e.g. \"1.2 MPa\")",
            Kind::Force => "a force (N, e.g. \"2 kN\")",
            Kind::Density => "a density (kg/m^3, e.g. \"1100 kg/m^3\")",
            Kind::Frequency => "a frequency (Hz = 1/s, e.g. \"50 Hz\")",
            Kind::Degrees => "an angle (degrees; e.g. \"45 deg\" or \"0.5 rad\")",
            Kind::Ratio => "a plain number (no unit)",
        }
    }
}

/// The name of a dimension users know, for messages; the base units otherwise.
fn name_of(dim: Dim) -> String {
    const KINDS: [Kind; 9] = [
        Kind::Length,
        Kind::Time,
        Kind::Velocity,
        Kind::Acceleration,
        Kind::Pressure,
        Kind::Force,
        Kind::Density,
        Kind::Frequency,
        Kind::Degrees,
    ];
    if let Some(kind) = KINDS.iter().find(|k| k.unit().dim == dim) {
        let d = kind.describe();
        return d.split(" (").next().unwrap_or(d).to_string();
    }
    match dim {
        Dim::NONE => "a plain number".into(),
        Dim([2, 1, -2, 0]) => "an energy (J)".into(),
        Dim([2, 1, -3, 0]) => "a power (W)".into(),
        Dim::MASS => "a mass (kg)".into(),
        Dim([3, 0, 0, 0]) => "a volume (m^3)".into(),
        Dim([2, 0, 0, 0]) => "an area (m^2)".into(),
        d => format!("of unit {d}"),
    }
}

/// The value of `text` (`"1.2 MPa"`) in the SI unit of `kind` (degrees for [`Kind::Degrees`]).
pub fn parse_quantity(text: &str, kind: Kind) -> Result<f64, String> {
    let trimmed = text.trim();
    let (significand, exponent, rest) = split_number(trimmed).ok_or_else(|| {
        format!(
            "\"{}\" is not a number with a unit: expected {}, e.g. \"{}\"",
            crate::error::clip(text),
            kind.describe(),
            example(kind)
        )
    })?;
    let unit = parse_unit(rest).map_err(|e| format!("\"{}\": {e}", crate::error::clip(text)))?;
    let target = kind.unit();
    if unit.dim != target.dim {
        let what = if rest.trim().is_empty() {
            "has no unit".to_string()
        } else {
            format!("is {}", name_of(unit.dim))
        };
        return Err(format!(
            "\"{}\" {what}, but this key takes {}",
            crate::error::clip(text),
            kind.describe()
        ));
    }
    let value =
        scale_decimal(significand, exponent, unit.pow10 - target.pow10).ok_or_else(|| {
            format!(
                "\"{}\": the number is out of range",
                crate::error::clip(text)
            )
        })?;
    // Degrees on a degrees key: (π/180)/(π/180) is exactly 1, so "90 deg" is exactly 90.
    let value = value * (unit.factor / target.factor);
    if !value.is_finite() {
        return Err(format!(
            "\"{}\" is out of double precision's range",
            crate::error::clip(text)
        ));
    }
    Ok(value)
}

/// An example string of `kind` for messages.
fn example(kind: Kind) -> &'static str {
    let d = kind.describe();
    d.split("e.g. \"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or("0.3")
}

/// The dimension of a key's value, as a type (for serde's `deserialize_with`).
pub trait Dimension {
    /// What the key holds.
    const KIND: Kind;
}

macro_rules! dimensions {
    ($($name:ident),*) => {$(
        #[doc = concat!("Marker: a key holding ", stringify!($name), ".")]
        pub enum $name {}
        impl Dimension for $name {
            const KIND: Kind = Kind::$name;
        }
    )*};
}
dimensions!(
    Length,
    Time,
    Velocity,
    Acceleration,
    Pressure,
    Force,
    Density,
    Frequency,
    Degrees,
    Ratio
);

/// A number or a `"<number> <unit>"` string of dimension `D`, as SI f64.
struct Quantity<D>(f64, PhantomData<D>);

impl<'de, D: Dimension> Deserialize<'de> for Quantity<D> {
    fn deserialize<De: Deserializer<'de>>(d: De) -> Result<Self, De::Error> {
        struct V<D>(PhantomData<D>);
        impl<D: Dimension> Visitor<'_> for V<D> {
            type Value = f64;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(
                    f,
                    "a number or a string with a unit: {}",
                    D::KIND.describe()
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<f64, E> {
                Ok(v)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<f64, E> {
                Ok(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<f64, E> {
                Ok(v as f64)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<f64, E> {
                parse_quantity(v, D::KIND).map_err(E::custom)
            }
        }
        d.deserialize_any(V::<D>(PhantomData))
            .map(|v| Quantity(v, PhantomData))
    }
}

/// A number-valued key of dimension `D`.
pub fn scalar<'de, De: Deserializer<'de>, D: Dimension>(d: De) -> Result<f64, De::Error> {
    Quantity::<D>::deserialize(d).map(|q| q.0)
}

/// An optional number-valued key of dimension `D` (give the field `#[serde(default)]`).
pub fn optional<'de, De: Deserializer<'de>, D: Dimension>(d: De) -> Result<Option<f64>, De::Error> {
    scalar::<De, D>(d).map(Some)
}

/// A 3-vector key of dimension `D`: exactly three entries, each a number or a string with a
/// unit (serde's arrays would read the first three and drop the rest silently).
pub fn three<'de, De: Deserializer<'de>, D: Dimension>(d: De) -> Result<[f64; 3], De::Error> {
    let v: Vec<Quantity<D>> = Vec::deserialize(d)?;
    let n = v.len();
    <[Quantity<D>; 3]>::try_from(v)
        .map(|q| q.map(|q| q.0))
        .map_err(|_| de::Error::invalid_length(n, &"exactly 3 entries [x, y, z]"))
}

/// An optional 3-vector key of dimension `D` (give the field `#[serde(default)]`).
pub fn optional_three<'de, De: Deserializer<'de>, D: Dimension>(
    d: De,
) -> Result<Option<[f64; 3]>, De::Error> {
    three::<De, D>(d).map(Some)
}

/// An optional pair key of dimension `D` (`damping_frequencies = ["2 Hz", 20]`): exactly two
/// entries (give the field `#[serde(default)]`).
pub fn optional_two<'de, De: Deserializer<'de>, D: Dimension>(
    d: De,
) -> Result<Option<[f64; 2]>, De::Error> {
    let v: Vec<Quantity<D>> = Vec::deserialize(d)?;
    let n = v.len();
    <[Quantity<D>; 2]>::try_from(v)
        .map(|q| Some(q.map(|q| q.0)))
        .map_err(|_| de::Error::invalid_length(n, &"exactly 2 entries [f1, f2]"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefixes_apply_to_the_decimal_text_exactly() {
        assert_eq!(parse_quantity("5 mm", Kind::Length), Ok(0.005));
        assert_eq!(parse_quantity("1.2 MPa", Kind::Pressure), Ok(1.2e6));
        assert_eq!(parse_quantity("1100 kg/m^3", Kind::Density), Ok(1100.0));
        assert_eq!(parse_quantity("1.1 g/cm^3", Kind::Density), Ok(1100.0));
        assert_eq!(parse_quantity("2 ms", Kind::Time), Ok(0.002));
        assert_eq!(parse_quantity("-9.81 m/s^2", Kind::Acceleration), Ok(-9.81));
        assert_eq!(parse_quantity("3e2 mm", Kind::Length), Ok(0.3));
        assert_eq!(parse_quantity("0.25mm", Kind::Length), Ok(0.00025));
        assert_eq!(parse_quantity("200 GPa", Kind::Pressure), Ok(2e11));
        assert_eq!(parse_quantity("2 bar", Kind::Pressure), Ok(2e5));
        assert_eq!(parse_quantity("1 kg/L", Kind::Density), Ok(1000.0));
        assert_eq!(parse_quantity("3 µm", Kind::Length), Ok(3e-6));
        assert_eq!(parse_quantity("3 um", Kind::Length), Ok(3e-6));
    }

    #[test]
    fn derived_units_products_quotients_and_powers() {
        assert_eq!(parse_quantity("5 N/mm^2", Kind::Pressure), Ok(5e6));
        assert_eq!(parse_quantity("5 N mm^-2", Kind::Pressure), Ok(5e6));
        assert_eq!(parse_quantity("5 N·mm⁻²", Kind::Pressure), Ok(5e6));
        assert_eq!(parse_quantity("7 kg m^-1 s^-2", Kind::Pressure), Ok(7.0));
        assert_eq!(parse_quantity("2 kN", Kind::Force), Ok(2000.0));
        assert_eq!(parse_quantity("4 kg m/s^2", Kind::Force), Ok(4.0));
        assert_eq!(parse_quantity("50 Hz", Kind::Frequency), Ok(50.0));
        assert_eq!(parse_quantity("3 1/s", Kind::Frequency), Ok(3.0));
        assert_eq!(parse_quantity("3 s^-1", Kind::Frequency), Ok(3.0));
        assert_eq!(parse_quantity("30 mm/s", Kind::Velocity), Ok(0.03));
        assert_eq!(parse_quantity("1 J/m^3", Kind::Pressure), Ok(1.0));
    }

    #[test]
    fn angles_convert_to_degrees_exactly() {
        assert_eq!(parse_quantity("90 deg", Kind::Degrees), Ok(90.0));
        assert_eq!(parse_quantity("90°", Kind::Degrees), Ok(90.0));
        let rad = parse_quantity("3.141592653589793 rad", Kind::Degrees).unwrap();
        assert!((rad - 180.0).abs() < 1e-12, "{rad}");
        assert!(parse_quantity("1 mdeg", Kind::Degrees).is_err());
    }

    #[test]
    fn wrong_dimensions_are_refused_and_named() {
        let e = parse_quantity("1 MPa m", Kind::Pressure).unwrap_err();
        assert!(
            e.contains("\"1 MPa m\" is") && e.contains("takes a pressure"),
            "{e}"
        );
        let e = parse_quantity("5 N", Kind::Pressure).unwrap_err();
        assert!(e.contains("is a force"), "{e}");
        let e = parse_quantity("2 rad/s", Kind::Frequency).unwrap_err();
        assert!(e.contains("takes a frequency"), "{e}");
        let e = parse_quantity("45 deg", Kind::Ratio).unwrap_err();
        assert!(e.contains("is an angle"), "{e}");
        let e = parse_quantity("5", Kind::Length).unwrap_err();
        assert!(e.contains("has no unit"), "{e}");
        assert_eq!(parse_quantity("0.3", Kind::Ratio), Ok(0.3));
    }

    #[test]
    fn unknown_units_and_case_are_refused() {
        for bad in [
            "5 mpa",
            "5 Mpa",
            "5 MPA",
            "5 furlongs",
            "5 m/s/s",
            "5 /s",
            "5 m^x",
            "5 M",
        ] {
            let e = parse_quantity(bad, Kind::Pressure).unwrap_err();
            assert!(
                e.contains("unknown unit")
                    || e.contains("at most one")
                    || e.contains("nothing")
                    || e.contains("power"),
                "{bad}: {e}"
            );
        }
        // mPa is milli-pascal: valid, and a thousandth.
        assert_eq!(parse_quantity("5 mPa", Kind::Pressure), Ok(0.005));
        for bad in ["mm", "", "abc", "nan m", "inf m", "1e999 m"] {
            assert!(parse_quantity(bad, Kind::Length).is_err(), "{bad}");
        }
    }

    #[test]
    fn mesh_units_scale() {
        let mm = length_unit("mm").unwrap();
        assert_eq!(mm.to_si(4000.0), 4.0);
        assert_eq!(mm.to_si(0.5), 0.0005);
        assert!(length_unit("kg").unwrap_err().contains("must be a length"));
        assert!(length_unit("").is_err());
        assert!(length_unit("MM").unwrap_err().contains("unknown unit"));
        assert_eq!(parse_unit("mm").unwrap().si_value(), 1e-3);
        assert_eq!(parse_unit("cm").unwrap().si_value(), 1e-2);
        assert_eq!(parse_unit("m").unwrap().si_value(), 1.0);
        assert_eq!(parse_unit("km").unwrap().si_value(), 1e3);
    }
}
