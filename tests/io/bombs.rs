//! Hostile files: declared sizes far beyond the data, decompression bombs,
//! endless streams. Each must end in an error naming the file and the array
//! or section, quickly, within a bounded memory: the CLI runs them as a child
//! whose peak RSS `wait4` reports.

use std::ffi::OsStr;
use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use base64::Engine;
use base64::engine::general_purpose::STANDARD as B64;

use meshsmooth::io::{self, Format, ReadLimits};
use meshsmooth::mesh::{ElementKind, Mesh};

/// What a child run of the CLI did.
pub struct Run {
    pub code: Option<i32>,
    /// The signal that ended it, if one did.
    pub signal: Option<i32>,
    pub stderr: String,
    pub max_rss_kib: i64,
    pub secs: f64,
}

/// `meshsmooth ARGS`, its peak RSS and time; killed after `timeout`.
// the child is reaped by wait4, which also reports its resource use
#[allow(clippy::zombie_processes)]
pub fn run_cli(args: &[&OsStr], timeout: Duration) -> Run {
    let start = Instant::now();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let pid = child.id() as libc::pid_t;
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watchdog = {
        let done = done.clone();
        std::thread::spawn(move || {
            while start.elapsed() < timeout {
                if done.load(std::sync::atomic::Ordering::SeqCst) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            if !done.load(std::sync::atomic::Ordering::SeqCst) {
                // SAFETY: our own child, not yet reaped (so the pid is still its)
                unsafe { libc::kill(pid, libc::SIGKILL) };
            }
        })
    };
    let mut status = 0;
    // ru_maxrss is an upper bound: Linux starts a child's peak at its
    // parent's RSS when it spawns (the exec'd image replaces a copy of it)
    // SAFETY: rusage is plain data, filled in by wait4
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: waits for our own child; `child` is never waited on afterwards
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut ru) };
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    assert_eq!(r, pid, "wait4");
    watchdog.join().unwrap();
    let secs = start.elapsed().as_secs_f64();
    Run {
        code: libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status)),
        signal: libc::WIFSIGNALED(status).then(|| libc::WTERMSIG(status)),
        stderr: reader.join().unwrap(),
        max_rss_kib: ru.ru_maxrss,
        secs,
    }
}

/// `meshsmooth quality FILE [--max-memory M]` must fail naming the file and
/// every needle, under 1 GiB of RSS and in under 5 s.
pub fn refused(file: &Path, max_memory: Option<&str>, needles: &[&str]) -> Run {
    let mut args: Vec<&OsStr> = vec!["quality".as_ref(), file.as_os_str()];
    if let Some(m) = max_memory {
        args.extend(["--max-memory".as_ref(), OsStr::new(m)]);
    }
    let run = run_cli(&args, Duration::from_secs(60));
    let name = file.file_name().unwrap().to_string_lossy();
    let what = format!(
        "{name}: {} (rss {} KiB, {:.2} s)",
        run.stderr.trim(),
        run.max_rss_kib,
        run.secs
    );
    assert_eq!(run.signal, None, "{what}");
    assert_eq!(run.code, Some(1), "{what}");
    assert!(run.stderr.contains(&*name), "the error does not name the file: {what}");
    for n in needles {
        assert!(run.stderr.contains(n), "the error lacks '{n}': {what}");
    }
    assert!(!run.stderr.contains("panicked"), "{what}");
    assert!(run.max_rss_kib < 1 << 20, "{what}");
    assert!(run.secs < 5.0, "{what}");
    eprintln!("{what}");
    run
}

fn tets(n: usize) -> Mesh {
    // points scattered by a hash (incompressible), tets over consecutive ones
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut r = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut m = Mesh::new((0..n).map(|_| [r(), r(), r()]).collect());
    for i in 0..n - 3 {
        m.push_element(
            ElementKind::Tetrahedron,
            &[i as u32, i as u32 + 1, i as u32 + 2, i as u32 + 3],
        );
    }
    m
}

