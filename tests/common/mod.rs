//! Shared by the GPU test files.

use meshsmooth::backend::gpu::{GpuContext, GpuOptions, Precision};

/// A device for the GPU tests: `None` (with the reason printed) on a machine
/// without an adapter, so the tests skip there — except under `CI`, where a
/// missing adapter fails them: CI installs lavapipe and must run them.
pub fn context(precision: Precision) -> Option<GpuContext> {
    match GpuContext::new(&GpuOptions {
        adapter: None,
        precision,
    }) {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.adapter_name());
            Some(ctx)
        }
        Err(e) if std::env::var_os("CI").is_some() => panic!("no GPU for the GPU tests in CI: {e}"),
        Err(e) => {
            eprintln!("skipping GPU test: {e}");
            None
        }
    }
}
