//! TetGen `.node` / `.ele` / `.face` files, read and written.
//!
//! Either the `.node` or the `.ele` may be named; the other (and `.face`, when present) is found
//! beside it. Node numbering may start at 0 or 1 (`tetgen -z`): elements name nodes by the ids the
//! `.node` file gives them. Element attributes (region numbers) become groups `region_<a>`
//! (dimension 3) and face boundary markers groups `marker_<m>` (dimension 2). 10-node tets keep
//! their four corners. Errors give the file and line, or the element and node ids.

use std::path::{Path, PathBuf};

use super::text::shorten;
use super::{
    Groups, IdMap, Ignored, Parsed, atomic_write, marked_faces, missing_node, read_bytes,
    write_numbered_points,
};
use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// The non-blank, comment-stripped lines of a file with their 1-based numbers.
struct Lines<'a> {
    path: &'a Path,
    lines: Vec<(usize, Vec<&'a str>)>,
    next: usize,
}

impl<'a> Lines<'a> {
    fn new(path: &'a Path, data: &'a [u8]) -> Self {
        let lines = data
            .split(|&b| b == b'\n')
            .enumerate()
            .filter_map(|(i, line)| {
                let line = line.split(|&b| b == b'#').next().unwrap_or_default();
                let text = std::str::from_utf8(line).unwrap_or("\u{fffd}");
                let words: Vec<&str> = text.split_ascii_whitespace().collect();
                (!words.is_empty()).then_some((i + 1, words))
            })
            .collect();
        Lines {
            path,
            lines,
            next: 0,
        }
    }

    /// The next line's number and words; `what` names it for the end-of-file error.
    fn line(&mut self, what: &str) -> Result<(usize, Vec<&'a str>)> {
        let last = self.lines.last().map_or(1, |l| l.0);
        let line = self.lines.get(self.next).cloned().ok_or_else(|| {
            Error::parse(
                self.path,
                Some(last),
                format!("unexpected end of file: expected {what}"),
            )
        })?;
        self.next += 1;
        Ok(line)
    }

    /// Word `k` of a line parsed as `T`.
    fn field<T: std::str::FromStr>(
        &self,
        line: &(usize, Vec<&str>),
        k: usize,
        what: &str,
    ) -> Result<T> {
        let word = line
            .1
            .get(k)
            .ok_or_else(|| Error::parse(self.path, Some(line.0), format!("missing {what}")))?;
        word.parse().map_err(|_| {
            Error::parse(
                self.path,
                Some(line.0),
                format!("expected {what}, found `{}`", shorten(word)),
            )
        })
    }

    /// A count from a header, bounded by the lines left (each item needs one).
    fn count(&self, line: &(usize, Vec<&str>), k: usize, what: &str) -> Result<usize> {
        let n: usize = self.field(line, k, what)?;
        let left = self.lines.len() - self.next;
        if n > left {
            return Err(Error::parse(
                self.path,
                Some(line.0),
                format!("{what} is {n}, but only {left} lines follow"),
            ));
        }
        Ok(n)
    }
}

/// The `.node`, `.ele` and `.face` paths beside `path`.
fn paths(path: &Path) -> (PathBuf, PathBuf, PathBuf) {
    (
        path.with_extension("node"),
        path.with_extension("ele"),
        path.with_extension("face"),
    )
}

