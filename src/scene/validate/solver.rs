//! The `[solver]` and `[output]` tables: ranges, tolerances, the damping ratio's rules.

use super::*;

impl Validator<'_> {
    pub(super) fn solver(&mut self, s: &SolverSpec) {
        let at = |k: &'static str| key!["solver", k];
        self.positive(&at("dt"), s.dt, "s");
        if s.dt > 0.0 && s.dt < MIN_DT {
            self.fail(
                &at("dt"),
                format!(
                    "must be at least {MIN_DT:e} s (1/dt² would overflow the inertia term), got {}",
                    s.dt
                ),
            );
        }
        self.at_least_one(&at("frames"), s.frames);
        self.at_least_one(&at("substeps"), s.substeps);
        for (k, value, max) in [
            ("frames", s.frames, MAX_FRAMES),
            ("substeps", s.substeps, MAX_SUBSTEPS),
            (
                "newton_max_iterations",
                s.newton_max_iterations,
                MAX_NEWTON_ITERATIONS,
            ),
            ("cg_max_iterations", s.cg_max_iterations, MAX_CG_ITERATIONS),
        ] {
            self.at_most(&at(k), value, max);
        }
        for (k, value) in [
            ("newton_tolerance", s.newton_tolerance),
            ("cg_tolerance", s.cg_tolerance),
        ] {
            if value >= 1.0 {
                self.fail(
                    &at(k),
                    format!("must be below 1 (it is relative to the first residual: 1 or more would accept any start as converged), got {value}"),
                );
            }
        }
        self.newmark(s);
        self.non_negative(&at("rayleigh_stiffness"), s.rayleigh_stiffness, "s");
        self.non_negative(&at("rayleigh_mass"), s.rayleigh_mass, "1/s");
        self.damping(s);
        self.positive(&at("newton_tolerance"), s.newton_tolerance, "");
        self.at_least_one(&at("newton_max_iterations"), s.newton_max_iterations);
        self.positive(&at("cg_tolerance"), s.cg_tolerance, "");
        self.at_least_one(&at("cg_max_iterations"), s.cg_max_iterations);
        if s.max_step_cuts > MAX_STEP_CUTS {
            self.fail(
                &at("max_step_cuts"),
                format!(
                    "must be at most {MAX_STEP_CUTS} (2²⁰ substeps), got {}",
                    s.max_step_cuts
                ),
            );
        }
        if s.preconditioner == PreconditionerName::Cholesky && !cfg!(feature = "direct") {
            self.fail(
                &at("preconditioner"),
                "\"cholesky\" needs the sparse direct solver, which this tetsim was built \
                 without: rebuild with `cargo build --release --features direct`",
            );
        }
    }

    /// `damping_ratio` and `damping_frequencies` (SPEC §13): a ratio ζ ≥ 0, never beside an
    /// explicit `rayleigh_*` key; frequencies 0 < f₁ < f₂ (Hz), only with a ratio.
    fn damping(&mut self, s: &SolverSpec) {
        let at = |k: &'static str| key!["solver", k];
        let Some(zeta) = s.damping_ratio else {
            if s.damping_frequencies.is_some() {
                self.fail(
                    &at("damping_frequencies"),
                    "needs solver.damping_ratio, the ratio to reach at these frequencies",
                );
            }
            return;
        };
        if !(zeta >= 0.0 && zeta.is_finite()) {
            self.fail(
                &at("damping_ratio"),
                format!("must be zero or positive and finite, got {zeta}"),
            );
        } else if zeta > MAX_DAMPING_RATIO {
            self.fail(
                &at("damping_ratio"),
                format!("must be at most {MAX_DAMPING_RATIO} (1 is critical damping), got {zeta}"),
            );
        }
        for k in ["rayleigh_mass", "rayleigh_stiffness"] {
            if self.at.has(&at(k)) {
                let (line, _) = self.at.line_column(&at("damping_ratio"));
                self.fail(
                    &at(k),
                    format!(
                        "cannot be given with solver.damping_ratio (line {line}), which sets it: \
                         give the ratio or the Rayleigh coefficients, not both"
                    ),
                );
            }
        }
        if let Some([f1, f2]) = s.damping_frequencies {
            let key = at("damping_frequencies");
            if ![f1, f2].iter().all(|f| *f > 0.0 && f.is_finite()) {
                self.fail(
                    &key,
                    format!("must be two positive, finite frequencies (Hz), got [{f1}, {f2}]"),
                );
            } else if f2 <= f1 {
                self.fail(
                    &key,
                    format!("the second frequency must be above the first (Hz), got [{f1}, {f2}]"),
                );
            } else if self.bounded(&key, f2, "Hz")
                && let Some(problem) = derived_damping_problem(zeta, f1, f2)
            {
                self.fail(&key, problem);
            }
        }
    }

    pub(super) fn output(&mut self, o: &OutputSpec) {
        let at = |k: &'static str| key!["output", k];
        if let Err(e) = o.field.parse::<crate::field::FieldChoice>() {
            let message = match e {
                Error::Parameter { message, .. } => message,
                other => other.to_string(),
            };
            self.fail(&at("field"), message);
        }
        for (k, value) in [
            ("width", o.width),
            ("height", o.height),
            ("gif_width", o.gif_width),
            ("gif_height", o.gif_height),
        ] {
            if !(16..=8192).contains(&value) {
                self.fail(
                    &at(k),
                    format!("must be between 16 and 8192 pixels, got {value}"),
                );
            }
        }
        self.at_least_one(&at("gif_stride"), o.gif_stride);
        self.non_negative(&at("checkpoint_every"), o.checkpoint_every, "s");
        for (k, value) in [("azimuth", o.azimuth), ("elevation", o.elevation)] {
            if !value.is_finite() {
                self.fail(&at(k), format!("must be finite (degrees), got {value}"));
            }
        }
    }

    /// Newmark's β and γ: only with `integrator = "newmark"`, and in the unconditionally stable
    /// range γ ≥ ½, β ≥ γ/2 (β > 0 also makes the step an incremental potential).
    fn newmark(&mut self, s: &SolverSpec) {
        let at = |k: &'static str| key!["solver", k];
        let newmark = s.integrator == crate::scene::IntegratorName::Newmark;
        for (k, value) in [
            ("newmark_beta", s.newmark_beta),
            ("newmark_gamma", s.newmark_gamma),
        ] {
            if value.is_some() && !newmark {
                self.fail(
                    &at(k),
                    "applies only to integrator = \"newmark\"; set that too, or remove this key",
                );
            }
        }
        let gamma = s
            .newmark_gamma
            .unwrap_or(crate::integrator::scheme::NEWMARK_GAMMA);
        let beta = s
            .newmark_beta
            .unwrap_or(crate::integrator::scheme::NEWMARK_BETA);
        if !(0.5..=1.0).contains(&gamma) {
            self.fail(
                &at("newmark_gamma"),
                format!(
                    "must be between 0.5 and 1 (below 0.5 the scheme amplifies every vibration; \
                     0.5 is second order and keeps energy), got {gamma}"
                ),
            );
        } else if !(beta >= 0.5 * gamma && beta <= 1.0) {
            self.fail(
                &at("newmark_beta"),
                format!(
                    "must be between γ/2 = {} and 1 for a step that is stable at any dt \
                     (0.25 with γ = 0.5 is the average-acceleration rule), got {beta}",
                    0.5 * gamma
                ),
            );
        }
    }
}
