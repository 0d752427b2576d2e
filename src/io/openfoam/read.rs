//! Reading a polyMesh: `points`, `faces`, `owner`, `neighbour`,
//! `boundary` and the zone files, each possibly gzip-compressed.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::foamfile::{DictEntry, Lexer, What};
use crate::error::{Error, Location, Result};
use crate::io::limits::Budget;
use crate::mesh::data::{DataArray, ElementSet, GMSH_PHYSICAL, NodeSet, PhysicalName, ValueType, Values};
use crate::mesh::polymesh::{FoamFileCopy, FoamStyle, Patch, PolyMesh};
use crate::mesh::{LowerKind, Mesh};

/// A polyMesh file's path (`name`, else `name.gz`) and whether it is
/// compressed; `None` when neither exists.
pub(super) fn find(dir: &Path, name: &str) -> Option<(PathBuf, bool)> {
    let plain = dir.join(name);
    if plain.exists() {
        return Some((plain, false));
    }
    let gz = dir.join(format!("{name}.gz"));
    gz.exists().then_some((gz, true))
}

/// A file's bytes, decompressed, within the budget.
fn load(path: &Path, gz: bool, budget: &Budget) -> Result<Vec<u8>> {
    let data = crate::io::input::read_file(path, budget)?;
    if !gz {
        return Ok(data);
    }
    let name = path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
    let left = budget.left();
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(&data[..])
        .take(left.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| Error::parse(path, None, format!("cannot decompress the file: {e}")))?;
    let what = format_args!("{name} decompressed");
    if out.len() as u64 > left {
        return Err(budget.over(what, out.len() as u64));
    }
    budget.release(data.len() as u64);
    budget.charge(what, out.len() as u64)?;
    Ok(out)
}

/// A required file of the polyMesh.
fn required(dir: &Path, name: &str, budget: &Budget) -> Result<(PathBuf, bool, Vec<u8>)> {
    let (path, gz) = find(dir, name).ok_or_else(|| {
        Error::parse(
            dir,
            None,
            format!("the polyMesh has no '{name}' file (nor '{name}.gz')"),
        )
    })?;
    let data = load(&path, gz, budget)?;
    Ok((path, gz, data))
}

