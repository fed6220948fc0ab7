//! Tangled elements: the inversion extension of a model (SPEC §3) is tuned for elements crushed
//! near inversion, where the compressive resistance must keep growing; a body that starts
//! collapsed, scrambled or inverted needs the opposite, an energy that stops driving flattened
//! tets to stretch in their plane. The exact Neo-Hookean energy has genuine local minima where a
//! tangled body stays folded (every tet positive, the mesh lying over itself, tets at a stretch
//! of about 0.25), so no extension below a small threshold can bring those bodies back.
//!
//! So each element carries a flag. A *tangled* element is evaluated with one of its model's
//! recovery forms ([`Model::recovery`]), every other one with the model itself; the forms equal
//! the model wherever every stretch is at least the recovery threshold (0.6). Which form
//! depends on the body:
//! - while the body is *collapsed* (at least [`COLLAPSED_SHARE`] of its tets inverted or flat,
//!   J ≤ 0), the collapsed form: for Neo-Hookean a levelled log
//!   ([`crate::material::LevelledNeoHookean`]), which opens a body squeezed onto a plane, a line
//!   or a point in a few Newton iterations;
//! - from then on, while a few tets are inverted or the body *overlaps* itself (a vertex
//!   strictly inside a tet it is not a vertex of, [`crate::mesh::overlap`]: a fold), Irving et
//!   al. 2004's clamp of the stretches with a 2μ spring, which undoes the folds the levelled log
//!   leaves (alone it left 106 of 172 tangled starts folded; see the user guide for the sweep).
//!
//! At the start of each step (never inside one, so every step minimises one energy):
//! - the body is *tangled* when it is collapsed or overlapping;
//! - a tangled start (the first step, or a state the caller put in place) flags every element;
//!   later, an element that is inverted or flat at a step's start is flagged;
//! - once the body is untangled, an element is cleared when every stretch is back above the
//!   recovery threshold, where its recovery form and its model are the same function: clearing
//!   never changes the energy.
//!
//! A body that never tangles is never checked beyond its inverted count, and its elements are
//! always their model.

use rayon::prelude::*;

use super::ElasticBody;
use crate::material::{DEFAULT_RECOVERY_THRESHOLD, Model, RecoveryForms};
use crate::math::{Vec3, svd_rv};

/// A body is [`Tangle::Collapsed`] while at least this share of its tets is inverted or flat.
/// The levelled log opens a collapsed body fast but can hold a few tets inverted for good (a
/// beam on a line kept one inside out over 300 frames), so the clamp takes over below it.
pub const COLLAPSED_SHARE: f64 = 0.1;

/// The collapsed form gives way to the clamp when its body's count of collapsed tets has not
/// reached a new low for this many frames: a jittered beam squeezed onto a point stayed there
/// under the levelled log (95 of 192 tets inverted for 300 frames).
pub const STALLED_FRAMES: u32 = 10;

/// The collapsed form's progress (see [`STALLED_FRAMES`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Unfolding {
    /// The fewest collapsed tets (over every rank) at a frame's start so far.
    pub best: usize,
    /// Frames since that low.
    pub stalled: u32,
}

/// How a body is tangled (ordered: the worst is the largest).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Tangle {
    /// Every tet positive and no vertex inside another tet.
    #[default]
    Untangled,
    /// A few tets inverted or flat, or a vertex strictly inside a tet it is not a vertex of.
    Overlapping,
    /// At least [`COLLAPSED_SHARE`] of the tets inverted or flat (J ≤ 0).
    Collapsed,
}

impl Tangle {
    /// The tangle of a body with `collapsed` of its `tets` inverted or flat, and a vertex inside
    /// a tet or not.
    pub fn classify(collapsed: usize, tets: usize, overlapping: bool) -> Self {
        if collapsed > 0 && collapsed as f64 >= COLLAPSED_SHARE * tets as f64 {
            Tangle::Collapsed
        } else if collapsed > 0 || overlapping {
            Tangle::Overlapping
        } else {
            Tangle::Untangled
        }
    }
}

/// The recovery forms of a body's materials and which elements use them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recovery {
    /// Per material index (0: the body's own, k: region k − 1): the threshold (0: off).
    thresholds: Vec<f64>,
    /// Per material index: the forms tangled elements use (None: the model itself).
    forms: Vec<Option<RecoveryForms>>,
    /// While the collapsed form is in use, its progress; None: the clamp.
    unfolding: Option<Unfolding>,
    /// Per tet: whether it is tangled (empty while none is).
    tangled: Vec<bool>,
    /// How many tets are tangled.
    count: usize,
}

