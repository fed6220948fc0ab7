//! Gmsh `.msh` files: MSH 2.2 and 4.1, ASCII and binary, read; 4.1 (ASCII or binary) and 2.2
//! ASCII written.
//!
//! Our own reader: `mshio` reads only 4.1 and is unmaintained. Tets become the mesh: 4-node
//! ones, or 10-node ones (type 11) with their mid-edge nodes, never both in one file (the
//! corners of tets of order 3 and more are kept); every other element only adds to the physical
//! groups it belongs to (a 6-node triangle gives its corner face and all six nodes), and
//! `$PhysicalNames` give the names. Sections we do not need (`$Periodic`, `$NodeData`, …) are
//! skipped. Errors give the line (in binary data, the byte offset) and, for a
//! missing node, the element and node ids as in the file.

use std::path::Path;

use super::text::{Cursor, Endian, Scalar, decode, shorten};
use super::{Parsed, read_bytes};
use crate::error::Result;
use crate::math::Vec3;

mod assemble;
mod write;
use assemble::{Raw, Seen, assemble, element_type};
pub use write::write;

/// The MSH versions tetsim writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Version {
    /// MSH 2.2 (ASCII only): what older tools (and meshio's defaults) expect.
    V22,
    /// MSH 4.1: Gmsh's current format.
    V41,
}

/// Binary layout of the file (None: ASCII).
#[derive(Clone, Copy)]
struct Binary {
    endian: Endian,
    /// `sizeof(size_t)` declared in `$MeshFormat` (4 or 8).
    size_t: Scalar,
}

struct Reader<'a> {
    c: Cursor<'a>,
    binary: Option<Binary>,
}

/// Read a `.msh` file (any supported version). Returns the parsed mesh and the format's name.
pub fn read(path: &Path) -> Result<(Parsed, String)> {
    let data = read_bytes(path)?;
    let mut c = Cursor::new(path, &data);
    let line = c.line();
    match c.next_token() {
        Some("$MeshFormat") => {}
        Some(t) => {
            return Err(c.error_at(
                line,
                format!(
                    "not a Gmsh mesh: expected `$MeshFormat`, found `{}`",
                    shorten(t)
                ),
            ));
        }
        None => return Err(c.error_at(line, "not a Gmsh mesh: the file is empty")),
    }
    let version_line = c.line();
    let version = c.token("the MSH version")?;
    let v2 = match version {
        "2" | "2.0" | "2.1" | "2.2" => true,
        "4.1" => false,
        v => {
            return Err(c.error_at(
                version_line,
                format!(
                    "MSH version {} is not supported (2.2 and 4.1 are; re-save with Gmsh)",
                    shorten(v)
                ),
            ));
        }
    };
    let file_type: u32 = c.parse("the file type (0 ASCII, 1 binary)")?;
    let size_t: usize = c.parse("the data size")?;
    let binary = match file_type {
        0 => None,
        1 => {
            let size_t = match size_t {
                4 => Scalar::U32,
                8 => Scalar::U64,
                n => return Err(c.error(format!("data size {n} is not 4 or 8"))),
            };
            c.skip_line();
            let one = c.bytes(4, "the endianness check (int 1)")?;
            let endian = if decode(one, Scalar::I32, Endian::Little) == super::text::Value::Int(1) {
                Endian::Little
            } else if decode(one, Scalar::I32, Endian::Big) == super::text::Value::Int(1) {
                Endian::Big
            } else {
                return Err(c.error("the endianness check is not the integer 1"));
            };
            Some(Binary { endian, size_t })
        }
        n => return Err(c.error(format!("file type {n} is neither 0 (ASCII) nor 1 (binary)"))),
    };
    c.expect("$EndMeshFormat")?;
    let mut r = Reader { c, binary };
    let mut raw = Raw {
        sets: vec![Vec::new()],
        ..Default::default()
    };
    while let Some(section) = r.c.next_token() {
        match section {
            "$PhysicalNames" => r.physical_names(&mut raw)?,
            "$Entities" if !v2 => r.entities(&mut raw)?,
            "$Nodes" | "$NOD" => {
                if v2 {
                    r.nodes_v2(&mut raw)?
                } else {
                    r.nodes_v4(&mut raw)?
                }
            }
            "$Elements" | "$ELM" => {
                if v2 {
                    r.elements_v2(&mut raw)?
                } else {
                    r.elements_v4(&mut raw)?
                }
            }
            s if s.starts_with('$') => {
                r.skip_section(&s[1..])?;
                continue;
            }
            s => {
                return Err(r.c.error(format!(
                    "expected a section such as `$Nodes`, found `{}`",
                    shorten(s)
                )));
            }
        }
        let end = format!("$End{}", &section[1..]);
        let end = match section {
            "$NOD" => "$ENDNOD".to_string(),
            "$ELM" => "$ENDELM".to_string(),
            _ => end,
        };
        r.c.expect(&end)?;
    }
    let name = match (v2, binary.is_some()) {
        (true, false) => "Gmsh 2.2 ASCII",
        (true, true) => "Gmsh 2.2 binary",
        (false, false) => "Gmsh 4.1 ASCII",
        (false, true) => "Gmsh 4.1 binary",
    };
    Ok((assemble(path, raw, v2)?, name.to_string()))
}

