//! What the benches share: command-line values, timing, GPU contexts.
//! Each bench uses part of it.
#![allow(dead_code)]

use meshsmooth::backend::gpu::{GpuContext, GpuOptions, Precision};
use std::time::Instant;

/// The value after `--name` on the command line.
pub fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

/// Whether `--name` is on the command line.
pub fn flag(name: &str) -> bool {
    std::env::args().any(|a| a == name)
}

pub fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Median seconds per call of `f` over `reps` calls after one warm-up call.
pub fn time(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    median(
        (0..reps)
            .map(|_| {
                let s = Instant::now();
                f();
                s.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

/// A context per precision the adapter offers (f32, then f64), named
/// "f32"/"f64", each built from `base` with its precision; the ones that
/// fail are said on stderr.
pub fn gpu_contexts(base: &GpuOptions) -> Vec<(String, GpuContext)> {
    [Precision::F32, Precision::F64]
        .into_iter()
        .filter_map(|precision| {
            let ctx = GpuContext::new(&GpuOptions {
                precision,
                ..base.clone()
            })
            .map_err(|e| eprintln!("no {precision:?} context: {e}"))
            .ok()?;
            Some((format!("{precision:?}").to_lowercase(), ctx))
        })
        .collect()
}

/// The lines a results file opens with: what ran, where and when.
pub fn provenance(command: &str) -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let date = std::process::Command::new("date")
        .args(["-u", "+%Y-%m-%d"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!("Machine: {cpu}, {threads} threads. Command: `{command}`. Date: {date}.\n")
}
