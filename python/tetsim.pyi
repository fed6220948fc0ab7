"""tetsim: large elastic deformation on tetrahedral meshes.

Scene.load(path) or Scene.from_dict(d) describe a run, Simulation(scene) steps it (step(),
run(out_dir)), read_mesh / write_mesh read and write tet meshes, and Material evaluates a
constitutive model on deformation gradients. Arrays are numpy float64 / int64, C-contiguous;
numbers are Python or numpy numbers, or strings with a unit where the scene key takes one
("1 MPa", "5 mm"). Every error is a tetsim.Error with the command line's message: a bad value,
a wrong type, a missing or unknown argument alike, its key naming the argument.
"""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

STEPS_COLUMNS: List[str]
"""The steps.csv columns every step() dict has, in order (SPEC §10, then extensions)."""

CONTACT_COLUMNS: List[str]
"""The columns step() dicts add when the scene has contact: contacts, min_distance,
contact_energy, friction_dissipation."""

RECOVERY_COLUMNS: List[str]
"""The column every step() dict ends with: tangled_elements (elements evaluated with their
model's recovery form, after a tangled or inverted start)."""

_Path = Union[str, "PathLike[str]"]
_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]
_Real = Union[float, int, np.floating, np.integer]
_Quantity = Union[_Real, str]
"""A number in the key's SI unit, or a string with a unit as a scene file takes it ("5 mm")."""
_Vec3 = Union[Sequence[_Quantity], npt.NDArray[Any]]
_Index = Union[int, np.integer]

class Error(ValueError, TypeError):
    """A bad input or a run that cannot go on: str(e) is the command line's message.

    Scene files: '<file>:<line>:<column>: <key>: <what is wrong>'; Scene.from_dict and
    Material leave out the location of the TOML text they make and keep the key. An argument of
    the module's own functions: '<argument>: <what is wrong>', e.g. "index: there is no
    [[fixed]] entry 3 (the scene has 1 [[fixed]] entry, numbered 0)" or "youngs_modulus: \"1 m\"
    is a length, but this key takes a pressure or stress (Pa, e.g. \"1.2 MPa\")".

    Every refusal raises this class: a value out of range, NaN or inf, a value beyond the cap
    of its unit in a scene (1e9 m, 1e8 m/s, ...), a wrong type, a missing argument, a positional
    argument too many, an unknown keyword (with the nearest known one), a dict or list that
    contains itself. It derives from ValueError and from TypeError, so `except ValueError` and
    `except TypeError` written for Python's own errors keep catching it.
    """

    message: str
    """The same as str(e)."""
    file: Optional[str]
    """The file the error is in (scene, mesh, positions), or None."""
    line: Optional[int]
    """1-based line in `file`, where the format has lines."""
    column: Optional[int]
    """1-based column in a scene file."""
    key: Optional[str]
    """The scene key or argument, e.g. 'solver.dt', '[[fixed]] #1 motion.translate',
    'positions', 'poisson_ratio', 'index', 'path' (a file that cannot be opened), or None."""
    frame: Optional[int]
    """The frame that failed (a step that cannot go on), or None."""

