//! Choosing where a solve runs: `--device cpu|gpu|auto`, `--precision`, `--adapter`.

use super::{DeviceArg, GpuArgs};
use meshsmooth::backend::gpu::{self, GpuContext, GpuOptions, Precision};
use meshsmooth::solve::{Device, Method};
use meshsmooth::{Error, Result};

/// The backend picked: the CPU, or a GPU context kept alive for the run.
pub enum Choice {
    Cpu,
    Gpu(Box<GpuContext>),
}

impl Choice {
    pub fn device(&self) -> Device<'_> {
        match self {
            Choice::Cpu => Device::Cpu,
            Choice::Gpu(ctx) => Device::Gpu(ctx),
        }
    }
}

/// Picks the backend for `methods`. `auto` takes a hardware GPU when there is
/// one and every method runs there; software adapters (lavapipe, llvmpipe)
/// emulate a GPU on the CPU and are slower than the CPU backend, so `auto`
/// passes them over unless `--adapter` names one.
pub fn choose(device: DeviceArg, gpu: &GpuArgs, methods: &[Method]) -> Result<Choice> {
    let opts = GpuOptions {
        adapter: gpu.adapter.clone(),
        precision: gpu.precision,
        ..Default::default()
    };
    match device {
        DeviceArg::Cpu => {
            if gpu.precision == Precision::F32 {
                return Err(Error::InvalidArgument(
                    "the CPU backend computes in f64; --precision f32 needs --device gpu".into(),
                ));
            }
            Ok(Choice::Cpu)
        }
        DeviceArg::Gpu => {
            for &m in methods {
                gpu_allowed(m)?;
            }
            Ok(Choice::Gpu(Box::new(GpuContext::new(&opts)?)))
        }
        DeviceArg::Auto => {
            if methods.iter().any(|&m| gpu_allowed(m).is_err()) {
                return Ok(Choice::Cpu);
            }
            let adapters = gpu::list_adapters();
            let hardware = adapters.iter().any(|a| a.compute && a.device_type != "Cpu");
            if hardware || gpu.adapter.is_some() {
                return Ok(Choice::Gpu(Box::new(GpuContext::new(&opts)?)));
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
            Ok(Choice::Cpu)
        }
    }
}

/// Why `method` cannot run on the GPU, if it cannot.
fn gpu_allowed(method: Method) -> Result<()> {
    if method == Method::Laplace {
        return Err(Error::InvalidArgument(format!(
            "{method} runs on the CPU only (the GPU runs bcd, colour by colour, newton and nlcg); use --device cpu"
        )));
    }
    Ok(())
}
