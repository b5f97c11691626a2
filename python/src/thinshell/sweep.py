"""Parameter sweeps: every combination of a grid of scene values, run locally in a process pool
or on a Dask cluster, resumable, interruptible, and never reusing a run of something else.

Each run writes into its own directory under ``out_dir``, named by its *run id*: a hash of the
scene after the run's overrides (every value, as canonical TOML), the content of every file the
run reads (the mesh's OBJ file), its parameters and the package version. There it writes
``scene.toml`` (the scene it ran) and ``provenance.json`` (what the id covers) first, then
``positions.npy`` (final positions, n x 3, m), ``summary.json`` (the simulation summary) and,
last and atomically, ``result.json`` (its row). A run is reused only when its ``result.json``
exists and its ``provenance.json`` equals the one the current call computes; anything else
(another scene, an edited mesh file, another version) has another id and runs again.

A run stopped by Ctrl-C (or a Dask worker told to stop) writes ``interrupted.json`` instead of
``result.json`` (with the steps it completed), so the next call runs it again from the start.

``out_dir`` also keeps ``scene.toml`` (the base scene), ``sweep.json`` (package version, grid,
the base scene's hash and files) and, at the end, ``results.json`` and ``results.csv``.
"""

from __future__ import annotations

import ast
import csv
import hashlib
import itertools
import json
import math
import os
import signal
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

__all__ = ["PackedScene", "SweepMismatch", "sweep", "toml_literal", "UNITS"]

Row = dict[str, Any]

#: Units of the result columns (also in the DataFrame's ``attrs["units"]``).
UNITS: dict[str, str] = {
    "steps": "1",
    "time_s": "s",
    "stretch_J": "J",
    "bend_J": "J",
    "elastic_J": "J",
    "newton_iterations": "1",
    "wall_s": "s",
}


class SweepMismatch(ValueError):
    """``out_dir`` holds a sweep of another scene, grid or package version, and the call asked
    (``on_mismatch="error"``) to refuse rather than to run the new one beside it."""


class PackedScene:
    """A scene by value: its text, its overrides and the content of every file it reads (the
    mesh's OBJ), so that it runs where the files are not - a Dask worker on another machine,
    with its own disk, HOME and working directory - or after they are gone.

    ``PackedScene.pack(scene)`` reads the files once; ``unpack(directory)`` writes them there
    (named by their content) and gives the :class:`thinshell.Scene` that reads them. Pickles as
    plain data. :func:`sweep` packs the scene it sends to Dask workers, and takes a packed scene
    as its ``scene`` (unpacked into ``out_dir/inputs``, so that run ids do not depend on where
    the files came from)."""

    def __init__(self, text: str, overrides: Sequence[str], origin: str, mesh_obj: bytes | None) -> None:
        self.text, self.overrides, self.origin, self.mesh_obj = text, list(overrides), origin, mesh_obj

    @classmethod
    def pack(cls, scene: Any) -> "PackedScene":
        """Reads the files of ``scene`` (a :class:`thinshell.Scene`, a dict or a path)."""
        from . import load_scene

        if isinstance(scene, PackedScene):
            return scene
        scene = load_scene(scene)
        files = list(scene.files)
        mesh = Path(files[0]).read_bytes() if files else None
        return cls(scene.toml, scene.overrides, scene.origin, mesh)

    def unpack(self, directory: "str | os.PathLike[str]") -> Any:
        """The scene, with its files written under ``directory`` (created)."""
        from . import Scene

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        overrides = list(self.overrides)
        if self.mesh_obj is not None:
            path = d / f"mesh-{hashlib.sha256(self.mesh_obj).hexdigest()[:24]}.obj"
            if not path.exists():
                fd, tmp = tempfile.mkstemp(dir=d, prefix=".mesh-", suffix=".obj")
                with os.fdopen(fd, "wb") as f:
                    f.write(self.mesh_obj)
                os.replace(tmp, path)
            # Relative to the directory: the scene (and a sweep's run ids) do not depend on it.
            overrides.append(f"mesh.obj={json.dumps(path.name)}")
        return Scene.from_toml(self.text, overrides, base_dir=str(d), origin=self.origin)


