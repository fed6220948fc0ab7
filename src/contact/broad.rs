//! Broad phase: which pairs of primitives might come within the contact distance during a step.
//!
//! Every primitive (vertex, edge, face) gets the axis-aligned box of its vertices at the start
//! *and* end of the step, inflated by r (m, unsquared: √d̂ plus any minimum separation). Linear
//! trajectories stay inside the convex hull of start and end, so two primitives whose boxes are
//! disjoint cannot come within r of each other during the step: the candidates are a superset
//! of the pairs the barrier and CCD need.
//!
//! A bounding volume hierarchy (median split on the longest axis of the centroids, up to
//! [`LEAF_SIZE`] primitives a leaf, nodes in depth-first order) is built over one set and queried
//! with every box of the other, in parallel with rayon. Each query's hits come back in the order
//! of the queries and the final lists are sorted and deduplicated, so the output does not depend
//! on the number of threads. Building is O(n log n) (about as cheap as one pass of distance
//! evaluations at 10⁵ primitives); [`Bvh::refit`] updates the boxes in O(n) when the topology
//! of the tree is reused.

use rayon::prelude::*;

use crate::math::Vec3;

/// Primitives per BVH leaf.
pub const LEAF_SIZE: usize = 4;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (contains nothing; the identity of [`Aabb::union`]).
    pub fn empty() -> Self {
        Aabb {
            min: Vec3::repeat(f64::INFINITY),
            max: Vec3::repeat(f64::NEG_INFINITY),
        }
    }

    /// The smallest box containing `points`.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points.into_iter().fold(Aabb::empty(), |b, p| Aabb {
            min: b.min.inf(p),
            max: b.max.sup(p),
        })
    }

    /// The smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Self {
        Aabb {
            min: self.min.inf(&other.min),
            max: self.max.sup(&other.max),
        }
    }

    /// The box grown by `r` on every side.
    pub fn inflate(&self, r: f64) -> Self {
        Aabb {
            min: self.min.add_scalar(-r),
            max: self.max.add_scalar(r),
        }
    }

    /// Whether the closed boxes share a point.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        (0..3).all(|i| self.min[i] <= other.max[i] && other.min[i] <= self.max[i])
    }

    fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    aabb: Aabb,
    /// Leaf (count > 0): primitives `order[first..first + count]`. Inner node (count == 0):
    /// children `first` (left) and `right`.
    first: usize,
    count: usize,
    right: usize,
}

/// A bounding volume hierarchy over a list of boxes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Primitive indices, grouped by leaf.
    order: Vec<usize>,
    /// Each primitive's box (leaves test them one by one).
    boxes: Vec<Aabb>,
}

impl Bvh {
    /// Build over `boxes` (primitive i has box `boxes[i]`). Deterministic.
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 1),
            order: (0..boxes.len()).collect(),
            boxes: boxes.to_vec(),
        };
        if !boxes.is_empty() {
            let centers: Vec<Vec3> = boxes.iter().map(Aabb::center).collect();
            bvh.split(boxes, &centers, 0, boxes.len());
        }
        bvh
    }

    /// Append the subtree over `order[lo..hi]`; returns its node index.
    fn split(&mut self, boxes: &[Aabb], centers: &[Vec3], lo: usize, hi: usize) -> usize {
        let id = self.nodes.len();
        let aabb = self.order[lo..hi]
            .iter()
            .fold(Aabb::empty(), |b, &i| b.union(&boxes[i]));
        self.nodes.push(Node {
            aabb,
            first: lo,
            count: hi - lo,
            right: 0,
        });
        if hi - lo <= LEAF_SIZE {
            return id;
        }
        let spread = Aabb::from_points(self.order[lo..hi].iter().map(|&i| &centers[i]));
        let extent = spread.max - spread.min;
        let axis = extent.imax();
        let mid = lo + (hi - lo) / 2;
        // Ties broken by index, so the tree depends only on the input.
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
            centers[a][axis]
                .total_cmp(&centers[b][axis])
                .then(a.cmp(&b))
        });
        let left = self.split(boxes, centers, lo, mid);
        let right = self.split(boxes, centers, mid, hi);
        self.nodes[id].first = left;
        self.nodes[id].count = 0;
        self.nodes[id].right = right;
        id
    }

    /// New boxes for the same primitives, keeping the tree (children come after parents, so
    /// one reverse sweep suffices). Queries stay exact; only their speed depends on the tree.
    /// `boxes` must have one box per primitive, as at [`Bvh::build`].
    pub fn refit(&mut self, boxes: &[Aabb]) {
        assert_eq!(
            boxes.len(),
            self.boxes.len(),
            "refit with a different primitive count"
        );
        self.boxes.copy_from_slice(boxes);
        for id in (0..self.nodes.len()).rev() {
            let node = self.nodes[id];
            self.nodes[id].aabb = if node.count > 0 {
                self.order[node.first..node.first + node.count]
                    .iter()
                    .fold(Aabb::empty(), |b, &i| b.union(&boxes[i]))
            } else {
                self.nodes[node.first]
                    .aabb
                    .union(&self.nodes[node.right].aabb)
            };
        }
    }

    /// Push onto `out` every primitive whose box overlaps `query` (in tree order).
    pub fn query(&self, query: &Aabb, out: &mut Vec<usize>) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0usize];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id];
            if !node.aabb.overlaps(query) {
                continue;
            }
            if node.count > 0 {
                let leaf = &self.order[node.first..node.first + node.count];
                out.extend(leaf.iter().filter(|&&i| self.boxes[i].overlaps(query)));
            } else {
                stack.push(node.right);
                stack.push(node.first);
            }
        }
    }
}

