"""Every error path: each raises tetsim.Error (a ValueError) with the command line's message,
and the file, line and key it is about."""

import numpy as np
import pytest

import tetsim

from conftest import FIXTURES, SCENES, run_cli
from test_simulation import box_scene


def raises(key=None, match=None, **attrs):
    """pytest.raises(tetsim.Error) that then checks the key and other attributes."""

    class Check:
        def __enter__(self):
            self.ctx = pytest.raises(tetsim.Error, match=match)
            self.info = self.ctx.__enter__()
            return self.info

        def __exit__(self, *exc):
            handled = self.ctx.__exit__(*exc)
            e = self.info.value
            assert isinstance(e, ValueError)
            assert e.message == str(e)
            assert e.key == key, (e.key, str(e))
            for name, value in attrs.items():
                assert getattr(e, name) == value, (name, getattr(e, name), str(e))
            return handled

    return Check()


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


GOOD = '[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n'


# --- scene files: the same message as the command line --------------------------------------


def test_misspelt_key_names_it_like_the_command_line(tmp_path, tetsim_bin):
    path = write(tmp_path, GOOD + "[solver]\ndt = 0.1\nframez = 3\n")
    with raises(key="solver.framez", line=5, column=1, file=str(path)) as e:
        tetsim.Scene.load(path)
    assert "unknown field `framez`" in str(e.value)
    code, _, err = run_cli(tetsim_bin, "run", path, "--out", tmp_path / "out")
    assert code != 0
    assert err.splitlines()[0] == f"error: {e.value}"


def test_bad_value_names_file_line_and_key(tmp_path):
    path = write(tmp_path, GOOD + "[solver]\nnewton_tolerance = 0\n")
    with raises(key="solver.newton_tolerance", line=4, file=str(path), match="must be positive"):
        tetsim.Scene.load(path)


def test_toml_syntax_error_has_a_line_and_no_key(tmp_path):
    path = write(tmp_path, "[solver]\ndt = = 1\n")
    with raises(key=None, line=2, file=str(path)):
        tetsim.Scene.load(path)


def test_missing_scene_file(tmp_path):
    path = tmp_path / "nope.toml"
    with raises(file=str(path), line=None, match="No such file"):
        tetsim.Scene.load(path)


def test_missing_mesh_file_is_reported_at_its_key(tmp_path):
    path = write(tmp_path, '[mesh]\nfile = "missing.msh"\n')
    scene = tetsim.Scene.load(path)
    with raises(key="mesh.file", line=2, match="missing.msh"):
        tetsim.Simulation(scene)


def test_malformed_mesh_names_its_file_and_line(tmp_path):
    bad = FIXTURES / "bad" / "truncated_v41.msh"
    path = write(tmp_path, f'[mesh]\nfile = "{bad.as_posix()}"\n')
    with pytest.raises(tetsim.Error) as e:
        tetsim.Simulation(tetsim.Scene.load(path))
    assert e.value.file == str(bad) and e.value.line is not None


# --- Scene.from_dict --------------------------------------------------------------------------


def test_from_dict_unknown_key_names_it_without_a_location():
    values = box_scene()
    values["solver"]["frobnicate"] = 3
    with raises(key="solver.frobnicate", file=None, line=None, match="^solver.frobnicate: unknown"):
        tetsim.Scene.from_dict(values)


def test_from_dict_bad_values():
    values = box_scene()
    values["material"]["poisson_ratio"] = 0.5
    with raises(key="material.poisson_ratio", match="Poisson ratio"):
        tetsim.Scene.from_dict(values)
    values = box_scene()
    values["fixed"][0]["duration"] = -1.0
    with raises(key="[[fixed]] #1 duration"):
        tetsim.Scene.from_dict(values)
    values = box_scene()
    values["solver"]["dt"] = "fast"
    with raises(key="solver.dt", match="not a number with a unit"):
        tetsim.Scene.from_dict(values)


