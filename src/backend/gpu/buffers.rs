//! Buffer creation, the binding-size check and read-back, in the context's
//! precision (`real` arrays are f32 or f64 on the device, f64 on the host).

use super::context::GpuContext;
use super::shader::Real;
use crate::error::{Error, Result};
use wgpu::util::DeviceExt;

pub(crate) const WORKGROUP: u32 = 64;
const MAX_GROUPS_PER_DIM: u32 = 65_535;

/// The device limits a problem must fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BindingLimits {
    /// Largest storage-buffer binding, in bytes.
    pub max_storage_buffer_binding_size: u64,
    /// Largest buffer, in bytes.
    pub max_buffer_size: u64,
}

impl BindingLimits {
    /// The limits of a wgpu device.
    pub fn of(limits: &wgpu::Limits) -> Self {
        BindingLimits {
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
        }
    }
}

/// Refuses arrays (name, bytes) that one storage binding cannot hold, so a
/// large mesh gets an error with the numbers instead of a wgpu panic. Only
/// for the arrays that are not split across bindings (`Binding::split`):
/// u32s per vertex and the sliding-boundary tables.
pub fn check_bindings(limits: &BindingLimits, arrays: &[(&str, u64)]) -> Result<()> {
    let cap = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    for &(name, bytes) in arrays {
        if bytes > cap {
            return Err(Error::Gpu(format!(
                "mesh too large for this device: the array '{name}' needs {bytes} bytes \
                 ({:.1} MiB) but one storage binding holds at most {cap} bytes ({:.1} MiB), \
                 and this array is not split across bindings",
                bytes as f64 / 1048576.0,
                cap as f64 / 1048576.0
            )));
        }
    }
    Ok(())
}

/// A 2D grid of workgroups covering `threads` (dispatches are capped per dimension).
pub(crate) fn grid(threads: usize) -> Result<(u32, u32)> {
    let groups = threads.div_ceil(WORKGROUP as usize).max(1);
    let x = groups.min(MAX_GROUPS_PER_DIM as usize);
    let y = groups.div_ceil(x);
    if y > MAX_GROUPS_PER_DIM as usize {
        return Err(Error::Gpu(format!(
            "{threads} threads exceed the dispatch limit of {MAX_GROUPS_PER_DIM}^2 workgroups"
        )));
    }
    Ok((x as u32, y as u32))
}

impl GpuContext {
    pub(crate) fn real_bytes(&self, v: &[f64]) -> Vec<u8> {
        match self.real {
            Real::F64 => bytemuck::cast_slice(v).to_vec(),
            Real::F32 => {
                let f: Vec<f32> = v.iter().map(|&c| c as f32).collect();
                bytemuck::cast_slice(&f).to_vec()
            }
        }
    }

