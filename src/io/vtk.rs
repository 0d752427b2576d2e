//! Legacy VTK (`.vtk`), DATASET UNSTRUCTURED_GRID, ASCII or BINARY (big-endian).
//!
//! Both the classic `CELLS n size` layout and VTK 5.1's OFFSETS/CONNECTIVITY
//! layout are read; the classic layout is written (every VTK reader takes it).
//! Point, cell and field arrays of every attribute kind (SCALARS, VECTORS,
//! FIELD arrays of numbers or strings, ...) are kept; they are written back
//! as FIELD arrays with their names, types and components.

use std::io::Write;
use std::path::Path;

use super::lex::{Cursor, Endian, Scalar, as_index, clip, empty_values, push_val};
use super::vtk_cells::{cell_types, out_cell_arrays};
use super::{CellData, RawMesh, Shape, WriteResult, check_cell_data, fmt_f64};
use crate::error::{Error, Result};
use crate::mesh::{DataArray, ElementKind, Mesh, ValueType, Values};

/// Human name of a VTK cell type, for error messages.
pub(crate) fn vtk_type_name(t: i64) -> &'static str {
    match t {
        1 => "vertex",
        2 => "poly-vertex",
        3 => "line",
        4 => "poly-line",
        5 => "triangle",
        6 => "triangle strip",
        7 => "polygon",
        8 => "pixel",
        9 => "quad",
        10 => "tetrahedron",
        11 => "voxel",
        12 => "hexahedron",
        13 => "wedge (prism)",
        14 => "pyramid",
        15 => "pentagonal prism",
        16 => "hexagonal prism",
        21 => "quadratic edge",
        22 => "quadratic triangle",
        23 => "quadratic quad",
        24 => "quadratic tetrahedron",
        25 => "quadratic hexahedron",
        26 => "quadratic wedge",
        27 => "quadratic pyramid",
        28 => "biquadratic quad",
        29 => "triquadratic hexahedron",
        42 => "polyhedron",
        _ => "cell of unknown type",
    }
}

/// The faces of a legacy VTK face stream (`nfaces, n0, ids.., n1, ids..`),
/// as VTK writes a polyhedron in CELLS (VTK 5 to 9, classic and 5.1 layouts).
pub(crate) fn face_stream(stream: &[u32], np: usize) -> std::result::Result<Vec<Vec<u32>>, String> {
    let bad = |what: &str| format!("malformed face stream {:?}: {what}", &stream[..stream.len().min(12)]);
    let (&nf, mut rest) = stream.split_first().ok_or_else(|| bad("empty"))?;
    let mut faces = Vec::with_capacity(nf as usize);
    for f in 0..nf {
        let (&k, tail) = rest.split_first().ok_or_else(|| bad(&format!("face {f} is missing")))?;
        let k = k as usize;
        if tail.len() < k {
            return Err(bad(&format!(
                "face {f} announces {k} vertices, {} are left",
                tail.len()
            )));
        }
        if let Some(&v) = tail[..k].iter().find(|&&v| v as usize >= np) {
            return Err(format!("face {f} refers to vertex {v}, but the file has {np} points"));
        }
        faces.push(tail[..k].to_vec());
        rest = &tail[k..];
    }
    if !rest.is_empty() {
        return Err(bad(&format!("{} values after the {nf} faces", rest.len())));
    }
    Ok(faces)
}

/// Map a VTK cell type to a shape, or explain why it is refused.
pub(crate) fn vtk_shape(e: usize, t: i64) -> std::result::Result<Shape, String> {
    match t {
        1 => Ok(Shape::Vertex),
        3 => Ok(Shape::Line),
        14 => Err(format!(
            "element {e} is a pyramid (VTK type 14); pyramids are not supported: \
             the corner-based metrics need exactly 3 edges at every corner"
        )),
        _ => u8::try_from(t)
            .ok()
            .and_then(ElementKind::from_vtk_id)
            .map(Shape::Elem)
            .ok_or_else(|| {
                format!(
                    "element {e} is a {} (VTK type {t}), which is not supported; \
                     supported: vertex 1, line 3, triangle 5, quad 9, tetrahedron 10, \
                     hexahedron 12, wedge 13, polyhedron 42",
                    vtk_type_name(t)
                )
            }),
    }
}

/// A POLYDATA file's cells, in VTK's order: vertices, lines, polygons.
fn poly_cells(path: &Path, mut raw: RawMesh, sections: PolySections) -> Result<RawMesh> {
    if sections.iter().all(Option::is_none) {
        return Err(Error::parse(
            path,
            None,
            "missing POLYGONS section: the POLYDATA has no cells",
        ));
    }
    for (i, cells) in sections.into_iter().enumerate() {
        let Some((offsets, conn)) = cells else { continue };
        for w in offsets.windows(2) {
            let vs = &conn[w[0]..w[1]];
            let shape = match (i, vs.len()) {
                (0, _) => Shape::Vertex,
                (1, _) => Shape::Line,
                (_, 3) => Shape::Elem(ElementKind::Triangle),
                _ => Shape::Elem(ElementKind::Quadrilateral),
            };
            raw.push(shape, vs);
        }
    }
    Ok(raw)
}

