"""read_mesh and write_mesh: real files from Gmsh and TetGen, groups, round trips."""

import numpy as np
import pytest

import tetsim

from conftest import FIXTURES, SCENES


def test_read_gmsh_with_physical_groups():
    mesh = tetsim.read_mesh(SCENES / "meshes" / "beam.msh")
    assert mesh.vertices.shape[1] == 3 and mesh.vertices.dtype == np.float64
    assert mesh.tets.shape[1] == 4 and mesh.tets.dtype == np.int64
    assert set(mesh.groups) == {"clamp", "tip", "body"}
    assert mesh.groups["clamp"].dtype == np.int64
    # The clamp face is the x = 0 end of the beam; the body group holds every tet.
    assert np.allclose(mesh.vertices[mesh.groups["clamp"], 0], mesh.vertices[:, 0].min())
    assert len(mesh.tet_groups["body"]) == len(mesh.tets)
    assert mesh.format.startswith("Gmsh")
    assert "Mesh(" in repr(mesh)


@pytest.mark.parametrize(
    "name", ["beam_v22.msh", "beam_v41.msh", "beam_v41_binary.msh", "ball.node", "torus.vtk", "torus.vtu"]
)
def test_every_fixture_reads(name):
    mesh = tetsim.read_mesh(FIXTURES / name)
    assert len(mesh.tets) > 0 and mesh.tets.max() < len(mesh.vertices)


@pytest.mark.parametrize("ext", ["msh", "vtu", "vtk", "node", "mesh"])
def test_write_then_read_round_trips(tmp_path, ext):
    mesh = tetsim.read_mesh(SCENES / "meshes" / "beam.msh")
    out = tmp_path / f"beam.{ext}"
    tetsim.write_mesh(out, mesh.vertices, mesh.tets, {"clamp": mesh.groups["clamp"]})
    back = tetsim.read_mesh(out)
    assert back.vertices.tobytes() == mesh.vertices.tobytes()
    np.testing.assert_array_equal(back.tets, mesh.tets)
    if ext == "msh":
        np.testing.assert_array_equal(back.groups["clamp"], mesh.groups["clamp"])


def test_a_written_mesh_simulates(tmp_path):
    mesh = tetsim.read_mesh(SCENES / "meshes" / "beam.msh")
    path = tmp_path / "beam.msh"
    tetsim.write_mesh(path, mesh.vertices, mesh.tets, {"clamp": mesh.groups["clamp"]})
    scene = tetsim.Scene.from_dict(
        {"mesh": {"file": path}, "fixed": [{"region": {"physical": "clamp"}}], "solver": {"frames": 1}}
    )
    sim = tetsim.Simulation(scene)
    assert sim.step()["converged"]
    np.testing.assert_array_equal(sim.rest_positions, mesh.vertices)
