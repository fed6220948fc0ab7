"""Every error path: each raises tetsim.Error (a ValueError and a TypeError) with the command
line's message, and the file, line and key it is about; every bad argument of every entry point
names the argument."""

import subprocess
import sys
import textwrap

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
            assert isinstance(e, ValueError) and isinstance(e, TypeError)
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
    with raises(key="path", file=str(path), line=None, match="No such file"):
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
    with raises(key="index", match="^index: there is no \\[\\[fixed\\]\\] entry 1 "):
        sim.fixed_vertices(1)
    with raises(key="index"):
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
    with raises(key="path", file=str(tmp_path / "none.msh"), match="No such file"):
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


# --- every argument of every entry point ---------------------------------------------------------
#
# Each case: a call on a small steerable simulation `s` (3 × 1 × 1 cells, one [[fixed]] entry),
# the argument it gets wrong, and what the message says. Every one must raise tetsim.Error (not a
# bare TypeError, OverflowError or ValueError) whose message and key name the argument.


def cyclic_dict():
    values = box_scene()
    values["solver"]["self"] = values
    return values


def cyclic_list():
    values = box_scene()
    gravity = [0.0, -9.81]
    gravity.append(gravity)
    values["gravity"] = gravity
    return values


def nested(depth):
    value = 1.0
    for _ in range(depth):
        value = [value]
    return dict(box_scene(), gravity=value)


class ReturnsItself:
    """An object whose tolist() (the numpy protocol from_dict follows) returns itself."""

    def tolist(self):
        return self


def n(s):
    return len(s.positions)


def k(s):
    return len(s.fixed_vertices(0))


BOX = box_scene(cells=(3, 1, 1))
ANY_F = np.eye(3)[None]
TET = (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), np.array([[0, 1, 2, 3]]))

