//! VTK XML unstructured grids (`.vtu`): inline ASCII or base64 DataArrays.
//!
//! Compressed and appended data are refused with a clear message; one Piece
//! only.

use std::io::Write;
use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD as B64;
use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;

use super::lex::{Cursor, Endian, Scalar, as_index};
use super::vtk::{vtk_shape, vtk_type_name};
use super::{CellData, RawMesh, WriteResult, check_cell_data, fmt_f64};
use crate::error::{Error, Location, Result};
use crate::mesh::Mesh;

fn xml_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "Int8" | "Char" => Scalar::I8,
        "UInt8" => Scalar::U8,
        "Int16" => Scalar::I16,
        "UInt16" => Scalar::U16,
        "Int32" => Scalar::I32,
        "UInt32" => Scalar::U32,
        "Int64" => Scalar::I64,
        "UInt64" => Scalar::U64,
        "Float32" => Scalar::F32,
        "Float64" => Scalar::F64,
        _ => return None,
    })
}

/// Which arrays of the file we keep.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    Points,
    Connectivity,
    Offsets,
    Types,
    Fixed,
    Ignored,
}

struct Pending {
    role: Role,
    ty: Scalar,
    binary: bool,
    name: String,
    /// Line of the `<DataArray` tag, for errors about its content.
    line: usize,
    text: String,
}

#[derive(Default)]
struct Arrays {
    points: Option<(Vec<f64>, usize)>,
    conn: Option<(Vec<f64>, usize)>,
    offsets: Option<(Vec<f64>, usize)>,
    types: Option<(Vec<f64>, usize)>,
    fixed: Option<Vec<f64>>,
}

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
    header: Scalar,
    endian: Endian,
}

impl Ctx<'_> {
    fn line_of(&self, pos: u64) -> usize {
        let pos = (pos as usize).min(self.text.len());
        1 + self.text.as_bytes()[..pos].iter().filter(|&&b| b == b'\n').count()
    }

    fn err(&self, line: usize, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Line(line)), msg)
    }

    fn decode(&self, p: &Pending) -> Result<Vec<f64>> {
        if !p.binary {
            let mut c = Cursor::new(self.path, p.text.as_bytes());
            c.set_line(p.line);
            let mut out = Vec::new();
            while let Some(t) = c.token() {
                out.push(
                    t.parse()
                        .map_err(|_| c.err(format!("expected a number in DataArray '{}', found '{t}'", p.name)))?,
                );
            }
            return Ok(out);
        }
        let b64: Vec<u8> = p.text.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
        let bad = |what: &str| self.err(p.line, format!("DataArray '{}': invalid base64 data ({what})", p.name));
        let hsize = self.header.size();
        // VTK encodes the byte-count header and the data as two base64 runs;
        // some writers encode them as one. A padded header run tells them apart.
        let hchars = hsize.div_ceil(3) * 4;
        let (header, payload) = match b64.get(..hchars) {
            Some(h) if h.ends_with(b"=") => {
                let head = B64.decode(h).map_err(|e| bad(&e.to_string()))?;
                let body = B64.decode(&b64[hchars..]).map_err(|e| bad(&e.to_string()))?;
                (head, body)
            }
            _ => {
                let mut all = B64.decode(&b64).map_err(|e| bad(&e.to_string()))?;
                if all.len() < hsize {
                    return Err(bad("shorter than its header"));
                }
                let body = all.split_off(hsize);
                (all, body)
            }
        };
        if header.len() < hsize {
            return Err(bad("header too short"));
        }
        let nbytes = self.header.get(self.endian, &header);
        if nbytes != payload.len() as f64 {
            return Err(self.err(
                p.line,
                format!(
                    "DataArray '{}': header says {nbytes} bytes but {} bytes follow (truncated?)",
                    p.name,
                    payload.len()
                ),
            ));
        }
        let size = p.ty.size();
        if payload.len() % size != 0 {
            return Err(bad("byte count is not a multiple of the value size"));
        }
        Ok(payload.chunks_exact(size).map(|c| p.ty.get(self.endian, c)).collect())
    }
}

fn attr(e: &BytesStart, key: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.local_name().as_ref() == key)
        .map(|a| {
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map(|v| v.into_owned())
                .unwrap_or_default()
        })
}

