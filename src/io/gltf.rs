//! One animated file of deformed render surfaces: glTF 2.0 binary (`.glb`) with a morph target
//! per frame and an animation on the morph weights.
//!
//! Why glTF: Blender (File › Import › glTF 2.0, built in), three.js, Godot, Unity and most
//! viewers read it without a plug-in; a morph target per frame plays back with nothing but the
//! file (no cache folder beside it, unlike Blender's point caches), and the format is a small,
//! stable JSON schema plus one binary buffer, written here with `serde_json` (no new
//! dependency). Alembic and USD, the film-pipeline formats, have no maintained Rust writer.
//!
//! Layout: one node and mesh per surface (named after its body); the glTF vertices are the
//! distinct (position, texture coordinate) pairs of its corners, so UV seams stay seams; one
//! primitive per material, all sharing the vertex attributes (POSITION, NORMAL, TEXCOORD_0 with
//! v flipped to glTF's top-left origin). Frame 0 is the base shape; frame k ≥ 1 is morph target
//! k − 1, holding position and normal offsets from frame 0. The animation keys every frame at
//! its time with weight 1 on its own target and 0 on the others, linearly interpolated.
//! Materials take their diffuse colour (`Kd`, `d`) from the surface's `.mtl` files when found.

use std::io::Write;
use std::path::Path;

use serde_json::{Value, json};

use super::atomic_write;
use super::render_obj::{Item, RenderSurface, vertex_normals};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// One surface of the animation.
pub struct AnimatedSurface<'a> {
    /// Node and mesh name.
    pub name: &'a str,
    /// Faces, texture coordinates and materials.
    pub surface: &'a RenderSurface,
    /// Diffuse colours (RGBA) of its materials by name, from its `.mtl` files.
    pub colours: Vec<(String, [f64; 4])>,
}

/// The glTF vertices and primitives of one surface.
struct Layout {
    /// The position index of each glTF vertex.
    source: Vec<u32>,
    /// Its texture coordinate (glTF orientation), when the surface has any.
    uv: Option<Vec<[f32; 2]>>,
    /// (material name, triangles as glTF vertex indices), one per material in order of use.
    primitives: Vec<(Option<String>, Vec<u32>)>,
    /// Fan triangles over positions, for normals.
    triangles: Vec<[usize; 3]>,
}

impl Layout {
    fn new(s: &RenderSurface) -> Layout {
        let mut index = std::collections::HashMap::new();
        let (mut source, mut uv) = (Vec::new(), Vec::new());
        let mut primitives: Vec<(Option<String>, Vec<u32>)> = Vec::new();
        let mut current = 0usize;
        let has_uv = !s.texcoords.is_empty();
        for item in &s.items {
            match item {
                Item::Material(name) => {
                    let name = Some(name.clone());
                    current = match primitives.iter().position(|(m, _)| *m == name) {
                        Some(k) => k,
                        None => {
                            primitives.push((name, Vec::new()));
                            primitives.len() - 1
                        }
                    };
                }
                Item::Face(corners) => {
                    if primitives.is_empty() {
                        primitives.push((None, Vec::new()));
                    }
                    let ids: Vec<u32> = corners
                        .iter()
                        .map(|c| {
                            *index.entry((c.v, c.vt)).or_insert_with(|| {
                                source.push(c.v);
                                let t = c.vt.map_or([0.0, 0.0], |t| s.texcoords[t as usize]);
                                uv.push([t[0] as f32, (1.0 - t[1]) as f32]);
                                (source.len() - 1) as u32
                            })
                        })
                        .collect();
                    let list = &mut primitives[current].1;
                    for k in 1..ids.len() - 1 {
                        list.extend([ids[0], ids[k], ids[k + 1]]);
                    }
                }
                _ => {}
            }
        }
        primitives.retain(|(_, t)| !t.is_empty());
        Layout {
            source,
            uv: has_uv.then_some(uv),
            primitives,
            triangles: s.triangles(),
        }
    }

