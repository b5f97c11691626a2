"""The energy layer: gradient against central differences of the energy, Hessian against
central differences of the gradient and, to 1e-12 relative, against a dense Hessian summed face
by face from the Rust kernel without the assembler; symmetry, rigid-motion invariance, and
agreement with the energies a Simulation reports for the same state."""

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
    r = thinshell.energy(V, F, V0, material=mat, form="mid_edge_average")
    H = r.hessian
    import scipy.sparse

    assert isinstance(H, scipy.sparse.csc_matrix) and H.shape == (3 * len(V),) * 2
    assert abs(H - H.T).max() == 0.0, "full symmetric, exactly"
    Hd = H.toarray()
    h = 1e-7
    u = V.ravel()

    def g(u):
        return thinshell.energy(u.reshape(-1, 3), F, V0, material=mat, form="mid_edge_average", hessian=False).gradient

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
    r1 = thinshell.energy(V, F, V0, form="mid_edge_average")
    r2 = thinshell.energy(V, F, (a, b), form="mid_edge_average")
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


def _fan():
    """A hexagonal fan of 6 faces around a centre vertex, bent out of plane: every face has two
    boundary edges (two missing flaps)."""
    t = np.arange(6) * np.pi / 3
    V0 = np.vstack([[0.0, 0.0, 0.0], np.column_stack([0.01 * np.cos(t), 0.01 * np.sin(t), np.zeros(6)])])
    F = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    V = V0 * 1.03
    V[:, 2] = 0.3 * (V0[:, 0] ** 2 + 2 * V0[:, 1] ** 2) / 0.01 + 1e-4 * np.sin(np.arange(7))
    return V0, V, F


def _tetrahedron():
    """A closed tetrahedron, squashed: every flap vertex is also a face vertex of the same face's
    stencil, so one vertex fills two stencil slots."""
    V0 = 0.01 * np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    F = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    V = V0 * np.array([1.0, 1.05, 0.9]) + 1e-4 * np.cos(np.arange(12)).reshape(4, 3)
    return V0, V, F


@pytest.mark.parametrize("form", ["mid_edge_average", "edge_director_tan", "edge_director_sin"])
@pytest.mark.parametrize("mesh", ["bent_sheet", "fan", "tetrahedron"])
@pytest.mark.parametrize("terms", [("stretching", "bending"), ("stretching",), ("bending",)])
def test_hessian_matches_the_dense_face_by_face_reference(bent_sheet, form, mesh, terms):
    """energy()'s scipy Hessian (assembler pattern + parallel gather + lower -> full conversion)
    equals a dense Hessian summed face by face from the per-face kernel in Rust, to 1e-12
    relative. Only summation order differs, so the match is to round-off; a mistake in the
    conversion is O(1): dropping the diagonal loses the largest entries, writing a strictly-lower
    entry to (r, c) twice instead of to (r, c) and (c, r) leaves the upper triangle empty, and
    mirroring the diagonal doubles it - each gives a relative difference of order 1."""
    V0, V, F = {"bent_sheet": bent_sheet, "fan": _fan(), "tetrahedron": _tetrahedron()}[mesh]
    mat = {"thickness": 1e-3, "young": 1e6, "poisson": 0.3}
    phi = None
    if form != "mid_edge_average" and "bending" in terms:
        phi = 0.02 * np.sin(1.0 + np.arange(thinshell.Mesh(V, F).n_edges))
    r = thinshell.energy(V, F, V0, material=mat, form=form, terms=terms, edge_angles=phi)
    ref = thinshell._thinshell._reference_hessian(V, F, V0, mat, form, list(terms), phi)
    n = len(r.gradient)
    assert ref.shape == (n, n) == r.hessian.shape
    assert n == 3 * len(V) + (0 if phi is None else len(phi))
    H = r.hessian.toarray()
    scale = np.abs(ref).max()
    assert scale > 0.0
    rel = np.abs(H - ref).max() / scale
    print(f"{mesh} {form} {'+'.join(terms)}: max |H - ref| / max |ref| = {rel:.3g}")
    assert rel <= 1e-12
    # Angle rows and columns (J/rad^2, N/rad) have other units than the position block (N/m):
    # each block also to 1e-12 of its own largest entry, so that no block hides under another.
    p = slice(0, 3 * len(V))
    a = slice(3 * len(V), n)
    for rows, cols in [(p, p), (a, p), (a, a)]:
        if ref[rows, cols].size:
            assert np.abs(H[rows, cols] - ref[rows, cols]).max() <= 1e-12 * np.abs(ref[rows, cols]).max()
