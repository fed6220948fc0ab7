//! Time schemes: what a dynamic step means.
//!
//! Every implicit scheme here makes a step from (xⁿ, vⁿ) an incremental potential in the end
//! positions x, with the velocity affine in x:
//!
//! ```text
//! v(x) = (x − x_still)/τ_v                      the scheme's velocity update
//! f_inertia = m·(ṽ − v(x))/τ_a                  minus m times its acceleration
//!           = −∇ ½‖x − x̃‖²_M / (τ_v·τ_a)        x̃ = x_still + τ_v·ṽ, the predicted position
//! ```
//!
//! | scheme | τ_v | τ_a | ṽ | x_still |
//! |---|---|---|---|---|
//! | backward Euler | h | h | vⁿ | xⁿ |
//! | BDF2 (step ratio ω = h/hₙ₋₁) | 1/a₀ | 1/a₀ | −(a₁vⁿ + a₂vⁿ⁻¹)/a₀ | −(a₁xⁿ + a₂xⁿ⁻¹)/a₀ |
//! | Newmark (β, γ) | βh/γ | γh | vⁿ + (1−γ)h·aⁿ | x̃ − τ_v·ṽ, x̃ = xⁿ + h·vⁿ + (½−β)h²·aⁿ |
//!
//! with BDF2's a₀ = (1+2ω)/((1+ω)h), a₁ = −(1+ω)/h, a₂ = ω²/((1+ω)h) (3/2h, −2/h, 1/2h at a
//! constant step). So the inertia term, Rayleigh damping (mass damping α·m·v(x) is the gradient of
//! ½α‖x − x_still‖²_M/τ_v; stiffness damping −γ·K·v(x) has the Hessian weight γ/τ_v), Newton,
//! contact and every linear-solver choice read a step through one [`Inertial`] and know no
//! scheme by name.
//!
//! What each keeps between steps ([`History`]): backward Euler nothing; BDF2 the previous step's
//! positions, velocities and length, and its acceleration (its first step, and any step more
//! than twice as long as the one before, is a trapezoidal-rule step from that acceleration,
//! second order like BDF2); Newmark the acceleration aⁿ. The first step of either starts from
//! the acceleration the forces at the initial state give ([`History::needs_acceleration`]).

use crate::math::Vec3;

/// What is integrated (scene key `[solver] integrator`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Integrator {
    /// Backward (implicit) Euler in time, SPEC §4: first order, damps a mode of angular
    /// frequency ω by 1/√(1 + (ωh)²) per step.
    #[default]
    BackwardEuler,
    /// The two-step backward differentiation formula: second order, damps far less (see
    /// [`Integrator::amplitude_per_step`]) but still unresolved modes strongly.
    Bdf2,
    /// Newmark's rule with parameters β (> 0) and γ: second order for γ = ½; with β = ¼, γ = ½
    /// (the average-acceleration or trapezoidal rule) it keeps the energy of a linear undamped
    /// system exactly.
    Newmark {
        /// β, default ¼.
        beta: f64,
        /// γ, default ½.
        gamma: f64,
    },
    /// Static equilibrium under loads ramped over load steps.
    Quasistatic,
}

/// Newmark's default β (average acceleration).
pub const NEWMARK_BETA: f64 = 0.25;
/// Newmark's default γ (average acceleration).
pub const NEWMARK_GAMMA: f64 = 0.5;

impl Integrator {
    /// Whether steps have inertia (every scheme but quasistatic).
    pub fn is_dynamic(self) -> bool {
        self != Integrator::Quasistatic
    }

