"""Mesh quality improvement by vertex repositioning, on numpy arrays and meshio meshes.

meshsmooth moves the free vertices of an unstructured mesh (triangles,
quadrilaterals, tetrahedra, hexahedra, prisms) to minimise a shape objective
F: by default the inverse mean ratio (``imr``) averaged over the element
corners. F is unit-free and equals 1 on a mesh of ideal elements; the mesh's
boundary skin and the vertices you mark ``fixed`` never move, and every
result is free of inverted elements.

Example::

    import meshio, meshsmooth
    mesh = meshio.read("in.vtk")
    smoothed = meshsmooth.smooth_meshio(mesh, method="newton")
    smoothed.write("out.vtk")

The work is done by the Rust library (``meshsmooth._core``) with the GIL
released; Ctrl-C stops a solve between iterations with ``KeyboardInterrupt``.

numpy is the only dependency. meshio (for :func:`smooth_meshio` and
:func:`to_meshio`) and PyVista (for :func:`smooth_pyvista`) are optional:
those functions raise an ImportError naming the missing package.
"""

from __future__ import annotations

import importlib
import os
from typing import Any, Callable, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

# Mesa's device-select Vulkan layer probes the display server and prints errors
# ("XDG_RUNTIME_DIR is invalid") on headless machines; as the CLI does, turn it off
# unless the caller set it (meshsmooth picks adapters itself). Read when wgpu first
# creates a Vulkan instance, so it must be set before any call into _core.
os.environ.setdefault("NODEVICE_SELECT", "1")

from . import _core

__all__ = [
    "MeshArrays",
    "Result",
    "UntangleResult",
    "devices",
    "from_meshio",
    "quality",
    "read",
    "smooth",
    "smooth_meshio",
    "smooth_pyvista",
    "to_meshio",
    "untangle",
    "write",
]

__version__: str = _core.VERSION

#: meshio's cell type names and the library's element kinds.
_MESHIO_TO_KIND = {
    "triangle": "triangle",
    "quad": "quadrilateral",
    "tetra": "tetrahedron",
    "hexahedron": "hexahedron",
    "wedge": "prism",
}
_KIND_TO_MESHIO = {v: k for k, v in _MESHIO_TO_KIND.items()}
_KIND_CODE = {name: code for code, name in enumerate(_core.KIND_NAMES)}
_NODES = {"triangle": 3, "quad": 4, "tetra": 4, "hexahedron": 8, "wedge": 6}
_DIM = {"triangle": 2, "quad": 2, "tetra": 3, "hexahedron": 3, "wedge": 3}
#: meshio's lower-dimensional cells: kept, never optimised, their vertices fixed.
_LOWER = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2}

CellBlocks = List[Tuple[str, np.ndarray]]
CellsLike = Union[npt.ArrayLike, Sequence[Tuple[str, npt.ArrayLike]]]
Callback = Callable[[Dict[str, float]], Optional[bool]]


class MeshArrays(NamedTuple):
    """A mesh as arrays: ``points`` (n, 2|3) float64, ``cells`` a list of
    ``(meshio cell type, (m, k) int64 array)`` blocks, ``fixed`` a boolean
    mask of vertices that must not move, or None."""

    points: np.ndarray
    cells: CellBlocks
    fixed: Optional[np.ndarray]


