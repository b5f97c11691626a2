"""State a script can set and keep: positions and velocities, meshes as arrays in a scene dict,
checkpoints (the CLI's format) that continue bit for bit, pickling, snapshots readable while
another thread runs the simulation; steps past the scene's end are refused; the package imports
from the python/ folder (src layout)."""

from __future__ import annotations

import pickle
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import thinshell

PYTHON_DIR = Path(__file__).resolve().parents[1]


def square(scenes, steps=6):
    return thinshell.Scene.from_file(scenes / "square_enlarged.toml", [f"integrator.steps={steps}"])


def test_set_positions_and_velocities_round_trip(scenes):
    sim = thinshell.Simulation(square(scenes))
    x = sim.reference_positions * 1.9
    v = np.full_like(x, 0.25)
    sim.set_positions(x)
    sim.set_velocities(v)
    assert np.array_equal(sim.positions, x) and np.array_equal(sim.velocities, v)
    # The energies are those of the new state: the scene started at scale 1.9 (instead of the
    # file's 1.95) has the same positions and, built independently, the same energies.
    ref = thinshell.Simulation(thinshell.Scene.from_file(scenes / "square_enlarged.toml", ["integrator.steps=6", "initial.scale=1.9"]))
    assert np.allclose(ref.positions, x, rtol=1e-15, atol=1e-15)
    assert sim.energies["stretch"] == pytest.approx(ref.energies["stretch"], rel=1e-12)
    assert sim.energies["bend"] == pytest.approx(ref.energies["bend"], rel=1e-12, abs=1e-18)
    mass = sim.energies["kinetic"] / (0.5 * 3 * 0.25**2)
    assert mass > 0  # the kinetic energy is of the new velocities: 1/2 M |v|^2
    # The next step starts from them: the initial velocity moves the shell against ref's.
    sim.step()
    ref.step()
    assert not np.array_equal(sim.positions, ref.positions)


def test_bad_state_is_a_clear_error(scenes):
    sim = thinshell.Simulation(square(scenes))
    x = sim.positions
    with pytest.raises(ValueError, match=r"positions: expected shape \(n, 3\)"):
        sim.set_positions(x[:, :2])
    with pytest.raises(thinshell.SimulationError, match="positions: 3 vectors given, the mesh has"):
        sim.set_positions(x[:3])
    bad = x.copy()
    bad[2, 1] = np.nan
    with pytest.raises(thinshell.SimulationError, match="positions: vertex 2 is not finite"):
        sim.set_positions(bad)
    with pytest.raises(thinshell.SimulationError, match="velocities: vertex 2 is not finite"):
        sim.set_velocities(bad)
    assert np.array_equal(sim.positions, x), "unchanged after an error"


def test_mesh_arrays_and_mesh_objects_in_a_scene_dict(scenes, tmp_path, monkeypatch):
    monkeypatch.setenv("THINSHELL_CACHE_DIR", str(tmp_path / "cache"))
    base = thinshell.Simulation(square(scenes))
    V, F = base.reference_positions, base.faces
    scene = {"effects": ["stretching", "bending"], "integrator": {"kind": "static", "steps": 2}, "initial": {"scale": 1.5}}
    by_arrays = thinshell.Simulation({**scene, "mesh": {"vertices": V, "faces": F}})
    by_mesh = thinshell.Simulation({**scene, "mesh": thinshell.Mesh(V, F)})
    by_generator = thinshell.Simulation({**scene, "mesh": {"generator": "seed_square"}})
    for s in (by_arrays, by_mesh, by_generator):
        s.run()
    assert np.array_equal(by_arrays.reference_positions, V) and np.array_equal(by_arrays.faces, F)
    # The same mesh given three ways is the same simulation, bit for bit.
    assert np.array_equal(by_arrays.positions, by_generator.positions)
    assert np.array_equal(by_mesh.positions, by_generator.positions)
    files = list((tmp_path / "cache" / "meshes").glob("mesh-*.obj"))
    assert len(files) == 1, "one file per mesh content"
    with pytest.raises(TypeError, match="only `vertices` and `faces`"):
        thinshell.Simulation({**scene, "mesh": {"vertices": V, "faces": F, "normals": V}})
    with pytest.raises(thinshell.MeshError):
        thinshell.Simulation({**scene, "mesh": {"vertices": V, "faces": F + 1000}})