fn scalar_type(name: &str) -> Option<Scalar> {
    Some(match name.to_ascii_lowercase().as_str() {
        "char" | "signed_char" => Scalar::I8,
        "unsigned_char" => Scalar::U8,
        "short" => Scalar::I16,
        "unsigned_short" => Scalar::U16,
        "int" | "vtktypeint32" => Scalar::I32,
        "unsigned_int" | "vtktypeuint32" => Scalar::U32,
        "long" | "vtktypeint64" | "vtkidtype" => Scalar::I64,
        "unsigned_long" | "vtktypeuint64" => Scalar::U64,
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        _ => return None,
    })
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Attach {
    /// Field data of the data set.
    None,
    /// Read and dropped (lookup tables).
    Discard,
    Points,
    Cells,
}

/// A POLYDATA's VERTICES, LINES and POLYGONS: offsets and connectivity of each.
type PolySections = [Option<(Vec<usize>, Vec<u32>)>; 3];

struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
    raw: RawMesh,
    npoints: Option<usize>,
    /// Cell offsets and connectivity, before CELL_TYPES gives the shapes.
    cells: Option<(Vec<usize>, Vec<u32>)>,
    has_types: bool,
    /// Where the CELLS values start, with the section's two counts.
    cells_at: Option<(Cursor<'a>, usize, usize)>,
    /// `DATASET POLYDATA`: its VERTICES, LINES and POLYGONS (offsets and
    /// connectivity), in VTK's cell order, which its cell data follow.
    poly: Option<PolySections>,
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &super::limits::Budget) -> Result<RawMesh> {
    let mut c = Cursor::new(path, data);
    c.budget = Some(budget);
    let (_, head) = c.line_tokens().ok_or_else(|| c.eof("the header"))?;
    if head.first() != Some(&"#") || !head.get(1).is_some_and(|t| t.eq_ignore_ascii_case("vtk")) {
        return Err(c.err("not a legacy VTK file: the first line must be '# vtk DataFile Version x.y'"));
    }
    c.end_line(); // title, free text
    let (_, fmt) = c.line_tokens().ok_or_else(|| c.eof("the ASCII/BINARY line"))?;
    let binary = match fmt.first().map(|t| t.to_ascii_uppercase()).as_deref() {
        Some("ASCII") => false,
        Some("BINARY") => true,
        _ => {
            return Err(c.err(format!(
                "expected ASCII or BINARY on line 3, found '{}'",
                clip(&fmt.join(" "))
            )));
        }
    };
    let mut r = Reader {
        c,
        binary,
        raw: RawMesh::default(),
        npoints: None,
        cells: None,
        has_types: false,
        cells_at: None,
        poly: None,
    };
    r.sections()?;
    let path = r.c.path;
    if r.npoints.is_none() {
        return Err(Error::parse(path, None, "missing POINTS section"));
    }
    if let Some(sections) = r.poly.take() {
        return poly_cells(path, r.raw, sections);
    }
    if r.cells.is_none() {
        return Err(Error::parse(path, None, "missing CELLS section"));
    }
    if !r.has_types {
        return Err(Error::parse(path, None, "missing CELL_TYPES section"));
    }
    Ok(r.raw)
}

impl Reader<'_> {
    fn sections(&mut self) -> Result<()> {
        let mut attach = Attach::None;
        let mut dataset = false;
        while let Some((_, toks)) = self.c.line_tokens() {
            let key = toks[0].to_ascii_uppercase();
            let arg = |i: usize| toks.get(i).copied().unwrap_or("");
            if !dataset && key != "DATASET" && key != "FIELD" {
                return Err(self.c.err(format!(
                    "expected 'DATASET UNSTRUCTURED_GRID', found '{}'",
                    clip(&toks.join(" "))
                )));
            }
            match key.as_str() {
                "DATASET" => {
                    if arg(1).eq_ignore_ascii_case("POLYDATA") {
                        self.poly = Some([None, None, None]);
                    } else if !arg(1).eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                        return Err(self.c.err(format!(
                            "DATASET {} is not supported; only UNSTRUCTURED_GRID and POLYDATA are",
                            clip(arg(1))
                        )));
                    }
                    dataset = true;
                }
                "VERTICES" | "LINES" | "POLYGONS" if self.poly.is_some() => self.poly_section(&key, &toks)?,
                "TRIANGLE_STRIPS" if self.poly.is_some() => {
                    return Err(self.c.err(
                        "TRIANGLE_STRIPS are not supported: write the strips as triangles (VTK's vtkTriangleFilter)",
                    ));
                }
                "POINTS" => self.points(&toks)?,
                "CELLS" => self.cell_conn(&toks)?,
                "CELL_TYPES" => self.cell_types(&toks)?,
                "POINT_DATA" | "CELL_DATA" => {
                    let n = self.header_count(&toks, 1)?;
                    let (want, what) = if key == "POINT_DATA" {
                        attach = Attach::Points;
                        (self.npoints, "points")
                    } else {
                        attach = Attach::Cells;
                        (self.ncells(), "cells")
                    };
                    if let Some(want) = want
                        && want != n
                    {
                        return Err(self
                            .c
                            .err(format!("{key} {n} does not match the {want} {what} of the mesh")));
                    }
                }
                "METADATA" => self.c.skip_to_blank_line(),
                _ => self.attribute(&key, &toks, attach)?,
            }
        }
        Ok(())
    }

    /// A POLYDATA section of cells: its vertex ids checked as they are read.
    fn poly_section(&mut self, key: &str, toks: &[&str]) -> Result<()> {
        if self.npoints.is_none() {
            return Err(self.c.err(format!("{key} before POINTS")));
        }
        let i = ["VERTICES", "LINES", "POLYGONS"]
            .iter()
            .position(|k| *k == key)
            .unwrap_or(2);
        if self.poly.as_ref().is_some_and(|p| p[i].is_some()) {
            return Err(self.c.err(format!("a second {key} section")));
        }
        let a = self.header_count(toks, 1)?;
        let b = self.header_count(toks, 2)?;
        let cells = self.cell_values(a, b, &|_| true)?;
        let at = self.c.token_line();
        let (offsets, _) = &cells;
        // one cell a shape: poly-vertices, polylines and polygons past 4 sides have none here
        let fits = |n: usize| match i {
            0 => n == 1,
            1 => n == 2,
            _ => n == 3 || n == 4,
        };
        if let Some(c) = (0..offsets.len() - 1).find(|&c| !fits(offsets[c + 1] - offsets[c])) {
            let what = ["a vertex needs 1", "a line needs 2", "a polygon needs 3 or 4"][i];
            return Err(Error::parse(
                self.c.path,
                Some(crate::error::Location::Line(at)),
                format!(
                    "{key} cell {c} has {} vertices: {what} (split poly-vertices, polylines and larger polygons first)",
                    offsets[c + 1] - offsets[c]
                ),
            ));
        }
        if let Some(p) = self.poly.as_mut() {
            p[i] = Some(cells);
        }
        Ok(())
    }

    fn header_count(&self, toks: &[&str], i: usize) -> Result<usize> {
        let t = toks.get(i).copied().unwrap_or("");
        t.parse().map_err(|_| {
            self.c.err(format!(
                "{}: expected a count, found '{}'",
                clip(toks.first().copied().unwrap_or("header")),
                clip(t)
            ))
        })
    }

    fn header_type(&self, toks: &[&str], i: usize) -> Result<Scalar> {
        let t = toks.get(i).copied().unwrap_or("");
        scalar_type(t).ok_or_else(|| {
            self.c.err(format!(
                "{}: unsupported or missing data type '{}'",
                clip(toks.first().copied().unwrap_or("header")),
                clip(t)
            ))
        })
    }

    /// Read `n` values of type `ty`, calling `f(index, value)` on each; `f`'s
    /// complaint becomes an error at the value's line (text) or byte (binary).
    fn array(
        &mut self,
        ty: Scalar,
        n: usize,
        what: &str,
        mut f: impl FnMut(usize, f64) -> std::result::Result<(), String>,
    ) -> Result<()> {
        if self.binary {
            let size = ty.size();
            let have = self.c.remaining() / size;
            if have < n {
                return Err(self.c.err_byte(format!(
                    "unexpected end of file while reading {what}: expected {n} values, found {have}"
                )));
            }
            let start = self.c.pos();
            let bytes = self.c.bytes(n * size, what)?;
            for (i, chunk) in bytes.chunks_exact(size).enumerate() {
                f(i, ty.get(Endian::Big, chunk)).map_err(|m| self.c.err_at_byte(start + i * size, m))?;
            }
        } else {
            for i in 0..n {
                let Some(t) = self.c.token() else {
                    return Err(Error::parse(
                        self.c.path,
                        None,
                        format!("unexpected end of file while reading {what}: expected {n} values, found {i}"),
                    ));
                };
                let v: f64 = t
                    .parse()
                    .map_err(|_| self.c.err(format!("expected a number in {what}, found '{}'", clip(t))))?;
                f(i, v).map_err(|m| self.c.err(m))?;
            }
        }
        Ok(())
    }

    fn points(&mut self, toks: &[&str]) -> Result<()> {
        if self.npoints.is_some() {
            return Err(self.c.err("a second POINTS section"));
        }
        let n = self.header_count(toks, 1)?;
        let ty = self.header_type(toks, 2)?;
        let total = n.checked_mul(3).ok_or_else(|| self.c.err("POINTS count too large"))?;
        let mut pts = Vec::with_capacity(self.c.reserve("POINTS", n, 3 * ty.size().min(2), 24)?);
        let mut p = [0.0; 3];
        self.array(ty, total, "POINTS", |i, v| {
            if !v.is_finite() {
                return Err(format!("point {} has a non-finite coordinate ({v})", i / 3));
            }
            p[i % 3] = v;
            if i % 3 == 2 {
                pts.push(p);
            }
            Ok(())
        })?;
        self.npoints = Some(n);
        self.raw.points = pts;
        Ok(())
    }

    fn cell_conn(&mut self, toks: &[&str]) -> Result<()> {
        if self.npoints.is_none() {
            return Err(self.c.err("CELLS before POINTS"));
        }
        if self.cells.is_some() {
            return Err(self.c.err("a second CELLS section"));
        }
        let a = self.header_count(toks, 1)?;
        let b = self.header_count(toks, 2)?;
        // a polyhedron's cell holds its face stream, whose counts may exceed
        // the point count: ids are checked once CELL_TYPES tells which cells
        // hold vertex ids, and a bad one re-read from here to name its line
        let start = self.c.clone();
        let (offsets, conn) = self.cell_values(a, b, &|_| false)?;
        self.cells = Some((offsets, conn));
        self.cells_at = Some((start, a, b));
        Ok(())
    }

    /// The `a` cells (`b` values) of a CELLS section: offsets and values;
    /// the values of the cells `checked(e)` must be vertex ids.
    fn cell_values(&mut self, a: usize, b: usize, checked: &dyn Fn(usize) -> bool) -> Result<(Vec<usize>, Vec<u32>)> {
        let np = self.npoints.unwrap_or(0);
        let ok_index = |e: usize, v: f64| {
            let limit = if checked(e) { np } else { u32::MAX as usize };
            as_index(v, limit)
                .map(|v| v as u32)
                .ok_or_else(|| format!("element {e} refers to vertex {v}, but the file has {np} points"))
        };
        if self.c.looking_at("OFFSETS") {
            // VTK 5.1: `a` offsets (cells + 1), `b` connectivity entries.
            let (_, t) = self.c.line_tokens().unwrap_or_default();
            let ty = self.header_type(&t, 1)?;
            let mut offsets = Vec::with_capacity(self.c.reserve("OFFSETS", a, 2, 8)?);
            self.array(ty, a, "OFFSETS", |i, v| {
                let prev = offsets.last().copied().unwrap_or(0);
                match as_index(v, b.saturating_add(1)) {
                    Some(o) if o >= prev && (i > 0 || o == 0) => {
                        offsets.push(o);
                        Ok(())
                    }
                    _ => Err(format!(
                        "offset {i} is {v}; offsets must start at 0 and increase up to {b}"
                    )),
                }
            })?;
            if offsets.last().copied().unwrap_or(0) != b || offsets.is_empty() {
                return Err(self
                    .c
                    .err(format!("the last offset must equal the connectivity size {b}")));
            }
            if !self.c.looking_at("CONNECTIVITY") {
                return Err(self.c.err("expected CONNECTIVITY after OFFSETS"));
            }
            let (_, t) = self.c.line_tokens().unwrap_or_default();
            let ty = self.header_type(&t, 1)?;
            let mut conn = Vec::with_capacity(self.c.reserve("CONNECTIVITY", b, 2, 4)?);
            let mut e = 0;
            self.array(ty, b, "CONNECTIVITY", |j, v| {
                while offsets[e + 1] <= j {
                    e += 1;
                }
                conn.push(ok_index(e, v)?);
                Ok(())
            })?;
            Ok((offsets, conn))
        } else {
            // Classic: per cell a vertex count, then the vertex ids.
            let ty = if self.binary { Scalar::I32 } else { Scalar::F64 };
            let mut offsets = Vec::with_capacity(self.c.reserve("CELLS", a + 1, 2, 8)?);
            offsets.push(0);
            let mut conn = Vec::with_capacity(self.c.reserve("CELLS", b, 2, 4)?);
            let mut left = 0usize;
            self.array(ty, b, "CELLS", |_, v| {
                let e = offsets.len() - 1;
                if left == 0 {
                    if e == a {
                        return Err(format!("CELLS has more data than its {a} cells"));
                    }
                    left = as_index(v, 1 << 20)
                        .filter(|&k| k > 0)
                        .ok_or_else(|| format!("element {e} has an invalid vertex count {v}"))?;
                } else {
                    conn.push(ok_index(e, v)?);
                    left -= 1;
                    if left == 0 {
                        offsets.push(conn.len());
                    }
                }
                Ok(())
            })?;
            if offsets.len() != a + 1 || left != 0 {
                return Err(self.c.err(format!(
                    "CELLS {a} {b}: the {b} values describe {} complete cells, not {a}",
                    offsets.len() - 1
                )));
            }
            Ok((offsets, conn))
        }
    }

    fn cell_types(&mut self, toks: &[&str]) -> Result<()> {
        let Some((offsets, conn)) = self.cells.take() else {
            return Err(self.c.err("CELL_TYPES before CELLS"));
        };
        let n = self.header_count(toks, 1)?;
        let ncells = offsets.len() - 1;
        if n != ncells {
            return Err(self
                .c
                .err(format!("CELL_TYPES {n} does not match the {ncells} cells in CELLS")));
        }
        let ty = if self.binary { Scalar::I32 } else { Scalar::F64 };
        let mut types = Vec::with_capacity(n);
        self.array(ty, n, "CELL_TYPES", |e, v| {
            let t = v as i64;
            if t != ElementKind::Polyhedron.vtk_id() as i64 {
                let shape = vtk_shape(e, t)?;
                let len = offsets[e + 1] - offsets[e];
                if len != shape.num_vertices() {
                    return Err(format!(
                        "element {e} is a {} (VTK type {t}) but has {len} vertices instead of {}",
                        vtk_type_name(t),
                        shape.num_vertices()
                    ));
                }
            }
            types.push(t);
            Ok(())
        })?;
        let np = self.npoints.unwrap_or(0);
        let is_poly = |e: usize| types[e] == ElementKind::Polyhedron.vtk_id() as i64;
        if let Some(e) =
            (0..n).find(|&e| !is_poly(e) && conn[offsets[e]..offsets[e + 1]].iter().any(|&v| v as usize >= np))
        {
            // re-read CELLS, now checking the vertex ids, for the error's line or byte
            let (cursor, a, b) = self.cells_at.take().expect("CELLS was read");
            let here = std::mem::replace(&mut self.c, cursor);
            let err = self.cell_values(a, b, &|e| !is_poly(e)).err();
            self.c = here;
            return Err(err.unwrap_or_else(|| {
                self.c
                    .err(format!("element {e} refers to a vertex outside the {np} points"))
            }));
        }
        let mut raw = std::mem::take(&mut self.raw);
        for (e, &t) in types.iter().enumerate() {
            let vs = &conn[offsets[e]..offsets[e + 1]];
            if is_poly(e) {
                let faces = face_stream(vs, np).map_err(|m| self.c.err(format!("element {e} (polyhedron): {m}")))?;
                raw.push_polyhedron(
                    &crate::mesh::polyhedron::vertices_of_faces(faces.iter().map(|f| &f[..])),
                    &faces,
                );
                continue;
            }
            raw.push(vtk_shape(e, t).map_err(|m| self.c.err(m))?, vs);
        }
        self.raw = raw;
        self.cells = Some((offsets, Vec::new()));
        self.has_types = true;
        Ok(())
    }

    /// Cells read so far: CELLS, or a POLYDATA's sections together.
    fn ncells(&self) -> Option<usize> {
        match &self.poly {
            Some(p) => Some(p.iter().flatten().map(|c| c.0.len() - 1).sum()),
            None => self.cells.as_ref().map(|c| c.0.len() - 1),
        }
    }

    fn count_for(&self, attach: Attach, key: &str) -> Result<usize> {
        match attach {
            Attach::Points => Ok(self.npoints.unwrap_or(0)),
            Attach::Cells => Ok(self.ncells().unwrap_or(0)),
            Attach::None | Attach::Discard => Err(self.c.err(format!("{key} outside POINT_DATA or CELL_DATA"))),
        }
    }

    fn mul(&self, a: usize, b: usize, key: &str) -> Result<usize> {
        a.checked_mul(b)
            .ok_or_else(|| self.c.err(format!("{key}: sizes too large")))
    }

    fn attribute(&mut self, key: &str, toks: &[&str], attach: Attach) -> Result<()> {
        let name = decode_name(toks.get(1).copied().unwrap_or(key));
        match key {
            "SCALARS" => {
                let n = self.count_for(attach, key)?;
                let ty = self.data_type(toks, 2)?;
                let ncomp = if toks.len() > 3 { self.header_count(toks, 3)? } else { 1 };
                if self.c.looking_at("LOOKUP_TABLE") {
                    self.c.line_tokens();
                }
                let is_fixed = attach == Attach::Points && name == "fixed" && ncomp == 1;
                self.data_array(ty, n, ncomp.max(1), &name, attach, is_fixed)
            }
            "LOOKUP_TABLE" => {
                let size = self.header_count(toks, 2)?;
                let ty = if self.binary { Scalar::U8 } else { Scalar::F64 };
                self.data_array(Some(ty), size, 4, "LOOKUP_TABLE", Attach::Discard, false)
            }
            "COLOR_SCALARS" => {
                let n = self.count_for(attach, key)?;
                let k = self.header_count(toks, 2)?;
                let ty = if self.binary { Scalar::U8 } else { Scalar::F32 };
                self.data_array(Some(ty), n, k.max(1), &name, attach, false)
            }
            "VECTORS" | "NORMALS" | "TENSORS" | "TENSORS6" | "GLOBAL_IDS" | "PEDIGREE_IDS" => {
                let n = self.count_for(attach, key)?;
                let ty = self.data_type(toks, 2)?;
                let k = match key {
                    "VECTORS" | "NORMALS" => 3,
                    "TENSORS" => 9,
                    "TENSORS6" => 6,
                    _ => 1,
                };
                self.data_array(ty, n, k, &name, attach, false)
            }
            "TEXTURE_COORDINATES" => {
                let n = self.count_for(attach, key)?;
                let k = self.header_count(toks, 2)?;
                let ty = self.data_type(toks, 3)?;
                self.data_array(ty, n, k.max(1), &name, attach, false)
            }
            "FIELD" => {
                let narrays = self.header_count(toks, 2)?;
                for _ in 0..narrays {
                    if self.c.looking_at("METADATA") {
                        self.c.skip_to_blank_line();
                    }
                    let (_, t) = self.c.line_tokens().ok_or_else(|| self.c.eof("FIELD arrays"))?;
                    if t.len() < 4 {
                        return Err(self.c.err(format!(
                            "expected 'name components tuples type' in FIELD, found '{}'",
                            clip(&t.join(" "))
                        )));
                    }
                    let k = self.header_count(&t, 1)?;
                    let tuples = self.header_count(&t, 2)?;
                    let ty = self.data_type(&t, 3)?;
                    let aname = decode_name(t[0]);
                    if let Some(want) = match attach {
                        Attach::Points => self.npoints,
                        Attach::Cells => self.ncells(),
                        Attach::None | Attach::Discard => None,
                    } && tuples != want
                    {
                        return Err(self.c.err(format!(
                            "FIELD array '{}' has {tuples} tuples, but the data section has {want}",
                            clip(&aname)
                        )));
                    }
                    let is_fixed = attach == Attach::Points && aname == "fixed" && k == 1;
                    self.data_array(ty, tuples, k.max(1), &aname, attach, is_fixed)?;
                }
                if self.c.looking_at("METADATA") {
                    self.c.line_tokens();
                    self.c.skip_to_blank_line();
                }
                Ok(())
            }
            _ => Err(self.c.err(format!("unknown keyword '{}'", clip(toks[0])))),
        }
    }

    /// A data type name; `None` for strings.
    fn data_type(&self, toks: &[&str], i: usize) -> Result<Option<Scalar>> {
        let t = toks.get(i).copied().unwrap_or("");
        if t.eq_ignore_ascii_case("string") || t.eq_ignore_ascii_case("utf8_string") {
            return Ok(None);
        }
        self.header_type(toks, i).map(Some)
    }

    /// Read an array of `tuples` x `k` values and keep it with the points,
    /// the cells or the data set; a point array named `fixed` sets the fixed
    /// flags instead.
    fn data_array(
        &mut self,
        ty: Option<Scalar>,
        tuples: usize,
        k: usize,
        name: &str,
        attach: Attach,
        is_fixed: bool,
    ) -> Result<()> {
        let n = self.mul(tuples, k, name)?;
        let what = format!("data array '{}'", clip(name));
        let values = match ty {
            None => Values::Str(self.strings(n, &what)?),
            Some(ty) => {
                let mut out = empty_values(ty, self.c.cap(n, 2));
                if self.binary {
                    let size = ty.size();
                    let have = self.c.remaining() / size;
                    if have < n {
                        return Err(self.c.err_byte(format!(
                            "unexpected end of file while reading {what}: expected {n} values, found {have}"
                        )));
                    }
                    let bytes = self.c.bytes(n * size, &what)?;
                    out = ty.decode_all(Endian::Big, bytes);
                } else {
                    for i in 0..n {
                        let Some(t) = self.c.token() else {
                            return Err(Error::parse(
                                self.c.path,
                                None,
                                format!("unexpected end of file while reading {what}: expected {n} values, found {i}"),
                            ));
                        };
                        let v = ty
                            .parse_text(t)
                            .ok_or_else(|| self.c.err(format!("expected a number in {what}, found '{}'", clip(t))))?;
                        push_val(&mut out, v);
                    }
                }
                out
            }
        };
        if is_fixed {
            if let Values::Int(v) = &values {
                for (i, _) in v.iter().enumerate().filter(|(_, x)| **x != 0) {
                    self.raw.fix(i);
                }
            } else if let Values::Float(v) = &values {
                for (i, _) in v.iter().enumerate().filter(|(_, x)| **x != 0.0) {
                    self.raw.fix(i);
                }
            }
            return Ok(());
        }
        let vt = ty.map_or(ValueType::Str, |t| t.value_type());
        let a = DataArray::new(name, vt, k, values);
        match attach {
            Attach::Points => self.raw.point_data.push(a),
            Attach::Cells => self.raw.cell_data.push(a),
            Attach::None => self.raw.field_data.push(a),
            Attach::Discard => {}
        }
        Ok(())
    }

    /// `n` strings: one %-encoded string a line (ASCII), or each with VTK's
    /// length prefix (binary: 1, 2, 4 or 8 big-endian bytes whose top two
    /// bits say which).
    fn strings(&mut self, n: usize, what: &str) -> Result<Vec<String>> {
        let mut out = Vec::with_capacity(self.c.reserve(what, n, 1, 24)?);
        if !self.binary {
            for i in 0..n {
                let s = self.c.raw_line().ok_or_else(|| {
                    Error::parse(
                        self.c.path,
                        None,
                        format!("unexpected end of file while reading {what}: expected {n} strings, found {i}"),
                    )
                })?;
                out.push(decode_name(s.trim_end_matches('\r')));
            }
            return Ok(out);
        }
        // the line break after the header line is consumed by line_tokens
        for _ in 0..n {
            let b0 = self.c.bytes(1, what)?[0];
            let len = match b0 >> 6 {
                3 => (b0 & 0x3f) as u64,
                2 => {
                    let b1 = self.c.bytes(1, what)?[0];
                    (u16::from_be_bytes([b0, b1]) & 0x3fff) as u64
                }
                1 => {
                    let r = self.c.bytes(3, what)?;
                    (u32::from_be_bytes([b0, r[0], r[1], r[2]]) & 0x3fff_ffff) as u64
                }
                _ => {
                    let r = self.c.bytes(7, what)?;
                    u64::from_be_bytes([b0, r[0], r[1], r[2], r[3], r[4], r[5], r[6]])
                }
            };
            let len = usize::try_from(len).unwrap_or(usize::MAX);
            let s = self.c.bytes(len, what)?;
            out.push(String::from_utf8_lossy(s).into_owned());
        }
        Ok(out)
    }
}

