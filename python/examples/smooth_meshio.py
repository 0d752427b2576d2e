"""Smooth a mesh file with meshio and meshsmooth: python smooth_meshio.py IN OUT."""

import sys

import meshio  # type: ignore[import-untyped]
import numpy as np

import meshsmooth

mesh = meshio.read(sys.argv[1])
smoothed = meshsmooth.smooth_meshio(mesh, method="newton", tol=1e-6)
print(smoothed.meshsmooth_result)
smoothed.write(sys.argv[2])

points = np.asarray(mesh.points, dtype=np.float64)
arrays = meshsmooth.from_meshio(mesh)
result: meshsmooth.Result = meshsmooth.smooth(arrays.points, arrays.cells, fixed=arrays.fixed, max_iter=10)
print(result.objective, result.stop, result.history["objective"][-1], result.report()["eta"])