impl Reader<'_> {
    fn int(&mut self, what: &str) -> Result<i64> {
        match self.binary {
            None => self.c.parse(what),
            Some(b) => Ok(as_int(decode(
                self.c.bytes(4, what)?,
                Scalar::I32,
                b.endian,
            ))),
        }
    }

    fn size(&mut self, what: &str) -> Result<u64> {
        match self.binary {
            None => self.c.parse(what),
            Some(b) => {
                let n = b.size_t.size();
                let v = as_int(decode(self.c.bytes(n, what)?, b.size_t, b.endian));
                Ok(v as u64)
            }
        }
    }

    fn float(&mut self, what: &str) -> Result<f64> {
        match self.binary {
            None => self.c.parse(what),
            Some(b) => Ok(decode(self.c.bytes(8, what)?, Scalar::F64, b.endian).as_f64()),
        }
    }

    /// A count read as `size_t` (or int in v2 binary headers), bounded by what the rest of the
    /// file can hold at `min_bytes` per item.
    fn count(&mut self, what: &str, min_bytes: usize) -> Result<usize> {
        let n = self.size(what)?;
        let limit = self.c.remaining().len() / min_bytes.max(1) + 1;
        if n > limit as u64 {
            return Err(self.c.error(format!(
                "{what} is {n}, but the file ends too soon to hold that many (truncated?)"
            )));
        }
        Ok(n as usize)
    }

    /// After an ASCII header line, binary data starts on the next line.
    fn start_binary(&mut self) {
        if self.binary.is_some() {
            self.c.skip_line();
        }
    }

    fn physical_names(&mut self, raw: &mut Raw) -> Result<()> {
        // Always ASCII, even in binary files.
        let n = self
            .c
            .count("the number of physical names", self.c.remaining().len())?;
        for _ in 0..n {
            let dim: usize = self.c.parse("a physical group's dimension")?;
            let tag: i64 = self.c.parse("a physical group's tag")?;
            let line = self.c.line();
            let name = self.c.rest_of_line();
            let name = name
                .strip_prefix('"')
                .and_then(|s| s.strip_suffix('"'))
                .ok_or_else(|| self.c.error_at(line, "expected a quoted physical name"))?;
            raw.names.insert((dim, tag), name.to_string());
        }
        Ok(())
    }

    fn entities(&mut self, raw: &mut Raw) -> Result<()> {
        self.start_binary();
        let mut counts = [0usize; 4];
        for (dim, count) in counts.iter_mut().enumerate() {
            *count = self.count(&format!("the number of dimension-{dim} entities"), 8)?;
        }
        for (dim, &count) in counts.iter().enumerate() {
            for _ in 0..count {
                let tag = self.int("an entity tag")?;
                let coordinates = if dim == 0 { 3 } else { 6 };
                for _ in 0..coordinates {
                    self.float("an entity coordinate")?;
                }
                let n = self.count("the number of physical tags", 4)?;
                let mut tags = Vec::with_capacity(n);
                for _ in 0..n {
                    tags.push(self.int("a physical tag")?);
                }
                if dim > 0 {
                    let bounding = self.count("the number of bounding entities", 4)?;
                    for _ in 0..bounding {
                        self.int("a bounding entity tag")?;
                    }
                }
                tags.retain(|&t| t != 0);
                let set = raw.set_index(tags);
                raw.entities.insert((dim, tag), set);
            }
        }
        Ok(())
    }

    fn nodes_v2(&mut self, raw: &mut Raw) -> Result<()> {
        let n = self
            .c
            .count("the number of nodes", self.c.remaining().len())?;
        raw.node_ids.reserve(n);
        raw.positions.reserve(n);
        match self.binary {
            None => {
                for _ in 0..n {
                    let id: u64 = self.c.parse("a node id")?;
                    let p = Vec3::new(
                        self.c.parse("an x coordinate")?,
                        self.c.parse("a y coordinate")?,
                        self.c.parse("a z coordinate")?,
                    );
                    raw.node_ids.push(id);
                    raw.positions.push(p);
                }
            }
            Some(b) => {
                self.c.skip_line();
                let bytes = self.c.bytes(n.saturating_mul(28), "the nodes")?;
                for chunk in bytes.chunks_exact(28) {
                    let id = as_int(decode(chunk, Scalar::I32, b.endian));
                    raw.node_ids.push(id as u64);
                    let f = |k: usize| decode(&chunk[4 + 8 * k..], Scalar::F64, b.endian).as_f64();
                    raw.positions.push(Vec3::new(f(0), f(1), f(2)));
                }
            }
        }
        Ok(())
    }

    fn nodes_v4(&mut self, raw: &mut Raw) -> Result<()> {
        self.start_binary();
        let blocks = self.count("the number of node blocks", 16)?;
        let total = self.count("the number of nodes", 8)?;
        self.size("the smallest node tag")?;
        self.size("the largest node tag")?;
        raw.node_ids.reserve(total);
        raw.positions.reserve(total);
        for _ in 0..blocks {
            let dim = self.int("an entity dimension")?;
            self.int("an entity tag")?;
            let parametric = self.int("the parametric flag")?;
            let n = self.count("the number of nodes in the block", 8)?;
            let extra = if parametric != 0 {
                dim.clamp(0, 3) as usize
            } else {
                0
            };
            match self.binary {
                None => {
                    for _ in 0..n {
                        raw.node_ids.push(self.c.parse("a node tag")?);
                    }
                    for _ in 0..n {
                        let p = Vec3::new(
                            self.c.parse("an x coordinate")?,
                            self.c.parse("a y coordinate")?,
                            self.c.parse("a z coordinate")?,
                        );
                        for _ in 0..extra {
                            self.c.parse::<f64>("a parametric coordinate")?;
                        }
                        raw.positions.push(p);
                    }
                }
                Some(b) => {
                    let sz = b.size_t.size();
                    let tags = self.c.bytes(n.saturating_mul(sz), "the node tags")?;
                    raw.node_ids.extend(
                        tags.chunks_exact(sz)
                            .map(|t| as_int(decode(t, b.size_t, b.endian)) as u64),
                    );
                    let stride = 8 * (3 + extra);
                    let xyz = self
                        .c
                        .bytes(n.saturating_mul(stride), "the node coordinates")?;
                    for chunk in xyz.chunks_exact(stride) {
                        let f = |k: usize| decode(&chunk[8 * k..], Scalar::F64, b.endian).as_f64();
                        raw.positions.push(Vec3::new(f(0), f(1), f(2)));
                    }
                }
            }
        }
        if raw.node_ids.len() != total {
            return Err(self.c.error(format!(
                "the $Nodes header announces {total} nodes but the blocks hold {}",
                raw.node_ids.len()
            )));
        }
        Ok(())
    }

    fn elements_v2(&mut self, raw: &mut Raw) -> Result<()> {
        let n = self
            .c
            .count("the number of elements", self.c.remaining().len())?;
        let mut nodes = Vec::new();
        match self.binary {
            None => {
                for _ in 0..n {
                    let line = self.c.line();
                    let id: u64 = self.c.parse("an element id")?;
                    let ty: i64 = self.c.parse("an element type")?;
                    let (nn, _, _) = element_type(ty).ok_or_else(|| {
                        self.c
                            .error_at(line, format!("element {id}: unknown element type {ty}"))
                    })?;
                    let ntags: usize = self.c.count("the number of tags", 64)?;
                    let mut physical = 0;
                    for k in 0..ntags {
                        let tag: i64 = self.c.parse("an element tag")?;
                        if k == 0 {
                            physical = tag;
                        }
                    }
                    nodes.clear();
                    for _ in 0..nn {
                        nodes.push(self.c.parse("a node id")?);
                    }
                    let set = raw.set_index(if physical != 0 {
                        vec![physical]
                    } else {
                        vec![]
                    });
                    let at = Seen {
                        id,
                        line: Some(line),
                    };
                    raw.add_element(self.c.path(), at, ty, set, &nodes)?;
                }
            }
            Some(b) => {
                self.c.skip_line();
                let mut read = 0;
                while read < n {
                    let header = self.c.bytes(12, "an element block header")?;
                    let field = |k: usize| as_int(decode(&header[4 * k..], Scalar::I32, b.endian));
                    let (ty, count, ntags) = (field(0), field(1), field(2));
                    let (nn, _, _) = element_type(ty).ok_or_else(|| {
                        self.c
                            .error(format!("unknown element type {ty} in a binary block"))
                    })?;
                    if count <= 0 || count as usize > n - read || !(0..=64).contains(&ntags) {
                        return Err(self.c.error(format!(
                            "bad element block header (type {ty}, {count} elements, {ntags} tags)"
                        )));
                    }
                    let words = 1 + ntags as usize + nn;
                    let bytes = self.c.bytes(count as usize * words * 4, "the elements")?;
                    for e in bytes.chunks_exact(words * 4) {
                        let w = |k: usize| as_int(decode(&e[4 * k..], Scalar::I32, b.endian));
                        let physical = if ntags > 0 { w(1) } else { 0 };
                        nodes.clear();
                        nodes.extend((0..nn).map(|k| w(1 + ntags as usize + k) as u64));
                        let set = raw.set_index(if physical != 0 {
                            vec![physical]
                        } else {
                            vec![]
                        });
                        let at = Seen {
                            id: w(0) as u64,
                            line: None,
                        };
                        raw.add_element(self.c.path(), at, ty, set, &nodes)?;
                    }
                    read += count as usize;
                }
            }
        }
        Ok(())
    }

    fn elements_v4(&mut self, raw: &mut Raw) -> Result<()> {
        self.start_binary();
        let blocks = self.count("the number of element blocks", 16)?;
        let total = self.count("the number of elements", 8)?;
        self.size("the smallest element tag")?;
        self.size("the largest element tag")?;
        raw.tets.reserve(total);
        let mut read = 0;
        let mut nodes = Vec::new();
        for _ in 0..blocks {
            let line = self.c.line();
            let dim = self.int("an entity dimension")?;
            let tag = self.int("an entity tag")?;
            let ty = self.int("an element type")?;
            let n = self.count("the number of elements in the block", 8)?;
            let (nn, _, _) = element_type(ty)
                .ok_or_else(|| self.c.error_at(line, format!("unknown element type {ty}")))?;
            let set = usize::try_from(dim)
                .ok()
                .and_then(|d| raw.entities.get(&(d, tag)).copied())
                .unwrap_or(0);
            match self.binary {
                None => {
                    for _ in 0..n {
                        let line = self.c.line();
                        let id: u64 = self.c.parse("an element tag")?;
                        nodes.clear();
                        for _ in 0..nn {
                            nodes.push(self.c.parse("a node tag")?);
                        }
                        let at = Seen {
                            id,
                            line: Some(line),
                        };
                        raw.add_element(self.c.path(), at, ty, set, &nodes)?;
                    }
                }
                Some(b) => {
                    let sz = b.size_t.size();
                    let stride = sz * (1 + nn);
                    let bytes = self.c.bytes(n.saturating_mul(stride), "the elements")?;
                    for e in bytes.chunks_exact(stride) {
                        let w = |k: usize| as_int(decode(&e[sz * k..], b.size_t, b.endian)) as u64;
                        nodes.clear();
                        nodes.extend((0..nn).map(|k| w(1 + k)));
                        let at = Seen {
                            id: w(0),
                            line: None,
                        };
                        raw.add_element(self.c.path(), at, ty, set, &nodes)?;
                    }
                }
            }
            read += n;
        }
        if read != total {
            return Err(self.c.error(format!(
                "the $Elements header announces {total} elements but the blocks hold {read}"
            )));
        }
        Ok(())
    }

    /// Skip an unneeded section up to its `$End…` line.
    fn skip_section(&mut self, name: &str) -> Result<()> {
        let end = format!("$End{name}");
        let rest = self.c.remaining();
        let found = rest.windows(end.len()).position(|w| w == end.as_bytes());
        match found {
            Some(offset) => {
                let newlines = rest[..offset].iter().filter(|&&b| b == b'\n').count();
                let pos = self.c.pos() + offset + end.len();
                self.c.seek(pos, newlines);
                Ok(())
            }
            None => Err(self.c.error(format!(
                "section `${}` has no `{}`",
                shorten(name),
                shorten(&end)
            ))),
        }
    }
}