    /// Positions and normals of the glTF vertices for the surface's `positions`.
    fn attributes(&self, positions: &[Vec3]) -> (Vec<Vec3>, Vec<Vec3>) {
        let normals = vertex_normals(positions, &self.triangles);
        let p = self.source.iter().map(|&v| positions[v as usize]).collect();
        let n = self.source.iter().map(|&v| normals[v as usize]).collect();
        (p, n)
    }
}

/// The binary buffer's parts, in order, with the JSON's bufferViews and accessors.
#[derive(Default)]
struct Builder {
    views: Vec<Value>,
    accessors: Vec<Value>,
    length: usize,
}

impl Builder {
    /// An accessor over `bytes` new bytes; returns its index.
    fn accessor(&mut self, bytes: usize, mut accessor: Value) -> usize {
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.length, "byteLength": bytes}));
        accessor["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(accessor);
        // Every part is whole 4-byte numbers, so views stay aligned without padding.
        self.length += bytes;
        self.accessors.len() - 1
    }

    fn vec3(&mut self, count: usize, bounds: Option<(Vec3, Vec3)>) -> usize {
        let mut a = json!({"componentType": FLOAT, "count": count, "type": "VEC3"});
        if let Some((lo, hi)) = bounds {
            a["min"] = json!([lo.x as f32, lo.y as f32, lo.z as f32]);
            a["max"] = json!([hi.x as f32, hi.y as f32, hi.z as f32]);
        }
        self.accessor(count * 12, a)
    }
}

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// The bounds of `v` as f32 would store them (glTF asks for exact bounds).
fn bounds(v: &[Vec3]) -> (Vec3, Vec3) {
    let f = |p: &Vec3| p.map(|c| c as f32 as f64);
    v.iter().fold(
        (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(&f(p)), hi.sup(&f(p))),
    )
}

fn put_vec3(w: &mut dyn Write, v: &[Vec3]) -> std::io::Result<()> {
    let mut bytes = Vec::with_capacity(v.len() * 12);
    for p in v {
        for c in p.iter() {
            bytes.extend_from_slice(&(*c as f32).to_le_bytes());
        }
    }
    w.write_all(&bytes)
}

