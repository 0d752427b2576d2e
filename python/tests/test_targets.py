"""Targets from Python: the default keeps a graded quad boundary layer that
the ideal objective thickens, a size field makes elements smaller where it
is smaller, and bad specs are refused by name."""

import numpy as np
import pytest

import meshsmooth as ms

from conftest import optional

NX, NY = 24, 14


def layer():
    """A unit strip of quads graded away from y = 0 (first height 1e-3, growth 1.3)."""
    ys = np.r_[0.0, np.cumsum(1e-3 * 1.3 ** np.arange(NY))]
    x, y = np.meshgrid(np.linspace(0.0, 1.0, NX + 1), ys)
    points = np.c_[x.ravel(), y.ravel()]
    quads = []
    for j in range(NY):
        for i in range(NX):
            v = j * (NX + 1) + i
            quads.append([v, v + 1, v + NX + 2, v + NX + 1])
    return points, np.array(quads)


def perturbed(points, seed):
    """Interior vertices moved by up to 0.3 of their row's smallest spacing."""
    rng = np.random.default_rng(seed)
    out = points.copy()
    ys = np.unique(points[:, 1])
    gaps = np.diff(ys)
    for v, (x, y) in enumerate(points):
        j = np.searchsorted(ys, y)
        if 0 < j < len(ys) - 1 and 0.0 < x < 1.0:
            h = min(gaps[j - 1], gaps[j], 1.0 / NX)
            out[v] += 0.3 * h * rng.uniform(-1.0, 1.0, 2)
    return out


def first_layer_error(points, base):
    row = np.arange(NX + 2, 2 * NX + 1)  # the free vertices of the second row
    return np.median(np.abs(points[row, 1] / base[row, 1] - 1.0))


def test_the_default_keeps_a_boundary_layer_that_ideal_targets_thicken():
    base, quads = layer()
    start = perturbed(base, 7)
    auto = ms.smooth(start, quads)
    assert auto.targets is not None and auto.targets.startswith("targets: input")
    explicit = ms.smooth(start, quads, target="input")
    assert explicit.targets is None
    np.testing.assert_array_equal(auto.points, explicit.points)
    ideal = ms.smooth(start, quads, target="ideal")
    assert ideal.targets is None
    assert first_layer_error(auto.points, base) < 0.08
    assert first_layer_error(ideal.points, base) > 2.0
    # shape only (imr against the input's targets) keeps the shapes, not the sizes
    shape_only = ms.smooth(start, quads, target="input", metric="imr")
    assert shape_only.stop == "converged"


def test_a_size_field_makes_elements_smaller_where_it_is_smaller():
    n = 16
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    points = np.c_[x.ravel(), y.ravel()]
    tris = []
    for j in range(n):
        for i in range(n):
            v = j * (n + 1) + i
            tris += [[v, v + 1, v + n + 2], [v, v + n + 2, v + n + 1]]
    tris = np.array(tris)
    h = 0.02 + 0.1 * points[:, 0]

    def ratio(p):
        a = p[tris]
        u, w = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
        area = 0.5 * np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
        cx = a[:, :, 0].mean(axis=1)
        return area[cx < 0.25].mean() / area[cx > 0.75].mean()

    out = ms.smooth(points, tris, target="size:h", fields={"h": h})
    assert ratio(out.points) < 0.5 * ratio(points)
    with pytest.raises(ValueError, match="'nope'"):
        ms.smooth(points, tris, target="size:nope", fields={"h": h})
    with pytest.raises(ValueError, match="unknown target 'sizes'"):
        ms.smooth(points, tris, target="sizes")
    with pytest.raises(ValueError, match="shape"):
        ms.smooth(points, tris, target="size:h", fields={"h": h[:-1]})


def test_smooth_meshio_reads_the_size_field_from_point_data():
    meshio = optional("meshio")
    n = 12
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    points = np.c_[x.ravel(), y.ravel(), np.zeros((n + 1) ** 2)]
    tris = []
    for j in range(n):
        for i in range(n):
            v = j * (n + 1) + i
            tris += [[v, v + 1, v + n + 2], [v, v + n + 2, v + n + 1]]
    h = 0.02 + 0.1 * points[:, 0]
    mesh = meshio.Mesh(points, [("triangle", np.array(tris))], point_data={"h": h})
    out = ms.smooth_meshio(mesh, target="size:h")
    direct = ms.smooth(points[:, :2], np.array(tris), target="size:h", fields={"h": h})
    np.testing.assert_allclose(out.points[:, :2], direct.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(out.point_data["h"], h)
