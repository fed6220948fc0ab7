//! A bounding-volume hierarchy over a triangle surface, answering the three questions the mesher
//! asks of it: the generalized winding number at a point (fast, with the far-field dipole
//! approximation of Barill et al. 2018), where a segment crosses the surface, and how far a point
//! is from it (for the Hausdorff measure).
//!
//! The tree is built once, sequentially and deterministically (median splits with index
//! tie-breaks), and every query walks it in a fixed order, so results do not depend on threads.

use crate::math::Vec3;

/// Triangles per leaf: small enough that exact leaf work stays cheap, large enough that the tree
/// stays shallow.
const LEAF_SIZE: usize = 8;

/// A node is approximated by its dipole when the query point is farther than this many node
/// radii from its centre. Barill et al. use 2; the error of the first-order term then stays
/// below a few hundredths of a turn, far from the ½ threshold that decides inside.
const FAR_FIELD_RATIO: f64 = 2.0;

#[derive(Clone, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Area-weighted centroid of the node's triangles (the dipole's position).
    center: Vec3,
    /// Σ of the triangles' vector areas ½(b−a)×(c−a) (the dipole's moment).
    moment: Vec3,
    /// Distance from `center` to the farthest corner of the box.
    radius: f64,
    /// Leaf: range in `order`; inner node: `start` is the first child, `count` is 0.
    start: usize,
    count: usize,
}

/// A triangle BVH (see the module doc).
#[derive(Clone, Debug)]
pub struct TriangleBvh {
    triangles: Vec<[Vec3; 3]>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

/// The signed solid angle (sr) triangle abc subtends at p (Van Oosterom & Strackee 1983),
/// positive when abc turns counter-clockwise seen from p.
fn solid_angle(p: &Vec3, t: &[Vec3; 3]) -> f64 {
    let (a, b, c) = (t[0] - p, t[1] - p, t[2] - p);
    let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
    let numerator = a.dot(&b.cross(&c));
    let denominator = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
    2.0 * numerator.atan2(denominator)
}

/// The point of triangle t closest to p (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_point_on_triangle(p: &Vec3, t: &[Vec3; 3]) -> Vec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // A degenerate triangle: the nearest of its corners is close enough.
        return [a, b, c]
            .into_iter()
            .min_by(|x, y| (x - p).norm_squared().total_cmp(&(y - p).norm_squared()))
            .unwrap_or(a);
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

/// The parameter s ∈ [0, 1] where segment p + s·(q − p) crosses triangle t, if it does
/// (Möller–Trumbore; a segment in the triangle's plane does not count).
fn segment_hit(p: &Vec3, q: &Vec3, t: &[Vec3; 3]) -> Option<f64> {
    let d = q - p;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = d.cross(&e2);
    let det = e1.dot(&h);
    if det.abs() <= 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let s = p - t[0];
    let u = s.dot(&h) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = s.cross(&e1);
    let v = d.dot(&qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let param = e2.dot(&qv) * inv;
    (0.0..=1.0).contains(&param).then_some(param)
}

fn box_distance_squared(p: &Vec3, min: &Vec3, max: &Vec3) -> f64 {
    (0..3)
        .map(|k| {
            let d = (min[k] - p[k]).max(p[k] - max[k]).max(0.0);
            d * d
        })
        .sum()
}

fn segment_meets_box(p: &Vec3, q: &Vec3, min: &Vec3, max: &Vec3) -> bool {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let d = q[k] - p[k];
        if d.abs() < 1e-300 {
            if p[k] < min[k] || p[k] > max[k] {
                return false;
            }
        } else {
            let (a, b) = ((min[k] - p[k]) / d, (max[k] - p[k]) / d);
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
            if lo > hi {
                return false;
            }
        }
    }
    true
}

impl TriangleBvh {
    /// Build the tree over `triangles` (corner positions, orientation kept).
    pub fn new(triangles: Vec<[Vec3; 3]>) -> Self {
        let mut bvh = TriangleBvh {
            order: (0..triangles.len()).collect(),
            triangles,
            nodes: Vec::new(),
        };
        if !bvh.triangles.is_empty() {
            let centroids: Vec<Vec3> = bvh
                .triangles
                .iter()
                .map(|t| (t[0] + t[1] + t[2]) / 3.0)
                .collect();
            bvh.nodes.push(bvh.leaf(0, bvh.triangles.len()));
            bvh.split(0, &centroids);
        }
        bvh
    }

    /// The triangles, as given.
    pub fn triangles(&self) -> &[[Vec3; 3]] {
        &self.triangles
    }

