//! Templates: global objective, gradient.
