//! What a solver needs.