/// The surface primitives of one body or obstacle, over its own position arrays.
#[derive(Clone, Copy, Debug)]
pub struct Primitives<'a> {
    /// Positions at the start of the step.
    pub start: &'a [Vec3],
    /// Positions at the end of the step (the same slice as `start` for a static query).
    pub end: &'a [Vec3],
    /// Surface vertices (indices into the positions).
    pub vertices: &'a [usize],
    /// Surface edges.
    pub edges: &'a [[usize; 2]],
    /// Surface triangles.
    pub faces: &'a [[usize; 3]],
}

impl Primitives<'_> {
    fn boxes<const K: usize>(&self, items: &[[usize; K]], r: f64) -> Vec<Aabb> {
        items
            .par_iter()
            .map(|item| {
                Aabb::from_points(item.iter().flat_map(|&v| [&self.start[v], &self.end[v]]))
                    .inflate(r)
            })
            .collect()
    }

    /// Swept, inflated boxes of the vertices, edges and faces.
    pub fn vertex_boxes(&self, r: f64) -> Vec<Aabb> {
        let v: Vec<[usize; 1]> = self.vertices.iter().map(|&v| [v]).collect();
        self.boxes(&v, r)
    }

    /// See [`Primitives::vertex_boxes`].
    pub fn edge_boxes(&self, r: f64) -> Vec<Aabb> {
        self.boxes(self.edges, r)
    }

    /// See [`Primitives::vertex_boxes`].
    pub fn face_boxes(&self, r: f64) -> Vec<Aabb> {
        self.boxes(self.faces, r)
    }
}

/// Candidate pairs, as indices into the primitive lists (`vertices`, `edges`, `faces`), sorted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Candidates {
    /// (vertex of the first set, face of the second set).
    pub point_triangle: Vec<[usize; 2]>,
    /// (face of the first set, vertex of the second set): empty for self-contact, where
    /// `point_triangle` already holds every vertex–face pair.
    pub triangle_point: Vec<[usize; 2]>,
    /// (edge of the first set, edge of the second set); for self-contact i < j.
    pub edge_edge: Vec<[usize; 2]>,
}

/// All (query i, tree j) with overlapping boxes that `keep`, sorted.
fn pairs(
    queries: &[Aabb],
    tree: &Bvh,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<[usize; 2]> {
    let mut out: Vec<[usize; 2]> = queries
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, q)| {
            let mut hits = Vec::new();
            tree.query(q, &mut hits);
            hits.sort_unstable();
            let keep = &keep;
            hits.into_iter()
                .filter(move |&j| keep(i, j))
                .map(move |j| [i, j])
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Self-contact candidates of one surface within `r` (m) over the step: vertex–face pairs
/// where the vertex is not a corner of the face, and edge–edge pairs i < j that share no vertex.
pub fn self_candidates(set: &Primitives, r: f64) -> Candidates {
    let faces = set.faces;
    let edges = set.edges;
    let verts = set.vertices;
    let face_tree = Bvh::build(&set.face_boxes(r));
    let point_triangle = pairs(&set.vertex_boxes(r), &face_tree, |v, f| {
        !faces[f].contains(&verts[v])
    });
    let edge_boxes = set.edge_boxes(r);
    let edge_tree = Bvh::build(&edge_boxes);
    let edge_edge = pairs(&edge_boxes, &edge_tree, |i, j| {
        i < j && !edges[i].iter().any(|v| edges[j].contains(v))
    });
    Candidates {
        point_triangle,
        triangle_point: Vec::new(),
        edge_edge,
    }
}

/// Candidates between two distinct surfaces (two bodies, or a body and an obstacle) within
/// `r` (m): vertices of `a` against faces of `b`, faces of `a` against vertices of `b`, edges
/// against edges.
pub fn cross_candidates(a: &Primitives, b: &Primitives, r: f64) -> Candidates {
    let b_faces = Bvh::build(&b.face_boxes(r));
    let point_triangle = pairs(&a.vertex_boxes(r), &b_faces, |_, _| true);
    let b_vertices = Bvh::build(&b.vertex_boxes(r));
    let triangle_point = pairs(&a.face_boxes(r), &b_vertices, |_, _| true);
    let b_edges = Bvh::build(&b.edge_boxes(r));
    let edge_edge = pairs(&a.edge_boxes(r), &b_edges, |_, _| true);
    Candidates {
        point_triangle,
        triangle_point,
        edge_edge,
    }
}

#[cfg(test)]
mod tests;
