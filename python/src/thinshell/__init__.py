"""thinshell from Python: thin elastic shells whose rest shape changes with heat, moisture or
growth (discrete Kirchhoff-Love shells, Chen et al. 2018), numpy in, numpy out.

Units are SI throughout: positions in m, time in s, energies in J, forces in N, Young's modulus
in Pa. Rest forms are 2 x 2 matrices per face in the face's basis (x_j - x_i, x_k - x_i): a_bar
in m^2, b_bar in m.

- :class:`Mesh` - a validated triangle mesh from ``V (n x 3)``, ``F (m x 3)`` or an OBJ file.
- :class:`Scene` - a scene (docs/scenes.md) from a TOML file, a TOML string or a dict.
- :class:`Simulation` - a built scene: ``step()``, ``run()``, ``positions``, ``energies``,
  ``set_positions()``, ``save()``/``restore()``, ``snapshot()``, ...; the GIL is released while
  a step runs, so threads stepping different simulations run in parallel, and Ctrl-C stops a
  step within one Newton iteration (KeyboardInterrupt; ``cancel()`` from another thread).
- :func:`energy` - energy, gradient and Hessian (``scipy.sparse.csc_matrix``) of a mesh;
  ``Simulation.energy()`` the same at a simulation's own state (``sim.form``, ``sim.material``).
- :func:`modes` - natural frequencies and mode shapes of a scene (``Simulation.modes()``).
- :func:`sweep` - every combination of a parameter grid, in a local process pool or on Dask;
  runs are keyed by scene, file contents and version, interruptible, returned as a DataFrame.

Errors are :class:`ThinshellError` subclasses whose message is what the ``thinshell`` CLI
prints: :class:`MeshError`, :class:`SceneError`, :class:`SimulationError`, :class:`EnergyError`, :class:`Cancelled`.
"""


from typing import Iterable as _Iterable
from typing import Mapping as _Mapping
from typing import NamedTuple as _NamedTuple
from typing import Sequence as _Sequence

import numpy as _np

from . import _thinshell
from ._thinshell import (
    Cancelled,
    EnergyError,
    Mesh,
    MeshError,
    Scene,
    SceneError,
    Simulation,
    SimulationError,
    ThinshellError,
)
from .sweep import PackedScene, SweepMismatch, sweep

__version__: str = _thinshell.__version__

__all__ = [
    "Cancelled",
    "EnergyError",
    "EnergyResult",
    "Mesh",
    "Modes",
    "MeshError",
    "PackedScene",
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "SweepMismatch",
    "ThinshellError",
    "energy",
    "load_scene",
    "modes",
    "sweep",
]


def load_scene(
    source: "str | bytes | _Mapping[str, object] | Scene | object",
    overrides: _Sequence[str] = (),
) -> Scene:
    """A :class:`Scene` from a file path (str or os.PathLike), a dict, or a Scene (returned
    with ``overrides`` applied). TOML text goes through :meth:`Scene.from_toml`.

    ``overrides`` are ``"key=value"`` strings with TOML values, as the CLI's ``--set``.
    """
    if isinstance(source, Scene):
        return source.with_overrides(list(overrides)) if overrides else source
    if isinstance(source, _Mapping):
        return Scene.from_dict(dict(source), list(overrides))
    return Scene.from_file(source, list(overrides))


class EnergyResult(_NamedTuple):
    """What :func:`energy` returns."""

    energy: float
    """Total elastic energy (stretch + bend), J."""
    stretch: float
    """Stretching energy, J."""
    bend: float
    """Bending energy, J."""
    gradient: _np.ndarray
    """dE/dx, N: 3 n entries vertex-major (x0, y0, z0, x1, ...), then dE/dphi_e (J/rad) per
    edge with an edge-director form."""
    hessian: "object | None"
    """d2E/dx2 as a full symmetric ``scipy.sparse.csc_matrix`` (N/m), same ordering as the
    gradient; None when ``hessian=False``."""
    edge_angles: "_np.ndarray | None" = None
    """The edge angles (rad, one per edge) the energy was evaluated at: those given, else the
    minimising ones (edge-director forms); empty for ``mid_edge_average``."""


def _energy_result(stretch, bend, grad, rows, cols, vals, n, hessian, phi) -> EnergyResult:
    """EnergyResult from the extension's parts (COO triplets of the full symmetric Hessian)."""
    import scipy.sparse

    H = None
    if hessian:
        H = scipy.sparse.csc_matrix((vals, (rows, cols)), shape=(n, n))
        H.sort_indices()
    return EnergyResult(stretch + bend, stretch, bend, grad, H, phi)


