"""Scenes from files and dicts, stepping, the state in and out, and steering a run between
steps."""

import math

import numpy as np
import pytest

import tetsim

from conftest import SCENES, scene_copy


def box_scene(cells=(6, 2, 2), **solver):
    """A clamped box (3×1×1 m, 6×2×2 cells by default) drooping under gravity."""
    return {
        "mesh": {"generator": {"box": {"min": [0, 0, 0], "max": [3, 1, 1], "cells": list(cells)}}},
        "material": {"model": "neo-hookean", "youngs_modulus": 1e6, "poisson_ratio": 0.3},
        "fixed": [{"region": {"physical": "xmin"}}],
        "solver": {"dt": 0.02, "frames": 10, **solver},
    }


def test_from_dict_equals_the_same_keys_in_a_file(tmp_path):
    from_file = tetsim.Simulation(tetsim.Scene.load(scene_copy(tmp_path, "cantilever.toml", 4)))
    values = tetsim.Scene.load(SCENES / "cantilever.toml").to_dict()
    values["solver"]["frames"] = 4
    from_dict = tetsim.Simulation(tetsim.Scene.from_dict(values))
    while not from_file.is_finished:
        a, b = from_file.step(), from_dict.step()
        assert a["elastic_energy"] == b["elastic_energy"]
    assert from_dict.is_finished
    assert from_file.positions.tobytes() == from_dict.positions.tobytes()


def test_from_dict_takes_numpy_values_paths_and_tuples(tmp_path):
    values = box_scene()
    values["gravity"] = np.array([0.0, -9.81, 0.0])
    values["material"]["density"] = np.float64(1100.0)
    values["solver"]["frames"] = np.int64(3)
    values["mesh"] = {"file": SCENES / "meshes" / "beam.msh"}
    values["fixed"] = [{"region": {"physical": "clamp"}, "components": ("x", "y", "z")}]
    scene = tetsim.Scene.from_dict(values)
    assert scene.frames == 3 and scene.path == "<dict>"
    assert scene.to_dict()["material"]["density"] == 1100.0
    assert "frames = 3" in scene.source
    assert tetsim.Scene.default().frames > 0


def test_step_returns_the_steps_csv_columns():
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    assert (sim.frame, sim.time, sim.frames, sim.is_finished) == (0, 0.0, 10, False)
    stats = sim.step()
    assert list(stats) == tetsim.STEPS_COLUMNS + tetsim.RECOVERY_COLUMNS
    assert stats["frame"] == 1 and stats["converged"] is True
    assert isinstance(stats["newton_iterations"], int) and isinstance(stats["residual"], float)
    assert sim.frame == 1 and sim.time == pytest.approx(0.02)
    n, m = len(sim.rest_positions), len(sim.tets)
    for array, shape, dtype in [
        (sim.positions, (n, 3), np.float64),
        (sim.velocities, (n, 3), np.float64),
        (sim.rest_positions, (n, 3), np.float64),
        (sim.tets, (m, 4), np.int64),
    ]:
        assert array.shape == shape and array.dtype == dtype and array.flags.c_contiguous
    assert sim.positions[:, 1].min() < 0  # drooping
    assert "Simulation(" in repr(sim) and "Scene(" in repr(sim.scene)


def test_contact_adds_its_columns(tmp_path):
    sim = tetsim.Simulation(tetsim.Scene.load(scene_copy(tmp_path, "jelly_drop.toml", 1)))
    stats = sim.step()
    assert list(stats) == tetsim.STEPS_COLUMNS + tetsim.CONTACT_COLUMNS + tetsim.RECOVERY_COLUMNS
    assert stats["min_distance"] is None or stats["min_distance"] > 0


