//! Output files: a crash or error never leaves a partial mesh file, and what
//! is not a regular file is never replaced.
//!
//! - a regular file (or a new path) is written to a temporary file beside it
//!   and renamed over it; a new file gets mode 0666 minus the umask, a
//!   replaced one keeps its mode;
//! - a symbolic link is followed: its final target is replaced that way, the
//!   link stays;
//! - a character device, FIFO or socket (`/dev/null`, `/dev/stdout`, a pipe)
//!   is written directly, whatever links lead to it (never a temporary file
//!   beside it, never a rename over it);
//! - a directory is refused.
//!
//! [`stage`] and [`Staged::commit`] split a write in two, so that several
//! outputs can be written all or nothing; [`stage_dir`] does the same for a
//! directory (an OpenFOAM polyMesh), written whole beside its target.

use std::fs::{self, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{WriteError, WriteResult};
use crate::error::{Error, Result};

fn not_found(path: &Path, msg: String) -> Error {
    Error::io(path, std::io::Error::new(std::io::ErrorKind::NotFound, msg))
}

/// Follow symbolic links from `path` to the path that is really written
/// (which need not exist yet); gives up after 40 links, like the kernel.
fn resolve_links(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = fs::read_link(&p).map_err(|e| Error::io(path, e))?;
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(Error::io(
        path,
        std::io::Error::other("too many levels of symbolic links"),
    ))
}

fn finish(path: &Path, filled: WriteResult) -> Result<()> {
    match filled {
        Ok(()) => Ok(()),
        Err(WriteError::Io(e)) => Err(Error::io(path, e)),
        Err(WriteError::Other(e)) => Err(e),
    }
}

/// Write what `fill` produces to `path` (see the module doc): either the
/// complete file replaces `path`, or `path` is left as it was. On any error
/// the temporary file is deleted.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> WriteResult) -> Result<()> {
    stage(path, fill)?.commit()
}

/// An output written but not yet in place: a complete temporary file beside
/// its target, renamed over it by [`Staged::commit`] and deleted if dropped
/// uncommitted. Several outputs are written all or nothing by staging each
/// (streams last: what goes to a device or pipe is gone once written) and
/// committing them only once every one is staged.
#[must_use = "a staged output is deleted unless committed"]
pub struct Staged {
    path: PathBuf,
    pending: Option<Pending>,
}

/// What [`Staged::commit`] renames into place.
enum Pending {
    /// A temporary file and the file it replaces.
    File(tempfile::NamedTempFile, PathBuf),
    /// A temporary directory, the directory it becomes (replacing one
    /// there), and an empty file to create afterwards if missing (an
    /// OpenFOAM case's `.foam` marker).
    Dir(tempfile::TempDir, PathBuf, Option<PathBuf>),
}

impl Staged {
    /// An output already written (to a stream): nothing left to commit.
    pub fn written(path: &Path) -> Staged {
        Staged {
            path: path.to_path_buf(),
            pending: None,
        }
    }

    /// The path given for this output.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Puts the output in place (renames the temporary file over its target).
    pub fn commit(self) -> Result<()> {
        match self.pending {
            None => Ok(()),
            Some(Pending::File(tmp, target)) => {
                tmp.persist(&target).map_err(|e| Error::io(&self.path, e.error))?;
                Ok(())
            }
            Some(Pending::Dir(tmp, target, marker)) => {
                let tmp = tmp.keep();
                let put = replace_dir(&tmp, &target).map_err(|e| Error::io(&self.path, e));
                if put.is_err() {
                    let _ = fs::remove_dir_all(&tmp);
                }
                put?;
                if let Some(m) = marker.filter(|m| fs::symlink_metadata(m).is_err()) {
                    fs::File::create(&m).map_err(|e| Error::io(&m, e))?;
                }
                Ok(())
            }
        }
    }
}

