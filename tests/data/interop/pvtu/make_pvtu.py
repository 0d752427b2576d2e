# Writes the .pvtu fixtures of tests/pvtu.rs with VTK (pip install vtk; 9.7.2 made
# the files here): whole.vtu (a perturbed 5x4x4 tet box from `meshsmooth generate
# box --cells 5 4 4 --perturb random:0.3`) split into 3 pieces by
# vtkExtractUnstructuredGridPiece, written by vtkXMLPUnstructuredGridWriter in its
# default mode (appended, zlib) without ghost cells and with one ghost level
# (duplicate cells and points flagged in vtkGhostType). VTK's pieces carry no
# global ids (the extraction drops them) and keep points their cells do not use.
import vtk

for ghost in (0, 1):
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName("whole.vtu")
    split = vtk.vtkExtractUnstructuredGridPiece()
    split.SetInputConnection(reader.GetOutputPort())
    writer = vtk.vtkXMLPUnstructuredGridWriter()
    writer.SetInputConnection(split.GetOutputPort())
    writer.SetFileName(f"vtk_ghost{ghost}.pvtu")
    writer.SetNumberOfPieces(3)
    writer.SetStartPiece(0)
    writer.SetEndPiece(2)
    writer.SetGhostLevel(ghost)
    writer.Write()
