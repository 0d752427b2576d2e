"""The Python package and the command line are two front ends of one library
entry (``Smoother``): same defaults, same checks, same answer."""

import inspect
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import meshsmooth as ms
from meshsmooth import _core

from conftest import box, hex_to_tets

# settings the Python keywords do not carry: files and groups are for files
# on disk (read them with the CLI or pass `fixed=`), partial results for CLIs
NOT_KEYWORDS = {"tol_x", "reference", "fix_groups", "free_groups", "fixed_arrays", "fixed_files", "keep_partial"}


def cli():
    """The meshsmooth binary built beside this package (`cargo build --release`)."""
    found = os.environ.get("MESHSMOOTH_CLI") or str(
        pathlib.Path(__file__).resolve().parents[2] / "target" / "release" / "meshsmooth"
    )
    if not os.path.exists(found):
        if os.environ.get("CI"):
            raise AssertionError(f"no meshsmooth binary at {found} (set MESHSMOOTH_CLI)")
        pytest.skip(f"no meshsmooth binary at {found}; build it with cargo build --release")
    return found


def test_keyword_defaults_are_the_library_defaults():
    library = json.loads(_core.default_settings())
    for function in (ms.smooth, ms.untangle):
        params = inspect.signature(function).parameters
        for key, value in library.items():
            if key in params:
                assert params[key].default == value, (function.__name__, key, params[key].default, value)
    missing = set(library) - set(inspect.signature(ms.smooth).parameters)
    assert missing == NOT_KEYWORDS
    assert library["device"] == "auto"


def test_time_limit_zero_is_refused_by_both_front_ends(tmp_path):
    points, hexes, _ = box(4)
    with pytest.raises(ValueError, match="time_limit: must be a positive number of seconds, got 0"):
        ms.smooth(points, hexes, time_limit=0)
    path = tmp_path / "box.vtu"
    ms.write(path, points, [("hexahedron", hexes)])
    o = subprocess.run(
        [cli(), "smooth", str(path), "-o", str(tmp_path / "out.vtu"), "--time-limit", "0"],
        capture_output=True, text=True,
    )
    assert o.returncode != 0
    assert "--time-limit: must be a positive number of seconds, got 0" in o.stderr, o.stderr
    assert not (tmp_path / "out.vtu").exists()


@pytest.mark.parametrize("method", ["newton", "bcd"])
def test_cli_and_python_give_the_same_mesh_untangling_included(tmp_path, method):
    points, hexes, interior = box(5, alpha=0.05, seed=3)
    tets = hex_to_tets(hexes)
    # tangle it: one interior vertex pushed through its neighbours
    v = int(np.flatnonzero(interior)[len(np.flatnonzero(interior)) // 2])
    points[v] += [0.4, 0.0, 0.0]
    # the library's writers refuse inverted elements: a legacy VTK file by hand,
    # every coordinate in repr (which reads back to the same double)
    path = tmp_path / "tangled.vtk"
    lines = ["# vtk DataFile Version 3.0", "tangled", "ASCII", "DATASET UNSTRUCTURED_GRID", f"POINTS {len(points)} double"]
    lines += [" ".join(repr(float(c)) for c in p) for p in points]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += ["4 " + " ".join(str(int(v)) for v in t) for t in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.vtu"
    o = subprocess.run(
        [cli(), "smooth", str(path), "-o", str(out), "--format", "vtu-binary", "--device", "cpu", "--method", method],
        capture_output=True, text=True,
    )
    assert o.returncode == 0, o.stderr
    assert "untangled" in o.stdout
    by_cli = ms.read(out).points
    by_python = ms.smooth(points, [("tetra", tets)], device="cpu", method=method)
    assert by_python.untangle["inverted_before"] > 0
    assert by_python.report()["inverted"] == 0
    np.testing.assert_array_equal(by_python.points, by_cli)