class Result:
    """What :func:`smooth` returns.

    Attributes:
        points: the new positions, a new float64 array with the input's shape.
        objective: F at the end (unit-free; 1 for ideal elements).
        grad_norm: 2-norm of the free-vertex gradient of F, lengths measured in
            mean edge lengths of the start (unit-free; the quantity ``tol`` bounds).
        iterations: Newton or NLCG iterations or sweeps (bcd, laplace) run.
        stop: why it stopped: "converged", "stalled", "max_iterations",
            "time_limit", "target_reached", "small_step" (nlcg: a step moved no
            vertex measurably) or "cancelled" (the callback returned False).
        history: numpy arrays per column: "iteration", "seconds", "objective",
            "grad_norm"; row 0 is the start.
        quality: per-cell inverse mean ratio at the new positions (1 is ideal).
        info: everything else the solver reported (device, seconds,
            setup_seconds, memory_bytes, colors, cg_iterations, method;
            Newton's negative_curvature_steps and line_search_trials, None
            for the other methods;
            optimise_seconds, reorder_seconds and reorderings: the
            reordering paper's COT, RT and the number of sweep orderings).
        untangle: what untangling a tangled input did first (the keys of
            :func:`untangle`'s ``info``), or None for an untangled input.
        targets: with ``target="auto"``, the line saying why the mesh's own
            (input) targets were chosen; None where the ideal shape was.
    """

    points: np.ndarray
    objective: float
    grad_norm: float
    iterations: int
    stop: str
    history: Dict[str, np.ndarray]
    quality: np.ndarray
    info: Dict[str, Any]

    def __init__(self, points: np.ndarray, info: Dict[str, Any]) -> None:
        self.points = points
        self.objective = float(info["objective"])
        self.grad_norm = float(info["grad_norm"])
        self.iterations = int(info["iterations"])
        self.stop = str(info["stop"])
        self.history = dict(info["history"])
        self.quality = info["quality"]
        self._report: Dict[str, Any] = info["report"]
        self.untangle: Optional[Dict[str, Any]] = info.get("untangle")
        self.targets: Optional[str] = info.get("targets")
        self.info = {k: v for k, v in info.items() if k not in ("history", "quality", "report", "untangle", "targets")}

    def report(self) -> Dict[str, Any]:
        """The quality report of the result (the keys of ``meshsmooth quality --json``)."""
        import copy

        return copy.deepcopy(self._report)

    def __repr__(self) -> str:
        return (
            f"Result(objective={self.objective!r}, grad_norm={self.grad_norm:.3e}, "
            f"iterations={self.iterations}, stop={self.stop!r}, device={self.info.get('device')!r})"
        )


def _check_points(points: npt.ArrayLike, name: str = "points") -> np.ndarray:
    if isinstance(points, np.ndarray):
        a = points
        if a.dtype.kind != "f":
            raise TypeError(f"{name} must be a float32 or float64 array, got dtype {a.dtype}")
    else:
        try:
            a = np.asarray(points, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise TypeError(f"{name} must be an (n, 2) or (n, 3) array of floats: {e}") from None
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (n, 2) or (n, 3), got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name} is empty")
    return a


def _as3(points: np.ndarray) -> np.ndarray:
    """(n, 3) C-contiguous float64: the input itself where it already is one."""
    if points.shape[1] == 2:
        out = np.zeros((points.shape[0], 3), dtype=np.float64)
        out[:, :2] = points
        return out
    return np.ascontiguousarray(points, dtype=np.float64)


def _check_block(data: npt.ArrayLike, name: str) -> np.ndarray:
    a = data if isinstance(data, np.ndarray) else np.asarray(data)
    if a.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer array (int32 or int64), got dtype {a.dtype}")
    if a.ndim != 2:
        raise ValueError(f"{name} must have shape (m, k), got {a.shape}")
    return a


def _check_cells(cells: CellsLike, points: np.ndarray, name: str = "cells") -> CellBlocks:
    """The cells as meshio-named blocks, with their shapes and index range checked."""
    n = points.shape[0]
    if isinstance(cells, np.ndarray) or (
        isinstance(cells, (list, tuple)) and len(cells) > 0 and not _is_block(cells[0])
    ):
        a = _check_block(cells, name)
        k = a.shape[1]
        flat = points.shape[1] == 2 or bool(np.all(points[:, 2] == points[0, 2]))
        by_nodes = {3: "triangle", 4: "quad" if flat else "tetra", 6: "wedge", 8: "hexahedron"}
        if k not in by_nodes:
            raise ValueError(
                f"{name} must have 3 (triangle), 4 (quad or tetra), 6 (wedge) or 8 (hexahedron) columns, got {k}"
            )
        blocks = [(by_nodes[k], a)]
    else:
        if not isinstance(cells, (list, tuple)) or len(cells) == 0:
            raise TypeError(f"{name} must be an (m, k) integer array or a non-empty list of (cell_type, array) blocks")
        blocks = []
        for i, block in enumerate(cells):
            if not _is_block(block):
                raise TypeError(f"{name}[{i}] must be a (cell_type, array) pair")
            ctype, data = _block_parts(block)
            if ctype not in _MESHIO_TO_KIND:
                raise ValueError(
                    f"{name}[{i}]: unsupported cell type {ctype!r}; supported: {', '.join(_MESHIO_TO_KIND)}"
                )
            a = _check_block(data, f"{name}[{i}] ({ctype})")
            if a.shape[1] != _NODES[ctype]:
                raise ValueError(f"{name}[{i}]: a {ctype} has {_NODES[ctype]} vertices, got {a.shape[1]} columns")
            blocks.append((ctype, a))
    for ctype, a in blocks:
        if a.size and (a.min() < 0 or a.max() >= n):
            bad = a[(a < 0) | (a >= n)][0]
            raise ValueError(f"{name}: vertex index {bad} out of range for {n} points (ids 0..{n - 1})")
    return blocks


