//! Body pair candidates kept from one evaluation to the next: a Verlet list.
//!
//! Searching a body's own surface for candidate pairs costs far more per pair than the pairs'
//! distances (a tree build, a query per primitive, sorting: hundreds of ns a pair against tens),
//! and a resting or slowly moving body's surface is full of neighbour pairs that are candidates
//! at every evaluation without ever coming within d̂. So the candidates are searched once with
//! boxes inflated by R = r + margin around reference positions, and reused while no surface
//! vertex has strayed further than δ from its reference with r + δ ≤ R.
//!
//! Why that is safe: a primitive's box swept over the move x₀ → x₁ and inflated by r lies inside
//! its box at the reference inflated by r + δ, so two swept boxes that overlap have reference
//! boxes inflated by R that overlap, which is how the list was made. Each use then keeps exactly
//! the pairs whose boxes overlap for the query at hand, in the list's (sorted) order: the
//! candidates, and everything computed from them, are the same bits as a fresh search's.

use rayon::prelude::*;

use super::bodies::BodyPair;
use crate::contact::broad::Aabb;
use crate::math::Vec3;

/// The cached candidates and where they were searched.
#[derive(Debug, Default)]
pub(super) struct CandidateCache {
    /// Positions of the surface vertices (by surface index) at the search.
    reference: Vec<Vec3>,
    /// The inflation (m) the list was searched with (−∞ before the first search).
    radius: f64,
    /// Candidates, in the order of a fresh search.
    pairs: Vec<BodyPair>,
    /// Searches made, for the list or for a moving query it did not cover (`tetsim bench`).
    pub searches: usize,
}

impl CandidateCache {
    pub fn new() -> Self {
        CandidateCache {
            radius: f64::NEG_INFINITY,
            ..Default::default()
        }
    }

    /// The largest distance (m) of a surface vertex from its reference at x₀ or x₁.
    fn strayed(&self, surface: &[usize], x0: &[Vec3], x1: &[Vec3]) -> f64 {
        if self.reference.len() != surface.len() {
            return f64::INFINITY;
        }
        let same = std::ptr::eq(x0, x1);
        surface
            .par_iter()
            .zip(&self.reference)
            .map(|(&v, r)| {
                let d0 = (x0[v] - r).norm_squared();
                if same {
                    d0
                } else {
                    d0.max((x1[v] - r).norm_squared())
                }
            })
            .reduce(|| 0.0, f64::max)
            .sqrt()
    }

    /// The candidates within `r` (m) over the move x₀ → x₁ (pairs whose boxes, swept and
    /// inflated by r, overlap), as `search(x, radius)` would find them at x₀ = x₁ = x. The list
    /// is searched anew at x₀ with radius r + `margin` when it no longer covers the query and
    /// the query is static; a moving query it does not cover gets a fresh search of its own.
    pub fn candidates(
        &mut self,
        surface: &[usize],
        x0: &[Vec3],
        x1: &[Vec3],
        r: f64,
        margin: f64,
        search: impl Fn(&[Vec3], &[Vec3], f64) -> Vec<BodyPair>,
    ) -> Vec<BodyPair> {
        if r + self.strayed(surface, x0, x1) > self.radius {
            self.searches += 1;
            if !std::ptr::eq(x0, x1) {
                return search(x0, x1, r);
            }
            self.radius = r + margin;
            self.pairs = search(x0, x0, self.radius);
            self.reference = surface.iter().map(|&v| x0[v]).collect();
        }
        let box_of = |vertices: &[usize]| {
            Aabb::from_points(vertices.iter().flat_map(|&v| [&x0[v], &x1[v]])).inflate(r)
        };
        self.pairs
            .par_iter()
            .filter(|p| {
                let (a, b) = p.vertices.split_at(p.split);
                box_of(a).overlaps(&box_of(b))
            })
            .copied()
            .collect()
    }
}
