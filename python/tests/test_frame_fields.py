"""The shell fields of a VTK frame (curvature, membrane strain, stress resultants, bending
moments; docs/scenes.md, `[output] formats`) read back by meshio, against the cylinder they
describe and the plane-stress law that relates them."""

from __future__ import annotations

import numpy as np
import pytest

import thinshell

POINT_FIELDS = ["mean_curvature", "gaussian_curvature", "curvature_direction_1", "curvature_direction_2"]
CELL_FIELDS = [
    "principal_curvature_1",
    "principal_curvature_2",
    "face_mean_curvature",
    "face_gaussian_curvature",
    "membrane_strain_1",
    "membrane_strain_2",
    "stress_resultant_1",
    "stress_resultant_2",
    "bending_moment_1",
    "bending_moment_2",
    "face_curvature_direction_1",
    "face_curvature_direction_2",
]


def test_meshio_reads_the_shell_fields_of_a_solved_cylinder(tmp_path, scenes):
    meshio = pytest.importorskip("meshio")
    # A free sheet with rest curvature 1/R = 1 1/m across x (StVK, h = 1e-2 m, E = 1e5 Pa,
    # nu = 0.3), one static solve: a cylinder of radius 1 m about y.
    scene = thinshell.Scene.from_file(scenes / "cylinder_directors.toml", ["mesh.n=16", 'output.formats=["vtk"]'])
    sim = thinshell.Simulation(scene, output=tmp_path)
    sim.run()
    m = meshio.read(tmp_path / "frame_000001.vtu")
    nv, nf = len(sim.positions), len(sim.faces)
    for name in POINT_FIELDS:
        assert m.point_data[name].shape[0] == nv, name
    for name in CELL_FIELDS:
        assert m.cell_data[name][0].shape[0] == nf, name
    cell = {k: v[0] for k, v in m.cell_data.items()}
    # Curvature against the cylinder (kappa = eigenvalues of -a^-1 b; negative for this
    # orientation): measured max errors at n = 16 are 8.6e-3 (kappa_2), 8.9e-3 (kappa_1) and
    # 2.0e-3 (vertex H).
    assert np.abs(cell["principal_curvature_2"] + 1.0).max() < 1e-2
    assert np.abs(cell["principal_curvature_1"]).max() < 1e-2
    assert np.abs(m.point_data["mean_curvature"] + 0.5).max() < 3e-3
    assert np.abs(m.point_data["gaussian_curvature"]).max() < 1e-2
    assert np.allclose(cell["face_mean_curvature"], 0.5 * (cell["principal_curvature_1"] + cell["principal_curvature_2"]), rtol=0, atol=1e-14)
    # Principal directions: unit, orthogonal, the zero curvature along the axis (y).
    for d1, d2 in [(cell["face_curvature_direction_1"], cell["face_curvature_direction_2"]), (m.point_data["curvature_direction_1"], m.point_data["curvature_direction_2"])]:
        assert np.allclose(np.linalg.norm(d1, axis=1), 1.0, atol=1e-12)
        assert np.allclose(np.linalg.norm(d2, axis=1), 1.0, atol=1e-12)
        assert np.abs(np.einsum("ij,ij->i", d1, d2)).max() < 1e-10
        assert np.abs(d1[:, 1]).min() > 0.99
    # StVK's resultants follow its strains face by face: N_1 = E h / (1 - nu^2) (eps_1 + nu eps_2).
    c, nu = 1e5 * 1e-2 / (1 - 0.09), 0.3
    e1, e2 = cell["membrane_strain_1"], cell["membrane_strain_2"]
    scale = np.abs(cell["stress_resultant_1"]).max()
    assert scale > 0
    assert np.abs(cell["stress_resultant_1"] - c * (e1 + nu * e2)).max() < 1e-9 * scale
    assert np.abs(cell["stress_resultant_2"] - c * (e2 + nu * e1)).max() < 1e-9 * scale
    assert np.all(e1 >= e2) and np.all(cell["bending_moment_1"] >= cell["bending_moment_2"])