def _is_block(x: Any) -> bool:
    if hasattr(x, "type") and hasattr(x, "data"):  # meshio.CellBlock
        return True
    return isinstance(x, tuple) and len(x) == 2 and isinstance(x[0], str)


def _block_parts(block: Any) -> Tuple[str, Any]:
    if hasattr(block, "type") and hasattr(block, "data"):
        return str(block.type), block.data
    return block[0], block[1]


def _flatten(blocks: CellBlocks) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    kinds = np.concatenate(
        [np.full(len(a), _KIND_CODE[_MESHIO_TO_KIND[t]], dtype=np.uint8) for t, a in blocks]
    )
    sizes = np.concatenate([np.full(len(a), a.shape[1], dtype=np.int64) for t, a in blocks])
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    conn = np.concatenate([a.reshape(-1) for _, a in blocks]).astype(np.uint32)
    return kinds, offsets, conn


def _check_fixed(fixed: Optional[npt.ArrayLike], n: int) -> Optional[np.ndarray]:
    if fixed is None:
        return None
    a = np.asarray(fixed)
    if a.ndim != 1:
        raise ValueError(f"fixed must be a 1-D boolean mask or index array, got shape {a.shape}")
    if a.dtype == np.bool_:
        if len(a) != n:
            raise ValueError(f"fixed: the mask has {len(a)} entries but there are {n} points")
        return np.ascontiguousarray(a)
    if a.dtype.kind in "iu" or a.size == 0:
        a = a.astype(np.int64)
        if a.size and (a.min() < -n or a.max() >= n):
            raise ValueError(f"fixed: vertex index out of range for {n} points")
        mask = np.zeros(n, dtype=np.bool_)
        mask[a] = True
        return mask
    raise TypeError(f"fixed must be a boolean mask or an integer index array, got dtype {a.dtype}")


def _checked(
    points: npt.ArrayLike,
    cells: CellsLike,
    fixed: Optional[npt.ArrayLike],
    boundary: str,
    method: str,
    metric: Optional[str],
    template: str,
    device: str,
    precision: str,
) -> Tuple[np.ndarray, Tuple[np.ndarray, ...]]:
    """The checks :func:`smooth` and :func:`untangle` share: the points, and
    the mesh as ``_core.smooth``'s first five arguments."""
    p = _check_points(points)
    blocks = _check_cells(cells, p)
    mask = _check_fixed(fixed, p.shape[0])
    if boundary not in ("fixed", "slide"):
        raise ValueError(f"boundary must be 'fixed' or 'slide', got {boundary!r}")
    for arg, value in (("method", method), ("metric", metric), ("template", template), ("device", device), ("precision", precision)):
        if arg == "metric" and value is None:
            continue
        if not isinstance(value, str):
            raise TypeError(f"{arg} must be a string, got {type(value).__name__}")
    kinds, offsets, conn = _flatten(blocks)
    return p, (_as3(p), kinds, offsets, conn, mask)


