//! The MSH writer: 4.1 (ASCII or binary) and 2.2 ASCII, with the groups as physical groups. A
//! quadratic mesh is written as 10-node tets (type 11) and its group faces as 6-node triangles
//! (type 9), so that Gmsh, meshio and tetsim read back the same mid-edge nodes.

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::Path;

use super::Version;
use super::assemble::{TET4, TET10, TRIANGLE6};
use crate::error::Result;
use crate::io::{atomic_write, fmt_f64, write_numbered_points};
use crate::mesh::TetMesh;

/// The physical groups of a mesh as Gmsh elements: tets, triangles (group faces) and points
/// (groups that have only vertices, e.g. the box generator's faces), each with its physical tags.
struct Physicals {
    /// (output dimension, tag, name) of every written group.
    names: Vec<(usize, i64, String)>,
    tet_tags: Vec<Vec<i64>>,
    /// Sorted face key → (face as given, tags).
    faces: BTreeMap<[usize; 3], ([usize; 3], Vec<i64>)>,
    points: BTreeMap<usize, Vec<i64>>,
}

impl Physicals {
    fn new(mesh: &TetMesh) -> Self {
        let mut p = Physicals {
            names: Vec::new(),
            tet_tags: vec![Vec::new(); mesh.tets.len()],
            faces: BTreeMap::new(),
            points: BTreeMap::new(),
        };
        let mut used: [Vec<i64>; 4] = Default::default();
        for g in &mesh.groups {
            let dim = if g.dim == 3 && !g.tets.is_empty() {
                3
            } else if !g.faces.is_empty() {
                2
            } else if !g.vertices.is_empty() {
                0
            } else {
                continue;
            };
            // Gmsh tags are positive and unique per dimension.
            let tag = if g.tag > 0 && !used[dim].contains(&g.tag) {
                g.tag
            } else {
                used[dim].iter().copied().max().unwrap_or(0) + 1
            };
            used[dim].push(tag);
            p.names.push((dim, tag, g.name.clone()));
            match dim {
                3 => {
                    for &t in g.tets.iter().filter(|&&t| t < mesh.tets.len()) {
                        p.tet_tags[t].push(tag);
                    }
                }
                2 => {
                    for f in &g.faces {
                        let mut key = *f;
                        key.sort_unstable();
                        p.faces.entry(key).or_insert((*f, Vec::new())).1.push(tag);
                    }
                }
                _ => {
                    for &v in &g.vertices {
                        p.points.entry(v).or_default().push(tag);
                    }
                }
            }
        }
        p
    }
}

/// Distinct tag sets in first-seen order, and each item's set index (its entity, 1-based).
fn entities_of<'a>(sets: impl Iterator<Item = &'a Vec<i64>>) -> (Vec<Vec<i64>>, Vec<usize>) {
    let mut distinct: Vec<Vec<i64>> = Vec::new();
    let mut index = Vec::new();
    for s in sets {
        let i = match distinct.iter().position(|d| d == s) {
            Some(i) => i,
            None => {
                distinct.push(s.clone());
                distinct.len() - 1
            }
        };
        index.push(i + 1);
    }
    (distinct, index)
}

/// The Gmsh element type and node list of every tet: 10-node tets in Gmsh's node order (its
/// mid-edge nodes 8 and 9 are tetsim's slots 5 and 4), or 4-node ones.
fn tet_elements(mesh: &TetMesh) -> (i64, Vec<Vec<usize>>) {
    if !mesh.is_quadratic() {
        return (TET4, mesh.tets.iter().map(|t| t.to_vec()).collect());
    }
    let items = (0..mesh.tets.len())
        .map(|t| {
            let q = mesh.quadratic_nodes(t);
            [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]
                .iter()
                .map(|&k| q[k])
                .collect()
        })
        .collect();
    (TET10, items)
}

/// The Gmsh element type and nodes of a group face: a 6-node triangle (corners, then the nodes
/// on edges 01, 12, 20) when the mesh is quadratic and the face's edges are tets' edges, else
/// the 3-node triangle.
fn face_element(face: &[usize; 3], mids: &HashMap<(usize, usize), usize>) -> (i64, Vec<usize>) {
    let mid = |a: usize, b: usize| mids.get(&(a.min(b), a.max(b))).copied();
    let [p, q, r] = *face;
    match (mid(p, q), mid(q, r), mid(r, p)) {
        (Some(pq), Some(qr), Some(rp)) => (TRIANGLE6, vec![p, q, r, pq, qr, rp]),
        _ => (2, face.to_vec()),
    }
}