fn as_int(v: super::text::Value) -> i64 {
    match v {
        super::text::Value::Int(i) => i as i64,
        super::text::Value::Float(f) => f as i64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MSH 2.2 binary, which no fixture covers: one tet in physical 7 "solid", one triangle in
    /// the unnamed physical 5, node ids from 10.
    fn binary_v22() -> Vec<u8> {
        let mut b = b"$MeshFormat\n2.2 1 8\n".to_vec();
        b.extend(1i32.to_le_bytes());
        b.extend(b"\n$EndMeshFormat\n$PhysicalNames\n1\n3 7 \"solid\"\n$EndPhysicalNames\n");
        b.extend(b"$Nodes\n4\n");
        let corners = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        for (i, x) in corners.iter().enumerate() {
            b.extend((10 + i as i32).to_le_bytes());
            x.iter().for_each(|c: &f64| b.extend(c.to_le_bytes()));
        }
        b.extend(b"\n$EndNodes\n$Elements\n2\n");
        for w in [
            4i32, 1, 2, 1, 7, 1, 10, 11, 12, 13, 2, 1, 2, 2, 5, 1, 10, 11, 12,
        ] {
            b.extend(w.to_le_bytes());
        }
        b.extend(b"\n$EndElements\n");
        b
    }

    #[test]
    fn msh22_binary_reads_tets_and_groups() {
        let dir = std::env::temp_dir().join(format!("tetsim-msh22b-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.msh");
        std::fs::write(&path, binary_v22()).unwrap();
        let (parsed, name) = read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(name, "Gmsh 2.2 binary");
        let mesh = parsed.mesh;
        assert_eq!(mesh.tets, vec![[0, 1, 2, 3]]);
        assert_eq!(mesh.vertex_id(0), 10);
        assert_eq!(mesh.positions[3], Vec3::new(0.0, 0.0, 1.0));
        let dims: Vec<(usize, i64, &str, usize)> = mesh
            .groups
            .iter()
            .map(|g| (g.dim, g.tag, g.name.as_str(), g.faces.len() + g.tets.len()))
            .collect();
        assert_eq!(dims, vec![(2, 5, "", 1), (3, 7, "solid", 1)]);
        assert_eq!(parsed.ignored, vec![("triangle".to_string(), 1)]);
    }
}
