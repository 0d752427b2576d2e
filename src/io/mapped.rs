//! A mesh file's bytes, mapped instead of copied when the file is large.
//!
//! Reading a 600 MB file meant a fresh 600 MB buffer: every page faulted in,
//! zeroed, then filled by a copy from the page cache, about 0.8 s on the
//! 2-core VM. Mapping the cached pages costs a fraction of that. The one
//! thing a mapping changes: a file truncated by another process while it is
//! being read ends the process (SIGBUS) instead of failing the read.

use std::fs::File;
use std::ops::Deref;
use std::path::Path;

use crate::error::{Error, Result};

/// Files at least this large are mapped; smaller ones are read.
const MAP_FROM: u64 = 16 << 20;

pub(crate) enum FileBytes {
    Read(Vec<u8>),
    #[cfg(unix)]
    Mapped {
        ptr: std::ptr::NonNull<u8>,
        len: usize,
    },
}

// SAFETY: the mapping is read-only and owned, like a Box<[u8]>
unsafe impl Send for FileBytes {}
unsafe impl Sync for FileBytes {}

impl FileBytes {
    pub fn of(path: &Path) -> Result<FileBytes> {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let meta = file.metadata().map_err(|e| Error::io(path, e))?;
        #[cfg(unix)]
        if meta.is_file()
            && meta.len() >= MAP_FROM
            && let Ok(len) = usize::try_from(meta.len())
            && let Some(ptr) = map(&file, len)
        {
            return Ok(FileBytes::Mapped { ptr, len });
        }
        let mut data = Vec::new();
        std::io::Read::read_to_end(&mut &file, &mut data).map_err(|e| Error::io(path, e))?;
        Ok(FileBytes::Read(data))
    }
}

/// The whole file mapped read-only and populated (its cached pages mapped
/// at once, not faulted in one by one); `None` if the system refuses, and
/// the file is then read.
#[cfg(unix)]
fn map(file: &File, len: usize) -> Option<std::ptr::NonNull<u8>> {
    use std::os::fd::AsRawFd;
    #[cfg(target_os = "linux")]
    let flags = libc::MAP_PRIVATE | libc::MAP_POPULATE;
    #[cfg(not(target_os = "linux"))]
    let flags = libc::MAP_PRIVATE;
    // SAFETY: a fresh read-only private mapping of an open file; nothing
    // else in this process refers to that memory
    let p = unsafe { libc::mmap(std::ptr::null_mut(), len, libc::PROT_READ, flags, file.as_raw_fd(), 0) };
    if p == libc::MAP_FAILED {
        return None;
    }
    std::ptr::NonNull::new(p.cast())
}

impl Deref for FileBytes {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Read(v) => v,
            // SAFETY: `len` bytes mapped readable for as long as self lives
            #[cfg(unix)]
            FileBytes::Mapped { ptr, len } => unsafe { std::slice::from_raw_parts(ptr.as_ptr(), *len) },
        }
    }
}

impl Drop for FileBytes {
    fn drop(&mut self) {
        #[cfg(unix)]
        if let FileBytes::Mapped { ptr, len } = self {
            // SAFETY: the mapping made in `map`, unmapped once; no borrow
            // of it outlives self
            unsafe {
                libc::munmap(ptr.as_ptr().cast(), *len);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_files_map_small_ones_read_and_both_hold_the_bytes() {
        let dir = tempfile::tempdir().unwrap();
        for (name, len) in [("small", 1000usize), ("large", MAP_FROM as usize + 12_345)] {
            let want: Vec<u8> = (0..len).map(|i| (i * 7 % 251) as u8).collect();
            let path = dir.path().join(name);
            std::fs::write(&path, &want).unwrap();
            let got = FileBytes::of(&path).unwrap();
            assert_eq!(matches!(got, FileBytes::Read(_)), len < MAP_FROM as usize, "{name}");
            assert!(*got == want[..], "{name}");
        }
        assert!(FileBytes::of(&dir.path().join("missing")).is_err());
    }
}
