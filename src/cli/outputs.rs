//! Output paths: every one checked before any work is done, all written or
//! none, and `-` (or `/dev/stdout`) for a mesh on standard output.

use meshsmooth::io::{self, Format, Staged};
use meshsmooth::{Error, Mesh, Result};
use std::fs::File;
use std::path::{Path, PathBuf};

/// Whether `path` asks for standard output: `-`, or a name of this
/// process's standard output that is not a regular file (`/dev/stdout`,
/// `/dev/fd/1`).
pub(super) fn is_stdout(path: &Path) -> bool {
    if path.as_os_str() == "-" {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        // SAFETY: fstat on a descriptor number into a zeroed struct it fills
        let (dev, ino) = unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            if libc::fstat(1, &mut st) != 0 {
                return false;
            }
            (st.st_dev as u64, st.st_ino as u64)
        };
        let not_a_file = std::fs::symlink_metadata(path).is_ok_and(|m| !m.is_file());
        not_a_file && std::fs::metadata(path).is_ok_and(|m| m.dev() == dev && m.ino() == ino)
    }
    #[cfg(not(unix))]
    false
}

fn refuse(message: String) -> Error {
    Error::InvalidArgument(message)
}

/// Checks the outputs `(flag, path)` of a command before it does any work:
/// none may be a directory, be in a directory that does not exist or cannot
/// be written, be the input (`input`) or another output; at most one goes
/// to standard output.
pub(super) fn check(input: Option<&Path>, outputs: &[(&str, &Path)]) -> Result<()> {
    let mut files: Vec<(&str, &Path)> = Vec::new();
    let mut on_stdout: Option<&str> = None;
    for &(flag, path) in outputs {
        if is_stdout(path) {
            if let Some(first) = on_stdout {
                return Err(refuse(format!(
                    "{flag} {} and {first} both write to standard output; give one of them a file",
                    path.display()
                )));
            }
            on_stdout = Some(flag);
            continue;
        }
        if let Some(input) = input.filter(|i| io::same_target(path, i) || io::same_case(path, i)) {
            return Err(refuse(format!(
                "{flag} {} is the input mesh {}; meshsmooth never overwrites its input: give {flag} a file of its own",
                path.display(),
                input.display()
            )));
        }
        if let Some((other, _)) = files.iter().find(|(_, p)| io::same_target(path, p)) {
            return Err(refuse(format!(
                "{flag} {} is also the file of {other}; give each output its own file",
                path.display()
            )));
        }
        if !io::is_stream(path) && !is_case(path, input) {
            check_file(flag, path)?;
        }
        files.push((flag, path));
    }
    Ok(())
}

/// Whether `path` is an OpenFOAM case to write (a folder, checked when it
/// is staged): an existing case or `.foam` marker, or any folder when the
/// input is a case.
fn is_case(path: &Path, input: Option<&Path>) -> bool {
    let foam_input = || input.and_then(Format::of_file).is_some_and(Format::is_openfoam);
    Format::from_path(path).is_ok_and(Format::is_openfoam) || (path.is_dir() && foam_input())
}