/// The polyMesh in `dir` as a mesh: its cells as elements (in cell
/// order), its boundary faces as lower cells tagged by patch, its zones
/// as sets, and the face topology kept for a write back.
pub(crate) fn read(dir: &Path, budget: &Budget) -> Result<Mesh> {
    let mut style = FoamStyle::default();
    let (points_path, gz, data) = required(dir, "points", budget)?;
    let points = {
        let mut lx = Lexer::new(&points_path, &data, budget)?;
        style.binary = lx.header.binary;
        style.compressed = gz;
        style.label64 = lx.header.label == 8;
        style.scalar32 = lx.header.scalar == 4;
        let p = lx.points()?;
        lx.end()?;
        p
    };
    drop(data);
    if points.is_empty() {
        return Err(Error::parse(&points_path, None, "the file has no points"));
    }
    let np = points.len();
    let (faces_path, _, data) = required(dir, "faces", budget)?;
    let (face_offsets, face_points) = {
        let mut lx = Lexer::new(&faces_path, &data, budget)?;
        style.compact_faces = lx.header.class == "faceCompactList";
        let faces = if style.compact_faces {
            lx.face_compact_list(np)?
        } else {
            lx.face_list(np)?
        };
        lx.end()?;
        faces
    };
    drop(data);
    let nf = face_offsets.len() - 1;
    for f in 0..nf {
        let face = &face_points[face_offsets[f]..face_offsets[f + 1]];
        if face.len() < 3 {
            return Err(Error::parse(
                &faces_path,
                None,
                format!("face {f} has {} points; a face needs at least 3", face.len()),
            ));
        }
        if let Some((i, v)) = face.iter().enumerate().find(|&(i, v)| face[..i].contains(v)) {
            return Err(Error::parse(
                &faces_path,
                None,
                format!("face {f} has point {v} twice (again at its entry {i})"),
            ));
        }
    }
    let owner = label_file(dir, "owner", budget, false)?;
    let (owner_path, owner) = owner;
    if owner.len() != nf {
        return Err(Error::parse(
            &owner_path,
            None,
            format!(
                "owner has {} entries but faces has {nf} faces: one owner per face",
                owner.len()
            ),
        ));
    }
    // a cell has 4 faces or more, a face 2 cells at most
    let max_cells = nf / 2;
    if let Some(f) = owner.iter().position(|&c| c as usize >= max_cells) {
        return Err(Error::parse(
            &owner_path,
            None,
            format!(
                "owner {f} is cell {}, but {nf} faces close at most {max_cells} cells",
                owner[f]
            ),
        ));
    }
    let (neighbour_path, mut neighbour) = label_file(dir, "neighbour", budget, true)?;
    // the old format lists every face, -1 for the boundary ones
    if neighbour.len() == nf
        && let Some(first) = neighbour.iter().position(|&c| c == u32::MAX)
    {
        neighbour.truncate(first);
    }
    if let Some(f) = neighbour.iter().position(|&c| c == u32::MAX) {
        return Err(Error::parse(
            &neighbour_path,
            None,
            format!("neighbour {f} is -1 before the last internal face"),
        ));
    }
    if neighbour.len() > nf {
        return Err(Error::parse(
            &neighbour_path,
            None,
            format!(
                "neighbour has {} entries but faces has only {nf} faces",
                neighbour.len()
            ),
        ));
    }
    if let Some(f) = neighbour.iter().position(|&c| c as usize >= max_cells) {
        return Err(Error::parse(
            &neighbour_path,
            None,
            format!(
                "neighbour {f} is cell {}, but {nf} faces close at most {max_cells} cells",
                neighbour[f]
            ),
        ));
    }
    if let Some(f) = (0..neighbour.len()).find(|&f| neighbour[f] == owner[f]) {
        return Err(Error::parse(
            &neighbour_path,
            None,
            format!("internal face {f} has cell {} on both sides", owner[f]),
        ));
    }
    let mut poly = PolyMesh {
        face_offsets,
        face_points,
        owner,
        neighbour,
        style,
        ..Default::default()
    };
    let (boundary, patches) = boundary(dir, &poly, budget)?;
    poly.patches = patches;
    poly.files.extend(boundary);
    let mut mesh = Mesh::new(points);
    super::cells::push_cells(dir, &poly, &mut mesh)?;
    boundary_cells(&mut poly, &mut mesh);
    zones(dir, &mut poly, &mut mesh, budget)?;
    poly.source = dir.canonicalize().ok();
    mesh.data.polymesh = Some(Arc::new(poly));
    Ok(mesh)
}

/// `owner` or `neighbour`: a label list (`minus_one`: -1 allowed, as `u32::MAX`).
fn label_file(dir: &Path, name: &str, budget: &Budget, minus_one: bool) -> Result<(PathBuf, Vec<u32>)> {
    let (path, _, data) = required(dir, name, budget)?;
    let mut lx = Lexer::new(&path, &data, budget)?;
    let labels = lx.labels(What::list(name), u32::MAX as usize, minus_one)?;
    lx.end()?;
    Ok((path, labels))
}

/// The patches of `boundary`, checked to cover the boundary faces in turn;
/// the file kept as it is.
fn boundary(dir: &Path, poly: &PolyMesh, budget: &Budget) -> Result<(Option<FoamFileCopy>, Vec<Patch>)> {
    let nf = poly.num_faces();
    let internal = poly.neighbour.len();
    let Some((path, gz)) = find(dir, "boundary") else {
        if internal == nf {
            return Ok((None, Vec::new()));
        }
        return Err(Error::parse(
            dir,
            None,
            format!(
                "the polyMesh has {} boundary faces but no 'boundary' file to say their patches",
                nf - internal
            ),
        ));
    };
    let data = load(&path, gz, budget)?;
    let mut lx = Lexer::new(&path, &data, budget)?;
    let entries = lx.dict_list(None, 0)?;
    lx.end()?;
    let at = |e: &DictEntry, msg: String| Error::parse(&path, Some(Location::Line(e.line)), msg);
    let mut next = internal;
    let mut patches = Vec::with_capacity(entries.len());
    for e in &entries {
        let number = |key: &str| -> Result<usize> {
            let v = e
                .get(key)
                .ok_or_else(|| at(e, format!("patch '{}' has no {key}", e.name)))?;
            v.parse()
                .map_err(|_| at(e, format!("patch '{}': {key} '{}' is not a count", e.name, v)))
        };
        let (start, count) = (number("startFace")?, number("nFaces")?);
        if start != next {
            return Err(at(
                e,
                format!(
                    "patch '{}' starts at face {start}, but its faces must follow the {} before it \
                     (from face {next}: internal faces first, then each patch's in turn)",
                    e.name, next
                ),
            ));
        }
        next = start.saturating_add(count);
        if next > nf {
            return Err(at(
                e,
                format!("patch '{}' ends at face {next}, past the {nf} faces", e.name),
            ));
        }
        patches.push(Patch {
            name: e.name.to_string(),
            kind: e.get("type").unwrap_or("patch").to_string(),
            start,
            faces: count,
        });
    }
    if next != nf {
        return Err(Error::parse(
            &path,
            None,
            format!("the patches cover faces up to {next}, but the mesh has {nf}: faces {next} on are in no patch"),
        ));
    }
    drop(lx);
    let copy = FoamFileCopy {
        name: "boundary".into(),
        compressed: gz,
        bytes: data,
    };
    Ok((Some(copy), patches))
}