/// A small ASCII .vtu with `extra` put at the start of its grid (FieldData).
pub fn vtu_with_field(extra: &str) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.vtu");
    io::write(&p, &tets(8), Format::VtuAscii, &[]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let at = text.find("<Piece").unwrap();
    format!("{}<FieldData>\n{extra}\n</FieldData>\n{}", &text[..at], &text[at..]).into_bytes()
}

/// (a) A string array and a number array declaring 256M entries, ASCII and
/// base64 (whose byte-count header says 2 GiB).
pub fn declared_256m() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let n = 1usize << 28;
    let strings =
        format!("<Array type=\"String\" Name=\"labels\" NumberOfTuples=\"{n}\" format=\"ascii\">97 0 98 0</Array>");
    let header = B64.encode((n as u32).to_le_bytes());
    let floats = format!(
        "<DataArray type=\"Float64\" Name=\"heat\" NumberOfTuples=\"{n}\" format=\"binary\">{header}{}</DataArray>",
        B64.encode([0u8; 24])
    );
    let ascii =
        format!("<DataArray type=\"Float64\" Name=\"heat\" NumberOfTuples=\"{n}\" format=\"ascii\">1 2 3</DataArray>");
    vec![
        ("strings256m.vtu", vtu_with_field(&strings), "labels"),
        ("floats256m.vtu", vtu_with_field(&floats), "heat"),
        ("ascii256m.vtu", vtu_with_field(&ascii), "heat"),
    ]
}

/// An xz stream header (no check) and block header (LZMA2, 4 KiB
/// dictionary), from Python's `lzma.compress(bytes(2 << 20),
/// format=FORMAT_XZ, check=CHECK_NONE, filters=[{"id": FILTER_LZMA2,
/// "preset": 0, "lc": 0, "lp": 0, "pb": 0}])`.
const XZ_HEAD: &str = "fd377a585a000000ff12d941020021010c0000008f98419c";

/// That stream's first LZMA2 chunk without its control byte: 2096914 zeros
/// in 346 bytes. With no position or literal context (lc = lp = pb = 0) and
/// its state reset, it decodes the same after any run of zeros, so repeated
/// it makes a bomb of any size.
const XZ_ZEROS: &str = concat!(
    "ff110159000000707dfdffae90a14013bd53369db418636ba1ee71f7e68d7b7d65f9d6317d20983008d0aa6374590fa5",
    "2bc9eadde279087cdea89a585521a4d174b2877e7146710823016d1357344f1e9fbeae7c311a9fb78d316e709ea7235f",
    "ec28cb85d195988a7e2a91f22775f719c006984d98fdd8afd5900fc42553f8f591363105a5b0ee6fc1704d470cd19111",
    "aaad601dbaceb127185c5986e9665258bee976ac59e4e55b0508f9c7daadfcfb522b74cd1e5b2042f9dd533df8296409",
    "3b80cb2a6cdfb53bf0c4bd2e5faa0f3e4b664290130eff1093f8717859f80bcdff9528460fa9fc7cdefb9a302e56c08f",
    "85f38381c065c42553f8f591363105a5b0ee6fc1704d470cd19111aaad601dbaceb127185c5986e9665258bee976ac59",
    "e4e55b0508f9c7daadfcfb522b74cd1e5b2042f9dd533df82964093b80cb2a6cdfb53bf0c4bd2e5faa0f3e4b66429013",
    "0eff1093f8717859f80bcde2783a1e",
);

/// Bytes of zeros one chunk inflates to.
pub const CHUNK_ZEROS: u64 = 2_096_914;

fn unhex(h: &str) -> Vec<u8> {
    (0..h.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&h[i..i + 2], 16).unwrap())
        .collect()
}

fn varint(mut x: u64, out: &mut Vec<u8>) {
    while x >= 0x80 {
        out.push(x as u8 | 0x80);
        x >>= 7;
    }
    out.push(x as u8);
}