/// Read `<base>.node` and `<base>.ele` (and `<base>.face` if it exists).
pub fn read(path: &Path) -> Result<Parsed> {
    let (node_path, ele_path, face_path) = paths(path);
    let node_data = read_bytes(&node_path)?;
    let mut nodes = Lines::new(&node_path, &node_data);
    let header = nodes.line("the header `<#points> 3 <#attributes> <#markers>`")?;
    let n = nodes.count(&header, 0, "the number of points")?;
    let dim: usize = nodes.field(&header, 1, "the dimension")?;
    if dim != 3 {
        return Err(Error::parse(
            &node_path,
            Some(header.0),
            format!("dimension is {dim}: tetsim needs 3D points"),
        ));
    }
    let attributes: usize = header.1.get(2).map_or(Ok(0), |_| {
        nodes.field(&header, 2, "the number of attributes")
    })?;
    let mut ids = Vec::with_capacity(n);
    let mut positions = Vec::with_capacity(n);
    for _ in 0..n {
        let line = nodes.line("a point")?;
        let id: u64 = nodes.field(&line, 0, "a point id")?;
        let x = Vec3::new(
            nodes.field(&line, 1, "an x coordinate")?,
            nodes.field(&line, 2, "a y coordinate")?,
            nodes.field(&line, 3, "a z coordinate")?,
        );
        // Attributes and the boundary marker are not needed; parse them only for a clear error.
        for k in 0..attributes {
            nodes.field::<f64>(&line, 4 + k, "a point attribute")?;
        }
        ids.push(id);
        positions.push(x);
    }
    let map = IdMap::new(&ids)
        .map_err(|id| Error::parse(&node_path, None, format!("point {id} is defined twice")))?;

    let ele_data = read_bytes(&ele_path)?;
    let mut eles = Lines::new(&ele_path, &ele_data);
    let header = eles.line("the header `<#tets> <4|10> <#attributes>`")?;
    let m = eles.count(&header, 0, "the number of tets")?;
    let per: usize = eles.field(&header, 1, "nodes per tet (4 or 10)")?;
    if per != 4 && per != 10 {
        return Err(Error::parse(
            &ele_path,
            Some(header.0),
            format!("{per} nodes per tet: expected 4 or 10"),
        ));
    }
    let attributes: usize = header.1.get(2).map_or(Ok(0), |_| {
        eles.field(&header, 2, "the number of attributes")
    })?;
    let mut groups = Groups::default();
    let mut tets = Vec::with_capacity(m);
    let mut tet_ids = Vec::with_capacity(m);
    for t in 0..m {
        let line = eles.line("a tet")?;
        let id: u64 = eles.field(&line, 0, "a tet id")?;
        let mut tet = [0usize; 4];
        for (k, slot) in tet.iter_mut().enumerate() {
            let node: u64 = eles.field(&line, 1 + k, "a node id")?;
            *slot = map
                .get(node)
                .ok_or_else(|| missing_node(&ele_path, id, node))?;
        }
        for k in 4..per {
            eles.field::<u64>(&line, 1 + k, "a node id")?;
        }
        if attributes > 0 {
            let a: f64 = eles.field(&line, 1 + per, "a region attribute")?;
            let g = groups.entry(3, a as i64, &format!("region_{a}"));
            g.tets.push(t);
            g.vertices.extend_from_slice(&tet);
        }
        tets.push(tet);
        tet_ids.push(id);
    }
    let mut ignored = Ignored::default();
    if per == 10 {
        ignored.add("10-node tetrahedron (corner nodes kept)", m);
    }
    if face_path.exists() {
        let face_data = read_bytes(&face_path)?;
        read_faces(&face_path, &face_data, &map, &mut groups, &mut ignored)?;
    }
    let mut mesh = TetMesh::new(positions, tets);
    mesh.groups = groups.finish();
    mesh.vertex_ids = Some(ids);
    mesh.tet_ids = Some(tet_ids);
    Ok(Parsed {
        mesh,
        ignored: ignored.finish(),
        element_path: ele_path,
        node_path,
    })
}

fn read_faces(
    path: &Path,
    data: &[u8],
    map: &IdMap,
    groups: &mut Groups,
    ignored: &mut Ignored,
) -> Result<()> {
    let mut lines = Lines::new(path, data);
    let header = lines.line("the header `<#faces> <#markers>`")?;
    let n = lines.count(&header, 0, "the number of faces")?;
    let markers: usize = header
        .1
        .get(1)
        .map_or(Ok(0), |_| lines.field(&header, 1, "the marker flag"))?;
    for _ in 0..n {
        let line = lines.line("a face")?;
        let id: u64 = lines.field(&line, 0, "a face id")?;
        let mut face = [0usize; 3];
        for (k, slot) in face.iter_mut().enumerate() {
            let node: u64 = lines.field(&line, 1 + k, "a node id")?;
            *slot = map.get(node).ok_or_else(|| missing_node(path, id, node))?;
        }
        if markers > 0 {
            let m: i64 = lines.field(&line, 4, "a boundary marker")?;
            if m != 0 {
                let g = groups.entry(2, m, &format!("marker_{m}"));
                g.faces.push(face);
                g.vertices.extend_from_slice(&face);
            }
        }
    }
    ignored.add("triangle", n);
    Ok(())
}

/// Write `<base>.node`, `<base>.ele` and, when the mesh has face groups, `<base>.face`,
/// 1-based. The first dimension-3 group of a tet becomes its region attribute; a face's
/// group tag its boundary marker.
pub fn write(path: &Path, mesh: &TetMesh) -> Result<()> {
    let (node_path, ele_path, face_path) = paths(path);
    atomic_write(&node_path, |w| {
        writeln!(w, "{} 3 0 0", mesh.positions.len())?;
        write_numbered_points(w, &mesh.positions)
    })?;
    let mut region = vec![None; mesh.tets.len()];
    for g in mesh.groups.iter().filter(|g| g.dim == 3) {
        for &t in &g.tets {
            if let Some(r) = region.get_mut(t) {
                r.get_or_insert(g.tag);
            }
        }
    }
    let attributes = usize::from(region.iter().any(Option::is_some));
    atomic_write(&ele_path, |w| {
        writeln!(w, "{} 4 {attributes}", mesh.tets.len())?;
        for (t, tet) in mesh.tets.iter().enumerate() {
            write!(
                w,
                "{} {} {} {} {}",
                t + 1,
                tet[0] + 1,
                tet[1] + 1,
                tet[2] + 1,
                tet[3] + 1
            )?;
            if attributes > 0 {
                write!(w, " {}", region[t].unwrap_or(0))?;
            }
            writeln!(w)?;
        }
        Ok(())
    })?;
    let faces = marked_faces(mesh);
    if !faces.is_empty() {
        atomic_write(&face_path, |w| {
            writeln!(w, "{} 1", faces.len())?;
            for (i, (f, m)) in faces.iter().enumerate() {
                writeln!(w, "{} {} {} {} {m}", i + 1, f[0] + 1, f[1] + 1, f[2] + 1)?;
            }
            Ok(())
        })?;
    }
    Ok(())
}
