"""Scenes from files, TOML strings and dicts: errors carry exactly the CLI's message; a Python
run reproduces the CLI's run of the same file bit for bit."""

from __future__ import annotations

import pickle
import subprocess

import numpy as np
import pytest

import thinshell

GOOD = """
name = "tiny"
effects = ["stretching", "bending"]
[mesh]
generator = "seed_square"
[integrator]
kind = "static"
"""

BAD = {
    "syntax": GOOD + "[material\n",
    "unknown key": GOOD + "[material]\nthicknes = 1e-4\n",
    "wrong type": GOOD + "[material]\nthickness = \"thin\"\n",
    "bad value": GOOD + "[material]\npoisson = 0.7\n",
    "unknown generator": GOOD.replace("seed_square", "seed_squar"),
    # Only the built mesh can check this one (a build error, not a validation error).
    "vertex out of range": GOOD + "[[boundary.pins]]\nregion = { vertices = [100000] }\n",
}


def cli_message(cli, path, *args):
    p = subprocess.run([str(cli), "check", str(path), *args], capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    prefix = "thinshell: error: "
    assert p.stderr.startswith(prefix), p.stderr
    return p.stderr[len(prefix):].rstrip("\n")


@pytest.mark.parametrize("case", sorted(BAD))
def test_scene_errors_are_the_cli_messages(cli, tmp_path, case):
    path = tmp_path / "scene.toml"
    path.write_text(BAD[case])
    expected = cli_message(cli, path)
    with pytest.raises(thinshell.SceneError) as e:
        thinshell.Simulation(thinshell.Scene.from_file(path))
    assert str(e.value) == expected
    # The same text from a string, named as the file: the same message.
    with pytest.raises(thinshell.SceneError) as e:
        thinshell.Simulation(thinshell.Scene.from_toml(BAD[case], origin=str(path)))
    assert str(e.value) == expected


def test_override_errors_are_the_cli_messages(cli, tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(GOOD)
    for ov in ["material.poisson=0.7", "mesh=3", "noequals"]:
        expected = cli_message(cli, path, "--set", ov)
        with pytest.raises(thinshell.SceneError) as e:
            thinshell.Scene.from_file(path, [ov])
        assert str(e.value) == expected


def test_missing_file_is_the_cli_message(cli, tmp_path):
    path = tmp_path / "nope.toml"
    expected = cli_message(cli, path)
    with pytest.raises(thinshell.SceneError) as e:
        thinshell.Scene.from_file(path)
    assert str(e.value) == expected


def test_mesh_file_errors_are_mesh_errors(cli, tmp_path):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    path = tmp_path / "scene.toml"
    path.write_text(GOOD.replace('generator = "seed_square"', 'obj = "m.obj"'))
    expected = cli_message(cli, path)
    with pytest.raises(thinshell.MeshError) as e:
        thinshell.Simulation(path)
    assert str(e.value) == expected


def test_dict_scenes_name_the_key_path():
    scene = {"effects": ["stretching", "bending"], "mesh": {"generator": "seed_square"}, "integrator": {"kind": "static"}}
    assert thinshell.Scene.from_dict(scene).name == "<dict>"
    bad = {**scene, "material": {"poisson": 0.7}}
    with pytest.raises(thinshell.SceneError, match=r"^<dict>:\d+:\d+: `material.poisson` "):
        thinshell.Scene.from_dict(bad)
    bad = {**scene, "boundary": {"pins": [{"region": {"vertices": [0]}, "axes": "xq"}]}}
    with pytest.raises(thinshell.SceneError, match=r"`boundary.pins\[0\].axes`"):
        thinshell.Scene.from_dict(bad)
    with pytest.raises(TypeError, match="`mesh.generator` has a value of type object"):
        thinshell.Scene.from_dict({**scene, "mesh": {"generator": object()}})


def test_dict_toml_and_file_scenes_are_the_same(scenes):
    import tomllib

    path = scenes / "square_rhombus.toml"
    text = path.read_text()
    sims = [
        thinshell.Simulation(thinshell.Scene.from_file(path, ["integrator.steps=3"])),
        thinshell.Simulation(thinshell.Scene.from_toml(text, ["integrator.steps=3"])),
        thinshell.Simulation(thinshell.Scene.from_dict(tomllib.loads(text), ["integrator.steps=3"])),
    ]
    for s in sims:
        s.run()
    assert all(np.array_equal(s.positions, sims[0].positions) for s in sims[1:])


def test_scenes_pickle(scenes):
    s = thinshell.Scene.from_file(scenes / "square_rhombus.toml", ["integrator.steps=3"])
    t = pickle.loads(pickle.dumps(s))
    assert (t.name, t.overrides, t.toml, t.base_dir) == (s.name, s.overrides, s.toml, s.base_dir)


def read_obj_positions(path):
    rows = [line.split()[1:] for line in path.read_text().splitlines() if line.startswith("v ")]
    return np.array([[float(c) for c in r] for r in rows])


@pytest.mark.parametrize(
    "scene,steps",
    [("square_enlarged.toml", 12), ("moisture_curl.toml", 3), ("cylinder_directors.toml", 2)],
)
def test_python_run_equals_cli_run_bit_for_bit(cli, scenes, tmp_path, scene, steps):
    # The CLI writes OBJ coordinates with Rust's shortest round-trip formatting, so parsing
    # them gives the exact f64 bits.
    src = (scenes / scene).read_text()
    path = tmp_path / scene
    path.write_text(src)
    over = [f"integrator.steps={steps}", 'output.formats=["obj"]', f"output.every={steps}"]
    args = [str(cli), "run", str(path), "--quiet", "--out", str(tmp_path / "out")]
    for o in over:
        args += ["--set", o]
    subprocess.run(args, check=True, capture_output=True)
    cli_x = read_obj_positions(tmp_path / "out" / f"frame_{steps:06d}.obj")

    sim = thinshell.Simulation(thinshell.Scene.from_file(path, over))
    summary = sim.run()
    assert summary["steps"] == steps
    assert cli_x.shape == sim.positions.shape
    assert np.array_equal(cli_x, sim.positions), np.abs(cli_x - sim.positions).max()


def test_mesh_obstacle_paths_resolve_like_the_cli(cli, scenes, tmp_path):
    # A `kind = "mesh"` obstacle's OBJ path is relative to the scene file, or to `base_dir` for
    # text and dict scenes: the shipped scene run from its file and as a dict gives the same
    # positions, and a missing OBJ is the CLI's error (a SceneError naming the key and file).
    import tomllib

    path = scenes / "sheet_on_pyramid.toml"
    text = path.read_text()
    a = thinshell.Simulation(thinshell.Scene.from_file(path, ["integrator.steps=3"]))
    b = thinshell.Simulation(
        thinshell.Scene.from_dict(tomllib.loads(text), ["integrator.steps=3"], base_dir=scenes)
    )
    a.run()
    b.run()
    assert np.all(np.isfinite(a.positions)) and np.array_equal(a.positions, b.positions)
    moved = tmp_path / "scene.toml"
    moved.write_text(text)
    expected = cli_message(cli, moved)
    assert "contact.obstacles[0].path" in expected and "pyramid.obj" in expected
    with pytest.raises(thinshell.SceneError) as e:
        thinshell.Simulation(moved)
    assert str(e.value) == expected
