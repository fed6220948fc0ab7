//! `[[probe]]` entries and `[[fixed]] name`s made into the [`Monitors`] a simulation records
//! (SPEC §13): each probe found in its tet, or refused at its `point` key's line.

use crate::elastic::ElasticBody;
use crate::error::Result;
use crate::math::Vec3;
use crate::monitor::{Monitors, Probe, ReactionGroup};

use super::bodies::Membership;
use super::locate::key;
use super::schema::Scene;

impl Scene {
    /// The probes located in `body` (rest positions after placement; a probe with `body = ...`
    /// only in that body's tets) and the named constraints (constraint i is `[[fixed]]` #i+1).
    pub(super) fn build_monitors(
        &self,
        body: &ElasticBody,
        membership: &Membership,
    ) -> Result<Monitors> {
        let mut probes = Vec::with_capacity(self.probe.len());
        for (i, spec) in self.probe.iter().enumerate() {
            let tets = match spec.body.as_deref() {
                Some(name) => Some(
                    membership
                        .keep_tets(Some(name), (0..body.tet_count()).collect())
                        .map_err(|m| self.error_at(&key!["probe", i, "body"], m))?,
                ),
                None => None,
            };
            let probe = Probe::locate(&spec.name, body, Vec3::from(spec.point), tets.as_deref())
                .map_err(|m| self.error_at(&key!["probe", i, "point"], m))?;
            probes.push(probe);
        }
        let reactions = self
            .fixed
            .iter()
            .enumerate()
            .filter_map(|(i, f)| {
                f.name.clone().map(|name| ReactionGroup {
                    name,
                    constraint: i,
                })
            })
            .collect();
        Ok(Monitors { probes, reactions })
    }
}
