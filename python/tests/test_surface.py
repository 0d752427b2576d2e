"""Surface meshes from Python: triangles with 3D points are a surface (every
vertex slides on it, each triangle measured in its own plane), through
smooth() and through a PyVista PolyData."""

import numpy as np
import pytest

import meshsmooth as ms
from conftest import optional


def uv_sphere(n_theta=16, n_phi=12):
    """A latitude-longitude sphere of radius 1: poor triangles at the poles."""
    pts = [[0.0, 0.0, 1.0]]
    for i in range(1, n_phi):
        phi = np.pi * i / n_phi
        for j in range(n_theta):
            th = 2 * np.pi * j / n_theta
            pts.append([np.sin(phi) * np.cos(th), np.sin(phi) * np.sin(th), np.cos(phi)])
    pts.append([0.0, 0.0, -1.0])
    ring = lambda i, j: 1 + (i - 1) * n_theta + j % n_theta  # noqa: E731
    tris = []
    for j in range(n_theta):
        tris.append([0, ring(1, j), ring(1, j + 1)])
    for i in range(1, n_phi - 1):
        for j in range(n_theta):
            a, b, c, d = ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)
            tris += [[a, b, c], [a, c, d]]
    south = len(pts) - 1
    for j in range(n_theta):
        tris.append([south, ring(n_phi - 1, j + 1), ring(n_phi - 1, j)])
    return np.array(pts), np.array(tris)


def normals(points, tris):
    p = points[tris]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


def test_triangles_in_3d_are_smoothed_on_their_surface():
    points, tris = uv_sphere()
    start = ms.quality(points, tris)
    result = ms.smooth(points, tris)
    assert result.points.shape == points.shape
    radius = np.linalg.norm(result.points, axis=1)
    # on the input's facets: no farther inside than a facet's sag, never outside
    assert radius.max() <= 1.0 + 1e-12 and radius.min() > 0.95
    # every triangle still faces outward, and the mean quality improved
    assert (np.einsum("ij,ij->i", normals(result.points, tris), result.points[tris].mean(axis=1)) > 0).all()
    assert result.quality.mean() < start["objective"] - 0.01
    assert result.report()["surface"] is True
    assert abs(result.objective - result.quality.mean()) < 1e-9


def test_a_surface_refuses_a_size_metric():
    points, tris = uv_sphere(8, 6)
    with pytest.raises(Exception, match="surface mesh"):
        ms.smooth(points, tris, metric="tmp", target="input")


def test_smooth_pyvista_takes_a_polydata_surface():
    pv = optional("pyvista")
    points, tris = uv_sphere()
    faces = np.hstack([np.full((len(tris), 1), 3), tris]).ravel()
    poly = pv.PolyData(points, faces)
    poly.point_data["height"] = points[:, 2].copy()
    poly.cell_data["id"] = np.arange(len(tris))
    out = ms.smooth_pyvista(poly)
    assert isinstance(out, pv.PolyData)
    assert out.n_points == poly.n_points and out.n_cells == poly.n_cells
    assert np.array_equal(out.point_data["height"], poly.point_data["height"])
    assert np.array_equal(out.cell_data["id"], poly.cell_data["id"])
    moved = np.asarray(out.points)
    assert np.abs(moved - points).max() > 1e-3
    assert np.linalg.norm(moved, axis=1).max() <= 1.0 + 1e-12
    assert out.meshsmooth_result.objective < ms.quality(points, tris)["objective"]
    # a polygon that is neither a triangle nor a quadrilateral is refused naming it
    hexagon = pv.PolyData(np.array([[np.cos(a), np.sin(a), 0.1 * np.cos(3 * a)] for a in np.linspace(0, 2 * np.pi, 7)[:-1]]),
                          np.array([6, 0, 1, 2, 3, 4, 5]))
    with pytest.raises(ValueError, match="polygon 0 has 6 vertices"):
        ms.smooth_pyvista(hexagon)
