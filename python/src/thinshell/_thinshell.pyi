"""Type stubs of the extension module (the classes are re-exported by ``thinshell``)."""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

__version__: str

class ThinshellError(Exception):
    """Base class of every error thinshell raises."""

class MeshError(ThinshellError):
    """A mesh that is not a valid shell mesh, or an OBJ file that cannot be read."""

class SceneError(ThinshellError):
    """A scene that cannot be loaded or built (message with file, line, column and key path)."""

class SimulationError(ThinshellError):
    """A step that failed (the last good state is kept), or a rejected rest-shape edit."""

class EnergyError(ThinshellError):
    """Energy evaluation rejected its input or produced non-finite values."""

class Cancelled(ThinshellError):
    """A step stopped by ``Simulation.cancel()``; the state is that of the last completed step."""

_Path = str | PathLike[str]

class Mesh:
    """A validated, consistently oriented, edge-manifold triangle mesh."""

    def __init__(self, vertices: npt.ArrayLike, faces: npt.ArrayLike) -> None:
        """From vertices V (n x 3, m) and faces F (m x 3, 0-based). Faces are flipped per
        component to one orientation and unused vertices dropped (see ``flipped_faces``,
        ``vertex_map``). Raises MeshError (degenerate, non-manifold, non-orientable, ...)."""
    @staticmethod
    def from_obj(path: _Path) -> Mesh:
        """Reads an OBJ file; polygons (quads, ...) are split into triangles fanning out from
        their first vertex."""
    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """n x 3, m (a copy)."""
    @property
    def faces(self) -> npt.NDArray[np.int64]:
        """m x 3, 0-based (a copy)."""
    @property
    def n_vertices(self) -> int: ...
    @property
    def n_faces(self) -> int: ...
    @property
    def n_edges(self) -> int: ...
    @property
    def flipped_faces(self) -> list[int]:
        """Faces whose orientation was reversed when the mesh was built."""
    @property
    def vertex_map(self) -> npt.NDArray[np.int64]:
        """Per input vertex its index in the mesh, -1 if dropped (unused)."""
    def save_obj(self, path: _Path, positions: npt.ArrayLike | None = None) -> None:
        """Writes OBJ at ``positions`` (n x 3, m), default the mesh's own vertices."""

class Scene:
    """A parsed and validated scene (docs/scenes.md). Picklable."""

    @staticmethod
    def from_file(path: _Path, overrides: Sequence[str] | None = None) -> Scene:
        """Reads a TOML scene file; ``overrides``: ``"key=value"`` as the CLI's ``--set``."""
    @staticmethod
    def from_toml(
        text: str,
        overrides: Sequence[str] | None = None,
        base_dir: _Path | None = None,
        origin: str = "<string>",
    ) -> Scene:
        """Parses TOML text; ``origin`` names it in messages, ``base_dir`` resolves paths."""
    @staticmethod
    def from_dict(
        scene: Mapping[str, Any],
        overrides: Sequence[str] | None = None,
        base_dir: _Path | None = None,
        origin: str = "<dict>",
    ) -> Scene:
        """A dict with the schema of a scene file (None values are left out). ``mesh`` may also
        be a ``Mesh`` or ``{"vertices": V, "faces": F}``: it is written as an OBJ file named by
        its content into the cache directory (``$THINSHELL_CACHE_DIR/meshes``, default
        ``~/.cache/thinshell/meshes``), which the scene names as ``mesh.obj``."""
    @property
    def name(self) -> str: ...
    @property
    def origin(self) -> str: ...
    @property
    def toml(self) -> str:
        """The TOML text (before overrides)."""
    @property
    def overrides(self) -> list[str]: ...
    @property
    def base_dir(self) -> Path: ...
    @property
    def resolved_toml(self) -> str:
        """The scene after its overrides as canonical TOML (every value; what a run does)."""
    @property
    def scene_hash(self) -> int:
        """64-bit fingerprint of the scene after overrides, as checkpoints store it."""
    @property
    def files(self) -> list[Path]:
        """Files a simulation of the scene reads (the mesh's OBJ file, if any)."""
    def with_overrides(self, overrides: Sequence[str]) -> Scene:
        """This scene with further ``key=value`` overrides."""

StepRecord = dict[str, Any]
"""One step: step, time (s), energy {stretch, bend, damping} (J), kinetic (J),
newton_iterations, backtracks, regularizations, residual, load_factor,
gauss_newton_iterations, shifted_iterations, negative_curvature_iterations, rejected_steps,
stable, min_eigenvalue (static steps: smallest eigenvalue of the exact Hessian, relative to each
unknown's stiffness; None for dynamic steps), wall_s, assembly_s, factorization_s, solve_s (s); contact
(None without the ``contact`` effect, else {active_pairs, min_gap (m, over active self pairs
and obstacles; None without either), energy (J), approximated_pairs, pattern_rebuilds})."""