CASES = [
    # Scene.load / Scene.from_dict / Scene.default / Scene.to_dict
    ("load-none", lambda s: tetsim.Scene.load(None), "path", "needs path"),
    ("load-int", lambda s: tetsim.Scene.load(3), "path", "expected a path .* got int 3"),
    ("load-surrogate", lambda s: tetsim.Scene.load("\ud800.toml"), "path", "usable file name"),
    ("load-keyword", lambda s: tetsim.Scene.load("a.toml", pth=1), "pth", "did you mean path"),
    ("dict-cycle", lambda s: tetsim.Scene.from_dict(cyclic_dict()), "solver.self", "contains itself"),
    ("list-cycle", lambda s: tetsim.Scene.from_dict(cyclic_list()), "gravity[2]", "contains itself"),
    ("tolist-self", lambda s: tetsim.Scene.from_dict(dict(BOX, gravity=ReturnsItself())),
     "gravity", "contains itself"),
    ("deep-nesting", lambda s: tetsim.Scene.from_dict(nested(100_000)), "gravity", "32 levels"),
    ("dict-not-dict", lambda s: tetsim.Scene.from_dict([("solver", {})]), "values",
     "expected a dict of scene keys, .* got list"),
    ("dict-none", lambda s: tetsim.Scene.from_dict(None), "values", "needs values"),
    ("dict-base-dir", lambda s: tetsim.Scene.from_dict(BOX, base_dir=1.5), "base_dir",
     "expected a path"),
    ("dict-surrogate", lambda s: tetsim.Scene.from_dict(dict(BOX, output={"dir": "\ud800"})),
     "output.dir", "lone surrogate"),
    ("dict-bytes", lambda s: tetsim.Scene.from_dict(dict(BOX, gravity=b"down")), "gravity",
     "bytes is not a scene value"),
    ("dict-set", lambda s: tetsim.Scene.from_dict(dict(BOX, gravity={1.0})), "gravity",
     "set is not a scene value"),
    ("dict-nan", lambda s: tetsim.Scene.from_dict(dict(BOX, gravity=[0, np.nan, 0])),
     "gravity", "must be finite"),
    ("dict-huge", lambda s: tetsim.Scene.from_dict(dict(BOX, gravity=np.array([0, 1e300, 0]))),
     "gravity", "beyond any physical value"),
    ("dict-bad-unit", lambda s: tetsim.Scene.from_dict(
        dict(BOX, material={"youngs_modulus": "1 Mpa"})), "material.youngs_modulus",
     "unknown unit"),
    ("default-args", lambda s: tetsim.Scene.default(1), "Scene.default", "no positional"),
    ("to-dict-keyword", lambda s: s.scene.to_dict(flat=True), "flat", "no argument flat"),
    # Simulation, step, run
    ("sim-none", lambda s: tetsim.Simulation(None), "scene", "needs scene"),
    ("sim-dict", lambda s: tetsim.Simulation(BOX), "scene", "expected a tetsim.Scene .* got dict"),
    ("sim-extra", lambda s: tetsim.Simulation(s.scene, 2), "Simulation",
     "takes 1 positional argument \\(scene\\), got 2"),
    ("sim-keyword", lambda s: tetsim.Simulation(scene=s.scene, frames=3), "frames",
     "no argument frames"),
    ("step-arg", lambda s: s.step(2), "Simulation.step", "no positional"),
    ("run-out-dir", lambda s: s.run(out_dir=7), "out_dir", "expected a path"),
    ("run-deterministic", lambda s: s.run(deterministic="yes"), "deterministic",
     "expected True or False, got str 'yes'"),
    ("run-keyword", lambda s: s.run(outdir="x"), "outdir", "did you mean out_dir"),
    # positions, velocities
    ("positions-list", lambda s: setattr(s, "positions", [[0.0] * 3] * n(s)), "positions",
     "expected a numpy array"),
    ("positions-nan", lambda s: setattr(s, "positions", np.full((n(s), 3), np.nan)), "positions",
     "position 0 is not finite"),
    ("positions-huge", lambda s: setattr(s, "positions", np.full((n(s), 3), 1e10)), "positions",
     "at most 1e9 \\(m\\)"),
    ("velocities-huge", lambda s: setattr(s, "velocities", np.full((n(s), 3), 1e300)),
     "velocities", "at most 1e8 \\(m/s\\)"),
    ("velocities-inf", lambda s: setattr(s, "velocities", np.full((n(s), 3), -np.inf)),
     "velocities", "velocity 0 is not finite"),
    ("velocities-dtype", lambda s: setattr(s, "velocities", np.zeros((n(s), 3), np.float16)),
     "velocities", "expected dtype float64, got float16"),
    # fixed_vertices, set_fixed_motion, set_fixed_targets
    ("fixed-negative", lambda s: s.fixed_vertices(-1), "index", "no \\[\\[fixed\\]\\] entry -1"),
    ("fixed-huge", lambda s: s.fixed_vertices(2**70), "index", "no \\[\\[fixed\\]\\] entry 1180"),
    ("fixed-float", lambda s: s.fixed_vertices(0.0), "index", "expected an integer index"),
    ("fixed-bool", lambda s: s.fixed_vertices(True), "index", "got bool True"),
    ("fixed-missing", lambda s: s.fixed_vertices(), "index", "needs index"),
    ("fixed-keyword", lambda s: s.fixed_vertices(indx=0), "indx", "did you mean index"),
    ("motion-index", lambda s: s.set_fixed_motion(-1), "index", "entry -1"),
    ("motion-short", lambda s: s.set_fixed_motion(0, translate=(1, 0)), "translate",
     "expected 3 numbers .* got tuple of 2"),
    ("motion-str", lambda s: s.set_fixed_motion(0, translate="up"), "translate",
     "expected 3 numbers"),
    ("motion-2d", lambda s: s.set_fixed_motion(0, translate=np.zeros((3, 1))), "translate",
     "shape \\(3, 1\\)"),
    ("motion-no-unit", lambda s: s.set_fixed_motion(0, translate=("1", 0, 0)), "translate[0]",
     "has no unit"),
    ("motion-wrong-unit", lambda s: s.set_fixed_motion(0, translate=("5 s", 0, 0)),
     "translate[0]", "is a time, but this key takes a length"),
    ("motion-far", lambda s: s.set_fixed_motion(0, translate=(1e10, 0, 0)), "translate",
     "at most 1e9 \\(m\\)"),
    ("motion-nan", lambda s: s.set_fixed_motion(0, translate=(np.nan, 0, 0)), "translate",
     "must be finite"),
    ("motion-zero-axis", lambda s: s.set_fixed_motion(0, rotate_degrees=30, axis=(0, 0, 0)),
     "axis", "needs a non-zero axis"),
    ("motion-tiny-axis", lambda s: s.set_fixed_motion(0, rotate_degrees=30, axis=(1e-320, 0, 0)),
     "axis", "needs a non-zero axis"),
    ("motion-huge-axis", lambda s: s.set_fixed_motion(0, rotate_degrees=30, axis=(0, 1e300, 0)),
     "axis", "beyond any physical value"),
    ("motion-angle-type", lambda s: s.set_fixed_motion(0, rotate_degrees=[30]), "rotate_degrees",
     "expected a number in degrees"),
    ("motion-angle-huge", lambda s: s.set_fixed_motion(0, rotate_degrees=1e300),
     "rotate_degrees", "at most 1e9 \\(degrees\\)"),
    ("motion-center", lambda s: s.set_fixed_motion(0, center=(0, 0, 1e10)), "center",
     "at most 1e9"),
    ("motion-duration", lambda s: s.set_fixed_motion(0, duration=-1), "duration",
     "zero or positive"),
    ("motion-duration-huge", lambda s: s.set_fixed_motion(0, duration=1e300), "duration",
     "at most 1e12 \\(s\\)"),
    ("motion-duration-str", lambda s: s.set_fixed_motion(0, duration="2"), "duration",
     "has no unit"),
    ("motion-keyword", lambda s: s.set_fixed_motion(0, translation=(1, 0, 0)), "translation",
     "no argument translation"),
    ("motion-extra", lambda s: s.set_fixed_motion(0, None, 0, None, None, None, 1),
     "Simulation.set_fixed_motion", "takes 6 positional arguments"),
    ("targets-index", lambda s: s.set_fixed_targets(5, np.zeros((k(s), 3))), "index", "entry 5"),
    ("targets-missing", lambda s: s.set_fixed_targets(0), "targets", "needs targets"),
    ("targets-far", lambda s: s.set_fixed_targets(0, np.full((k(s), 3), 1e300)), "targets",
     "target 0: 1e300 is beyond"),
    # read_mesh, write_mesh
    ("read-int", lambda s: tetsim.read_mesh(3), "path", "expected a path"),
    ("read-force", lambda s: tetsim.read_mesh("beam.msh", force="yes"), "force",
     "expected True or False"),
    ("read-keyword", lambda s: tetsim.read_mesh("beam.msh", forse=True), "forse",
     "did you mean force"),
    ("write-none", lambda s: tetsim.write_mesh(None, *TET), "path", "needs path"),
    ("write-groups", lambda s: tetsim.write_mesh("t.msh", *TET, groups=[0]), "groups",
     "expected a dict"),
    ("write-vertices", lambda s: tetsim.write_mesh("t.msh", None, TET[1]), "vertices",
     "needs vertices"),
    ("write-keyword", lambda s: tetsim.write_mesh("t.msh", *TET, group={}), "group",
     "did you mean groups"),
    # Material and its evaluations
    ("material-unit", lambda s: tetsim.Material(youngs_modulus="1 MPascal"), "youngs_modulus",
     "unknown unit"),
    ("material-dimension", lambda s: tetsim.Material(youngs_modulus="1 m"), "youngs_modulus",
     "is a length, but this key takes a pressure"),
    ("material-list", lambda s: tetsim.Material(youngs_modulus=[1e6]), "youngs_modulus",
     "expected a number in Pa .* got list"),
    ("material-bool", lambda s: tetsim.Material(poisson_ratio=True), "poisson_ratio",
     "got bool True"),
    ("material-bigint", lambda s: tetsim.Material(mu=10**400, lam=1.0), "mu",
     "does not fit in a double"),
    ("material-nan", lambda s: tetsim.Material(youngs_modulus=np.nan), "youngs_modulus",
     "must be positive"),
    ("material-threshold", lambda s: tetsim.Material(inversion_threshold=-1),
     "inversion_threshold", "a stretch in"),
    ("material-model-type", lambda s: tetsim.Material(3), "model", "expected a model name"),
    ("material-positional", lambda s: tetsim.Material("linear", 1e6), "Material",
     "give youngs_modulus, .* by keyword"),
    ("material-keyword", lambda s: tetsim.Material(youngs=1e6), "youngs",
     "did you mean youngs_modulus"),
    ("energy-nan", lambda s: tetsim.Material().energy(np.full((2, 3, 3), np.nan)), "F",
     "F\\[0\\] is not finite"),
    ("stress-inf", lambda s: tetsim.Material().stress(np.stack([np.eye(3), np.full((3, 3), np.inf)])),
     "F", "F\\[1\\] is not finite"),
    ("tangent-nan", lambda s: tetsim.Material().tangent(np.full((1, 3, 3), np.nan)), "F",
     "not finite"),
    ("energy-overflow", lambda s: tetsim.Material().energy(ANY_F * 1e300), "F",
     "overflows double precision"),
    ("energy-missing", lambda s: tetsim.Material().energy(), "F", "needs F"),
    ("energy-extra", lambda s: tetsim.Material().energy(ANY_F, ANY_F), "Material.energy",
     "takes 1 positional argument \\(F\\), got 2"),
    ("tangent-definiteness", lambda s: tetsim.Material().tangent(ANY_F, definiteness=1),
     "definiteness", "expected one of"),
    ("tangent-keyword", lambda s: tetsim.Material().tangent(ANY_F, definitness="teran"),
     "definitness", "did you mean definiteness"),
]


