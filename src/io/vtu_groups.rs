//! A mesh's named groups in a `.vtu` file, the way ParaView and meshio users see them: one
//! `UInt8` array per group, named as the group, 1 on its members and 0 elsewhere. Volume groups
//! mark tets (cell data); face groups mark triangle cells written after the tets (`VTK_TRIANGLE`,
//! 6-node `VTK_QUADRATIC_TRIANGLE` beside 10-node tets; tet readers skip them); point and line
//! groups mark vertices (point data). Numeric tags are not kept (an array has only a name). Reading back,
//! every `UInt8` array of 0s and 1s is a group (tetsim writes its frames' fields as `Float64`),
//! so a converted mesh keeps `region = { physical = "clamp" }` working.

use std::path::Path;

use super::vtu::FieldData;
use super::vtu_write::{Array, VtuOptions, geometry, write_arrays};
use crate::error::Result;
use crate::mesh::{Group, TetMesh};

/// VTK's linear triangle.
const VTK_TRIANGLE: i64 = 5;
/// VTK's 6-node triangle: corners, then the nodes on edges 01, 12, 20.
const VTK_QUADRATIC_TRIANGLE: i64 = 22;

/// The name a group's array gets: its own, or `group_TAG` when the file gave only a tag.
fn array_name(g: &Group) -> String {
    if g.name.is_empty() {
        format!("group_{}", g.tag)
    } else {
        g.name.clone()
    }
}

/// Write `mesh` (linear or 10-node tets) with its groups as arrays.
pub fn write_mesh_vtu(path: &Path, mesh: &TetMesh) -> Result<()> {
    let quadratic = mesh.is_quadratic();
    let mut connectivity: Vec<i64> = Vec::new();
    let mut ends: Vec<i64> = Vec::new();
    let mut types: Vec<u8> = Vec::new();
    let mut push = |nodes: &[usize], ty: i64| {
        connectivity.extend(nodes.iter().map(|&v| v as i64));
        ends.push(connectivity.len() as i64);
        types.push(ty as u8);
    };
    for t in 0..mesh.tets.len() {
        if quadratic {
            push(&mesh.quadratic_nodes(t), super::vtk::VTK_QUADRATIC_TETRA);
        } else {
            push(&mesh.tets[t], super::vtk::VTK_TETRA);
        }
    }
    // Each face group's triangles, in group order: (group, first cell, count).
    let mut face_cells = Vec::new();
    let mut cells = mesh.tets.len();
    // Quadratic tets: face groups as 6-node triangles, so their edge nodes come back too.
    let mut mids = std::collections::HashMap::new();
    if quadratic {
        for (t, tet) in mesh.tets.iter().enumerate() {
            for (k, [i, j]) in crate::mesh::quadratic::EDGES.iter().enumerate() {
                let (a, b) = (tet[*i], tet[*j]);
                mids.insert((a.min(b), a.max(b)), mesh.edge_nodes[t][k]);
            }
        }
    }
    let mid = |a: usize, b: usize| mids.get(&(a.min(b), a.max(b))).copied();
    for (k, g) in mesh.groups.iter().enumerate() {
        if g.dim == 2 && !g.faces.is_empty() {
            face_cells.push((k, cells, g.faces.len()));
            cells += g.faces.len();
            for f in &g.faces {
                match (mid(f[0], f[1]), mid(f[1], f[2]), mid(f[2], f[0])) {
                    (Some(m01), Some(m12), Some(m20)) => {
                        push(&[f[0], f[1], f[2], m01, m12, m20], VTK_QUADRATIC_TRIANGLE)
                    }
                    _ => push(f, VTK_TRIANGLE),
                }
            }
        }
    }
    let mut arrays = Vec::new();
    for g in mesh.groups.iter().filter(|g| g.dim < 2) {
        let mut flags = vec![0u8; mesh.positions.len()];
        g.vertices.iter().for_each(|&v| flags[v] = 1);
        arrays.push(flag_array("PointData", array_name(g), flags));
    }
    for (k, g) in mesh.groups.iter().enumerate().filter(|(_, g)| g.dim >= 2) {
        let mut flags = vec![0u8; cells];
        if g.dim == 3 {
            g.tets.iter().for_each(|&t| flags[t] = 1);
        }
        for &(_, first, count) in face_cells.iter().filter(|c| c.0 == k) {
            flags[first..first + count].fill(1);
        }
        arrays.push(flag_array("CellData", array_name(g), flags));
    }
    arrays.extend(geometry(&mesh.positions, &connectivity, &ends, types));
    write_arrays(
        path,
        mesh.positions.len(),
        cells,
        &arrays,
        VtuOptions::default(),
    )
}

fn flag_array(section: &'static str, name: String, flags: Vec<u8>) -> Array {
    Array {
        section,
        name,
        ty: "UInt8",
        components: 1,
        bytes: flags,
    }
}

/// The groups a VTU file's `UInt8` 0/1 arrays describe. `flags` are the (cell data?, name) of
/// the file's `UInt8` arrays; `cells` the file's cells as (VTK type, nodes); `tet_cells` the
/// file cell of each tet read.
pub(super) fn read_groups(
    flags: &[(bool, String)],
    point_data: &[(String, FieldData)],
    cell_data: &[(String, FieldData)],
    cells: &[(i64, Vec<usize>)],
    tet_cells: &[usize],
) -> Vec<Group> {
    let ones = |data: &[(String, FieldData)], name: &str| -> Option<Vec<usize>> {
        let (_, FieldData::Scalar(values)) = data.iter().find(|(n, _)| n == name)? else {
            return None;
        };
        values
            .iter()
            .all(|&v| v == 0.0 || v == 1.0)
            .then(|| (0..values.len()).filter(|&i| values[i] == 1.0).collect())
    };
    let mut groups = Vec::new();
    for (cell, name) in flags {
        let mut g = Group {
            name: name.clone(),
            ..Default::default()
        };
        if *cell {
            let Some(members) = ones(cell_data, name) else {
                continue;
            };
            let mut member = vec![false; cells.len()];
            members
                .iter()
                .filter(|&&c| c < cells.len())
                .for_each(|&c| member[c] = true);
            g.tets = (0..tet_cells.len())
                .filter(|&t| member[tet_cells[t]])
                .collect();
            let triangles: Vec<&Vec<usize>> = members
                .iter()
                .filter_map(|&c| cells.get(c))
                .filter(|(ty, nodes)| {
                    (*ty == VTK_TRIANGLE && nodes.len() == 3)
                        || (*ty == VTK_QUADRATIC_TRIANGLE && nodes.len() == 6)
                })
                .map(|(_, nodes)| nodes)
                .collect();
            g.faces = triangles.iter().map(|n| [n[0], n[1], n[2]]).collect();
            g.dim = if g.faces.is_empty() { 3 } else { 2 };
            g.vertices = if g.dim == 2 {
                triangles.iter().flat_map(|n| n.iter().copied()).collect()
            } else {
                g.tets
                    .iter()
                    .flat_map(|&t| cells[tet_cells[t]].1.iter().copied())
                    .collect()
            };
        } else {
            let Some(members) = ones(point_data, name) else {
                continue;
            };
            g.vertices = members;
        }
        g.vertices.sort_unstable();
        g.vertices.dedup();
        groups.push(g);
    }
    groups
}
