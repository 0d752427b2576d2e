//! STL (`.stl`), ASCII and binary: triangles only.
//!
//! STL stores every facet with its own three corners, so vertices are
//! merged on reading by exact coordinate equality (`-0.0` and `0.0` are one
//! vertex). Each ASCII `solid NAME` becomes an element set of that name;
//! binary files have no solids, and their per-facet attribute bytes are
//! ignored. Facet normals are not read (they follow from the corners).
//! Writing refuses any element that is not a triangle, naming it, rather
//! than splitting quadrilaterals: a split would change the mesh being
//! smoothed without the user asking. Lower cells are not written.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use super::limits::Budget;
use super::{RawMesh, Shape, WriteResult};
use crate::error::{Error, Location, Result};
use crate::mesh::{ElementKind, Mesh};

/// Whether `data` is a binary STL: its facet count matches its size
/// exactly (an ASCII file starting `solid` almost never does).
pub(crate) fn is_binary(data: &[u8]) -> bool {
    if data.len() < 84 {
        return false;
    }
    let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
    n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(data.len() as u64)
}

/// Merges equal corners into one vertex.
struct Merger {
    ids: HashMap<[u64; 3], u32>,
}

impl Merger {
    fn id(&mut self, raw: &mut RawMesh, p: [f64; 3]) -> std::result::Result<u32, String> {
        if p.iter().any(|x| !x.is_finite()) {
            return Err(format!("a corner has a non-finite coordinate {p:?}"));
        }
        // + 0.0 turns -0.0 into 0.0, which compare equal
        let key = p.map(|x| (x + 0.0).to_bits());
        let next = raw.points.len();
        let id = *self.ids.entry(key).or_insert(next as u32);
        if id as usize == next {
            raw.points.push(p);
        }
        Ok(id)
    }
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    if is_binary(data) {
        read_binary(path, data, budget)
    } else {
        read_ascii(path, data, budget)
    }
}

fn read_binary(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let n = (data.len() - 84) / 50;
    // points, connectivity and the merge table: bounded by the file's own size
    budget.charge("the STL facets", (n as u64).saturating_mul(3 * (24 + 4 + 40)))?;
    let mut raw = RawMesh::default();
    let mut m = Merger {
        ids: HashMap::with_capacity(n.min(1 << 20)),
    };
    raw.points.reserve(n.min(1 << 20));
    let mut ids = Vec::with_capacity(3 * n);
    for f in 0..n {
        let rec = &data[84 + 50 * f..84 + 50 * f + 50];
        for c in 0..3 {
            let at = 12 + 12 * c;
            let x = |k: usize| {
                let b = &rec[at + 4 * k..at + 4 * k + 4];
                f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            };
            let id = m.id(&mut raw, [x(0), x(1), x(2)]).map_err(|e| {
                Error::parse(
                    path,
                    Some(Location::Byte((84 + 50 * f) as u64)),
                    format!("facet {f}: {e}"),
                )
            })?;
            ids.push(id);
        }
    }
    raw.push_block(Shape::Elem(ElementKind::Triangle), 3, ids);
    Ok(raw)
}

fn read_ascii(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let text = std::str::from_utf8(data).map_err(|e| {
        // a file that is neither says why it is not binary either, since a
        // truncated or padded binary STL is the usual cause
        let binary = if data.len() < 84 {
            format!("only {} bytes, shorter than a binary STL's 84-byte header", data.len())
        } else {
            let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
            format!(
                "its binary facet count {n} needs {} bytes but the file has {}",
                84 + 50 * n,
                data.len()
            )
        };
        Error::parse(
            path,
            Some(Location::Byte(e.valid_up_to() as u64)),
            format!("neither an ASCII STL (this byte is not text) nor a binary STL ({binary})"),
        )
    })?;
    // points, connectivity and merge table: at most one corner per 12 bytes of text
    budget.charge("the STL facets", (data.len() as u64 / 12).saturating_mul(24 + 4 + 40))?;
    let mut raw = RawMesh::default();
    let mut m = Merger { ids: HashMap::new() };
    let err = |line: usize, msg: String| Error::parse(path, Some(Location::Line(line)), msg);
    let mut solid: Option<(String, Vec<u32>)> = None;
    let mut corners: Vec<u32> = Vec::with_capacity(3);
    let mut in_loop = false;
    let mut last_line = 0;
    for (i, line) in text.lines().enumerate() {
        let ln = i + 1;
        last_line = ln;
        let mut t = line.split_ascii_whitespace();
        let Some(kw) = t.next() else { continue };
        match kw.to_ascii_lowercase().as_str() {
            "solid" => {
                if solid.is_some() {
                    return Err(err(ln, "'solid' inside a solid: missing 'endsolid'".into()));
                }
                let name = line.trim_start()[5..].trim().to_string();
                solid = Some((name, Vec::new()));
            }
            "endsolid" => {
                let Some((name, cells)) = solid.take() else {
                    return Err(err(ln, "'endsolid' without 'solid'".into()));
                };
                if in_loop {
                    return Err(err(ln, "'endsolid' inside a facet".into()));
                }
                if !name.is_empty() {
                    raw.cell_sets.push((name, cells));
                }
            }
            "facet" => {
                if solid.is_none() {
                    return Err(err(ln, "'facet' outside a solid".into()));
                }
                // the normal is recomputed from the corners when needed
            }
            "outer" => {
                if solid.is_none() || in_loop {
                    return Err(err(ln, "'outer loop' outside a facet or inside another loop".into()));
                }
                in_loop = true;
                corners.clear();
            }
            "vertex" => {
                if !in_loop {
                    return Err(err(ln, "'vertex' outside an 'outer loop'".into()));
                }
                let mut p = [0.0; 3];
                for x in &mut p {
                    let tok = t
                        .next()
                        .ok_or_else(|| err(ln, "a vertex needs three coordinates".into()))?;
                    *x = tok
                        .parse()
                        .map_err(|_| err(ln, format!("expected a coordinate, found '{}'", super::lex::clip(tok))))?;
                }
                if corners.len() == 3 {
                    return Err(err(
                        ln,
                        "a facet with more than 3 vertices: STL facets are triangles".into(),
                    ));
                }
                corners.push(m.id(&mut raw, p).map_err(|e| err(ln, e))?);
            }
            "endloop" => {
                if !in_loop || corners.len() != 3 {
                    return Err(err(
                        ln,
                        format!("'endloop' after {} vertices: a facet needs exactly 3", corners.len()),
                    ));
                }
                in_loop = false;
                if let Some((_, cells)) = solid.as_mut() {
                    cells.push(raw.shapes.len() as u32);
                }
                raw.push(Shape::Elem(ElementKind::Triangle), &corners);
            }
            "endfacet" => {
                if in_loop {
                    return Err(err(ln, "'endfacet' before 'endloop'".into()));
                }
            }
            _ => {
                return Err(err(
                    ln,
                    format!(
                        "expected an STL keyword (solid, facet, vertex, ...), found '{}'",
                        super::lex::clip(kw)
                    ),
                ));
            }
        }
    }
    if solid.is_some() || in_loop {
        return Err(Error::parse(
            path,
            Some(Location::Line(last_line)),
            "unexpected end of file inside a solid: missing 'endsolid'",
        ));
    }
    Ok(raw)
}

