"""The Python package against the CLI and its documented behaviour."""

import _thread
import csv
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import meshsmooth as ms

from conftest import box, grid, hex_to_tets

ROOT = Path(__file__).resolve().parents[2]
VTK_TYPES = {"triangle": 5, "quad": 9, "tetra": 10, "hexahedron": 12, "wedge": 13}


def cli():
    """The release CLI next to this checkout (`cargo test --release` builds it);
    missing, the comparison skips, except under CI, where it fails."""
    exe = Path(os.environ.get("MESHSMOOTH_BIN", ROOT / "target" / "release" / "meshsmooth"))
    if not exe.exists():
        if os.environ.get("CI"):
            pytest.fail(f"{exe} is missing: build it with cargo build --release")
        pytest.skip(f"{exe} is missing: build it with cargo build --release")
    return exe


def write_vtk(path, points, cell_type, cells):
    """Legacy ASCII VTK written here, not by the package, with repr() floats (exact)."""
    k = cells.shape[1]
    lines = ["# vtk DataFile Version 2.0", "box", "ASCII", "DATASET UNSTRUCTURED_GRID"]
    lines.append(f"POINTS {len(points)} double")
    lines += [" ".join(repr(float(c)) for c in p) for p in points]
    lines.append(f"CELLS {len(cells)} {len(cells) * (k + 1)}")
    lines += [f"{k} " + " ".join(str(int(v)) for v in c) for c in cells]
    lines.append(f"CELL_TYPES {len(cells)}")
    lines += [str(VTK_TYPES[cell_type])] * len(cells)
    Path(path).write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("method", ["newton", "bcd", "nlcg"])
def test_box_reaches_the_clis_objective(tmp_path, method):
    points, hexes, _ = box(n=5)
    tets = hex_to_tets(hexes)
    write_vtk(tmp_path / "box.vtk", points, "tetra", tets)
    out = subprocess.run(
        [str(cli()), "smooth", str(tmp_path / "box.vtk"), "-o", str(tmp_path / "out.vtk"),
         "--device", "cpu", "--method", method, "--history", str(tmp_path / "h.csv"), "--quiet"],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader((tmp_path / "h.csv").open()))
    r = ms.smooth(points, tets, method=method)
    assert r.stop == "converged"
    assert r.iterations == int(rows[-1]["iteration"])
    assert abs(r.objective - float(rows[-1]["objective"])) <= 1e-10
    assert abs(r.history["objective"][0] - float(rows[0]["objective"])) <= 1e-10
    cli_points, cli_cells, _ = ms.read(tmp_path / "out.vtk")
    assert np.abs(cli_points - r.points).max() <= 1e-10
    np.testing.assert_array_equal(cli_cells[0][1], tets)


def test_result_fields(hex_box):
    points, hexes, _ = hex_box
    r = ms.smooth(points.astype(np.float32), hexes.astype(np.int32), method="bcd", tol=1e-5)
    assert r.points.dtype == np.float64 and r.points.shape == points.shape
    assert r.objective < r.history["objective"][0]
    assert set(r.history) == {"iteration", "seconds", "objective", "grad_norm"}
    assert len(r.history["objective"]) == r.iterations + 1
    assert r.history["grad_norm"][-1] == r.grad_norm
    assert r.quality.shape == (len(hexes),) and np.all(r.quality >= 1 - 1e-12)
    rep = r.report()
    assert rep["elements"] == len(hexes) and rep["inverted"] == 0
    assert abs(rep["objective"] - r.quality.mean()) < 1e-12
    assert "cpu" in r.info["device"]
    # Newton's counters belong to Newton: None for a sweep method, counts for Newton
    assert r.info["negative_curvature_steps"] is None and r.info["line_search_trials"] is None
    n = ms.smooth(points, hexes, method="newton", tol=1e-5)
    assert n.info["line_search_trials"] >= n.iterations >= 1
    assert 0 <= n.info["negative_curvature_steps"] <= n.iterations


def test_planar_quads_keep_two_columns(quad_grid):
    points, quads, interior = quad_grid
    r = ms.smooth(points, quads)
    assert r.points.shape == points.shape
    assert r.objective < 1 + 1e-9  # a perturbed square grid goes back to squares
    np.testing.assert_array_equal(r.points[~interior], points[~interior])


