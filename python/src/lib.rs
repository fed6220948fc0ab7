//! The Python module `tetsim` (SPEC §12): scenes, simulations, meshes and materials over the lean
//! tetsim library, with numpy arrays in and out.
//!
//! Every entry point checks its arguments the way the scene file checks the same values, and every
//! error is a `tetsim.Error` (a `ValueError` and a `TypeError`) carrying the command line's
//! message, the file, the line and the key: wrong types, missing arguments and unknown keywords
//! too, named by the argument (`args`), never Python's bare `TypeError`. The GIL is released while the library steps, and a run checks for Ctrl-C
//! between frames.

mod args;
mod arrays;
mod errors;
mod material;
mod mesh;
mod scene;
mod simulation;

use pyo3::prelude::*;

/// tetsim: large elastic deformation on tetrahedral meshes.
///
/// Scene.load(path) or Scene.from_dict(d) describe a run, Simulation(scene) steps it (step(),
/// run(out_dir)), read_mesh/write_mesh read and write tet meshes, Material evaluates a
/// constitutive model on deformation gradients. Arrays are numpy float64 / int64, C-contiguous;
/// errors are tetsim.Error.
#[pymodule]
#[pyo3(name = "tetsim")]
fn tetsim_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("Error", errors::error_type(py)?)?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<simulation::Simulation>()?;
    m.add_class::<mesh::Mesh>()?;
    m.add_class::<material::Material>()?;
    m.add_function(wrap_pyfunction!(mesh::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::tetrahedralize, m)?)?;
    m.add(
        "STEPS_COLUMNS",
        tetsim::output::STEPS_HEADER.split(',').collect::<Vec<_>>(),
    )?;
    m.add(
        "CONTACT_COLUMNS",
        tetsim::output::CONTACT_COLUMNS
            .split(',')
            .collect::<Vec<_>>(),
    )?;
    m.add(
        "RECOVERY_COLUMNS",
        tetsim::output::RECOVERY_COLUMNS
            .split(',')
            .collect::<Vec<_>>(),
    )?;
    Ok(())
}
