//! Mesh generators and perturbations for tests and benchmarks, including the
//! test meshes of the papers (horseshoe family, distorted prism and hex
//! boxes, graded tet boxes, the polyhedral Voronoi box, the Newton paper's
//! unstructured ducts through Gmsh).

pub mod box_mesh;
pub mod graded;
pub mod grid;
pub mod hetero;
pub mod horseshoe;
pub mod layer;
pub mod mixed;
pub mod perturb;
pub mod prism;
pub mod surface;
pub mod unstructured_duct;
pub mod voronoi;

pub use box_mesh::{duct, tet_box};
pub use graded::{graded_tet_box, graded_tet_box_aniso};
pub use grid::{hex_box, quad_grid, tri_grid};
pub use hetero::{HeteroOptions, hetero_tet_box};
pub use horseshoe::{HorseshoeKind, horseshoe};
pub use layer::{LayerKind, boundary_layer, boundary_layer_2d, graded_hex_box};
pub use mixed::mixed_block;
pub use perturb::{PerturbOptions, PerturbStats, Perturbation, perturb, perturb_unguarded};
pub use prism::{Distortion, distorted_hex_box, distorted_prism_mesh, prism_mesh};
pub use surface::{cube_surface, sphere};
pub use unstructured_duct::{duct_size_for, unstructured_duct};
pub use voronoi::{VoronoiOptions, voronoi_mesh};