    fn init(&self, label: &str, mut bytes: Vec<u8>, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        // an empty binding is invalid; pad (never read past the real length)
        if bytes.len() < 16 {
            bytes.resize(16, 0);
        }
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &bytes,
            usage,
        })
    }

    pub(crate) fn storage_real(&self, label: &str, v: &[f64]) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        self.init(label, self.real_bytes(v), usage)
    }

    pub(crate) fn storage_u32(&self, label: &str, v: &[u32]) -> wgpu::Buffer {
        self.init(label, bytemuck::cast_slice(v).to_vec(), wgpu::BufferUsages::STORAGE)
    }

    pub(crate) fn uniform_real(&self, label: &str, v: &[f64]) -> wgpu::Buffer {
        self.init(label, self.real_bytes(v), wgpu::BufferUsages::UNIFORM)
    }

    pub(crate) fn uniform_bytes(&self, label: &str, bytes: Vec<u8>) -> wgpu::Buffer {
        self.init(label, bytes, wgpu::BufferUsages::UNIFORM)
    }

    pub(crate) fn uniform<T: bytemuck::Pod>(&self, label: &str, v: &T) -> wgpu::Buffer {
        self.init(label, bytemuck::bytes_of(v).to_vec(), wgpu::BufferUsages::UNIFORM)
    }

    /// `bytes` in buffers of `part_bytes` each (the last shorter): the
    /// parts of an array split across bindings.
    fn init_split(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> Vec<wgpu::Buffer> {
        if bytes.is_empty() {
            return vec![self.init(label, Vec::new(), usage)];
        }
        bytes
            .chunks(self.part_bytes() as usize)
            .map(|c| self.init(label, c.to_vec(), usage))
            .collect()
    }

    /// A storage array of reals split across bindings.
    pub(crate) fn split_real(&self, label: &str, v: &[f64]) -> Vec<wgpu::Buffer> {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        self.init_split(label, &self.real_bytes(v), usage)
    }

    /// A storage array of u32s split across bindings.
    pub(crate) fn split_u32(&self, label: &str, v: &[u32]) -> Vec<wgpu::Buffer> {
        self.init_split(label, bytemuck::cast_slice(v), wgpu::BufferUsages::STORAGE)
    }

    /// A zeroed array of `n` reals split across bindings; wgpu zeroes new
    /// buffers, so nothing of that size is built on the host.
    pub(crate) fn split_zeros_real(&self, label: &str, n: usize) -> Vec<wgpu::Buffer> {
        let total = (n as u64 * self.real_size()).max(16);
        let part = self.part_bytes();
        (0..total.div_ceil(part))
            .map(|k| {
                self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: part.min(total - k * part),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect()
    }

    /// The first `n` reals of an array split across bindings.
    pub(crate) fn read_split_real(&self, parts: &[wgpu::Buffer], n: usize) -> Result<Vec<f64>> {
        let per = (self.part_bytes() / self.real_size()) as usize;
        let mut out = Vec::with_capacity(n);
        for (k, part) in parts.iter().enumerate() {
            let want = n.saturating_sub(k * per).min(per);
            if want > 0 {
                out.extend(self.read_real(part, want)?);
            }
        }
        Ok(out)
    }

    /// Overwrites the start of an array split across bindings with `v`
    /// (applied before the next submission).
    pub(crate) fn write_split_real(&self, parts: &[wgpu::Buffer], v: &[f64]) {
        let per = (self.part_bytes() / self.real_size()) as usize;
        for (part, chunk) in parts.iter().zip(v.chunks(per)) {
            self.write_real(part, chunk);
        }
    }

    /// Overwrites the start of `dst` with `v` (applied before the next submission).
    pub(crate) fn write_real(&self, dst: &wgpu::Buffer, v: &[f64]) {
        if !v.is_empty() {
            self.queue.write_buffer(dst, 0, &self.real_bytes(v));
        }
    }

    /// A zeroed storage array of `n` reals.
    pub(crate) fn zeros_real(&self, label: &str, n: usize) -> wgpu::Buffer {
        self.storage_real(label, &vec![0.0; n])
    }

    pub(crate) fn real_size(&self) -> u64 {
        self.real.size() as u64
    }

    /// Copies the first `n` reals of `src` back to the host.
    pub(crate) fn read_real(&self, src: &wgpu::Buffer, n: usize) -> Result<Vec<f64>> {
        let bytes = (n as u64 * self.real_size()).max(4);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
        self.queue.submit([enc.finish()]);
        self.map_read(&staging, n)
    }

    /// Maps a MAP_READ buffer already filled by submitted work.
    pub(crate) fn map_read(&self, staging: &wgpu::Buffer, n: usize) -> Result<Vec<f64>> {
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|_| Error::Gpu("read-back never completed".into()))?
            .map_err(|e| Error::Gpu(format!("mapping a read-back buffer: {e}")))?;
        let out = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| Error::Gpu(format!("mapping a read-back buffer: {e:?}")))?;
            match self.real {
                Real::F64 => bytemuck::cast_slice::<u8, f64>(&view)[..n].to_vec(),
                Real::F32 => bytemuck::cast_slice::<u8, f32>(&view)[..n]
                    .iter()
                    .map(|&c| c as f64)
                    .collect(),
            }
        };
        staging.unmap();
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn too_large_array_is_refused_with_the_numbers() {
        let limits = BindingLimits {
            max_storage_buffer_binding_size: 1 << 20,
            max_buffer_size: 1 << 30,
        };
        assert!(check_bindings(&limits, &[("x", 1 << 20)]).is_ok());
        let e = check_bindings(&limits, &[("x", 10), ("grad", (1 << 20) + 8)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'grad'") && e.contains("1048584") && e.contains("1048576"),
            "{e}"
        );
    }

    #[test]
    fn grid_covers_threads_within_dispatch_limits() {
        assert_eq!(grid(1).unwrap(), (1, 1));
        assert_eq!(grid(64 * 65_535).unwrap(), (65_535, 1));
        assert_eq!(grid(64 * 65_536).unwrap(), (65_535, 2));
        assert!(grid(64 * 65_535 * 65_535 + 64).is_err());
    }
}
