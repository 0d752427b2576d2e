"""Untangling from Python: ``smooth`` untangles a tangled input first (as the
CLI's ``smooth``), ``untangle=False`` refuses it, and ``untangle`` does only
the untangling (the library's ``solve::untangle_mesh``)."""

import numpy as np
import pytest

import meshsmooth as ms

from conftest import grid


def tangled_grid():
    """A 6 x 6 quad grid whose vertex at (0.4, 0.4) was pushed past its
    neighbour at (0.6, 0.4): the quads around it are inverted."""
    points, quads, interior = grid(n=6, alpha=0.0)
    v = 2 * 6 + 2
    assert np.allclose(points[v], [0.4, 0.4])
    points = points.copy()
    points[v] = [0.75, 0.45]
    return points, quads


def signed_areas(points, quads):
    p = points[quads]
    x, y = p[..., 0], p[..., 1]
    # shoelace per corner triangle: every corner of a valid quad turns left
    out = []
    for k in range(4):
        a, b, c = (k - 1) % 4, k, (k + 1) % 4
        out.append((x[:, b] - x[:, a]) * (y[:, c] - y[:, a]) - (y[:, b] - y[:, a]) * (x[:, c] - x[:, a]))
    return np.min(np.array(out), axis=0)


def test_smooth_untangles_first_by_default():
    points, quads = tangled_grid()
    assert (signed_areas(points, quads) <= 0).sum() >= 2
    before = points.copy()
    r = ms.smooth(points, quads)
    assert np.array_equal(points, before), "the input is never modified"
    assert r.untangle is not None
    assert r.untangle["inverted_before"] >= 2
    assert r.untangle["inverted_after"] == 0
    assert r.untangle["rounds"] >= 1
    assert (signed_areas(r.points, quads) > 0).all()
    assert np.isfinite(r.quality).all() and (r.quality >= 1.0).all()
    assert r.stop == "converged"
    # the boundary stayed
    on_side = np.any((before == 0.0) | (before == 1.0), axis=1)
    assert np.array_equal(r.points[on_side], before[on_side])


def test_no_untangle_refuses_a_tangled_mesh():
    points, quads = tangled_grid()
    with pytest.raises(ValueError, match="invert"):
        ms.smooth(points, quads, untangle=False)
    # an untangled input says so: nothing was untangled
    ok, quads_ok, _ = grid()
    assert ms.smooth(ok, quads_ok).untangle is None


def test_untangle_only_untangles():
    points, quads = tangled_grid()
    u = ms.untangle(points, quads)
    assert isinstance(u, ms.UntangleResult)
    assert u.info["inverted_before"] >= 2 and u.info["inverted_after"] == 0
    assert (signed_areas(u.points, quads) > 0).all()
    assert u.points.shape == points.shape
    # only untangled: smoothing the result lowers F further
    s = ms.smooth(u.points, quads)
    assert s.untangle is None
    assert s.iterations > 0
    # an untangled input comes back as it was
    ok, quads_ok, _ = grid()
    same = ms.untangle(ok, quads_ok)
    assert same.info is None
    assert np.array_equal(same.points, ok)