class Scene:
    """A scene: the mesh, material, boundary conditions, solver and output settings of a run,
    with every value checked (docs/scene-reference.md lists every key).

    Immutable: change a copy with to_dict() and from_dict().
    """

    @staticmethod
    def load(path: _Path) -> "Scene":
        """Read and check a scene file (TOML); its relative paths are relative to its folder.

        Raises Error naming the file, line and key of the first bad value.
        """

    @staticmethod
    def from_dict(values: Mapping[str, Any], base_dir: Optional[_Path] = None) -> "Scene":
        """A scene from Python values with the TOML keys: dicts for tables, lists of dicts for
        [[fixed]], [[load]], [[volume]], [[obstacle]]; numbers, strings, bools, lists, paths and
        numpy arrays for values. Relative paths are relative to base_dir (default: the current
        folder).

        Raises Error whose key names the bad key (e.g. 'solver.frobnicate', 'fixed[0].region'),
        also for None or a type TOML has not, a dict or list that contains itself, and values
        nested more than 32 levels deep.
        """

    @staticmethod
    def default() -> "Scene":
        """The built-in default scene (what `tetsim run` runs without a scene file)."""

    def to_dict(self) -> Dict[str, Any]:
        """Every key with its value, defaults filled in (from_dict takes it back)."""

    @property
    def path(self) -> str:
        """The scene file ('<dict>' for from_dict, '<built-in default scene>')."""

    @property
    def source(self) -> str:
        """The scene's TOML text."""

    @property
    def frames(self) -> int:
        """Frames (backward Euler) or load steps (quasistatic) of the run."""

class Simulation:
    """A running simulation of a scene: its body, boundary conditions, state and solver.

    Vertex arrays (positions, velocities, rest_positions, tets, fixed vertices) use the mesh
    file's numbering, the same as the output frames. Between steps you may set positions and
    velocities and move the fixed vertices; each value is checked like the same value in a scene
    file. The GIL is released while stepping.
    """

    def __init__(self, scene: Scene) -> None:
        """Build everything the scene describes (reads its mesh), ready to step from frame 0.

        Raises Error for a mesh that cannot be simulated or a region that selects nothing.
        """

    def step(self) -> Dict[str, Union[int, float, bool, None]]:
        """Advance one frame (all its substeps); return its row of steps.csv as a dict keyed by
        STEPS_COLUMNS (then CONTACT_COLUMNS with contact; min_distance is None when nothing is
        near; then RECOVERY_COLUMNS).

        Raises Error when the run is finished, or when the frame fails under [solver]
        on_failure (the state is then left as it was before the step). Ctrl-C stops the frame
        within a Newton iteration and raises KeyboardInterrupt, the state left as it was.
        """

    def run(
        self, out_dir: Optional[_Path] = None, deterministic: Optional[bool] = None
    ) -> List[Dict[str, Union[int, float, bool, None]]]:
        """Run every remaining frame, writing what `tetsim run --no-pictures` writes into out_dir
        (default: the scene's [output] dir), with the same bytes: frame_NNNN.vtu (the current
        frame first), frames.pvd, surface_NNNN.obj, steps.csv, timings.csv, manifest.json.
        deterministic=True writes steps.csv's wall_seconds as 0 (like --deterministic).

        A checkpoint.bin as the command line writes it (at the first frame, every [output]
        checkpoint_every of the run, at the end and on Ctrl-C): `tetsim run --resume
        out_dir --frames N` goes on with the run (with the scene's own motions and loads: steering
        done from Python between steps is not in the scene).

        Returns the step() dicts of the frames run. Ctrl-C stops the frame being computed within
        a Newton iteration (raising KeyboardInterrupt): the files end at the last complete frame,
        every one valid, and the manifest's status says "interrupted", as the command line's.
        """

    @property
    def positions(self) -> _F64:
        """Current positions, m: (n, 3) float64, a copy.

        Setting it moves every vertex (checked like [initial] positions: n finite rows, each
        coordinate within 1e9 m, none inside an obstacle); constrained components are set again
        by their constraint at the next step. A refused value changes nothing.
        """

    @positions.setter
    def positions(self, value: _F64) -> None: ...

    @property
    def velocities(self) -> _F64:
        """Current velocities, m/s: (n, 3) float64, a copy.

        Setting it checks n finite rows, each component within 1e8 m/s (the cap of [initial]
        velocity); constrained components are set to zero (their constraint moves them); a
        quasistatic run accepts only zeros. A refused value changes nothing.
        """

    @velocities.setter
    def velocities(self, value: _F64) -> None: ...

    @property
    def rest_positions(self) -> _F64:
        """Rest positions of the mesh, m: (n, 3) float64."""

    @property
    def tets(self) -> _I64:
        """The tets: (m, 4) int64 indices into positions."""

    @property
    def time(self) -> float:
        """Time, s (quasistatic: the load factor, 0 to 1)."""

    @property
    def frame(self) -> int:
        """Frames done so far (0 before the first step)."""

    @property
    def frames(self) -> int:
        """Frames of the whole run ([solver] frames)."""

    @property
    def is_finished(self) -> bool:
        """True once every frame of the run is done."""

    @property
    def scene(self) -> Scene:
        """The scene this simulation was built from."""

    @property
    def fixed_count(self) -> int:
        """How many [[fixed]] entries the scene has (index them from 0)."""

    def fixed_vertices(self, index: _Index) -> _I64:
        """The vertices of [[fixed]] entry `index` (0-based: [[fixed]] #1 is 0), sorted: (k,)
        int64. set_fixed_targets takes one target per vertex, in this order."""

    def set_fixed_motion(
        self,
        index: _Index,
        translate: Optional[_Vec3] = (0.0, 0.0, 0.0),
        rotate_degrees: Optional[_Quantity] = 0.0,
        axis: Optional[_Vec3] = (1.0, 0.0, 0.0),
        center: Optional[_Vec3] = (0.0, 0.0, 0.0),
        duration: Optional[_Quantity] = None,
    ) -> None:
        """Give [[fixed]] entry `index` a new motion of its frame-0 positions, with the checks of
        the scene's `motion` and `duration` keys: rotate by rotate_degrees about axis through
        center, then translate; ramped linearly over duration seconds from the start of the run
        (None: the whole run; 0: at once). Takes effect at the next step and replaces targets
        set by set_fixed_targets. None for any other argument is its default.

        Each value is a number in the key's unit or a string with a unit, as in a scene
        (translate=("5 mm", 0, 0), rotate_degrees="0.5 rad", duration="200 ms"). Raises Error,
        changing nothing, for an index that is not an entry, a value that is not finite or is
        beyond its unit's cap (1e9 m, 1e9 degrees, 1e12 s), or a rotation about a zero axis."""

    def set_fixed_targets(self, index: _Index, targets: _F64) -> None:
        """Hold the vertices of [[fixed]] entry `index` at `targets` ((k, 3) float64, one finite
        row per vertex of fixed_vertices(index), in its order, each coordinate within 1e9 m)
        from the next step on, in place of the entry's motion. Only its constrained components
        follow."""