/// The first element that is not a triangle, for the writer's refusal.
pub(crate) fn non_triangle(mesh: &Mesh) -> Option<(usize, ElementKind)> {
    mesh.kinds
        .iter()
        .position(|&k| k != ElementKind::Triangle)
        .map(|e| (e, mesh.kinds[e]))
}

/// Element sets that hold every element exactly once: written as one
/// ASCII solid each, so a file's solids read back as they were.
fn solids(mesh: &Mesh) -> Option<Vec<(&str, &[u32])>> {
    let sets = &mesh.data.element_sets;
    if sets.is_empty() {
        return None;
    }
    let mut seen = vec![false; mesh.num_elements()];
    for s in sets {
        for &e in &s.elements {
            let slot = seen.get_mut(e as usize)?;
            if *slot {
                return None;
            }
            *slot = true;
        }
    }
    seen.iter()
        .all(|&s| s)
        .then(|| sets.iter().map(|s| (s.name.as_str(), &s.elements[..])).collect())
}

fn normal(mesh: &Mesh, vs: &[u32]) -> [f32; 3] {
    let p = |i: usize| mesh.points[vs[i] as usize];
    let (a, b, c) = (p(0), p(1), p(2));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 {
        n.map(|x| (x / len) as f32)
    } else {
        [0.0; 3]
    }
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, binary: bool) -> WriteResult {
    if binary {
        let mut head = [b' '; 80];
        // a binary header must not start with "solid", or readers take it for ASCII
        let title = b"binary STL written by meshsmooth";
        head[..title.len()].copy_from_slice(title);
        w.write_all(&head)?;
        w.write_all(&(mesh.num_elements() as u32).to_le_bytes())?;
        let mut rec = [0u8; 50];
        for e in 0..mesh.num_elements() {
            let vs = mesh.element(e);
            let n = normal(mesh, vs);
            let vals = n
                .into_iter()
                .chain(vs.iter().flat_map(|&v| mesh.points[v as usize].map(|x| x as f32)));
            for (k, x) in vals.enumerate() {
                rec[4 * k..4 * k + 4].copy_from_slice(&x.to_le_bytes());
            }
            w.write_all(&rec)?;
        }
        return Ok(());
    }
    let all: Vec<u32> = (0..mesh.num_elements() as u32).collect();
    let groups = solids(mesh).unwrap_or_else(|| vec![("meshsmooth", &all[..])]);
    for (name, els) in groups {
        writeln!(w, "solid {name}")?;
        for &e in els {
            let vs = mesh.element(e as usize);
            let n = normal(mesh, vs);
            writeln!(w, "  facet normal {:e} {:e} {:e}\n    outer loop", n[0], n[1], n[2])?;
            for &v in vs {
                let p = mesh.points[v as usize];
                writeln!(
                    w,
                    "      vertex {} {} {}",
                    super::fmt_f64(p[0]),
                    super::fmt_f64(p[1]),
                    super::fmt_f64(p[2])
                )?;
            }
            writeln!(w, "    endloop\n  endfacet")?;
        }
        writeln!(w, "endsolid {name}")?;
    }
    Ok(())
}