def smooth(
    points: npt.ArrayLike,
    cells: CellsLike,
    *,
    method: str = "newton",
    metric: Optional[str] = None,
    target: str = "auto",
    fields: Optional[Dict[str, npt.ArrayLike]] = None,
    template: str = "harmonic",
    fixed: Optional[npt.ArrayLike] = None,
    boundary: str = "fixed",
    feature_angle: float = 30.0,
    surface: Optional[Union[str, os.PathLike]] = None,
    device: str = "auto",
    precision: str = "auto",
    adapter: Optional[str] = None,
    tol: float = 1e-6,
    max_iter: int = 1000,
    time_limit: Optional[float] = None,
    callback: Optional[Callback] = None,
    untangle: bool = True,
    order: str = "rbfs",
    order_seed: int = 0,
    reorder_every: Optional[int] = None,
    inner_iterations: int = 1,
    target_objective: Optional[float] = None,
    preconditioner: str = "auto",
    negative_curvature: str = "iterate",
    inversion_fraction: float = 0.7,
    start_sweeps: int = 0,
) -> Result:
    """Smooths a mesh: moves its free vertices to minimise the objective F.
    A mesh with inverted elements is untangled first (as the CLI's ``smooth``;
    ``untangle=False`` refuses it instead, like ``--no-untangle``).

    Args:
        points: (n, 2) or (n, 3) float32/float64 array of vertex coordinates (any
            unit: the answer does not depend on it). Never modified.
        cells: an (m, k) int32/int64 array of vertex ids (k = 3 triangles,
            4 quads for planar points or tetrahedra otherwise, 6 wedges,
            8 hexahedra, in VTK/meshio order), or a list of ``(cell_type,
            array)`` blocks with meshio's names "triangle", "quad", "tetra",
            "hexahedron", "wedge" (meshio ``CellBlock``s work too).
        method: "newton" (inexact Newton with block-Jacobi PCG), "bcd" (block
            coordinate descent, per-vertex Newton), "bcd-colored" (the same,
            colour by colour), "nlcg" (nonlinear conjugate gradients with a
            strong-Wolfe line search) or "laplace" (smart Laplacian, CPU only).
        metric: "imr" (inverse mean ratio), "cn" (condition number),
            "shape-size" (keeps the targets' sizes as well as their shapes)
            or "tmp" (target matrix). None: "imr", or "shape-size" with
            constructed targets.
        target: where each corner's target comes from: "auto" (the default:
            "input" with shape-size where the mesh has a boundary layer or
            wall grading, as ``Result.info["targets"]`` then says, "ideal"
            otherwise), "ideal" (each kind's ideal corner), "input" (the
            input's own corners, regularised), "size:NAME" (a scalar field
            of target edge lengths in ``fields``) or "metric:NAME" (a
            symmetric-tensor field, 3 or 6 components, unit edges in it).
        fields: point-data arrays by name, of shape (n,) or (n, k), for the
            size and metric targets.
        template: "harmonic" (minimise the mean metric) or "average" (maximise
            the mean quality 1/metric).
        fixed: vertices that must not move besides the boundary skin (fixed
            unless ``boundary="slide"``): a boolean mask of length n or an index array.
        boundary: "fixed" (the boundary skin never moves) or "slide" (boundary
            vertices move within their boundary face or along their feature
            edge and stay on the original boundary; corners stay).
        feature_angle: with ``boundary="slide"``, faces meeting at more than
            this many degrees form a feature edge, and an edge turning by more
            than it makes a corner.
        surface: a triangulated geometry file (STL, OBJ, PLY, VTK, Gmsh; typically
            a finer export of the CAD surface) for a volume mesh's boundary to
            slide on instead of its own skin: every boundary vertex is projected
            onto it, on its patches, along its feature curves, and its corners
            stay. Implies ``boundary="slide"``.
        device: "auto" (a hardware GPU when there is one, else the CPU;
            ``Result.info["notes"]`` says why the CPU was chosen), "cpu" (f64
            on all cores) or "gpu" (wgpu; bcd runs colour by colour).
        precision: GPU arithmetic "f32", "f64" or "auto" (f64 where the adapter has it).
        adapter: use the GPU adapter whose name contains this.
        tol: stop when the 2-norm of the free-vertex gradient of F, with
            lengths measured in mean edge lengths of the start (unit-free, like
            F), falls below this.
        max_iter: most Newton iterations or sweeps (bcd, laplace).
        time_limit: stop after this many seconds (the mesh so far is kept; it is always valid).
        callback: called with a dict (iteration, seconds, objective,
            grad_norm) for the start and after every iteration; returning
            False stops the solve (``stop == "cancelled"``). An exception it
            raises propagates, with the input unchanged.
        untangle: untangle a tangled input first (``Result.untangle`` says
            what that did); False raises ValueError on inverted elements.
        order: the vertex order, the CLI's ``--order`` names in any case:
            "rbfs" (default), "cuthill-mckee", "red-black", or a scheme of the
            vertex-reordering paper ("n", "r", "wqp", "gavm", "grvm", "lng",
            "d-wqp", "d-gavm", "d-grvm", "d-lng", each reversed as
            "reverse-NAME" or "-NAME"), which orders the sequential sweep of
            ``method="bcd"`` on the CPU.
        order_seed: seed of the random orders "r" and "-r".
        reorder_every: with a paper scheme, order the sweep again after every
            this many sweeps (dynamic); None orders it once (static).
        inner_iterations: Newton steps per vertex visit of the sequential sweep.
        target_objective: also stop as soon as F is at or below this.
        preconditioner: Newton's CG preconditioner: "auto" (the CLI's default:
            symmetric block Gauss-Seidel for planar meshes on the CPU, block
            Jacobi elsewhere), "jacobi" (block Jacobi, the Newton paper's; every
            device) or "sgs" (symmetric block Gauss-Seidel; CPU only).
        negative_curvature: what Newton's CG returns on negative curvature:
            "iterate" (the CG iterate so far) or "direction" (the paper's).
        inversion_fraction: after a Newton trial step that inverts an element,
            try this fraction (0 <= f < 1) of the distance at which the first
            corner inverts; 0 halves the step as the paper's Armijo search does.
        start_sweeps: Newton: at most this many coloured BCD sweeps before the
            first Newton step, ending once a sweep gains more than a quarter of
            the one before; 0 (the default) starts with Newton, as the paper
            does. Sweeps first pay on large, badly perturbed meshes, where
            Newton's early steps meet negative curvature.

    Points no cell uses (a Gmsh mesh exported with its volume cells only)
    are kept where they are, bit for bit; ``Result.info["notes"]`` says how many.

    Returns:
        A :class:`Result`; ``Result.points`` is a new float64 array.

    Raises:
        TypeError: wrong dtype of points, cells or fixed, or a callback that is not callable.
        ValueError: wrong shapes, out-of-range ids, a mesh the library refuses
            (non-finite coordinates, inverted or degenerate elements,
            duplicate vertices), unknown option names.
        RuntimeError: the GPU failed (no adapter, device lost).
        KeyboardInterrupt: Ctrl-C during the solve.
    """
    if callback is not None and not callable(callback):
        raise TypeError(f"callback must be callable, got {type(callback).__name__}")
    p, mesh = _checked(points, cells, fixed, boundary, method, metric, template, device, precision)
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 0:
        raise ValueError(f"max_iter must be a non-negative integer, got {max_iter!r}")
    settings = _settings(
        method=method, metric=metric, target=target, template=template, boundary=boundary,
        feature_angle=float(feature_angle), device=device, precision=precision, adapter=adapter,
        surface=None if surface is None else os.fspath(surface),
        tol=float(tol), max_iter=int(max_iter),
        time_limit=None if time_limit is None else float(time_limit),
        untangle=bool(untangle), order=str(order), order_seed=int(order_seed),
        reorder_every=None if reorder_every is None else int(reorder_every),
        inner_iterations=int(inner_iterations),
        target_objective=None if target_objective is None else float(target_objective),
        preconditioner=str(preconditioner), negative_curvature=str(negative_curvature),
        inversion_fraction=float(inversion_fraction),
        start_sweeps=_count("start_sweeps", start_sweeps),
    )
    out, info = _core.smooth(*mesh, settings, callback, fields=_fields(fields, p.shape[0]))
    return Result(np.ascontiguousarray(out[:, : p.shape[1]]), info)