@pytest.fixture(scope="module")
def steerable():
    return tetsim.Simulation(tetsim.Scene.from_dict(box_scene(cells=(3, 1, 1), frames=3)))


@pytest.mark.parametrize(
    "call, name, match", [pytest.param(*c[1:], id=c[0]) for c in CASES]
)
def test_every_bad_argument_raises_tetsim_error_naming_it(steerable, tmp_path, monkeypatch,
                                                          call, name, match):
    monkeypatch.chdir(tmp_path)  # what write_mesh or run might write lands here
    with pytest.raises(tetsim.Error, match=match) as e:
        call(steerable)
    assert name in str(e.value), str(e.value)
    assert e.value.key is not None and name.split("[")[0] in e.value.key, (e.value.key, str(e.value))
    assert e.value.message == str(e.value)
    assert not list(tmp_path.iterdir())


def test_what_every_case_refused_left_the_simulation_as_it_was(steerable):
    # Runs after the cases above (same module-scoped simulation): none of them changed it.
    assert steerable.frame == 0
    assert steerable.positions.tobytes() == steerable.rest_positions.tobytes()
    assert not steerable.velocities.any()
    stats = steerable.step()
    assert stats["converged"] and np.isfinite(steerable.positions).all()


def test_error_is_a_value_error_and_a_type_error():
    assert issubclass(tetsim.Error, ValueError) and issubclass(tetsim.Error, TypeError)
    assert tetsim.Error.__module__ == "tetsim"
    with pytest.raises(TypeError):
        tetsim.Material(youngs_modulus=[1.0])
    with pytest.raises(ValueError):
        tetsim.Material(youngs_modulus=-1.0)


