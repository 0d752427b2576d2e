//! Writing a polyMesh: the input's faces, owners, neighbours, `boundary`
//! and zones with the new points where the mesh came from a polyMesh,
//! else faces built from the cells (see `build`).

use std::borrow::Cow;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::build;
use crate::error::{Error, Result};
use crate::io::{Staged, fmt_f64};
use crate::mesh::Mesh;
use crate::mesh::polymesh::{FoamStyle, PolyMesh};

/// The files this writer makes (each maybe with `.gz`); any other file of
/// the input's polyMesh is copied.
const OWN: [&str; 8] = [
    "points",
    "faces",
    "owner",
    "neighbour",
    "boundary",
    "cellZones",
    "faceZones",
    "pointZones",
];

/// Where a case goes: its folder and the `.foam` marker named, if any.
pub(super) struct Target {
    pub case: PathBuf,
    pub marker: Option<PathBuf>,
}

impl Target {
    /// `CASE`, `CASE/x.foam` or `CASE/constant/polyMesh`.
    pub fn of(path: &Path) -> Target {
        if super::is_marker(path) {
            let case = match path.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            return Target {
                case,
                marker: Some(path.to_path_buf()),
            };
        }
        if path.ends_with("constant/polyMesh")
            && let Some(case) = path.parent().and_then(Path::parent)
        {
            let case = if case.as_os_str().is_empty() {
                Path::new(".")
            } else {
                case
            };
            return Target {
                case: case.to_path_buf(),
                marker: None,
            };
        }
        Target {
            case: path.to_path_buf(),
            marker: None,
        }
    }

    pub fn polymesh(&self) -> PathBuf {
        self.case.join("constant").join("polyMesh")
    }
}

/// The stored topology where it still fits the mesh (same cells, points
/// and boundary cells), else `None`.
fn stored(mesh: &Mesh) -> Option<&PolyMesh> {
    let p = mesh.data.polymesh.as_deref()?;
    let np = mesh.num_points() as u32;
    let lower = p.lower.last().map_or(0, |r| r.end);
    (p.num_cells() == mesh.num_elements()
        && lower == mesh.lower.len()
        && p.face_points.iter().all(|&v| v < np)
        && p.owner.len() == p.num_faces())
    .then_some(p)
}

/// Stages `mesh` as the polyMesh of the case `path` names (see [`Target`]).
pub(crate) fn stage(path: &Path, mesh: &Mesh, binary: bool) -> Result<Staged> {
    if mesh.dim() != 3 {
        return Err(Error::InvalidArgument(format!(
            "cannot write {}: an OpenFOAM polyMesh is three-dimensional, and this mesh is planar",
            path.display()
        )));
    }
    let target = Target::of(path);
    let dest = target.polymesh();
    if let Some(src) = mesh.data.polymesh.as_ref().and_then(|p| p.source.as_ref())
        && super::same_dir(&dest, src)
    {
        return Err(Error::InvalidArgument(format!(
            "cannot write {}: it is the case the mesh was read from ({}); meshsmooth never overwrites \
             its input: give the output a case folder of its own",
            path.display(),
            src.display()
        )));
    }
    let (poly, style): (Cow<PolyMesh>, FoamStyle) = match stored(mesh) {
        Some(p) => {
            let style = FoamStyle {
                binary,
                // OpenFOAM writes binary faces compact
                compact_faces: binary || p.style.compact_faces,
                ..p.style
            };
            (Cow::Borrowed(p), style)
        }
        None => {
            let style = FoamStyle {
                binary,
                compact_faces: binary,
                ..Default::default()
            };
            (Cow::Owned(build::build(mesh)?), style)
        }
    };
    let from_input = matches!(poly, Cow::Borrowed(_));
    let source = from_input.then(|| poly.source.clone()).flatten();
    // the deepest folder of the case that exists is where the new one goes
    let constant = target.case.join("constant");
    let (dir, inner) = if constant.is_dir() {
        (dest.clone(), PathBuf::new())
    } else if target.case.is_dir() {
        (constant, PathBuf::from("polyMesh"))
    } else {
        (target.case.clone(), Path::new("constant").join("polyMesh"))
    };
    let keep: Vec<String> = OWN.iter().flat_map(|n| [n.to_string(), format!("{n}.gz")]).collect();
    let keep: Vec<&str> = keep.iter().map(String::as_str).collect();
    let keep: &[&str] = if inner.as_os_str().is_empty() { &keep } else { &[] };
    crate::io::atomic::stage_dir(path, &dir, keep, target.marker.clone(), |tmp| {
        let out = tmp.join(&inner);
        fs::create_dir_all(&out).map_err(|e| Error::io(path, e))?;
        write_files(&out, mesh, &poly, style, from_input).map_err(|(at, e)| Error::io(at, e))?;
        if let Some(src) = &source {
            copy_extras(src, &out).map_err(|(at, e)| Error::io(at, e))?;
        }
        Ok(())
    })
}