/// A valid xz stream of `chunks` x [`CHUNK_ZEROS`] zeros (block, index and
/// footer as `xz` writes them, no check).
pub fn xz_zeros(chunks: usize) -> Vec<u8> {
    let mut out = unhex(XZ_HEAD);
    let block_start = 12;
    let body = unhex(XZ_ZEROS);
    for i in 0..chunks {
        // the first resets the dictionary, the others only the state
        out.push(if i == 0 { 0xff } else { 0xdf });
        out.extend_from_slice(&body);
    }
    out.push(0);
    let unpadded = (out.len() - block_start) as u64;
    while !(out.len() - block_start).is_multiple_of(4) {
        out.push(0);
    }
    let mut index = vec![0u8];
    varint(1, &mut index);
    varint(unpadded, &mut index);
    varint(chunks as u64 * CHUNK_ZEROS, &mut index);
    while index.len() % 4 != 0 {
        index.push(0);
    }
    let crc = |b: &[u8]| {
        let mut c = flate2::Crc::new();
        c.update(b);
        c.sum().to_le_bytes()
    };
    index.extend_from_slice(&crc(&index));
    let backward = (index.len() / 4 - 1) as u32;
    out.extend_from_slice(&index);
    let mut tail = backward.to_le_bytes().to_vec();
    tail.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&crc(&tail));
    out.extend_from_slice(&tail);
    out.extend_from_slice(b"YZ");
    out
}

/// (b) An appended raw .vtu whose FieldData array is one LZMA block that
/// inflates to `chunks` x 2 MB of zeros, its block header declaring
/// `declared` bytes (and the array `declared / 8` Float64 values).
pub fn lzma_bomb(chunks: usize, declared: u64) -> Vec<u8> {
    let xz = xz_zeros(chunks);
    let mut block = Vec::new();
    for w in [1u64, declared, declared, xz.len() as u64] {
        block.extend_from_slice(&w.to_le_bytes());
    }
    block.extend_from_slice(&xz);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.vtu");
    io::write(&p, &tets(8), Format::VtuAscii, &[]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let text = text.replacen(
        "<VTKFile ",
        "<VTKFile compressor=\"vtkLZMADataCompressor\" header_type=\"UInt64\" ",
        1,
    );
    let at = text.find("<Piece").unwrap();
    let end = text.rfind("</VTKFile>").unwrap();
    let mut out = format!(
        "{}<FieldData>\n<DataArray type=\"Float64\" Name=\"zeros\" NumberOfTuples=\"{}\" format=\"appended\" offset=\"0\"/>\n</FieldData>\n{}",
        &text[..at],
        declared.div_ceil(8),
        &text[at..end]
    )
    .into_bytes();
    out.extend_from_slice(b"<AppendedData encoding=\"raw\">\n_");
    out.extend_from_slice(&block);
    out.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    out
}

/// (c) A ~1 MB zlib .vtu (meshsmooth's own vtu-zlib) whose connectivity's
/// block header claims 1 GiB.
pub fn zlib_conn_1g() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("z.vtu");
    io::write(&p, &tets(40_000), Format::VtuZlib, &[]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let tag = text.find("Name=\"connectivity\"").unwrap();
    let start = tag + text[tag..].find('>').unwrap() + 1;
    let start = start + text[start..].find(|c: char| !c.is_whitespace()).unwrap();
    // the header is its own padded base64 run: [nblocks, blocksize, lastsize, sizes..]
    let run_end = start + text[start..].find('=').unwrap();
    let run_end = run_end + text[run_end..].find(|c| c != '=').unwrap();
    let mut header = B64.decode(&text[start..run_end]).unwrap();
    let nb = u64::from_le_bytes(header[..8].try_into().unwrap());
    let bs = (1u64 << 30).div_ceil(nb);
    header[8..16].copy_from_slice(&bs.to_le_bytes());
    header[16..24].copy_from_slice(&0u64.to_le_bytes());
    let out = format!("{}{}{}", &text[..start], B64.encode(&header), &text[run_end..]);
    assert!(out.len() > 500_000, "{} bytes", out.len());
    out.into_bytes()
}

/// Abaqus files that ask for more than they hold: a GENERATE range of
/// 10^15 node numbers, and a set naming a 1000-node set 200000 times
/// (800 MB of members from 0.6 MB of text).
pub fn abaqus_bombs() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let mut nodes = String::from("*NODE, NSET=A\n");
    for i in 1..=1000 {
        nodes.push_str(&format!("{i}, {i}., 0., 0.\n"));
    }
    let range = format!("{nodes}*NSET, NSET=R, GENERATE\n1, 1000000000000000, 1\n");
    let many = format!("{nodes}*NSET, NSET=B\n{}\n", "A, ".repeat(200_000));
    vec![
        ("generate.inp", range.into_bytes(), "covers 1000000000000000 nodes"),
        ("amplified.inp", many.into_bytes(), "set 'B'"),
    ]
}

