//! Adapter choice, device creation and the long-lived context that owns the
//! device, queue and compiled pipelines.

use super::layout::Op;
use super::shader::{Access, Binding, Real, Variant};
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

pub use crate::backend::settings::Precision;

/// How to open a GPU: which adapter, which arithmetic, and device-side layout choices.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Substring of the adapter name (case-insensitive); the environment
    /// variable `MESHSMOOTH_ADAPTER` is used when this is `None`.
    pub adapter: Option<String>,
    /// The arithmetic wanted.
    pub precision: Precision,
    /// Caps the bytes one storage binding may hold below what the adapter
    /// offers, so that tests reach split arrays (`Binding::split`) with
    /// small meshes.
    pub max_binding_bytes: Option<u64>,
    /// Caps the storage buffers one kernel may bind below what the adapter
    /// offers, so that tests reach kernels run one window of parts at a time
    /// (`GpuBackend::window_dispatches`) on any device.
    pub max_storage_buffers: Option<u32>,
    /// How vertices and corners are numbered on the device.
    pub layout: DeviceLayout,
    /// Which corner kernels a model gets: closed forms or the general ones.
    pub forms: KernelForms,
}

/// Which compiled instance of the corner kernels (`shader::Form`) a model
/// gets where a closed form applies. The answer is the same either way
/// (within rounding: `tests/gpu/kernels.rs`); only the speed differs, and it
/// differs by adapter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum KernelForms {
    /// Closed forms where they were measured to pay on this kind of adapter:
    /// every one on a software adapter (lavapipe), every one but the
    /// tetrahedral inverse mean ratio in f32 on a hardware GPU, where the
    /// general kernel swept tetrahedra and hexahedra 1.6x faster in two runs
    /// on an H200 (README, "On a hardware GPU").
    #[default]
    Auto,
    /// Every closed form that applies (`shader::Form::Fast`, `Form::Planar`).
    Closed,
    /// Every model through the structured general kernels: for comparisons.
    General,
}

/// The device numbering of vertices and corners (`sweep_layout.rs`); what
/// the backend hands back is in the problem's numbering whichever is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum DeviceLayout {
    /// Each colour's vertices together in sweep order, each colour sorted by
    /// the vertices' number of corners; corners by the same order.
    #[default]
    ByValence,
    /// Each colour's vertices together in sweep order; corners by the same order.
    ByColour,
    /// The problem's numbering: for comparisons.
    Problem,
}

crate::error::by_name!(KernelForms: "forms" { Auto = "auto", Closed = "closed", General = "general" });
crate::error::by_name!(DeviceLayout: "layout" { ByValence = "by-valence", ByColour = "by-colour", Problem = "problem" });

/// One adapter as `meshsmooth devices` lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    /// The adapter's name.
    pub name: String,
    /// The graphics API it runs on (wgpu's `Backend`, e.g. Vulkan).
    pub backend: String,
    /// wgpu's device type (discrete, integrated, virtual, CPU, other).
    pub device_type: String,
    /// The driver's name.
    pub driver: String,
    /// The driver's version information.
    pub driver_info: String,
    /// Does it have `SHADER_F64` (double precision in shaders)?
    pub f64: bool,
    /// Can it run compute shaders at all?
    pub compute: bool,
}

fn instance_with(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

fn summary(a: &wgpu::Adapter) -> AdapterSummary {
    let info = a.get_info();
    AdapterSummary {
        name: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: info.driver,
        driver_info: info.driver_info,
        f64: a.features().contains(wgpu::Features::SHADER_F64),
        compute: can_compute(a),
    }
}

fn can_compute(a: &wgpu::Adapter) -> bool {
    a.get_downlevel_capabilities()
        .flags
        .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        && a.limits().max_compute_workgroup_size_x >= 64
        && a.limits().max_compute_invocations_per_workgroup >= 64
}

/// Every adapter wgpu finds, best first. Asking the drivers takes a tenth
/// of a second or more, so the answer is kept for the process (adapters do
/// not come and go during a run).
pub fn list_adapters() -> Vec<AdapterSummary> {
    ADAPTERS.get_or_init(|| ranked().iter().map(summary).collect()).clone()
}

static ADAPTERS: std::sync::OnceLock<Vec<AdapterSummary>> = std::sync::OnceLock::new();

/// Starts [`list_adapters`]'s question to the drivers on a thread of its
/// own, so that it overlaps with whatever comes before the answer is
/// needed (reading the input file).
pub fn list_adapters_in_background() {
    if ADAPTERS.get().is_none() {
        std::thread::spawn(|| drop(list_adapters()));
    }
}

/// Discrete, integrated, then virtual and CPU adapters. The native compute
/// backends come first; GL is asked only when they find nothing, because it
/// lacks f64 on llvmpipe and its EGL start-up complains on headless machines.
fn ranked() -> Vec<wgpu::Adapter> {
    let native = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    let mut all = pollster::block_on(instance_with(native).enumerate_adapters(native));
    if all.is_empty() {
        all = pollster::block_on(instance_with(wgpu::Backends::GL).enumerate_adapters(wgpu::Backends::GL));
    }
    all.sort_by_key(|a| {
        let info = a.get_info();
        let kind = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        let backend = match info.backend {
            wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
            _ => 1,
        };
        (kind, backend)
    });
    all
}

/// Device, queue and pipelines for one precision; built once and reused.
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) real: Real,
    pub(crate) limits: wgpu::Limits,
    /// `GpuOptions::layout`.
    pub(crate) layout: DeviceLayout,
    /// `GpuOptions::forms`.
    pub(crate) forms: KernelForms,
    info: wgpu::AdapterInfo,
    /// Built on first use: a run needs the instances of one metric only, and
    /// compiling all of them costs seconds on a software adapter.
    pipelines: Mutex<HashMap<Variant, Arc<(wgpu::BindGroupLayout, wgpu::ComputePipeline)>>>,
    /// Errors reported by wgpu outside any call's reach (validation, OOM, loss).
    errors: Arc<Mutex<Vec<String>>>,
}