    /// The scene name.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::BackwardEuler => "backward-euler",
            Integrator::Bdf2 => "bdf2",
            Integrator::Newmark { .. } => "newmark",
            Integrator::Quasistatic => "quasistatic",
        }
    }

    /// Newmark with the default parameters.
    pub fn newmark() -> Self {
        Integrator::Newmark {
            beta: NEWMARK_BETA,
            gamma: NEWMARK_GAMMA,
        }
    }

    /// The amplitude a free undamped linear oscillator of angular frequency ω keeps per step of
    /// h (`omega_h` = ωh): the spectral radius of the scheme's step (1 when static).
    pub fn amplitude_per_step(self, omega_h: f64) -> f64 {
        let w2 = omega_h * omega_h;
        match self {
            Integrator::BackwardEuler => 1.0 / (1.0 + w2).sqrt(),
            Integrator::Quasistatic => 1.0,
            // BDF2 on ẏ = λy with λ = ±iω: (3 − 2hλ)z² − 4z + 1 = 0.
            Integrator::Bdf2 => {
                type C = nalgebra::Complex<f64>;
                let a = C::new(3.0, -2.0 * omega_h);
                let disc = (C::new(16.0, 0.0) - 4.0 * a).sqrt();
                let roots = [(4.0 + disc) / (2.0 * a), (4.0 - disc) / (2.0 * a)];
                roots.iter().map(|z| z.norm()).fold(0.0, f64::max)
            }
            // The amplification matrix of (x, h·v) for ẍ = −ω²x (Hughes 2000, §9.1).
            Integrator::Newmark { beta, gamma } => {
                // Eigenvalues from the trace and determinant of the (x, hv) map.
                let (tr, det) = newmark_trace_det(beta, gamma, w2);
                let disc = tr * tr / 4.0 - det;
                if disc >= 0.0 {
                    let s = disc.sqrt();
                    (tr / 2.0 + s).abs().max((tr / 2.0 - s).abs())
                } else {
                    det.max(0.0).sqrt()
                }
            }
        }
    }
}

/// Trace and determinant of Newmark's step matrix on (x, h·v) for ẍ = −ω²x, w2 = (ωh)².
fn newmark_trace_det(beta: f64, gamma: f64, w2: f64) -> (f64, f64) {
    // aⁿ = −ω²xⁿ; x⁺ = x + hv + h²((½−β)a + βa⁺), hv⁺ = hv + h²((1−γ)a + γa⁺), a⁺ = −ω²x⁺.
    // Solving: x⁺(1 + βw²) = x(1 − (½−β)w²) + hv.
    let d = 1.0 + beta * w2;
    let xx = (1.0 - (0.5 - beta) * w2) / d;
    let xv = 1.0 / d;
    // hv⁺ = hv − (1−γ)w²x − γw²x⁺.
    let vx = -(1.0 - gamma) * w2 - gamma * w2 * xx;
    let vv = 1.0 - gamma * w2 * xv;
    (xx + vv, xx * vv - xv * vx)
}

/// One dynamic step as the incremental potential sees it (see the module docs): borrowed from
/// the step's start and the scheme's buffers.
#[derive(Clone, Copy, Debug)]
pub struct Inertial<'a> {
    /// The step's length, s.
    pub h: f64,
    /// x̃: where inertia alone takes each vertex (the minimum of the inertia term).
    pub predicted: &'a [Vec3],
    /// x_still: where the velocity the scheme gives the step's end is zero.
    pub still: &'a [Vec3],
    /// ṽ: the velocity at which the inertia force vanishes.
    pub base_velocity: &'a [Vec3],
    /// τ_v: v(x) = (x − x_still)/τ_v, s.
    pub velocity_time: f64,
    /// τ_a: the inertia force m·(ṽ − v)/τ_a, s.
    pub inertia_time: f64,
    /// τ_v·τ_a: the inertia term's Hessian is M divided by it, s².
    pub inertia_denominator: f64,
    /// Backward Euler's end displacement is h·v exactly (the audit uses that form).
    pub displacement_is_hv: bool,
    /// The weight of the forces at the step's start in the work the scheme balances against
    /// the kinetic energy: 1 − γ for a Newmark step with β = γ/2 (½ for the trapezoidal rule),
    /// 0 for backward Euler and BDF2, which balance the forces at the end.
    pub start_weight: f64,
    /// A BDF2 step's vⁿ⁻¹ (the audit's allowance for its two-step energy).
    pub previous_velocity: Option<&'a [Vec3]>,
    /// A Newmark step's aⁿ and β − γ/2 (the audit's allowance for β ≠ γ/2).
    pub start_acceleration: Option<(&'a [Vec3], f64)>,
}

