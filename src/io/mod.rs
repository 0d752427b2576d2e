//! Mesh files: VTK legacy and XML, Gmsh, Medit; atomic writes.