/// Each tet edge's mid-edge node, by its sorted corner pair (empty for a linear mesh).
fn mid_edge_nodes(mesh: &TetMesh) -> HashMap<(usize, usize), usize> {
    let mut mids = HashMap::new();
    for (tet, e) in mesh.tets.iter().zip(&mesh.edge_nodes) {
        for (k, [i, j]) in crate::mesh::quadratic::EDGES.iter().enumerate() {
            let (a, b) = (tet[*i], tet[*j]);
            mids.insert((a.min(b), a.max(b)), e[k]);
        }
    }
    mids
}

/// Token writer: text separated by spaces, or little-endian binary with 8-byte `size_t`.
struct Out<'w> {
    w: &'w mut dyn Write,
    binary: bool,
}

impl Out<'_> {
    fn raw(&mut self, s: &str) -> std::io::Result<()> {
        self.w.write_all(s.as_bytes())
    }
    fn int(&mut self, v: i64) -> std::io::Result<()> {
        if self.binary {
            self.w.write_all(&(v as i32).to_le_bytes())
        } else {
            write!(self.w, "{v} ")
        }
    }
    fn size(&mut self, v: u64) -> std::io::Result<()> {
        if self.binary {
            self.w.write_all(&v.to_le_bytes())
        } else {
            write!(self.w, "{v} ")
        }
    }
    fn float(&mut self, v: f64) -> std::io::Result<()> {
        if self.binary {
            self.w.write_all(&v.to_le_bytes())
        } else {
            write!(self.w, "{} ", fmt_f64(v))
        }
    }
    fn end_line(&mut self) -> std::io::Result<()> {
        if self.binary {
            Ok(())
        } else {
            self.w.write_all(b"\n")
        }
    }
}

/// Write `mesh` as MSH `version` with its groups as physical groups (2.2 is always ASCII).
/// Nodes are numbered 1..n and elements 1..m in mesh order, so a read of the written file gives
/// back the same positions, tets and groups. Groups with only vertices become point elements.
pub fn write(path: &Path, mesh: &TetMesh, version: Version, binary: bool) -> Result<()> {
    let physicals = Physicals::new(mesh);
    atomic_write(path, |w| match version {
        Version::V41 => write_v41(w, mesh, &physicals, binary),
        Version::V22 => write_v22(w, mesh, &physicals),
    })
}

fn write_names(w: &mut dyn Write, p: &Physicals) -> std::io::Result<()> {
    if p.names.is_empty() {
        return Ok(());
    }
    writeln!(w, "$PhysicalNames\n{}", p.names.len())?;
    for (dim, tag, name) in &p.names {
        writeln!(w, "{dim} {tag} \"{}\"", name.replace('"', "'"))?;
    }
    writeln!(w, "$EndPhysicalNames")
}