def test_self_containing_values_do_not_crash_the_interpreter(tmp_path):
    # A separate interpreter, so that a regression shows as a failed test, not a dead run.
    code = textwrap.dedent(
        """
        import tetsim
        d = {"mesh": {}}
        d["mesh"]["again"] = d
        l = [0.0]
        l.append(l)
        deep = 0.0
        for _ in range(200_000):
            deep = [deep]
        for values in (d, {"gravity": l}, {"gravity": deep}):
            try:
                tetsim.Scene.from_dict(values)
            except tetsim.Error as e:
                print(e.key)
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["mesh.again", "gravity[1]", "gravity[0][0]…"]


def test_arguments_take_what_the_scene_takes():
    """The values the checks above refuse have neighbours that work: numpy scalars, unit
    strings, None for a default, os.PathLike paths."""
    m = tetsim.Material(youngs_modulus="1 MPa", poisson_ratio=np.float32(0.25), lam=None)
    assert m.youngs_modulus == pytest.approx(1e6) and m.poisson_ratio == pytest.approx(0.25)
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(cells=(3, 1, 1))))
    assert len(sim.fixed_vertices(np.int64(0))) > 0
    sim.set_fixed_motion(np.int64(0), translate=("5 mm", 0, 0), rotate_degrees="0.01 rad",
                         axis=np.array([0.0, 0.0, 1.0]), duration="0.1 s")
    sim.set_fixed_motion(0, translate=None, duration=None)
    sim.step()
    assert tetsim.Material().tangent(ANY_F, definiteness=None).shape == (1, 9, 9)