impl Inertial<'_> {
    /// The velocity of position x of vertex i at the step's end, m/s.
    pub fn velocity(&self, i: usize, x: &Vec3) -> Vec3 {
        (x - self.still[i]) / self.velocity_time
    }

    /// Minus the mass-normalised inertia force at velocity v of vertex i: the acceleration, m/s².
    pub fn acceleration(&self, i: usize, v: &Vec3) -> Vec3 {
        (v - self.base_velocity[i]) / self.inertia_time
    }

    /// The Hessian weight of the stiffness-damping force −γ·K·v(x): γ/τ_v.
    pub fn damping_weight(&self, gamma: f64) -> f64 {
        gamma / self.velocity_time
    }

    /// The first-order shift θ of the damping tangent: `(1 + γ/τ_v)·K(x) + γ·(∂K/∂x)[v] =
    /// (1 + γ/τ_v)·K(x + θ·v) + O(θ²)` with θ = γτ_v/(τ_v + γ).
    pub fn damping_shift(&self, gamma: f64) -> f64 {
        gamma * self.velocity_time / (self.velocity_time + gamma)
    }
}

/// A backward-Euler step from (xⁿ, vⁿ) over h, with its own x̃ (for callers that make a step by
/// hand: checks, estimates, tests).
#[derive(Clone, Debug)]
pub struct BackwardEulerStep<'a> {
    xn: &'a [Vec3],
    vn: &'a [Vec3],
    h: f64,
    predicted: Vec<Vec3>,
}

impl<'a> BackwardEulerStep<'a> {
    /// The step from (xn, vn) over h.
    pub fn new(xn: &'a [Vec3], vn: &'a [Vec3], h: f64) -> Self {
        let predicted = xn.iter().zip(vn).map(|(x, v)| x + h * v).collect();
        BackwardEulerStep {
            xn,
            vn,
            h,
            predicted,
        }
    }

    /// The step as the potential reads it.
    pub fn inertial(&self) -> Inertial<'_> {
        backward_euler(self.xn, self.vn, self.h, &self.predicted)
    }
}

fn backward_euler<'a>(
    xn: &'a [Vec3],
    vn: &'a [Vec3],
    h: f64,
    predicted: &'a [Vec3],
) -> Inertial<'a> {
    Inertial {
        h,
        predicted,
        still: xn,
        base_velocity: vn,
        velocity_time: h,
        inertia_time: h,
        inertia_denominator: h * h,
        displacement_is_hv: true,
        start_weight: 0.0,
        previous_velocity: None,
        start_acceleration: None,
    }
}

/// What a scheme keeps from step to step, and the buffers its steps are read from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct History {
    /// BDF2: positions, velocities and length of the step before (length 0: none).
    previous_x: Vec<Vec3>,
    previous_v: Vec<Vec3>,
    previous_h: f64,
    /// Newmark: the acceleration at the current state (empty: not known yet).
    acceleration: Vec<Vec3>,
    /// The planned step: x̃, x_still, ṽ and the scalars.
    predicted: Vec<Vec3>,
    still: Vec<Vec3>,
    base_velocity: Vec<Vec3>,
    plan: Plan,
}

/// The planned step's scalars and which kind of step it is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Plan {
    h: f64,
    velocity_time: f64,
    inertia_time: f64,
    inertia_denominator: f64,
    /// A backward-Euler step (x_still = xⁿ, ṽ = vⁿ: read from the step's start).
    backward_euler: bool,
    /// See [`Inertial::start_weight`].
    start_weight: f64,
    /// A BDF2 step on its history.
    two_step: bool,
    /// A Newmark step's β − γ/2.
    beta_excess: f64,
}