def test_quality_report_and_values(tet_box):
    points, tets, _ = tet_box
    q = ms.quality(points, tets)
    assert q["elements"] == len(tets) and q["inverted"] == 0
    assert q["values"].shape == (len(tets),)
    assert abs(q["objective"] - ms.smooth(points, tets, max_iter=0).objective) < 1e-12
    assert ms.quality(points, tets, metric="cn")["values"].shape == (len(tets),)


def test_inputs_are_never_modified(hex_box):
    points, hexes, _ = hex_box
    points.flags.writeable = False
    hexes.flags.writeable = False
    before = points.copy()
    r = ms.smooth(points, hexes)
    np.testing.assert_array_equal(points, before)
    assert not np.shares_memory(r.points, points)


@pytest.mark.parametrize("as_indices", [False, True])
def test_fixed_vertices_do_not_move(hex_box, as_indices):
    points, hexes, interior = hex_box
    chosen = np.flatnonzero(interior)[::3]
    mask = np.zeros(len(points), dtype=bool)
    mask[chosen] = True
    r = ms.smooth(points, hexes, fixed=chosen if as_indices else mask)
    np.testing.assert_array_equal(r.points[mask], points[mask])
    np.testing.assert_array_equal(r.points[~interior], points[~interior])
    assert np.any(r.points[interior & ~mask] != points[interior & ~mask])


def test_callback_sees_every_iteration_and_can_stop(hex_box):
    points, hexes, _ = hex_box
    seen = []

    def cb(record):
        seen.append(record)
        return record["iteration"] < 2

    r = ms.smooth(points, hexes, method="bcd", callback=cb)
    assert r.stop == "cancelled" and r.iterations == 2
    assert [s["iteration"] for s in seen] == [0, 1, 2]
    assert seen[-1]["objective"] == r.objective
    assert ms.smooth(points, hexes, callback=lambda rec: None).stop == "converged"


def test_exception_in_callback_propagates_with_input_unchanged(hex_box):
    points, hexes, _ = hex_box
    before = points.copy()

    def cb(record):
        if record["iteration"] == 1:
            raise KeyboardInterrupt
        return True

    with pytest.raises(KeyboardInterrupt):
        ms.smooth(points, hexes, method="bcd", callback=cb)
    np.testing.assert_array_equal(points, before)

    with pytest.raises(ZeroDivisionError):
        ms.smooth(points, hexes, callback=lambda rec: 1 / 0)


def test_ctrl_c_interrupts_between_iterations(hex_box):
    """A SIGINT arriving during the solve (simulated with interrupt_main, as a
    signal from another thread would) stops it at the next iteration."""
    points, hexes, _ = hex_box
    before = points.copy()
    seen = []

    def cb(record):
        seen.append(record["iteration"])
        if record["iteration"] == 1:
            _thread.interrupt_main()
        return True

    with pytest.raises(KeyboardInterrupt):
        ms.smooth(points, hexes, method="bcd", tol=0.0, max_iter=10_000, callback=cb)
    assert seen == [0, 1]
    np.testing.assert_array_equal(points, before)


def test_bad_inputs_raise_documented_errors(tet_box):
    points, tets, _ = tet_box
    with pytest.raises(ValueError, match="non-finite"):
        bad = points.copy()
        bad[3, 1] = np.nan
        ms.smooth(bad, tets)
    with pytest.raises(ValueError, match="out of range"):
        bad = tets.copy()
        bad[0, 0] = len(points)
        ms.smooth(points, bad)
    with pytest.raises(ValueError, match="out of range"):
        bad = tets.copy()
        bad[0, 0] = -1
        ms.smooth(points, bad)
    with pytest.raises(ValueError, match="points must have shape"):
        ms.smooth(np.c_[points, points[:, :1]], tets)
    with pytest.raises(ValueError, match="cells must have"):
        ms.smooth(points, tets[:, :2])
    with pytest.raises(ValueError, match="cells must have shape"):
        ms.smooth(points, tets.ravel())
    with pytest.raises(TypeError, match="cells must be an integer array"):
        ms.smooth(points, tets.astype(float))
    with pytest.raises(TypeError, match="points must be a float"):
        ms.smooth(points.astype(np.int64), tets)
    with pytest.raises(ValueError, match="inverted"):
        flipped = tets.copy()
        flipped[:5, [0, 1]] = flipped[:5, [1, 0]]
        ms.smooth(points, flipped)
    with pytest.raises(ValueError, match="fixed"):
        ms.smooth(points, tets, fixed=np.zeros(3, dtype=bool))
    with pytest.raises(ValueError, match="newtn"):
        ms.smooth(points, tets, method="newtn")
    with pytest.raises(ValueError, match="unsupported cell type"):
        ms.smooth(points, [("pyramid", tets)])
    with pytest.raises(TypeError, match="callback"):
        ms.smooth(points, tets, callback=3)