    fn leaf(&self, start: usize, count: usize) -> Node {
        let mut min = Vec3::repeat(f64::INFINITY);
        let mut max = Vec3::repeat(f64::NEG_INFINITY);
        let (mut moment, mut weighted, mut area) = (Vec3::zeros(), Vec3::zeros(), 0.0);
        for &i in &self.order[start..start + count] {
            let t = &self.triangles[i];
            for p in t {
                min = min.inf(p);
                max = max.sup(p);
            }
            let m = 0.5 * (t[1] - t[0]).cross(&(t[2] - t[0]));
            let a = m.norm();
            moment += m;
            weighted += a * (t[0] + t[1] + t[2]) / 3.0;
            area += a;
        }
        let center = if area > 0.0 {
            weighted / area
        } else {
            0.5 * (min + max)
        };
        let radius = (0..8)
            .map(|c| {
                let corner = Vec3::new(
                    if c & 1 == 0 { min.x } else { max.x },
                    if c & 2 == 0 { min.y } else { max.y },
                    if c & 4 == 0 { min.z } else { max.z },
                );
                (corner - center).norm()
            })
            .fold(0.0, f64::max);
        Node {
            min,
            max,
            center,
            moment,
            radius,
            start,
            count,
        }
    }

    /// Split node `n` at the median centroid along its longest axis, recursively (an explicit
    /// stack, so a degenerate input cannot overflow the call stack).
    fn split(&mut self, root: usize, centroids: &[Vec3]) {
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            let (start, count) = (self.nodes[n].start, self.nodes[n].count);
            if count <= LEAF_SIZE {
                continue;
            }
            let extent = self.nodes[n].max - self.nodes[n].min;
            let axis = extent.imax();
            let mid = count / 2;
            self.order[start..start + count].select_nth_unstable_by(mid, |&a, &b| {
                centroids[a][axis]
                    .total_cmp(&centroids[b][axis])
                    .then(a.cmp(&b))
            });
            let first = self.nodes.len();
            let left = self.leaf(start, mid);
            let right = self.leaf(start + mid, count - mid);
            self.nodes.push(left);
            self.nodes.push(right);
            self.nodes[n].start = first;
            self.nodes[n].count = 0;
            stack.push(first + 1);
            stack.push(first);
        }
    }

    /// The generalized winding number of the surface about `p` (Jacobson et al. 2013): 1 inside
    /// and 0 outside a closed, outward-oriented surface, blending smoothly across holes. Far
    /// nodes contribute their dipole term `m·(c − p) / ‖c − p‖³ / 4π`.
    pub fn winding_number(&self, p: &Vec3) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut total = 0.0;
        let mut stack = [0usize; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top]];
            let d = node.center - p;
            let dist = d.norm();
            if dist > FAR_FIELD_RATIO * node.radius {
                total += node.moment.dot(&d) / (dist * dist * dist);
            } else if node.count > 0 {
                for &i in &self.order[node.start..node.start + node.count] {
                    total += solid_angle(p, &self.triangles[i]);
                }
            } else {
                stack[top] = node.start + 1;
                stack[top + 1] = node.start;
                top += 2;
            }
        }
        total / (4.0 * std::f64::consts::PI)
    }

    /// The parameters s ∈ [0, 1] (sorted) where segment p → q crosses a triangle.
    pub fn segment_crossings(&self, p: &Vec3, q: &Vec3) -> Vec<f64> {
        let mut hits = Vec::new();
        if self.nodes.is_empty() {
            return hits;
        }
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            if !segment_meets_box(p, q, &node.min, &node.max) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.start..node.start + node.count] {
                    if let Some(s) = segment_hit(p, q, &self.triangles[i]) {
                        hits.push(s);
                    }
                }
            } else {
                stack.push(node.start + 1);
                stack.push(node.start);
            }
        }
        hits.sort_by(f64::total_cmp);
        hits
    }

    /// The distance from `p` to the nearest point of the surface (∞ for an empty surface).
    pub fn distance(&self, p: &Vec3) -> f64 {
        let mut best = f64::INFINITY;
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            if box_distance_squared(p, &node.min, &node.max) >= best {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.start..node.start + node.count] {
                    let c = closest_point_on_triangle(p, &self.triangles[i]);
                    best = best.min((c - p).norm_squared());
                }
            } else {
                // Nearer child first, so that the other is more often pruned.
                let (a, b) = (node.start, node.start + 1);
                let da = box_distance_squared(p, &self.nodes[a].min, &self.nodes[a].max);
                let db = box_distance_squared(p, &self.nodes[b].min, &self.nodes[b].max);
                if da <= db {
                    stack.push(b);
                    stack.push(a);
                } else {
                    stack.push(a);
                    stack.push(b);
                }
            }
        }
        best.sqrt()
    }
}
