//! Stanford `.ply` triangle surfaces, ASCII and binary (little and big endian), read as a
//! [`TriangleSurface`]: `vertex` elements with `x`, `y`, `z` of any numeric type, and `face`
//! elements with a `vertex_indices` (or `vertex_index`) list of any integer type. Polygons are
//! split into fans; other elements and properties (colours, normals, edges, materials) are
//! skipped. Errors name the file and the header line, the body line (ASCII) or the element and
//! byte offset (binary).

use std::path::Path;

use super::obj::TriangleSurface;
use super::read_bytes;
use super::text::{Endian, Scalar, decode};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// PLY's type names: the binary readers' scalar types.
fn scalar(name: &str) -> Option<Scalar> {
    Some(match name {
        "char" | "int8" => Scalar::I8,
        "uchar" | "uint8" => Scalar::U8,
        "short" | "int16" => Scalar::I16,
        "ushort" | "uint16" => Scalar::U16,
        "int" | "int32" => Scalar::I32,
        "uint" | "uint32" => Scalar::U32,
        "float" | "float32" => Scalar::F32,
        "double" | "float64" => Scalar::F64,
        _ => return None,
    })
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    /// Some(count type) for a list property.
    list: Option<Scalar>,
    kind: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// The header: format, elements, and the byte offset and line where the body starts.
fn header(path: &Path, data: &[u8]) -> Result<(Encoding, Vec<Element>, usize, usize)> {
    let err = |line: usize, m: String| Error::parse(path, Some(line), m);
    let mut offset = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0;
    loop {
        let Some(end) = data[offset..].iter().position(|&b| b == b'\n') else {
            return Err(Error::parse(
                path,
                Some(line_no + 1),
                "the header has no `end_header` line",
            ));
        };
        let line = String::from_utf8_lossy(&data[offset..offset + end]);
        let line = line.trim_end_matches('\r').trim();
        offset += end + 1;
        line_no += 1;
        let mut tokens = line.split_whitespace();
        let first = tokens.next();
        if line_no == 1 {
            if first != Some("ply") {
                return Err(err(1, "not a PLY file: the first line is not `ply`".into()));
            }
            continue;
        }
        match first {
            Some("format") => {
                encoding = Some(match tokens.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Little,
                    Some("binary_big_endian") => Encoding::Big,
                    other => {
                        return Err(err(
                            line_no,
                            format!("unknown format `{}`", other.unwrap_or("")),
                        ));
                    }
                });
            }
            Some("element") => {
                let name = tokens.next().unwrap_or("").to_string();
                let count = tokens.next().and_then(|c| c.parse().ok()).ok_or_else(|| {
                    err(line_no, format!("element `{name}` without a valid count"))
                })?;
                elements.push(Element {
                    name,
                    count,
                    properties: Vec::new(),
                });
            }
            Some("property") => {
                let words: Vec<&str> = tokens.collect();
                let property = match words.as_slice() {
                    ["list", count, item, name] => {
                        let (Some(c), Some(i)) = (scalar(count), scalar(item)) else {
                            return Err(err(line_no, format!("unknown type in `{line}`")));
                        };
                        if !c.is_integer() {
                            return Err(err(line_no, "a list's count must be an integer".into()));
                        }
                        Property {
                            name: name.to_string(),
                            list: Some(c),
                            kind: i,
                        }
                    }
                    [kind, name] => Property {
                        name: name.to_string(),
                        list: None,
                        kind: scalar(kind).ok_or_else(|| {
                            err(line_no, format!("unknown property type `{kind}`"))
                        })?,
                    },
                    _ => return Err(err(line_no, format!("malformed property `{line}`"))),
                };
                let element = elements
                    .last_mut()
                    .ok_or_else(|| err(line_no, "a property before any element".into()))?;
                element.properties.push(property);
            }
            Some("end_header") => break,
            Some("comment" | "obj_info") | None => {}
            Some(other) => {
                return Err(err(line_no, format!("unknown header keyword `{other}`")));
            }
        }
    }
    let encoding =
        encoding.ok_or_else(|| Error::parse(path, Some(line_no), "the header has no `format`"))?;
    Ok((encoding, elements, offset, line_no))
}

/// One element's values: scalars as f64, lists as their items.
type Row = Vec<Vec<f64>>;

/// Reads rows of elements from the body, ASCII or binary.
struct Body<'a> {
    path: &'a Path,
    data: &'a [u8],
    encoding: Encoding,
    offset: usize,
    line: usize,
}