def toml_literal(value: Any) -> str:
    """``value`` as a TOML literal for a ``key=value`` override (bool, int, float, str, lists
    and dicts of those; numpy scalars and arrays via ``tolist``)."""
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)  # shortest round-trip representation
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string is a JSON string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"sweep: a value of type {type(value).__name__} cannot be a scene value: {value!r}")


def _plain(v: Any) -> Any:
    return v.tolist() if hasattr(v, "tolist") else v


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _file_digests(paths: Sequence[Any], cache: dict[str, str]) -> dict[str, str]:
    """sha256 of each file's content ("missing: ..." when it cannot be read: the run will fail
    and say why, and a file appearing later changes the id), by file name: where the file lies
    is the scene's business (its resolved text names the path), what it holds is this."""
    out = {}
    for p in paths:
        key = str(Path(p).resolve())
        if key not in cache:
            try:
                cache[key] = hashlib.sha256(Path(key).read_bytes()).hexdigest()
            except OSError as e:
                cache[key] = f"missing: {type(e).__name__}"
        out[Path(key).name] = cache[key]
    return out


def _provenance(scene: Any, params: Mapping[str, Any], version: str, digests: dict[str, str]) -> dict[str, Any]:
    """What a run's id covers: the scene after its overrides, the files it reads, its
    parameters, the package version. An invalid value (SceneError) has no resolved scene: the
    base scene and the overrides stand for it."""
    from . import SceneError

    overrides = [f"{k}={toml_literal(v)}" for k, v in params.items()]
    try:
        run_scene = scene.with_overrides(overrides)
        resolved = run_scene.resolved_toml
        files = _file_digests(run_scene.files, digests)
    except SceneError:
        resolved = scene.resolved_toml + "\n# invalid overrides: " + json.dumps(overrides)
        files = _file_digests(scene.files, digests)
    return {
        "version": version,
        "params": {k: _plain(v) for k, v in params.items()},
        "scene": resolved,
        "files": files,
    }