class Mesh:
    """A tet mesh read from a file."""

    vertices: _F64
    """(n, 3) float64 vertex positions, m."""
    tets: _I64
    """(m, 4) int64 vertex indices of each tet (positively oriented)."""
    groups: Dict[str, _I64]
    """Named groups (Gmsh physical groups of any dimension): name -> sorted vertex ids."""
    tet_groups: Dict[str, _I64]
    """Named volume groups: name -> tet ids."""
    format: str
    """The format read, e.g. 'Gmsh 4.1 ASCII'."""

def read_mesh(path: _Path, force: bool = False) -> Mesh:
    """Read a tet mesh: Gmsh .msh (2.2, 4.1; ASCII or binary), TetGen .node/.ele, VTK
    .vtk/.vtu, MEDIT .mesh. Vertices no tet uses are dropped, tets reoriented to positive
    volume, and a mesh with degenerate or duplicate tets refused unless force=True.

    Raises Error naming the file and line of a malformed file.
    """

def write_mesh(
    path: _Path,
    vertices: _F64,
    tets: _I64,
    groups: Optional[Mapping[str, _I64]] = None,
) -> None:
    """Write a tet mesh in the format of path's extension: .msh (Gmsh 4.1 ASCII), .vtu, .vtk,
    .node/.ele (TetGen), .mesh (MEDIT), .obj (the boundary surface). vertices (n, 3) float64;
    tets (m, 4) int64 indices into vertices; groups: name -> vertex ids (int64), written as
    Gmsh physical groups of points in a .msh (the other formats have no groups). Written
    atomically (a temp file renamed)."""

