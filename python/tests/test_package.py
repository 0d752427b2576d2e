"""The package as installed: its exports and stubs, a silent import, numpy as
its only dependency (meshio and PyVista optional, named when missing), and a
numpy hex mesh smoothed with nothing else."""

import ast
import inspect
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import meshsmooth as ms
from meshsmooth import _core

from conftest import box

PACKAGE = Path(ms.__file__).resolve().parent
SOURCE = Path(__file__).resolve().parents[1] / "meshsmooth"
#: each hexahedron corner (VTK order) and its three edge neighbours, right-handed
HEX_CORNERS = [(0, 1, 3, 4), (1, 2, 0, 5), (2, 3, 1, 6), (3, 0, 2, 7),
               (4, 7, 5, 0), (5, 4, 6, 1), (6, 5, 7, 2), (7, 6, 4, 3)]


def fresh_python(code, cwd):
    """`code` run by a new interpreter of this environment, started in `cwd`
    (away from the source tree); its meshsmooth must be the one under test."""
    check = f"import meshsmooth as _m, sys; assert _m.__file__ == {ms.__file__!r}, _m.__file__\n"
    out = subprocess.run([sys.executable, "-c", code + "\n" + check], cwd=cwd, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    return out


def test_the_package_under_test_is_the_installed_one():
    """.ci/python-tests sets MESHSMOOTH_TEST_INSTALLED_IN to the venv the wheel went into."""
    venv = os.environ.get("MESHSMOOTH_TEST_INSTALLED_IN")
    if not venv:
        pytest.skip("MESHSMOOTH_TEST_INSTALLED_IN is not set (set by .ci/python-tests)")
    assert PACKAGE.is_relative_to(Path(venv).resolve()), PACKAGE
    assert PACKAGE != SOURCE.resolve()
    assert Path(_core.__file__).resolve().parent == PACKAGE
    assert Path(_core.__file__).name.endswith(".abi3.so"), _core.__file__


def test_import_prints_nothing(tmp_path):
    out = fresh_python("import meshsmooth", tmp_path)
    assert out.stdout == "" and out.stderr == ""


def test_a_cpu_smooth_and_the_adapter_list_print_nothing(tmp_path):
    code = (
        "import sys; sys.path.insert(0, %r)\n"
        "import meshsmooth as ms\n"
        "from conftest import box\n"
        "points, hexes, _ = box(n=4)\n"
        "ms.smooth(points, hexes, device='cpu'); ms.quality(points, hexes); ms.devices()\n"
    ) % str(Path(__file__).resolve().parent)
    out = fresh_python(code, tmp_path)
    assert out.stdout == "" and out.stderr == ""


def test_all_names_the_public_api():
    assert len(set(ms.__all__)) == len(ms.__all__)
    missing = [name for name in ms.__all__ if not hasattr(ms, name)]
    assert not missing
    defined = {
        name
        for name, value in vars(ms).items()
        if not name.startswith("_")
        and (inspect.isfunction(value) or inspect.isclass(value))
        and getattr(value, "__module__", None) == "meshsmooth"
    }
    assert defined == set(ms.__all__)
    star: dict = {}
    exec("from meshsmooth import *", star)
    assert set(star) - {"__builtins__"} == set(ms.__all__)
    # the helpers the module imports stay its own
    assert all(not name.startswith("_") for name in ms.__all__)
    assert not {"np", "npt", "os", "importlib", "annotations", "Any", "Dict", "List", "Optional"} & set(star)


def test_the_adapter_list_prints_nothing_to_stderr_on_a_headless_machine(tmp_path):
    """Mesa's Vulkan loader layers probe the display server; without one they
    complain ("XDG_RUNTIME_DIR is invalid") unless meshsmooth keeps them quiet."""
    code = (
        "import os\n"
        "os.environ.pop('XDG_RUNTIME_DIR', None); os.environ.pop('WAYLAND_DISPLAY', None)\n"
        "os.environ.pop('DISPLAY', None); os.environ.pop('NODEVICE_SELECT', None)\n"
        "import meshsmooth as ms\n"
        "assert isinstance(ms.devices(), list)\n"
    )
    out = fresh_python(code, tmp_path)
    assert out.stdout == "" and out.stderr == "", out.stderr


def test_the_stubs_ship_and_match_the_compiled_module():
    assert (PACKAGE / "py.typed").is_file()
    tree = ast.parse((PACKAGE / "_core.pyi").read_text())
    functions = {node.name: node for node in tree.body if isinstance(node, ast.FunctionDef)}
    constants = {node.target.id for node in tree.body if isinstance(node, ast.AnnAssign)}
    public = {name for name in dir(_core) if not name.startswith("_")}
    assert set(functions) | constants == public
    for name, node in functions.items():
        args = node.args.args + node.args.kwonlyargs
        defaults = [None] * (len(node.args.args) - len(node.args.defaults)) + node.args.defaults + node.args.kw_defaults
        stub = {a.arg: ast.literal_eval(d) if d is not None else inspect.Parameter.empty for a, d in zip(args, defaults)}
        real = {p.name: p.default for p in inspect.signature(getattr(_core, name)).parameters.values()}
        # the same parameters in the same order, with the same defaults
        assert list(stub.items()) == list(real.items()), name


def test_import_loads_neither_meshio_nor_pyvista(tmp_path):
    fresh_python(
        "import sys\n"
        "import meshsmooth\n"
        "assert 'meshio' not in sys.modules and 'pyvista' not in sys.modules, sorted(sys.modules)\n",
        tmp_path,
    )


def test_the_optional_functions_name_the_missing_package(monkeypatch, hex_box):
    # None in sys.modules makes `import meshio` fail as if it were not installed
    monkeypatch.setitem(sys.modules, "meshio", None)
    monkeypatch.setitem(sys.modules, "pyvista", None)
    points, hexes, _ = hex_box
    for call in (lambda: ms.to_meshio(points, hexes), lambda: ms.smooth_meshio(object())):
        with pytest.raises(ImportError, match="needs the optional package meshio.*pip install meshio") as e:
            call()
        assert e.value.name == "meshio"
    with pytest.raises(ImportError, match="smooth_pyvista needs the optional package pyvista") as e:
        ms.smooth_pyvista(object())
    assert e.value.name == "pyvista"
    # the numpy functions do not need them
    assert ms.quality(points, hexes)["inverted"] == 0
    assert ms.from_meshio(ms.MeshArrays(points, [("hexahedron", hexes)], None)).cells[0][0] == "hexahedron"


def corner_jacobians(points, hexes):
    """The determinant of the three edges at each corner of each hexahedron, (m, 8)."""
    p = points[hexes]
    return np.stack([np.linalg.det(p[:, [a, b, d]] - p[:, [c]]) for c, a, b, d in HEX_CORNERS], axis=1)


def test_a_perturbed_numpy_hex_box_smooths_back_to_its_grid():
    # one element starts nearly flat (inverse mean ratio 2.07)
    points, hexes, interior = box(n=6, alpha=0.06, seed=1)
    grid, _, _ = box(n=6, alpha=0.0)
    before = ms.quality(points, hexes)
    assert corner_jacobians(points, hexes).min() > 0 and before["inverted"] == 0
    assert before["objective"] > 1.1 and before["values"].max() > 2
    r = ms.smooth(points, hexes, device="cpu")
    assert r.stop == "converged"
    # the objective and the worst element improve, no corner inverts
    assert abs(r.history["objective"][0] - before["objective"]) < 1e-12
    assert r.objective < before["objective"]
    assert r.quality.max() < before["values"].max()
    assert corner_jacobians(r.points, hexes).min() > 0
    after = ms.quality(r.points, hexes)
    assert after["inverted"] == 0 and abs(after["objective"] - r.objective) < 1e-12
    # the boundary stays; the interior goes back to the regular grid, the optimum
    np.testing.assert_array_equal(r.points[~interior], points[~interior])
    assert r.objective < 1 + 1e-6
    assert np.abs(r.points - grid).max() < 1e-5
