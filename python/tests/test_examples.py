"""The two examples run (short) and write what they say: the curvature plot and a VTU series
that meshio reads back with the simulation's own numbers."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_moisture_curl_plots_curvature(tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "k.png"
    p = subprocess.run([sys.executable, str(EXAMPLES / "moisture_curl.py"), "--steps", "6", "--out", str(png)], check=True, capture_output=True, text=True)
    assert png.stat().st_size > 1000
    t, k = np.loadtxt(tmp_path / "k.csv", delimiter=",", skiprows=1).T
    # The printout names the curvature of largest magnitude (negative here) and its time.
    peak = int(np.argmax(np.abs(k)))
    assert f"peak curvature {k[peak]:.2f} 1/m at t = {t[peak]:.1f} s" in p.stdout, p.stdout
    assert k[peak] < 0
    assert len(t) == 7 and t[0] == 0.0 and k[0] == 0.0
    # The wet top swells: the strip curls (towards -z for a top that grows), bounded by the
    # natural curvature c*dm/h = 20 1/m.
    assert 0.5 < np.abs(k[1:]).max() < 20.0


def test_shrinking_sphere_writes_a_vtu_series(tmp_path):
    meshio = pytest.importorskip("meshio")
    import thinshell

    subprocess.run([sys.executable, str(EXAMPLES / "shrinking_sphere.py"), "--steps", "4", "--every", "2", "--out", str(tmp_path)], check=True, capture_output=True)
    names = sorted(p.name for p in tmp_path.glob("*.vtu"))
    assert names == ["frame_000000.vtu", "frame_000002.vtu", "frame_000004.vtu"]
    assert (tmp_path / "frames.pvd").read_text().count("<DataSet") == 3
    m = meshio.read(tmp_path / "frame_000004.vtu")
    sim = thinshell.Simulation(thinshell.Scene.from_file(Path(__file__).resolve().parents[2] / "data/scenes/sphere_uniform_heat.toml", ["integrator.steps=4"]))
    sim.run()
    assert np.allclose(m.points, sim.positions, rtol=1e-12, atol=0)
    assert np.array_equal(m.cells_dict["triangle"], sim.faces)
    assert np.allclose(m.point_data["displacement"], sim.positions - sim.reference_positions, rtol=1e-12, atol=1e-15)
