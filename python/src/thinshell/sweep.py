"""Parameter sweeps: every combination of a grid of scene values, run locally in a process pool
or on a Dask cluster, resumable.

Each run writes into its own directory under ``out_dir`` (named by a hash of its parameters):
``positions.npy`` (final positions, n x 3, m), ``summary.json`` (the simulation summary) and,
last and atomically, ``result.json`` (its row). A run whose ``result.json`` exists is complete
and is not run again, so an interrupted sweep is resumed by calling :func:`sweep` again with the
same arguments. ``results.json`` and ``results.csv`` in ``out_dir`` hold all rows at the end.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

__all__ = ["sweep", "toml_literal"]

Row = dict[str, Any]


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


def _run_id(params: Mapping[str, Any]) -> str:
    text = json.dumps({k: _plain(v) for k, v in params.items()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


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


def run_one(scene: Any, params: Mapping[str, Any], run_dir: str) -> Row:
    """One run of a sweep: the scene with ``params`` applied as overrides, run to the end.
    Never raises: a failure (bad value, failed step, anything) becomes a row with status
    ``"error"``. Writes the run's files, ``result.json`` last."""
    from . import Simulation, ThinshellError  # in a worker process

    t0 = time.perf_counter()
    out = Path(run_dir)
    out.mkdir(parents=True, exist_ok=True)
    row: Row = {"run": out.name, **{k: _plain(v) for k, v in params.items()}}
    metrics: Row = {
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
    try:
        overrides = [f"{k}={toml_literal(v)}" for k, v in params.items()]
        sim = Simulation(scene.with_overrides(overrides))
        try:
            summary = sim.run()
        finally:
            summary_now = sim.summary
            np.save(out / "positions.npy", sim.positions)
            _write_atomic(out / "summary.json", json.dumps(summary_now, indent=2))
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
    except ThinshellError as e:
        metrics["error"] = f"{type(e).__name__}: {e}"
    except Exception as e:  # a sweep never crashes on one run
        metrics["error"] = f"{type(e).__name__}: {e}\n{traceback.format_exc()}"
    row.update(metrics)
    row["wall_s"] = time.perf_counter() - t0
    _write_atomic(out / "result.json", json.dumps(row, indent=2))
    return row


def _load_complete(run_dir: Path, params: Mapping[str, Any]) -> Row | None:
    try:
        row = json.loads((run_dir / "result.json").read_text())
    except (OSError, ValueError):
        return None
    if any(row.get(k) != _plain(v) for k, v in params.items()):
        return None  # a hash collision or a hand-edited file: run it again
    return row


def sweep(
    scene: Any,
    grid: Mapping[str, Sequence[Any]],
    out_dir: "str | os.PathLike[str]",
    client: Any = None,
    *,
    max_workers: int | None = None,
) -> list[Row]:
    """Runs every combination of ``grid`` on ``scene`` and returns one row per run.

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
        ``if __name__ == "__main__":`` guard (notebooks need nothing).

    Returns
    -------
    One dict per run, in grid order: ``run`` (its directory name), the parameters, ``status``
    ("completed", "interrupted" or "error"), ``error`` (the message, None if it ran),
    ``steps``, ``time_s`` (s), ``stretch_J``, ``bend_J``, ``elastic_J`` (J),
    ``newton_iterations``, ``stable``, ``wall_s`` (s, the run's wall time), and ``reused``
    (True when the run was complete in ``out_dir`` already and was not run again).
    """
    from . import load_scene

    scene = load_scene(scene)
    keys = list(grid)
    for k in keys:
        if isinstance(grid[k], (str, bytes)) or not isinstance(grid[k], Sequence | np.ndarray):
            raise TypeError(f"sweep: grid[{k!r}] must be a list of values")
    combos = [dict(zip(keys, values)) for values in itertools.product(*(list(grid[k]) for k in keys))]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dirs = [out / f"run-{_run_id(p)}" for p in combos]

    rows: list[Row | None] = [None] * len(combos)
    todo: list[int] = []
    for i, (p, d) in enumerate(zip(combos, dirs)):
        done = _load_complete(d, p)
        if done is not None:
            rows[i] = {**done, "reused": True}
        else:
            todo.append(i)

    def failed(i: int, e: BaseException) -> Row:
        # The worker died (killed, out of memory): no result.json, so a resume runs it again.
        return {
            "run": dirs[i].name,
            **{k: _plain(v) for k, v in combos[i].items()},
            "status": "error",
            "error": f"worker failed: {type(e).__name__}: {e}",
            "wall_s": None,
        }

    if client is not None:
        futures = client.map(
            run_one,
            [scene] * len(todo),
            [combos[i] for i in todo],
            [str(dirs[i]) for i in todo],
            pure=False,
        )
        for i, fut in zip(todo, futures):
            try:
                rows[i] = fut.result()
            except Exception as e:
                rows[i] = failed(i, e)
    elif max_workers == 1 or len(todo) <= 1:
        for i in todo:
            rows[i] = run_one(scene, combos[i], str(dirs[i]))
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # "spawn": a forked child would inherit a Rust thread pool whose threads it does not have.
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=max_workers, mp_context=ctx) as pool:
            pending = {i: pool.submit(run_one, scene, combos[i], str(dirs[i])) for i in todo}
            for i, fut in pending.items():
                try:
                    rows[i] = fut.result()
                except Exception as e:
                    rows[i] = failed(i, e)
    result: list[Row] = []
    for r in rows:
        assert r is not None
        r.setdefault("reused", False)
        result.append(r)
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
    return result
