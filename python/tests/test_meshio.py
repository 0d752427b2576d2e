"""The meshio adapters: data arrays survive, fixed vertices stay."""

import numpy as np

import meshsmooth as ms

from conftest import optional

# without meshio this module skips; test_package.py checks what these functions raise then
meshio = optional("meshio")


def test_meshio_round_trip_keeps_data(tmp_path, tet_box):
    points, tets, interior = tet_box
    n = len(points)
    boundary_faces = np.array([[0, 1, 2]])
    mesh = meshio.Mesh(
        np.r_[points, [[9.0, 9.0, 9.0]]],  # an unused point, as gmsh files have
        [("tetra", tets), ("triangle", boundary_faces)],
        point_data={"temperature": np.arange(n + 1, dtype=float)},
        cell_data={"material": [np.arange(len(tets)) % 3, np.array([7])]},
        field_data={"steel": np.array([1, 3])},
    )
    mesh.write(tmp_path / "in.vtu")
    mesh = meshio.read(tmp_path / "in.vtu")
    out = ms.smooth_meshio(mesh, method="newton")
    assert out.meshsmooth_result.stop == "converged"
    np.testing.assert_array_equal(out.point_data["temperature"], mesh.point_data["temperature"])
    for a, b in zip(out.cell_data["material"], mesh.cell_data["material"]):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(out.points[n], [9.0, 9.0, 9.0])
    np.testing.assert_array_equal(out.points[:n][~interior], points[~interior])
    assert np.any(out.points[:n][interior] != points[interior])
    out.write(tmp_path / "out.vtu")
    back = meshio.read(tmp_path / "out.vtu")
    np.testing.assert_array_equal(back.point_data["temperature"], mesh.point_data["temperature"])
    np.testing.assert_allclose(back.points, out.points, rtol=0, atol=1e-15)
    arrays = ms.from_meshio(back)
    assert [t for t, _ in arrays.cells] == ["tetra"] and arrays.fixed is not None
    assert set(np.flatnonzero(arrays.fixed)) == {0, 1, 2}
    m2 = ms.to_meshio(out.points[:n], [("tetra", tets)], point_data={"t": np.zeros(n)})
    assert m2.cells[0].type == "tetra" and "t" in m2.point_data


def test_smooth_meshio_honours_fixed(tet_box):
    points, tets, interior = tet_box
    mesh = meshio.Mesh(points, [("tetra", tets)])
    chosen = np.flatnonzero(interior)[:2]
    out = ms.smooth_meshio(mesh, fixed=chosen)
    np.testing.assert_array_equal(out.points[chosen], points[chosen])


def test_smooth_pyvista_keeps_arrays(tet_box):
    pv = optional("pyvista")
    points, tets, interior = tet_box
    cells = np.c_[np.full(len(tets), 4), tets].ravel()
    grid = pv.UnstructuredGrid(cells, np.full(len(tets), 10, dtype=np.uint8), points)
    grid.point_data["t"] = np.arange(len(points), dtype=float)
    grid.cell_data["m"] = np.arange(len(tets))
    out = ms.smooth_pyvista(grid)
    assert out.meshsmooth_result.stop == "converged"
    np.testing.assert_array_equal(out.point_data["t"], grid.point_data["t"])
    np.testing.assert_array_equal(out.cell_data["m"], grid.cell_data["m"])
    np.testing.assert_array_equal(np.asarray(grid.points), points)
    np.testing.assert_array_equal(np.asarray(out.points)[~interior], points[~interior])
    assert abs(out.meshsmooth_result.objective - ms.smooth(points, tets).objective) < 1e-12