def _count(name: str, value: Any) -> int:
    """A non-negative integer setting, or a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
    return int(value)


def _settings(**settings: Any) -> str:
    """The settings as the JSON object the library's ``Smoother`` reads: the
    keys are the keywords, and every check and default is the library's (the
    command line's)."""
    import json

    return json.dumps(settings)


def _fields(fields: Optional[Dict[str, npt.ArrayLike]], n: int) -> Optional[Dict[str, np.ndarray]]:
    if fields is None:
        return None
    if not isinstance(fields, dict):
        raise TypeError(f"fields must be a dict of name -> array, got {type(fields).__name__}")
    return {str(k): np.ascontiguousarray(np.asarray(v, dtype=np.float64)) for k, v in fields.items()}


class UntangleResult:
    """What :func:`untangle` returns.

    Attributes:
        points: the untangled positions, a new float64 array with the input's shape.
        info: None when the input had no inverted element, else a dict:
            inverted_before / inverted_after (elements), inverted_corners_before,
            corners_before / corners_after (corners below the margin), rounds
            (eps values tried), iterations (inner iterations in all), seconds, device.
        quality: per-cell inverse mean ratio at the new positions.
    """

    def __init__(self, points: np.ndarray, info: Dict[str, Any]) -> None:
        self.points = points
        self.info: Optional[Dict[str, Any]] = info["untangle"]
        self.quality = info["quality"]
        self._report: Dict[str, Any] = info["report"]

    def report(self) -> Dict[str, Any]:
        """The quality report of the result (the keys of ``meshsmooth quality --json``)."""
        import copy

        return copy.deepcopy(self._report)

    def __repr__(self) -> str:
        return f"UntangleResult(info={self.info!r})"