def test_positions_and_velocities_can_be_set_between_steps():
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    sim.step()
    x = sim.positions
    x[:, 1] += 0.01
    sim.positions = x
    assert sim.positions.tobytes() == x.tobytes()
    clamp = sim.fixed_vertices(0)
    v = np.ones_like(x)
    sim.velocities = v
    got = sim.velocities
    assert (got[clamp] == 0).all()
    free = np.setdiff1d(np.arange(len(x)), clamp)
    assert (got[free] == 1).all()
    assert sim.step()["converged"]


def test_a_control_loop_moves_the_clamp():
    # Drag the clamped end up 1 cm per frame: a controller setting targets each step.
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(frames=4)))
    clamp = sim.fixed_vertices(0)
    rest = sim.rest_positions[clamp]
    while not sim.is_finished:
        targets = rest + [0.0, 0.01 * (sim.frame + 1), 0.0]
        sim.set_fixed_targets(0, targets)
        sim.step()
        np.testing.assert_array_equal(sim.positions[clamp], targets)
    # A rigid motion instead: a quarter turn about x through the face's centre, at once.
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(frames=2)))
    sim.set_fixed_motion(0, rotate_degrees=90, axis=(1, 0, 0), center=(0, 0.5, 0.5), duration=0.0)
    sim.step()
    turned = sim.positions[clamp]
    c = np.array([0, 0.5, 0.5])
    expected = c + (rest - c) @ np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]])
    np.testing.assert_allclose(turned, expected, atol=1e-12)
    assert sim.fixed_count == 1


def test_quasistatic_runs_and_refuses_velocities():
    values = box_scene(integrator="quasistatic", frames=3)
    sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
    sim.velocities = np.zeros((len(sim.positions), 3))
    with pytest.raises(tetsim.Error, match="quasistatic") as e:
        sim.velocities = np.ones((len(sim.positions), 3))
    assert e.value.key == "velocities"
    sim.step()
    assert sim.time == pytest.approx(1 / 3)


def test_run_continues_from_the_current_frame(tmp_path):
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(frames=3)))
    sim.step()
    rows = sim.run(tmp_path / "out")
    assert [r["frame"] for r in rows] == [2, 3]
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    frames = [n for n in names if n.startswith("frame_")]
    assert frames == ["frame_0001.vtu", "frame_0002.vtu", "frame_0003.vtu"]
    assert {"frames.pvd", "steps.csv", "timings.csv", "manifest.json", "checkpoint.bin"} <= set(names)
    assert not any(n.endswith(".png") or n.endswith(".gif") for n in names)
    assert sim.run(tmp_path / "again") == []
    assert math.isfinite(sim.time)


def test_the_example_script_runs(tmp_path):
    import runpy
    import sys

    from conftest import ROOT

    script = ROOT / "python" / "examples" / "plot_cantilever.py"
    argv = sys.argv
    sys.argv = [str(script), "--frames", "3", "--out", str(tmp_path)]
    try:
        runpy.run_path(str(script), run_name="__main__")
    finally:
        sys.argv = argv
    assert (tmp_path / "E2e+06" / "manifest.json").exists()


def test_the_readme_example_runs(tmp_path, monkeypatch):
    import re

    from conftest import ROOT

    readme = (ROOT / "README.md").read_text()
    code = re.search(r"```python\n(import tetsim.*?)```", readme, re.S).group(1)
    assert code.count("\n") <= 14
    monkeypatch.chdir(ROOT)  # the example's paths are relative to the repository
    code = code.replace('"out/py"', repr(str(tmp_path / "py")))  # never write into the repository
    namespace = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["dPdF"].shape == (5, 9, 9) and namespace["sim"].is_finished
    assert (tmp_path / "py" / "manifest.json").exists()