def tetrahedralize(
    vertices: _F64,
    faces: _I64,
    size: float,
    min_closure: float = 0.8,
) -> Tuple[_F64, _I64]:
    """Fill the solid a closed triangle surface bounds with tets (isosurface stuffing on a BCC
    lattice of spacing size, m). vertices (n, 3) float64, faces (k, 3) int64; returns
    (vertices (p, 3) float64, tets (m, 4) int64), tets positively oriented. Small holes and
    self-intersections are tolerated (generalized winding numbers). Raises Error for a surface
    too open (closure below min_closure), a size with no lattice point inside, or one whose
    estimated mesh would not fit in memory."""

class Material:
    """A constitutive model: energy density Ψ(F) (J/m³), first Piola-Kirchhoff stress
    P(F) = ∂Ψ/∂F (Pa) and its tangent ∂P/∂F, on arrays of deformation gradients (k, 3, 3).

    Models: neo-hookean, neo-hookean-clamped, corotated, stable-neo-hookean,
    st-venant-kirchhoff, mooney-rivlin, linear. Give youngs_modulus and poisson_ratio, or mu and
    lam (λ), as in the scene's [material] (defaults E = 1e5 Pa, ν = 0.3), with its checks.
    inversion_threshold (default 0.1, a stretch): every model is its formula wherever every
    principal stretch of F is at least this; below it the model's inversion extension acts.
    """

    def __init__(
        self,
        model: str = "neo-hookean",
        *,
        youngs_modulus: Optional[_Quantity] = None,
        poisson_ratio: Optional[_Quantity] = None,
        mu: Optional[_Quantity] = None,
        lam: Optional[_Quantity] = None,
        inversion_threshold: Optional[_Quantity] = None,
    ) -> None:
        """Moduli as numbers in Pa or strings with a unit ("1.2 MPa"), as [material] takes them;
        None (or left out) for the scene's default. Raises Error naming the argument for a value
        the scene would refuse (Poisson ratio 0.5, NaN, 1e300 Pa, ...) or of the wrong type."""

    @property
    def inversion_threshold(self) -> Optional[float]:
        """The inversion threshold (a stretch), or None for a model without an extension."""

    @property
    def model(self) -> str:
        """The model's scene name, e.g. 'neo-hookean'."""

    @property
    def mu(self) -> float:
        """Lamé μ (shear modulus), Pa."""

    @property
    def lam(self) -> float:
        """Lamé λ, Pa."""

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus E, Pa."""

    @property
    def poisson_ratio(self) -> float:
        """Poisson ratio ν."""

    def energy(self, F: _F64) -> _F64:
        """Energy density Ψ(F), J/m³: (k, 3, 3) float64 -> (k,) float64.

        Raises Error (key 'F') naming the first F[i] that holds NaN or inf, or whose result
        overflows double precision; never returns NaN or inf."""

    def stress(self, F: _F64) -> _F64:
        """First Piola-Kirchhoff stress P(F), Pa: (k, 3, 3) -> (k, 3, 3) float64 (refusing
        non-finite F as energy does)."""

    def tangent(self, F: _F64, definiteness: str = "none") -> _F64:
        """∂P/∂F, Pa: (k, 3, 3) -> (k, 9, 9) float64 with T[k, 3i+j, 3l+m] = ∂P_ij/∂F_lm, so that
        (T @ dF.reshape(k, 9, 1)).reshape(k, 3, 3) is the stress differential.

        definiteness: 'none' (the exact derivative; also None), or the solver's positive
        semi-definite fixes 'teran', 'analytic', 'abs', 'adaptive'. Refuses non-finite F as
        energy does.
        """