/// The history a checkpoint keeps (see [`History::saved`]).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SavedHistory {
    /// BDF2's previous positions and velocities, and the previous step's length (0: none).
    pub previous: (Vec<[f64; 3]>, Vec<[f64; 3]>, f64),
    /// Newmark's acceleration (empty: none).
    pub acceleration: Vec<[f64; 3]>,
}

/// The largest step ratio h/hₙ₋₁ a BDF2 step takes on its history (variable-step BDF2 is
/// zero-stable below 1 + √2); longer steps start afresh with backward Euler.
const BDF2_MAX_RATIO: f64 = 2.0;

impl History {
    /// Whether `scheme`'s next step needs the acceleration at the current state first (the
    /// first step of Newmark and BDF2, or one after the state was moved from outside).
    pub fn needs_acceleration(&self, scheme: Integrator, n: usize) -> bool {
        matches!(scheme, Integrator::Newmark { .. } | Integrator::Bdf2)
            && self.acceleration.len() != n
    }

    /// Newmark's acceleration at the current state (the forces over the masses).
    pub fn set_acceleration(&mut self, a: Vec<Vec3>) {
        self.acceleration = a;
    }

    /// Forget everything (the state was moved from outside the scheme).
    pub fn clear(&mut self) {
        self.previous_x.clear();
        self.previous_v.clear();
        self.previous_h = 0.0;
        self.acceleration.clear();
    }

    /// Plan `scheme`'s step of h from (xn, vn); [`History::inertial`] then reads it. Returns
    /// the predicted positions (Newton's first guess).
    pub fn plan(&mut self, scheme: Integrator, xn: &[Vec3], vn: &[Vec3], h: f64) -> &[Vec3] {
        let n = xn.len();
        self.predicted.resize(n, Vec3::zeros());
        let ratio = h / self.previous_h;
        match scheme {
            Integrator::Bdf2
                if self.previous_x.len() == n
                    && self.previous_h > 0.0
                    && ratio <= BDF2_MAX_RATIO =>
            {
                let w = ratio;
                let a0 = (1.0 + 2.0 * w) / ((1.0 + w) * h);
                let a1 = -(1.0 + w) / h;
                let a2 = w * w / ((1.0 + w) * h);
                let tau = 1.0 / a0;
                self.still.resize(n, Vec3::zeros());
                self.base_velocity.resize(n, Vec3::zeros());
                for i in 0..n {
                    self.still[i] = -(a1 * xn[i] + a2 * self.previous_x[i]) * tau;
                    self.base_velocity[i] = -(a1 * vn[i] + a2 * self.previous_v[i]) * tau;
                    self.predicted[i] = self.still[i] + tau * self.base_velocity[i];
                }
                self.plan = Plan {
                    h,
                    velocity_time: tau,
                    inertia_time: tau,
                    inertia_denominator: tau * tau,
                    backward_euler: false,
                    start_weight: 0.0,
                    two_step: true,
                    beta_excess: 0.0,
                };
            }
            Integrator::Newmark { beta, gamma } => self.plan_newmark(xn, vn, h, beta, gamma),
            // BDF2's first step (or one after a step change it cannot take): the trapezoidal
            // rule, second order too, from the acceleration at the start.
            Integrator::Bdf2 if self.acceleration.len() == n => {
                self.plan_newmark(xn, vn, h, NEWMARK_BETA, NEWMARK_GAMMA)
            }
            // Backward Euler, BDF2's first step; quasistatic steps read nothing.
            _ => {
                for ((p, x), v) in self.predicted.iter_mut().zip(xn).zip(vn) {
                    *p = x + h * v;
                }
                self.plan = Plan {
                    h,
                    velocity_time: h,
                    inertia_time: h,
                    inertia_denominator: h * h,
                    backward_euler: true,
                    start_weight: 0.0,
                    two_step: false,
                    beta_excess: 0.0,
                };
            }
        }
        &self.predicted
    }