def _run_id(prov: Mapping[str, Any]) -> str:
    text = json.dumps(prov, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# --- the work of one run (in this process, a pool worker or a Dask worker) -------------------

#: Set in a pool worker by SIGINT: the run in progress stops, runs not started are not.
_stop = threading.Event()
_running = threading.Event()


def _pool_worker_init(threads: int) -> None:
    """Initialiser of process-pool workers: a thread count for rayon's global pool, and a SIGINT
    handler that interrupts a running run (KeyboardInterrupt inside the Newton solve) and makes
    the worker skip the runs still queued, instead of killing the worker."""
    os.environ["RAYON_NUM_THREADS"] = str(threads)

    def on_sigint(signum: int, frame: Any) -> None:
        # Once: a terminal's Ctrl-C reaches the workers directly and again through the sweep,
        # and a second KeyboardInterrupt must not cut short the partial run's bookkeeping.
        first = not _stop.is_set()
        _stop.set()
        if first and _running.is_set():
            raise KeyboardInterrupt

    signal.signal(signal.SIGINT, on_sigint)


def _empty_metrics() -> Row:
    return {
        "status": "error",
        "error": None,
        "steps": None,
        "time_s": None,
        "stretch_J": None,
        "bend_J": None,
        "elastic_J": None,
        "newton_iterations": None,
        "stable": None,
    }


def run_one(
    scene: Any,
    params: Mapping[str, Any],
    run_dir: str,
    threads: int | None = None,
    provenance: Mapping[str, Any] | None = None,
    *,
    reraise_interrupt: bool = True,
    on_simulation: Callable[[Any], None] | None = None,
) -> Row:
    """One run of a sweep: the scene with ``params`` applied as overrides, run to the end with
    ``threads`` threads. A failure (bad value, failed step, anything) becomes a row with status
    ``"error"``. Ctrl-C (KeyboardInterrupt) or ``Simulation.cancel()`` stops it within one Newton
    iteration: ``interrupted.json`` marks the partial run, and KeyboardInterrupt is raised again
    when ``reraise_interrupt`` (else the row, status ``"interrupted"``, is returned). Writes the
    run's files, ``result.json`` last, only for a run that finished."""
    from . import Cancelled, Simulation, ThinshellError  # in a worker process

    t0 = time.perf_counter()
    out = Path(run_dir)
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("result.json", "interrupted.json"):
        (out / stale).unlink(missing_ok=True)
    row: Row = {"run": out.name, **{k: _plain(v) for k, v in params.items()}}
    metrics = _empty_metrics()
    if _stop.is_set():
        metrics.update(status="interrupted", error="not started: the sweep was interrupted")
        row.update(metrics, wall_s=0.0)
        return row
    if provenance is not None:
        _write_atomic(out / "provenance.json", json.dumps(provenance, indent=2, sort_keys=True))
    interrupt: BaseException | None = None
    sim = None
    _running.set()
    try:
        overrides = [f"{k}={toml_literal(v)}" for k, v in params.items()]
        run_scene = scene.with_overrides(overrides)
        _write_atomic(out / "scene.toml", run_scene.resolved_toml)
        sim = Simulation(run_scene, threads=threads)
        if on_simulation is not None:
            on_simulation(sim)
        if _stop.is_set():
            raise KeyboardInterrupt
        summary = sim.run()
        energy = summary["energy"]
        metrics.update(
            status=summary["status"],
            steps=summary["steps"],
            time_s=summary["time_s"],
            stretch_J=energy["stretch"],
            bend_J=energy["bend"],
            elastic_J=energy["stretch"] + energy["bend"],
            newton_iterations=summary["newton_iterations"],
            stable=summary["stable"],
        )
    except (KeyboardInterrupt, Cancelled) as e:
        interrupt = e
        metrics.update(status="interrupted", error=f"interrupted after {sim.steps_done if sim else 0} steps ({type(e).__name__})")
        if sim is not None:
            metrics.update(steps=sim.steps_done, time_s=sim.time)
    except ThinshellError as e:
        metrics["error"] = f"{type(e).__name__}: {e}"
    except Exception as e:  # a sweep never crashes on one run
        metrics["error"] = f"{type(e).__name__}: {e}\n{traceback.format_exc()}"
    finally:
        _running.clear()
        if sim is not None:
            np.save(out / "positions.npy", sim.positions)
            _write_atomic(out / "summary.json", json.dumps(sim.summary, indent=2))
    row.update(metrics)
    row["wall_s"] = time.perf_counter() - t0
    # The threads the run used: its own pool's, else the shared pool's (RAYON_NUM_THREADS).
    row["threads"] = threads if threads is not None else int(os.environ.get("RAYON_NUM_THREADS") or os.cpu_count() or 1)
    if interrupt is not None:
        _write_atomic(out / "interrupted.json", json.dumps(row, indent=2))
        if reraise_interrupt and isinstance(interrupt, KeyboardInterrupt):
            raise interrupt
        return row
    _write_atomic(out / "result.json", json.dumps(row, indent=2))
    return row


def _dask_run(
    packed: PackedScene,
    params: Mapping[str, Any],
    run_name: str,
    threads_by_host: Mapping[str, int],
    provenance: Mapping[str, Any],
    stop_event: str,
) -> tuple[Row, dict[str, bytes]]:
    """:func:`run_one` in a Dask worker, by value: the scene arrives packed (its text and mesh),
    the run goes into a directory of the worker's own (its temporary directory: nothing of the
    client's disk is read or written), and the row comes back with the run's files, which the
    client writes into ``out_dir``. Stopped (``Simulation.cancel()``, within one Newton
    iteration) when the sweep sets the Dask ``Event`` named ``stop_event``: the worker is told
    to stop, not killed, and returns the partial run's row."""
    import shutil

    import distributed

    worker = distributed.get_worker()
    host = worker.address.rsplit(":", 1)[0]
    threads = threads_by_host.get(host, 1)
    event = distributed.Event(stop_event)
    if event.is_set():
        row: Row = {"run": run_name, **{k: _plain(v) for k, v in params.items()}}
        row.update(_empty_metrics(), status="interrupted", error="not started: the sweep was interrupted", wall_s=0.0)
        return row, {}
    sims: list[Any] = []
    done = threading.Event()

    def watch() -> None:
        while not done.is_set():
            try:
                stop = event.wait(timeout=0.1)
            except Exception:  # the client is going away: nothing left to stop
                return
            if stop:
                for s in sims:
                    s.cancel()
                return

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    local = Path(tempfile.mkdtemp(prefix="thinshell-run-"))
    try:
        scene = packed.unpack(local / "inputs")
        run_dir = local / run_name
        row = run_one(scene, params, str(run_dir), threads, provenance, reraise_interrupt=False, on_simulation=sims.append)
        files = {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()}
        return row, files
    finally:
        done.set()
        shutil.rmtree(local, ignore_errors=True)


# --- the sweep ------------------------------------------------------------------------------


def _load_complete(run_dir: Path, prov: Mapping[str, Any]) -> Row | None:
    try:
        row = json.loads((run_dir / "result.json").read_text())
        stored = json.loads((run_dir / "provenance.json").read_text())
    except (OSError, ValueError):
        return None
    if stored != json.loads(json.dumps(prov)):
        return None  # a hash collision or a hand-edited file: run it again
    return row


def _check_main_guard() -> None:
    """A process pool starts its workers with "spawn": each imports the main script again, so a
    script that calls sweep() outside ``if __name__ == "__main__":`` would start the sweep again
    in every worker. Detected here, from the calling frames and the script's source."""
    import multiprocessing

    main = sys.modules.get("__main__")
    if multiprocessing.parent_process() is not None and getattr(main, "__name__", "") == "__mp_main__":
        raise RuntimeError(
            "thinshell.sweep() was called while a process-pool worker imported the main script: "
            "the script needs an `if __name__ == \"__main__\":` guard around its call of sweep()"
        )
    path = getattr(main, "__file__", None)
    if not path:
        return  # an interactive session, a notebook, `python -c`: workers do not re-run it
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals.get("__name__") == "__main__" and frame.f_code.co_name == "<module>"):
        frame = frame.f_back
    if frame is None:
        return  # called from a function of the script: only reached under its own guard or call
    line = frame.f_lineno
    try:
        tree = ast.parse(Path(path).read_text(), path)
    except (OSError, SyntaxError, ValueError):
        return
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "__name__" in ast.unparse(node.test):
            if node.lineno <= line <= (node.end_lineno or node.lineno):
                return
    raise RuntimeError(
        f"thinshell.sweep() is called at the top level of {path} (line {line}) without an "
        f"`if __name__ == \"__main__\":` guard. The process pool starts its workers with "
        f"\"spawn\", which imports the script again in each of them, so each would start the "
        f"sweep again. Put the call under the guard (or pass max_workers=1 to run in this process)."
    )


