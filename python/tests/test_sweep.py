"""Sweeps: a Dask LocalCluster gives exactly the serial results, a bad run is an error row,
and an interrupted sweep resumes with only the missing runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import thinshell

# 3 × 3 = 9 runs of a short dynamic run of the seed's enlarged square; E = -1 Pa is invalid, so
# the three runs with it are error rows.
GRID = {"initial.scale": [1.9, 1.95, 1.98], "material.young": [1e9, 2e9, -1.0]}
OVERRIDES = ["integrator.steps=6"]

TIMING = {"wall_s", "reused", "threads"}


def base_scene(scenes: Path) -> thinshell.Scene:
    return thinshell.Scene.from_file(scenes / "square_enlarged.toml", OVERRIDES)


def comparable(rows):
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    from conftest import SCENES

    out = tmp_path_factory.mktemp("serial")
    return out, thinshell.sweep(base_scene(SCENES), GRID, out, max_workers=1, frame=False)


def test_rows_errors_and_files(serial):
    out, rows = serial
    assert len(rows) == 9
    bad = [r for r in rows if r["material.young"] == -1.0]
    good = [r for r in rows if r["material.young"] != -1.0]
    assert len(bad) == 3 and all(r["status"] == "error" for r in bad)
    for r in bad:
        assert r["error"].startswith("SceneError: ") and "`material.young`" in r["error"], r["error"]
    assert all(r["status"] == "completed" and r["error"] is None and r["steps"] == 6 for r in good)
    # One simulation by hand equals its row.
    r = good[0]
    sim = thinshell.Simulation(base_scene(thinshell_scenes()).with_overrides([f"initial.scale={r['initial.scale']!r}", f"material.young={r['material.young']!r}"]))
    s = sim.run()
    assert r["elastic_J"] == s["energy"]["stretch"] + s["energy"]["bend"]
    assert np.array_equal(np.load(out / r["run"] / "positions.npy"), sim.positions)
    assert json.loads((out / "results.json").read_text())[0]["run"] == rows[0]["run"]
    assert (out / "results.csv").read_text().count("\n") == 10


def thinshell_scenes() -> Path:
    from conftest import SCENES

    return SCENES


def test_local_cluster_gives_the_serial_results(serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    out, rows = serial
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            dask_rows = thinshell.sweep(base_scene(thinshell_scenes()), GRID, tmp_path, client=client, frame=False)
    assert comparable(dask_rows) == comparable(rows)
    for r in rows:
        if r["status"] == "completed":
            a = np.load(out / r["run"] / "positions.npy")
            b = np.load(tmp_path / r["run"] / "positions.npy")
            assert np.array_equal(a, b)


def test_process_pool_gives_the_serial_results(serial, tmp_path):
    out, rows = serial
    assert comparable(thinshell.sweep(base_scene(thinshell_scenes()), GRID, tmp_path, max_workers=2, frame=False)) == comparable(rows)


KILLABLE = r"""
import sys, thinshell
scene = thinshell.Scene.from_file(sys.argv[1], ["integrator.steps=40"])
thinshell.sweep(scene, {"initial.scale": [1.9, 1.92, 1.94, 1.96, 1.98, 1.99], "material.young": [2e9]}, sys.argv[2], max_workers=1, frame=False)
"""


def test_an_interrupted_sweep_resumes_with_the_missing_runs(serial, tmp_path):
    out, _ = serial
    scene = thinshell_scenes() / "square_enlarged.toml"
    child = subprocess.Popen([sys.executable, "-c", KILLABLE, str(scene), str(tmp_path)])
    try:
        deadline = time.time() + 120
        while len(list(tmp_path.glob("run-*/result.json"))) < 2:
            assert child.poll() is None, "the sweep ended before it could be interrupted"
            assert time.time() < deadline
            time.sleep(0.02)
        child.send_signal(signal.SIGKILL)
        child.wait()
    finally:
        if child.poll() is None:
            child.kill()
    done_before = {p.parent.name: p.stat().st_mtime_ns for p in tmp_path.glob("run-*/result.json")}
    assert 2 <= len(done_before) < 6, done_before
    rows = thinshell.sweep(
        thinshell.Scene.from_file(scene, ["integrator.steps=40"]),
        {"initial.scale": [1.9, 1.92, 1.94, 1.96, 1.98, 1.99], "material.young": [2e9]},
        tmp_path,
        max_workers=1,
        frame=False,
    )
    assert len(rows) == 6 and all(r["status"] == "completed" for r in rows)
    reused = {r["run"] for r in rows if r["reused"]}
    assert reused == set(done_before), "exactly the complete runs are skipped"
    for name, mtime in done_before.items():
        assert (tmp_path / name / "result.json").stat().st_mtime_ns == mtime, "not run again"
    # A second call runs nothing.
    again = thinshell.sweep(thinshell.Scene.from_file(scene, ["integrator.steps=40"]), {"initial.scale": [1.9, 1.92, 1.94, 1.96, 1.98, 1.99], "material.young": [2e9]}, tmp_path, max_workers=1, frame=False)
    assert all(r["reused"] for r in again)
    assert comparable(again) == comparable(rows)


def test_a_cluster_of_other_machines_gives_the_serial_results(tmp_path):
    """Issue 42: a scene travels by value. The client's scene file and its OBJ mesh are
    packed and then deleted; the workers have their own HOME, cache directory, temporary and
    working directories. The Dask sweep equals a serial sweep of the same packed scene, row for
    row and position for position, and its files come back into the client's out_dir."""
    import shutil

    distributed = pytest.importorskip("distributed")
    client_files = tmp_path / "client"
    client_files.mkdir()
    shutil.copy(thinshell_scenes().parent / "meshes" / "seed_square.obj", client_files / "sheet.obj")
    (client_files / "scene.toml").write_text(
        'effects = ["stretching", "bending", "inertia"]\n'
        '[mesh]\nobj = "sheet.obj"\n'
        "[initial]\nscale = 1.9\n"
        '[integrator]\nkind = "implicit"\ndt = 1e-3\nsteps = 4\n'
    )
    packed = thinshell.PackedScene.pack(client_files / "scene.toml")
    shutil.rmtree(client_files)  # nothing of the client's files is left to read
    grid = {"material.young": [1e9, 2e9], "integrator.dt": [1e-3, 2e-3]}
    serial = thinshell.sweep(packed, grid, tmp_path / "serial", max_workers=1, frame=False)
    assert all(r["status"] == "completed" for r in serial), serial
    homes = {}
    for k in ("home", "cache", "tmp", "cwd"):
        homes[k] = tmp_path / "worker" / k
        homes[k].mkdir(parents=True)
    env = {"HOME": str(homes["home"]), "THINSHELL_CACHE_DIR": str(homes["cache"]), "TMPDIR": str(homes["tmp"])}
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        env=env, local_directory=str(homes["tmp"]),
    ) as cluster:
        with distributed.Client(cluster) as client:
            client.run(os.chdir, str(homes["cwd"]))
            assert set(client.run(os.getcwd).values()) == {str(homes["cwd"])}
            assert set(client.run(os.path.expanduser, "~").values()) == {str(homes["home"])}
            rows = thinshell.sweep(packed, grid, tmp_path / "dask", client=client, frame=False)
    assert comparable(rows) == comparable(serial)
    for r in serial:
        a = np.load(tmp_path / "serial" / r["run"] / "positions.npy")
        b = np.load(tmp_path / "dask" / r["run"] / "positions.npy")
        assert np.array_equal(a, b)
        assert (tmp_path / "dask" / r["run"] / "result.json").exists()
    # The workers wrote nothing outside their own temporary directory.
    assert not any(homes["cwd"].iterdir()) and not any(homes["home"].iterdir())