    /// Plan a Newmark step with (β, γ) from the acceleration kept.
    fn plan_newmark(&mut self, xn: &[Vec3], vn: &[Vec3], h: f64, beta: f64, gamma: f64) {
        let n = xn.len();
        let a = &self.acceleration;
        assert_eq!(a.len(), n, "the acceleration is set before a Newmark step");
        let velocity_time = beta * h / gamma;
        self.still.resize(n, Vec3::zeros());
        self.base_velocity.resize(n, Vec3::zeros());
        for i in 0..n {
            self.predicted[i] = xn[i] + h * vn[i] + (0.5 - beta) * h * h * a[i];
            self.base_velocity[i] = vn[i] + (1.0 - gamma) * h * a[i];
            self.still[i] = self.predicted[i] - velocity_time * self.base_velocity[i];
        }
        self.plan = Plan {
            h,
            velocity_time,
            inertia_time: gamma * h,
            inertia_denominator: beta * h * h,
            backward_euler: false,
            start_weight: 1.0 - gamma,
            two_step: false,
            beta_excess: beta - 0.5 * gamma,
        };
    }

    /// The planned step, read from the step's start (xn, vn) and this history's buffers.
    pub fn inertial<'a>(&'a self, xn: &'a [Vec3], vn: &'a [Vec3]) -> Inertial<'a> {
        let p = self.plan;
        if p.backward_euler {
            return backward_euler(xn, vn, p.h, &self.predicted);
        }
        Inertial {
            h: p.h,
            predicted: &self.predicted,
            still: &self.still,
            base_velocity: &self.base_velocity,
            velocity_time: p.velocity_time,
            inertia_time: p.inertia_time,
            inertia_denominator: p.inertia_denominator,
            displacement_is_hv: false,
            start_weight: p.start_weight,
            previous_velocity: p.two_step.then_some(&self.previous_v[..]),
            start_acceleration: (p.beta_excess != 0.0)
                .then_some((&self.acceleration[..], p.beta_excess)),
        }
    }

    /// Carry the history past the step just solved from (xn, vn) to (x, v).
    pub fn finish(&mut self, scheme: Integrator, xn: &[Vec3], vn: &[Vec3], x: &[Vec3], v: &[Vec3]) {
        match scheme {
            Integrator::Bdf2 => {
                self.previous_x.clear();
                self.previous_x.extend_from_slice(xn);
                self.previous_v.clear();
                self.previous_v.extend_from_slice(vn);
                self.previous_h = self.plan.h;
                // The step's acceleration, to start afresh from after a change of step.
                let mut a = std::mem::take(&mut self.acceleration);
                a.resize(v.len(), Vec3::zeros());
                let step = self.inertial(xn, vn);
                for (i, a) in a.iter_mut().enumerate() {
                    *a = step.acceleration(i, &v[i]);
                }
                self.acceleration = a;
            }
            Integrator::Newmark { .. } => {
                let d = self.plan.inertia_denominator;
                for ((a, x), p) in self.acceleration.iter_mut().zip(x).zip(&self.predicted) {
                    *a = (x - p) / d;
                }
            }
            Integrator::BackwardEuler | Integrator::Quasistatic => {}
        }
    }

    /// The part a checkpoint keeps.
    pub fn saved(&self) -> SavedHistory {
        let out = |v: &[Vec3]| v.iter().map(|p| [p.x, p.y, p.z]).collect();
        SavedHistory {
            previous: (
                out(&self.previous_x),
                out(&self.previous_v),
                self.previous_h,
            ),
            acceleration: out(&self.acceleration),
        }
    }

    /// Continue from a checkpoint's history.
    pub fn restore(&mut self, saved: &SavedHistory) {
        let vin = |v: &[[f64; 3]]| v.iter().map(|p| Vec3::from(*p)).collect();
        self.previous_x = vin(&saved.previous.0);
        self.previous_v = vin(&saved.previous.1);
        self.previous_h = saved.previous.2;
        self.acceleration = vin(&saved.acceleration);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Backward Euler's per-step amplitude is 1/√(1 + (ωh)²); the trapezoidal rule keeps 1;
    /// BDF2 lies between and tends to 1 − O((ωh)⁴) for small steps.
    #[test]
    fn amplitude_per_step_matches_the_known_formulas() {
        for wh in [0.01, 0.1, 0.5, 1.0, 3.0, 30.0] {
            let be = Integrator::BackwardEuler.amplitude_per_step(wh);
            assert!((be - 1.0 / (1.0 + wh * wh).sqrt()).abs() < 1e-15);
            let nm = Integrator::newmark().amplitude_per_step(wh);
            assert!((nm - 1.0).abs() < 1e-12, "{wh}: {nm}");
            let bdf = Integrator::Bdf2.amplitude_per_step(wh);
            assert!(bdf < 1.0 && bdf > be, "{wh}: {bdf} against {be}");
        }
        let small = 1.0 - Integrator::Bdf2.amplitude_per_step(0.01);
        assert!(small < 1e-7, "{small}");
        // γ > ½ damps.
        let damped = Integrator::Newmark {
            beta: 0.3025,
            gamma: 0.6,
        };
        assert!(damped.amplitude_per_step(10.0) < 0.95);
    }

    /// A step of the harmonic oscillator ẍ = −x planned and finished by the history matches
    /// the schemes' textbook updates.
    #[test]
    fn planned_steps_match_the_textbook_updates() {
        let h = 0.1;
        // Solve the scalar step: m(ṽ − v(x))/τ_a − x = 0 with v(x) = (x − still)/τ_v.
        let solve = |s: Inertial<'_>| {
            let (still, vt) = (s.still[0].x, s.base_velocity[0].x);
            // (vt − (x − still)/τ_v)/τ_a = x  ⇒  x (1 + 1/(τ_vτ_a)) = vt/τ_a + still/(τ_vτ_a)
            let d = s.inertia_denominator;
            (vt / s.inertia_time + still / d) / (1.0 + 1.0 / d)
        };
        let (x0, v0) = (
            vec![Vec3::new(1.0, 0.0, 0.0)],
            vec![Vec3::new(0.5, 0.0, 0.0)],
        );
        // Newmark, average acceleration: the energy ½(x² + v²) is kept.
        let mut history = History::default();
        history.set_acceleration(vec![-x0[0]]);
        history.plan(Integrator::newmark(), &x0, &v0, h);
        let x1 = solve(history.inertial(&x0, &v0));
        let v1 = history
            .inertial(&x0, &v0)
            .velocity(0, &Vec3::new(x1, 0.0, 0.0))
            .x;
        assert!(((x1 * x1 + v1 * v1) - (1.0 + 0.25)).abs() < 1e-14);
        // BDF2 after a backward-Euler start: v₂ = (3x₂ − 4x₁ + x₀)/(2h), a₂ likewise.
        let mut history = History::default();
        history.plan(Integrator::Bdf2, &x0, &v0, h);
        let s = history.inertial(&x0, &v0);
        assert!(s.displacement_is_hv);
        let x1 = solve(s);
        let v1 = s.velocity(0, &Vec3::new(x1, 0.0, 0.0)).x;
        assert!((v1 - (x1 - 1.0) / h).abs() < 1e-15);
        let (xs1, vs1) = (vec![Vec3::new(x1, 0.0, 0.0)], vec![Vec3::new(v1, 0.0, 0.0)]);
        history.finish(Integrator::Bdf2, &x0, &v0, &xs1, &vs1);
        history.plan(Integrator::Bdf2, &xs1, &vs1, h);
        let s = history.inertial(&xs1, &vs1);
        let x2 = solve(s);
        let v2 = s.velocity(0, &Vec3::new(x2, 0.0, 0.0)).x;
        assert!((v2 - (3.0 * x2 - 4.0 * x1 + 1.0) / (2.0 * h)).abs() < 1e-12);
        let a2 = s.acceleration(0, &Vec3::new(v2, 0.0, 0.0)).x;
        assert!((a2 - (3.0 * v2 - 4.0 * v1 + 0.5) / (2.0 * h)).abs() < 1e-12);
        assert!((a2 + x2).abs() < 1e-12);
    }
}