/// Write the animation of `surfaces` over the frames at `times` (s) to `path`. `frame(k)`
/// gives frame k's positions of every surface, one after the other; it is called twice per
/// frame (bounds first, then data), so that memory holds one frame at a time.
pub fn write_glb(
    path: &Path,
    surfaces: &[AnimatedSurface],
    times: &[f64],
    mut frame: impl FnMut(usize) -> Result<Vec<Vec3>>,
) -> Result<()> {
    let layouts: Vec<Layout> = surfaces.iter().map(|s| Layout::new(s.surface)).collect();
    let counts: Vec<usize> = surfaces.iter().map(|s| s.surface.positions.len()).collect();
    let split = |all: Vec<Vec3>, k: usize| -> Result<Vec<Vec<Vec3>>> {
        if all.len() != counts.iter().sum::<usize>() {
            return Err(Error::parameter(
                "render",
                format!(
                    "frame {k} of the render surfaces holds {} vertices, not {}",
                    all.len(),
                    counts.iter().sum::<usize>()
                ),
            ));
        }
        let mut out = Vec::new();
        let mut rest = all.as_slice();
        for &n in &counts {
            let (a, b) = rest.split_at(n);
            out.push(a.to_vec());
            rest = b;
        }
        Ok(out)
    };
    let frames = times.len();
    let base = split(frame(0)?, 0)?;
    let base_attr: Vec<(Vec<Vec3>, Vec<Vec3>)> = layouts
        .iter()
        .zip(&base)
        .map(|(l, p)| l.attributes(p))
        .collect();
    // First pass: the bounds of every target's position offsets.
    let mut target_bounds = vec![Vec::with_capacity(frames); surfaces.len()];
    for k in 1..frames {
        for (b, p) in split(frame(k)?, k)?.iter().enumerate() {
            let (pos, _) = layouts[b].attributes(p);
            let d: Vec<Vec3> = pos
                .iter()
                .zip(&base_attr[b].0)
                .map(|(a, o)| a - o)
                .collect();
            target_bounds[b].push(bounds(&d));
        }
    }
    let mut g = Builder::default();
    let mut materials: Vec<Value> = Vec::new();
    let (mut meshes, mut nodes) = (Vec::new(), Vec::new());
    for (b, (s, l)) in surfaces.iter().zip(&layouts).enumerate() {
        let n = l.source.len();
        let position = g.vec3(n, Some(bounds(&base_attr[b].0)));
        let normal = g.vec3(n, None);
        let mut attributes = json!({"POSITION": position, "NORMAL": normal});
        if l.uv.is_some() {
            let a = json!({"componentType": FLOAT, "count": n, "type": "VEC2"});
            attributes["TEXCOORD_0"] = json!(g.accessor(n * 8, a));
        }
        let mut primitives = Vec::new();
        for (name, tris) in &l.primitives {
            let a = json!({"componentType": UNSIGNED_INT, "count": tris.len(), "type": "SCALAR"});
            let mut p = json!({"attributes": attributes.clone(), "indices": g.accessor(tris.len() * 4, a), "mode": 4});
            if let Some(name) = name {
                let colour = s
                    .colours
                    .iter()
                    .find(|(m, _)| m == name)
                    .map_or([0.8, 0.8, 0.8, 1.0], |(_, c)| *c);
                let mut m = json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": colour, "metallicFactor": 0.0, "roughnessFactor": 0.6}, "doubleSided": true});
                if colour[3] < 1.0 {
                    m["alphaMode"] = json!("BLEND");
                }
                materials.push(m);
                p["material"] = json!(materials.len() - 1);
            }
            primitives.push(p);
        }
        meshes.push(json!({"name": s.name, "primitives": primitives}));
        nodes.push(json!({"name": s.name, "mesh": b}));
    }
    let mut json = json!({
        "asset": {"version": "2.0", "generator": concat!("tetsim ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..surfaces.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
    });
    let targets = frames.saturating_sub(1);
    if targets > 0 {
        let t0 = times[0];
        let (t_lo, t_hi) = ((times[0] - t0) as f32, (times[frames - 1] - t0) as f32);
        let a = json!({"componentType": FLOAT, "count": frames, "type": "SCALAR", "min": [t_lo], "max": [t_hi]});
        let input = g.accessor(frames * 4, a);
        let a = json!({"componentType": FLOAT, "count": frames * targets, "type": "SCALAR"});
        let output = g.accessor(frames * targets * 4, a);
        for (b, l) in layouts.iter().enumerate() {
            let list: Vec<Value> = (0..targets)
                .map(|k| {
                    let position = g.vec3(l.source.len(), Some(target_bounds[b][k]));
                    let normal = g.vec3(l.source.len(), None);
                    json!({"POSITION": position, "NORMAL": normal})
                })
                .collect();
            for p in meshes[b]["primitives"].as_array_mut().into_iter().flatten() {
                p["targets"] = json!(list);
            }
            meshes[b]["weights"] = json!(vec![0.0; targets]);
        }
        let channels: Vec<Value> = (0..surfaces.len())
            .map(|b| json!({"sampler": 0, "target": {"node": b, "path": "weights"}}))
            .collect();
        json["animations"] = json!([{"name": "tetsim", "samplers": [{"input": input, "output": output, "interpolation": "LINEAR"}], "channels": channels}]);
    }
    json["meshes"] = json!(meshes);
    if !materials.is_empty() {
        json["materials"] = json!(materials);
    }
    json["bufferViews"] = json!(g.views);
    json["accessors"] = json!(g.accessors);
    json["buffers"] = json!([{"byteLength": g.length}]);
    let mut text =
        serde_json::to_vec(&json).map_err(|e| Error::parameter("render", e.to_string()))?;
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + g.length;
    let total = u32::try_from(total).map_err(|_| {
        Error::parameter(
            "render",
            format!(
                "{}: the animation would take {total} bytes, more than a .glb holds (4 GiB); \
                 use fewer frames or a coarser render surface",
                path.display()
            ),
        )
    })?;
    // The frames are read again inside the writer; their errors come out through this slot.
    let mut failed: Option<Error> = None;
    let result = atomic_write(path, |w| {
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&total.to_le_bytes())?;
        w.write_all(&(text.len() as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&text)?;
        w.write_all(&(g.length as u32).to_le_bytes())?;
        w.write_all(b"BIN\0")?;
        for (l, (p, n)) in layouts.iter().zip(&base_attr) {
            put_vec3(w, p)?;
            put_vec3(w, n)?;
            if let Some(uv) = &l.uv {
                let bytes: Vec<u8> = uv.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
                w.write_all(&bytes)?;
            }
            for (_, tris) in &l.primitives {
                let bytes: Vec<u8> = tris.iter().flat_map(|i| i.to_le_bytes()).collect();
                w.write_all(&bytes)?;
            }
        }
        if targets > 0 {
            let bytes: Vec<u8> = times
                .iter()
                .flat_map(|t| ((t - times[0]) as f32).to_le_bytes())
                .collect();
            w.write_all(&bytes)?;
            let mut weights = Vec::with_capacity(frames * targets * 4);
            for k in 0..frames {
                for j in 0..targets {
                    let on = if k >= 1 && j == k - 1 { 1.0f32 } else { 0.0 };
                    weights.extend_from_slice(&on.to_le_bytes());
                }
            }
            w.write_all(&weights)?;
        }
        for k in 1..frames {
            let all = match frame(k).and_then(|a| split(a, k)) {
                Ok(all) => all,
                Err(e) => {
                    failed = Some(e);
                    return Err(std::io::Error::other("a frame could not be read"));
                }
            };
            for (b, p) in all.iter().enumerate() {
                let (pos, nor) = layouts[b].attributes(p);
                let dp: Vec<Vec3> = pos
                    .iter()
                    .zip(&base_attr[b].0)
                    .map(|(a, o)| a - o)
                    .collect();
                let dn: Vec<Vec3> = nor
                    .iter()
                    .zip(&base_attr[b].1)
                    .map(|(a, o)| a - o)
                    .collect();
                put_vec3(w, &dp)?;
                put_vec3(w, &dn)?;
            }
        }
        Ok(())
    });
    match failed {
        Some(e) => Err(e),
        None => result,
    }
}

/// The diffuse colours of the materials of the `.mtl` file at `path` (`newmtl`, `Kd`, `d`);
/// an unreadable file gives none (the materials then keep a neutral grey).
pub fn mtl_colours(path: &Path) -> Vec<(String, [f64; 4])> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    let mut out: Vec<(String, [f64; 4])> = Vec::new();
    for line in text.lines() {
        let mut t = line.split_whitespace();
        let key = t.next();
        let values: Vec<f64> = t.clone().filter_map(|x| x.parse().ok()).collect();
        match (key, out.last_mut()) {
            (Some("newmtl"), _) => {
                out.push((t.collect::<Vec<_>>().join(" "), [0.8, 0.8, 0.8, 1.0]))
            }
            (Some("Kd"), Some((_, c))) if values.len() >= 3 => {
                c[..3].copy_from_slice(
                    &values[..3]
                        .iter()
                        .map(|v| v.clamp(0.0, 1.0))
                        .collect::<Vec<_>>(),
                );
            }
            (Some("d"), Some((_, c))) if !values.is_empty() => c[3] = values[0].clamp(0.0, 1.0),
            _ => {}
        }
    }
    out
}
