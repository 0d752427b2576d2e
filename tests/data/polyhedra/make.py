"""Writes the polyhedron fixtures of tests/polyhedra.rs with VTK and meshio.

Input: ours.vtk, from `meshsmooth generate voronoi --bcc --cells 2 2 2 --jitter 0.1 --seed 1`
(written by meshsmooth's legacy writer, read here by VTK's reader).
Run with a Python that has vtk (9.7.2) and meshio (5.3.5): python make.py
"""
import meshio
import numpy as np
import vtk

r = vtk.vtkUnstructuredGridReader()
r.SetFileName("ours.vtk")
r.Update()
grid = r.GetOutput()

# VTK's own check of every cell (convexity, outward faces, ...)
v = vtk.vtkCellValidator()
v.SetInputData(grid)
v.Update()
states = v.GetOutput().GetCellData().GetArray("ValidityState")
bad = [i for i in range(states.GetNumberOfTuples()) if states.GetTuple1(i) != 0]
print("cells", grid.GetNumberOfCells(), "invalid by vtkCellValidator:", bad)

leg = vtk.vtkUnstructuredGridWriter()
leg.SetInputData(grid)
leg.SetFileName("vtk_leg51_ascii.vtk")
leg.SetFileTypeToASCII()
leg.Write()
leg.SetFileName("vtk_leg51_binary.vtk")
leg.SetFileTypeToBinary()
leg.Write()

x = vtk.vtkXMLUnstructuredGridWriter()
x.SetInputData(grid)
for name, setup in [
    ("vtk_xml_ascii.vtu", lambda w: w.SetDataModeToAscii()),
    ("vtk_xml_binary_zlib.vtu", lambda w: (w.SetDataModeToBinary(), w.SetCompressorTypeToZLib())),
    ("vtk_xml_appended_raw.vtu", lambda w: (w.SetDataModeToAppended(), w.EncodeAppendedDataOff(), w.SetCompressorTypeToNone())),
]:
    setup(x)
    x.SetFileName(name)
    x.Write()

# meshio: polyhedra as lists of faces (one block per vertex count, as meshio names them)
pts = np.array([grid.GetPoint(i) for i in range(grid.GetNumberOfPoints())])
blocks = {}
for c in range(grid.GetNumberOfCells()):
    ids = vtk.vtkIdList()
    grid.GetFaceStream(c, ids)
    s = [ids.GetId(i) for i in range(ids.GetNumberOfIds())]
    faces, k = [], 1
    for _ in range(s[0]):
        faces.append(np.array(s[k + 1 : k + 1 + s[k]]))
        k += 1 + s[k]
    n = len({v for f in faces for v in f})
    blocks.setdefault(f"polyhedron{n}", []).append(faces)
meshio.write("meshio_poly.vtu", meshio.Mesh(pts, list(blocks.items())), binary=False)
meshio.write("meshio_poly_zlib.vtu", meshio.Mesh(pts, list(blocks.items())), binary=True, compression="zlib")
print("meshio blocks:", {k: len(v) for k, v in blocks.items()})
