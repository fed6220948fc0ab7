"""The command line and Python give the same bits: every output file of `tetsim run
--deterministic --no-pictures` equals what Simulation.run writes, and the positions step()
reaches are the frames' points, bit for bit."""

import json

import numpy as np
import pytest

import tetsim

from conftest import run_cli, scene_copy


def output_files(folder):
    """name -> bytes of every output file (timings.csv holds wall-clock times: left out)."""
    return {
        p.name: p.read_bytes()
        for p in sorted(folder.iterdir())
        if p.is_file() and p.name != "timings.csv"
    }


@pytest.mark.parametrize(
    "name, frames",
    [
        ("gmsh_beam.toml", 6),  # a Gmsh file with physical groups, renumbered inside
        ("cantilever.toml", 6),  # the box generator, a ramped traction
        ("jelly_drop.toml", 3),  # contact with an obstacle: the contact columns and files
    ],
)
def test_run_writes_the_same_bytes_as_the_command_line(tmp_path, tetsim_bin, name, frames):
    scene = scene_copy(tmp_path, name, frames)
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    code, _, err = run_cli(
        tetsim_bin, "-q", "run", scene, "--out", cli_out, "--deterministic", "--no-pictures"
    )
    assert code == 0, err
    sim = tetsim.Simulation(tetsim.Scene.load(scene))
    rows = sim.run(py_out, deterministic=True)
    assert len(rows) == frames and sim.is_finished
    cli, py = output_files(cli_out), output_files(py_out)
    # Both write a checkpoint for `tetsim run --resume`; a checkpoint names its
    # own run folder.
    cli.pop("checkpoint.bin")
    py.pop("checkpoint.bin")
    # The manifests name their own folders.
    for files, folder in ((cli, cli_out), (py, py_out)):
        manifest = json.loads(files["manifest.json"])
        manifest.pop("output_dir", None)
        files["manifest.json"] = json.dumps(manifest, sort_keys=True).encode()
    assert sorted(cli) == sorted(py)
    assert "manifest.json" in py and "steps.csv" in py and f"frame_{frames:04d}.vtu" in py
    for file in cli:
        assert cli[file] == py[file], f"{file} differs"


def test_step_reaches_the_command_line_s_positions_bit_for_bit(tmp_path, tetsim_bin):
    frames = 5
    scene = scene_copy(tmp_path, "gmsh_beam.toml", frames)
    out = tmp_path / "cli"
    code, _, err = run_cli(tetsim_bin, "-q", "run", scene, "--out", out, "--no-pictures")
    assert code == 0, err
    sim = tetsim.Simulation(tetsim.Scene.load(scene))
    csv = (out / "steps.csv").read_text().splitlines()
    header = csv[0].split(",")
    assert header == tetsim.STEPS_COLUMNS + tetsim.RECOVERY_COLUMNS
    for frame in range(1, frames + 1):
        stats = sim.step()
        assert stats["frame"] == frame == sim.frame
        cli = tetsim.read_mesh(out / f"frame_{frame:04d}.vtu").vertices
        assert sim.positions.tobytes() == cli.tobytes()
        row = dict(zip(header, csv[frame + 1].split(",")))  # after the header and frame 0
        # Every column but the wall-clock time, as the CSV writes it.
        assert int(row["newton_iterations"]) == stats["newton_iterations"]
        assert float(row["elastic_energy"]) == stats["elastic_energy"]
        assert float(row["min_J"]) == stats["min_J"]
        assert row["converged"] == str(stats["converged"]).lower()
    assert sim.is_finished
    np.testing.assert_array_equal(sim.tets, tetsim.read_mesh(out / "frame_0000.vtu").tets)