pub(crate) fn read(path: &Path, data: &[u8]) -> Result<RawMesh> {
    let text = std::str::from_utf8(data).map_err(|e| {
        Error::parse(
            path,
            Some(Location::Byte(e.valid_up_to() as u64)),
            "not valid UTF-8 text (is this really a .vtu file?)",
        )
    })?;
    let mut ctx = Ctx {
        path,
        text,
        header: Scalar::U32,
        endian: Endian::Little,
    };
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<String> = Vec::new();
    let mut pending: Option<Pending> = None;
    let mut arrays = Arrays::default();
    let mut counts: Option<(usize, usize)> = None;
    loop {
        let tag_pos = reader.buffer_position();
        let ev = reader
            .read_event()
            .map_err(|e| ctx.err(ctx.line_of(reader.error_position()), format!("malformed XML: {e}")))?;
        let line = ctx.line_of(tag_pos);
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = e.local_name().as_ref().to_string();
                match name.as_str() {
                    "VTKFile" => {
                        if let Some(t) = attr(e, "type")
                            && t != "UnstructuredGrid"
                        {
                            return Err(ctx.err(
                                line,
                                format!("VTKFile type '{t}' is not supported; only UnstructuredGrid is"),
                            ));
                        }
                        if attr(e, "compressor").is_some_and(|c| !c.is_empty()) {
                            return Err(ctx.err(
                                line,
                                "compressed VTU files are not supported; write them uncompressed (e.g. ParaView: Data Mode ascii or binary, Compressor None)",
                            ));
                        }
                        if attr(e, "byte_order").as_deref() == Some("BigEndian") {
                            ctx.endian = Endian::Big;
                        }
                        if let Some(h) = attr(e, "header_type") {
                            ctx.header = match h.as_str() {
                                "UInt32" => Scalar::U32,
                                "UInt64" => Scalar::U64,
                                _ => {
                                    return Err(
                                        ctx.err(line, format!("header_type '{h}' is not supported (UInt32 or UInt64)"))
                                    );
                                }
                            };
                        }
                    }
                    "Piece" => {
                        if counts.is_some() {
                            return Err(ctx.err(line, "files with several Pieces are not supported"));
                        }
                        let num = |k: &str| {
                            let v = attr(e, k).unwrap_or_default();
                            v.trim()
                                .parse::<usize>()
                                .map_err(|_| ctx.err(line, format!("Piece: {k} must be a count, found '{v}'")))
                        };
                        counts = Some((num("NumberOfPoints")?, num("NumberOfCells")?));
                    }
                    "AppendedData" => {
                        return Err(ctx.err(
                            line,
                            "appended data is not supported; write the file with inline (ascii or binary) DataArrays",
                        ));
                    }
                    "DataArray" => {
                        let parent = stack.last().map(String::as_str).unwrap_or("");
                        let aname = attr(e, "Name").unwrap_or_default();
                        let role = match (parent, aname.as_str()) {
                            ("Points", _) => Role::Points,
                            ("Cells", "connectivity") => Role::Connectivity,
                            ("Cells", "offsets") => Role::Offsets,
                            ("Cells", "types") => Role::Types,
                            ("PointData", "fixed") => Role::Fixed,
                            _ => Role::Ignored,
                        };
                        let format = attr(e, "format").unwrap_or_else(|| "ascii".into());
                        let binary = match format.as_str() {
                            "ascii" => false,
                            "binary" => true,
                            "appended" => {
                                return Err(ctx.err(
                                    line,
                                    format!("DataArray '{aname}': appended data is not supported; write the file with inline (ascii or binary) DataArrays"),
                                ));
                            }
                            f => {
                                return Err(ctx.err(line, format!("DataArray '{aname}': unknown format '{f}'")));
                            }
                        };
                        let tyname = attr(e, "type").unwrap_or_default();
                        let ty = match xml_type(&tyname) {
                            Some(t) => t,
                            None if role == Role::Ignored => Scalar::U8,
                            None => {
                                return Err(ctx.err(line, format!("DataArray '{aname}': unsupported type '{tyname}'")));
                            }
                        };
                        if role == Role::Points {
                            let nc = attr(e, "NumberOfComponents").unwrap_or_else(|| "1".into());
                            if nc.trim() != "3" {
                                return Err(ctx.err(
                                    line,
                                    format!("Points must have NumberOfComponents=\"3\", found \"{nc}\""),
                                ));
                            }
                        }
                        let p = Pending {
                            role,
                            ty,
                            binary,
                            name: aname,
                            line,
                            text: String::new(),
                        };
                        if matches!(ev, Event::Empty(_)) {
                            finish(&ctx, p, &mut arrays)?;
                        } else {
                            pending = Some(p);
                        }
                    }
                    _ => {}
                }
                if matches!(ev, Event::Start(_)) {
                    stack.push(name);
                }
            }
            Event::Text(t) => {
                if let Some(p) = pending.as_mut() {
                    if p.text.is_empty() {
                        p.line = line;
                    }
                    p.text.push_str(&t);
                }
            }
            Event::CData(t) => {
                if let Some(p) = pending.as_mut() {
                    p.text.push_str(&t);
                }
            }
            Event::GeneralRef(_) if pending.as_ref().is_some_and(|p| p.role != Role::Ignored) => {
                return Err(ctx.err(line, "unexpected XML entity inside numeric data"));
            }
            Event::End(_) => {
                if stack.pop().as_deref() == Some("DataArray")
                    && let Some(p) = pending.take()
                {
                    finish(&ctx, p, &mut arrays)?;
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assemble(&ctx, counts, arrays)
}

fn finish(ctx: &Ctx, p: Pending, arrays: &mut Arrays) -> Result<()> {
    if p.role == Role::Ignored {
        return Ok(());
    }
    let line = p.line;
    let values = ctx.decode(&p)?;
    let slot = match p.role {
        Role::Points => &mut arrays.points,
        Role::Connectivity => &mut arrays.conn,
        Role::Offsets => &mut arrays.offsets,
        Role::Types => &mut arrays.types,
        Role::Fixed => {
            arrays.fixed = Some(values);
            return Ok(());
        }
        Role::Ignored => return Ok(()),
    };
    *slot = Some((values, line));
    Ok(())
}

fn assemble(ctx: &Ctx, counts: Option<(usize, usize)>, a: Arrays) -> Result<RawMesh> {
    let missing = |what: &str| Error::parse(ctx.path, None, format!("missing {what}"));
    let (np, nc) = counts.ok_or_else(|| missing("<Piece> element (is this an UnstructuredGrid?)"))?;
    let (pts, pline) = a.points.ok_or_else(|| missing("<Points> DataArray"))?;
    let (conn, cline) = a.conn.ok_or_else(|| missing("Cells DataArray 'connectivity'"))?;
    let (offs, oline) = a.offsets.ok_or_else(|| missing("Cells DataArray 'offsets'"))?;
    let (types, tline) = a.types.ok_or_else(|| missing("Cells DataArray 'types'"))?;
    let count_err = |line: usize, what: &str, want: usize, got: usize| {
        ctx.err(line, format!("{what}: expected {want} values, found {got}"))
    };
    if pts.len() != 3 * np {
        return Err(count_err(pline, "Points", 3 * np, pts.len()));
    }
    if offs.len() != nc {
        return Err(count_err(oline, "offsets", nc, offs.len()));
    }
    if types.len() != nc {
        return Err(count_err(tline, "types", nc, types.len()));
    }
    let mut raw = RawMesh::default();
    for (i, p) in pts.chunks_exact(3).enumerate() {
        if p.iter().any(|c| !c.is_finite()) {
            return Err(ctx.err(pline, format!("point {i} has a non-finite coordinate {p:?}")));
        }
        raw.points.push([p[0], p[1], p[2]]);
    }
    let mut start = 0;
    let mut ids = Vec::new();
    for e in 0..nc {
        let end = as_index(offs[e], conn.len() + 1)
            .filter(|&o| o >= start)
            .ok_or_else(|| {
                ctx.err(
                    oline,
                    format!(
                        "offset {e} is {}; offsets must increase up to the connectivity size {}",
                        offs[e],
                        conn.len()
                    ),
                )
            })?;
        ids.clear();
        for &v in &conn[start..end] {
            ids.push(as_index(v, np).ok_or_else(|| {
                ctx.err(
                    cline,
                    format!("element {e} refers to vertex {v}, but the file has {np} points"),
                )
            })? as u32);
        }
        let t = types[e] as i64;
        let shape = vtk_shape(e, t).map_err(|m| ctx.err(tline, m))?;
        if ids.len() != shape.num_vertices() {
            return Err(ctx.err(
                tline,
                format!(
                    "element {e} is a {} (VTK type {t}) but has {} vertices instead of {}",
                    vtk_type_name(t),
                    ids.len(),
                    shape.num_vertices()
                ),
            ));
        }
        raw.push(shape, &super::vtk_order(shape.kind(), &ids));
        start = end;
    }
    if let Some(f) = a.fixed {
        if f.len() != np {
            return Err(Error::parse(
                ctx.path,
                None,
                format!("PointData 'fixed' has {} values for {np} points", f.len()),
            ));
        }
        for (v, _) in f.iter().enumerate().filter(|(_, x)| **x != 0.0) {
            raw.fix(v);
        }
    }
    Ok(raw)
}

/// Escape an attribute value.
fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

struct Out<'w> {
    w: &'w mut dyn Write,
    binary: bool,
}

impl Out<'_> {
    /// One DataArray; `bytes` is the little-endian payload, `text` the ASCII form.
    fn array(
        &mut self,
        ty: &str,
        name: &str,
        ncomp: usize,
        bytes: impl FnOnce() -> Vec<u8>,
        text: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> WriteResult {
        let fmt = if self.binary { "binary" } else { "ascii" };
        writeln!(
            self.w,
            "        <DataArray type=\"{ty}\" Name=\"{}\" NumberOfComponents=\"{ncomp}\" format=\"{fmt}\">",
            xml_attr(name)
        )?;
        if self.binary {
            let data = bytes();
            let header = (data.len() as u64).to_le_bytes();
            writeln!(self.w, "{}{}", B64.encode(header), B64.encode(&data))?;
        } else {
            text(self.w)?;
        }
        writeln!(self.w, "        </DataArray>")?;
        Ok(())
    }
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    let ne = mesh.num_elements();
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(w, "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{ne}\">")?;
    let mut o = Out { w, binary };
    if !mesh.fixed.is_empty() {
        writeln!(o.w, "      <PointData Scalars=\"fixed\">")?;
        o.array(
            "Int32",
            "fixed",
            1,
            || mesh.fixed.iter().flat_map(|&f| (f as i32).to_le_bytes()).collect(),
            |w| {
                for &f in &mesh.fixed {
                    writeln!(w, "{}", f as i32)?;
                }
                Ok(())
            },
        )?;
        writeln!(o.w, "      </PointData>")?;
    }
    writeln!(o.w, "      <Points>")?;
    o.array(
        "Float64",
        "Points",
        3,
        || mesh.points.iter().flatten().flat_map(|c| c.to_le_bytes()).collect(),
        |w| {
            for p in &mesh.points {
                writeln!(w, "{} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
            }
            Ok(())
        },
    )?;
    writeln!(o.w, "      </Points>")?;
    writeln!(o.w, "      <Cells>")?;
    o.array(
        "Int64",
        "connectivity",
        1,
        || {
            (0..ne)
                .flat_map(|e| super::vtk_order(Some(mesh.kinds[e]), mesh.element(e)).into_owned())
                .flat_map(|v| (v as i64).to_le_bytes())
                .collect()
        },
        |w| {
            for e in 0..ne {
                let vs: Vec<String> = super::vtk_order(Some(mesh.kinds[e]), mesh.element(e))
                    .iter()
                    .map(|v| v.to_string())
                    .collect();
                writeln!(w, "{}", vs.join(" "))?;
            }
            Ok(())
        },
    )?;
    o.array(
        "Int64",
        "offsets",
        1,
        || {
            mesh.offsets[1..]
                .iter()
                .flat_map(|&x| (x as i64).to_le_bytes())
                .collect()
        },
        |w| {
            for x in &mesh.offsets[1..] {
                writeln!(w, "{x}")?;
            }
            Ok(())
        },
    )?;
    o.array(
        "UInt8",
        "types",
        1,
        || mesh.kinds.iter().map(|k| k.vtk_id()).collect(),
        |w| {
            for k in &mesh.kinds {
                writeln!(w, "{}", k.vtk_id())?;
            }
            Ok(())
        },
    )?;
    writeln!(o.w, "      </Cells>")?;
    check_cell_data(mesh, cell_data)?;
    if !cell_data.is_empty() {
        writeln!(o.w, "      <CellData>")?;
        for cd in cell_data {
            o.array(
                "Float64",
                cd.name,
                1,
                || cd.values.iter().flat_map(|v| v.to_le_bytes()).collect(),
                |w| {
                    for &v in cd.values {
                        writeln!(w, "{}", fmt_f64(v))?;
                    }
                    Ok(())
                },
            )?;
        }
        writeln!(o.w, "      </CellData>")?;
    }
    writeln!(o.w, "    </Piece>")?;
    writeln!(o.w, "  </UnstructuredGrid>")?;
    writeln!(o.w, "</VTKFile>")?;
    Ok(())
}
