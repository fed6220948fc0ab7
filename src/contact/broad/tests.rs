//! The BVH against brute force on random soups, and the same output on 1 and 2 threads.

use rand_chacha::ChaCha8Rng;

use super::*;
use crate::contact::testutil::{point, rng, uniform};

/// A soup of small random triangles (each with its own 3 vertices, plus some shared ones so
/// that the "no shared vertex" filters are exercised), moved by a random step.
struct Soup {
    start: Vec<Vec3>,
    end: Vec<Vec3>,
    vertices: Vec<usize>,
    edges: Vec<[usize; 2]>,
    faces: Vec<[usize; 3]>,
}

fn soup(rng: &mut ChaCha8Rng, n: usize, size: f64) -> Soup {
    let mut start = Vec::new();
    let mut faces = Vec::new();
    for k in 0..n {
        let c = 5.0 * point(rng);
        let base = start.len();
        for _ in 0..3 {
            start.push(c + size * point(rng));
        }
        // Every other triangle shares an edge with the previous one.
        if k % 2 == 1 {
            faces.push([base - 3, base - 2, base]);
        }
        faces.push([base, base + 1, base + 2]);
    }
    let end: Vec<Vec3> = start.iter().map(|x| x + 0.3 * point(rng)).collect();
    let mut edges: Vec<[usize; 2]> = faces
        .iter()
        .flat_map(|f| [[f[0], f[1]], [f[1], f[2]], [f[2], f[0]]])
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let vertices = (0..start.len()).collect();
    Soup {
        start,
        end,
        vertices,
        edges,
        faces,
    }
}

impl Soup {
    fn primitives(&self) -> Primitives<'_> {
        Primitives {
            start: &self.start,
            end: &self.end,
            vertices: &self.vertices,
            edges: &self.edges,
            faces: &self.faces,
        }
    }
}

fn brute(qs: &[Aabb], ts: &[Aabb], keep: impl Fn(usize, usize) -> bool) -> Vec<[usize; 2]> {
    let mut out = Vec::new();
    for (i, q) in qs.iter().enumerate() {
        for (j, t) in ts.iter().enumerate() {
            if q.overlaps(t) && keep(i, j) {
                out.push([i, j]);
            }
        }
    }
    out
}

#[test]
fn self_candidates_match_brute_force() {
    let mut rng = rng(31);
    for n in [0, 1, 7, 300] {
        let s = soup(&mut rng, n, 0.3);
        let p = s.primitives();
        let r = uniform(&mut rng, 0.0, 0.2);
        let c = self_candidates(&p, r);
        let pt = brute(&p.vertex_boxes(r), &p.face_boxes(r), |v, f| {
            !s.faces[f].contains(&s.vertices[v])
        });
        let eb = p.edge_boxes(r);
        let ee = brute(&eb, &eb, |i, j| {
            i < j && !s.edges[i].iter().any(|v| s.edges[j].contains(v))
        });
        assert_eq!(c.point_triangle, pt, "n = {n}");
        assert_eq!(c.edge_edge, ee, "n = {n}");
        assert!(c.triangle_point.is_empty());
        if n == 300 {
            assert!(pt.len() > 50 && ee.len() > 50, "{} {}", pt.len(), ee.len());
        }
    }
}

#[test]
fn cross_candidates_match_brute_force() {
    let mut rng = rng(32);
    let a = soup(&mut rng, 200, 0.4);
    let b = soup(&mut rng, 150, 0.4);
    let (pa, pb) = (a.primitives(), b.primitives());
    let r = 0.05;
    let c = cross_candidates(&pa, &pb, r);
    assert_eq!(
        c.point_triangle,
        brute(&pa.vertex_boxes(r), &pb.face_boxes(r), |_, _| true)
    );
    assert_eq!(
        c.triangle_point,
        brute(&pa.face_boxes(r), &pb.vertex_boxes(r), |_, _| true)
    );
    assert_eq!(
        c.edge_edge,
        brute(&pa.edge_boxes(r), &pb.edge_boxes(r), |_, _| true)
    );
    assert!(!c.point_triangle.is_empty() && !c.edge_edge.is_empty());
}

#[test]
fn refit_keeps_queries_exact() {
    let mut rng = rng(33);
    let s = soup(&mut rng, 200, 0.3);
    let p = s.primitives();
    let boxes = p.face_boxes(0.0);
    let mut bvh = Bvh::build(&boxes);
    // Move everything: the old tree refitted answers like a fresh one.
    let moved: Vec<Aabb> = boxes
        .iter()
        .map(|b| {
            let d = point(&mut rng);
            Aabb {
                min: b.min + d,
                max: b.max + d,
            }
        })
        .collect();
    bvh.refit(&moved);
    let fresh = Bvh::build(&moved);
    for q in moved.iter().take(50) {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        bvh.query(q, &mut x);
        fresh.query(q, &mut y);
        x.sort_unstable();
        y.sort_unstable();
        assert_eq!(x, y);
    }
}

#[test]
fn candidates_are_the_same_on_1_and_2_threads() {
    let mut rng = rng(34);
    let s = soup(&mut rng, 2000, 0.3);
    let p = s.primitives();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| self_candidates(&p, 0.05))
    };
    let one = run(1);
    assert!(!one.point_triangle.is_empty());
    assert_eq!(one, run(2));
}
