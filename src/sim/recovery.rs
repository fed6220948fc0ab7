//! The start of a frame for the tangled-element flags (see [`crate::elastic::recovery`]).

use super::*;

/// Newton's iteration cap in a frame that starts with tangled elements, when the scene's is
/// lower: a tangled body's first frames converge linearly while the clamp's stiffness changes
/// under them (a cube flattened onto a plane: 35 iterations in one step, where a cap of 20 cut
/// the step into 16 substeps and still did not converge).
pub const TANGLED_NEWTON_CAP: usize = 100;

impl Simulation {
    /// Update the body's tangled-element flags at the start of a frame; `fresh` when the state
    /// was not reached by a frame (the first, or put in place by the caller). Returns whether any
    /// element changed its form (the ledger's elastic energy is then stale). Skipped, at the
    /// cost of nothing, while the last frame ended with no inverted tet and no element is
    /// tangled. Every decision here is the same on every rank.
    pub(super) fn update_recovery(&mut self, fresh: bool) -> bool {
        if !self.body.has_recovery()
            || (!fresh && self.tangled_total == 0 && self.inverted_at_end == 0)
        {
            return false;
        }
        let ranks = self.newton.ranks().cloned();
        let (collapsed, overlapping) = self.body.tangle_counts(&self.state.x);
        let mut sums = [
            collapsed as f64,
            self.body.tet_count() as f64,
            if overlapping { 1.0 } else { 0.0 },
        ];
        if let Some(ranks) = &ranks {
            ranks.sum(&mut sums);
        }
        let tangle = crate::elastic::recovery::Tangle::classify(
            sums[0] as usize,
            sums[1] as usize,
            sums[2] > 0.0,
        );
        let update = self
            .body
            .update_recovery(&self.state.x, tangle, sums[0] as usize, fresh);
        let mut counts = [
            self.body.tangled_tets() as f64,
            update.flagged as f64,
            update.cleared as f64,
        ];
        if let Some(ranks) = &ranks {
            ranks.sum(&mut counts);
        }
        self.tangled_total = counts[0] as usize;
        let (flagged, cleared) = (counts[1] as usize, counts[2] as usize);
        if update.changed() {
            log::info!(
                "frame {}: {} elements tangled ({flagged} flagged, {cleared} cleared; body \
                 {tangle:?}, {} form): evaluated with their model's recovery form",
                self.frame + 1,
                self.tangled_total,
                if self.body.unfolding().is_some() {
                    "collapsed"
                } else {
                    "clamped"
                },
            );
        }
        update.changed()
    }

    /// The solver settings of the next frame: the scene's, with Newton's cap raised to
    /// [`TANGLED_NEWTON_CAP`] while elements are tangled.
    pub(super) fn frame_params(&self) -> std::borrow::Cow<'_, SolverParams> {
        if self.tangled_total > 0 && self.params.newton_max_iterations < TANGLED_NEWTON_CAP {
            std::borrow::Cow::Owned(SolverParams {
                newton_max_iterations: TANGLED_NEWTON_CAP,
                ..self.params.clone()
            })
        } else {
            std::borrow::Cow::Borrowed(&self.params)
        }
    }
}
