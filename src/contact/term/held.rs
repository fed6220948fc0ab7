//! The Hessian blocks that contact pairs between body vertices may fill beyond the mesh's own
//! adjacency (body–body and self-contact pairs couple vertices of distinct primitives), held as
//! a superset so that the matrix pattern changes rarely.
//!
//! A new pattern rebuilds the assembled matrix and what depends on it (AMG aggregates, the
//! Cholesky analysis): far too expensive for every Newton iterate. So the held set is the
//! couplings of every pair within a *hold radius* (2√d̂) of each other, not only of the pairs
//! within d̂: it is renewed at the start of each step, grown during the step only when an active
//! pair is not covered, and started over only when it has grown far beyond what the step needs.
//! Its generation changes exactly when the set does.

/// A sorted, unique set of blocks (i, j), i < j, with a generation.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct HeldBlocks {
    blocks: Vec<(u32, u32)>,
    generation: u64,
}

/// Hold at most this many times the step's need (plus [`SLACK`]) before starting over.
const GROWTH: usize = 4;
const SLACK: usize = 256;

impl HeldBlocks {
    /// The blocks held.
    pub fn blocks(&self) -> &[(u32, u32)] {
        &self.blocks
    }

    /// A set saved with its generation (a checkpoint's).
    pub fn restored(blocks: Vec<(u32, u32)>, generation: u64) -> Self {
        HeldBlocks { blocks, generation }
    }

    /// Changes whenever the held set does.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Whether every block of `needed` (sorted, unique) is held.
    pub fn covers(&self, needed: &[(u32, u32)]) -> bool {
        let mut held = self.blocks.iter().peekable();
        'next: for n in needed {
            while let Some(h) = held.peek() {
                match (*h).cmp(n) {
                    std::cmp::Ordering::Less => {
                        held.next();
                    }
                    std::cmp::Ordering::Equal => continue 'next,
                    std::cmp::Ordering::Greater => return false,
                }
            }
            return false;
        }
        true
    }

    /// Hold `more` (sorted, unique) as well; true (and a new generation) when that adds blocks.
    pub fn grow(&mut self, more: &[(u32, u32)]) -> bool {
        if self.covers(more) {
            return false;
        }
        self.blocks.extend_from_slice(more);
        self.blocks.sort_unstable();
        self.blocks.dedup();
        self.generation += 1;
        true
    }

    /// At the start of a step, with `near` (sorted, unique) the couplings within the hold radius
    /// now: grow to cover them, or start over from them when the held set has become much larger
    /// than the need (contacts that ended long ago).
    pub fn renew(&mut self, near: &[(u32, u32)]) {
        if self.blocks.len() > GROWTH * near.len() + SLACK {
            self.blocks = near.to_vec();
            self.generation += 1;
        } else {
            self.grow(near);
        }
    }
}

/// Sort and deduplicate a list of couplings.
pub(crate) fn normalize(blocks: &mut Vec<(u32, u32)>) {
    blocks.sort_unstable();
    blocks.dedup();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_only_when_something_new_is_needed_and_starts_over_when_far_too_large() {
        let mut h = HeldBlocks::default();
        assert!(h.covers(&[]));
        assert!(!h.covers(&[(0, 1)]));
        assert!(h.grow(&[(0, 1), (2, 5)]));
        assert_eq!(h.generation(), 1);
        assert!(h.covers(&[(2, 5)]) && h.covers(&[(0, 1), (2, 5)]));
        assert!(!h.covers(&[(0, 2)]) && !h.covers(&[(3, 4)]) && !h.covers(&[(0, 1), (9, 9)]));
        assert!(!h.grow(&[(0, 1)]));
        assert_eq!(h.generation(), 1);
        h.renew(&[(2, 5)]);
        assert_eq!((h.generation(), h.blocks().len()), (1, 2));
        let many: Vec<(u32, u32)> = (0..400).map(|i| (i, i + 1)).collect();
        h.renew(&many);
        assert_eq!((h.generation(), h.blocks().len()), (2, 401));
        h.renew(&[(7, 8)]);
        assert_eq!((h.generation(), h.blocks()), (3, &[(7, 8)][..]));
    }
}
