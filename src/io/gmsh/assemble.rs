//! From the element lists a `.msh` file holds to a [`TetMesh`]: Gmsh's element types, the
//! node order of its 10-node tet, node-id resolution, and the physical groups.
//!
//! Kept apart from the section parser so that every path through the file (2.2 and 4.1, ASCII
//! and binary) meets the same rules: all tets of one order, node ids that exist, groups that
//! hold every node of their elements.

use std::collections::BTreeMap;
use std::path::Path;

use super::super::{Groups, IdMap, Ignored, Parsed, missing_node};
use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// (node count, dimension, name) of Gmsh element type `t`, for the types in use.
pub(super) fn element_type(t: i64) -> Option<(usize, usize, &'static str)> {
    Some(match t {
        1 => (2, 1, "line"),
        2 => (3, 2, "triangle"),
        3 => (4, 2, "quadrangle"),
        4 => (4, 3, "tetrahedron"),
        5 => (8, 3, "hexahedron"),
        6 => (6, 3, "prism"),
        7 => (5, 3, "pyramid"),
        8 => (3, 1, "line3"),
        9 => (6, 2, "triangle6"),
        10 => (9, 2, "quadrangle9"),
        11 => (10, 3, "tetrahedron10"),
        12 => (27, 3, "hexahedron27"),
        13 => (18, 3, "prism18"),
        14 => (14, 3, "pyramid14"),
        15 => (1, 0, "point"),
        16 => (8, 2, "quadrangle8"),
        17 => (20, 3, "hexahedron20"),
        18 => (15, 3, "prism15"),
        19 => (13, 3, "pyramid13"),
        20 => (9, 2, "triangle9"),
        21 => (10, 2, "triangle10"),
        22 => (12, 2, "triangle12"),
        23 => (15, 2, "triangle15"),
        24 => (15, 2, "triangle15i"),
        25 => (21, 2, "triangle21"),
        26 => (4, 1, "line4"),
        27 => (5, 1, "line5"),
        28 => (6, 1, "line6"),
        29 => (20, 3, "tetrahedron20"),
        30 => (35, 3, "tetrahedron35"),
        31 => (56, 3, "tetrahedron56"),
        _ => return None,
    })
}

/// Gmsh's linear tet.
pub(super) const TET4: i64 = 4;
/// Gmsh's 10-node (second-order) tet.
pub(super) const TET10: i64 = 11;
/// Gmsh's 6-node (second-order) triangle.
pub(super) const TRIANGLE6: i64 = 9;
/// Tets of order 3 and more: only their corners are kept (tetsim has no cubic elements).
const CORNER_ONLY_TETS: [i64; 3] = [29, 30, 31];
const TRIANGLE_TYPES: [i64; 8] = [2, 9, 20, 21, 22, 23, 24, 25];

/// For each of tetsim's mid-edge slots ([`crate::mesh::quadratic::EDGES`]: 01, 12, 02, 03, 13,
/// 23), the node of Gmsh's 10-node tet that sits there. Gmsh numbers its mid-edge nodes 4:01,
/// 5:12, 6:20, 7:30, 8:32, 9:31 (`MTetrahedron10` in Gmsh's sources), so the last two are
/// swapped against VTK's order; meshio uses the same permutation.
pub(super) const TET10_EDGE_NODES: [usize; 6] = [4, 5, 6, 7, 9, 8];

/// The element a mixed-order mesh is refused at: its id and, in ASCII files, its line.
#[derive(Clone, Copy)]
pub(super) struct Seen {
    pub id: u64,
    pub line: Option<usize>,
}

/// What the sections hold, before node ids are resolved.
#[derive(Default)]
pub(super) struct Raw {
    pub node_ids: Vec<u64>,
    pub positions: Vec<Vec3>,
    pub tets: Vec<[u64; 4]>,
    /// 10-node tets only: each tet's mid-edge nodes, in tetsim's (VTK's) order.
    pub edges: Vec<[u64; 6]>,
    pub tet_ids: Vec<u64>,
    /// Index into `sets` of each tet's physical tags.
    pub tet_set: Vec<u32>,
    /// Non-tet elements that belong to a physical group: (id, type, set, nodes).
    pub others: Vec<(u64, i64, u32, Vec<u64>)>,
    /// Distinct physical tag lists; index 0 is the empty list.
    pub sets: Vec<Vec<i64>>,
    pub names: BTreeMap<(usize, i64), String>,
    /// v4: (entity dim, entity tag) → index into `sets`.
    pub entities: BTreeMap<(usize, i64), u32>,
    pub ignored: Ignored,
    /// Tets of order 3 and more (corners kept).
    pub higher_order: usize,
    /// The first tet kept as four nodes and the first 10-node tet: both set means a mixed mesh.
    pub first_linear: Option<Seen>,
    pub first_quadratic: Option<Seen>,
}

impl Raw {
    pub fn set_index(&mut self, tags: Vec<i64>) -> u32 {
        match self.sets.iter().position(|s| *s == tags) {
            Some(i) => i as u32,
            None => {
                self.sets.push(tags);
                (self.sets.len() - 1) as u32
            }
        }
    }