impl Body<'_> {
    fn row(&mut self, element: &Element, index: usize) -> Result<Row> {
        match self.encoding {
            Encoding::Ascii => self.ascii_row(element, index),
            _ => self.binary_row(element, index),
        }
    }

    fn ascii_row(&mut self, element: &Element, index: usize) -> Result<Row> {
        // Skip blank lines; one element per line.
        let text = loop {
            if self.offset >= self.data.len() {
                return Err(Error::parse(
                    self.path,
                    Some(self.line + 1),
                    format!(
                        "the file ends before {} {} of {}",
                        element.name,
                        index + 1,
                        element.count
                    ),
                ));
            }
            let end = self.data[self.offset..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(self.data.len(), |e| self.offset + e);
            let line = String::from_utf8_lossy(&self.data[self.offset..end]).into_owned();
            self.offset = end + 1;
            self.line += 1;
            if !line.trim().is_empty() {
                break line;
            }
        };
        let line_no = self.line;
        let err = |m: String| Error::parse(self.path, Some(line_no), m);
        let mut tokens = text.split_whitespace();
        let mut next = |what: &str| -> Result<f64> {
            let token = tokens
                .next()
                .ok_or_else(|| err(format!("{} {}: missing {what}", element.name, index + 1)))?;
            token.parse::<f64>().map_err(|_| {
                err(format!(
                    "{} {}: {what} `{token}` is not a number",
                    element.name,
                    index + 1
                ))
            })
        };
        let mut row = Vec::with_capacity(element.properties.len());
        for p in &element.properties {
            if p.list.is_some() {
                let n = next(&format!("the count of `{}`", p.name))?;
                if !(n >= 0.0 && n.fract() == 0.0) {
                    return Err(err(format!(
                        "{} {}: list count {n} is not a count",
                        element.name,
                        index + 1
                    )));
                }
                let items = (0..n as usize)
                    .map(|_| next(&format!("an item of `{}`", p.name)))
                    .collect::<Result<Vec<f64>>>()?;
                row.push(items);
            } else {
                row.push(vec![next(&format!("`{}`", p.name))?]);
            }
        }
        Ok(row)
    }

    fn value(&mut self, kind: Scalar, element: &Element, index: usize) -> Result<f64> {
        let size = kind.size();
        let Some(bytes) = self.data.get(self.offset..self.offset + size) else {
            return Err(Error::parse(
                self.path,
                None,
                format!(
                    "{} {} of {} (byte offset {}): the file ends inside it (truncated?)",
                    element.name,
                    index + 1,
                    element.count,
                    self.offset
                ),
            ));
        };
        self.offset += size;
        let endian = if self.encoding == Encoding::Big {
            Endian::Big
        } else {
            Endian::Little
        };
        Ok(decode(bytes, kind, endian).as_f64())
    }

    fn binary_row(&mut self, element: &Element, index: usize) -> Result<Row> {
        let mut row = Vec::with_capacity(element.properties.len());
        for p in &element.properties {
            if let Some(count_kind) = p.list {
                let at = self.offset;
                let n = self.value(count_kind, element, index)?;
                if n < 0.0 {
                    return Err(Error::parse(
                        self.path,
                        None,
                        format!(
                            "{} {} (byte offset {at}): negative list count {n}",
                            element.name,
                            index + 1
                        ),
                    ));
                }
                let items = (0..n as usize)
                    .map(|_| self.value(p.kind, element, index))
                    .collect::<Result<Vec<f64>>>()?;
                row.push(items);
            } else {
                row.push(vec![self.value(p.kind, element, index)?]);
            }
        }
        Ok(row)
    }

    /// Where the last row was, for messages.
    fn place(&self, element: &Element, index: usize) -> (Option<usize>, String) {
        match self.encoding {
            Encoding::Ascii => (Some(self.line), format!("{} {}", element.name, index + 1)),
            _ => (None, format!("{} {}", element.name, index + 1)),
        }
    }
}

/// Read an ASCII or binary `.ply` surface (see the module doc).
pub fn read_ply(path: &Path) -> Result<TriangleSurface> {
    let data = read_bytes(path)?;
    let (encoding, elements, offset, line) = header(path, &data)?;
    let mut body = Body {
        path,
        data: &data,
        encoding,
        offset,
        line,
    };
    let mut surface = TriangleSurface::default();
    let mut faces: Vec<(Option<usize>, String, Vec<f64>)> = Vec::new();
    for element in &elements {
        let find = |name: &str| element.properties.iter().position(|p| p.name == name);
        match element.name.as_str() {
            "vertex" => {
                let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
                    return Err(Error::parse(
                        path,
                        None,
                        "the vertex element lacks an x, y or z property",
                    ));
                };
                for i in 0..element.count {
                    let row = body.row(element, i)?;
                    let p = Vec3::new(row[x][0], row[y][0], row[z][0]);
                    if !p.iter().all(|c| c.is_finite()) {
                        let (line, what) = body.place(element, i);
                        return Err(Error::parse(
                            path,
                            line,
                            format!("{what} has a non-finite coordinate"),
                        ));
                    }
                    surface.positions.push(p);
                }
            }
            "face" => {
                let list = find("vertex_indices").or_else(|| find("vertex_index"));
                let Some(list) = list.filter(|&k| element.properties[k].list.is_some()) else {
                    return Err(Error::parse(
                        path,
                        None,
                        "the face element lacks a vertex_indices list",
                    ));
                };
                for i in 0..element.count {
                    let mut row = body.row(element, i)?;
                    let (line, what) = body.place(element, i);
                    faces.push((line, what, std::mem::take(&mut row[list])));
                }
            }
            _ => {
                for i in 0..element.count {
                    body.row(element, i)?;
                }
            }
        }
    }
    let n = surface.positions.len();
    for (line, what, ids) in faces {
        if ids.len() < 3 {
            return Err(Error::parse(
                path,
                line,
                format!("{what} has {} vertices (at least 3 needed)", ids.len()),
            ));
        }
        if let Some(&bad) = ids
            .iter()
            .find(|&&v| !(v >= 0.0 && v.fract() == 0.0 && (v as usize) < n))
        {
            return Err(Error::parse(
                path,
                line,
                format!("{what} refers to vertex {bad}, but the file has {n} vertices (0-based)"),
            ));
        }
        for k in 1..ids.len() - 1 {
            surface
                .faces
                .push([ids[0] as usize, ids[k] as usize, ids[k + 1] as usize]);
        }
    }
    if surface.faces.is_empty() {
        return Err(Error::parse(path, None, "no faces"));
    }
    Ok(surface)
}
