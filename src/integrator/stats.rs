//! What a Newton solve and a frame did: iterations, residuals, failures, timings; a frame's
//! row of steps.csv.

/// What one Newton solve did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NewtonInfo {
    /// Newton iterations (linear solves).
    pub iterations: usize,
    /// CG iterations summed over the solves.
    pub cg_iterations: usize,
    /// Final ‖rhs‖ over free DOFs, N.
    pub residual: f64,
    /// Final ‖rhs‖ / first ‖rhs‖ (0 when the first was already below the floor).
    pub relative_residual: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
    /// Line-search halvings taken.
    pub line_search_cuts: usize,
    /// CG solves that broke down (pᵀAp ≤ 0): the step then used the iterate so far.
    pub cg_breakdowns: usize,
    /// CG solves that hit their iteration cap.
    pub cg_capped: usize,
    /// Most tets with a clamped tangent at any iterate.
    pub clamped_tets: usize,
    /// Most tets with a strongly clamped tangent at any iterate (beyond rounding; see
    /// [`crate::material::STRONG_CLAMP`]).
    pub strongly_clamped_tets: usize,
    /// `adaptive` definiteness: Newton iterates whose exact-tangent direction was given up for
    /// the projected one (CG met negative curvature, no descent, or the line search failed).
    pub projected_fallbacks: usize,
    /// Elastic energy at the final iterate, J.
    pub elastic_energy: f64,
    /// Why it stopped without converging, in words.
    pub failure: Option<String>,
    /// ‖rhs‖ at every iterate, first to last (for convergence studies).
    pub history: Vec<f64>,
    /// Where the time went.
    pub timings: Timings,
}

impl NewtonInfo {
    /// Fold in a follow-up solve of the same step (a moving obstacle's next push): counts and
    /// times add up, the history goes on, and the outcome is the follow-up's.
    pub fn then(&mut self, more: NewtonInfo) {
        self.iterations += more.iterations;
        self.cg_iterations += more.cg_iterations;
        self.line_search_cuts += more.line_search_cuts;
        self.cg_breakdowns += more.cg_breakdowns;
        self.cg_capped += more.cg_capped;
        self.projected_fallbacks += more.projected_fallbacks;
        self.clamped_tets = self.clamped_tets.max(more.clamped_tets);
        self.strongly_clamped_tets = self.strongly_clamped_tets.max(more.strongly_clamped_tets);
        self.residual = more.residual;
        self.relative_residual = more.relative_residual;
        self.converged = more.converged;
        self.elastic_energy = more.elastic_energy;
        self.failure = more.failure;
        self.history.extend(more.history);
        self.timings.add(&more.timings);
    }
}

/// Wall-clock seconds by phase, for `tetsim bench` and tuning.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Forces, energy and tangents (one SVD per tet per evaluation, line-search trials included).
    pub evaluate: f64,
    /// Preconditioner setup (and matrix assembly, on assembled paths).
    pub preconditioner: f64,
    /// Conjugate gradient.
    pub cg: f64,
}

impl Timings {
    /// Add another's times.
    pub fn add(&mut self, other: &Timings) {
        self.evaluate += other.evaluate;
        self.preconditioner += other.preconditioner;
        self.cg += other.cg;
    }
}

/// Per-frame statistics: one row of steps.csv.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Frame number (1-based; frame 0 is the initial state).
    pub frame: usize,
    /// Time at the end of the frame, s (quasistatic: the load factor).
    pub time: f64,
    /// Newton iterations over the frame's substeps.
    pub newton_iterations: usize,
    /// CG iterations over the frame's substeps.
    pub cg_iterations: usize,
    /// Largest final ‖rhs‖ over the substeps, N.
    pub residual: f64,
    /// Largest final relative residual over the substeps.
    pub relative_residual: f64,
    /// Whether every substep converged.
    pub converged: bool,
    /// Elastic energy at the end of the frame, J.
    pub elastic_energy: f64,
    /// Kinetic energy at the end of the frame, J.
    pub kinetic_energy: f64,
    /// Smallest det F at the end of the frame.
    pub min_j: f64,
    /// Tets with det F ≤ 0 at the end of the frame.
    pub inverted_elements: usize,
    /// Tets evaluated with their model's recovery form during the frame (see
    /// [`crate::elastic::recovery`]).
    pub tangled_elements: usize,
    /// Wall-clock seconds spent on the frame (retries included).
    pub wall_seconds: f64,
    /// Substeps used (more than asked when the step was cut).
    pub substeps: usize,
    /// Line-search halvings over the frame.
    pub line_search_cuts: usize,
    /// CG solves that broke down.
    pub cg_breakdowns: usize,
    /// CG solves that hit their cap.
    pub cg_capped: usize,
    /// Most tets with a clamped tangent at any iterate.
    pub clamped_tets: usize,
    /// Most tets with a strongly clamped tangent at any iterate (not in steps.csv).
    pub strongly_clamped_tets: usize,
    /// Why the frame did not converge, in words.
    pub failure: Option<String>,
    /// Active contact pairs at the end of the frame (0 without contact).
    pub contacts: usize,
    /// The smallest gap between a body and anything it can touch at the end of the frame, m
    /// (None without contact).
    pub min_distance: Option<f64>,
    /// Barrier energy at the end of the frame, J.
    pub contact_energy: f64,
    /// Energy friction dissipated over the frame, J.
    pub friction_dissipation: f64,
    /// The frame's energy audit (see [`crate::audit`]).
    pub energy: crate::audit::EnergyAudit,
    /// Time by phase over the frame (not written to steps.csv: it is not deterministic).
    pub timings: Timings,
}

impl StepStats {
    /// Fold one substep's Newton result in.
    pub fn absorb(&mut self, info: &NewtonInfo) {
        self.newton_iterations += info.iterations;
        self.cg_iterations += info.cg_iterations;
        self.residual = self.residual.max(info.residual);
        self.relative_residual = self.relative_residual.max(info.relative_residual);
        self.converged &= info.converged;
        self.line_search_cuts += info.line_search_cuts;
        self.cg_breakdowns += info.cg_breakdowns;
        self.cg_capped += info.cg_capped;
        self.clamped_tets = self.clamped_tets.max(info.clamped_tets);
        self.strongly_clamped_tets = self.strongly_clamped_tets.max(info.strongly_clamped_tets);
        self.elastic_energy = info.elastic_energy;
        self.timings.add(&info.timings);
        if self.failure.is_none() {
            self.failure.clone_from(&info.failure);
        }
    }
}
