"""numpy in, numpy out: shapes, dtypes and exact round trips."""

from __future__ import annotations

import numpy as np
import pytest

import thinshell


def grid_mesh(nx: int = 4, ny: int = 3) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 0.5, ny + 1))
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    F = []
    for j in range(ny):
        for i in range(nx):
            a, b = j * (nx + 1) + i, j * (nx + 1) + i + 1
            c, d = a + nx + 1, b + nx + 1
            F += [[a, b, d], [a, d, c]]
    return V, np.array(F)


def test_mesh_round_trip_is_exact():
    V, F = grid_mesh()
    V = V + 1e-3 * np.random.default_rng(1).standard_normal(V.shape)
    m = thinshell.Mesh(V, F.astype(np.int32))
    assert m.vertices.dtype == np.float64 and m.faces.dtype == np.int64
    assert np.array_equal(m.vertices, V) and np.array_equal(m.faces, F)
    assert (m.n_vertices, m.n_faces) == (20, 24)
    assert m.n_edges == 20 + 24 - 1  # Euler: V - E + F = 1 for a disc
    assert m.flipped_faces == [] and np.array_equal(m.vertex_map, np.arange(20))


def test_mesh_reports_what_it_fixed():
    V, F = grid_mesh()
    F = F.copy()
    F[5] = F[5][[0, 2, 1]]
    V = np.vstack([V, [[9.0, 9.0, 9.0]]])  # unused
    m = thinshell.Mesh(V, F)
    assert m.flipped_faces == [5]
    assert m.vertex_map[-1] == -1 and m.n_vertices == 20


def test_obj_round_trip(tmp_path):
    V, F = grid_mesh()
    m = thinshell.Mesh(V, F)
    p = tmp_path / "m.obj"
    m.save_obj(p, V * 2.0)
    back = thinshell.Mesh.from_obj(p)
    assert np.array_equal(back.vertices, V * 2.0) and np.array_equal(back.faces, F)


def test_bad_arrays_are_clear_errors():
    V, F = grid_mesh()
    with pytest.raises(ValueError, match=r"vertices: expected shape \(n, 3\), got \(20, 2\)"):
        thinshell.Mesh(V[:, :2], F)
    with pytest.raises(TypeError, match="faces: expected an integer array"):
        thinshell.Mesh(V, F.astype(float))
    with pytest.raises(thinshell.MeshError, match="negative index"):
        thinshell.Mesh(V, -F)
    bad = V.copy()
    bad[3, 1] = np.nan
    with pytest.raises(thinshell.MeshError, match="vertex 3"):
        thinshell.Mesh(bad, F)
    with pytest.raises(thinshell.MeshError) as e:
        thinshell.Mesh(V, np.vstack([F, [[0, 1, 99]]]))
    assert isinstance(e.value, thinshell.ThinshellError)


def test_simulation_arrays(scenes):
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "square_enlarged.toml", ["integrator.steps=2"]))
    x0 = sim.positions
    assert x0.shape == (108, 3) and x0.dtype == np.float64
    assert np.array_equal(x0, sim.reference_positions * 1.95)  # initial.scale = 1.95
    assert np.array_equal(sim.velocities, np.zeros_like(x0))
    assert sim.edge_angles.shape == (0,)  # mid_edge_average: no edge unknowns
    assert sim.time == 0.0
    sim.step()
    assert sim.time == pytest.approx(5e-6, rel=1e-15)
    assert not np.array_equal(sim.positions, x0)
    # The arrays are copies: changing them does not change the simulation.
    p = sim.positions
    p[:] = 0.0
    assert not np.array_equal(sim.positions, p)


def test_rest_forms_and_stimulus_round_trip(scenes):
    sim = thinshell.Simulation(scenes / "sphere_uniform_heat.toml")
    a, b = sim.rest_forms
    assert a.shape == b.shape == (320, 2, 2)
    a2, b2 = 1.01 * a, b + 0.0
    sim.set_rest_forms(a2, b2)
    a3, b3 = sim.rest_forms
    assert np.array_equal(a3, a2) and np.array_equal(b3, b2)
    s = np.linspace(-0.05, 0.0, 320)
    sim.set_stimulus(s)
    assert np.array_equal(sim.stimulus, np.column_stack([s, s]))
    tb = np.column_stack([s, -s])
    sim.set_stimulus(tb)
    assert np.array_equal(sim.stimulus, tb)
    with pytest.raises(thinshell.SimulationError, match="expected 320 entries, got 3"):
        sim.set_stimulus(np.zeros(3))
    bad = a.copy()
    bad[7] = -bad[7]
    with pytest.raises(thinshell.SimulationError, match="f7: a_bar is not positive definite"):
        sim.set_rest_forms(bad, b)
    assert np.array_equal(sim.rest_forms[0], a2), "a rejected edit changes nothing"


def test_rest_forms_drive_the_shape(scenes):
    """ā = 4 a of the current (unit) square: an enlarged square of side 2 at equilibrium."""
    scene = thinshell.Scene.from_file(
        scenes / "square_enlarged.toml",
        ['effects=["stretching","bending"]', 'integrator.kind="static"', "integrator.steps=1", "initial.scale=1.0"],
    )
    sim = thinshell.Simulation(scene)
    a, b = sim.rest_forms
    assert sim.energies["elastic"] > 0
    x = sim.positions
    sim.set_rest_forms(a / 4.0, b)  # the scene's ā is 4 a⁰; a quarter of it is the unit square
    assert sim.energies["elastic"] == pytest.approx(0.0, abs=1e-20)
    sim.set_rest_forms(a, b)
    sim.step()
    y = sim.positions
    # Side 2 modulo rigid motion: all pairwise distances double.
    d0 = np.linalg.norm(x[:, None] - x[None], axis=-1)
    d1 = np.linalg.norm(y[:, None] - y[None], axis=-1)
    assert np.allclose(d1, 2.0 * d0, rtol=1e-8, atol=1e-10)


def test_face_energies_sum_to_the_energies(scenes):
    sim = thinshell.Simulation(scenes / "square_rhombus.toml")
    fe = sim.face_energies()
    e = sim.energies
    assert fe["stretch"].shape == (184,)
    assert fe["stretch"].sum() == pytest.approx(e["stretch"], rel=1e-12)
    assert fe["bend"].sum() == pytest.approx(e["bend"], rel=1e-12, abs=1e-30)