class Simulation:
    """A scene built into a simulation. Steps release the GIL; one thread steps a simulation,
    any thread may read its state (a snapshot after the last completed step) meanwhile.
    Picklable (through its checkpoint bytes)."""

    def __init__(
        self,
        scene: Scene | Mapping[str, Any] | _Path,
        threads: int | None = None,
        output: _Path | None = None,
    ) -> None:
        """``threads``: threads of this simulation's own pool (default: the shared pool of all
        cores). ``output``: a directory that receives the scene's ``[output]`` as
        ``thinshell run --out`` writes it (frames, steps.csv; summary.json once the run
        completes, fails or is interrupted). Raises SceneError / MeshError with the CLI's
        message."""
    def step(self) -> StepRecord:
        """One step; raises SimulationError (the state stays the last good one), also once the
        scene's ``integrator.steps`` are done. Ctrl-C stops the Newton solve within one
        iteration (KeyboardInterrupt; the state stays that of the last completed step)."""
    def cancel(self) -> None:
        """From any thread: the running step stops within one Newton iteration and raises
        ``Cancelled``; between steps, the next step raises it without stepping."""
    def snapshot(self) -> dict[str, Any]:
        """Read-only copy of the state after the last completed step: step, steps_total,
        time (s), positions (n x 3, m), velocities (m/s), energies (J), load_factor."""
    def set_positions(self, positions: npt.ArrayLike) -> None:
        """n x 3, m; energies re-evaluated. Raises SimulationError on a wrong shape or NaN."""
    def set_velocities(self, velocities: npt.ArrayLike) -> None:
        """n x 3, m/s. Raises SimulationError on a wrong shape or NaN."""
    def save(self, path: _Path) -> None:
        """Checkpoint of the current state (the format of the CLI's ``checkpoint.bin``)."""
    def restore(self, path: _Path) -> None:
        """Continues from a checkpoint of the same scene (``save`` or the CLI's); bit for bit."""
    def to_bytes(self) -> bytes:
        """The checkpoint as bytes."""
    @staticmethod
    def from_bytes(scene: Scene | Mapping[str, Any] | _Path, data: bytes, threads: int | None = None) -> Simulation:
        """A simulation of ``scene`` in the checkpoint's state (what unpickling calls)."""
    def run(
        self,
        callback: Callable[[Simulation, StepRecord], object] | None = None,
        every: int = 1,
    ) -> dict[str, Any]:
        """The remaining steps; ``callback(sim, record)`` every ``every`` steps and after the
        last. Returns ``summary``."""
    @property
    def summary(self) -> dict[str, Any]:
        """name, status, error, steps, steps_requested, time_s, energy (J), wall_s,
        newton_iterations, gauss_newton_iterations, shifted_iterations,
        negative_curvature_iterations, rejected_steps, load_factor, stable, unstable_steps, contact
        (None without the ``contact`` effect, else {max_active_pairs, min_gap_m,
        approximated_steps, pattern_rebuilds})."""
    def describe(self) -> str:
        """What ``thinshell check`` prints."""
    @property
    def name(self) -> str: ...
    @property
    def mesh(self) -> Mesh: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """n x 3, m."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """n x 3, m/s."""
    @property
    def reference_positions(self) -> npt.NDArray[np.float64]:
        """n x 3, m: the mesh as given."""
    @property
    def edge_angles(self) -> npt.NDArray[np.float64]:
        """rad, one per edge (edge-director forms), else empty."""
    @property
    def time(self) -> float:
        """s."""
    @property
    def dt(self) -> float:
        """s."""
    @property
    def steps_done(self) -> int: ...
    @property
    def steps_total(self) -> int: ...
    @property
    def load_factor(self) -> float: ...
    @property
    def energies(self) -> dict[str, float]:
        """J: stretch, bend, damping (of the last step), elastic, kinetic."""
    def face_energies(self) -> dict[str, npt.NDArray[np.float64]]:
        """J per face: stretch, bend."""
    @property
    def rest_forms(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(a_bar m^2, b_bar m), each m x 2 x 2 in the face basis (x_j - x_i, x_k - x_i)."""
    def set_rest_forms(self, a_bar: npt.ArrayLike, b_bar: npt.ArrayLike) -> None:
        """Replaces the rest forms between steps; raises SimulationError on invalid forms."""
    @property
    def stimulus(self) -> npt.NDArray[np.float64] | None:
        """m x 2 (top, bottom) in the stimulus' unit; None without growth."""
    def set_stimulus(self, values: npt.ArrayLike) -> None:
        """Per-face stimulus, (m,) or (m, 2), held constant from now on (growth scenes)."""
    @property
    def form(self) -> str:
        """The bending form: "edge_director_tan" (default), "edge_director_sin", "mid_edge_average"."""
    @property
    def material(self) -> dict[str, Any]:
        """thickness (m), young (Pa), poisson, density (kg/m^3), viscosity (Pa s), model."""
    def energy(self, positions: npt.ArrayLike | None = None, hessian: bool = True) -> Any:
        """EnergyResult at the simulation's own state (positions and edge angles): elastic
        energy (J), gradient over all coordinates, Hessian over the unknowns. With
        ``positions``: this simulation's model (faces, current rest forms, material, form) at
        those positions, with the minimising edge angles (``thinshell.energy(x, sim=self)``)."""
    def modes(self, count: int = 6) -> Any:
        """Modes: the count lowest natural frequencies (Hz) and mode shapes about the state."""

def energy_parts(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    rest: Any,
    material: Mapping[str, Any] | None = None,
    form: str = "edge_director_tan",
    terms: Sequence[str] | None = None,
    edge_angles: npt.ArrayLike | None = None,
    hessian: bool = True,
) -> tuple[
    float,
    float,
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
    int,
    npt.NDArray[np.float64],
]: ...
def _reference_hessian(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    rest: Any,
    material: Mapping[str, Any] | None = None,
    form: str = "edge_director_tan",
    terms: Sequence[str] | None = None,
    edge_angles: npt.ArrayLike | None = None,
) -> npt.NDArray[np.float64]:
    """Private, for tests: the dense Hessian of ``energy_parts``' energy, summed face by face
    from the per-face kernel without the assembler (O(n^2) memory)."""
