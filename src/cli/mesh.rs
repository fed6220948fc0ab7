//! `tetsim mesh check FILE`, `tetsim mesh convert IN OUT` and
//! `tetsim mesh tetrahedralize SURFACE OUT --size H`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Subcommand;
use tetsim::error::Error;
use tetsim::io::gmsh::{self, Version};
use tetsim::io::{self, MeshRead, ReadOptions};

/// Mesh subcommands.
#[derive(Debug, Subcommand)]
pub enum MeshCommand {
    /// Diagnose a mesh: what loading changed, counts, bounding box, volume, orientation,
    /// degenerate and sliver tets, quality histogram, pieces, duplicates, surface, a time step.
    /// Exits non-zero when tetsim would refuse the mesh.
    Check {
        /// The mesh (.msh, .node/.ele, .vtk, .vtu, .mesh).
        file: PathBuf,
        /// Exit zero even when the doctor finds errors (degenerate or duplicate tets, …).
        #[arg(long)]
        force: bool,
    },
    /// Convert a mesh to the format of OUTPUT's extension (.msh, .vtu, .vtk, .node, .mesh, .obj
    /// for the boundary surface), after the same checks as a run.
    Convert {
        /// The mesh to read.
        input: PathBuf,
        /// The file to write.
        output: PathBuf,
        /// Convert even when the doctor finds errors.
        #[arg(long)]
        force: bool,
        /// Write .msh and .vtk as binary (default: .msh ASCII 4.1, .vtk binary).
        #[arg(long, conflicts_with = "ascii")]
        binary: bool,
        /// Write .msh and .vtk as ASCII.
        #[arg(long)]
        ascii: bool,
        /// Write .msh in the older MSH 2.2 format (ASCII).
        #[arg(long)]
        msh22: bool,
    },
    /// Fill the solid a closed triangle surface (.obj, .stl, .ply) bounds with tets of bounded
    /// quality (isosurface stuffing on a BCC lattice), write it to OUTPUT (.msh, .vtu, .vtk,
    /// .node, .mesh) and print its quality: dihedral angles, volume against the surface's,
    /// Hausdorff distance of its boundary to the surface.
    Tetrahedralize {
        /// The surface to fill.
        input: PathBuf,
        /// The tet mesh to write.
        output: PathBuf,
        /// Lattice spacing: the tets' edge length inside (metres, or with a unit: "5 mm").
        #[arg(long, allow_hyphen_values = true)]
        size: String,
        /// Smallest accepted closure (0..1; 1 = closed surface, 0 = open sheet).
        #[arg(long, default_value_t = 0.8)]
        min_closure: f64,
    },
}

/// Run a mesh subcommand.
pub fn run(cmd: MeshCommand) -> anyhow::Result<()> {
    match cmd {
        MeshCommand::Check { file, force } => check(&file, force),
        MeshCommand::Tetrahedralize {
            input,
            output,
            size,
            min_closure,
        } => tetrahedralize(&input, &output, &size, min_closure),
        MeshCommand::Convert {
            input,
            output,
            force,
            binary,
            ascii,
            msh22,
        } => {
            let read = load(&input, force)?;
            for line in read.report.to_string().lines() {
                log::info!("{}: {line}", input.display());
            }
            let ext = output
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase);
            let written = match ext.as_deref() {
                Some("msh") if msh22 => gmsh::write(&output, &read.mesh, Version::V22, false),
                Some("msh") => gmsh::write(&output, &read.mesh, Version::V41, binary),
                Some("vtk") => io::vtk::write(&output, &read.mesh, !ascii),
                _ => io::write_mesh(&output, &read.mesh),
            };
            written.with_context(|| format!("cannot convert {}", input.display()))?;
            // Count the groups the written file gives back, not the ones we had: legacy VTK,
            // TetGen and OBJ hold no named groups, and a user converting must not believe they
            // came along.
            let had = read.mesh.groups.len();
            let kept = io::parse_mesh(&output).map_or(0, |(p, _)| {
                read.mesh
                    .groups
                    .iter()
                    .filter(|g| p.mesh.group(&g.name).is_some())
                    .count()
            });
            println!(
                "wrote {} ({} vertices, {} tets, {kept} of {had} groups)",
                output.display(),
                read.mesh.positions.len(),
                read.mesh.tets.len(),
            );
            if kept < had {
                let names: Vec<String> = read
                    .mesh
                    .groups
                    .iter()
                    .map(|g| tetsim::error::clip(&g.name))
                    .take(10)
                    .collect();
                eprintln!(
                    "warning: {} groups dropped ({}{}): this format keeps no named groups \
                     that tetsim reads back; write .msh to keep them",
                    had - kept,
                    names.join(", "),
                    if had > 10 { ", …" } else { "" }
                );
            }
            Ok(())
        }
    }
}