/// The boundary faces as lower cells (a polygon as a fan of triangles),
/// their vertices fixed, tagged by patch through the `gmsh:physical`
/// arrays and physical names, so that a patch is a group for
/// `--fix-group` and `--free-group`.
fn boundary_cells(poly: &mut PolyMesh, mesh: &mut Mesh) {
    let mut tags = Vec::new();
    let mut fixed = vec![false; mesh.num_points()];
    let mut ranges = Vec::with_capacity(poly.patches.len());
    for (p, patch) in poly.patches.iter().enumerate() {
        let from = mesh.lower.len();
        for f in patch.start..patch.start + patch.faces {
            let face = poly.face(f);
            face.iter().for_each(|&v| fixed[v as usize] = true);
            match face.len() {
                3 => mesh.lower.push((LowerKind::Triangle, face.to_vec())),
                4 => mesh.lower.push((LowerKind::Quadrilateral, face.to_vec())),
                k => {
                    for i in 1..k - 1 {
                        mesh.lower
                            .push((LowerKind::Triangle, vec![face[0], face[i], face[i + 1]]));
                    }
                }
            }
        }
        tags.resize(mesh.lower.len(), p as i64 + 1);
        ranges.push(from..mesh.lower.len());
        mesh.data.physical_names.push(PhysicalName {
            dim: 2,
            tag: p as i32 + 1,
            name: patch.name.clone(),
        });
    }
    poly.lower = ranges;
    if !mesh.lower.is_empty() {
        let cells = vec![0; mesh.num_elements()];
        mesh.data.cell = vec![DataArray::new(GMSH_PHYSICAL, ValueType::I32, 1, Values::Int(cells))];
        mesh.data.lower = vec![DataArray::new(GMSH_PHYSICAL, ValueType::I32, 1, Values::Int(tags))];
    }
    if fixed.iter().any(|&f| f) {
        mesh.fixed = fixed;
    }
}

/// `cellZones` as element sets, `pointZones` as node sets, `faceZones` as
/// node sets of their faces' points; each file kept as it is.
fn zones(dir: &Path, poly: &mut PolyMesh, mesh: &mut Mesh, budget: &Budget) -> Result<()> {
    let limits = [mesh.num_elements(), poly.num_faces(), mesh.num_points()];
    for (kind, (name, key)) in [
        ("cellZones", "cellLabels"),
        ("faceZones", "faceLabels"),
        ("pointZones", "pointLabels"),
    ]
    .into_iter()
    .enumerate()
    {
        let Some((path, gz)) = find(dir, name) else {
            continue;
        };
        let data = load(&path, gz, budget)?;
        let mut lx = Lexer::new(&path, &data, budget)?;
        let entries = lx.dict_list(Some(key), limits[kind])?;
        lx.end()?;
        for e in entries {
            let mut ids = e.labels.unwrap_or_default();
            if kind == 1 {
                ids = ids.iter().flat_map(|&f| poly.face(f as usize)).copied().collect();
            }
            ids.sort_unstable();
            ids.dedup();
            if kind == 0 {
                mesh.data.element_sets.push(ElementSet {
                    name: e.name.to_string(),
                    elements: ids,
                    lower: Vec::new(),
                });
            } else {
                mesh.data.node_sets.push(NodeSet {
                    name: e.name.to_string(),
                    vertices: ids,
                });
            }
        }
        drop(lx);
        poly.files.push(FoamFileCopy {
            name: name.into(),
            compressed: gz,
            bytes: data,
        });
    }
    Ok(())
}