/// What [`ElasticBody::update_recovery`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecoveryUpdate {
    /// Elements newly flagged.
    pub flagged: usize,
    /// Elements cleared.
    pub cleared: usize,
    /// Tangled elements that changed from one recovery form to the other.
    pub switched: usize,
}

impl RecoveryUpdate {
    /// Whether any element changed its form (and so the body its energy).
    pub fn changed(&self) -> bool {
        self.flagged + self.cleared + self.switched > 0
    }
}

impl Recovery {
    /// The default forms of `models` (material index order).
    pub(super) fn new<'a>(models: impl Iterator<Item = &'a Model>) -> Self {
        let forms: Vec<Option<RecoveryForms>> = models
            .map(|m| m.recovery(DEFAULT_RECOVERY_THRESHOLD))
            .collect();
        Recovery {
            thresholds: vec![DEFAULT_RECOVERY_THRESHOLD; forms.len()],
            forms,
            unfolding: None,
            tangled: Vec::new(),
            count: 0,
        }
    }

    /// The form tet t of material k is evaluated with, when not its model.
    #[inline]
    pub(super) fn form(&self, t: usize, k: usize) -> Option<&Model> {
        match self.tangled.get(t) {
            Some(true) => self.forms[k].as_ref().map(|f| match self.unfolding {
                Some(_) => &f.collapsed,
                None => &f.overlapping,
            }),
            _ => None,
        }
    }

    /// The same for a part of the body: `tets` are the whole body's indices of the part's tets.
    pub(super) fn part(&self, tets: &[usize]) -> Recovery {
        let tangled: Vec<bool> = if self.tangled.is_empty() {
            Vec::new()
        } else {
            tets.iter().map(|&t| self.tangled[t]).collect()
        };
        let count = tangled.iter().filter(|&&b| b).count();
        Recovery {
            thresholds: self.thresholds.clone(),
            forms: self.forms.clone(),
            unfolding: self.unfolding,
            tangled: if count == 0 { Vec::new() } else { tangled },
            count,
        }
    }
}

impl ElasticBody {
    /// Set the recovery threshold of material k (see [`ElasticBody::material_index`]): a tangled
    /// element of it is evaluated with Irving's clamp of the stretches below `threshold`; 0 turns
    /// recovery off for it (a tangled element is then its model).
    pub fn set_recovery_threshold(&mut self, k: usize, threshold: f64) {
        let model = *self.material(k).0;
        self.recovery.thresholds[k] = threshold;
        self.recovery.forms[k] = model.recovery(threshold);
    }

    /// The recovery threshold of material k (0: off).
    pub fn recovery_threshold(&self, k: usize) -> f64 {
        self.recovery.thresholds[k]
    }

    /// Whether element t is tangled (evaluated with its recovery form).
    pub fn is_tangled_tet(&self, t: usize) -> bool {
        self.recovery.tangled.get(t) == Some(&true)
    }

    /// How many elements are tangled (evaluated with their recovery form).
    pub fn tangled_tets(&self) -> usize {
        self.recovery.count
    }

    /// The tangled elements, in order (for a checkpoint).
    pub fn tangled_list(&self) -> Vec<u32> {
        (0..self.recovery.tangled.len())
            .filter(|&t| self.recovery.tangled[t])
            .map(|t| t as u32)
            .collect()
    }

    /// The collapsed form's progress while it is in use (None: tangled elements use the clamp).
    pub fn unfolding(&self) -> Option<Unfolding> {
        self.recovery.unfolding
    }

    /// Flag exactly the listed elements as tangled, with the collapsed form while `unfolding`
    /// (a checkpoint's state). Fails on an index beyond the body's tets.
    pub fn set_tangled_list(
        &mut self,
        list: &[u32],
        unfolding: Option<Unfolding>,
    ) -> Result<(), String> {
        self.recovery.unfolding = unfolding;
        let n = self.tet_count();
        if let Some(&bad) = list.iter().find(|&&t| t as usize >= n) {
            return Err(format!("tangled element {bad} of a body of {n} tets"));
        }
        self.recovery.tangled = if list.is_empty() {
            Vec::new()
        } else {
            let mut flags = vec![false; n];
            for &t in list {
                flags[t as usize] = true;
            }
            flags
        };
        self.recovery.count = self.recovery.tangled.iter().filter(|&&b| b).count();
        Ok(())
    }

