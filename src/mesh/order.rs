//! Vertex orderings.