def test_cell_blocks_and_ambiguous_four_columns(tet_box, quad_grid):
    points, tets, _ = tet_box
    a = ms.smooth(points, tets)
    b = ms.smooth(points, [("tetra", tets[:10]), ("tetra", tets[10:].astype(np.int32))])
    assert a.objective == b.objective
    p2, quads, _ = quad_grid
    flat3 = np.c_[p2, np.full(len(p2), 2.5)]
    r = ms.smooth(flat3, quads)  # z constant: 4 columns are quads
    assert r.points.shape == flat3.shape and np.all(r.points[:, 2] == 2.5)
    assert abs(r.objective - ms.smooth(p2, quads).objective) < 1e-12


def test_read_write_round_trip(tmp_path, tet_box):
    points, tets, _ = tet_box
    for name in ["m.vtu", "m.msh", "m.vtk"]:
        ms.write(tmp_path / name, points, tets)
        p, cells, fixed = ms.read(tmp_path / name)
        np.testing.assert_array_equal(p, points)
        assert [t for t, _ in cells] == ["tetra"]
        np.testing.assert_array_equal(cells[0][1], tets)
    with pytest.raises(OSError):
        ms.read(tmp_path / "missing.vtu")


def test_formats_of_simulation_codes(tmp_path, tet_box):
    points, tets, _ = tet_box
    ms.write(tmp_path / "m.inp", points, tets)
    p, cells, _ = ms.read(tmp_path / "m.inp")
    np.testing.assert_array_equal(p, points)
    np.testing.assert_array_equal(cells[0][1], tets)
    # Exodus II and VTKHDF link C libraries: a wheel built without them says
    # which feature to build with, and writes nothing
    for name, feature in [("m.exo", "exodus"), ("m.vtkhdf", "vtkhdf")]:
        try:
            ms.write(tmp_path / name, points, tets)
        except ValueError as e:
            assert f"--features {feature}" in str(e), e
            assert not (tmp_path / name).exists()
            continue
        p, cells, _ = ms.read(tmp_path / name)
        np.testing.assert_array_equal(p, points)
        np.testing.assert_array_equal(cells[0][1], tets)


def test_surface_formats_round_trip(tmp_path):
    # a flat triangulated square: STL, OBJ and PLY hold surfaces only
    n = 4
    xs = np.linspace(0.0, 1.0, n + 1)
    points = np.array([[x, y, 0.0] for y in xs for x in xs])
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [[a, b, c], [a, c, d]]
    tris = np.array(tris)
    for name, fmt in [("m.stl", None), ("a.stl", "stl-ascii"), ("m.obj", None), ("m.ply", None), ("a.ply", "ply-ascii")]:
        ms.write(tmp_path / name, points, tris, format=fmt)
        p, cells, _ = ms.read(tmp_path / name)
        assert [t for t, _ in cells] == ["triangle"], name
        # STL numbers the vertices as their corners come: compare the corners
        np.testing.assert_allclose(p[cells[0][1]], points[tris], err_msg=name)


def test_boundary_slides_on_a_surface_geometry(tmp_path):
    # the unit cube's 12 triangles as the geometry; the hexahedral box with
    # its boundary vertices moved within their faces and along their edges
    cube = np.array([[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)])
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    tris = np.array([t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])])
    # written by hand: the package writes surfaces only in a plane for now
    facets = "".join(
        "facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {x} {y} {z}\n" for x, y, z in cube[t]) + "endloop\nendfacet\n"
        for t in tris
    )
    (tmp_path / "cube.stl").write_text(f"solid cube\n{facets}endsolid cube\n")
    points, hexes, _ = box(5, alpha=0.0)
    rng = np.random.default_rng(4)
    start = points.copy()
    for v, p in enumerate(points):
        free = (p > 1e-12) & (p < 1 - 1e-12)
        start[v, free] += rng.uniform(-0.06, 0.06, free.sum())
    fixed = ms.smooth(start, hexes)
    slid = ms.smooth(start, hexes, surface=tmp_path / "cube.stl")
    assert slid.objective < fixed.objective - 1e-3
    bound = (start < 1e-12) | (start > 1 - 1e-12)
    # bound coordinates kept: faces stay on their faces, edges on their edges, corners in place
    np.testing.assert_allclose(slid.points[bound], start[bound], atol=1e-9)
    moved = np.abs(slid.points - start).max(axis=1) > 1e-6
    assert (moved & bound.any(axis=1)).sum() > 10
    with pytest.raises(Exception, match="nope.stl"):
        ms.smooth(start, hexes, surface=tmp_path / "nope.stl")


