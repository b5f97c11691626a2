"""A sweep never returns runs of something else: the run id covers the scene after overrides,
the content of the files it reads and the package version; ``out_dir`` records what it holds.
Results come as a DataFrame with units; progress is reported; threads are shared out."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

import thinshell

GRID = {"initial.scale": [1.9, 1.95]}


def square(scenes: Path, *overrides: str) -> thinshell.Scene:
    return thinshell.Scene.from_file(scenes / "square_enlarged.toml", ["integrator.steps=3", *overrides])


def run(scene, out, **kw):
    kw.setdefault("max_workers", 1)
    kw.setdefault("frame", False)
    return thinshell.sweep(scene, GRID, out, **kw)


def test_out_dir_keeps_scene_version_and_grid(scenes, tmp_path):
    scene = square(scenes)
    rows = run(scene, tmp_path)
    meta = json.loads((tmp_path / "sweep.json").read_text())
    assert meta["version"] == thinshell.__version__
    assert meta["grid"] == GRID
    assert meta["scene_hash"] == f"{scene.scene_hash:016x}"
    assert (tmp_path / "scene.toml").read_text() == scene.resolved_toml
    for r in rows:
        d = tmp_path / r["run"]
        prov = json.loads((d / "provenance.json").read_text())
        assert prov["version"] == thinshell.__version__ and prov["params"] == {"initial.scale": r["initial.scale"]}
        # The run's scene.toml is the scene it ran: the base with its override applied.
        ran = thinshell.Scene.from_toml((d / "scene.toml").read_text())
        assert ran.resolved_toml == scene.with_overrides([f"initial.scale={r['initial.scale']!r}"]).resolved_toml


def test_another_scene_value_is_not_reused(scenes, tmp_path):
    first = run(square(scenes), tmp_path)
    assert not any(r["reused"] for r in first)
    assert all(r["reused"] for r in run(square(scenes), tmp_path)), "the same sweep is reused"
    # Another step count, another damping: new runs, with their own results.
    for ov in ["integrator.steps=4", "material.viscosity=0.5"]:
        rows = run(square(scenes, ov), tmp_path)
        assert not any(r["reused"] for r in rows), ov
        assert {r["run"] for r in rows}.isdisjoint({r["run"] for r in first}), ov
    rows = run(square(scenes, "integrator.steps=4"), tmp_path)
    assert all(r["steps"] == 4 and r["reused"] for r in rows)


def test_another_mesh_file_content_is_not_reused(scenes, tmp_path):
    mesh_path = tmp_path / "mesh.obj"
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.0]], float)
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    thinshell.Mesh(V, F).save_obj(mesh_path)
    scene_path = tmp_path / "scene.toml"
    scene_path.write_text(
        'effects = ["stretching", "bending"]\n[mesh]\nobj = "mesh.obj"\n[integrator]\nkind = "static"\nsteps = 1\n'
    )
    grid = {"initial.scale": [1.1]}
    out = tmp_path / "out"
    a = thinshell.sweep(thinshell.Scene.from_file(scene_path), grid, out, max_workers=1, frame=False)
    assert a[0]["status"] == "completed", a[0]["error"]
    b = thinshell.sweep(thinshell.Scene.from_file(scene_path), grid, out, max_workers=1, frame=False)
    assert b[0]["reused"] and b[0]["run"] == a[0]["run"]
    # Same scene text, same file name, other content (the centre vertex lifted).
    V[4, 2] = 0.1
    thinshell.Mesh(V, F).save_obj(mesh_path)
    c = thinshell.sweep(thinshell.Scene.from_file(scene_path), grid, out, max_workers=1, frame=False)
    assert not c[0]["reused"] and c[0]["run"] != a[0]["run"]
    assert c[0]["elastic_J"] != a[0]["elastic_J"]
    assert not np.array_equal(np.load(out / a[0]["run"] / "positions.npy"), np.load(out / c[0]["run"] / "positions.npy"))


def test_another_package_version_is_not_reused(scenes, tmp_path, monkeypatch):
    first = run(square(scenes), tmp_path)
    monkeypatch.setattr(thinshell, "__version__", thinshell.__version__ + ".post1")
    rows = run(square(scenes), tmp_path)
    assert not any(r["reused"] for r in rows)
    assert {r["run"] for r in rows}.isdisjoint({r["run"] for r in first})


def test_a_hand_edited_provenance_is_not_reused(scenes, tmp_path):
    first = run(square(scenes), tmp_path)
    p = tmp_path / first[0]["run"] / "provenance.json"
    prov = json.loads(p.read_text())
    prov["scene"] += "\n# edited"
    p.write_text(json.dumps(prov))
    rows = run(square(scenes), tmp_path)
    assert [r["reused"] for r in rows] == [False, True]


def test_on_mismatch_error_refuses_and_says_what_differs(scenes, tmp_path):
    run(square(scenes), tmp_path)
    with pytest.raises(thinshell.SweepMismatch, match="scene_hash"):
        run(square(scenes, "integrator.steps=4"), tmp_path, on_mismatch="error")
    with pytest.raises(thinshell.SweepMismatch, match="grid"):
        thinshell.sweep(square(scenes), {"initial.scale": [1.9]}, tmp_path, max_workers=1, on_mismatch="error")
    # The same sweep passes.
    assert all(r["reused"] for r in run(square(scenes), tmp_path, on_mismatch="error"))


def test_results_are_a_dataframe_with_units(scenes, tmp_path):
    pd = pytest.importorskip("pandas")
    df = thinshell.sweep(square(scenes), {"initial.scale": [1.9, 1.95], "material.young": [1e9, -1.0]}, tmp_path, max_workers=1)
    assert isinstance(df, pd.DataFrame) and len(df) == 4
    for col in ["run", "initial.scale", "material.young", "status", "error", "steps", "time_s", "stretch_J", "bend_J", "elastic_J", "newton_iterations", "stable", "wall_s", "threads", "reused"]:
        assert col in df.columns, col
    assert df.attrs["units"]["elastic_J"] == "J" and df.attrs["units"]["time_s"] == "s"
    assert df.attrs["parameters"] == ["initial.scale", "material.young"]
    assert list(df["status"]) == ["completed", "error", "completed", "error"]
    rows = thinshell.sweep(square(scenes), {"initial.scale": [1.9, 1.95], "material.young": [1e9, -1.0]}, tmp_path, max_workers=1, frame=False)
    assert isinstance(rows, list) and [r["elastic_J"] for r in rows][0] == df["elastic_J"].iloc[0]


def test_progress_callback_counts_runs(scenes, tmp_path):
    seen = []
    run(square(scenes), tmp_path, progress=seen.append)
    done = [s for s in seen if s["row"] is not None]
    assert [s["done"] for s in done] == [1, 2] and all(s["total"] == 2 for s in seen)
    assert done[-1]["eta_s"] == 0.0 and done[-1]["failed"] == 0
    # A resumed sweep starts at the reused count: one run new, one reused.
    seen.clear()
    thinshell.sweep(square(scenes), {"initial.scale": [1.9, 1.97]}, tmp_path, max_workers=1, progress=seen.append)
    done = [s for s in seen if s["row"] is not None]
    assert [(s["done"], s["reused"], s["total"]) for s in done] == [(2, 1, 2)]


def test_progress_bar(scenes, tmp_path, capsys):
    pytest.importorskip("tqdm")
    run(square(scenes), tmp_path, progress=True)
    err = capsys.readouterr().err
    assert "2/2" in err and "failed=0" in err, err


def test_pool_runs_get_a_share_of_the_cores(scenes, tmp_path):
    cpus = os.cpu_count() or 1
    rows = run(square(scenes), tmp_path, max_workers=2)
    assert all(r["threads"] == max(1, cpus // 2) for r in rows), rows
    rows = thinshell.sweep(square(scenes), {"initial.scale": [1.91, 1.92]}, tmp_path, max_workers=2, threads=3, frame=False)
    assert all(r["threads"] == 3 for r in rows)
    with pytest.raises(ValueError, match="threads"):
        run(square(scenes), tmp_path, threads=0)