/// Puts the directory `new` in the place of `target`: at once where
/// `target` is a directory the kernel can exchange it with (the old one
/// then deleted), else by moving the old one aside first.
fn replace_dir(new: &Path, target: &Path) -> std::io::Result<()> {
    if fs::symlink_metadata(target).is_err() {
        return fs::rename(new, target);
    }
    if exchange(new, target)? {
        // `new` now holds the old directory
        return fs::remove_dir_all(new);
    }
    let aside = new.with_extension("old");
    fs::rename(target, &aside)?;
    if let Err(e) = fs::rename(new, target) {
        let _ = fs::rename(&aside, target);
        return Err(e);
    }
    fs::remove_dir_all(&aside)
}

/// Swaps two directories in one step (Linux's `renameat2` with
/// `RENAME_EXCHANGE`); false where the system or file system cannot.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| std::ffi::CString::new(p.as_os_str().as_bytes()).map_err(std::io::Error::other);
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: two valid NUL-terminated paths; the call only renames
    let r = unsafe {
        libc::syscall(
            libc::SYS_renameat2,
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        return Ok(true);
    }
    match std::io::Error::last_os_error().raw_os_error() {
        Some(libc::ENOSYS | libc::EINVAL | libc::EOPNOTSUPP) => Ok(false),
        _ => Err(std::io::Error::last_os_error()),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<bool> {
    Ok(false)
}

/// A directory written whole beside `target` by `fill` (given the
/// temporary directory to fill) and put in its place by [`Staged::commit`]:
/// the directory-valued twin of [`stage`]. A link at `target` is followed
/// (the link stays); anything there but a directory is refused, and so is
/// an entry of the old directory that `keep` names and that is not a
/// regular file (a device or FIFO is never replaced). `marker`: an empty
/// file created after the commit if missing. `path` is what errors call
/// the output.
pub(crate) fn stage_dir(
    path: &Path,
    target: &Path,
    keep: &[&str],
    marker: Option<PathBuf>,
    fill: impl FnOnce(&Path) -> Result<()>,
) -> Result<Staged> {
    let target = resolve_links(target)?;
    match fs::metadata(&target) {
        Ok(m) if !m.is_dir() => {
            return Err(Error::io(
                &target,
                std::io::Error::new(std::io::ErrorKind::NotADirectory, "is not a directory"),
            ));
        }
        Ok(_) => {
            for name in keep {
                let p = target.join(name);
                if let Ok(m) = fs::symlink_metadata(&p)
                    && !m.is_file()
                {
                    return Err(Error::io(
                        &p,
                        std::io::Error::other(
                            "is not a regular file; meshsmooth never replaces a device, FIFO, socket or link",
                        ),
                    ));
                }
            }
        }
        Err(_) => {}
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(not_found(
            path,
            format!("output directory {} does not exist", dir.display()),
        ));
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".meshsmooth-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(fs::Permissions::from_mode(0o777));
    }
    let tmp = builder.tempdir_in(dir).map_err(|e| Error::io(path, e))?;
    fill(tmp.path())?;
    if let Ok(m) = fs::metadata(&target) {
        fs::set_permissions(tmp.path(), m.permissions()).map_err(|e| Error::io(path, e))?;
    }
    Ok(Staged {
        path: path.to_path_buf(),
        pending: Some(Pending::Dir(tmp, target, marker)),
    })
}

/// Whether `path` is written through rather than replaced: it exists
/// (links followed, `/dev/stdout` and `/proc/self/fd/N` included) and is a
/// device, FIFO or socket.
pub fn is_stream(path: &Path) -> bool {
    fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// The first half of [`write_atomic`]: `fill` writes the complete output to a
/// temporary file beside the target, synced to the disk; [`Staged::commit`]
/// puts it in place. A device, FIFO or socket is written through at once.
pub fn stage(path: &Path, fill: impl FnOnce(&mut dyn Write) -> WriteResult) -> Result<Staged> {
    // what the path names, every link followed: the kernel's own view, right
    // for the magic links of /proc (/dev/stdout -> /proc/self/fd/1 ->
    // "pipe:[…]" names no file that could be replaced)
    let existing = match fs::metadata(path) {
        Ok(m) => Some(m),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(Error::io(path, e)),
    };
    if let Some(m) = &existing {
        if m.is_dir() {
            return Err(Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a directory, not a file"),
            ));
        }
        if !m.is_file() {
            // a device, FIFO or socket: write through, never replace
            write_through(path, fill)?;
            return Ok(Staged::written(path));
        }
    }
    let target = resolve_links(path)?;
    if let Some(m) = &existing {
        // the link resolved by hand must lead to the file the kernel opens,
        // else (a /proc link to a deleted file, say) nothing may be renamed
        if !same_inode(m, &target) {
            write_through(path, fill)?;
            return Ok(Staged::written(path));
        }
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(not_found(
            path,
            format!("output directory {} does not exist", dir.display()),
        ));
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".meshsmooth-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // created with 0666 & ~umask, as any tool would (the kernel applies the umask)
        builder.permissions(fs::Permissions::from_mode(0o666));
    }
    let tmp = builder.tempfile_in(dir).map_err(|e| Error::io(path, e))?;
    let filled = {
        let mut w = BufWriter::with_capacity(1 << 20, Streamed::new(tmp.as_file()));
        fill(&mut w).and_then(|()| w.flush().map_err(WriteError::Io))
    };
    finish(path, filled)?;
    if let Some(m) = &existing {
        // a replaced file keeps its mode
        tmp.as_file()
            .set_permissions(m.permissions())
            .map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    Ok(Staged {
        path: path.to_path_buf(),
        pending: Some(Pending::File(tmp, target)),
    })
}

/// Opens `path` (links followed by the kernel) and writes `fill` into it.
fn write_through(path: &Path, fill: impl FnOnce(&mut dyn Write) -> WriteResult) -> Result<()> {
    let f = OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    let mut w = BufWriter::new(f);
    let filled = fill(&mut w).and_then(|()| w.flush().map_err(WriteError::Io));
    finish(path, filled)
}

#[cfg(unix)]
fn same_inode(m: &fs::Metadata, other: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    fs::metadata(other).is_ok_and(|o| o.dev() == m.dev() && o.ino() == m.ino())
}

#[cfg(not(unix))]
fn same_inode(_: &fs::Metadata, other: &Path) -> bool {
    other.is_file()
}

/// The temporary file, its pages sent to the disk as it grows. Left to
/// itself the kernel starts writing a file back only once a tenth of the
/// memory is dirty, so a file of a few hundred MB would wait whole for the
/// closing `fsync`, the disk idle while it was encoded. Starting the
/// writeback every few MB overlaps the two; the `fsync` still decides.
struct Streamed<'a> {
    file: &'a fs::File,
    written: u64,
    started: u64,
}

impl<'a> Streamed<'a> {
    /// How much is written before its writeback is started.
    const STEP: u64 = 16 << 20;

    fn new(file: &'a fs::File) -> Self {
        Streamed {
            file,
            written: 0,
            started: 0,
        }
    }
}

impl Write for Streamed<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let k = (&mut &*self.file).write(buf)?;
        self.written += k as u64;
        if self.written - self.started >= Self::STEP {
            start_writeback(self.file, self.started, self.written - self.started);
            self.started = self.written;
        }
        Ok(k)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        (&mut &*self.file).flush()
    }
}

/// Asks the kernel to start writing `len` bytes at `from` to the disk,
/// without waiting for them: a hint, so its failure is ignored (the closing
/// `fsync` reports what matters).
#[cfg(target_os = "linux")]
fn start_writeback(file: &fs::File, from: u64, len: u64) {
    use std::os::fd::AsRawFd;
    // SAFETY: only integers and an open descriptor cross; no memory is shared
    unsafe {
        libc::sync_file_range(
            file.as_raw_fd(),
            from as libc::off64_t,
            len as libc::off64_t,
            libc::SYNC_FILE_RANGE_WRITE,
        );
    }
}

#[cfg(not(target_os = "linux"))]
fn start_writeback(_: &fs::File, _: u64, _: u64) {}

/// Whether two paths name the same existing file (after resolving links and
/// `..`); false when either does not exist.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Whether writing to `a` and to `b` would write the same file, whether or
/// not it exists yet (links and `..` resolved as far as they exist).
pub fn same_target(a: &Path, b: &Path) -> bool {
    fn norm(p: &Path) -> Option<PathBuf> {
        let p = resolve_links(p).ok()?;
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let name = p.file_name()?;
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(name))
    }
    match (norm(a), norm(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}