@pytest.mark.parametrize(
    "value, key, match",
    [
        (None, "solver.dt", "None is not a scene value"),
        (object(), "solver.dt", "object is not a scene value"),
        (2**70, "solver.dt", "too large"),
    ],
)
def test_from_dict_refuses_values_toml_has_not(value, key, match):
    values = box_scene()
    values["solver"]["dt"] = value
    with raises(key=key, match=match):
        tetsim.Scene.from_dict(values)


def test_from_dict_keys_must_be_strings():
    with raises(key="scene", match="keys must be strings"):
        tetsim.Scene.from_dict({1: 2})


def test_region_that_selects_nothing():
    values = box_scene()
    values["fixed"][0]["region"] = {"box": {"min": [9, 9, 9], "max": [10, 10, 10]}}
    with raises(key="[[fixed]] #1 region", match="selects no vertices"):
        tetsim.Simulation(tetsim.Scene.from_dict(values))


# --- Simulation -------------------------------------------------------------------------------


def test_failed_frame_names_it():
    values = box_scene(newton_max_iterations=1, newton_tolerance=1e-12, on_failure="stop")
    sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
    x = sim.positions
    with raises(frame=1, match="^frame 1: "):
        sim.step()
    assert sim.frame == 0 and sim.positions.tobytes() == x.tobytes()


def test_stepping_past_the_end():
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(frames=1)))
    sim.step()
    with raises(key="solver.frames", match="the run is finished"):
        sim.step()


@pytest.mark.parametrize(
    "value, match",
    [
        ([[0.0, 0.0, 0.0]], "expected a numpy array of float64 with shape \\(\\d+, 3\\), got list"),
        (np.zeros((5, 3)), "expected shape \\(\\d+, 3\\), got \\(5, 3\\)"),
        ("N3", "expected shape"),
        ("int", "expected dtype float64, got int64"),
        ("f32", "expected dtype float64, got float32"),
        ("strided", "C-contiguous"),
        ("nan", "position 2 is not finite"),
    ],
)
def test_positions_setter_checks_shape_dtype_and_values(value, match):
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    n = len(sim.positions)
    if isinstance(value, str):
        value = {
            "N3": np.zeros((n, 2)),
            "int": np.zeros((n, 3), dtype=np.int64),
            "f32": np.zeros((n, 3), dtype=np.float32),
            "strided": np.zeros((n, 6))[:, ::2],
            "nan": np.where(np.arange(n)[:, None] == 2, np.nan, sim.positions),
        }[value]
    with raises(key="positions", match=match):
        sim.positions = value


def test_velocities_setter_checks():
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    n = len(sim.positions)
    with raises(key="velocities", match="expected shape"):
        sim.velocities = np.zeros((n + 1, 3))
    with raises(key="velocities", match="velocity 0 is not finite"):
        sim.velocities = np.full((n, 3), np.inf)


def test_positions_inside_an_obstacle_are_refused(tmp_path):
    from conftest import scene_copy

    sim = tetsim.Simulation(tetsim.Scene.load(scene_copy(tmp_path, "jelly_drop.toml", 2)))
    x = sim.positions
    x[:, 1] -= 100.0
    with raises(key="positions"):
        sim.positions = x


def test_fixed_moves_are_checked():
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene()))
    with raises(key="fixed", match="no fixed entry 1"):
        sim.fixed_vertices(1)
    with raises(key="fixed"):
        sim.set_fixed_motion(3, translate=(1, 0, 0))
    with raises(key="[[fixed]] #1 motion.translate", match="must be finite"):
        sim.set_fixed_motion(0, translate=(np.nan, 0, 0))
    with raises(key="[[fixed]] #1 motion.rotate_degrees"):
        sim.set_fixed_motion(0, rotate_degrees=np.inf)
    with raises(key="[[fixed]] #1 duration", match="zero or positive"):
        sim.set_fixed_motion(0, duration=-1.0)
    k = len(sim.fixed_vertices(0))
    with raises(key="targets", match="expected shape"):
        sim.set_fixed_targets(0, np.zeros((k - 1, 3)))
    with raises(key="[[fixed]] #1 targets", match="target 0 is not finite"):
        sim.set_fixed_targets(0, np.full((k, 3), np.nan))