def test_openfoam_case_round_trip(tmp_path, tet_box):
    points, tets, _ = tet_box
    case = tmp_path / "case"
    ms.write(case, points, tets, format="openfoam")
    assert (case / "constant" / "polyMesh" / "faces").is_file()
    (case / "case.foam").touch()
    for path in [case, case / "case.foam", case / "constant" / "polyMesh"]:
        p, cells, fixed = ms.read(path)
        np.testing.assert_array_equal(p, points)
        assert [t for t, _ in cells] == ["tetra"]
        # each cell is rebuilt from its faces: the same points, maybe in another order
        np.testing.assert_array_equal(np.sort(cells[0][1], axis=1), np.sort(tets, axis=1))
        # the boundary faces (one patch) fix their points
        assert fixed is not None and 0 < fixed.sum() < len(points)


def test_gpu_device_matches_cpu(tet_box):
    usable = [d for d in ms.devices() if d["compute"]]
    if not usable:
        if os.environ.get("CI"):
            pytest.fail("no GPU adapter (lavapipe should be installed by .ci/install-test-deps)")
        pytest.skip("no GPU adapter with compute shaders")
    points, tets, _ = tet_box
    cpu = ms.smooth(points, tets)
    try:
        gpu = ms.smooth(points, tets, device="gpu", tol=1e-5)
    except RuntimeError as e:
        if os.environ.get("CI"):
            raise
        pytest.skip(f"GPU unusable here: {e}")
    assert gpu.stop in ("converged", "stalled")
    assert "cpu" not in gpu.info["device"].split(" ")[0]
    assert abs(gpu.objective - cpu.objective) < 1e-5
    assert abs(gpu.objective - ms.quality(gpu.points, tets)["objective"]) < 1e-6


def test_stopping_rules(hex_box):
    points, hexes, _ = hex_box
    assert ms.smooth(points, hexes, max_iter=1).stop == "max_iterations"
    assert ms.smooth(points, hexes, time_limit=1e-9).stop == "time_limit"
    with pytest.raises(ValueError, match="time_limit: must be a positive number of seconds"):
        ms.smooth(points, hexes, time_limit=0.0)
    assert ms.smooth(points, hexes, time_limit=1e300).stop == "converged"
    with pytest.raises(ValueError, match="time_limit"):
        ms.smooth(points, hexes, time_limit=-1.0)
    with pytest.raises(ValueError, match="f32"):
        ms.smooth(points, hexes, device="cpu", precision="f32")
    with pytest.raises(ValueError, match="device"):
        ms.smooth(points, hexes, device="tpu")
    with pytest.raises(ValueError, match="boundary"):
        ms.smooth(points, hexes, boundary="free")
    with pytest.raises(ValueError, match="feature_angle"):
        ms.smooth(points, hexes, boundary="slide", feature_angle=200.0)


def test_sliding_boundary_keeps_sides_and_corners(quad_grid):
    points, quads, interior = quad_grid
    p = points.copy()
    rng = np.random.default_rng(3)
    for k in range(2):
        # boundary vertices strictly inside a side running along axis k move along it
        along = ~interior & (points[:, k] > 0) & (points[:, k] < 1)
        p[along, k] += rng.uniform(-0.05, 0.05, along.sum())
    fixed = ms.smooth(p, quads)
    slid = ms.smooth(p, quads, boundary="slide")
    assert slid.objective < fixed.objective - 1e-4
    on = (points == 0.0) | (points == 1.0)
    assert np.abs(slid.points[on] - p[on]).max() <= 1e-12
    corners = on.all(axis=1)
    assert np.array_equal(slid.points[corners], p[corners])
    assert not np.array_equal(slid.points[~interior], p[~interior])