fn write_v41(
    w: &mut dyn Write,
    mesh: &TetMesh,
    p: &Physicals,
    binary: bool,
) -> std::io::Result<()> {
    let (volumes, tet_entity) = entities_of(p.tet_tags.iter());
    let volumes = if volumes.is_empty() {
        vec![Vec::new()]
    } else {
        volumes
    };
    let (surfaces, face_entity) = entities_of(p.faces.values().map(|f| &f.1));
    let (points, point_entity) = entities_of(p.points.values());
    let (lo, hi) = mesh.bounding_box();
    let mut o = Out { w, binary };
    o.raw(&format!(
        "$MeshFormat\n4.1 {} 8\n",
        if binary { 1 } else { 0 }
    ))?;
    if binary {
        o.w.write_all(&1i32.to_le_bytes())?;
        o.raw("\n")?;
    }
    o.raw("$EndMeshFormat\n")?;
    write_names(o.w, p)?;
    o.raw("$Entities\n")?;
    for n in [points.len(), 0, surfaces.len(), volumes.len()] {
        o.size(n as u64)?;
    }
    o.end_line()?;
    let tags = |o: &mut Out, set: &Vec<i64>| -> std::io::Result<()> {
        o.size(set.len() as u64)?;
        set.iter().try_for_each(|&t| o.int(t))
    };
    for (i, set) in points.iter().enumerate() {
        o.int(i as i64 + 1)?;
        for c in lo.iter() {
            o.float(*c)?;
        }
        tags(&mut o, set)?;
        o.end_line()?;
    }
    for list in [&surfaces, &volumes] {
        for (i, set) in list.iter().enumerate() {
            o.int(i as i64 + 1)?;
            for c in lo.iter().chain(hi.iter()) {
                o.float(*c)?;
            }
            tags(&mut o, set)?;
            o.size(0)?;
            o.end_line()?;
        }
    }
    if binary {
        o.raw("\n")?;
    }
    o.raw("$EndEntities\n$Nodes\n")?;
    let n = mesh.positions.len() as u64;
    // All nodes in one block on volume 1: readers (Gmsh, meshio, ours) accept that.
    for v in [1, n, 1.min(n), n] {
        o.size(v)?;
    }
    o.end_line()?;
    for v in [3, 1, 0] {
        o.int(v)?;
    }
    o.size(n)?;
    o.end_line()?;
    for i in 1..=n {
        o.size(i)?;
        o.end_line()?;
    }
    for x in &mesh.positions {
        for c in x.iter() {
            o.float(*c)?;
        }
        o.end_line()?;
    }
    if binary {
        o.raw("\n")?;
    }
    o.raw("$EndNodes\n$Elements\n")?;
    // Blocks: one per (dim, entity, type): points, triangles, tets.
    let mut blocks: Vec<(i64, usize, i64, Vec<Vec<usize>>)> = Vec::new();
    let mids = mid_edge_nodes(mesh);
    let (tet_type, tet_nodes) = tet_elements(mesh);
    for (e, _) in points.iter().enumerate() {
        let items = p
            .points
            .keys()
            .zip(&point_entity)
            .filter(|(_, pe)| **pe == e + 1)
            .map(|(&v, _)| vec![v])
            .collect();
        blocks.push((0, e + 1, 15, items));
    }
    for (e, _) in surfaces.iter().enumerate() {
        // A block holds one element type: 6-node and 3-node triangles apart.
        let mut by_type: BTreeMap<i64, Vec<Vec<usize>>> = BTreeMap::new();
        for (f, _) in p
            .faces
            .values()
            .zip(&face_entity)
            .filter(|(_, fe)| **fe == e + 1)
        {
            let (ty, nodes) = face_element(&f.0, &mids);
            by_type.entry(ty).or_default().push(nodes);
        }
        for (ty, items) in by_type {
            blocks.push((2, e + 1, ty, items));
        }
    }
    for (e, _) in volumes.iter().enumerate() {
        let items = (0..mesh.tets.len())
            .filter(|&t| tet_entity.get(t).copied().unwrap_or(1) == e + 1)
            .map(|t| tet_nodes[t].clone())
            .collect();
        blocks.push((3, e + 1, tet_type, items));
    }
    let total: usize = blocks.iter().map(|b| b.3.len()).sum();
    for v in [blocks.len(), total, 1.min(total), total] {
        o.size(v as u64)?;
    }
    o.end_line()?;
    let mut id = 0u64;
    for (dim, entity, ty, items) in &blocks {
        o.int(*dim)?;
        o.int(*entity as i64)?;
        o.int(*ty)?;
        o.size(items.len() as u64)?;
        o.end_line()?;
        for item in items {
            id += 1;
            o.size(id)?;
            for &v in item {
                o.size(v as u64 + 1)?;
            }
            o.end_line()?;
        }
    }
    if binary {
        o.raw("\n")?;
    }
    o.raw("$EndElements\n")
}

fn write_v22(w: &mut dyn Write, mesh: &TetMesh, p: &Physicals) -> std::io::Result<()> {
    w.write_all(b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n")?;
    write_names(w, p)?;
    writeln!(w, "$Nodes\n{}", mesh.positions.len())?;
    write_numbered_points(w, &mesh.positions)?;
    w.write_all(b"$EndNodes\n$Elements\n")?;
    // One line per (element, physical tag); a tet in no group has physical tag 0.
    let copies = |tags: &Vec<i64>| tags.len().max(1);
    let total = p.points.values().map(copies).sum::<usize>()
        + p.faces.values().map(|f| copies(&f.1)).sum::<usize>()
        + p.tet_tags.iter().map(copies).sum::<usize>();
    writeln!(w, "{total}")?;
    let mut id = 0;
    let mut line = |w: &mut dyn Write, ty: i64, tags: &Vec<i64>, nodes: &[usize]| {
        let list: Vec<i64> = if tags.is_empty() {
            vec![0]
        } else {
            tags.clone()
        };
        for tag in list {
            id += 1;
            write!(w, "{id} {ty} 2 {tag} 1")?;
            for &v in nodes {
                write!(w, " {}", v + 1)?;
            }
            writeln!(w)?;
        }
        Ok::<(), std::io::Error>(())
    };
    for (&v, tags) in &p.points {
        line(w, 15, tags, &[v])?;
    }
    let mids = mid_edge_nodes(mesh);
    for (face, tags) in p.faces.values() {
        let (ty, nodes) = face_element(face, &mids);
        line(w, ty, tags, &nodes)?;
    }
    let (tet_type, tet_nodes) = tet_elements(mesh);
    for (t, nodes) in tet_nodes.iter().enumerate() {
        line(w, tet_type, &p.tet_tags[t], nodes)?;
    }
    w.write_all(b"$EndElements\n")
}
