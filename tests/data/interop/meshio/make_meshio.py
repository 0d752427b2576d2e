"""Writes the files of this folder with meshio 5.3.5 (and netCDF4 for Exodus).

box.vtu: a perturbed tet box from `meshsmooth generate box --cells 4 3 3
--perturb random:0.3 --seed 5`. box.exo (Exodus II, netCDF-4) and box.inp
(Abaqus): its tetrahedra, the point set `wall` of the vertices at x = 0 and
the point array `heat` (x + 2 y + 3 z; in the Exodus file only, meshio's
Abaqus writer has no data). Run: python make_meshio.py
"""
import meshio
import numpy as np

m = meshio.read("box.vtu")
pts = m.points
tets = m.cells_dict["tetra"]
wall = np.flatnonzero(pts[:, 0] == pts[:, 0].min())
heat = pts[:, 0] + 2 * pts[:, 1] + 3 * pts[:, 2]
meshio.write(
    "box.exo",
    meshio.Mesh(pts, [("tetra", tets)], point_data={"heat": heat}, point_sets={"wall": wall}),
    file_format="exodus",
)
meshio.write("box.inp", meshio.Mesh(pts, [("tetra", tets)], point_sets={"wall": wall}), file_format="abaqus")
print(len(pts), len(tets), len(wall))