#[test]
fn abaqus_ranges_and_set_references_past_the_budget_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, needle) in abaqus_bombs() {
        let p = dir.path().join(name);
        std::fs::write(&p, &bytes).unwrap();
        refused(&p, Some("256M"), &[needle, "line"]);
    }
}

/// Includes: a binary tree of 12 levels whose leaves are 2 MiB (8 GiB
/// read in all) ends at the budget; a chain 20 files deep at the depth
/// limit; a file that includes itself at once.
#[test]
fn abaqus_include_trees_chains_and_cycles_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let levels = 12;
    for k in 0..levels {
        let next = format!("tree{}.inp", k + 1);
        let body = format!("*INCLUDE, INPUT={next}\n*INCLUDE, INPUT={next}\n");
        std::fs::write(d.join(format!("tree{k}.inp")), body).unwrap();
    }
    let leaf = "** padding to make the leaf large\n".repeat((2 << 20) / 34);
    std::fs::write(d.join(format!("tree{levels}.inp")), leaf).unwrap();
    for k in 0..20 {
        std::fs::write(
            d.join(format!("chain{k}.inp")),
            format!("*INCLUDE, INPUT=chain{}.inp\n", k + 1),
        )
        .unwrap();
    }
    std::fs::write(d.join("chain20.inp"), "*NODE\n1, 0, 0, 0\n").unwrap();
    std::fs::write(d.join("self.inp"), "*NODE\n1, 0, 0, 0\n*INCLUDE, INPUT=./self.inp\n").unwrap();
    for (top, needles) in [
        ("tree0.inp", &["memory budget", "*INCLUDE of"][..]),
        ("chain0.inp", &["chain15.inp: line 1", "more than 16 files deep"][..]),
        ("self.inp", &["self.inp: line 3", "*INCLUDE cycle"][..]),
    ] {
        let p = d.join(top);
        let run = run_cli(
            &[
                "quality".as_ref(),
                p.as_os_str(),
                "--max-memory".as_ref(),
                "256M".as_ref(),
            ],
            Duration::from_secs(60),
        );
        let what = format!(
            "{top}: {} (rss {} KiB, {:.2} s)",
            run.stderr.trim(),
            run.max_rss_kib,
            run.secs
        );
        assert_eq!((run.code, run.signal), (Some(1), None), "{what}");
        for n in needles {
            assert!(run.stderr.contains(n), "the error lacks '{n}': {what}");
        }
        assert!(run.max_rss_kib < 1 << 20 && run.secs < 5.0, "{what}");
    }
}

#[test]
fn declared_sizes_past_the_data_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, array) in declared_256m() {
        let p = dir.path().join(name);
        std::fs::write(&p, &bytes).unwrap();
        refused(&p, None, &[array]);
    }
}

#[test]
fn the_lzma_chunk_repeats_into_zeros() {
    // the bomb's chunk is real: three of them decode to zeros
    let mut out = Vec::new();
    lzma_rs::xz_decompress(&mut std::io::Cursor::new(xz_zeros(3)), &mut out).unwrap();
    assert_eq!(out.len() as u64, 3 * CHUNK_ZEROS);
    assert!(out.iter().all(|&b| b == 0));
}