/// An OS error and the file it happened to.
type Failure = (PathBuf, std::io::Error);

/// Writes one file `name` (`.gz` where `gz`) in `dir`, synced to the disk.
fn put(
    dir: &Path,
    name: &str,
    gz: bool,
    body: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::result::Result<(), Failure> {
    let path = dir.join(if gz { format!("{name}.gz") } else { name.to_string() });
    let fail = |e| (path.clone(), e);
    let file = fs::File::create(&path).map_err(fail)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, &file);
    if gz {
        let mut z = flate2::write::GzEncoder::new(&mut w, flate2::Compression::default());
        body(&mut z).map_err(fail)?;
        z.finish().map_err(fail)?;
    } else {
        body(&mut w).map_err(fail)?;
    }
    w.flush().map_err(fail)?;
    drop(w);
    file.sync_all().map_err(fail)
}

fn header(w: &mut dyn Write, style: FoamStyle, class: &str, object: &str, note: Option<&str>) -> std::io::Result<()> {
    writeln!(
        w,
        "/*--------------------------------*- C++ -*----------------------------------*\\\n\
         | Written by meshsmooth                                                       |\n\
         \\*---------------------------------------------------------------------------*/\n\
         FoamFile\n{{\n    version     2.0;\n    format      {};",
        if style.binary { "binary" } else { "ascii" }
    )?;
    writeln!(
        w,
        "    arch        \"LSB;label={};scalar={}\";",
        if style.label64 { 64 } else { 32 },
        if style.scalar32 { 32 } else { 64 }
    )?;
    if let Some(note) = note {
        writeln!(w, "    note        \"{note}\";")?;
    }
    writeln!(
        w,
        "    class       {class};\n    location    \"constant/polyMesh\";\n    object      {object};\n}}\n\
         // * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //\n"
    )
}

fn labels(w: &mut dyn Write, style: FoamStyle, ls: impl ExactSizeIterator<Item = u64>) -> std::io::Result<()> {
    write!(w, "{}\n(", ls.len())?;
    if style.binary {
        let mut buf = Vec::with_capacity(ls.len() * 8);
        for l in ls {
            if style.label64 {
                buf.extend_from_slice(&l.to_le_bytes());
            } else {
                buf.extend_from_slice(&(l as u32).to_le_bytes());
            }
        }
        w.write_all(&buf)?;
        return writeln!(w, ")");
    }
    writeln!(w)?;
    for l in ls {
        writeln!(w, "{l}")?;
    }
    writeln!(w, ")")
}

