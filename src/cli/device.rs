//! Choosing where a solve runs: `--device cpu|gpu|auto`, `--precision`, `--adapter`.

use super::GpuArgs;
use meshsmooth::backend::gpu::{self, GpuContext, GpuOptions, Precision};
use meshsmooth::solve::Method;
use meshsmooth::{Error, Result};

pub enum Backend {
    Cpu,
    Gpu(Box<GpuContext>),
}

impl Backend {
    pub fn describe(&self) -> String {
        match self {
            Backend::Cpu => format!("cpu (f64, {} threads)", rayon::current_num_threads()),
            Backend::Gpu(ctx) => {
                format!(
                    "gpu {} ({})",
                    ctx.adapter_name(),
                    if ctx.is_f64() { "f64" } else { "f32" }
                )
            }
        }
    }
}

fn precision(p: &str) -> Precision {
    match p {
        "f32" => Precision::F32,
        "f64" => Precision::F64,
        _ => Precision::Auto,
    }
}

fn runs_on_gpu(method: Method) -> bool {
    matches!(method, Method::Bcd | Method::BcdColored | Method::Newton)
}

/// Picks the backend. `auto` takes a hardware GPU when there is one and the
/// method runs there; software adapters (lavapipe, llvmpipe) emulate a GPU on
/// the CPU and are slower than the CPU backend, so `auto` passes them over
/// unless `--adapter` names one.
pub fn choose(device: &str, gpu: &GpuArgs, method: Method) -> Result<Backend> {
    let (prec, adapter) = (gpu.precision.as_str(), gpu.adapter.as_deref());
    let opts = GpuOptions {
        adapter: adapter.map(str::to_string),
        precision: precision(prec),
    };
    match device {
        "cpu" => {
            if prec == "f32" {
                return Err(Error::InvalidArgument(
                    "the CPU backend computes in f64; --precision f32 needs --device gpu".into(),
                ));
            }
            Ok(Backend::Cpu)
        }
        "gpu" => {
            gpu_allowed(method)?;
            Ok(Backend::Gpu(Box::new(GpuContext::new(&opts)?)))
        }
        _ => {
            if !runs_on_gpu(method) {
                return Ok(Backend::Cpu);
            }
            let adapters = gpu::list_adapters();
            let hardware = adapters.iter().any(|a| a.compute && a.device_type != "Cpu");
            if hardware || adapter.is_some() {
                return Ok(Backend::Gpu(Box::new(GpuContext::new(&opts)?)));
            }
            let found: Vec<String> = adapters
                .iter()
                .map(|a| format!("{} ({})", a.name, a.device_type))
                .collect();
            eprintln!(
                "note: no hardware GPU found{}; running on the CPU (--device gpu uses a software adapter)",
                if found.is_empty() {
                    String::new()
                } else {
                    format!(" (adapters: {})", found.join(", "))
                }
            );
            Ok(Backend::Cpu)
        }
    }
}

/// Why `method` cannot run on the GPU, if it cannot.
pub fn gpu_allowed(method: Method) -> Result<()> {
    if !runs_on_gpu(method) {
        return Err(Error::InvalidArgument(format!(
            "{method} runs on the CPU only (the GPU runs bcd, colour by colour, and newton); use --device cpu"
        )));
    }
    Ok(())
}