    /// Store one element: tets become the mesh, other elements only count for their groups.
    /// A tet whose order differs from the tets before it is refused, naming both: tetsim's
    /// elements all have the same nodes, and guessing which order was meant would be wrong
    /// for half the mesh.
    pub fn add_element(
        &mut self,
        path: &Path,
        at: Seen,
        ty: i64,
        set: u32,
        nodes: &[u64],
    ) -> Result<()> {
        let (_, _, name) = element_type(ty).unwrap_or((0, 0, "unknown"));
        if ty == TET4 || ty == TET10 || CORNER_ONLY_TETS.contains(&ty) {
            let quadratic = ty == TET10;
            let (mine, other) = if quadratic {
                (&mut self.first_quadratic, self.first_linear)
            } else {
                (&mut self.first_linear, self.first_quadratic)
            };
            mine.get_or_insert(at);
            if let Some(other) = other {
                let (kind, other_kind) = if quadratic {
                    ("10-node", "4-node")
                } else {
                    ("4-node", "10-node")
                };
                let other_line = other.line.map_or(String::new(), |l| format!(" (line {l})"));
                return Err(Error::parse(
                    path,
                    at.line,
                    format!(
                        "element {} is a {kind} tetrahedron but element {}{other_line} is a \
                         {other_kind} one: a mesh must have tets of one order (re-mesh with one \
                         Mesh.ElementOrder)",
                        at.id, other.id
                    ),
                ));
            }
            if CORNER_ONLY_TETS.contains(&ty) {
                self.higher_order += 1;
            }
            self.tets.push([nodes[0], nodes[1], nodes[2], nodes[3]]);
            if quadratic {
                self.edges.push(TET10_EDGE_NODES.map(|k| nodes[k]));
            }
            self.tet_ids.push(at.id);
            self.tet_set.push(set);
        } else {
            self.ignored.add(name, 1);
            if set != 0 {
                self.others.push((at.id, ty, set, nodes.to_vec()));
            }
        }
        Ok(())
    }
}

/// Resolve node ids, build the tets and the groups. A face group's faces are its triangles'
/// corners (as for a linear mesh and as [`crate::mesh::quadratic::elevate`] keeps them); its
/// vertices are every node of its elements, so a 6-node triangle's mid-edge nodes belong to
/// the group that is clamped or loaded.
pub(super) fn assemble(path: &Path, raw: Raw, v2: bool) -> Result<Parsed> {
    let ids = IdMap::new(&raw.node_ids)
        .map_err(|id| Error::parse(path, None, format!("node {id} is defined twice")))?;
    let mut ignored = raw.ignored;
    if raw.higher_order > 0 {
        ignored.add(
            "higher-order tetrahedron (corner nodes kept)",
            raw.higher_order,
        );
    }
    let quadratic = !raw.edges.is_empty();
    let name_of = |dim: usize, tag: i64| raw.names.get(&(dim, tag)).cloned().unwrap_or_default();
    let mut groups = Groups::default();
    let mut tets: Vec<[usize; 4]> = Vec::with_capacity(raw.tets.len());
    let mut edge_nodes: Vec<[usize; 6]> = Vec::with_capacity(raw.edges.len());
    let mut tet_ids = Vec::with_capacity(raw.tets.len());
    // MSH 2 writes an element once per physical group it is in: merge such copies.
    let mut seen: std::collections::HashMap<[u64; 4], (usize, usize)> = Default::default();
    let mut first_set = None;
    let merge = v2
        && raw
            .tet_set
            .iter()
            .filter(|&&s| s != 0)
            .any(|&s| *first_set.get_or_insert(s) != s);
    let resolve = |element: u64, nodes: &[u64], out: &mut [usize]| -> Result<()> {
        for (slot, &node) in out.iter_mut().zip(nodes) {
            *slot = ids
                .get(node)
                .ok_or_else(|| missing_node(path, element, node))?;
        }
        Ok(())
    };
    for (k, nodes) in raw.tets.iter().enumerate() {
        let mut tet = [0usize; 4];
        resolve(raw.tet_ids[k], nodes, &mut tet)?;
        let mut edges = [0usize; 6];
        if quadratic {
            resolve(raw.tet_ids[k], &raw.edges[k], &mut edges)?;
        }
        let set = raw.tet_set[k] as usize;
        let index = match merge.then(|| seen.get(nodes).copied()).flatten() {
            Some((t, first_set)) if first_set != set => t,
            _ => {
                if merge {
                    seen.insert(*nodes, (tets.len(), set));
                }
                tets.push(tet);
                if quadratic {
                    edge_nodes.push(edges);
                }
                tet_ids.push(raw.tet_ids[k]);
                tets.len() - 1
            }
        };
        for &p in &raw.sets[set] {
            let g = groups.entry(3, p, &name_of(3, p));
            g.tets.push(index);
            g.vertices.extend_from_slice(&tet);
            if quadratic {
                g.vertices.extend_from_slice(&edges);
            }
        }
    }
    for (id, ty, set, nodes) in &raw.others {
        let dim = element_type(*ty).map_or(0, |t| t.1);
        let mut vertices = vec![0; nodes.len()];
        resolve(*id, nodes, &mut vertices)?;
        for &p in &raw.sets[*set as usize] {
            let g = groups.entry(dim, p, &name_of(dim, p));
            g.vertices.extend_from_slice(&vertices);
            if TRIANGLE_TYPES.contains(ty) {
                g.faces.push([vertices[0], vertices[1], vertices[2]]);
            }
        }
    }
    let mut mesh = TetMesh::new(raw.positions, tets);
    mesh.edge_nodes = edge_nodes;
    mesh.groups = groups.finish();
    mesh.tet_ids = Some(tet_ids);
    mesh.vertex_ids = Some(raw.node_ids);
    Ok(Parsed {
        mesh,
        ignored: ignored.finish(),
        element_path: path.to_path_buf(),
        node_path: path.to_path_buf(),
    })
}
