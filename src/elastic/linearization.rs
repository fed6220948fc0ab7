//! [`Linearization`]: K frozen at one state, the per-point tangents a Newton iterate's
//! stiffness products and assembled matrices are made from.

use super::*;

/// K frozen at one state: the per-tet tangents and the scratch the stiffness product needs.
/// Built by [`ElasticBody::linearize`], refilled in place by [`ElasticBody::linearize_into`].
#[derive(Clone, Debug)]
pub struct Linearization {
    pub(super) definiteness: Definiteness,
    pub(super) tangents: Vec<Tangent>,
    /// `adaptive` only: per tet the pieces not in use (the exact ones while `tangents` holds
    /// the projected ones, and the other way round after [`Linearization::use_exact`]).
    pub(super) alternate: Vec<DiagonalPieces>,
    pub(super) exact_active: bool,
    pub(super) buffer: Vec<TetSlot>,
    /// Damped steps only: per tet its K_d·v contributions (empty until the first one).
    pub(super) damping: Vec<TetSlot>,
    /// Quadratic tets: their slots in place of `buffer` and `damping` (which stay empty).
    pub(super) buffer10: Vec<quadratic::Slot10>,
    pub(super) damping10: Vec<quadratic::Slot10>,
    /// The tangents are not those of the last evaluation yet (a damped step with a shift; see
    /// [`ElasticBody::damped_tangents_into`]).
    pub(super) tangents_pending: bool,
    pub(super) chunk_energy: Vec<f64>,
    pub(super) clamped_tets: usize,
    pub(super) strongly_clamped_tets: usize,
    pub(super) inverted_tets: usize,
}

impl Linearization {
    /// Buffers sized for `body`, to be filled by [`ElasticBody::linearize_into`].
    pub fn new(body: &ElasticBody, definiteness: Definiteness) -> Self {
        let n = body.point_count();
        let quadratic = body.quadratic.is_some();
        let rest = crate::material::Material::tangent(&body.model, &Mat3::identity(), definiteness);
        let alternate = match definiteness {
            Definiteness::Adaptive => vec![DiagonalPieces::default(); n],
            _ => Vec::new(),
        };
        Linearization {
            definiteness,
            tangents: vec![rest; n],
            alternate,
            exact_active: false,
            buffer: if quadratic {
                Vec::new()
            } else {
                vec![[Vec3::zeros(); 3]; n]
            },
            damping: Vec::new(),
            buffer10: quadratic_body::slots10(body),
            damping10: Vec::new(),
            tangents_pending: false,
            chunk_energy: vec![0.0; n.div_ceil(CHUNK)],
            clamped_tets: 0,
            strongly_clamped_tets: 0,
            inverted_tets: 0,
        }
    }

    /// Its per-tet buffers, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        inventory.add(
            "per-tet tangents (U, V, diagonal-space pieces)",
            vec_bytes(&self.tangents),
        );
        inventory.add(
            "per-tet alternate pieces (adaptive)",
            vec_bytes(&self.alternate),
        );
        inventory.add(
            "per-tet force slots",
            vec_bytes(&self.buffer) + vec_bytes(&self.buffer10),
        );
        inventory.add(
            "per-tet damping K·v slots",
            vec_bytes(&self.damping) + vec_bytes(&self.damping10),
        );
    }

    /// Whether the tangents still wait for [`ElasticBody::damped_tangents_into`] (their counts
    /// are then those of an earlier linearization).
    pub fn tangents_pending(&self) -> bool {
        self.tangents_pending
    }

    /// Count the clamped, strongly clamped and inverted tets of the tangents just made.
    /// One parallel pass (integer sums: the same for any thread count).
    pub(super) fn count_tets(&mut self) {
        let (clamped, strongly, inverted) = self
            .tangents
            .par_iter()
            .with_min_len(CHUNK)
            .map(|t| {
                (
                    (t.clamped_pieces() > 0) as usize,
                    t.strongly_clamped() as usize,
                    t.is_inverted() as usize,
                )
            })
            .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
        self.clamped_tets = clamped;
        self.strongly_clamped_tets = strongly;
        self.inverted_tets = inverted;
    }

    /// The definiteness treatment these tangents were built with.
    pub fn definiteness(&self) -> Definiteness {
        self.definiteness
    }

    /// The per-tet tangents ∂P/∂F.
    pub fn tangents(&self) -> &[Tangent] {
        &self.tangents
    }

    /// How many tets had part of their tangent clamped by the definiteness fix.
    pub fn clamped_tets(&self) -> usize {
        self.clamped_tets
    }

    /// How many tets had a piece of their tangent clamped by more than rounding (see
    /// [`crate::material::STRONG_CLAMP`]).
    pub fn strongly_clamped_tets(&self) -> usize {
        self.strongly_clamped_tets
    }

    /// How many tets were inverted or flat (σ₃ ≤ 0).
    pub fn inverted_tets(&self) -> usize {
        self.inverted_tets
    }

    /// With the `adaptive` strategy, switch the clamped tets to their exact tangents (`true`)
    /// or back to the projected ones (`false`); a linearization starts projected. Does nothing
    /// for the other strategies.
    pub fn use_exact(&mut self, exact: bool) {
        if self.alternate.is_empty() || exact == self.exact_active {
            return;
        }
        self.tangents
            .par_iter_mut()
            .zip(self.alternate.par_iter_mut())
            .with_min_len(CHUNK)
            .filter(|(t, _)| t.clamped_pieces() > 0)
            .for_each(|(t, a)| t.swap_pieces(a));
        self.exact_active = exact;
    }

    /// True while [`Linearization::use_exact`] has the exact tangents in use.
    pub fn exact_in_use(&self) -> bool {
        self.exact_active
    }
}