def test_checkpoint_restore_equals_an_uninterrupted_run(scenes, tmp_path):
    straight = thinshell.Simulation(square(scenes))
    straight.run()
    first = thinshell.Simulation(square(scenes))
    for _ in range(3):
        first.step()
    first.save(tmp_path / "ck.bin")
    second = thinshell.Simulation(square(scenes))
    second.restore(tmp_path / "ck.bin")
    assert second.steps_done == 3 and np.array_equal(second.positions, first.positions)
    second.run()
    assert np.array_equal(second.positions, straight.positions)
    assert np.array_equal(second.velocities, straight.velocities)
    assert second.summary["newton_iterations"] == straight.summary["newton_iterations"]
    # Another scene's checkpoint is refused, the simulation unchanged.
    other = thinshell.Simulation(square(scenes, steps=7))
    with pytest.raises(thinshell.SimulationError, match="belongs to another scene"):
        other.restore(tmp_path / "ck.bin")
    assert other.steps_done == 0


def test_a_cli_checkpoint_restores_into_python(cli, scenes, tmp_path):
    out = tmp_path / "run"
    # 3 steps with a checkpoint every 2: the checkpoint holds step 2.
    p = subprocess.run(
        [str(cli), "run", str(scenes / "square_enlarged.toml"), "--set", "integrator.steps=6", "--out", str(out), "--quiet", "--checkpoint-every", "2"],
        capture_output=True, text=True,
    )
    assert p.returncode == 0, p.stderr
    if not (out / "checkpoint.bin").exists():
        pytest.skip("the CLI removes its checkpoint at the end of a complete run")
    sim = thinshell.Simulation(square(scenes))
    sim.restore(out / "checkpoint.bin")
    k = sim.steps_done
    ref = thinshell.Simulation(square(scenes))
    for _ in range(k):
        ref.step()
    assert np.array_equal(sim.positions, ref.positions)


def test_pickling_goes_through_the_checkpoint(scenes):
    sim = thinshell.Simulation(square(scenes))
    sim.step()
    sim.step()
    copy = pickle.loads(pickle.dumps(sim))
    assert copy.steps_done == 2 and np.array_equal(copy.positions, sim.positions)
    assert copy.summary["newton_iterations"] == sim.summary["newton_iterations"]
    sim.run()
    copy.run()
    assert np.array_equal(copy.positions, sim.positions)
    data = sim.to_bytes()
    assert data[:8] == b"TSHELLCK"
    again = thinshell.Simulation.from_bytes(square(scenes), data)
    assert np.array_equal(again.positions, sim.positions)


def test_snapshots_are_readable_while_another_thread_runs(scenes):
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "sphere_uniform_heat.toml", ["mesh.level=3", "integrator.steps=30"]))
    reads, errors = [], []
    runner = threading.Thread(target=sim.run)
    runner.start()
    while runner.is_alive():
        try:
            snap = sim.snapshot()
            x = sim.positions
            reads.append((snap["step"], snap["positions"], x))
        except Exception as e:  # noqa: BLE001 - every failure counts
            errors.append(repr(e))
    runner.join()
    assert errors == []
    assert len(reads) >= 10 and reads[0][0] < 30
    snap = sim.snapshot()
    assert snap["step"] == 30 and np.array_equal(snap["positions"], sim.positions)
    assert not snap["positions"].flags.writeable
    with pytest.raises(ValueError):
        snap["positions"][0, 0] = 1.0
    # Each read is a state the run went through (steps are monotone).
    steps = [r[0] for r in reads]
    assert steps == sorted(steps)