#[test]
fn lzma_bombs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let chunks = 1025; // 2.15 GB of zeros from 356 KB
    let p = dir.path().join("lzma_small_header.vtu");
    std::fs::write(&p, lzma_bomb(chunks, 1 << 20)).unwrap();
    refused(&p, None, &["zeros", "LZMA", "inflate"]);
    // a header as large as the bomb: the budget stops it
    let p = dir.path().join("lzma_huge_header.vtu");
    let bomb = lzma_bomb(chunks, chunks as u64 * CHUNK_ZEROS);
    std::fs::write(&p, &bomb).unwrap();
    refused(&p, Some("512M"), &["zeros", "memory budget", "--max-memory"]);
    let e = io::read_with_limits(&p, &ReadLimits { max_bytes: 256 << 20 })
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("lzma_huge_header.vtu") && e.contains("zeros") && e.contains("256.0 MiB"),
        "{e}"
    );
}

#[test]
fn a_zlib_header_claiming_a_gigabyte_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("zlib_1g.vtu");
    std::fs::write(&p, zlib_conn_1g()).unwrap();
    refused(&p, None, &["connectivity", "compression header"]);
}

#[cfg(target_os = "linux")]
#[test]
fn devices_and_pipes_are_read_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let z = dir.path().join("z.vtk");
    std::os::unix::fs::symlink("/dev/zero", &z).unwrap();
    refused(&z, None, &["not a mesh file"]);
    // a pipe of endless text: read until the budget is spent
    let fifo = dir.path().join("endless.vtk");
    crate::common::fifo(&fifo);
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut f = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
            let mut text = b"# vtk DataFile Version 3.0\nendless\nASCII\n".to_vec();
            text.resize(1 << 16, b'\n');
            let _ = f.write_all(&text);
            let line = [b' '; 1 << 16];
            while f.write_all(&line).is_ok() {}
        })
    };
    refused(&fifo, Some("64M"), &["the stream", "memory budget"]);
    writer.join().unwrap();
}

#[test]
fn max_memory_takes_sizes_and_refuses_others() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ok.vtu");
    let mut one = Mesh::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    one.push_element(ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    io::write(&p, &one, Format::VtuAscii, &[]).unwrap();
    for (size, ok) in [("4G", true), ("512M", true), ("100", false), ("lots", false)] {
        let run = run_cli(
            &[
                "quality".as_ref(),
                p.as_os_str(),
                "--max-memory".as_ref(),
                size.as_ref(),
            ],
            Duration::from_secs(60),
        );
        assert_eq!(run.code == Some(0), ok, "{size}: {}", run.stderr);
        if size == "lots" {
            assert!(run.stderr.contains("memory size"), "{}", run.stderr);
        }
        if size == "100" {
            assert!(
                run.stderr.contains("ok.vtu") && run.stderr.contains("memory budget"),
                "{}",
                run.stderr
            );
        }
    }
}

/// A large input truncated by another process while it is read: an error
/// naming the file (or a read of what was there), never a signal. Files
/// used to be memory-mapped, and a mapped file cut short ended the process
/// with SIGBUS.
#[cfg(unix)]
#[test]
fn an_input_truncated_while_it_is_read_is_an_error_not_a_signal() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.vtk");
    let n = 16_000_000;
    let mut text =
        format!("# vtk DataFile Version 3.0\nbig\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS {n} double\n").into_bytes();
    text.reserve(n * 6);
    for _ in 0..n {
        text.extend_from_slice(b"0 0 0\n");
    }
    let mut errors = 0;
    for delay_ms in [0u64, 5, 20, 60, 150] {
        std::fs::write(&p, &text).unwrap();
        let cutter = {
            let p = p.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(delay_ms));
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(&p)
                    .unwrap()
                    .set_len(4096)
                    .unwrap();
            })
        };
        let run = run_cli(&["quality".as_ref(), p.as_os_str()], Duration::from_secs(60));
        cutter.join().unwrap();
        let what = format!("cut after {delay_ms} ms: {:?} {}", run.code, run.stderr.trim());
        assert_eq!(run.signal, None, "{what}");
        assert_eq!(run.code, Some(1), "{what}");
        assert!(
            run.stderr.contains("big.vtk") && !run.stderr.contains("panicked"),
            "{what}"
        );
        errors += usize::from(run.stderr.contains("shrank") || run.stderr.contains("end of file"));
        eprintln!("{what}");
    }
    assert!(errors > 0, "no run saw the file cut short");
}