/// Read with the doctor's verdict enforced unless `force`.
fn load(path: &Path, force: bool) -> anyhow::Result<MeshRead> {
    let read = io::read_mesh_with(path, ReadOptions { force })?;
    Ok(read)
}

fn check(path: &Path, force: bool) -> anyhow::Result<()> {
    // Read forced, so that the report is printed in full even for a mesh that is refused.
    let read = io::read_mesh_with(path, ReadOptions { force: true })?;
    println!("{}", path.display());
    print!("{}", read.report);
    for g in &read.mesh.groups {
        println!(
            "group {:?} (dimension {}, tag {}): {} vertices, {} faces, {} tets",
            g.name,
            g.dim,
            g.tag,
            g.vertices.len(),
            g.faces.len(),
            g.tets.len()
        );
    }
    print!("{}", read.diagnosis);
    if let Some(problem) = read.diagnosis.refusal()
        && !force
    {
        let err = Error::Mesh {
            path: Some(path.to_path_buf()),
            problem,
        };
        bail!("{err} (use --force to accept it)");
    }
    Ok(())
}

/// `tetsim mesh tetrahedralize`: mesh, write, and print what a user judges the mesh by.
fn tetrahedralize(input: &Path, output: &Path, size: &str, min_closure: f64) -> anyhow::Result<()> {
    use tetsim::mesh::stuff::{self, StuffParams, measure};
    let start = std::time::Instant::now();
    use tetsim::scene::units::{Kind, parse_quantity};
    // A plain number is metres, as in a scene; otherwise a length with its unit.
    let h = match size.trim().parse::<f64>() {
        Ok(v) => v,
        Err(_) => parse_quantity(size, Kind::Length).map_err(|m| Error::parameter("--size", m))?,
    };
    // The output format is checked before the work, so a typo costs nothing.
    io::Format::from_path(output)?;
    let surface = io::read_surface(input)?;
    let params = StuffParams {
        size: h,
        min_closure,
        ..Default::default()
    };
    let (mesh, info) = stuff::tetrahedralize(&surface, &params)
        .map_err(|e| e.into_error(Some(input), "--size"))?;
    let meshed = start.elapsed().as_secs_f64();
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("msh") => gmsh::write(output, &mesh, Version::V41, false)?,
        Some("vtk") => io::vtk::write(output, &mesh, true)?,
        Some("obj") => bail!(
            "{}: an OBJ holds a surface, not tets; write .msh, .vtu, .vtk, .node or .mesh",
            output.display()
        ),
        _ => io::write_mesh(output, &mesh)?,
    }
    let q = measure::assess(&mesh, &surface);
    println!(
        "surface: {} vertices, {} triangles, closure {:.3}{}",
        surface.positions.len(),
        surface.faces.len(),
        info.closure,
        if info.flipped {
            " (faced inward: read reversed)"
        } else {
            ""
        }
    );
    println!(
        "wrote {}: {} tets, {} vertices (lattice {} points, {} warped onto the surface)",
        output.display(),
        mesh.tets.len(),
        mesh.positions.len(),
        info.lattice_vertices,
        info.warped
    );
    println!(
        "dihedral angles: {:.2}° .. {:.2}°, {} inverted tets",
        q.min_dihedral, q.max_dihedral, q.inverted
    );
    println!(
        "volume: {:.6e} vs the surface's {:.6e} ({:+.3} %)",
        q.volume,
        q.surface_volume,
        100.0 * (q.volume - q.surface_volume) / q.surface_volume.max(f64::MIN_POSITIVE)
    );
    println!(
        "Hausdorff distance: {:.4e} (boundary → surface {:.4e}, surface → boundary {:.4e}) = {:.3} h",
        q.hausdorff(),
        q.boundary_to_surface,
        q.surface_to_boundary,
        q.hausdorff() / h
    );
    println!(
        "time: {:.2} s meshing, {:.2} s in all",
        meshed,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