def test_time_schemes_are_chosen_in_the_scene():
    """Each scheme from a dict: undamped, Newmark keeps the mechanical energy of a drooping
    beam (kinetic + elastic + gravitational, summed here from each step's own columns) up to the
    trapezoid's error on a nonlinear motion (1.5e-5 of it over 40 frames); BDF2 loses 25 times
    more and backward Euler 80 times more again; bad Newmark parameters are refused at their
    key."""
    totals = {}
    for scheme in ["backward-euler", "bdf2", "newmark"]:
        values = box_scene(integrator=scheme, frames=40, dt=0.01, newton_tolerance=1e-10)
        sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
        assert sim.scene.to_dict()["solver"]["integrator"] == scheme
        energy = []
        while not sim.is_finished:
            s = sim.step()
            energy.append(s["kinetic_energy"] + s["elastic_energy"] + s["gravitational_energy"])
        totals[scheme] = (energy[0], energy[-1])
    start = totals["newmark"][0]
    lost = {k: (a - b) / abs(start) for k, (a, b) in totals.items()}
    assert abs(lost["newmark"]) < 1e-4, lost
    assert lost["backward-euler"] > lost["bdf2"] > 10 * abs(lost["newmark"]), lost
    with pytest.raises(tetsim.Error, match="between 0.5 and 1") as e:
        tetsim.Scene.from_dict(box_scene(integrator="newmark", newmark_gamma=0.3))
    assert e.value.key == "solver.newmark_gamma"
    with pytest.raises(tetsim.Error, match="only to integrator") as e:
        tetsim.Scene.from_dict(box_scene(newmark_beta=0.3))


def test_a_python_run_is_resumed_by_the_command_line(tmp_path, tetsim_bin):
    """run() writes the command line's checkpoint: `tetsim run --resume` takes the run on to
    frame 5 with the bytes of a command-line run of the same scene."""
    from conftest import run_cli

    values = box_scene(frames=3)
    sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
    sim.step()
    sim.run(tmp_path / "py", deterministic=True)
    assert (tmp_path / "py" / "checkpoint.bin").exists()
    code, _, err = run_cli(tetsim_bin, "run", "--resume", str(tmp_path / "py"), "--frames", "5", "-q")
    assert code == 0, err
    scene = tmp_path / "box.toml"
    scene.write_text(tetsim.Scene.from_dict(values).source)
    code, _, err = run_cli(
        tetsim_bin, "run", str(scene), "--out", str(tmp_path / "cli"), "--frames", "5",
        "--deterministic", "--no-pictures", "-q",
    )
    assert code == 0, err
    for name in ["frame_0004.vtu", "frame_0005.vtu"]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name


def test_quadratic_tets_give_ten_nodes_per_tet(tmp_path):
    """`order = 2` from a dict: tets of width 10 whose last six nodes sit at their edges'
    midpoints at rest; this thick beam sags as far as with linear tets (within 5 %), every free
    node moves, and each mid-edge node stays near its edge (the elements bend, not tear)."""
    values = box_scene()
    values["mesh"]["order"] = 2
    sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
    tets, rest = sim.tets, sim.rest_positions
    assert tets.shape == (6 * 6 * 2 * 2, 10)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    for k, (i, j) in enumerate(edges):
        middle = 0.5 * (rest[tets[:, i]] + rest[tets[:, j]])
        assert np.abs(rest[tets[:, 4 + k]] - middle).max() < 1e-12
    linear = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    sim.run(tmp_path / "quadratic")
    linear.run(tmp_path / "linear")
    sag = rest[:, 1].max() - sim.positions[:, 1].min()
    sag_linear = linear.rest_positions[:, 1].max() - linear.positions[:, 1].min()
    assert abs(sag / sag_linear - 1) < 0.05, (sag, sag_linear)
    x = sim.positions
    assert np.all(np.linalg.norm(x - rest, axis=1)[rest[:, 0] > 0.1] > 0)
    for k, (i, j) in enumerate(edges):
        chord = np.linalg.norm(x[tets[:, i]] - x[tets[:, j]], axis=1)
        off = np.linalg.norm(x[tets[:, 4 + k]] - 0.5 * (x[tets[:, i]] + x[tets[:, j]]), axis=1)
        assert np.all(off < 0.1 * chord)