/// OpenFOAM cases with one file that asks for more than it holds:
/// 256M points declared in a few bytes (ASCII and binary), owners given as
/// a uniform list of 10^9 labels, a zone of 256M cells, and `faces.gz`
/// that inflates to 320 MiB (20 gzip members of 16 MiB of zeros each).
/// Each case is the hand-made box of `openfoam` with that file replaced.
/// Each case with its bomb file and what its error says.
pub fn openfoam_bombs(root: &Path) -> Vec<(std::path::PathBuf, std::path::PathBuf, &'static str)> {
    let header = |format: &str, class: &str, object: &str| {
        format!("FoamFile\n{{\n    format {format};\n    class {class};\n    object {object};\n}}\n")
    };
    let mut member = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    member.write_all(&vec![0u8; 16 << 20]).unwrap();
    let member = member.finish().unwrap();
    let files: Vec<(&str, &str, Vec<u8>, &str)> = vec![
        (
            "points-ascii",
            "points",
            format!("{}268435456\n(\n(0 0 0)\n)\n", header("ascii", "vectorField", "points")).into_bytes(),
            "268435456 declared",
        ),
        (
            "points-binary",
            "points",
            format!("{}268435456\n(\0\0\0\0)\n", header("binary", "vectorField", "points")).into_bytes(),
            "268435456 declared",
        ),
        (
            "owner-uniform",
            "owner",
            format!("{}1000000000{{0}}\n", header("ascii", "labelList", "owner")).into_bytes(),
            "memory budget",
        ),
        (
            "zone",
            "cellZones",
            format!(
                "{}1\n(\nz\n{{\n    type cellZone;\n    cellLabels List<label> 268435456(0 1);\n}}\n)\n",
                header("ascii", "regIOobject", "cellZones")
            )
            .into_bytes(),
            "268435456 declared",
        ),
        ("faces-gz", "faces.gz", member.repeat(20), "memory budget"),
    ];
    files
        .into_iter()
        .map(|(case, file, bytes, needle)| {
            let dir = root.join(case);
            crate::openfoam::hex_box(4, 1).write(&dir, crate::openfoam::STYLES[0]);
            let poly = dir.join("constant/polyMesh");
            if file == "faces.gz" {
                std::fs::remove_file(poly.join("faces")).unwrap();
            }
            std::fs::write(poly.join(file), bytes).unwrap();
            (dir, poly.join(file), needle)
        })
        .collect()
}

/// Each bomb refused naming it; its mutants (the bomb file cut short or a
/// byte changed) read through the CLI within the budget: `Ok` or an error,
/// never a signal, a panic or more than 1 GiB of RSS.
#[test]
fn openfoam_declared_sizes_and_gzip_bombs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut rand = crate::common::xorshift(0x2545_f491_4f6c_dd1du64);
    for (case, name, needle) in openfoam_bombs(dir.path()) {
        refused(&case, Some("256M"), &[needle]);
        let bytes = std::fs::read(&name).unwrap();
        for k in 0..6 {
            let mut b = bytes.clone();
            if k % 3 == 0 {
                b.truncate(rand() as usize % b.len());
            } else {
                let i = rand() as usize % b.len();
                b[i] = rand() as u8;
            }
            std::fs::write(&name, &b).unwrap();
            let args: [&OsStr; 4] = [
                "quality".as_ref(),
                case.as_os_str(),
                "--max-memory".as_ref(),
                "256M".as_ref(),
            ];
            let run = run_cli(&args, Duration::from_secs(60));
            let what = format!("{} mutant {k}: {:?} {}", name.display(), run.code, run.stderr.trim());
            assert_eq!(run.signal, None, "{what}");
            assert!(
                matches!(run.code, Some(0 | 1)) && !run.stderr.contains("panicked"),
                "{what}"
            );
            assert!(run.max_rss_kib < 1 << 20 && run.secs < 5.0, "{what}");
        }
    }
}