fn write_files(
    dir: &Path,
    mesh: &Mesh,
    poly: &PolyMesh,
    style: FoamStyle,
    from_input: bool,
) -> std::result::Result<(), Failure> {
    let gz = style.compressed;
    put(dir, "points", gz, |w| {
        header(w, style, "vectorField", "points", None)?;
        write!(w, "{}\n(", mesh.num_points())?;
        if style.binary {
            let mut buf = Vec::with_capacity(mesh.num_points() * 24);
            for p in mesh.points.iter().flatten() {
                if style.scalar32 {
                    buf.extend_from_slice(&(*p as f32).to_le_bytes());
                } else {
                    buf.extend_from_slice(&p.to_le_bytes());
                }
            }
            w.write_all(&buf)?;
        } else {
            writeln!(w)?;
            for p in &mesh.points {
                writeln!(w, "({} {} {})", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
            }
        }
        writeln!(w, ")")
    })?;
    let nf = poly.num_faces();
    put(dir, "faces", gz, |w| {
        if style.compact_faces {
            header(w, style, "faceCompactList", "faces", None)?;
            labels(w, style, poly.face_offsets.iter().map(|&o| o as u64))?;
            writeln!(w)?;
            labels(w, style, poly.face_points.iter().map(|&v| u64::from(v)))
        } else {
            header(w, style, "faceList", "faces", None)?;
            writeln!(w, "{nf}\n(")?;
            for f in 0..nf {
                let face = poly.face(f);
                write!(w, "{}(", face.len())?;
                for (i, v) in face.iter().enumerate() {
                    write!(w, "{}{v}", if i > 0 { " " } else { "" })?;
                }
                writeln!(w, ")")?;
            }
            writeln!(w, ")")
        }
    })?;
    let note = format!(
        "nPoints:{} nCells:{} nFaces:{nf} nInternalFaces:{}",
        mesh.num_points(),
        mesh.num_elements(),
        poly.neighbour.len()
    );
    put(dir, "owner", gz, |w| {
        header(w, style, "labelList", "owner", Some(&note))?;
        labels(w, style, poly.owner.iter().map(|&c| u64::from(c)))
    })?;
    put(dir, "neighbour", gz, |w| {
        header(w, style, "labelList", "neighbour", Some(&note))?;
        labels(w, style, poly.neighbour.iter().map(|&c| u64::from(c)))
    })?;
    if from_input {
        for f in &poly.files {
            put(dir, &f.name, f.compressed, |w| w.write_all(&f.bytes))?;
        }
        return Ok(());
    }
    let ascii = FoamStyle { binary: false, ..style };
    put(dir, "boundary", gz, |w| {
        header(w, ascii, "polyBoundaryMesh", "boundary", None)?;
        writeln!(w, "{}\n(", poly.patches.len())?;
        for p in &poly.patches {
            writeln!(
                w,
                "    {}\n    {{\n        type            {};\n        nFaces          {};\n        startFace       {};\n    }}",
                p.name, p.kind, p.faces, p.start
            )?;
        }
        writeln!(w, ")")
    })?;
    zones(dir, mesh, ascii)
}

/// A mesh's element sets as `cellZones`, its node sets as `pointZones`.
fn zones(dir: &Path, mesh: &Mesh, style: FoamStyle) -> std::result::Result<(), Failure> {
    let cells: Vec<(&str, &[u32])> = mesh
        .data
        .element_sets
        .iter()
        .filter(|s| !s.elements.is_empty())
        .map(|s| (s.name.as_str(), &s.elements[..]))
        .collect();
    let points: Vec<(&str, &[u32])> = mesh
        .data
        .node_sets
        .iter()
        .map(|s| (s.name.as_str(), &s.vertices[..]))
        .collect();
    for (file, kind, key, sets) in [
        ("cellZones", "cellZone", "cellLabels", cells),
        ("pointZones", "pointZone", "pointLabels", points),
    ] {
        if sets.is_empty() {
            continue;
        }
        put(dir, file, style.compressed, |w| {
            header(w, style, "regIOobject", file, None)?;
            writeln!(w, "{}\n(", sets.len())?;
            for (name, ids) in &sets {
                writeln!(w, "{name}\n{{\n    type {kind};\n    {key} List<label> ")?;
                labels(w, style, ids.iter().map(|&i| u64::from(i)))?;
                writeln!(w, ";\n}}")?;
            }
            writeln!(w, ")")
        })?;
    }
    Ok(())
}

/// The input polyMesh's files this writer does not make (`sets/`,
/// `cellLevel`, ...), copied as they are: regular files, and the regular
/// files of its folders.
fn copy_extras(src: &Path, out: &Path) -> std::result::Result<(), (PathBuf, std::io::Error)> {
    let Ok(entries) = fs::read_dir(src) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let plain = name.to_string_lossy();
        let plain = plain.strip_suffix(".gz").unwrap_or(&plain);
        if OWN.contains(&plain) {
            continue;
        }
        let Ok(kind) = entry.file_type() else { continue };
        let to = out.join(&name);
        if kind.is_file() {
            fs::copy(entry.path(), &to).map_err(|e| (to.clone(), e))?;
        } else if kind.is_dir() {
            fs::create_dir(&to).map_err(|e| (to.clone(), e))?;
            for inner in fs::read_dir(entry.path()).map_err(|e| (entry.path(), e))?.flatten() {
                if inner.file_type().is_ok_and(|t| t.is_file()) {
                    let to = to.join(inner.file_name());
                    fs::copy(inner.path(), &to).map_err(|e| (to.clone(), e))?;
                }
            }
        }
    }
    Ok(())
}
