//! Atomic file replacement: a crash or error never leaves a partial mesh file.

use std::io::{BufWriter, Write};
use std::path::Path;

use super::{WriteError, WriteResult};
use crate::error::{Error, Result};

/// Run `fill` on a temporary file in `path`'s directory, then rename it over
/// `path`. On any error the temporary file is deleted (by `NamedTempFile`'s
/// drop) and `path` keeps its previous content.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> WriteResult) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("output directory {} does not exist", dir.display()),
            ),
        ));
    }
    let mut tmp = tempfile::Builder::new()
        .prefix(".meshsmooth-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| Error::io(path, e))?;
    let filled = {
        let mut w = BufWriter::new(tmp.as_file_mut());
        fill(&mut w).and_then(|()| w.flush().map_err(WriteError::Io))
    };
    match filled {
        Ok(()) => {}
        Err(WriteError::Io(e)) => return Err(Error::io(path, e)),
        Err(WriteError::Other(e)) => return Err(e),
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Whether two paths name the same existing file (after resolving links and
/// `..`); false when either does not exist.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}