class Modes(_NamedTuple):
    """What :meth:`Simulation.modes` and :func:`modes` return (docs/modal.md)."""

    frequencies: _np.ndarray
    """Natural frequencies, Hz, ascending (rigid motions: about 0)."""
    eigenvalues: _np.ndarray
    """omega^2, rad^2/s^2, ascending."""
    shapes: _np.ndarray
    """count x n x 3 displacements (m), mass-normalised (sum m_i |v_i|^2 = 1), 0 where held."""
    residuals: _np.ndarray
    """Relative residual of each mode."""


def modes(
    scene: "str | _Mapping[str, object] | Scene | object",
    count: int = 6,
    overrides: _Sequence[str] = (),
) -> Modes:
    """The ``count`` lowest natural frequencies and mode shapes of a scene about its start
    state (what ``thinshell modes`` computes; the massless edge angles condensed, damping left
    out): ``Simulation(load_scene(scene, overrides)).modes(count)``."""
    return Simulation(load_scene(scene, overrides)).modes(count)


def energy(
    V: _np.ndarray,
    F: "_np.ndarray | None" = None,
    rest: "_np.ndarray | tuple[_np.ndarray, _np.ndarray] | None" = None,
    material: "_Mapping[str, float | str] | None" = None,
    form: "str | None" = None,
    terms: "str | _Iterable[str]" = ("stretching", "bending"),
    edge_angles: "_np.ndarray | None" = None,
    hessian: bool = True,
    *,
    sim: "Simulation | None" = None,
) -> EnergyResult:
    """Elastic energy of the shell ``(V, F)`` at positions ``V`` against ``rest``, with its
    gradient and Hessian, for use in your own solver.

    With ``sim=``: the model of that simulation - its faces, its current rest forms (grown or
    edited, ``sim.rest_forms``), its material and its bending form - at positions ``V``, so that
    ``energy(sim.positions, sim=sim).energy`` is the simulation's elastic energy. Giving ``F``,
    ``rest``, ``material`` or ``form`` as well is refused (which model would be meant?).

    Parameters
    ----------
    V : (n, 3) float array, m. The positions at which to evaluate.
    F : (m, 3) int array. Faces; they must be consistently oriented and use every vertex
        (:class:`Mesh` fixes both; its ``vertices``/``faces`` can be passed here).
    rest : rest positions (n, 3) - the rest forms are that shape's - or a tuple
        ``(a_bar, b_bar)`` of (m, 2, 2) arrays (m^2 and m, in each face's basis).
    material : dict with any of ``thickness`` (m), ``young`` (Pa), ``poisson``, ``density``
        (kg/m^3), ``viscosity`` (Pa s), ``model`` ("stvk", "neo_hookean" or
        "tension_field"); the rest are paper's (h = 1e-4 m, E = 2e9 Pa, nu = 0.3).
    form : discrete second fundamental form: "edge_director_tan" (the default, as in scenes)
        or "edge_director_sin" (one angle unknown per edge), or "mid_edge_average" (positions
        only). A Simulation's own is ``sim.form``.
    terms : "stretching" and/or "bending".
    edge_angles : edge-director angles (rad, one per edge); default: the angles that minimise
        the energy at ``V`` (the massless angles' equilibrium, as a simulation solves them:
        fitted free edges, model.md section 1.2, keep 0; returned as ``edge_angles``).
    hessian : whether to assemble the Hessian.
    sim : a :class:`Simulation` whose model to evaluate (see above).
    """
    if isinstance(terms, str):
        terms = [terms]  # "bending" is one term, not the letters b, e, n, ...
    if sim is not None:
        given = [k for k, v in (("F", F), ("rest", rest), ("material", material), ("form", form)) if v is not None]
        if given:
            raise ValueError(
                f"energy(): sim= gives the faces, rest forms, material and form; "
                f"{', '.join(given)} given as well is ambiguous (drop sim= to evaluate another model)"
            )
        F, rest, material, form = sim.faces, sim.rest_forms, sim.material, sim.form
    elif F is None or rest is None:
        raise TypeError("energy(): give the faces F and the rest shape (rest=), or a simulation (sim=)")
    stretch, bend, grad, rows, cols, vals, n, phi = _thinshell.energy_parts(
        V,
        F,
        rest,
        dict(material) if material is not None else None,
        form or "edge_director_tan",
        list(terms),
        None if edge_angles is None else _np.ascontiguousarray(edge_angles, dtype=_np.float64),
        hessian,
    )
    return _energy_result(stretch, bend, grad, rows, cols, vals, n, hessian, phi)


def _energy_of_simulation(sim: Simulation, V: _np.ndarray, hessian: bool = True) -> EnergyResult:
    """``Simulation.energy(positions)``: :func:`energy` with ``sim=``."""
    return energy(V, sim=sim, hessian=hessian)
