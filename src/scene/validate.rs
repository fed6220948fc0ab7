//! The one scene validator. serde has already checked names and types; this checks every value
//! the schema lets through but the physics cannot use, and reports the first bad one in the file
//! as `file:line:column: key.path: what is wrong, got value`, at the line of the key itself
//! (inside inline tables and `[[table]]` entries too).
//!
//! Every check goes through [`Validator::fail`] with a key path, so no message can lose its
//! line. The library keeps its own guards (`sim::check_params`, `lame_from`, the region
//! selection) for values built in code; a scene never reaches them with a bad value.

use std::fmt::Display;

use super::locate::{Locator, Seg, key};
use super::schema::{
    ContactSpec, FixedSpec, Generator, LoadSpec, MeshSpec, MotionSpec, ObstacleEntry, OutputSpec,
    PreconditionerName, RegionSpec, Scene, SolverSpec,
};
use crate::error::{Error, Result};

mod limits;
mod obstacles;
mod solver;

pub(crate) use limits::{beyond_length_cap, beyond_limit, derived_damping_problem};
use limits::{has_direction, limit};

/// How many `[[volume]]` entries a mesh can hold (materials are stored per tet in a byte).
const MAX_VOLUMES: usize = u8::MAX as usize;

/// Largest λ/μ accepted (ν ≈ 0.499999995): beyond it ε·λ/μ exceeds 2e-8, and Newton on the
/// default beam already fails to converge at λ/μ = 5e6 (ν = 0.4999999). See `validate` for why.
pub(crate) const MAX_LAME_RATIO: f64 = 1e8;

/// Caps on counts: each far above any useful value, and low enough that nothing sized by them
/// (a per-step history, a frame loop of substeps × 2^max_step_cuts) overflows or allocates
/// absurdly. A user who reaches one is better served by a different setting (see the messages
/// in docs/scene-reference.md).
pub(crate) const MAX_FRAMES: usize = 1_000_000;
/// See [`MAX_FRAMES`].
pub(crate) const MAX_SUBSTEPS: usize = 100_000;
/// See [`MAX_FRAMES`].
pub(crate) const MAX_NEWTON_ITERATIONS: usize = 10_000;
/// See [`MAX_FRAMES`].
pub(crate) const MAX_CG_ITERATIONS: usize = 10_000_000;
/// The largest damping ratio accepted: far into overdamping (1 is critical), and low enough
/// that the Rayleigh coefficients it gives stay finite.
const MAX_DAMPING_RATIO: f64 = 1000.0;
/// The shortest time step, s.
const MIN_DT: f64 = 1e-12;

/// `max_step_cuts` beyond this would ask for more than 2²⁰ substeps per frame.
const MAX_STEP_CUTS: usize = 20;

/// Check every value of `scene` (parsed from `scene.source`); the first bad one in the file is
/// the error.
pub(super) fn validate(scene: &Scene) -> Result<()> {
    let mut v = Validator {
        scene,
        at: Locator::new(&scene.source),
        problems: Vec::new(),
    };
    v.finite3(&key!["gravity"], scene.gravity, "m/s²");
    v.mesh(&key!["mesh"], &scene.mesh);
    v.bodies();
    let m = &scene.material;
    v.elastic(
        &key!["material"],
        [m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda],
        Some(m.density),
    );
    v.volumes();
    for (i, fixed) in scene.fixed.iter().enumerate() {
        v.fixed(i, fixed);
    }
    for (i, load) in scene.load.iter().enumerate() {
        v.load(i, load);
    }
    v.finite3(&key!["initial", "velocity"], scene.initial.velocity, "m/s");
    for (i, obstacle) in scene.obstacle.iter().enumerate() {
        v.obstacle(i, obstacle);
    }
    if let Some(contact) = &scene.contact {
        v.contact(contact);
    }
    v.probes();
    v.fixed_names();
    v.solver(&scene.solver);
    v.output(&scene.output);
    v.finish()
}

struct Validator<'s> {
    scene: &'s Scene,
    at: Locator<'s>,
    /// Every problem found, with its (line, column) for ordering.
    problems: Vec<((usize, usize), Error)>,
}

/// `base` followed by `tail`: a key path inside a table or an entry.
/// Every body's name, body 0 first (defaults filled in).
pub(crate) fn body_names(scene: &Scene) -> Vec<String> {
    std::iter::once(scene.mesh.name.clone().unwrap_or_else(|| "body0".into()))
        .chain(
            scene
                .body
                .iter()
                .enumerate()
                .map(|(i, b)| b.name.clone().unwrap_or_else(|| format!("body{}", i + 1))),
        )
        .collect()
}