# --- meshes ------------------------------------------------------------------------------------


def test_read_mesh_errors(tmp_path):
    with raises(file=str(tmp_path / "none.msh"), match="No such file"):
        tetsim.read_mesh(tmp_path / "none.msh")
    with raises(match="unknown mesh format `.xyz`"):
        tetsim.read_mesh(write(tmp_path, "1 2 3\n", "points.xyz"))
    with pytest.raises(tetsim.Error) as e:
        tetsim.read_mesh(FIXTURES / "bad" / "not_a_mesh.msh")
    assert e.value.file == str(FIXTURES / "bad" / "not_a_mesh.msh") and e.value.line is not None
    with pytest.raises(tetsim.Error, match="degenerate"):
        tetsim.read_mesh(FIXTURES / "bad" / "degenerate.ele")
    assert len(tetsim.read_mesh(FIXTURES / "bad" / "degenerate.ele", force=True).tets) > 0
    with pytest.raises(tetsim.Error, match="no tetrahedra"):
        tetsim.read_mesh(FIXTURES / "bad" / "triangles_only_v22.msh")


def test_write_mesh_errors(tmp_path):
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    t = np.array([[0, 1, 2, 3]])
    out = tmp_path / "t.msh"
    with raises(key="tets", match="tet 0 refers to vertex 4"):
        tetsim.write_mesh(out, v, np.array([[0, 1, 2, 4]]))
    with raises(key="tets", match="refers to vertex -1"):
        tetsim.write_mesh(out, v, np.array([[0, 1, 2, -1]]))
    with raises(key="tets", match="expected dtype int64, got int32"):
        tetsim.write_mesh(out, v, t.astype(np.int32))
    with raises(key="tets", match="no tetrahedra"):
        tetsim.write_mesh(out, v, np.zeros((0, 4), dtype=np.int64))
    with raises(key="vertices", match="vertex 1 is not finite"):
        tetsim.write_mesh(out, np.where(np.arange(4)[:, None] == 1, np.inf, v), t)
    with raises(key='groups["a"]', match="vertex 9 does not exist"):
        tetsim.write_mesh(out, v, t, {"a": np.array([0, 9])})
    with raises(key="groups", match="names must be strings"):
        tetsim.write_mesh(out, v, t, {1: np.array([0])})
    with raises(match="unknown mesh format"):
        tetsim.write_mesh(tmp_path / "t.xyz", v, t)
    assert not out.exists()


# --- materials ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, key, match",
    [
        ({"model": "neo-hookian"}, "model", 'unknown material model "neo-hookian"'),
        ({"poisson_ratio": 0.5}, "poisson_ratio", "Poisson ratio must lie in"),
        ({"youngs_modulus": -1.0}, "youngs_modulus", "must be positive"),
        ({"mu": 1.0}, "mu", "give lambda too"),
        ({"lam": 1.0}, "lam", "give mu too"),
        ({"mu": 1.0, "lam": 1.0, "youngs_modulus": 1.0}, "mu", "not both pairs"),
        ({"mu": 1.0, "lam": -10.0}, "lam", "3λ \\+ 2μ > 0"),
    ],
)
def test_material_checks_like_the_scene(kwargs, key, match):
    model = kwargs.pop("model", "neo-hookean")
    with raises(key=key, match=f"^{key}: .*{match}"):
        tetsim.Material(model, **kwargs)


def test_material_arguments():
    m = tetsim.Material("corotated")
    with raises(key="F", match="expected shape \\(k, 3, 3\\), got \\(3, 3\\)"):
        m.energy(np.eye(3))
    with raises(key="F", match="expected dtype float64"):
        m.stress(np.eye(3, dtype=np.float32)[None])
    with raises(key="F", match="got list"):
        m.tangent([[[1.0]]])
    with raises(key="definiteness", match="unknown definiteness strategy"):
        m.tangent(np.eye(3)[None], definiteness="psd")