def test_vertex_orders_reach_one_optimum_and_report_their_times(hex_box):
    points, hexes, _ = hex_box
    base = ms.smooth(points, hexes, method="bcd", order="n", tol=1e-9)
    for order in ["WQP", "-d-grvm", "reverse-lng", "r", "red-black", "cuthill-mckee"]:
        r = ms.smooth(points, hexes, method="bcd", order=order, tol=1e-9)
        assert abs(r.objective - base.objective) <= 1e-8 * base.objective, order
        np.testing.assert_allclose(r.points, base.points, atol=1e-5)
    r = ms.smooth(points, hexes, method="bcd", order="gavm", reorder_every=2, inner_iterations=2, max_iter=6)
    assert r.info["reorderings"] == 4
    assert r.info["optimise_seconds"] + r.info["reorder_seconds"] <= r.info["seconds"]
    with pytest.raises(ValueError, match="unknown ordering 'wqpp'"):
        ms.smooth(points, hexes, order="wqpp")
    with pytest.raises(ValueError, match="reorder_every"):
        ms.smooth(points, hexes, order="rbfs", reorder_every=2)


def test_target_objective_stops_at_the_first_sweep_below_it(hex_box):
    points, hexes, _ = hex_box
    full = ms.smooth(points, hexes, method="bcd", order="d-lng")
    f0 = full.history["objective"][0]
    target = full.objective + 0.2 * (f0 - full.objective)
    r = ms.smooth(points, hexes, method="bcd", order="d-lng", target_objective=target)
    assert r.stop == "target_reached"
    assert r.objective <= target < r.history["objective"][-2]


@pytest.mark.parametrize(
    "options, flags",
    [
        ({}, []),
        ({"preconditioner": "jacobi", "inversion_fraction": 0.0},
         ["--preconditioner", "jacobi", "--inversion-fraction", "0"]),
        ({"preconditioner": "sgs", "negative_curvature": "direction"},
         ["--preconditioner", "sgs", "--negative-curvature", "direction"]),
    ],
)
def test_newton_options_match_the_cli(tmp_path, options, flags):
    points, quads, _ = grid(n=14, alpha=0.3, seed=5)
    planar = np.c_[points, np.zeros(len(points))]
    write_vtk(tmp_path / "g.vtk", planar, "quad", quads)
    out = subprocess.run(
        [str(cli()), "smooth", str(tmp_path / "g.vtk"), "-o", str(tmp_path / "out.vtk"), "--device", "cpu",
         "--method", "newton", "--history", str(tmp_path / "h.csv"), "--quiet", *flags],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader((tmp_path / "h.csv").open()))
    r = ms.smooth(points, quads, method="newton", **options)
    assert r.stop == "converged"
    assert r.iterations == int(rows[-1]["iteration"])
    np.testing.assert_allclose(r.history["objective"], [float(x["objective"]) for x in rows], rtol=0, atol=1e-12)
    # whatever the options, the same optimum: the squares of the grid
    assert r.objective < 1 + 1e-9


def test_newton_defaults_follow_the_cli_and_bad_options_are_refused(quad_grid):
    points, quads, _ = quad_grid
    auto = ms.smooth(points, quads)
    # planar on the CPU, "auto" is symmetric Gauss-Seidel, as on the command line
    sgs = ms.smooth(points, quads, preconditioner="sgs")
    jacobi = ms.smooth(points, quads, preconditioner="jacobi")
    assert auto.info["cg_iterations"] == sgs.info["cg_iterations"] != jacobi.info["cg_iterations"]
    np.testing.assert_array_equal(auto.points, sgs.points)
    assert abs(jacobi.objective - auto.objective) < 1e-9
    with pytest.raises(ValueError, match="preconditioner must be one of 'auto', 'jacobi', 'sgs', got \"ilu\""):
        ms.smooth(points, quads, preconditioner="ilu")
    with pytest.raises(ValueError, match="negative_curvature must be one of"):
        ms.smooth(points, quads, negative_curvature="none")
    with pytest.raises(ValueError, match="inversion fraction 1 must be at least 0 and below 1"):
        ms.smooth(points, quads, inversion_fraction=1.0)


def test_points_used_by_no_cell_are_kept_bit_for_bit(tet_box):
    points, tets, interior = tet_box
    n = len(points)
    extra = np.array([[0.51, 0.49, 0.5], [0.3, 0.7, 0.1 + 1e-17], [9.0, -3.0, 1e-300]])
    r = ms.smooth(np.r_[points, extra], tets, device="cpu")
    assert r.points.shape == (n + 3, 3)
    assert r.points[n:].tobytes() == extra.tobytes()
    np.testing.assert_array_equal(r.points[:n][~interior], points[~interior])
    assert np.any(r.points[:n][interior] != points[interior])
    assert r.objective < ms.quality(points, tets)["objective"]
    assert "3 points are used by no element: kept where they are" in r.info["notes"]
    q = ms.quality(np.r_[points, extra], tets)
    assert q["vertices"] == n + 3 and q["elements"] == len(tets)
