"""The energy at a simulation's own state and with the default form (issue #28): ``energy()``
defaults to the scenes' form and, without edge angles, evaluates at the minimising ones;
``Simulation.energy()`` agrees with the simulation's energies; ``form``/``material`` are exposed;
``modes()`` gives a simply supported plate's Kirchhoff frequencies."""

from __future__ import annotations

import math

import numpy as np
import pytest

import thinshell

SHEET = {
    "effects": ["stretching", "bending"],
    "mesh": {"generator": "rectangle", "width": 0.04, "height": 0.03, "nx": 4, "ny": 3},
    "integrator": {"kind": "static"},
}


def test_default_form_relaxes_the_edge_angles():
    mesh = thinshell.Simulation(SHEET).mesh
    V0 = mesh.vertices
    V = V0 * 1.01
    V[:, 2] = 0.5 * V0[:, 0] ** 2 / 0.04
    mat = {"thickness": 1e-3, "young": 1e6, "poisson": 0.3}
    r = thinshell.energy(V, mesh.faces, V0, material=mat, hessian=False)
    n = 3 * len(V)
    assert len(r.gradient) == n + mesh.n_edges and len(r.edge_angles) == mesh.n_edges
    # At the minimising angles the angle gradient vanishes (to the relaxation's tolerance) on
    # every edge whose angle is an unknown of a simulation; fitted free edges keep 0, as in a
    # simulation (model.md §1.2).
    moved = r.edge_angles != 0.0
    assert moved.sum() > 10
    g_phi = np.abs(r.gradient[n:][moved]).max()
    assert g_phi < 1e-8 * np.abs(r.gradient[:n]).max() * 0.04, g_phi
    # … and zero angles (what None used to mean) give a higher energy.
    zero = thinshell.energy(V, mesh.faces, V0, material=mat, edge_angles=np.zeros(mesh.n_edges), hessian=False)
    assert zero.energy > r.energy * (1 + 1e-6)
    # The explicit form gives the same.
    same = thinshell.energy(V, mesh.faces, V0, material=mat, form="edge_director_tan", hessian=False)
    assert same.energy == r.energy


def test_simulation_energy_at_its_own_state(scenes):
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "cylinder_directors.toml"))
    assert sim.form == "edge_director_sin"
    assert sim.material["young"] == 1e5 and sim.material["density"] == 250.0
    sim.step()
    r = sim.energy()
    e = sim.energies
    assert r.stretch == pytest.approx(e["stretch"], rel=1e-12)
    assert r.bend == pytest.approx(e["bend"], rel=1e-12)
    assert np.array_equal(r.edge_angles, sim.edge_angles)
    H = r.hessian
    assert H.shape == (len(r.gradient),) * 2 and abs(H - H.T).max() == 0.0
    # The module-level function with the simulation's form, material and rest forms agrees
    # (this scene has no clamps, so nothing but those enters).
    m = thinshell.energy(sim.positions, sim.faces, sim.rest_forms, material=sim.material, form=sim.form, edge_angles=sim.edge_angles, hessian=False)
    assert m.energy == pytest.approx(r.energy, rel=1e-12)


def test_plate_modes_match_kirchhoff(scenes):
    m = thinshell.modes(scenes / "plate_modes.toml", count=4)
    a, b, h, E, nu, rho = 1.5, 1.0, 0.01, 2e11, 0.3, 7850.0
    D = E * h**3 / (12 * (1 - nu * nu))
    exact = sorted(math.pi / 2 * (i * i / a**2 + j * j / b**2) * math.sqrt(D / (rho * h)) for i in range(1, 5) for j in range(1, 5))[:4]
    assert np.all(np.diff(m.frequencies) >= 0)
    assert np.allclose(m.frequencies, exact, rtol=0.02), (m.frequencies, exact)
    assert m.shapes.shape[0] == 4 and m.shapes.shape[2] == 3
    assert np.all(m.residuals < 1e-9)


def test_energy_with_a_simulation_is_the_simulations_model(scenes):
    """Issue 42: after growth, the module-level energy() with ``sim=`` and ``sim.energy(x)``
    evaluate the simulation's own model (grown rest forms, its form and material): both equal
    the elastic energy the simulation reports, while the rest *shape* alone is another model."""
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "sphere_uniform_heat.toml", ["integrator.steps=20"]))
    sim.run()
    x = sim.positions
    reported = sim.energies["stretch"] + sim.energies["bend"]
    a = thinshell.energy(x, sim=sim, hessian=False)
    b = sim.energy(x, hessian=False)
    assert a.energy == pytest.approx(reported, rel=1e-12)
    assert b.energy == pytest.approx(reported, rel=1e-12)
    assert a.stretch == pytest.approx(sim.energies["stretch"], rel=1e-12)
    # The energy against the undeformed reference shape (what energy(x, F, rest=positions)
    # means) is another model: grown rest forms differ from it by far more than round-off.
    other = thinshell.energy(x, sim.faces, sim.reference_positions, form=sim.form, material=sim.material, hessian=False)
    assert abs(other.energy - reported) > 0.1 * reported
    # Another position: still the simulation's model (its gradient matches finite differences
    # of the same call).
    y = x * 1.001
    g = sim.energy(y, hessian=False).gradient
    d = np.zeros_like(y)
    d[0, 2] = 1e-7
    fd = (sim.energy(y + d, hessian=False).energy - sim.energy(y - d, hessian=False).energy) / 2e-7
    assert fd == pytest.approx(g[2], rel=1e-5, abs=1e-9 * np.abs(g).max())
    with pytest.raises(ValueError, match="ambiguous"):
        thinshell.energy(x, sim.faces, sim=sim)
    with pytest.raises(TypeError, match="sim="):
        thinshell.energy(x)