def test_steps_past_the_scene_are_refused(scenes):
    sim = thinshell.Simulation(square(scenes, steps=2))
    sim.run()
    with pytest.raises(thinshell.SimulationError, match="all 2 steps of the scene are done"):
        sim.step()
    assert sim.steps_done == 2 and sim.summary["status"] == "completed"
    sim.run()  # nothing left: returns the summary
    assert sim.steps_done == 2


def test_terms_as_one_string(scenes):
    sim = thinshell.Simulation(square(scenes))
    a = thinshell.energy(sim.positions, sim.faces, sim.reference_positions * 0.9, terms="bending", hessian=False)
    b = thinshell.energy(sim.positions, sim.faces, sim.reference_positions * 0.9, terms=["bending"], hessian=False)
    assert a.energy == b.energy and a.stretch == 0.0


def test_the_package_imports_from_the_python_folder():
    # src layout: python/ holds no `thinshell` folder that would shadow the installed package.
    p = subprocess.run([sys.executable, "-c", "import thinshell, sys; print(thinshell.__file__); thinshell.Simulation"], cwd=PYTHON_DIR, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "_thinshell" not in p.stderr
    names = subprocess.run([sys.executable, "-c", "import thinshell; print(' '.join(n for n in dir(thinshell) if not n.startswith('_')))"], cwd=PYTHON_DIR, capture_output=True, text=True).stdout.split()
    assert "np" not in names and "Mapping" not in names and "annotations" not in names, names


def test_output_is_what_the_cli_writes(cli, scenes, tmp_path):
    overrides = ["integrator.steps=6", "output.every=2", 'output.formats=["obj", "vtk"]']
    args = [a for ov in overrides for a in ("--set", ov)]
    p = subprocess.run([str(cli), "run", str(scenes / "square_enlarged.toml"), "--out", str(tmp_path / "cli"), "--quiet", *args], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "square_enlarged.toml", overrides), output=tmp_path / "py")
    assert (tmp_path / "py" / "frame_000000.obj").exists() and not (tmp_path / "py" / "summary.json").exists()
    sim.run()
    cli_files = sorted(q.name for q in (tmp_path / "cli").iterdir())
    py_files = sorted(q.name for q in (tmp_path / "py").iterdir())
    assert py_files == cli_files and "frames.pvd" in py_files and "frame_000006.vtu" in py_files
    for name in py_files:
        if name.endswith(".obj") or name == "frames.pvd":
            assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    timing = set(thinshell_timing_columns())
    import csv

    def rows(d):
        with open(d / "steps.csv") as f:
            return [{k: v for k, v in r.items() if k not in timing} for r in csv.DictReader(f)]

    assert rows(tmp_path / "py") == rows(tmp_path / "cli") and len(rows(tmp_path / "py")) == 6
    import json

    a = json.loads((tmp_path / "py" / "summary.json").read_text())
    b = json.loads((tmp_path / "cli" / "summary.json").read_text())
    for k in ("wall_s", "scene"):
        a.pop(k), b.pop(k)
    assert a == b and a["status"] == "completed" and a["frames"] == 4


def thinshell_timing_columns():
    return ["wall_s", "assembly_s", "factorization_s", "solve_s", "line_search_s", "growth_s", "output_s", "other_s"]


@pytest.mark.parametrize("where", ["python", "elsewhere"])
def test_pytest_collects_from_python_and_from_elsewhere(where, tmp_path):
    cwd, target = (PYTHON_DIR, "tests/test_energy.py") if where == "python" else (tmp_path, str(PYTHON_DIR / "tests" / "test_energy.py"))
    p = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", target], cwd=cwd, capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "error" not in p.stdout.lower(), p.stdout


def test_obj_quads_load_as_two_triangles(tmp_path):
    # As Mesh.from_obj documents: polygons are split into triangles from their first vertex.
    p = tmp_path / "quad.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    m = thinshell.Mesh.from_obj(p)
    assert m.n_faces == 2 and sorted(map(sorted, m.faces.tolist())) == [[0, 1, 2], [0, 2, 3]]
    assert "split into triangles" in thinshell.Mesh.from_obj.__doc__
