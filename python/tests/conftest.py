import importlib
import os

import numpy as np
import pytest


def optional(name):
    """An optional package the test needs (meshio, pyvista): skips the test when it
    is missing, except where MESHSMOOTH_TEST_NEEDS (comma-separated; .ci/python-tests
    sets it for the run in .venv) names it: there a missing package fails."""
    if name in os.environ.get("MESHSMOOTH_TEST_NEEDS", "").split(","):
        return importlib.import_module(name)
    return pytest.importorskip(name)


def box(n=5, alpha=0.08, seed=1):
    """An n x n x n grid of points on the unit cube, its (n-1)^3 hexahedra,
    the interior points moved by up to `alpha` (seeded)."""
    g = np.linspace(0.0, 1.0, n)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    points = np.c_[x.ravel(), y.ravel(), z.ravel()]

    def idx(i, j, k):
        return (i * n + j) * n + k

    hexes = np.array(
        [
            [idx(i, j, k), idx(i + 1, j, k), idx(i + 1, j + 1, k), idx(i, j + 1, k),
             idx(i, j, k + 1), idx(i + 1, j, k + 1), idx(i + 1, j + 1, k + 1), idx(i, j + 1, k + 1)]
            for i in range(n - 1)
            for j in range(n - 1)
            for k in range(n - 1)
        ],
        dtype=np.int64,
    )
    interior = np.all((points > 0) & (points < 1), axis=1)
    rng = np.random.default_rng(seed)
    points[interior] += rng.uniform(-alpha, alpha, (interior.sum(), 3))
    return points, hexes, interior


def hex_to_tets(hexes):
    """Each hexahedron split into 6 tetrahedra around its 0-6 diagonal (positively oriented)."""
    split = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
    return np.array([[h[a], h[b], h[c], h[d]] for h in hexes for a, b, c, d in split], dtype=np.int64)


def grid(n=6, alpha=0.1, seed=2):
    """A planar n x n grid of points, its quads, the interior moved by up to `alpha`."""
    g = np.linspace(0.0, 1.0, n)
    x, y = np.meshgrid(g, g, indexing="ij")
    points = np.c_[x.ravel(), y.ravel()]
    quads = np.array(
        [[i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1] for i in range(n - 1) for j in range(n - 1)],
        dtype=np.int64,
    )
    interior = np.all((points > 0) & (points < 1), axis=1)
    rng = np.random.default_rng(seed)
    points[interior] += rng.uniform(-alpha, alpha, (interior.sum(), 2))
    return points, quads, interior


@pytest.fixture
def hex_box():
    return box()


@pytest.fixture
def tet_box():
    points, hexes, interior = box(n=4, alpha=0.05)
    return points, hex_to_tets(hexes), interior


@pytest.fixture
def quad_grid():
    return grid()