class _Progress:
    """Runs done / running / failed with an ETA: a tqdm bar (``progress=True``) and/or a
    callback (``progress=callable``, for notebooks: called with a dict after every run)."""

    def __init__(self, progress: Any, total: int, reused: int) -> None:
        self.total, self.done, self.failed, self.reused = total, reused, 0, reused
        self.started = time.perf_counter()
        self.callback = progress if callable(progress) else None
        self.bar = None
        if progress is True:
            try:
                from tqdm.auto import tqdm
            except ImportError as e:
                raise ImportError("sweep(progress=True) needs tqdm (pip install tqdm), or pass a callback") from e
            self.bar = tqdm(total=total, initial=reused, unit="run", desc="sweep")

    def update(self, row: Row | None, running: int) -> None:
        if row is not None:
            self.done += 1
            if row.get("status") not in ("completed",):
                self.failed += 1
        ran = self.done - self.reused
        elapsed = time.perf_counter() - self.started
        left = self.total - self.done
        eta = elapsed / ran * left if ran > 0 else None
        if self.bar is not None:
            if row is not None:
                self.bar.update(1)
            self.bar.set_postfix(running=running, failed=self.failed, refresh=True)
        if self.callback is not None:
            self.callback(
                {
                    "done": self.done,
                    "total": self.total,
                    "running": running,
                    "failed": self.failed,
                    "reused": self.reused,
                    "elapsed_s": elapsed,
                    "eta_s": eta,
                    "row": row,
                }
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def sweep(
    scene: Any,
    grid: Mapping[str, Sequence[Any]],
    out_dir: "str | os.PathLike[str]",
    client: Any = None,
    *,
    max_workers: int | None = None,
    threads: int | None = None,
    progress: "bool | Callable[[dict[str, Any]], None]" = False,
    on_mismatch: str = "rerun",
    frame: bool | None = None,
) -> Any:
    """Runs every combination of ``grid`` on ``scene``; returns one row per run.

    Parameters
    ----------
    scene : a :class:`thinshell.Scene`, a dict, or a path to a scene file.
    grid : scene keys (dotted, as the CLI's ``--set``) -> lists of values, e.g.
        ``{"material.thickness": [1e-4, 2e-4], "growth.coefficient": [0.001, 0.002]}``.
        Runs are the Cartesian product, in the order of the keys (last key fastest).
    out_dir : directory for the runs' files (created).
    client : a ``dask.distributed.Client``: the runs are submitted to its cluster (a
        ``LocalCluster``, or an HPC cluster through dask-jobqueue). None: a local process
        pool of ``max_workers`` processes (default: the CPU count); ``max_workers=1`` runs
        them one after the other in this process. The pool starts its workers with Python's
        "spawn" method, so a script that calls ``sweep`` needs the usual
        ``if __name__ == "__main__":`` guard (checked: a RuntimeError names the line).
    threads : threads per run. Default: the cores divided among the runs that share them (the
        CPU count / ``max_workers`` in a pool; per Dask host, its cores / the worker threads
        there; all cores when runs go one after the other), so that parallel runs do not
        oversubscribe the machine.
    progress : True: a progress bar (tqdm) with runs done, running and failed and an ETA; a
        callable: called after every run with a dict (``done``, ``total``, ``running``,
        ``failed``, ``reused``, ``elapsed_s``, ``eta_s`` (None until a run finished), ``row``).
    on_mismatch : when ``out_dir`` holds a sweep of another base scene, grid, mesh content or
        package version: "rerun" (default) runs the new sweep beside it (the old runs have
        other ids and are never reused), "error" raises :class:`SweepMismatch` saying what
        differs.
    frame : return a ``pandas.DataFrame`` (True), the list of row dicts (False), or a
        DataFrame when pandas is installed (None, the default).

    Returns
    -------
    One row per run, in grid order: ``run`` (its directory name), the parameters, ``status``
    ("completed", "interrupted" or "error"), ``error`` (the message, None if it ran),
    ``steps``, ``time_s`` (s), ``stretch_J``, ``bend_J``, ``elastic_J`` (J),
    ``newton_iterations``, ``stable``, ``wall_s`` (s, the run's wall time), ``threads`` (the
    threads it used), and ``reused``
    (True when the run was complete in ``out_dir`` already and was not run again). As a
    DataFrame, ``attrs["units"]`` maps columns to units (:data:`UNITS`).

    Ctrl-C cancels the runs not started, stops the running ones within one Newton iteration
    (pool workers by SIGINT, Dask workers through a Dask ``Event``), waits for them, and raises
    KeyboardInterrupt; complete runs are reused by the next call, partial ones are marked
    (``interrupted.json``) and run again.
    """
    from . import __version__, load_scene

    if on_mismatch not in ("rerun", "error"):
        raise ValueError(f"sweep: on_mismatch must be 'rerun' or 'error', not {on_mismatch!r}")
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ValueError(f"sweep: threads must be a positive integer, not {threads!r}")
    if max_workers is not None and (not isinstance(max_workers, int) or max_workers < 1):
        raise ValueError(f"sweep: max_workers must be a positive integer, not {max_workers!r}")
    if frame is True:
        import pandas  # noqa: F401  (fail before the runs, not after)
    if isinstance(scene, PackedScene):
        # Its files under out_dir: run ids then do not depend on where the files came from.
        scene = scene.unpack(Path(out_dir) / "inputs")
    scene = load_scene(scene)
    keys = list(grid)
    for k in keys:
        if isinstance(grid[k], (str, bytes)) or not isinstance(grid[k], Sequence | np.ndarray):
            raise TypeError(f"sweep: grid[{k!r}] must be a list of values")
    combos = [dict(zip(keys, values)) for values in itertools.product(*(list(grid[k]) for k in keys))]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    digests: dict[str, str] = {}
    meta = {
        "version": __version__,
        "grid": {k: [_plain(v) for v in grid[k]] for k in keys},
        "scene_hash": f"{scene.scene_hash:016x}",
        "files": _file_digests(scene.files, digests),
    }
    meta_path = out / "sweep.json"
    if meta_path.exists():
        try:
            before = json.loads(meta_path.read_text())
        except ValueError:
            before = None
        now = json.loads(json.dumps(meta))
        if before is not None and before != now and on_mismatch == "error":
            what = [k for k in now if before.get(k) != now[k]]
            raise SweepMismatch(
                f"sweep: {out} holds a sweep with another {', '.join(what)} "
                f"({ {k: before.get(k) for k in what} } there, { {k: now[k] for k in what} } now); "
                f"pass on_mismatch='rerun' to run this one beside it, or use another out_dir"
            )
    _write_atomic(out / "scene.toml", scene.resolved_toml)
    _write_atomic(meta_path, json.dumps(meta, indent=2))

    provs = [_provenance(scene, p, __version__, digests) for p in combos]
    dirs = [out / f"run-{_run_id(pv)}" for pv in provs]
    rows: list[Row | None] = [None] * len(combos)
    todo: list[int] = []
    for i, (pv, d) in enumerate(zip(provs, dirs)):
        done = _load_complete(d, pv)
        if done is not None:
            rows[i] = {**done, "reused": True}
        else:
            todo.append(i)

    def failed(i: int, e: BaseException) -> Row:
        # The worker died (killed, out of memory): no result.json, so a resume runs it again.
        row = {"run": dirs[i].name, **{k: _plain(v) for k, v in combos[i].items()}}
        row.update(_empty_metrics(), error=f"worker failed: {type(e).__name__}: {e}", wall_s=None)
        return row

    bar = _Progress(progress, len(combos), len(combos) - len(todo)) if progress else None
    cpus = os.cpu_count() or 1
    try:
        if client is not None:
            _sweep_dask(client, scene, combos, provs, dirs, todo, rows, threads, bar, failed)
        elif max_workers == 1 or len(todo) <= 1:
            for i in todo:
                if bar is not None:
                    bar.update(None, running=1)
                rows[i] = run_one(scene, combos[i], str(dirs[i]), threads, provs[i])
                if bar is not None:
                    bar.update(rows[i], running=0)
        else:
            workers = min(max_workers or cpus, len(todo))
            _check_main_guard()
            _sweep_pool(scene, combos, provs, dirs, todo, rows, workers, threads or max(1, cpus // workers), bar, failed)
    except KeyboardInterrupt:
        complete = sum((d / "result.json").exists() for d in dirs)
        message = (
            f"thinshell.sweep: interrupted; {complete} of {len(dirs)} runs are complete in {out} "
            f"(kept: calling sweep() again runs only the others)"
        )
        print(message, file=sys.stderr, flush=True)
        raise KeyboardInterrupt(message) from None
    finally:
        if bar is not None:
            bar.close()
    result: list[Row] = []
    for r in rows:
        assert r is not None
        r.setdefault("reused", False)
        result.append(r)
    _write_results(out, result)
    return _as_table(result, keys, frame)


def _sweep_pool(scene, combos, provs, dirs, todo, rows, workers, threads, bar, failed) -> None:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    # "spawn": a forked child would inherit a Rust thread pool whose threads it does not have.
    ctx = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_pool_worker_init, initargs=(threads,))
    pending: dict[Any, int] = {}
    try:
        for i in todo:
            pending[pool.submit(run_one, scene, combos[i], str(dirs[i]), threads, provs[i], reraise_interrupt=False)] = i
        left = set(pending)
        while left:
            finished, left = wait(left, timeout=0.5, return_when=FIRST_COMPLETED)
            for fut in finished:
                i = pending[fut]
                try:
                    rows[i] = fut.result()
                except Exception as e:
                    rows[i] = failed(i, e)
                if bar is not None:
                    bar.update(rows[i], running=sum(f.running() for f in left))
    except KeyboardInterrupt:
        # Queued runs are cancelled; running ones are told to stop (SIGINT: their Newton solve
        # stops within one iteration and they return partial rows); then the workers exit.
        for fut in pending:
            fut.cancel()
        for proc in list(getattr(pool, "_processes", {}).values()):
            try:
                os.kill(proc.pid, signal.SIGINT)
            except (OSError, AttributeError):
                pass
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _sweep_dask(client, scene, combos, provs, dirs, todo, rows, threads, bar, failed) -> None:
    import uuid

    import distributed

    info = client.scheduler_info()["workers"]
    slots: dict[str, int] = {}
    for addr, w in info.items():
        host = addr.rsplit(":", 1)[0]
        slots[host] = slots.get(host, 0) + int(w.get("nthreads", 1))
    cpus = os.cpu_count() or 1
    # Threads per run: the host's cores shared by the worker threads there (this machine's core
    # count stands for remote hosts' when their workers do not report theirs).
    by_host = {h: threads or max(1, cpus // n) for h, n in slots.items()}
    total_slots = max(1, sum(slots.values()))
    stop_name = f"thinshell-sweep-stop-{uuid.uuid4().hex}"
    stop = distributed.Event(stop_name, client=client)
    # A terminal's Ctrl-C reaches every process of its group: the workers and nannies of a
    # LocalCluster too, which would die printing tracebacks. They ignore it while the sweep
    # runs; the sweep tells their runs to stop through the Event instead.
    _set_worker_sigint(client, True)
    # By value: the scene's text and mesh, not paths on this machine; the same object for
    # every run (scattered once).
    packed = client.scatter(PackedScene.pack(scene), broadcast=True)
    futures = client.map(
        _dask_run,
        [packed] * len(todo),
        [combos[i] for i in todo],
        [dirs[i].name for i in todo],
        [by_host] * len(todo),
        [provs[i] for i in todo],
        [stop_name] * len(todo),
        pure=False,
    )
    index = {f.key: i for f, i in zip(futures, todo)}
    try:
        remaining = len(futures)
        for fut in distributed.as_completed(futures):
            i = index[fut.key]
            try:
                rows[i] = _receive(dirs[i], *fut.result())
            except Exception as e:
                rows[i] = failed(i, e)
            # Streamed: the run's files are on disk now; the cluster forgets them.
            fut.release()
            remaining -= 1
            if bar is not None:
                bar.update(rows[i], running=min(remaining, total_slots))
    except KeyboardInterrupt:
        # Told to stop rather than killed: the Event cancels running simulations (within one
        # Newton iteration); runs not started see it and return at once. What comes back within
        # a moment is written (partial runs: interrupted.json); the rest has no result.json and
        # runs again next time.
        _within(0.3, stop.set)

        def collect() -> None:
            # The runs that stop within a moment send their partial files (interrupted.json).
            distributed.wait(futures, timeout=0.5)
            for f in futures:
                i = index[f.key]
                if rows[i] is None and f.status == "finished":
                    rows[i] = _receive(dirs[i], *f.result(timeout=0.2))

        _within(0.8, collect)
        _within(0.2, lambda: client.cancel([f for f in futures if f.status == "pending"]))
        raise
    finally:
        _within(0.3, lambda: _set_worker_sigint(client, False))


def _receive(run_dir: Path, row: Row, files: Mapping[str, bytes]) -> Row:
    """Writes a run's files that came back by value into its directory (``result.json`` or
    ``interrupted.json`` last, as a run does); returns its row."""
    run_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("result.json", "interrupted.json"):
        (run_dir / stale).unlink(missing_ok=True)
    last = [n for n in files if n in ("result.json", "interrupted.json")]
    for name in [n for n in files if n not in last] + last:
        fd, tmp = tempfile.mkstemp(dir=run_dir, prefix=name, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(files[name])
        os.replace(tmp, run_dir / name)
    return row


def _within(seconds: float, fn: Callable[[], Any]) -> None:
    """``fn()`` in a daemon thread, given up after ``seconds``; exceptions ignored (a cluster
    going away while the sweep is interrupted must not hold up its return or print)."""

    def call() -> None:
        try:
            fn()
        except BaseException:
            pass

    t = threading.Thread(target=call, daemon=True)
    t.start()
    t.join(seconds)


#: In a Dask worker or nanny process: its own SIGINT handler while a sweep ignores the signal.
_saved_sigint: list[Any] = []


def _worker_sigint(ignore: bool) -> None:
    """Run in a Dask worker or nanny process (in its event loop's thread, the main one):
    ignore SIGINT, or restore the handler it had."""
    if threading.current_thread() is not threading.main_thread():
        return
    if ignore:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        if not _saved_sigint:
            _saved_sigint.append(previous)
    elif _saved_sigint:
        signal.signal(signal.SIGINT, _saved_sigint.pop())


def _set_worker_sigint(client: Any, ignore: bool) -> None:
    """Makes every worker and nanny process of ``client``'s cluster ignore SIGINT, or restores
    their handler (best effort: a cluster that does not answer is left as it is)."""
    for nanny in (False, True):
        try:
            client.run(_worker_sigint, ignore, nanny=nanny)
        except Exception:
            pass


def _write_results(out: Path, result: list[Row]) -> None:
    _write_atomic(out / "results.json", json.dumps(result, indent=2))
    fields: list[str] = []
    for r in result:
        fields += [k for k in r if k not in fields]
    with open(out / "results.csv.tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in result:
            w.writerow({k: (json.dumps(v) if isinstance(v, (list, dict)) else v) for k, v in r.items()})
    os.replace(out / "results.csv.tmp", out / "results.csv")


def _as_table(rows: list[Row], keys: list[str], frame: bool | None) -> Any:
    if frame is False:
        return rows
    try:
        import pandas as pd
    except ImportError:
        if frame:
            raise
        return rows
    df = pd.DataFrame(rows)
    df.attrs["units"] = dict(UNITS)
    df.attrs["parameters"] = list(keys)
    return df