    /// Whether any material has a recovery form.
    pub fn has_recovery(&self) -> bool {
        self.recovery.forms.iter().any(Option::is_some)
    }

    /// What makes the body tangled at `x` (see the module docs): how many tets are inverted or
    /// flat, and (only asked when none is) whether a vertex lies strictly inside a tet it is not
    /// a vertex of. Under MPI a part answers for its own tets; [`Tangle::classify`] the sums.
    pub fn tangle_counts(&self, x: &[Vec3]) -> (usize, bool) {
        let collapsed = (0..self.tet_count())
            .into_par_iter()
            .filter(|&t| self.deformation_gradient(x, t).determinant() <= 0.0)
            .count();
        let overlapping = collapsed == 0
            && crate::mesh::overlap::first_vertex_inside(x, &self.mesh.tets).is_some();
        (collapsed, overlapping)
    }

    /// Update the flags at the start of a step (see the module docs). `tangle` is the body's at
    /// `x` and `collapsed` its count of inverted or flat tets (over every rank, see
    /// [`ElasticBody::tangle_counts`]); `fresh`: whether `x` was not reached by a step (the first
    /// one, or put in place by the caller).
    pub fn update_recovery(
        &mut self,
        x: &[Vec3],
        tangle: Tangle,
        collapsed: usize,
        fresh: bool,
    ) -> RecoveryUpdate {
        let tangled = tangle != Tangle::Untangled;
        let mut update = RecoveryUpdate::default();
        // The collapsed form only opens a tangle: a body that is collapsed as a new tangle starts
        // uses it until it is no longer collapsed or stops making progress; then the clamp,
        // until every element is cleared, even if tets invert again (switching back and forth
        // made a beam fold and unfold in a cycle of 20 frames).
        let was = self.recovery.unfolding;
        let opening = fresh || self.recovery.count == 0;
        let now = match (tangle, was) {
            (Tangle::Collapsed, Some(u)) if collapsed < u.best => Some(Unfolding {
                best: collapsed,
                stalled: 0,
            }),
            (Tangle::Collapsed, Some(u)) if u.stalled + 1 < STALLED_FRAMES => Some(Unfolding {
                best: u.best,
                stalled: u.stalled + 1,
            }),
            (Tangle::Collapsed, None) if opening => Some(Unfolding {
                best: collapsed,
                stalled: 0,
            }),
            _ => None,
        };
        if self.recovery.count > 0 && was.is_some() != now.is_some() {
            // Another form for every tangled element: the energy changes.
            update.switched = self.recovery.count;
        }
        self.recovery.unfolding = now;
        // The forms follow the models (a caller may have replaced `model`).
        for k in 0..self.recovery.forms.len() {
            let model = *self.material(k).0;
            self.recovery.forms[k] = model.recovery(self.recovery.thresholds[k]);
        }
        if !self.has_recovery() || (!tangled && self.recovery.count == 0) {
            return update;
        }
        let n = self.tet_count();
        if self.recovery.tangled.is_empty() {
            self.recovery.tangled = vec![false; n];
        }
        let has_form: Vec<bool> = (0..n)
            .map(|t| self.recovery.forms[self.material_index(t)].is_some())
            .collect();
        let changes: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|t| {
                if !has_form[t] {
                    return false;
                }
                let flagged = self.recovery.tangled[t];
                if tangled {
                    !flagged && (fresh || self.deformation_gradient(x, t).determinant() <= 0.0)
                } else {
                    flagged && {
                        let threshold = self.recovery.thresholds[self.material_index(t)];
                        svd_rv(&self.deformation_gradient(x, t)).sigma[2] >= threshold
                    }
                }
            })
            .collect();
        for (t, change) in changes.into_iter().enumerate() {
            if change {
                let flag = &mut self.recovery.tangled[t];
                *flag = !*flag;
                if *flag {
                    update.flagged += 1;
                } else {
                    update.cleared += 1;
                }
            }
        }
        self.recovery.count = self.recovery.count + update.flagged - update.cleared;
        if self.recovery.count == 0 {
            self.recovery.tangled = Vec::new();
        }
        update
    }
}