/// A file output: not a directory, its directory there and writable.
fn check_file(flag: &str, path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(refuse(format!(
            "{flag} {} is a directory; give a file name",
            path.display()
        )));
    }
    if path.as_os_str().is_empty() {
        return Err(refuse(format!("{flag} needs a file name")));
    }
    if path.exists() {
        // an existing file (or a link to one): replaced beside its target
        return Ok(());
    }
    if std::fs::symlink_metadata(path).is_ok() {
        // a dangling link: the write creates its target, where it says
        return Ok(());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.exists() {
        return Err(refuse(format!(
            "{flag} {}: the directory {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    if !dir.is_dir() {
        return Err(refuse(format!(
            "{flag} {}: {} is not a directory",
            path.display(),
            dir.display()
        )));
    }
    // the temporary file the write will need: made and removed now
    tempfile::Builder::new()
        .prefix(".meshsmooth-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| {
            refuse(format!(
                "{flag} {}: cannot write in {}: {e}",
                path.display(),
                dir.display()
            ))
        })
}

/// The format of the mesh output `flag path`: `--format` where given, else
/// the extension; standard output has none, so there `--format` is required.
pub(super) fn mesh_format(flag: &str, path: &Path, name: Option<&str>, input: Option<&Path>) -> Result<Format> {
    if name.is_none() && (path.as_os_str() == "-" || (path.extension().is_none() && is_stdout(path))) {
        return Err(refuse(format!(
            "{flag} {} names standard output, which has no extension to tell the mesh format: \
             give --format (vtk, vtk-binary, vtu, vtu-binary, vtu-zlib, vtp, vtp-ascii, vtp-zlib, msh2, msh2-binary, msh4, \
             msh4-binary, medit, abaqus, stl, stl-ascii, obj, ply or ply-ascii)",
            path.display()
        )));
    }
    match (name, input) {
        (None, Some(input)) => Format::following(path, input),
        _ => super::commands::output_format(path, name),
    }
}

/// Where a mesh goes: a file, or standard output. Opened for standard
/// output, it takes the process's standard output for the mesh and points
/// descriptor 1 at standard error, so every report printed afterwards goes
/// there and nothing but the mesh reaches the pipe.
pub(super) struct MeshSink {
    path: PathBuf,
    stdout: Option<File>,
}

impl MeshSink {
    /// Call after [`check`], before anything is printed.
    pub(super) fn open(path: &Path) -> Result<MeshSink> {
        let stdout = if is_stdout(path) { Some(claim_stdout()?) } else { None };
        Ok(MeshSink {
            path: path.to_path_buf(),
            stdout,
        })
    }

    /// How the reports name the output.
    pub(super) fn name(&self) -> String {
        match self.stdout {
            Some(_) => "the mesh to standard output".into(),
            None => self.path.display().to_string(),
        }
    }

    /// Writes `mesh` (with the quality field where `quality`): staged when a
    /// file, written at once to standard output.
    pub(super) fn stage(&mut self, mesh: &Mesh, format: Format, quality: bool) -> Result<Staged> {
        match &mut self.stdout {
            Some(out) => {
                let name = Path::new("standard output");
                if quality {
                    io::write_mesh_to(out, name, mesh, format)?;
                } else {
                    io::write_to(out, name, mesh, format, &[])?;
                }
                Ok(Staged::written(&self.path))
            }
            None if quality => io::stage_mesh(&self.path, mesh, format),
            None => io::stage_write(&self.path, mesh, format, &[]),
        }
    }
}

/// Standard output for the mesh; descriptor 1 then leads to standard error.
#[cfg(unix)]
fn claim_stdout() -> Result<File> {
    use std::io::Write;
    use std::os::fd::FromRawFd;
    let _ = std::io::stdout().flush();
    let failed = || Error::io("standard output", std::io::Error::last_os_error());
    // SAFETY: descriptor numbers only; the duplicate is owned by the File alone
    unsafe {
        let fd = libc::fcntl(1, libc::F_DUPFD_CLOEXEC, 3);
        if fd < 0 {
            return Err(failed());
        }
        let out = File::from_raw_fd(fd);
        if libc::dup2(2, 1) < 0 {
            return Err(failed());
        }
        Ok(out)
    }
}

#[cfg(not(unix))]
fn claim_stdout() -> Result<File> {
    Err(Error::InvalidArgument(
        "writing the mesh to standard output needs a Unix system; give -o a file".into(),
    ))
}

/// Outputs written all or nothing: [`Writes::stage`] runs every job, files
/// first (each to a temporary file beside its target) and streams last
/// (what reaches a pipe cannot be taken back), and only
/// [`Staging::commit`] renames the files into place. An error anywhere
/// before leaves no output behind.
#[derive(Default)]
pub(super) struct Writes<'a> {
    /// Whether each job writes a stream, and the job.
    jobs: Vec<(bool, Job<'a>)>,
}

type Job<'a> = Box<dyn FnOnce() -> Result<Staged> + 'a>;

impl<'a> Writes<'a> {
    pub(super) fn add(&mut self, path: &Path, job: impl FnOnce() -> Result<Staged> + 'a) {
        let stream = path.as_os_str() == "-" || io::is_stream(path);
        self.jobs.push((stream, Box::new(job)));
    }

    pub(super) fn stage(mut self) -> Result<Staging> {
        self.jobs.sort_by_key(|(stream, _)| *stream);
        let mut staged = Vec::with_capacity(self.jobs.len());
        for (_, job) in self.jobs {
            staged.push(job()?);
        }
        Ok(Staging(staged))
    }

    pub(super) fn run(self) -> Result<()> {
        self.stage()?.commit()
    }
}

/// Outputs staged by [`Writes::stage`]; dropped uncommitted, they are deleted.
pub(super) struct Staging(Vec<Staged>);

impl Staging {
    pub(super) fn commit(self) -> Result<()> {
        for s in self.0 {
            s.commit()?;
        }
        Ok(())
    }
}

/// Stages `text` as the file `path`.
pub(super) fn stage_text(path: &Path, text: String) -> Result<Staged> {
    io::stage(path, move |w| Ok(w.write_all(text.as_bytes())?))
}