def untangle(
    points: npt.ArrayLike,
    cells: CellsLike,
    *,
    method: str = "newton",
    metric: Optional[str] = None,
    template: str = "harmonic",
    fixed: Optional[npt.ArrayLike] = None,
    boundary: str = "fixed",
    feature_angle: float = 30.0,
    device: str = "auto",
    precision: str = "auto",
    adapter: Optional[str] = None,
) -> UntangleResult:
    """Untangles a mesh with inverted elements, and only that (the library's
    ``solve::untangle_mesh``, the CLI's ``meshsmooth untangle``): the free
    vertices move until no element is inverted; an untangled input comes back
    unchanged with ``info`` None. Arguments as for :func:`smooth` (``laplace``
    untangles with ``newton``).

    Raises:
        ValueError: as for :func:`smooth`, and when elements stay inverted
            (the message counts them).
        RuntimeError: the GPU failed.
    """
    p, mesh = _checked(points, cells, fixed, boundary, method, metric, template, device, precision)
    settings = _settings(
        method=method, metric=metric, template=template, boundary=boundary,
        feature_angle=float(feature_angle), device=device, precision=precision, adapter=adapter,
    )
    out, info = _core.smooth(*mesh, settings, None, untangle_only=True)
    return UntangleResult(np.ascontiguousarray(out[:, : p.shape[1]]), info)


def quality(points: npt.ArrayLike, cells: CellsLike, metric: str = "imr") -> Dict[str, Any]:
    """The quality report of a mesh (the keys of ``meshsmooth quality --json``:
    eta and volume statistics, histogram, worst and inverted elements,
    ``objective`` = mean inverse mean ratio) plus ``values``: the per-cell
    value of ``metric`` (NaN where a cell is inverted) and ``metric``."""
    p = _check_points(points)
    kinds, offsets, conn = _flatten(_check_cells(cells, p))
    report, values = _core.quality(_as3(p), kinds, offsets, conn, metric)
    report["metric"] = metric
    report["values"] = values
    return dict(report)


def _blocks_of(kinds: np.ndarray, offsets: np.ndarray, conn: np.ndarray) -> CellBlocks:
    """Consecutive runs of one kind as meshio blocks."""
    blocks: CellBlocks = []
    start = 0
    m = len(kinds)
    while start < m:
        end = start
        while end < m and kinds[end] == kinds[start]:
            end += 1
        k = int(offsets[start + 1] - offsets[start])
        data = conn[offsets[start] : offsets[end]].astype(np.int64).reshape(end - start, k)
        blocks.append((_KIND_TO_MESHIO[_core.KIND_NAMES[kinds[start]]], data))
        start = end
    return blocks


def read(path: Union[str, "os.PathLike[str]"]) -> MeshArrays:
    """Reads a mesh with the library's readers (.vtk, .vtu, .msh, .mesh, .inp,
    .stl, .obj, .ply, or an OpenFOAM case folder):
    its points, cell blocks and fixed vertices (None when the file marks none).
    Point and cell data are not returned; use meshio and :func:`from_meshio` for them."""
    points, kinds, offsets, conn, fixed = _core.read(os.fspath(path))
    return MeshArrays(points, _blocks_of(kinds, offsets, conn), fixed)


def write(
    path: Union[str, "os.PathLike[str]"],
    points: npt.ArrayLike,
    cells: CellsLike,
    *,
    format: Optional[str] = None,
) -> None:
    """Writes a mesh with the library's writers, with the per-cell
    ``inverse_mean_ratio``; refuses (writing nothing) a mesh with inverted
    cells. ``format`` (vtk, vtk-binary, vtu, vtu-binary, vtu-zlib, msh2,
    msh2-binary, msh4, msh4-binary, medit, abaqus, openfoam, openfoam-binary,
    stl, stl-ascii, obj, ply, ply-ascii, vtp, vtp-ascii, vtp-zlib)
    defaults to the extension's; ``openfoam`` writes ``path`` as an OpenFOAM
    case folder (its faces built from the cells, one ``defaultFaces`` patch)."""
    p = _check_points(points)
    kinds, offsets, conn = _flatten(_check_cells(cells, p))
    _core.write(os.fspath(path), _as3(p), kinds, offsets, conn, format)


