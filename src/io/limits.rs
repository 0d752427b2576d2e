//! How much memory reading one mesh file may take.
//!
//! A file's headers declare sizes (array lengths, block sizes, counts of
//! nodes and elements) that a hostile or broken file can set to anything; a
//! compressed block can inflate a thousandfold (zlib) or far more (LZMA).
//! Every declared size is checked against what the file can hold, and what
//! is left is charged to a budget before it is allocated, so that such a
//! file ends in an error naming the file and the array instead of filling
//! the memory.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Limits on what reading a mesh file may allocate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// Bytes one file's read may allocate: its bytes, decompressed blocks
    /// and decoded arrays (the mesh built from them comes on top).
    pub max_bytes: u64,
}

/// 0: no default set, the system's is used.
static DEFAULT_MAX: AtomicU64 = AtomicU64::new(0);

/// Without /proc/meminfo (not Linux): a budget most machines that read
/// large meshes have.
const FALLBACK: u64 = 8 << 30;

impl Default for ReadLimits {
    /// The process's default: the one [`ReadLimits::set_default`] set, else
    /// [`ReadLimits::system`].
    fn default() -> Self {
        match DEFAULT_MAX.load(Ordering::Relaxed) {
            0 => ReadLimits::system(),
            max_bytes => ReadLimits { max_bytes },
        }
    }
}

impl ReadLimits {
    /// Half the physical memory (`MemTotal` of /proc/meminfo), or 8 GiB where
    /// that cannot be read: large enough for any mesh the machine can smooth
    /// (smoothing needs several times the file's arrays), small enough that a
    /// hostile file is refused before the system starts swapping.
    pub fn system() -> ReadLimits {
        let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: u64 = line["MemTotal:".len()..]
                .trim()
                .strip_suffix("kB")?
                .trim()
                .parse()
                .ok()?;
            Some(kib.saturating_mul(1024))
        });
        ReadLimits {
            max_bytes: total.filter(|&t| t > 0).map_or(FALLBACK, |t| t / 2),
        }
    }

    /// Makes these the limits of [`read`](super::read) (and of every read
    /// without limits of its own) in this process.
    pub fn set_default(self) {
        DEFAULT_MAX.store(self.max_bytes.max(1), Ordering::Relaxed);
    }

    /// A size such as `4G`, `512M`, `64k` or `1000000` (bytes): binary
    /// multiples (K = 1024), case-insensitive, an optional `B` or `iB` after
    /// the unit, a fraction allowed (`1.5G`).
    pub fn parse_size(s: &str) -> Result<u64> {
        let bad = || {
            Error::InvalidArgument(format!(
                "'{}' is not a memory size (a number of bytes, or with a unit: 512M, 4G, 1.5T)",
                super::lex::clip(s)
            ))
        };
        let t = s.trim();
        let lower = t.to_ascii_lowercase();
        let body = lower
            .strip_suffix("ib")
            .or_else(|| lower.strip_suffix('b'))
            .unwrap_or(&lower);
        let (num, shift) = match body.chars().last() {
            Some('k') => (&body[..body.len() - 1], 10),
            Some('m') => (&body[..body.len() - 1], 20),
            Some('g') => (&body[..body.len() - 1], 30),
            Some('t') => (&body[..body.len() - 1], 40),
            _ => (body, 0),
        };
        let x: f64 = num.trim().parse().map_err(|_| bad())?;
        let bytes = x * (1u64 << shift) as f64;
        if !(bytes >= 1.0) || bytes >= u64::MAX as f64 {
            return Err(bad());
        }
        Ok(bytes as u64)
    }
}

/// Bytes in words: `512 MiB`, `3.2 GiB`.
pub(crate) struct Size(pub u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        match self.0 {
            n if n < 1 << 10 => write!(f, "{n} bytes"),
            n if n < 1 << 20 => write!(f, "{:.1} KiB", b / 1024.0),
            n if n < 1 << 30 => write!(f, "{:.1} MiB", b / (1u64 << 20) as f64),
            _ => write!(f, "{:.2} GiB", b / (1u64 << 30) as f64),
        }
    }
}

/// What one file's read has allocated so far, against its limit.
pub(crate) struct Budget {
    path: PathBuf,
    max: u64,
    used: AtomicU64,
}

impl Budget {
    pub fn new(path: &Path, limits: &ReadLimits) -> Budget {
        Budget {
            path: path.to_path_buf(),
            max: limits.max_bytes,
            used: AtomicU64::new(0),
        }
    }

    /// Bytes that may still be allocated.
    pub fn left(&self) -> u64 {
        self.max.saturating_sub(self.used.load(Ordering::Relaxed))
    }

    /// Takes `bytes` for `what` (an array, a section) from the budget, or
    /// fails naming both and the limit.
    pub fn charge(&self, what: impl fmt::Display, bytes: u64) -> Result<()> {
        let mut used = self.used.load(Ordering::Relaxed);
        loop {
            let after = used.saturating_add(bytes);
            if after > self.max {
                return Err(self.over(what, bytes));
            }
            match self
                .used
                .compare_exchange_weak(used, after, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => return Ok(()),
                Err(now) => used = now,
            }
        }
    }

    /// Gives back what a buffer that is gone had taken.
    pub fn release(&self, bytes: u64) {
        let _ = self
            .used
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |u| Some(u.saturating_sub(bytes)));
    }

    /// The error for `what` needing `bytes` more than is left.
    pub fn over(&self, what: impl fmt::Display, bytes: u64) -> Error {
        Error::parse(&self.path, None, self.over_msg(what, bytes))
    }

    pub fn over_msg(&self, what: impl fmt::Display, bytes: u64) -> String {
        let used = self.used.load(Ordering::Relaxed);
        format!(
            "{what} needs {}, more than the memory budget for reading allows ({} limit, {} already taken); \
             raise it with --max-memory (ReadLimits::max_bytes) if the file is genuine",
            Size(bytes),
            Size(self.max),
            Size(used)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        for (s, want) in [
            ("4G", 4u64 << 30),
            ("512M", 512 << 20),
            ("512mib", 512 << 20),
            ("64kB", 64 << 10),
            ("1.5g", 3 << 29),
            ("1000", 1000),
            (" 2T ", 2 << 40),
        ] {
            assert_eq!(ReadLimits::parse_size(s).unwrap(), want, "{s}");
        }
        for s in ["", "G", "-1G", "0", "four", "1Q", "nanG", "1e30T"] {
            assert!(ReadLimits::parse_size(s).is_err(), "{s}");
        }
    }

    #[test]
    fn the_budget_refuses_what_is_past_its_limit() {
        let b = Budget::new(Path::new("f.vtu"), &ReadLimits { max_bytes: 100 });
        b.charge("a", 60).unwrap();
        let e = b.charge("DataArray 'x'", 41).unwrap_err().to_string();
        assert!(
            e.contains("f.vtu") && e.contains("DataArray 'x'") && e.contains("41 bytes"),
            "{e}"
        );
        b.charge("b", 40).unwrap();
        b.release(50);
        assert_eq!(b.left(), 50);
        assert!(ReadLimits::system().max_bytes >= 1 << 20);
    }
}
