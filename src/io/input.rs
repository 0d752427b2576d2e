//! A mesh file's bytes, read into memory within the read's budget.
//!
//! Files are read, not memory-mapped: a mapped file truncated by another
//! process while it is parsed ends the process with SIGBUS, and no safe Rust
//! recovers from that. Reading costs little more: on the 2-core VM a 600 MB
//! file in the page cache took 0.11 s to read into huge pages against
//! 0.05 s to map (MAP_POPULATE) and touch, and 0.34 s into 4 KiB pages.
//! A file that shrinks while it is read is an error naming it; devices and
//! FIFOs (a symlink to /dev/zero named z.vtk) are read as a stream, within
//! the same budget.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use super::limits::{Budget, Size};
use crate::error::{Error, Result};

/// From this size the buffer asks for huge pages: a quarter of the cost of
/// faulting in 4 KiB pages.
const HUGE_FROM: usize = 16 << 20;

/// How much of a stream is looked at before the rest is read.
const HEAD: u64 = 64 << 10;

/// The whole file, its bytes charged to `budget`.
pub(crate) fn read_file(path: &Path, budget: &Budget) -> Result<Vec<u8>> {
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    let io = |e| Error::io(path, e);
    if !meta.is_file() {
        return read_stream(path, &mut file, budget);
    }
    let len = meta.len();
    budget.charge(format_args!("the file ({len} bytes)"), len)?;
    let len = usize::try_from(len).map_err(|_| budget.over("the file", len))?;
    let mut data = Vec::new();
    data.try_reserve_exact(len)
        .map_err(|_| Error::parse(path, None, format!("cannot allocate {} for the file", Size(len as u64))))?;
    advise_huge(&mut data);
    // a file that grows while it is read: what it grew by is charged too
    let extra = budget.left();
    (&mut file)
        .take(len as u64 + extra.saturating_add(1))
        .read_to_end(&mut data)
        .map_err(io)?;
    if data.len() < len {
        return Err(Error::parse(
            path,
            None,
            format!(
                "the file shrank from {len} to {} bytes while it was read (truncated by another process?)",
                data.len()
            ),
        ));
    }
    let grew = (data.len() - len) as u64;
    if grew > 0 {
        budget.charge("the file, which grew while it was read,", grew)?;
    }
    Ok(data)
}

/// A device, FIFO or other stream: its first bytes must look like a mesh
/// file (every format starts with text); the rest is read up to what the
/// budget allows.
fn read_stream(path: &Path, file: &mut File, budget: &Budget) -> Result<Vec<u8>> {
    let io = |e| Error::io(path, e);
    let mut data = Vec::new();
    file.take(HEAD.min(budget.left())).read_to_end(&mut data).map_err(io)?;
    if data.len() as u64 == HEAD && super::sniff(&data).is_none() && data.contains(&0) {
        return Err(Error::parse(
            path,
            None,
            "not a mesh file: a stream (device or pipe) whose first bytes are binary, not a format's header",
        ));
    }
    let left = budget.left().saturating_sub(data.len() as u64);
    file.take(left.saturating_add(1)).read_to_end(&mut data).map_err(io)?;
    budget.charge("the stream", data.len() as u64)?;
    Ok(data)
}

/// Huge pages for a large buffer about to be filled (Linux; elsewhere, or
/// if refused, ordinary pages).
fn advise_huge(data: &mut Vec<u8>) {
    #[cfg(target_os = "linux")]
    if data.capacity() >= HUGE_FROM {
        let page = 4096;
        let start = data.as_mut_ptr() as usize;
        let aligned = start.next_multiple_of(page);
        let len = (start + data.capacity() - aligned) / page * page;
        // SAFETY: advice on pages of this Vec's own allocation; it changes
        // how they are backed, not their contents or validity
        unsafe {
            libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (data, HUGE_FROM);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ReadLimits;

    fn budget(max_bytes: u64) -> Budget {
        Budget::new(Path::new("x"), &ReadLimits { max_bytes })
    }

    #[test]
    fn files_read_whole_within_the_budget() {
        let dir = tempfile::tempdir().unwrap();
        for (name, len) in [("small", 1000usize), ("large", HUGE_FROM + 12_345)] {
            let want: Vec<u8> = (0..len).map(|i| (i * 7 % 251) as u8).collect();
            let path = dir.path().join(name);
            std::fs::write(&path, &want).unwrap();
            let b = budget(1 << 30);
            assert!(read_file(&path, &b).unwrap() == want, "{name}");
            assert_eq!(b.left(), (1 << 30) - len as u64);
            let e = read_file(&path, &budget(len as u64 - 1)).unwrap_err().to_string();
            assert!(
                e.contains("memory budget") && e.contains(&format!("{len} bytes")),
                "{e}"
            );
        }
        assert!(read_file(&dir.path().join("missing"), &budget(1 << 20)).is_err());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn endless_streams_end_at_the_budget() {
        let e = read_file(Path::new("/dev/zero"), &budget(1 << 30))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a mesh file"), "{e}");
        // text without end: read until the budget is spent
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.vtk");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let writer = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                use std::io::Write;
                let mut f = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
                let line = [b' '; 4096];
                while f.write_all(&line).is_ok() {}
            })
        };
        let e = read_file(&fifo, &budget(8 << 20)).unwrap_err().to_string();
        assert!(e.contains("the stream") && e.contains("memory budget"), "{e}");
        writer.join().unwrap();
    }
}