def devices() -> List[Dict[str, Any]]:
    """The GPU adapters wgpu finds, best first (as ``meshsmooth devices`` lists them)."""
    return list(_core.devices())


def _optional(module: str, caller: str) -> Any:
    """The optional dependency `module` (meshio, pyvista), imported; missing,
    an ImportError that names it and the function that needs it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(
            f"meshsmooth.{caller} needs the optional package {module}, which is not installed "
            f"(pip install {module})",
            name=module,
        ) from e


def from_meshio(mesh: Any) -> MeshArrays:
    """The cells of a meshio mesh that meshsmooth optimises (the blocks of
    the highest dimension), with its points; the vertices of its
    lower-dimensional cells (boundary lines, faces, points) come back as
    ``fixed`` (None when it has none)."""
    points = _check_points(np.asarray(mesh.points), "mesh.points")
    parts = [_block_parts(c) for c in mesh.cells]
    dims = [_DIM[t] for t, _ in parts if t in _DIM]
    if not dims:
        raise ValueError(
            "the mesh has no cells meshsmooth optimises (triangle, quad, tetra, hexahedron, wedge); "
            f"it has {', '.join(sorted({t for t, _ in parts})) or 'none'}"
        )
    top = max(dims)
    cells: CellBlocks = [(t, np.asarray(d)) for t, d in parts if _DIM.get(t) == top]
    fixed: Optional[np.ndarray] = None
    lower = [np.asarray(d) for t, d in parts if _DIM.get(t) != top and _LOWER.get(t, 99) < top]
    if lower:
        fixed = np.zeros(len(points), dtype=np.bool_)
        for d in lower:
            fixed[d.reshape(-1)] = True
    return MeshArrays(points, cells, fixed)


def to_meshio(
    points: npt.ArrayLike,
    cells: CellsLike,
    point_data: Optional[Dict[str, Any]] = None,
    cell_data: Optional[Dict[str, Any]] = None,
    field_data: Optional[Dict[str, Any]] = None,
) -> Any:
    """A ``meshio.Mesh`` of points and cell blocks (needs meshio)."""
    meshio = _optional("meshio", "to_meshio")

    p = _check_points(points)
    blocks = _check_cells(cells, p)
    return meshio.Mesh(p, blocks, point_data=point_data or {}, cell_data=cell_data or {}, field_data=field_data or {})


def _smooth_parts(
    points: np.ndarray, parts: List[Tuple[str, Any]], kwargs: Dict[str, Any], point_data: Optional[Dict[str, Any]] = None
) -> Tuple[np.ndarray, Result]:
    """New positions for all `points` of a mesh given as meshio-named cell
    blocks: the blocks of the highest dimension are optimised, the vertices of
    lower ones fixed, points no optimised cell uses left where they are. A
    size or metric target reads its field from `point_data` unless
    ``fields`` is given."""
    arrays = from_meshio(_Parts(points, parts))
    n = len(arrays.points)
    user_fixed = _check_fixed(kwargs.pop("fixed", None), n)
    fixed = arrays.fixed
    if user_fixed is not None:
        fixed = user_fixed if fixed is None else (fixed | user_fixed)
    # points no optimised cell uses (gmsh geometry points, say) the library keeps where they are
    fields = kwargs.pop("fields", None)
    if fields is None and point_data and str(kwargs.get("target", "")).startswith(("size:", "metric:")):
        fields = {k: v for k, v in point_data.items() if np.asarray(v).dtype.kind in "fiu" and len(v) == n}
    result = smooth(arrays.points, arrays.cells, fixed=fixed, fields=fields, **kwargs)
    new_points = np.array(points, dtype=np.float64, copy=True)
    new_points[:, : result.points.shape[1]] = result.points
    return new_points, result


class _Parts:
    """The two attributes of a meshio mesh that from_meshio reads."""

    def __init__(self, points: np.ndarray, cells: List[Tuple[str, Any]]) -> None:
        self.points = points
        self.cells = cells


def smooth_meshio(mesh: Any, **kwargs: Any) -> Any:
    """Smooths a ``meshio.Mesh`` and returns a new one with the new points and
    the same cells, point data, cell data, field data and sets. The keyword
    arguments are :func:`smooth`'s; ``fixed`` adds to the vertices of the
    mesh's lower-dimensional cells, which stay where they are, as do points
    no optimised cell uses. The result of the solve is on ``.meshsmooth_result``
    of the returned mesh. Needs meshio."""
    meshio = _optional("meshio", "smooth_meshio")

    points, result = _smooth_parts(
        np.asarray(mesh.points), [_block_parts(c) for c in mesh.cells], kwargs, dict(mesh.point_data)
    )
    out = meshio.Mesh(
        points,
        [(c.type, c.data) for c in mesh.cells],
        point_data=dict(mesh.point_data),
        cell_data=dict(mesh.cell_data),
        field_data=dict(mesh.field_data),
        point_sets=dict(getattr(mesh, "point_sets", {}) or {}),
        cell_sets=dict(getattr(mesh, "cell_sets", {}) or {}),
    )
    out.meshsmooth_result = result
    return out


#: VTK cell type ids (PyVista's ``celltypes``) as meshio names.
_VTK_TO_MESHIO = {1: "vertex", 3: "line", 5: "triangle", 9: "quad", 10: "tetra", 12: "hexahedron", 13: "wedge"}


def _polydata_parts(mesh: Any) -> List[Tuple[str, Any]]:
    """A PolyData's polygons as meshio-named blocks: triangles and
    quadrilaterals (a surface), lines as lower-dimensional cells; strips and
    polygons of other sizes refused naming the cell."""
    parts: List[Tuple[str, Any]] = []
    if getattr(mesh, "n_strips", 0):
        raise ValueError("polydata: triangle strips are not supported (triangulate() the mesh first)")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    by_size: Dict[int, List[Any]] = {3: [], 4: []}
    i, cell = 0, 0
    while i < len(faces):
        k = int(faces[i])
        if k not in by_size:
            raise ValueError(
                f"polydata: polygon {cell} has {k} vertices; only triangles and quadrilaterals are smoothed "
                "(triangulate() the mesh first)"
            )
        by_size[k].append(faces[i + 1 : i + 1 + k])
        i += k + 1
        cell += 1
    for k, name in ((3, "triangle"), (4, "quad")):
        if by_size[k]:
            parts.append((name, np.array(by_size[k], dtype=np.int64)))
    lines = np.asarray(getattr(mesh, "lines", []), dtype=np.int64)
    i, segments = 0, []
    while i < len(lines):
        k = int(lines[i])
        ids = lines[i + 1 : i + 1 + k]
        segments.extend([ids[j], ids[j + 1]] for j in range(k - 1))
        i += k + 1
    if segments:
        parts.append(("line", np.array(segments, dtype=np.int64)))
    if not parts:
        raise ValueError("polydata: no triangles or quadrilaterals to smooth")
    return parts


def smooth_pyvista(grid: Any, **kwargs: Any) -> Any:
    """Smooths a PyVista ``UnstructuredGrid`` or ``PolyData`` surface (needs
    pyvista) and returns a copy with the new points and all its arrays;
    keyword arguments as for :func:`smooth`, lower-dimensional cells (a
    PolyData's lines among them) handled as in :func:`smooth_meshio`. A
    PolyData's triangles and quadrilaterals are a surface: every vertex slides
    on it, features and corners kept. The result of the solve is on
    ``.meshsmooth_result`` of the returned mesh."""
    _optional("pyvista", "smooth_pyvista")
    if hasattr(grid, "cells_dict"):
        parts = []
        for vtk_type, data in grid.cells_dict.items():
            name = _VTK_TO_MESHIO.get(int(vtk_type))
            if name is None:
                raise ValueError(f"grid: unsupported VTK cell type {int(vtk_type)}")
            parts.append((name, np.asarray(data)))
    elif hasattr(grid, "faces"):
        parts = _polydata_parts(grid)
    else:
        raise TypeError(f"smooth_pyvista takes a pyvista UnstructuredGrid or PolyData, not {type(grid).__name__}")
    points, result = _smooth_parts(np.asarray(grid.points), parts, kwargs, dict(grid.point_data))
    out = grid.copy()
    out.points = points
    # an attribute PyVista does not know about would warn on assignment
    object.__setattr__(out, "meshsmooth_result", result)
    return out
