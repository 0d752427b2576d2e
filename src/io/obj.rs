//! Wavefront OBJ (`.obj`), ASCII: `v` vertices and `f` faces of 3 or 4
//! vertices.
//!
//! Face corners may be `v`, `v/vt`, `v//vn` or `v/vt/vn`, with negative
//! indices counting back from the last vertex; only the vertex index is
//! kept. `g NAME` and `o NAME` start an element set of that name (faces
//! before any group are in none; a face under `g a b` is in both sets).
//! Texture coordinates, normals, materials and smoothing groups (`vt`, `vn`,
//! `mtllib`, `usemtl`, `s`) are ignored. A `v` line's optional weight or
//! colour values are ignored too. Written back: `v`, `f` and one `g` per
//! element set (elements in no set first). Lower cells are not written.

use std::io::Write;
use std::path::Path;

use super::limits::Budget;
use super::{RawMesh, Shape, WriteResult};
use crate::error::{Error, Location, Result};
use crate::mesh::{ElementKind, Mesh};

pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    // points and connectivity: at most one value per 2 bytes of text
    budget.charge("the OBJ vertices and faces", (data.len() as u64 / 2).saturating_mul(12))?;
    let mut raw = RawMesh::default();
    let err = |line: usize, msg: String| Error::parse(path, Some(Location::Line(line)), msg);
    // index of each set in raw.cell_sets by name, and the sets now open
    let mut by_name: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut open: Vec<usize> = Vec::new();
    let mut corners: Vec<u32> = Vec::with_capacity(4);
    for (i, line) in data.split(|&b| b == b'\n').enumerate() {
        let ln = i + 1;
        let Ok(line) = std::str::from_utf8(line) else {
            return Err(err(ln, "the line is not text (UTF-8)".into()));
        };
        let line = line.split('#').next().unwrap_or("");
        let mut t = line.split_ascii_whitespace();
        let Some(kw) = t.next() else { continue };
        match kw {
            "v" => {
                let mut p = [0.0; 3];
                for x in &mut p {
                    let tok = t
                        .next()
                        .ok_or_else(|| err(ln, "a vertex needs three coordinates".into()))?;
                    *x = tok.parse().ok().filter(|x: &f64| x.is_finite()).ok_or_else(|| {
                        err(
                            ln,
                            format!("expected a finite coordinate, found '{}'", super::lex::clip(tok)),
                        )
                    })?;
                }
                if raw.points.len() >= u32::MAX as usize {
                    return Err(err(ln, "more vertices than 32-bit ids can number".into()));
                }
                raw.points.push(p);
            }
            "f" => {
                corners.clear();
                let np = raw.points.len();
                for tok in t {
                    let idx = tok.split('/').next().unwrap_or("");
                    let k: i64 = idx.parse().map_err(|_| {
                        err(
                            ln,
                            format!("expected a vertex index, found '{}'", super::lex::clip(tok)),
                        )
                    })?;
                    // 1-based; negative counts back from the last vertex read so far
                    let id = if k > 0 { k - 1 } else { np as i64 + k };
                    if k == 0 || id < 0 || id >= np as i64 {
                        return Err(err(
                            ln,
                            format!("face refers to vertex {k}, but {np} vertices are defined before this line"),
                        ));
                    }
                    if corners.len() == 4 {
                        return Err(err(
                            ln,
                            "a face with more than 4 vertices: only triangles and quadrilaterals are supported".into(),
                        ));
                    }
                    corners.push(id as u32);
                }
                let kind = match corners.len() {
                    3 => ElementKind::Triangle,
                    4 => ElementKind::Quadrilateral,
                    n => return Err(err(ln, format!("a face with {n} vertices: a face needs 3 or 4"))),
                };
                let c = raw.shapes.len() as u32;
                for &s in &open {
                    raw.cell_sets[s].1.push(c);
                }
                raw.push(Shape::Elem(kind), &corners);
            }
            "l" => {
                // polylines: kept as lower line cells, segment by segment
                let np = raw.points.len() as i64;
                let mut prev: Option<u32> = None;
                for tok in t {
                    let k: i64 = tok.split('/').next().unwrap_or("").parse().map_err(|_| {
                        err(
                            ln,
                            format!("expected a vertex index, found '{}'", super::lex::clip(tok)),
                        )
                    })?;
                    let id = if k > 0 { k - 1 } else { np + k };
                    if k == 0 || id < 0 || id >= np {
                        return Err(err(
                            ln,
                            format!("line refers to vertex {k}, but {np} vertices are defined before this line"),
                        ));
                    }
                    if let Some(p) = prev {
                        raw.push(Shape::Line, &[p, id as u32]);
                    }
                    prev = Some(id as u32);
                }
            }
            "g" | "o" => {
                open.clear();
                for name in t {
                    let next = raw.cell_sets.len();
                    let s = *by_name.entry(name.to_string()).or_insert(next);
                    if s == next {
                        raw.cell_sets.push((name.to_string(), Vec::new()));
                    }
                    if !open.contains(&s) {
                        open.push(s);
                    }
                }
            }
            "vt" | "vn" | "vp" | "mtllib" | "usemtl" | "s" => {}
            _ => {
                return Err(err(
                    ln,
                    format!(
                        "'{}' is not an OBJ statement meshsmooth reads (v, f, l, g, o; vt, vn, mtllib, usemtl, s are ignored)",
                        super::lex::clip(kw)
                    ),
                ));
            }
        }
    }
    // a set that lost all its faces to later groups of the same name stays, empty
    Ok(raw)
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh) -> WriteResult {
    writeln!(w, "# written by meshsmooth")?;
    for p in &mesh.points {
        writeln!(
            w,
            "v {} {} {}",
            super::fmt_f64(p[0]),
            super::fmt_f64(p[1]),
            super::fmt_f64(p[2])
        )?;
    }
    let face = |w: &mut dyn Write, e: usize| -> WriteResult {
        write!(w, "f")?;
        for v in mesh.element(e) {
            write!(w, " {}", v + 1)?;
        }
        writeln!(w)?;
        Ok(())
    };
    // OBJ groups can overlap, but a face is written once: under the first
    // set that holds it (later sets holding it too lose it)
    let mut done = vec![false; mesh.num_elements()];
    let sets = &mesh.data.element_sets;
    for s in sets {
        for &e in &s.elements {
            if let Some(d) = done.get_mut(e as usize) {
                *d = true;
            }
        }
    }
    for e in 0..mesh.num_elements() {
        if !done[e] {
            face(w, e)?;
        }
    }
    done.fill(false);
    for s in sets {
        // names with spaces would read back as several groups
        writeln!(w, "g {}", s.name.replace(char::is_whitespace, "_"))?;
        for &e in &s.elements {
            let e = e as usize;
            if e < done.len() && !done[e] {
                done[e] = true;
                face(w, e)?;
            }
        }
    }
    Ok(())
}
