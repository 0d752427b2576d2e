"""Writes the VTKHDF files of this folder with VTK's own vtkHDFWriter.

whole.vtu: a perturbed tet box from `meshsmooth generate box --cells 4 3 3
--perturb random:0.3 --seed 5`. one_piece.vtkhdf: that box with a point vector
`flow` (i, -i, i/2), a cell integer array `zone` (cell id mod 3) and a field
string `origin`. two_pieces.vtkhdf: the box split by cell id into two
partitions (each with its own copy of the points it uses), written as one
file of two pieces, gzip-compressed. Chunks of 64 rows keep the files small. Run with VTK 9.7.2: python make_vtkhdf.py
"""
import vtk

r = vtk.vtkXMLUnstructuredGridReader()
r.SetFileName("whole.vtu")
r.Update()
g = vtk.vtkUnstructuredGrid()
g.DeepCopy(r.GetOutput())
g.GetPointData().Initialize()
g.GetCellData().Initialize()
flow = vtk.vtkDoubleArray()
flow.SetName("flow")
flow.SetNumberOfComponents(3)
for i in range(g.GetNumberOfPoints()):
    flow.InsertNextTuple3(i, -i, 0.5 * i)
g.GetPointData().AddArray(flow)
zone = vtk.vtkIntArray()
zone.SetName("zone")
for c in range(g.GetNumberOfCells()):
    zone.InsertNextValue(c % 3)
g.GetCellData().AddArray(zone)
origin = vtk.vtkStringArray()
origin.SetName("origin")
origin.InsertNextValue("VTK 9.7.2 vtkHDFWriter")
g.GetFieldData().AddArray(origin)

w = vtk.vtkHDFWriter()
w.SetChunkSize(64)
w.SetInputData(g)
w.SetFileName("one_piece.vtkhdf")
w.Write()

half = g.GetNumberOfCells() // 2
parts = vtk.vtkPartitionedDataSet()
for k, (lo, hi) in enumerate([(0, half - 1), (half, g.GetNumberOfCells() - 1)]):
    e = vtk.vtkExtractCells()
    e.SetInputData(g)
    e.AddCellRange(lo, hi)
    e.Update()
    part = vtk.vtkUnstructuredGrid()
    part.DeepCopy(e.GetOutput())
    parts.SetPartition(k, part)
w = vtk.vtkHDFWriter()
w.SetChunkSize(64)
w.SetCompressionLevel(4)
w.SetInputData(parts)
w.SetFileName("two_pieces.vtkhdf")
w.Write()