fn join<'a>(base: &[Seg<'a>], tail: &[Seg<'a>]) -> Vec<Seg<'a>> {
    base.iter().chain(tail).copied().collect()
}

fn vec3(v: [f64; 3]) -> String {
    let c = |x: f64| {
        if x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) {
            format!("{x:e}")
        } else {
            format!("{x}")
        }
    };
    format!("[{}, {}, {}]", c(v[0]), c(v[1]), c(v[2]))
}

impl Validator<'_> {
    /// The one way a check fails: the message is prefixed with the key path and located at
    /// the key's line (or its table's, for a key the file leaves at its default).
    fn fail(&mut self, key: &[Seg], message: impl Display) {
        let line_column = self.at.line_column(key);
        let error = self.at.error(&self.scene.path, key, message);
        self.problems.push((line_column, error));
    }

    /// The first problem in file order, if any.
    fn finish(self) -> Result<()> {
        match self.problems.into_iter().min_by_key(|(at, _)| *at) {
            Some((_, error)) => Err(error),
            None => Ok(()),
        }
    }

    /// |value| ≤ the unit's [`limit`] (NaN and inf are reported by the callers' own checks).
    fn bounded(&mut self, key: &[Seg], value: f64, unit: &str) -> bool {
        match beyond_limit(value, unit) {
            Some(why) => {
                self.fail(key, why);
                false
            }
            None => true,
        }
    }

    /// `value` > 0 and finite.
    fn positive(&mut self, key: &[Seg], value: f64, unit: &str) {
        if !self.bounded(key, value, unit) {
            return;
        }
        if !(value > 0.0 && value.is_finite()) {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" ({unit})")
            };
            self.fail(
                key,
                format!("must be positive and finite{unit}, got {value}"),
            );
        }
    }

    /// `value` ≥ 0 and finite.
    fn non_negative(&mut self, key: &[Seg], value: f64, unit: &str) {
        if !self.bounded(key, value, unit) {
            return;
        }
        if !(value >= 0.0 && value.is_finite()) {
            self.fail(
                key,
                format!("must be zero or positive and finite ({unit}), got {value}"),
            );
        }
    }

    fn at_most(&mut self, key: &[Seg], value: usize, max: usize) {
        if value > max {
            self.fail(key, format!("must be at most {max}, got {value}"));
        }
    }

    fn at_least_one(&mut self, key: &[Seg], value: usize) {
        if value == 0 {
            self.fail(key, "must be at least 1, got 0");
        }
    }

    fn finite3(&mut self, key: &[Seg], value: [f64; 3], unit: &str) {
        if !value.iter().all(|c| c.is_finite()) {
            self.fail(key, format!("must be finite ({unit}), got {}", vec3(value)));
        } else if let Some(&c) = value.iter().find(|c| c.abs() > limit(unit)) {
            self.bounded(key, c, unit);
        }
    }

    /// A `[mesh]` or a `[[body]]`'s `mesh` (at `at`).
    fn mesh(&mut self, at: &[Seg], mesh: &MeshSpec) {
        if let Some(render) = &mesh.render {
            self.render_file(&join(at, &key!["render"]), render);
        }
        if !matches!(mesh.element_order(), 1 | 2) {
            self.fail(
                &join(at, &key!["order"]),
                format!(
                    "must be 1 (linear tets) or 2 (quadratic tets), got {}",
                    mesh.element_order()
                ),
            );
        }
        match (&mesh.file, &mesh.surface) {
            (Some(_), Some(_)) => self.fail(
                &join(at, &key!["surface"]),
                "give either file or surface, not both",
            ),
            (None, Some(_)) if mesh.generator.is_some() => self.fail(
                &join(at, &key!["surface"]),
                "give either generator or surface, not both",
            ),
            _ => {}
        }
        match (&mesh.surface, mesh.size) {
            (Some(_), None) => self.fail(
                &join(at, &key!["surface"]),
                "a surface needs `size`, the lattice spacing of its tets (e.g. size = \"5 mm\")",
            ),
            (None, Some(_)) => self.fail(
                &join(at, &key!["size"]),
                "size is the lattice spacing for a `surface`; a mesh file or generator takes none",
            ),
            (Some(_), Some(h)) if !(h.is_finite() && h > 0.0) => self.fail(
                &join(at, &key!["size"]),
                format!("must be a positive length, got {h}"),
            ),
            _ => {}
        }
        match (&mesh.file, &mesh.generator) {
            (Some(_), Some(_)) => self.fail(
                &join(at, &key!["generator"]),
                "give either file or generator, not both",
            ),
            (None, None) if mesh.surface.is_some() => {}
            (None, None) => self.fail(
                &join(at, &key!["file"]),
                "give a mesh file or a generator (or a surface to fill with tets)",
            ),
            (None, Some(Generator::Box { min, max, cells })) => {
                let base = join(at, &key!["generator", "box"]);
                self.finite3(&join(&base, &key!["min"]), *min, "m");
                self.finite3(&join(&base, &key!["max"]), *max, "m");
                if (0..3).any(|k| max[k] <= min[k] || max[k].is_nan() || min[k].is_nan()) {
                    self.fail(
                        &join(&base, &key!["max"]),
                        format!(
                            "must exceed min on every axis, got min = {}, max = {}",
                            vec3(*min),
                            vec3(*max)
                        ),
                    );
                }
                if cells.contains(&0) {
                    self.fail(
                        &join(&base, &key!["cells"]),
                        format!("need at least one cell per axis, got {cells:?}"),
                    );
                } else {
                    // 6 Kuhn tets a cube; counted in f64 so that no product overflows.
                    let tets = 6.0 * cells.iter().map(|&c| c as f64).product::<f64>();
                    if let Some(why) = crate::resources::memory_shortfall(tets) {
                        self.fail(
                            &join(&base, &key!["cells"]),
                            format!("{cells:?} cells: {why}; use fewer cells"),
                        );
                    }
                }
            }
            (Some(_), None) => {}
        }
        if let Some(unit) = &mesh.unit {
            let key = join(at, &key!["unit"]);
            if let Err(e) = super::units::length_unit(unit) {
                self.fail(&key, e);
            } else if mesh.generator.is_some() {
                self.fail(
                    &key,
                    "a unit applies to a mesh file; a generator's min and max take units in \
                     their own values (min = [\"0 mm\", \"0 mm\", \"0 mm\"])",
                );
            }
        }
    }

    /// A render surface must be a Wavefront OBJ (the format that keeps texture coordinates,
    /// groups and materials); whether it reads is found when the scene is built.
    fn render_file(&mut self, key: &[Seg], path: &std::path::Path) {
        let obj = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if !obj {
            self.fail(
                key,
                format!(
                    "\"{}\": a render surface is a Wavefront .obj file",
                    crate::error::clip(&path.display().to_string())
                ),
            );
        }
    }

    /// A name that becomes CSV column names (`tip` → `tip_x`): 1 to 64 of letters, digits,
    /// `_`, `-`, `.`, so that no column needs quoting.
    fn column_name(&mut self, key: &[Seg], name: &str) -> bool {
        let ok = (1..=64).contains(&name.len())
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !ok {
            self.fail(
                key,
                format!(
                    "\"{}\": a name here needs 1 to 64 letters, digits, '_', '-' or '.' (it names \
                     CSV columns)",
                    crate::error::clip(name)
                ),
            );
        }
        ok
    }

    /// `[[probe]]` entries: usable unique names, finite points, known bodies.
    fn probes(&mut self) {
        let scene = self.scene;
        for (i, p) in scene.probe.iter().enumerate() {
            let base = key!["probe", i];
            let at = |k: &'static str| join(&base, &key![k]);
            if self.column_name(&at("name"), &p.name)
                && scene.probe[..i].iter().any(|q| q.name == p.name)
            {
                self.fail(
                    &at("name"),
                    format!(
                        "\"{}\" names two probes: every probe needs its own name",
                        p.name
                    ),
                );
            }
            self.finite3(&at("point"), p.point, "m");
            self.body_ref(&at("body"), p.body.as_ref());
        }
    }

    /// `[[fixed]] name`s: usable and unique (each names three reactions.csv columns).
    fn fixed_names(&mut self) {
        let fixed = &self.scene.fixed;
        for (i, f) in fixed.iter().enumerate() {
            let Some(name) = &f.name else { continue };
            let key = key!["fixed", i, "name"];
            if self.column_name(&key, name)
                && fixed[..i].iter().any(|g| g.name.as_ref() == Some(name))
            {
                self.fail(
                    &key,
                    format!(
                        "\"{name}\" names two [[fixed]] entries: every named constraint needs its own name"
                    ),
                );
            }
        }
    }

    /// Elastic constants `[youngs_modulus, poisson_ratio, mu, lambda]` and density of
    /// `[material]` or a `[[volume]]` (at `base`): one pair or the other, each in range.
    fn elastic(&mut self, base: &[Seg], constants: [Option<f64>; 4], density: Option<f64>) {
        let [e, nu, mu, lambda] = constants;
        let at = |k: &'static str| join(base, &key![k]);
        let young_poisson = e.is_some() || nu.is_some();
        match (mu, lambda) {
            (None, None) => {}
            _ if young_poisson => {
                let k = if mu.is_some() { "mu" } else { "lambda" };
                self.fail(
                    &at(k),
                    "give youngs_modulus and poisson_ratio, or mu and lambda, not both pairs",
                );
            }
            (Some(_), None) => self.fail(
                &at("mu"),
                "give lambda too (or youngs_modulus and poisson_ratio instead)",
            ),
            (None, Some(_)) => self.fail(
                &at("lambda"),
                "give mu too (or youngs_modulus and poisson_ratio instead)",
            ),
            (Some(mu), Some(lambda)) => {
                if !(mu > 0.0 && mu.is_finite()) {
                    self.fail(&at("mu"), format!("μ must be positive (Pa), got {mu}"));
                } else if !(lambda.is_finite() && 3.0 * lambda + 2.0 * mu > 0.0) {
                    self.fail(
                        &at("lambda"),
                        format!("need 3λ + 2μ > 0 (Pa), got μ = {mu}, λ = {lambda}"),
                    );
                }
            }
        }
        for (k, value) in [("youngs_modulus", e), ("mu", mu), ("lambda", lambda)] {
            if let Some(value) = value {
                self.bounded(&at(k), value, "Pa");
            }
        }
        if let Some(e) = e
            && !(e > 0.0 && e.is_finite())
        {
            self.fail(
                &at("youngs_modulus"),
                format!("Young's modulus must be positive (Pa), got {e}"),
            );
        }
        if let Some(nu) = nu
            && !(nu > -1.0 && nu < 0.5)
        {
            self.fail(
                &at("poisson_ratio"),
                format!(
                    "Poisson ratio must lie in (-1, 0.5), got {nu} (0.5 is incompressible: λ would be infinite)"
                ),
            );
        }
        // λ/μ beyond what double precision resolves: the volumetric stress's rounding
        // (ε·λ/μ of the shear response) swamps the shear response Newton must balance.
        let ratio = match (nu, mu, lambda) {
            (Some(nu), _, _) if nu > -1.0 && nu < 0.5 => {
                Some(("poisson_ratio", 2.0 * nu / (1.0 - 2.0 * nu)))
            }
            (None, Some(mu), Some(lambda)) if mu > 0.0 && lambda.is_finite() => {
                Some(("lambda", lambda / mu))
            }
            _ => None,
        };
        if let Some((k, ratio)) = ratio
            && ratio > MAX_LAME_RATIO
        {
            self.fail(
                &at(k),
                format!(
                    "nearly incompressible beyond what double precision can solve: λ/μ = {ratio:.1e} \
                     exceeds {MAX_LAME_RATIO:.0e} (ν ≈ 0.499999995), so rounding of the volumetric \
                     stress (ε·λ/μ = {:.0e} of the shear stress) swamps the shear response and \
                     Newton cannot converge; linear tets also lock there. Use poisson_ratio = 0.49 \
                     or less (rubber is well modelled by 0.45-0.49)",
                    f64::EPSILON * ratio
                ),
            );
        }
        if let Some(rho) = density {
            self.positive(&at("density"), rho, "kg/m³");
        }
    }

    fn volumes(&mut self) {
        let volumes = &self.scene.volume;
        if volumes.len() > MAX_VOLUMES {
            self.fail(
                &key!["volume", MAX_VOLUMES],
                format!("at most {MAX_VOLUMES} [[volume]] entries"),
            );
        }
        for (i, v) in volumes.iter().enumerate() {
            let base = key!["volume", i];
            self.body_ref(&join(&base, &key!["body"]), v.body.as_ref());
            self.elastic(
                &base,
                [v.youngs_modulus, v.poisson_ratio, v.mu, v.lambda],
                v.density,
            );
            if let RegionSpec::Vertices(_) = v.region {
                self.fail(
                    &join(&base, &key!["region", "vertices"]),
                    "a material region needs tets: use physical, box or plane",
                );
            } else {
                self.region(&join(&base, &key!["region"]), &v.region);
            }
        }
    }

    /// The values a region holds (what it selects needs the mesh: see `build`).
    fn region(&mut self, base: &[Seg], region: &RegionSpec) {
        let at = |tail: &[Seg<'static>]| join(base, tail);
        match region {
            RegionSpec::Box { min, max } => {
                self.finite3(&at(&key!["box", "min"]), *min, "m");
                self.finite3(&at(&key!["box", "max"]), *max, "m");
            }
            RegionSpec::Plane { point, normal } => {
                self.finite3(&at(&key!["plane", "point"]), *point, "m");
                if !(normal.iter().all(|c| c.is_finite()) && normal.iter().any(|&c| c != 0.0)) {
                    self.fail(
                        &at(&key!["plane", "normal"]),
                        format!("must be finite and non-zero, got {}", vec3(*normal)),
                    );
                }
            }
            RegionSpec::Vertices(list) if list.is_empty() => self.fail(
                &at(&key!["vertices"]),
                "the list is empty: the region selects no vertices",
            ),
            RegionSpec::Vertices(_) | RegionSpec::Physical(_) => {}
        }
    }

    /// The `[[body]]` entries: names unique and sane, a mesh, a material, a usable placement.
    fn bodies(&mut self) {
        let scene = self.scene;
        let names = body_names(scene);
        // Generator boxes that each fit may not fit together (mesh files are summed once read).
        let generated = |m: &MeshSpec| match &m.generator {
            Some(Generator::Box { cells, .. }) if m.file.is_none() => {
                6.0 * cells.iter().map(|&c| c as f64).product::<f64>()
            }
            _ => 0.0,
        };
        let each: Vec<f64> = std::iter::once(&scene.mesh)
            .chain(scene.body.iter().map(|b| &b.mesh))
            .map(generated)
            .collect();
        let fits = |tets: f64| crate::resources::memory_shortfall(tets).is_none();
        if each.iter().all(|&t| fits(t))
            && let Some(why) = crate::resources::memory_shortfall(each.iter().sum())
            && let Some(last) = each.iter().rposition(|&t| t > 0.0)
        {
            let key: Vec<Seg> = match last {
                0 => key!["mesh", "generator", "box", "cells"].to_vec(),
                i => key!["body", i - 1, "mesh", "generator", "box", "cells"].to_vec(),
            };
            self.fail(
                &key,
                format!("the scene's generator boxes together: {why}; use fewer cells"),
            );
        }
        if let Some(name) = &scene.mesh.name {
            self.name(&key!["mesh", "name"], name);
        }
        for (i, b) in scene.body.iter().enumerate() {
            let base = key!["body", i];
            let at = |k: &'static str| join(&base, &key![k]);
            if let Some(name) = &b.name {
                self.name(&at("name"), name);
            }
            // Names as the run uses them, defaults filled in: `[mesh] name = "body1"` and an
            // unnamed first [[body]] (default "body1") would be two bodies of one name.
            let name = &names[i + 1];
            if names[..=i].contains(name) {
                match &b.name {
                    Some(_) => self.fail(
                        &at("name"),
                        format!("\"{name}\" names two bodies: every body needs its own name"),
                    ),
                    None => self.fail(
                        &base,
                        format!(
                            "this unnamed body's default name \"{name}\" is taken by another \
                             body: give it a name = \"...\" of its own"
                        ),
                    ),
                }
            }
            if b.mesh.name.is_some() {
                self.fail(
                    &join(&base, &key!["mesh", "name"]),
                    "a [[body]] is named by its own name key, not its mesh's",
                );
            }
            self.mesh(&at("mesh"), &b.mesh);
            if let Some(render) = &b.render {
                if b.mesh.render.is_some() {
                    self.fail(
                        &at("render"),
                        "give the render surface once: here or as the mesh's render key",
                    );
                }
                self.render_file(&at("render"), render);
            }
            if b.mesh.element_order() != 1 {
                self.fail(
                    &join(&base, &key!["mesh", "order"]),
                    "the element order applies to every body: set it in [mesh]",
                );
            }
            let m = &b.material;
            self.elastic(
                &at("material"),
                [m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda],
                Some(m.density),
            );
            self.positive(&at("scale"), b.scale, "a factor");
            if !b.rotate_degrees.is_finite() {
                self.fail(
                    &at("rotate_degrees"),
                    format!("must be finite (degrees), got {}", b.rotate_degrees),
                );
            }
            self.finite3(&at("axis"), b.axis, "a direction");
            if b.rotate_degrees != 0.0 && !has_direction(b.axis) {
                self.fail(&at("axis"), "a rotation needs a nonzero axis");
            }
            self.finite3(&at("translate"), b.translate, "m");
            self.finite3(&at("velocity"), b.velocity, "m/s");
        }
    }

    /// A body name: not empty, printable, not absurdly long.
    fn name(&mut self, key: &[Seg], name: &str) {
        if name.trim().is_empty() || name.len() > 64 || name.chars().any(char::is_control) {
            self.fail(
                key,
                "a name needs 1 to 64 printable characters (it is used in messages and outputs)",
            );
        }
    }

    /// A `body = "..."` reference of a region (at `key`) names a body of the scene.
    fn body_ref(&mut self, key: &[Seg], body: Option<&String>) {
        let Some(body) = body else { return };
        let names = body_names(self.scene);
        if !names.contains(body) {
            self.fail(
                key,
                format!(
                    "no body is named \"{body}\"; the scene's bodies are {}",
                    names
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            );
        }
    }

    fn fixed(&mut self, i: usize, fixed: &FixedSpec) {
        let base = key!["fixed", i];
        self.body_ref(&join(&base, &key!["body"]), fixed.body.as_ref());
        self.region(&join(&base, &key!["region"]), &fixed.region);
        if let Some(m) = &fixed.motion {
            self.motion(&join(&base, &key!["motion"]), m);
        }
        if let Some(d) = fixed.duration {
            self.non_negative(&join(&base, &key!["duration"]), d, "s");
        }
        if let Some(t) = fixed.until {
            let key = join(&base, &key!["until"]);
            self.non_negative(&key, t, "s, or a load factor");
            // Quasistatic runs read it as a load factor: a time unit would be silently wrong.
            if self.scene.solver.integrator == super::schema::IntegratorName::Quasistatic
                && self.at.is_string(&key)
            {
                self.fail(
                    &key,
                    "a quasistatic run reads until as a load factor (0 to 1), which has no \
                     unit: give a plain number",
                );
            }
        }
    }

    /// A rigid motion of `[[fixed]]` or `[[obstacle]]` (at `base`).
    fn motion(&mut self, base: &[Seg], m: &MotionSpec) {
        let at = |k: &'static str| join(base, &key![k]);
        self.finite3(&at("translate"), m.translate, "m");
        if !m.rotate_degrees.is_finite() {
            self.fail(
                &at("rotate_degrees"),
                format!("must be finite (degrees), got {}", m.rotate_degrees),
            );
        }
        self.bounded(&at("rotate_degrees"), m.rotate_degrees, "degrees");
        self.finite3(&at("axis"), m.axis, "a direction");
        if m.rotate_degrees != 0.0 && !has_direction(m.axis) {
            self.fail(
                &at("axis"),
                format!(
                    "a rotation of {} degrees needs a non-zero axis, got {}",
                    m.rotate_degrees,
                    vec3(m.axis)
                ),
            );
        }
        self.finite3(&at("center"), m.center, "m");
    }

    fn load(&mut self, i: usize, load: &LoadSpec) {
        let base = key!["load", i];
        self.body_ref(&join(&base, &key!["body"]), load.body.as_ref());
        self.region(&join(&base, &key!["region"]), &load.region);
        let forces = [
            ("traction", load.traction, "Pa"),
            ("total_force", load.total_force, "N"),
            ("point_force", load.point_force, "N"),
        ];
        let given: Vec<_> = forces.iter().filter(|(_, f, _)| f.is_some()).collect();
        match given.as_slice() {
            [] => self.fail(
                &base,
                "needs exactly one of traction, total_force, point_force; got none",
            ),
            [(name, Some(force), unit)] => {
                self.finite3(&join(&base, &key![*name]), *force, unit);
            }
            [(first, ..), (second, ..), ..] => self.fail(
                &join(&base, &key![*second]),
                format!(
                    "needs exactly one of traction, total_force, point_force; got {first} and {second}"
                ),
            ),
            [(_, None, _)] => unreachable!("only given forces are kept"),
        }
        if let Some(d) = load.duration {
            self.non_negative(&join(&base, &key!["duration"]), d, "s");
        }
    }
}

#[cfg(test)]
mod tests;
