//! Snapshot and restore of a simulation for a checkpoint (SPEC §14): everything the next frame reads that the scene does not give.

use super::*;

impl Simulation {
    /// The state after the last frame, for a checkpoint: everything the next frame reads that
    /// the scene does not give (see [`crate::checkpoint`]).
    pub fn snapshot(&self) -> crate::checkpoint::SimulationState {
        use crate::linear::state::vectors_out;
        crate::checkpoint::SimulationState {
            frame: self.frame,
            t: self.state.t,
            x: vectors_out(&self.state.x),
            v: vectors_out(&self.state.v),
            free: vectors_out(&self.free),
            ledger: (
                self.ledger.elastic,
                vectors_out(&self.ledger.loads),
                vectors_out(&self.ledger.reactions),
            ),
            ramp_frames: self.ramp_frames(),
            pattern_generation: self.newton.potential().pattern_generation(),
            solver: self.newton.solver_state(),
            contact: self.contact().map(|c| c.saved_state()),
            tangled: self.body.tangled_list(),
            unfolding: self.body.unfolding().map(|u| (u.best as u64, u.stalled)),
            inverted_at_end: self.inverted_at_end as u64,
            history: self.history.saved(),
            ledger_damping: vectors_out(&self.ledger.damping),
            ledger_added: self.ledger.added,
        }
    }

    /// Continue from a [`Simulation::snapshot`] of a simulation made from the same scene; the
    /// frames to run (`params.frames`) may have grown since, the ramps keep the snapshot's.
    pub fn restore(&mut self, saved: &crate::checkpoint::SimulationState) -> Result<()> {
        use crate::linear::state::vectors_in;
        let n = self.body.vertex_count();
        let fits = |v: &Vec<[f64; 3]>| v.len() == n;
        if !(fits(&saved.x)
            && fits(&saved.v)
            && fits(&saved.free)
            && fits(&saved.ledger.1)
            && fits(&saved.ledger.2))
        {
            return Err(Error::parameter(
                "resume",
                format!("the checkpoint's state does not fit the scene's mesh of {n} vertices"),
            ));
        }
        if saved.contact.is_some() != self.contact().is_some() {
            return Err(Error::parameter(
                "resume",
                "the checkpoint and the scene disagree on contact",
            ));
        }
        // Before the forces below: a tangled element's forces are its recovery form's.
        self.body
            .set_tangled_list(
                &saved.tangled,
                saved
                    .unfolding
                    .map(|(best, stalled)| crate::elastic::recovery::Unfolding {
                        best: best as usize,
                        stalled,
                    }),
            )
            .map_err(|e| Error::parameter("resume", e))?;
        self.newton
            .restore_solver_state(&saved.solver, &self.body.mesh.positions)
            .map_err(|e| Error::parameter("resume", e))?;
        self.newton
            .potential_mut()
            .restore_pattern_generation(saved.pattern_generation);
        if let (Some(state), Some(contact)) =
            (&saved.contact, &mut self.newton.potential_mut().contact)
        {
            contact.restore_state(state);
        }
        self.state = State {
            x: vectors_in(&saved.x),
            v: vectors_in(&saved.v),
            t: saved.t,
        };
        self.free = vectors_in(&saved.free);
        // The elastic forces at the saved state are a function of it: recomputed, not stored.
        let mut forces = vec![Vec3::zeros(); self.state.x.len()];
        self.body.add_forces(&self.state.x, &mut forces);
        self.ledger = Ledger {
            elastic: saved.ledger.0,
            loads: vectors_in(&saved.ledger.1),
            reactions: vectors_in(&saved.ledger.2),
            forces,
            damping: vectors_in(&saved.ledger_damping),
            added: saved.ledger_added,
        };
        self.saved_ledger.clone_from(&self.ledger);
        self.ledger_x.clone_from(&self.state.x);
        self.saved.clone_from(&self.state);
        self.history.restore(&saved.history);
        self.saved_history.clone_from(&self.history);
        self.frame = saved.frame;
        self.ramp_frames = Some(saved.ramp_frames);
        self.inverted_at_end = saved.inverted_at_end as usize;
        self.tangled_total = saved.tangled.len();
        Ok(())
    }
}