impl GpuContext {
    /// Opens the adapter `opts` names (or the best one) and builds a device and queue on it.
    pub fn new(opts: &GpuOptions) -> Result<GpuContext> {
        let adapters = ranked();
        let wanted = opts
            .adapter
            .clone()
            .or_else(|| std::env::var("MESHSMOOTH_ADAPTER").ok())
            .filter(|s| !s.is_empty());
        let found = || {
            if adapters.is_empty() {
                "none found".to_string()
            } else {
                adapters
                    .iter()
                    .map(|a| {
                        let s = summary(a);
                        format!(
                            "'{}' ({}, {}{}{})",
                            s.name,
                            s.backend,
                            s.device_type,
                            if s.f64 { ", f64" } else { "" },
                            if s.compute { "" } else { ", no compute" }
                        )
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            }
        };
        let candidates: Vec<&wgpu::Adapter> = adapters
            .iter()
            .filter(|a| can_compute(a))
            .filter(|a| {
                wanted
                    .as_ref()
                    .is_none_or(|w| a.get_info().name.to_lowercase().contains(&w.to_lowercase()))
            })
            .collect();
        let has_f64 = |a: &wgpu::Adapter| a.features().contains(wgpu::Features::SHADER_F64);
        let adapter = match opts.precision {
            // an f64 request passes over adapters without it
            Precision::F64 => candidates.iter().find(|a| has_f64(a)).ok_or_else(|| {
                Error::Gpu(format!(
                    "no adapter{} supports f64 shaders (SHADER_F64); adapters: {}",
                    wanted.as_ref().map(|w| format!(" matching '{w}'")).unwrap_or_default(),
                    found()
                ))
            })?,
            _ => candidates.first().ok_or_else(|| {
                Error::Gpu(format!(
                    "no usable compute adapter{}; adapters: {}",
                    wanted.as_ref().map(|w| format!(" matching '{w}'")).unwrap_or_default(),
                    found()
                ))
            })?,
        };
        let f64_ok = has_f64(adapter);
        let real = match opts.precision {
            Precision::F32 => Real::F32,
            Precision::F64 => Real::F64,
            Precision::Auto if f64_ok => Real::F64,
            Precision::Auto => Real::F32,
        };
        // all the adapter offers (binding and buffer sizes, storage buffers
        // per stage), not WebGPU's defaults: large meshes need them
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("meshsmooth"),
            required_features: if f64_ok {
                wgpu::Features::SHADER_F64
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu(format!("requesting a device: {e}")))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            sink.lock().unwrap().push(e.to_string());
        }));
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, msg| {
            sink.lock().unwrap().push(format!("device lost ({reason:?}): {msg}"));
        });
        let mut limits = limits;
        if let Some(cap) = opts.max_binding_bytes {
            limits.max_storage_buffer_binding_size = limits.max_storage_buffer_binding_size.min(cap.max(256));
        }
        if let Some(cap) = opts.max_storage_buffers {
            limits.max_storage_buffers_per_shader_stage = limits.max_storage_buffers_per_shader_stage.min(cap);
        }
        let ctx = GpuContext {
            device,
            queue,
            real,
            limits,
            layout: opts.layout,
            forms: opts.forms,
            info: adapter.get_info(),
            pipelines: Mutex::new(HashMap::new()),
            errors,
        };
        ctx.check()?;
        Ok(ctx)
    }

    /// The adapter's name, backend and type, for reports.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// Whether the adapter emulates a GPU on the CPU (Mesa lavapipe).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The storage buffers one kernel may bind (`GpuOptions::max_storage_buffers`
    /// or the adapter's limit).
    pub fn max_storage_buffers(&self) -> u32 {
        self.limits.max_storage_buffers_per_shader_stage
    }

    /// Whether the device computes in f64.
    pub fn is_f64(&self) -> bool {
        self.real == Real::F64
    }

    /// log2 of the bytes in each buffer of a split array: the largest power
    /// of two one binding (and one buffer) holds, so that a kernel finds an
    /// element's buffer with a shift.
    pub(crate) fn part_log2(&self) -> u32 {
        let cap = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
            .min(1 << 31);
        63 - cap.leading_zeros()
    }

    /// Bytes in each buffer of a split array.
    pub(crate) fn part_bytes(&self) -> u64 {
        1 << self.part_log2()
    }

    /// The bind-group layout and pipeline of a kernel instance, both from
    /// the kernel table (`shader::KERNELS`); the extra buffers of split
    /// bindings follow the table's bindings (`Variant::compose_split`).
    fn build_pipeline(&self, v: Variant) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
        let label = v.label();
        let entries: Vec<wgpu::BindGroupLayoutEntry> = binding_order(v)
            .into_iter()
            .enumerate()
            .map(|(i, (b, _))| wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match b.access {
                        Access::Uniform | Access::Op => wgpu::BufferBindingType::Uniform,
                        Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                        Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                    },
                    has_dynamic_offset: b.access == Access::Op,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(&label),
            entries: &entries,
        });
        let pipeline_layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&label),
            source: wgpu::ShaderSource::Wgsl(v.compose_split(self.real, self.part_log2()).into()),
        });
        let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(&label),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        (layout, pipeline)
    }

    /// The bind-group layout and pipeline of `v`, built on first use.
    fn pipeline(&self, v: Variant) -> Arc<(wgpu::BindGroupLayout, wgpu::ComputePipeline)> {
        let mut built = self.pipelines.lock().unwrap();
        built
            .entry(v)
            .or_insert_with(|| Arc::new(self.build_pipeline(v)))
            .clone()
    }

    /// Bytes between `Op` records in a uniform buffer bound at dynamic offsets.
    pub(crate) fn op_stride(&self) -> u64 {
        let align = self.limits.min_uniform_buffer_offset_alignment as u64;
        (Op::size(self.real) as u64).div_ceil(align) * align
    }

    /// `bind` with one buffer per binding, each given with its name in the
    /// kernel table (`KernelDef::in_binding_order`).
    pub(crate) fn bind_each(&self, v: Variant, buffers: &[(&str, &wgpu::Buffer)]) -> wgpu::BindGroup {
        let parts: Vec<&[wgpu::Buffer]> = v
            .kernel
            .def()
            .in_binding_order(buffers)
            .into_iter()
            .map(std::slice::from_ref)
            .collect();
        self.bind(v, &parts)
    }

    /// A bind group for `v` with `buffers[i]` (the parts of the i-th array)
    /// for the i-th binding of the kernel table; the `Op` binding sees one record.
    pub(crate) fn bind(&self, v: Variant, buffers: &[&[wgpu::Buffer]]) -> wgpu::BindGroup {
        let bindings = v.kernel.def().bindings;
        assert_eq!(
            buffers.len(),
            bindings.len(),
            "{}: buffers for every binding",
            v.label()
        );
        let entries: Vec<wgpu::BindGroupEntry> = binding_order(v)
            .into_iter()
            .enumerate()
            .map(|(i, (b, (index, part)))| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: if b.access == Access::Op {
                    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &buffers[index][0],
                        offset: 0,
                        size: std::num::NonZeroU64::new(Op::size(self.real) as u64),
                    })
                } else {
                    buffers[index][part].as_entire_binding()
                },
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(v.kernel.name()),
            layout: &self.pipeline(v).0,
            entries: &entries,
        })
    }

    /// Records one dispatch of `v` covering `threads` (2D grid), its `Op`
    /// record (if it has one) at `offset` in the bound uniform buffer.
    pub(crate) fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        v: Variant,
        group: &wgpu::BindGroup,
        offset: Option<u32>,
        threads: usize,
    ) -> Result<()> {
        let (x, y) = super::buffers::grid(threads)?;
        pass.set_pipeline(&self.pipeline(v).1);
        pass.set_bind_group(0, group, offset.as_slice());
        pass.dispatch_workgroups(x, y, 1);
        Ok(())
    }

    /// Turns any error wgpu reported since the last check into `Err`.
    pub(crate) fn check(&self) -> Result<()> {
        let mut errors = self.errors.lock().unwrap();
        if errors.is_empty() {
            Ok(())
        } else {
            let msg = errors.join("; ");
            errors.clear();
            Err(Error::Gpu(msg))
        }
    }

    /// Waits for all submitted work.
    pub(crate) fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("waiting for the device: {e}")))?;
        self.check()
    }
}

/// The bindings of `v` in binding-number order, each with (its index in the
/// kernel table, which part of that array): the table's bindings, then the
/// extra parts of its split bindings.
fn binding_order(v: Variant) -> Vec<(Binding, (usize, usize))> {
    let table = v.kernel.def().bindings;
    let mut out: Vec<_> = table.iter().enumerate().map(|(i, b)| (*b, (i, 0))).collect();
    for (j, (i, b)) in table.iter().enumerate().filter(|(_, b)| b.split).enumerate() {
        for part in 1..=v.extra[j] as usize {
            out.push((*b, (i, part)));
        }
    }
    out
}