/// VTK (4.2 and later) %-encodes whitespace and unprintable bytes in names
/// and ASCII strings.
fn decode_name(s: &str) -> String {
    let b = s.as_bytes();
    if !b.contains(&b'%') {
        return s.to_string();
    }
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && let Some(h) = b.get(i + 1..i + 3)
            && let Ok(v) = u8::from_str_radix(std::str::from_utf8(h).unwrap_or("zz"), 16)
        {
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The inverse of [`decode_name`]: what VTK's reader decodes back.
fn encode_name(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_graphic() && b != b'%' && b != b'"' {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// Type names of the legacy format's version 3.0 that meshio (5.3) reads as
/// well as VTK: meshio's table has no `signed_char` or `vtktypeint64` (a
/// KeyError), and takes `char` and `long` as int8 and int64, as VTK does on
/// 64-bit Linux and macOS.
fn legacy_type(t: ValueType) -> &'static str {
    match t {
        ValueType::I8 => "char",
        ValueType::U8 => "unsigned_char",
        ValueType::I16 => "short",
        ValueType::U16 => "unsigned_short",
        ValueType::I32 => "int",
        ValueType::U32 => "unsigned_int",
        ValueType::I64 => "long",
        ValueType::U64 => "unsigned_long",
        ValueType::F32 => "float",
        ValueType::F64 => "double",
        ValueType::Str => "string",
    }
}

/// Big-endian bytes of an array in its own type.
fn be_bytes(a: &DataArray) -> Vec<u8> {
    let mut out = Vec::with_capacity(a.values.len() * a.ty.size().max(1));
    let int = |out: &mut Vec<u8>, x: i64| match a.ty {
        ValueType::I8 | ValueType::U8 => out.push(x as u8),
        ValueType::I16 | ValueType::U16 => out.extend_from_slice(&(x as u16).to_be_bytes()),
        ValueType::I32 | ValueType::U32 => out.extend_from_slice(&(x as u32).to_be_bytes()),
        ValueType::F32 => out.extend_from_slice(&(x as f32).to_be_bytes()),
        ValueType::F64 => out.extend_from_slice(&(x as f64).to_be_bytes()),
        _ => out.extend_from_slice(&x.to_be_bytes()),
    };
    match &a.values {
        Values::Int(v) => v.iter().for_each(|&x| int(&mut out, x)),
        Values::Float(v) => {
            for &x in v {
                match a.ty {
                    ValueType::F32 => out.extend_from_slice(&(x as f32).to_be_bytes()),
                    ValueType::F64 => out.extend_from_slice(&x.to_be_bytes()),
                    _ => int(&mut out, x as i64),
                }
            }
        }
        Values::Str(v) => {
            for s in v {
                let len = s.len() as u64;
                if len < 1 << 6 {
                    out.push(0xc0 | len as u8);
                } else if len < 1 << 14 {
                    out.extend_from_slice(&(0x8000 | len as u16).to_be_bytes());
                } else if len < 1 << 30 {
                    out.extend_from_slice(&(0x4000_0000 | len as u32).to_be_bytes());
                } else {
                    out.extend_from_slice(&len.to_be_bytes());
                }
                out.extend_from_slice(s.as_bytes());
            }
        }
    }
    out
}

/// `FIELD FieldData n` with every array of `arrays`.
fn write_field(w: &mut dyn Write, arrays: &[&DataArray], binary: bool) -> WriteResult {
    if arrays.is_empty() {
        return Ok(());
    }
    writeln!(w, "FIELD FieldData {}", arrays.len())?;
    for a in arrays {
        writeln!(
            w,
            "{} {} {} {}",
            encode_name(&a.name),
            a.components,
            a.tuples(),
            legacy_type(a.ty)
        )?;
        if binary {
            w.write_all(&be_bytes(a))?;
            writeln!(w)?;
            continue;
        }
        match &a.values {
            Values::Str(v) => {
                for s in v {
                    writeln!(w, "{}", encode_name(s))?;
                }
            }
            Values::Int(v) => {
                for row in v.chunks(a.components.clamp(1, 9)) {
                    let t: Vec<String> = row
                        .iter()
                        .map(|&x| {
                            if a.ty == ValueType::U64 {
                                (x as u64).to_string()
                            } else {
                                x.to_string()
                            }
                        })
                        .collect();
                    writeln!(w, "{}", t.join(" "))?;
                }
            }
            Values::Float(v) => {
                for row in v.chunks(a.components.clamp(1, 9)) {
                    let t: Vec<String> = row
                        .iter()
                        .map(|&x| {
                            if a.ty == ValueType::F32 {
                                format!("{:?}", x as f32)
                            } else {
                                fmt_f64(x)
                            }
                        })
                        .collect();
                    writeln!(w, "{}", t.join(" "))?;
                }
            }
        }
    }
    Ok(())
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    let ne = mesh.num_elements();
    writeln!(w, "# vtk DataFile Version 3.0")?;
    writeln!(w, "written by meshsmooth")?;
    writeln!(w, "{}", if binary { "BINARY" } else { "ASCII" })?;
    writeln!(w, "DATASET UNSTRUCTURED_GRID")?;
    let field = super::out_field_arrays(mesh);
    write_field(w, &field.iter().map(|a| &**a).collect::<Vec<_>>(), binary)?;
    writeln!(w, "POINTS {n} double")?;
    if binary {
        let mut buf = Vec::with_capacity(24 * n);
        for c in mesh.points.iter().flatten() {
            buf.extend_from_slice(&c.to_be_bytes());
        }
        w.write_all(&buf)?;
        writeln!(w)?;
    } else {
        for p in &mesh.points {
            writeln!(w, "{} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
        }
    }
    // a polyhedron is written as its face stream, as VTK's own writer does
    let cell_values = |e: usize| -> Vec<u32> {
        if mesh.kinds[e] != ElementKind::Polyhedron {
            return mesh.element(e).to_vec();
        }
        let mut stream = vec![mesh.faces.of(e).count() as u32];
        for f in mesh.faces.of(e) {
            stream.push(f.len() as u32);
            stream.extend_from_slice(f);
        }
        stream
    };
    let size: usize = (0..ne)
        .map(|e| match mesh.kinds[e] {
            ElementKind::Polyhedron => 2 + mesh.faces.of(e).map(|f| 1 + f.len()).sum::<usize>(),
            _ => 1 + mesh.element(e).len(),
        })
        .chain(mesh.lower.iter().map(|(_, vs)| 1 + vs.len()))
        .sum();
    // the lower cells follow the elements (see `vtk_cells`)
    let nc = ne + mesh.lower.len();
    writeln!(w, "CELLS {nc} {size}")?;
    let mut buf = Vec::new();
    for c in 0..nc {
        let vs = match c.checked_sub(ne) {
            None => cell_values(c),
            Some(l) => mesh.lower[l].1.clone(),
        };
        if binary {
            buf.extend_from_slice(&(vs.len() as i32).to_be_bytes());
            for &v in vs.iter() {
                buf.extend_from_slice(&(v as i32).to_be_bytes());
            }
        } else {
            write!(w, "{}", vs.len())?;
            for v in vs.iter() {
                write!(w, " {v}")?;
            }
            writeln!(w)?;
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
    }
    writeln!(w, "CELL_TYPES {nc}")?;
    write_ints(w, binary, cell_types(mesh).map(i32::from))?;
    let point_arrays: Vec<&DataArray> = mesh.data.point.iter().filter(|a| a.name != "fixed").collect();
    if !mesh.fixed.is_empty() || !point_arrays.is_empty() {
        writeln!(w, "POINT_DATA {n}")?;
    }
    if !mesh.fixed.is_empty() {
        writeln!(w, "SCALARS fixed int 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        write_ints(w, binary, mesh.fixed.iter().map(|&f| f as i32))?;
    }
    write_field(w, &point_arrays, binary)?;
    check_cell_data(mesh, cell_data)?;
    let cells = out_cell_arrays(mesh, cell_data);
    if !cells.is_empty() {
        writeln!(w, "CELL_DATA {nc}")?;
        let refs: Vec<&DataArray> = cells.iter().map(|c| c.as_ref()).collect();
        write_field(w, &refs, binary)?;
    }
    Ok(())
}

fn write_ints(w: &mut dyn Write, binary: bool, it: impl Iterator<Item = i32>) -> WriteResult {
    if binary {
        let buf: Vec<u8> = it.flat_map(|v| v.to_be_bytes()).collect();
        w.write_all(&buf)?;
        writeln!(w)?;
    } else {
        for v in it {
            writeln!(w, "{v}")?;
        }
    }
    Ok(())
}
