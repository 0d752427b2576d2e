//! Vertex adjacency and boundary skin.
