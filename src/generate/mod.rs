//! Mesh generators and perturbations for tests and benchmarks.
