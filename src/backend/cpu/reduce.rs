//! CPU twin of `shaders/reduce.wgsl`: sums over fixed chunks, the chunk sums
//! then added in order, so a result repeats bit for bit whatever the thread
//! count (the GPU's fixed tree differs from it by rounding only).

use rayon::prelude::*;

/// Items per chunk.
pub const CHUNK: usize = 4096;

/// Partial sums added in order.
pub fn in_order(partials: &[f64]) -> f64 {
    partials.iter().sum()
}

/// The sum of `f` over `items` in fixed chunks.
pub fn sum<T: Sync>(items: &[T], f: impl Fn(&T) -> f64 + Sync) -> f64 {
    let partials: Vec<f64> = items.par_chunks(CHUNK).map(|c| c.iter().map(&f).sum()).collect();
    in_order(&partials)
}
