"""The energy layer: gradient against central differences of the energy, Hessian against
central differences of the gradient, symmetry, rigid-motion invariance, and agreement with the
energies a Simulation reports for the same state."""

from __future__ import annotations

import numpy as np
import pytest

import thinshell


@pytest.fixture(scope="module")
def bent_sheet():
    """A 4 × 3 sheet (mid_edge_average) bent and stretched away from its flat rest shape."""
    mesh = thinshell.Simulation(
        {"effects": ["stretching", "bending"], "mesh": {"generator": "rectangle", "width": 0.04, "height": 0.03, "nx": 4, "ny": 3}, "integrator": {"kind": "static"}}
    ).mesh
    V0 = mesh.vertices
    rng = np.random.default_rng(7)
    V = V0 * 1.02
    V[:, 2] = 0.05 * V0[:, 0] ** 2 / 0.04 + 1e-4 * rng.standard_normal(len(V0))
    return V0, V, mesh.faces


@pytest.mark.parametrize("form", ["mid_edge_average", "edge_director_tan"])
def test_gradient_matches_central_differences(bent_sheet, form):
    V0, V, F = bent_sheet
    mat = {"thickness": 1e-3, "young": 1e6, "poisson": 0.3}
    r = thinshell.energy(V, F, V0, material=mat, form=form, hessian=False)
    n = 3 * len(V)
    phi = np.zeros(len(r.gradient) - n)
    if form != "mid_edge_average":
        assert len(phi) == thinshell.Mesh(V, F).n_edges
        phi = 0.01 * np.sin(np.arange(len(phi)))
        r = thinshell.energy(V, F, V0, material=mat, form=form, edge_angles=phi, hessian=False)
    u = np.concatenate([V.ravel(), phi])

    def E(u):
        return thinshell.energy(u[:n].reshape(-1, 3), F, V0, material=mat, form=form, edge_angles=u[n:] if len(phi) else None, hessian=False).energy

    h = 1e-7
    fd = np.array([(E(u + h * e) - E(u - h * e)) / (2 * h) for e in np.eye(len(u))])
    scale = np.abs(r.gradient).max()
    assert np.abs(fd - r.gradient).max() < 1e-6 * scale


def test_hessian_is_the_derivative_of_the_gradient(bent_sheet):
    V0, V, F = bent_sheet
    mat = {"thickness": 1e-3, "young": 1e6, "poisson": 0.3}
    r = thinshell.energy(V, F, V0, material=mat)
    H = r.hessian
    import scipy.sparse

    assert isinstance(H, scipy.sparse.csc_matrix) and H.shape == (3 * len(V),) * 2
    assert abs(H - H.T).max() == 0.0, "full symmetric, exactly"
    Hd = H.toarray()
    h = 1e-7
    u = V.ravel()

    def g(u):
        return thinshell.energy(u.reshape(-1, 3), F, V0, material=mat, hessian=False).gradient

    fd = np.column_stack([(g(u + h * e) - g(u - h * e)) / (2 * h) for e in np.eye(len(u))])
    assert np.abs(fd - Hd).max() < 1e-5 * np.abs(Hd).max()
    # Rigid translations cost no energy: H t = 0 to round-off.
    for axis in range(3):
        t = np.zeros((len(V), 3))
        t[:, axis] = 1.0
        assert np.abs(H @ t.ravel()).max() < 1e-12 * np.abs(Hd).sum(axis=1).max()


def test_rest_as_forms_equals_rest_as_positions(bent_sheet):
    V0, V, F = bent_sheet
    sim = thinshell.Simulation(
        {"effects": ["stretching", "bending"], "mesh": {"generator": "rectangle", "width": 0.04, "height": 0.03, "nx": 4, "ny": 3}, "integrator": {"kind": "static"}, "bending": {"form": "mid_edge_average"}}
    )
    a, b = sim.rest_forms  # flat rest forms of the generated sheet
    r1 = thinshell.energy(V, F, V0)
    r2 = thinshell.energy(V, F, (a, b))
    assert r1.energy == pytest.approx(r2.energy, rel=1e-12)
    assert np.allclose(r1.gradient, r2.gradient, rtol=0, atol=1e-12 * np.abs(r1.gradient).max())


def test_energy_matches_the_simulation(scenes):
    """Same state, same rest forms: the energy layer and the Simulation's assembly agree."""
    sim = thinshell.Simulation(thinshell.Scene.from_file(scenes / "square_rhombus.toml"))
    r = thinshell.energy(sim.positions, sim.faces, sim.rest_forms, form="mid_edge_average")
    e = sim.energies
    assert r.stretch == pytest.approx(e["stretch"], rel=1e-12)
    assert r.bend == pytest.approx(e["bend"], rel=1e-12, abs=1e-300)


def test_energy_rejects_bad_input(bent_sheet):
    V0, V, F = bent_sheet
    with pytest.raises(ValueError, match="unknown key `thick`"):
        thinshell.energy(V, F, V0, material={"thick": 1.0})
    with pytest.raises(ValueError, match="form: `mid_edge`"):
        thinshell.energy(V, F, V0, form="mid_edge")
    with pytest.raises(thinshell.EnergyError, match="poisson"):
        thinshell.energy(V, F, V0, material={"poisson": 0.7})
    F2 = F.copy()
    F2[0] = F2[0][[0, 2, 1]]
    with pytest.raises(thinshell.MeshError, match="flipped 1 face"):
        thinshell.energy(V, F2, V0)
