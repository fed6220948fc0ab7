//! The MSH writer: 4.1 (ASCII or binary) and 2.2 ASCII, with the groups as physical groups.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use super::Version;
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
    // Blocks: one per (dim, entity): points, triangles, tets.
    let mut blocks: Vec<(i64, usize, i64, Vec<Vec<usize>>)> = Vec::new();
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
        let items = p
            .faces
            .values()
            .zip(&face_entity)
            .filter(|(_, fe)| **fe == e + 1)
            .map(|(f, _)| f.0.to_vec())
            .collect();
        blocks.push((2, e + 1, 2, items));
    }
    for (e, _) in volumes.iter().enumerate() {
        let items = (0..mesh.tets.len())
            .filter(|&t| tet_entity.get(t).copied().unwrap_or(1) == e + 1)
            .map(|t| mesh.tets[t].to_vec())
            .collect();
        blocks.push((3, e + 1, 4, items));
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
    let mut line = |w: &mut dyn Write, ty: u32, tags: &Vec<i64>, nodes: &[usize]| {
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
    for (face, tags) in p.faces.values() {
        line(w, 2, tags, face)?;
    }
    for (t, tet) in mesh.tets.iter().enumerate() {
        line(w, 4, &p.tet_tags[t], tet)?;
    }
    w.write_all(b"$EndElements\n")
}
