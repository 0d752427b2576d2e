//! VTK XML unstructured grids (`.vtu`) and PolyData (`.vtp`), one Piece.
//!
//! Read: every mode VTK writes — ascii, inline binary (base64), appended raw
//! and appended base64 — uncompressed or with VTK's zlib, LZ4 or LZMA block
//! compression, UInt32 or UInt64 headers, either byte order, any integer
//! type for the cells. Point, cell and field arrays (numbers and strings)
//! are kept; `<InformationKey>` elements inside arrays are skipped. The XML
//! is streamed (linear in the file size) and must be complete: a file cut
//! anywhere is refused with the byte offset.
//!
//! A PolyData's `Verts`, `Lines` and `Polys` read as the cells of an
//! UnstructuredGrid in VTK's cell order (vertices, lines, polygons): single
//! vertices, segments, triangles and quadrilaterals; poly-vertices,
//! polylines, larger polygons and triangle strips are refused naming the
//! cell.
//!
//! Written: ascii, inline base64, or inline base64 with zlib blocks; a
//! PolyData ([`write_poly`]) as surfaces of triangles and quadrilaterals with
//! their boundary vertices and lines, its uncompressed base64 arrays each one
//! run over header and data as VTK writes them (VTK reads a PolyData's cell
//! arrays part by part from offsets into that run).

use std::io::Write;
use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD as B64;
use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;
use rayon::prelude::*;
use std::borrow::Cow;

use super::batch::write_pieces;
use super::codec::{B64Source, Codec, Layout, RawSource, Source, b64_encode, b64_values, zlib_blocks};
use super::lex::{Endian, NumVal, Scalar, as_index, clip, empty_values, push_val};
use super::limits::Budget;
use super::vtk::{vtk_shape, vtk_type_name};
use super::vtk_cells::{cell_types, lower_connectivity, out_cell_arrays};
use super::{CellData, RawMesh, Shape, WriteError, WriteResult, check_cell_data, fmt_f64};
use crate::error::{Error, Location, Result};
use crate::mesh::{DataArray, ElementKind, LowerKind, Mesh, ValueType, Values};

/// Element type of an XML array.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Ty {
    Num(Scalar),
    Str,
}

fn xml_type(name: &str) -> Option<Ty> {
    Some(Ty::Num(match name {
        "Int8" | "Char" => Scalar::I8,
        "UInt8" => Scalar::U8,
        "Int16" => Scalar::I16,
        "UInt16" => Scalar::U16,
        "Int32" => Scalar::I32,
        "UInt32" => Scalar::U32,
        "Int64" | "IdType" => Scalar::I64,
        "UInt64" => Scalar::U64,
        "Float32" => Scalar::F32,
        "Float64" => Scalar::F64,
        "String" => return Some(Ty::Str),
        _ => return None,
    }))
}

pub(crate) fn xml_type_name(t: ValueType) -> &'static str {
    match t {
        ValueType::I8 => "Int8",
        ValueType::U8 => "UInt8",
        ValueType::I16 => "Int16",
        ValueType::U16 => "UInt16",
        ValueType::I32 => "Int32",
        ValueType::U32 => "UInt32",
        ValueType::I64 => "Int64",
        ValueType::U64 => "UInt64",
        ValueType::F32 => "Float32",
        ValueType::F64 => "Float64",
        ValueType::Str => "String",
    }
}

/// Where an array sits in the file.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Section {
    Points,
    Cells,
    /// A PolyData's `Verts`, `Lines`, `Polys` or `Strips` (index into [`POLY_PARTS`]).
    Poly(usize),
    PointData,
    CellData,
    FieldData,
    Other,
}

/// A PolyData's cell sections, in its cells' order (VTK numbers them
/// vertices, lines, polygons, strips), with the `Piece` count of each.
const POLY_PARTS: [(&str, &str); 4] = [
    ("Verts", "NumberOfVerts"),
    ("Lines", "NumberOfLines"),
    ("Polys", "NumberOfPolys"),
    ("Strips", "NumberOfStrips"),
];

#[derive(Clone, Copy, PartialEq, Eq)]
enum Storage {
    Ascii,
    Binary,
    Appended(usize),
}

/// An array as declared by its tag, with its inline text once read.
struct Spec<'a> {
    section: Section,
    name: String,
    ty: Ty,
    components: usize,
    tuples: Option<usize>,
    storage: Storage,
    /// File offset of the tag.
    at: usize,
    /// File offset of the inline text.
    text_at: usize,
    /// Borrowed from the file when it comes in one piece (no copy of a
    /// large array's text).
    text: Cow<'a, str>,
}

/// A decoded array.
enum Decoded {
    Num(Scalar, Values),
    Str(Vec<String>),
}

struct Appended<'a> {
    raw: bool,
    data: &'a [u8],
    base: usize,
}

struct Ctx<'a> {
    path: &'a Path,
    layout: Layout,
    appended: Option<Appended<'a>>,
    counts: Option<(usize, usize)>,
    /// File offset of the `<Piece>` tag.
    piece_at: usize,
    /// A PolyData file's cell count of each of [`POLY_PARTS`] (`None`: an UnstructuredGrid).
    poly: Option<[usize; 4]>,
    budget: &'a Budget,
    /// The last offset, once the offsets are read: the connectivity's length.
    conn_len: std::cell::Cell<Option<usize>>,
}

impl Ctx<'_> {
    fn err(&self, at: usize, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Byte(at as u64)), msg)
    }

    /// Most values the array can hold: what its section implies, else what
    /// the file could encode.
    fn max_values(&self, s: &Spec<'_>, file_len: usize) -> usize {
        let k = s.components;
        let implied = match (s.section, self.counts) {
            (Section::Points | Section::PointData, Some((np, _))) => Some(np.saturating_mul(k)),
            (Section::CellData, Some((_, nc))) => Some(nc.saturating_mul(k)),
            // one value per cell (a leading 0 allowed in polyhedron_offsets);
            // connectivity and the face arrays are bounded by the file only
            (Section::Cells, Some((_, nc))) if matches!(s.name.as_str(), "offsets" | "types" | "faceoffsets") => {
                Some(nc)
            }
            (Section::Cells, Some((_, nc))) if s.name == "polyhedron_offsets" => Some(nc + 1),
            (Section::Cells, _) if s.name == "connectivity" => self.conn_len.get(),
            (Section::Poly(k), _) if s.name == "offsets" => self.poly.map(|c| c[k]),
            _ => None,
        };
        let implied = implied.or(s.tuples.map(|t| t.saturating_mul(k)));
        match (implied, s.ty) {
            (Some(n), Ty::Num(_)) => n,
            // strings and connectivity: bounded by what zlib could inflate the file to
            _ => file_len.saturating_mul(1100).saturating_add(1 << 16),
        }
    }

    fn decode(&self, s: &Spec<'_>, file_len: usize) -> Result<Decoded> {
        if s.storage == Storage::Ascii {
            return self.decode_ascii(s);
        }
        if let (Storage::Binary, Ty::Num(t)) = (s.storage, s.ty) {
            // past the budget: the byte path, which says so
            let max = self.max_values(s, file_len).min(self.budget.left() as usize / 8);
            let (text, e) = (s.text.as_bytes(), self.layout.endian);
            let fused = if t.is_float() {
                b64_values(&self.layout, text, max, t.size(), |c| t.get(e, c)).map(Values::Float)
            } else {
                b64_values(&self.layout, text, max, t.size(), |c| t.get_i64(e, c)).map(Values::Int)
            };
            if let Some(v) = fused {
                self.charge(s, v.len() as u64 * 8)?;
                return Ok(Decoded::Num(t, v));
            }
        }
        let bytes = self.payload(s, file_len)?;
        let out = match s.ty {
            Ty::Num(t) => {
                // decoded to 8-byte values: a UInt8 array grows eightfold
                self.charge(s, (bytes.len() / t.size()) as u64 * 8)?;
                Ok(Decoded::Num(t, t.decode_all(self.layout.endian, &bytes)))
            }
            Ty::Str => self.strings(s, &bytes),
        };
        self.budget.release(bytes.len() as u64);
        out
    }

    /// Takes `bytes` for array `s` from the budget.
    fn charge(&self, s: &Spec<'_>, bytes: u64) -> Result<()> {
        self.budget
            .charge(format_args!("{} '{}'", tag_name(s), clip(&s.name)), bytes)
            .map_err(|_| {
                self.err(
                    s.at,
                    self.budget
                        .over_msg(format_args!("{} '{}'", tag_name(s), clip(&s.name)), bytes),
                )
            })
    }

    /// A binary integer array's bytes as stored, not decoded (the
    /// connectivity goes straight to u32 from them); `None` for other arrays.
    fn raw_ints(&self, s: &Spec<'_>, file_len: usize) -> Result<Option<Ints>> {
        match s.ty {
            Ty::Num(t) if s.storage != Storage::Ascii && !t.is_float() => {
                if s.storage == Storage::Binary {
                    // ids that fit u32 (all but a broken file's) decoded
                    // straight to u32; u32::MAX marks one that does not
                    let e = self.layout.endian;
                    let max = self.max_values(s, file_len).min(self.budget.left() as usize / 4);
                    let narrow = |c: &[u8]| u32::try_from(t.get_i64(e, c)).unwrap_or(u32::MAX);
                    if let Some(ids) = b64_values(&self.layout, s.text.as_bytes(), max, t.size(), narrow)
                        && ids.par_iter().all(|&v| v != u32::MAX)
                    {
                        self.charge(s, ids.len() as u64 * 4)?;
                        return Ok(Some(Ints::U32(ids)));
                    }
                }
                Ok(Some(Ints::Raw(t, self.layout.endian, self.payload(s, file_len)?)))
            }
            _ => Ok(None),
        }
    }

    /// The bytes of a binary or appended array: a whole number of values.
    fn payload(&self, s: &Spec<'_>, file_len: usize) -> Result<Vec<u8>> {
        let at_err = |(at, m): (usize, String)| self.err(at, format!("{} '{}': {m}", tag_name(s), clip(&s.name)));
        let bytes = match s.storage {
            Storage::Ascii => unreachable!("ascii arrays are parsed as text"),
            Storage::Binary => {
                let max = self.max_values(s, file_len).saturating_mul(elem_size(s.ty));
                let mut src = B64Source::new(s.text.as_bytes(), 0, s.text_at);
                let b = self.layout.read(&mut src, max, self.budget).map_err(at_err)?;
                // nothing but padding or whitespace may follow
                b
            }
            Storage::Appended(offset) => {
                let Some(app) = &self.appended else {
                    return Err(self.err(
                        s.at,
                        format!(
                            "{} '{}' is appended but the file has no <AppendedData>",
                            tag_name(s),
                            clip(&s.name)
                        ),
                    ));
                };
                if offset > app.data.len() {
                    return Err(self.err(
                        s.at,
                        format!(
                            "{} '{}': offset {offset} is past the end of the appended data ({} bytes; truncated file?)",
                            tag_name(s),
                            clip(&s.name),
                            app.data.len()
                        ),
                    ));
                }
                let max = self.max_values(s, file_len).saturating_mul(elem_size(s.ty));
                let mut src: Box<dyn Source> = if app.raw {
                    Box::new(RawSource {
                        data: app.data,
                        pos: offset,
                        base: app.base,
                    })
                } else {
                    Box::new(B64Source::new(app.data, offset, app.base))
                };
                self.layout.read(src.as_mut(), max, self.budget).map_err(at_err)?
            }
        };
        if let Ty::Num(t) = s.ty
            && bytes.len() % t.size() != 0
        {
            return Err(self.err(
                s.at,
                format!(
                    "DataArray '{}': {} bytes is not a whole number of {}-byte values",
                    clip(&s.name),
                    bytes.len(),
                    t.size()
                ),
            ));
        }
        Ok(bytes)
    }

    fn decode_ascii(&self, s: &Spec<'_>) -> Result<Decoded> {
        let text = s.text.as_bytes();
        // a value takes a character and a separator
        let room = text.len() / 2 + 1;
        if let Some(n) = s.tuples
            && n.saturating_mul(s.components) > room
        {
            return Err(self.err(
                s.at,
                format!(
                    "{} '{}' declares {} values (NumberOfTuples {n} x {} components), its {} characters of text hold at most {room}",
                    tag_name(s),
                    clip(&s.name),
                    n.saturating_mul(s.components),
                    s.components,
                    text.len()
                ),
            ));
        }
        let mut i = 0;
        let mut tokens = std::iter::from_fn(|| {
            while i < text.len() && text[i].is_ascii_whitespace() {
                i += 1;
            }
            if i >= text.len() {
                return None;
            }
            let start = i;
            while i < text.len() && !text[i].is_ascii_whitespace() {
                i += 1;
            }
            Some((start, &s.text[start..i]))
        });
        match s.ty {
            Ty::Num(t) => {
                let mut out = empty_values(t, 0);
                for (pos, tok) in tokens.by_ref() {
                    let v = t.parse_text(tok).ok_or_else(|| {
                        self.err(
                            s.text_at + pos,
                            format!(
                                "expected a number in DataArray '{}', found '{}'",
                                clip(&s.name),
                                clip(tok)
                            ),
                        )
                    })?;
                    push_val(&mut out, v);
                }
                // bounded by the text, which the file's bytes paid for
                self.charge(s, out.len() as u64 * 8)?;
                Ok(Decoded::Num(t, out))
            }
            Ty::Str => {
                let mut bytes = Vec::new();
                for (pos, tok) in tokens.by_ref() {
                    match Scalar::U8.parse_text(tok) {
                        Some(NumVal::I(b)) if (0..256).contains(&b) => bytes.push(b as u8),
                        _ => {
                            return Err(self.err(
                                s.text_at + pos,
                                format!(
                                    "expected a character code in Array '{}', found '{}'",
                                    clip(&s.name),
                                    clip(tok)
                                ),
                            ));
                        }
                    }
                }
                self.strings(s, &bytes)
            }
        }
    }

    /// VTK stores a string array as its strings, each followed by a NUL.
    fn strings(&self, s: &Spec<'_>, bytes: &[u8]) -> Result<Decoded> {
        // a million NULs would be a million Strings of 24 bytes each:
        // counted and checked before any is made
        let count = memchr::memchr_iter(0, bytes).count() + usize::from(bytes.last().is_some_and(|&b| b != 0));
        if let Some(n) = s.tuples {
            let want = n.saturating_mul(s.components);
            if count != want {
                return Err(self.err(
                    s.at,
                    format!(
                        "Array '{}' has {count} strings, NumberOfTuples says {want}",
                        clip(&s.name)
                    ),
                ));
            }
        }
        self.charge(
            s,
            count as u64 * std::mem::size_of::<String>() as u64 + bytes.len() as u64,
        )?;
        let mut out = Vec::with_capacity(count);
        let mut rest = bytes;
        while !rest.is_empty() {
            let end = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
            out.push(String::from_utf8_lossy(&rest[..end]).into_owned());
            rest = rest.get(end + 1..).unwrap_or(&[]);
        }
        if let Some(n) = s.tuples {
            let want = n.saturating_mul(s.components);
            if out.len() != want {
                return Err(self.err(
                    s.at,
                    format!(
                        "Array '{}' has {} strings, NumberOfTuples says {want}",
                        clip(&s.name),
                        out.len()
                    ),
                ));
            }
        }
        Ok(Decoded::Str(out))
    }
}

fn elem_size(t: Ty) -> usize {
    match t {
        Ty::Num(s) => s.size(),
        Ty::Str => 1,
    }
}

fn tag_name(s: &Spec<'_>) -> &'static str {
    if s.ty == Ty::Str { "Array" } else { "DataArray" }
}

pub(crate) fn attr(e: &BytesStart, key: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.local_name().as_ref() == key)
        .map(|a| {
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map(|v| v.into_owned())
                .unwrap_or_default()
        })
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    // vectorised: a plain scan of a gigabyte file took longer than decoding it
    memchr::memmem::find(hay, needle)
}

fn rfind(hay: &[u8], needle: &[u8]) -> Option<usize> {
    memchr::memmem::rfind(hay, needle)
}

/// Split off `<AppendedData>`: its payload is binary (raw) and no XML parser
/// may look at it. Returns the length of the XML part.
fn split_appended<'a>(path: &Path, data: &'a [u8]) -> Result<(usize, Option<Appended<'a>>)> {
    let Some(ap) = find(data, b"<AppendedData") else {
        return Ok((data.len(), None));
    };
    let err = |at: usize, m: String| Error::parse(path, Some(Location::Byte(at as u64)), m);
    let gt = data[ap..]
        .iter()
        .position(|&b| b == b'>')
        .map(|i| ap + i)
        .ok_or_else(|| {
            err(
                data.len(),
                "the file ends inside the <AppendedData> tag (truncated)".into(),
            )
        })?;
    let tag = std::str::from_utf8(&data[ap + 1..gt]).map_err(|_| err(ap, "<AppendedData> tag is not text".into()))?;
    let start = BytesStart::from_content(tag, "AppendedData".len());
    let encoding = attr(&start, "encoding").unwrap_or_else(|| "raw".into());
    let raw = match encoding.as_str() {
        "raw" => true,
        "base64" => false,
        e => {
            return Err(err(
                ap,
                format!("<AppendedData> encoding '{}' is not raw or base64", clip(e)),
            ));
        }
    };
    let mut u = gt + 1;
    while u < data.len() && data[u].is_ascii_whitespace() {
        u += 1;
    }
    if data.get(u) != Some(&b'_') {
        return Err(err(u, "<AppendedData> must start with '_'".into()));
    }
    u += 1;
    let end = rfind(&data[u..], b"</AppendedData>").map(|i| u + i).ok_or_else(|| {
        err(
            data.len(),
            format!(
                "the file ends inside <AppendedData> (no </AppendedData>; truncated at byte {})",
                data.len()
            ),
        )
    })?;
    let tail = std::str::from_utf8(&data[end + "</AppendedData>".len()..]).unwrap_or("");
    if tail.trim() != "</VTKFile>" {
        return Err(err(
            end,
            format!(
                "expected </VTKFile> after </AppendedData>, found '{}' (truncated file?)",
                clip(tail.trim())
            ),
        ));
    }
    Ok((
        ap,
        Some(Appended {
            raw,
            data: &data[u..end],
            base: u,
        }),
    ))
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let (xml_len, appended) = split_appended(path, data)?;
    let text = std::str::from_utf8(&data[..xml_len]).map_err(|e| {
        Error::parse(
            path,
            Some(Location::Byte(e.valid_up_to() as u64)),
            "not valid UTF-8 text (is this really a .vtu file?)",
        )
    })?;
    let mut ctx = Ctx {
        path,
        layout: Layout {
            header: Scalar::U32,
            endian: Endian::Little,
            codec: None,
        },
        appended,
        counts: None,
        piece_at: 0,
        poly: None,
        budget,
        conn_len: std::cell::Cell::new(None),
    };
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<String> = Vec::new();
    let mut pending: Option<Spec> = None;
    let mut specs: Vec<Spec> = Vec::new();
    let mut seen_root = false;
    loop {
        let tag_pos = reader.buffer_position() as usize;
        let ev = reader.read_event().map_err(|e| {
            ctx.err(
                reader.error_position() as usize,
                format!("malformed XML: {}", clip(&e.to_string())),
            )
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = e.local_name().as_ref().to_string();
                let parent = stack.last().map(String::as_str).unwrap_or("");
                if stack.is_empty() && (name != "VTKFile" || seen_root) {
                    return Err(ctx.err(tag_pos, format!("expected <VTKFile>, found <{}>", clip(&name))));
                }
                match name.as_str() {
                    "VTKFile" => {
                        seen_root = true;
                        vtkfile(&mut ctx, e, tag_pos)?;
                    }
                    "Piece" => {
                        if ctx.counts.is_some() {
                            return Err(ctx.err(tag_pos, "files with several Pieces are not supported"));
                        }
                        let num = |k: &str| {
                            let v = attr(e, k).unwrap_or_default();
                            v.trim().parse::<usize>().map_err(|_| {
                                ctx.err(tag_pos, format!("Piece: {k} must be a count, found '{}'", clip(&v)))
                            })
                        };
                        let np = num("NumberOfPoints")?;
                        let nc = if ctx.poly.is_some() {
                            let mut c = [0; 4];
                            for (k, (_, key)) in POLY_PARTS.iter().enumerate() {
                                c[k] = if attr(e, key).is_some() { num(key)? } else { 0 };
                            }
                            ctx.poly = Some(c);
                            c.iter().fold(0usize, |a, &b| a.saturating_add(b))
                        } else {
                            num("NumberOfCells")?
                        };
                        // coordinates, and an offset, a type and a vertex per cell
                        let least = (np as u64)
                            .saturating_mul(24)
                            .saturating_add((nc as u64).saturating_mul(20));
                        if least > ctx.budget.left() {
                            return Err(ctx.err(
                                tag_pos,
                                ctx.budget
                                    .over_msg(format_args!("Piece: {np} points and {nc} cells"), least),
                            ));
                        }
                        ctx.counts = Some((np, nc));
                        ctx.piece_at = tag_pos;
                    }
                    "DataArray" | "Array" if pending.is_none() => {
                        let section = match parent {
                            "Points" => Section::Points,
                            // a PolyData's cells are in its Verts, Lines, Polys and Strips
                            "Cells" if ctx.poly.is_none() => Section::Cells,
                            p if ctx.poly.is_some() && POLY_PARTS.iter().any(|(n, _)| *n == p) => {
                                Section::Poly(POLY_PARTS.iter().position(|(n, _)| *n == p).unwrap_or(0))
                            }
                            "PointData" => Section::PointData,
                            "CellData" => Section::CellData,
                            "FieldData" => Section::FieldData,
                            _ => Section::Other,
                        };
                        let spec = array_spec(&ctx, e, section, tag_pos)?;
                        if matches!(ev, Event::Empty(_)) {
                            specs.push(spec);
                        } else {
                            pending = Some(spec);
                        }
                    }
                    _ => {}
                }
                if matches!(ev, Event::Start(_)) {
                    stack.push(name);
                }
            }
            Event::Text(t) => {
                // text of the array itself, not of an <InformationKey> inside it
                if let Some(p) = pending.as_mut()
                    && matches!(stack.last().map(String::as_str), Some("DataArray" | "Array"))
                {
                    if p.text.trim().is_empty() {
                        p.text = Cow::Borrowed("");
                        p.text_at = tag_pos;
                    }
                    if p.text.is_empty() {
                        p.text = t.into_inner();
                    } else {
                        p.text.to_mut().push_str(&t);
                    }
                }
            }
            Event::CData(t) => {
                if let Some(p) = pending.as_mut()
                    && matches!(stack.last().map(String::as_str), Some("DataArray" | "Array"))
                {
                    p.text.to_mut().push_str(&t);
                }
            }
            Event::GeneralRef(_) if pending.is_some() => {
                return Err(ctx.err(tag_pos, "unexpected XML entity inside array data"));
            }
            Event::End(_) => {
                let closed = stack.pop();
                if matches!(closed.as_deref(), Some("DataArray" | "Array"))
                    && !matches!(stack.last().map(String::as_str), Some("DataArray" | "Array"))
                    && let Some(p) = pending.take()
                {
                    specs.push(p);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    // With appended data, the XML part ends inside <VTKFile> (the rest was checked
    // by split_appended); without, every element must be closed.
    let open: Vec<&str> = stack.iter().map(String::as_str).collect();
    let complete = if ctx.appended.is_some() {
        open == ["VTKFile"]
    } else {
        open.is_empty() && seen_root
    };
    if !complete {
        let what = match open.last() {
            Some(t) => format!("<{}> is not closed", clip(t)),
            None => "no <VTKFile> element".into(),
        };
        return Err(ctx.err(
            xml_len,
            format!("the file ends at byte {xml_len} but {what} (truncated file?)"),
        ));
    }
    assemble(&ctx, specs, data.len())
}

fn vtkfile(ctx: &mut Ctx, e: &BytesStart, at: usize) -> Result<()> {
    match attr(e, "type").as_deref() {
        None | Some("UnstructuredGrid") => {}
        Some("PolyData") => ctx.poly = Some([0; 4]),
        Some(t) => {
            return Err(ctx.err(
                at,
                format!(
                    "VTKFile type '{}' is not supported; UnstructuredGrid (.vtu) and PolyData (.vtp) are",
                    clip(t)
                ),
            ));
        }
    }
    if let Some(c) = attr(e, "compressor")
        && !c.is_empty()
    {
        ctx.layout.codec = Some(Codec::from_vtk(&c).ok_or_else(|| {
            ctx.err(
                at,
                format!(
                    "compressor '{}' is not supported (vtkZLibDataCompressor, vtkLZ4DataCompressor, vtkLZMADataCompressor are)",
                    clip(&c)
                ),
            )
        })?);
    }
    match attr(e, "byte_order").as_deref() {
        None | Some("LittleEndian") => ctx.layout.endian = Endian::Little,
        Some("BigEndian") => ctx.layout.endian = Endian::Big,
        Some(b) => return Err(ctx.err(at, format!("byte_order '{}' is not LittleEndian or BigEndian", clip(b)))),
    }
    if let Some(h) = attr(e, "header_type") {
        ctx.layout.header = match h.as_str() {
            "UInt32" => Scalar::U32,
            "UInt64" => Scalar::U64,
            _ => {
                return Err(ctx.err(
                    at,
                    format!("header_type '{}' is not supported (UInt32 or UInt64)", clip(&h)),
                ));
            }
        };
    }
    Ok(())
}

fn array_spec(ctx: &Ctx, e: &BytesStart, section: Section, at: usize) -> Result<Spec<'static>> {
    let name = attr(e, "Name").unwrap_or_default();
    let tyname = attr(e, "type").unwrap_or_default();
    let ty = xml_type(&tyname).ok_or_else(|| {
        ctx.err(
            at,
            format!("DataArray '{}': unsupported type '{}'", clip(&name), clip(&tyname)),
        )
    })?;
    let count = |k: &str| -> Result<Option<usize>> {
        match attr(e, k) {
            None => Ok(None),
            Some(v) => v.trim().parse::<usize>().map(Some).map_err(|_| {
                ctx.err(
                    at,
                    format!("DataArray '{}': {k} must be a count, found '{}'", clip(&name), clip(&v)),
                )
            }),
        }
    };
    let components = count("NumberOfComponents")?.unwrap_or(1);
    if components == 0 {
        return Err(ctx.err(at, format!("DataArray '{}': NumberOfComponents is 0", clip(&name))));
    }
    let tuples = count("NumberOfTuples")?;
    let storage = match attr(e, "format").as_deref().unwrap_or("ascii") {
        "ascii" => Storage::Ascii,
        "binary" => Storage::Binary,
        "appended" => Storage::Appended(
            count("offset")?
                .ok_or_else(|| ctx.err(at, format!("DataArray '{}': appended without an offset", clip(&name))))?,
        ),
        f => {
            return Err(ctx.err(at, format!("DataArray '{}': unknown format '{}'", clip(&name), clip(f))));
        }
    };
    if section == Section::Points && components != 3 {
        return Err(ctx.err(
            at,
            format!("Points must have NumberOfComponents=\"3\", found \"{components}\""),
        ));
    }
    Ok(Spec {
        section,
        name,
        ty,
        components,
        tuples,
        storage,
        at,
        text_at: at,
        text: Cow::Borrowed(""),
    })
}

fn data_array(s: &Spec<'_>, d: Decoded) -> DataArray {
    match d {
        Decoded::Num(t, v) => DataArray::new(s.name.clone(), t.value_type(), s.components, v),
        Decoded::Str(v) => DataArray::new(s.name.clone(), ValueType::Str, s.components, Values::Str(v)),
    }
}

/// `a`, read from `s`, if it has a tuple for each of the `want` points or cells.
fn sized(ctx: &Ctx, s: &Spec<'_>, a: DataArray, want: usize, what: &str) -> Result<DataArray> {
    if a.values.len() == want.saturating_mul(a.components) {
        return Ok(a);
    }
    Err(ctx.err(
        s.at,
        format!(
            "array '{}' has {} values, expected {} ({want} {what} x {} components)",
            clip(&a.name),
            a.values.len(),
            want.saturating_mul(a.components),
            a.components
        ),
    ))
}

fn numbers(ctx: &Ctx, s: &Spec<'_>, d: Decoded) -> Result<Vec<f64>> {
    match d {
        Decoded::Num(_, Values::Int(v)) => Ok(v.into_iter().map(|x| x as f64).collect()),
        Decoded::Num(_, Values::Float(v)) => Ok(v),
        _ => Err(ctx.err(s.at, format!("'{}' must hold numbers, not strings", clip(&s.name)))),
    }
}

fn assemble(ctx: &Ctx, specs: Vec<Spec<'_>>, file_len: usize) -> Result<RawMesh> {
    let missing = |what: &str| Error::parse(ctx.path, None, format!("missing {what}"));
    let (np, nc) = ctx
        .counts
        .ok_or_else(|| missing("<Piece> element (is this an UnstructuredGrid?)"))?;
    let mut raw = RawMesh::default();
    let (mut pts, mut conn, mut offs, mut types) = (None, None, None, None);
    let mut fixed = None;
    let mut poly = PolyArrays::default();
    // the offsets first: their last one is the connectivity's length, which
    // then bounds what its header may declare
    let offsets_first = |s: &&Spec<'_>| !(s.section == Section::Cells && s.name == "offsets");
    let mut order: Vec<&Spec<'_>> = specs.iter().collect();
    order.sort_by_key(offsets_first);
    if let Some(counts) = ctx.poly {
        let (c, o, t) = poly_cells(ctx, &specs, counts, file_len)?;
        (conn, offs, types) = (Some(c), Some(o), Some(t));
    }
    for s in order {
        if matches!(s.section, Section::Other | Section::Poly(_)) {
            continue; // arrays outside the grid: not ours; a PolyData's cells: read above
        }
        if s.section == Section::Cells
            && s.name == "connectivity"
            && let Some(raw_conn) = ctx.raw_ints(s, file_len)?
        {
            conn = Some((raw_conn, s.at));
            continue;
        }
        let d = ctx.decode(s, file_len)?;
        match s.section {
            Section::Points => pts = Some((numbers(ctx, s, d)?, s.at)),
            Section::Cells => {
                let main = match s.name.as_str() {
                    "connectivity" => Some(&mut conn),
                    "offsets" => Some(&mut offs),
                    "types" => Some(&mut types),
                    _ => None,
                };
                if let Some(slot) = main {
                    if s.name == "offsets"
                        && let Decoded::Num(_, Values::Int(v)) = &d
                        && let Some(n) = v.last().map_or(Some(0), |&o| usize::try_from(o).ok())
                    {
                        ctx.conn_len.set(Some(n));
                    }
                    *slot = Some((
                        match d {
                            Decoded::Num(_, Values::Int(v)) => Ints::I(v),
                            d => Ints::F(numbers(ctx, s, d)?),
                        },
                        s.at,
                    ));
                    continue;
                }
                let slot = match s.name.as_str() {
                    "faces" => &mut poly.faces,
                    "faceoffsets" => &mut poly.faceoffsets,
                    "face_connectivity" => &mut poly.face_connectivity,
                    "face_offsets" => &mut poly.face_offsets,
                    "polyhedron_to_faces" => &mut poly.polyhedron_to_faces,
                    "polyhedron_offsets" => &mut poly.polyhedron_offsets,
                    _ => continue,
                };
                *slot = Some((numbers(ctx, s, d)?, s.at));
            }
            Section::PointData if s.name == "fixed" && s.components == 1 && s.ty != Ty::Str => {
                fixed = Some((numbers(ctx, s, d)?, s.at));
            }
            Section::PointData => raw.point_data.push(sized(ctx, s, data_array(s, d), np, "points")?),
            Section::CellData => raw.cell_data.push(sized(ctx, s, data_array(s, d), nc, "cells")?),
            Section::FieldData => raw.field_data.push(data_array(s, d)),
            Section::Other | Section::Poly(_) => {}
        }
    }
    let (pts, pat) = pts.ok_or_else(|| missing("<Points> DataArray"))?;
    let (mut conn, cat) = conn.ok_or_else(|| missing("Cells DataArray 'connectivity'"))?;
    let (offs, oat) = offs.ok_or_else(|| missing("Cells DataArray 'offsets'"))?;
    let (types, tat) = types.ok_or_else(|| missing("Cells DataArray 'types'"))?;
    let count_err = |at: usize, what: &str, want: usize, got: usize| {
        ctx.err(at, format!("{what}: expected {want} values, found {got}"))
    };
    if pts.len() != 3 * np {
        return Err(count_err(pat, "Points", 3 * np, pts.len()));
    }
    if offs.len() != nc {
        return Err(count_err(oat, "offsets", nc, offs.len()));
    }
    if types.len() != nc {
        return Err(count_err(tat, "types", nc, types.len()));
    }
    if pts.par_iter().all(|c| c.is_finite()) {
        raw.points = pts.par_chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    } else {
        for (i, p) in pts.chunks_exact(3).enumerate() {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(ctx.err(pat, format!("point {i} has a non-finite coordinate {p:?}")));
            }
        }
    }
    let fast = match (&mut conn, &offs, &types) {
        (c @ (Ints::I(_) | Ints::Raw(..) | Ints::U32(_)), Ints::I(o), Ints::I(t)) => fast_cells(c, o, t, np),
        _ => None,
    };
    if let Some((shapes, offsets, ids)) = fast {
        raw.shapes = shapes;
        raw.offsets = offsets;
        raw.conn = ids;
    } else {
        slow_cells(
            ctx,
            &mut raw,
            poly,
            conn.into_f64(),
            (offs.into_f64(), oat),
            (types.into_f64(), tat),
            (cat, np),
        )?;
    }
    if let Some((f, fat)) = fixed {
        if f.len() != np {
            return Err(ctx.err(fat, format!("PointData 'fixed' has {} values for {np} points", f.len())));
        }
        for (v, _) in f.iter().enumerate().filter(|(_, x)| **x != 0.0) {
            raw.fix(v);
        }
    }
    Ok(raw)
}

/// An array with the file offset it is located at.
type Located = (Ints, usize);

/// A PolyData's cells as an UnstructuredGrid's connectivity, offsets and
/// types, located at the first cell section's connectivity: its vertices,
/// lines and polygons in VTK's cell order (vertices, lines, polygons,
/// strips). Each cell is checked here, its errors located at its own
/// section and naming it by its cell number and its place in the section:
/// a vertex id past the points, a poly-vertex, a polyline, a polygon of
/// more than four sides and any triangle strip are refused.
fn poly_cells(
    ctx: &Ctx,
    specs: &[Spec<'_>],
    counts: [usize; 4],
    file_len: usize,
) -> Result<(Located, Located, Located)> {
    let np = ctx.counts.map_or(0, |(np, _)| np);
    let (mut conn, mut offs, mut types) = (Vec::new(), Vec::new(), Vec::new());
    let mut at = None;
    let mut first = 0;
    for (k, (part, key)) in POLY_PARTS.iter().enumerate() {
        let count = counts[k];
        if count == 0 {
            continue;
        }
        let get = |name: &str| {
            specs
                .iter()
                .find(|s| s.section == Section::Poly(k) && s.name == name)
                .ok_or_else(|| {
                    ctx.err(
                        ctx.piece_at,
                        format!("missing {part} DataArray '{name}' ({key} is {count})"),
                    )
                })
        };
        let (cs, os) = (get("connectivity")?, get("offsets")?);
        if k == 3 {
            return Err(ctx.err(
                cs.at,
                format!(
                    "cell {first} (Strips 0) is a triangle strip, one of {count} ({key}): strips are not supported \
                     (split them into triangles, e.g. with vtkTriangleFilter)"
                ),
            ));
        }
        at.get_or_insert(cs.at);
        let c = ids(ctx, cs, ctx.decode(cs, file_len)?)?;
        let o = ids(ctx, os, ctx.decode(os, file_len)?)?;
        if o.len() != count {
            return Err(ctx.err(
                os.at,
                format!("{part} offsets: expected {count} values ({key}), found {}", o.len()),
            ));
        }
        let mut start = 0usize;
        for (i, &end) in o.iter().enumerate() {
            let cell = first + i;
            let end = usize::try_from(end)
                .ok()
                .filter(|&e| e >= start && e <= c.len())
                .ok_or_else(|| {
                    ctx.err(
                        os.at,
                        format!(
                            "{part} offset {i} is {end}; offsets must increase up to the connectivity size {}",
                            c.len()
                        ),
                    )
                })?;
            let n = end - start;
            let what = |m: String| ctx.err(os.at, format!("cell {cell} ({part} {i}) is {m}"));
            let t = match (k, n) {
                (0, 1) => 1,
                (1, 2) => 3,
                (2, 3) => 5,
                (2, 4) => 9,
                (0, _) => {
                    return Err(what(format!(
                        "a poly-vertex of {n} points: only single vertices are supported"
                    )));
                }
                (1, _) => {
                    return Err(what(format!(
                        "a polyline of {n} points: only single segments are supported"
                    )));
                }
                _ => {
                    return Err(what(format!(
                        "a polygon of {n} vertices: triangles and quadrilaterals are supported"
                    )));
                }
            };
            let vs = &c[start..end];
            if let Some(&v) = vs.iter().find(|&&v| usize::try_from(v).map_or(true, |v| v >= np)) {
                return Err(ctx.err(
                    cs.at,
                    format!("cell {cell} ({part} {i}) refers to vertex {v}, but the file has {np} points"),
                ));
            }
            conn.extend_from_slice(vs);
            offs.push(conn.len() as i64);
            types.push(t);
            start = end;
        }
        first += count;
    }
    let at = at.unwrap_or(0);
    Ok(((Ints::I(conn), at), (Ints::I(offs), at), (Ints::I(types), at)))
}

/// A cell array's values as integers: a float array's must be whole.
fn ids(ctx: &Ctx, s: &Spec<'_>, d: Decoded) -> Result<Vec<i64>> {
    match d {
        Decoded::Num(_, Values::Int(v)) => Ok(v),
        Decoded::Num(_, Values::Float(v)) => v
            .into_iter()
            .map(|x| {
                // whole and within i64 (NaN fails both)
                if x.fract() == 0.0 && x.abs() < 9.0e18 {
                    Ok(x as i64)
                } else {
                    Err(ctx.err(
                        s.at,
                        format!("'{}' holds {x}, which is not a whole number", clip(&s.name)),
                    ))
                }
            })
            .collect(),
        _ => Err(ctx.err(s.at, format!("'{}' must hold numbers, not strings", clip(&s.name)))),
    }
}

/// Connectivity, offsets or types as read: integers stay integers (a
/// 10M-tet file has 40M connectivity values, and a round trip through f64
/// cost a pass and a copy).
enum Ints {
    I(Vec<i64>),
    F(Vec<f64>),
    /// Binary integers as stored (a whole number of values): the
    /// connectivity, converted once, straight to u32, by [`fast_cells`].
    Raw(Scalar, Endian, Vec<u8>),
    /// Binary integers decoded straight to u32 (every one fitted).
    U32(Vec<u32>),
}

impl Ints {
    fn len(&self) -> usize {
        match self {
            Ints::I(v) => v.len(),
            Ints::F(v) => v.len(),
            Ints::Raw(t, _, b) => b.len() / t.size(),
            Ints::U32(v) => v.len(),
        }
    }

    fn into_f64(self) -> Vec<f64> {
        match self {
            Ints::I(v) => v.into_par_iter().map(|x| x as f64).collect(),
            Ints::F(v) => v,
            Ints::U32(v) => v.into_par_iter().map(|x| x as f64).collect(),
            Ints::Raw(t, e, b) => {
                let s = t.size();
                b.par_chunks_exact(s).map(|c| t.get_i64(e, c) as f64).collect()
            }
        }
    }
}

/// Cells without polyhedra whose arrays are all valid, checked and
/// converted in parallel: shapes, offsets (with the leading 0) and vertex
/// ids. `None` for anything else; [`slow_cells`] then builds the cells, or
/// names the first bad one, exactly as it always has.
fn fast_cells(conn: &mut Ints, offs: &[i64], types: &[i64], np: usize) -> Option<(Vec<Shape>, Vec<usize>, Vec<u32>)> {
    let mut table: ShapeTable = [None; 256];
    for (t, slot) in table.iter_mut().enumerate() {
        *slot = vtk_shape(0, t as i64)
            .ok()
            .filter(|s| *s != Shape::Elem(ElementKind::Polyhedron))
            .map(|s| (s, s.num_vertices()));
    }
    let len = conn.len() as i64;
    let ok = (0..offs.len()).into_par_iter().with_min_len(1 << 14).all(|e| {
        let start = if e == 0 { 0 } else { offs[e - 1] };
        let end = offs[e];
        let fits = usize::try_from(types[e])
            .ok()
            .and_then(|t| table.get(t).copied().flatten())
            .is_some_and(|(_, nv)| end - start == nv as i64);
        start >= 0 && end >= start && end <= len && fits
    });
    if !ok {
        return None;
    }
    let used = offs.last().map_or(0, |&o| o as usize);
    // checked and narrowed in one pass; any id out of range: the slow path
    if let Ints::U32(c) = conn {
        // already narrowed: checked, then moved
        if !c[..used].par_iter().all(|&v| (v as usize) < np) {
            return None;
        }
        let mut ids = std::mem::take(c);
        ids.truncate(used);
        return Some((shapes(types, &table), offsets(offs), ids));
    }
    let mut ids = vec![0u32; used];
    let ok = match conn {
        Ints::I(c) => narrow_ids(&c[..used], 1, &mut ids, np, |v| v[0]),
        Ints::Raw(t, e, b) => {
            let (t, e) = (*t, *e);
            let b = &b[..used * t.size()];
            // the common layouts converted without a match per value
            match (t, e) {
                (Scalar::I64 | Scalar::U64, Endian::Little) => narrow_ids(b, 8, &mut ids, np, |c| {
                    i64::from_le_bytes(c.try_into().unwrap_or([0; 8]))
                }),
                (Scalar::I32, Endian::Little) => narrow_ids(b, 4, &mut ids, np, |c| {
                    i32::from_le_bytes(c.try_into().unwrap_or([0; 4])) as i64
                }),
                _ => narrow_ids(b, t.size(), &mut ids, np, |c| t.get_i64(e, c)),
            }
        }
        Ints::F(_) | Ints::U32(_) => false,
    };
    if !ok {
        return None;
    }
    Some((shapes(types, &table), offsets(offs), ids))
}

type ShapeTable = [Option<(Shape, usize)>; 256];

/// The shapes of checked cell types.
fn shapes(types: &[i64], table: &ShapeTable) -> Vec<Shape> {
    types
        .par_iter()
        .map(|&t| table[t as usize].map(|(s, _)| s).unwrap_or(Shape::Vertex))
        .collect()
}

/// Checked end offsets, with the leading 0.
fn offsets(offs: &[i64]) -> Vec<usize> {
    std::iter::once(0).chain(offs.iter().map(|&o| o as usize)).collect()
}

/// `out[i]` = the vertex id that `get` reads from the `i`-th group of
/// `step` items of `from`, in parallel; false if any is not below `np`.
fn narrow_ids<T: Sync>(from: &[T], step: usize, out: &mut [u32], np: usize, get: impl Fn(&[T]) -> i64 + Sync) -> bool {
    const CHUNK: usize = 1 << 16;
    out.par_chunks_mut(CHUNK)
        .zip(from.par_chunks(CHUNK * step))
        .all(|(o, f)| {
            o.iter_mut().zip(f.chunks_exact(step)).all(|(o, c)| {
                let v = get(c);
                *o = v as u32;
                v >= 0 && (v as u64) < np as u64
            })
        })
}

/// Cells one by one, polyhedra included, stopping at the first bad one.
fn slow_cells(
    ctx: &Ctx,
    raw: &mut RawMesh,
    poly: PolyArrays,
    conn: Vec<f64>,
    (offs, oat): (Vec<f64>, usize),
    (types, tat): (Vec<f64>, usize),
    (cat, np): (usize, usize),
) -> Result<()> {
    let nc = types.len();
    let mut cell_faces = poly.cells(ctx, &types, np)?;
    let mut start = 0;
    let mut ids = Vec::new();
    for e in 0..nc {
        let end = as_index(offs[e], conn.len() + 1)
            .filter(|&o| o >= start)
            .ok_or_else(|| {
                ctx.err(
                    oat,
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
                    cat,
                    format!("element {e} refers to vertex {v}, but the file has {np} points"),
                )
            })? as u32);
        }
        let t = types[e] as i64;
        if let Some(faces) = cell_faces.get_mut(e).and_then(Option::take) {
            raw.push_polyhedron(&ids, &faces);
            start = end;
            continue;
        }
        let shape = vtk_shape(e, t).map_err(|m| ctx.err(tat, m))?;
        if ids.len() != shape.num_vertices() {
            return Err(ctx.err(
                tat,
                format!(
                    "element {e} is a {} (VTK type {t}) but has {} vertices instead of {}",
                    vtk_type_name(t),
                    ids.len(),
                    shape.num_vertices()
                ),
            ));
        }
        raw.push(shape, &ids);
        start = end;
    }
    Ok(())
}

/// The Cells arrays of polyhedra: VTK's first layout (`faces`, one face
/// stream per polyhedron, `faceoffsets`, its end per cell or -1) and VTK
/// 9.4's (`face_connectivity`/`face_offsets` per face, `polyhedron_to_faces`/
/// `polyhedron_offsets` per cell); offsets are ends, a leading 0 is accepted.
#[derive(Default)]
struct PolyArrays {
    faces: Option<(Vec<f64>, usize)>,
    faceoffsets: Option<(Vec<f64>, usize)>,
    face_connectivity: Option<(Vec<f64>, usize)>,
    face_offsets: Option<(Vec<f64>, usize)>,
    polyhedron_to_faces: Option<(Vec<f64>, usize)>,
    polyhedron_offsets: Option<(Vec<f64>, usize)>,
}

impl PolyArrays {
    /// Per cell: the faces of a polyhedron, `None` for any other cell.
    fn cells(self, ctx: &Ctx, types: &[f64], np: usize) -> Result<Vec<Option<Vec<Vec<u32>>>>> {
        let nc = types.len();
        let is_poly = |e: usize| types[e] == ElementKind::Polyhedron.vtk_id() as f64;
        let Some(first) = (0..nc).find(|&e| is_poly(e)) else {
            return Ok(Vec::new());
        };
        let mut out = vec![None; nc];
        let index = |v: f64, limit: usize, at: usize, what: &str| {
            as_index(v, limit).ok_or_else(|| ctx.err(at, format!("{what}: invalid value {v} (limit {limit})")))
        };
        // end offsets, a leading 0 dropped when there is one more than `n`
        let ends = |a: &[f64], n: usize| {
            if a.len() == n + 1 && a.first() == Some(&0.0) {
                a[1..].to_vec()
            } else {
                a.to_vec()
            }
        };
        if let (Some((stream, sat)), Some((offs, oat))) = (&self.faces, &self.faceoffsets) {
            if offs.len() != nc {
                return Err(ctx.err(*oat, format!("faceoffsets: expected {nc} values, found {}", offs.len())));
            }
            let mut start = 0;
            for e in (0..nc).filter(|&e| is_poly(e)) {
                let end = index(offs[e], stream.len() + 1, *oat, "faceoffsets")?;
                let vals = stream
                    .get(start..end)
                    .ok_or_else(|| ctx.err(*oat, format!("faceoffsets: cell {e} ends at {end}, before {start}")))?
                    .iter()
                    .map(|&v| index(v, u32::MAX as usize, *sat, "faces").map(|v| v as u32))
                    .collect::<Result<Vec<u32>>>()?;
                let faces = super::vtk::face_stream(&vals, np)
                    .map_err(|m| ctx.err(*sat, format!("element {e} (polyhedron): {m}")))?;
                out[e] = Some(faces);
                start = end;
            }
            return Ok(out);
        }
        let (Some((fc, fcat)), Some((fo, foat)), Some((pf, pfat)), Some((po, poat))) = (
            &self.face_connectivity,
            &self.face_offsets,
            &self.polyhedron_to_faces,
            &self.polyhedron_offsets,
        ) else {
            return Err(ctx.err(
                0,
                format!(
                    "element {first} is a polyhedron (VTK type 42), but the Cells have no faces and \
                     faceoffsets arrays (nor face_connectivity, face_offsets, polyhedron_to_faces and \
                     polyhedron_offsets)"
                ),
            ));
        };
        let npoly = (0..nc).filter(|&e| is_poly(e)).count();
        let fo = ends(fo, fo.len().saturating_sub(1));
        // one offset per cell, as VTK writes, or one per polyhedron
        let po = if po.len() == nc || po.len() == nc + 1 {
            ends(po, nc)
        } else {
            ends(po, npoly)
        };
        let per_cell = po.len() == nc;
        if !per_cell && po.len() != npoly {
            return Err(ctx.err(
                *poat,
                format!("polyhedron_offsets: expected {nc} values, found {}", po.len()),
            ));
        }
        let face = |f: usize| -> Result<Vec<u32>> {
            let start = if f == 0 {
                0
            } else {
                index(fo[f - 1], fc.len() + 1, *foat, "face_offsets")?
            };
            let end = index(fo[f], fc.len() + 1, *foat, "face_offsets")?;
            fc.get(start..end)
                .ok_or_else(|| ctx.err(*foat, format!("face_offsets: face {f} ends at {end}, before {start}")))?
                .iter()
                .map(|&v| index(v, np, *fcat, "face_connectivity").map(|v| v as u32))
                .collect()
        };
        let mut start = 0;
        for (k, e) in (0..nc).filter(|&e| per_cell || is_poly(e)).enumerate() {
            let end = index(po[k], pf.len() + 1, *poat, "polyhedron_offsets")?;
            let ids = pf.get(start..end).ok_or_else(|| {
                ctx.err(
                    *poat,
                    format!("polyhedron_offsets: cell {e} ends at {end}, before {start}"),
                )
            })?;
            if is_poly(e) {
                let faces = ids
                    .iter()
                    .map(|&f| face(index(f, fo.len(), *pfat, "polyhedron_to_faces")?))
                    .collect::<Result<Vec<_>>>()?;
                out[e] = Some(faces);
            } else if !ids.is_empty() {
                return Err(ctx.err(
                    *poat,
                    format!("polyhedron_offsets: cell {e} is not a polyhedron but has faces"),
                ));
            }
            start = end;
        }
        Ok(out)
    }
}

/// Escape an attribute value.
pub(crate) fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// How the writer encodes arrays.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Encoding {
    Ascii,
    Base64,
    Zlib,
}

/// Little-endian bytes of an array in its own type (strings NUL-terminated).
fn array_bytes(a: &DataArray) -> Vec<u8> {
    // fixed-size values: encoded in parallel chunks, each at its own offset
    const CHUNK: usize = 1 << 14;
    let size = a.ty.size();
    match &a.values {
        Values::Int(v) if a.ty != ValueType::Str => {
            let mut out = vec![0u8; v.len() * size];
            out.par_chunks_mut(CHUNK * size)
                .zip(v.par_chunks(CHUNK))
                .for_each(|(o, v)| {
                    let mut part = Vec::with_capacity(o.len());
                    v.iter().for_each(|&x| push_int(&mut part, a.ty, x));
                    o.copy_from_slice(&part);
                });
            return out;
        }
        Values::Float(v) if a.ty != ValueType::Str => {
            let mut out = vec![0u8; v.len() * size];
            out.par_chunks_mut(CHUNK * size)
                .zip(v.par_chunks(CHUNK))
                .for_each(|(o, v)| {
                    let mut part = Vec::with_capacity(o.len());
                    v.iter().for_each(|&x| push_float(&mut part, a.ty, x));
                    o.copy_from_slice(&part);
                });
            return out;
        }
        _ => {}
    }
    let mut out = Vec::with_capacity(a.values.len() * a.ty.size().max(1));
    match &a.values {
        Values::Str(v) => {
            for s in v {
                out.extend_from_slice(s.as_bytes());
                out.push(0);
            }
        }
        Values::Int(v) => {
            for &x in v {
                push_int(&mut out, a.ty, x);
            }
        }
        Values::Float(v) => {
            for &x in v {
                push_float(&mut out, a.ty, x);
            }
        }
    }
    out
}

fn push_float(out: &mut Vec<u8>, t: ValueType, x: f64) {
    match t {
        ValueType::F32 => out.extend_from_slice(&(x as f32).to_le_bytes()),
        ValueType::F64 => out.extend_from_slice(&x.to_le_bytes()),
        t => push_int(out, t, x as i64),
    }
}

fn push_int(out: &mut Vec<u8>, t: ValueType, x: i64) {
    match t {
        ValueType::I8 | ValueType::U8 => out.push(x as u8),
        ValueType::I16 | ValueType::U16 => out.extend_from_slice(&(x as u16).to_le_bytes()),
        ValueType::I32 | ValueType::U32 => out.extend_from_slice(&(x as u32).to_le_bytes()),
        ValueType::F32 => out.extend_from_slice(&(x as f32).to_le_bytes()),
        ValueType::F64 => out.extend_from_slice(&(x as f64).to_le_bytes()),
        ValueType::I64 | ValueType::U64 | ValueType::Str => out.extend_from_slice(&x.to_le_bytes()),
    }
}

/// The ASCII form of an array: a tuple a line, or (`rows`, CSR offsets) a
/// cell a line.
fn array_text(w: &mut dyn Write, a: &DataArray, rows: Option<&[usize]>) -> std::io::Result<()> {
    let mut line = String::new();
    let mut i = 0;
    let mut row = 1;
    let mut push = |w: &mut dyn Write, s: &str| -> std::io::Result<()> {
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(s);
        i += 1;
        let end = match rows {
            Some(r) => {
                while row < r.len() && r[row] < i {
                    row += 1;
                }
                row < r.len() && r[row] == i
            }
            None => i % a.components.max(1) == 0,
        };
        if end {
            writeln!(w, "{line}")?;
            line.clear();
        }
        Ok(())
    };
    match &a.values {
        Values::Str(v) => {
            // character codes, each string closed by 0
            for s in v {
                let codes: Vec<String> = s.bytes().chain([0]).map(|b| b.to_string()).collect();
                writeln!(w, "{}", codes.join(" "))?;
            }
        }
        Values::Int(v) => {
            for &x in v {
                let s = if a.ty == ValueType::U64 {
                    (x as u64).to_string()
                } else {
                    x.to_string()
                };
                push(w, &s)?;
            }
        }
        Values::Float(v) => {
            for &x in v {
                let s = if a.ty == ValueType::F32 {
                    format!("{:?}", x as f32)
                } else {
                    fmt_f64(x)
                };
                push(w, &s)?;
            }
        }
    }
    if !line.is_empty() {
        writeln!(w, "{line}")?;
    }
    Ok(())
}

struct Out<'w> {
    w: &'w mut dyn Write,
    enc: Encoding,
    /// Uncompressed base64 as one run over the byte-count header and the
    /// data, as VTK writes it, rather than the header in its own padded run
    /// (which VTK and meshio read, and meshsmooth reads fastest). VTK reads
    /// a PolyData's cell arrays from an offset into that run (the vertices',
    /// lines' and polygons' parts apart), so a `.vtp` needs it.
    joint: bool,
}

/// The XML declaration and the `VTKFile` and dataset (`kind`) tags of a
/// file whose arrays are in `enc`.
fn begin(w: &mut dyn Write, kind: &str, enc: Encoding) -> WriteResult {
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    let compressor = if enc == Encoding::Zlib {
        " compressor=\"vtkZLibDataCompressor\""
    } else {
        ""
    };
    writeln!(
        w,
        "<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{compressor}>"
    )?;
    writeln!(w, "  <{kind}>")?;
    Ok(())
}

impl Out<'_> {
    /// The dataset's `FieldData`, where it has any.
    fn field_data(&mut self, field: &[std::borrow::Cow<'_, DataArray>]) -> WriteResult {
        if !field.is_empty() {
            writeln!(self.w, "    <FieldData>")?;
            for a in field {
                self.array("      ", a)?;
            }
            writeln!(self.w, "    </FieldData>")?;
        }
        Ok(())
    }

    /// The piece's `PointData`: the fixed flags, then the point arrays.
    fn point_data(&mut self, mesh: &Mesh) -> WriteResult {
        let points_data: Vec<&DataArray> = mesh.data.point.iter().filter(|a| a.name != "fixed").collect();
        if !mesh.fixed.is_empty() || !points_data.is_empty() {
            writeln!(self.w, "      <PointData>")?;
            if !mesh.fixed.is_empty() {
                let f = Values::Int(mesh.fixed.iter().map(|&f| f as i64).collect());
                self.array("        ", &DataArray::new("fixed", ValueType::I32, 1, f))?;
            }
            for a in points_data {
                self.array("        ", a)?;
            }
            writeln!(self.w, "      </PointData>")?;
        }
        Ok(())
    }

    /// The piece's `CellData` in the file's cell order (`rows`: each file
    /// cell's row of the arrays; `None`: the arrays' own order).
    fn cell_data(&mut self, cells: &[std::borrow::Cow<'_, DataArray>], rows: Option<&[usize]>) -> WriteResult {
        if !cells.is_empty() {
            writeln!(self.w, "      <CellData>")?;
            for a in cells {
                match rows {
                    Some(rows) => self.array("        ", &a.select(rows))?,
                    None => self.array("        ", a)?,
                }
            }
            writeln!(self.w, "      </CellData>")?;
        }
        Ok(())
    }

    /// Closes the piece, the dataset (`kind`) and the file.
    fn end(&mut self, kind: &str) -> WriteResult {
        writeln!(self.w, "    </Piece>")?;
        writeln!(self.w, "  </{kind}>")?;
        writeln!(self.w, "</VTKFile>")?;
        Ok(())
    }

    fn array(&mut self, indent: &str, a: &DataArray) -> WriteResult {
        self.array_rows(indent, a, None)
    }

    fn array_rows(&mut self, indent: &str, a: &DataArray, rows: Option<&[usize]>) -> WriteResult {
        let fmt = if self.enc == Encoding::Ascii { "ascii" } else { "binary" };
        let tag = if a.ty == ValueType::Str { "Array" } else { "DataArray" };
        writeln!(
            self.w,
            "{indent}<{tag} type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" NumberOfTuples=\"{}\" format=\"{fmt}\">",
            xml_type_name(a.ty),
            xml_attr(&a.name),
            a.components,
            a.tuples()
        )?;
        match self.enc {
            Encoding::Ascii => array_text(self.w, a, rows)?,
            Encoding::Base64 => match &a.values {
                Values::Int(v) if a.ty.size() > 0 => {
                    self.b64_values(v.len(), a.ty.size(), |i, out| push_int(out, a.ty, v[i]))?
                }
                Values::Float(v) if a.ty.size() > 0 => {
                    self.b64_values(v.len(), a.ty.size(), |i, out| push_float(out, a.ty, v[i]))?
                }
                _ if self.joint => {
                    let data = array_bytes(a);
                    let joint = [&(data.len() as u64).to_le_bytes()[..], &data].concat();
                    writeln!(self.w, "{}", b64_encode(&joint))?;
                }
                _ => {
                    let data = array_bytes(a);
                    let header = (data.len() as u64).to_le_bytes();
                    writeln!(self.w, "{}{}", B64.encode(header), b64_encode(&data))?;
                }
            },
            Encoding::Zlib => {
                let (header, body) = zlib_blocks(&array_bytes(a));
                writeln!(self.w, "{}{}", B64.encode(header), b64_encode(&body))?;
            }
        }
        writeln!(self.w, "{indent}</{tag}>")?;
        Ok(())
    }

    /// A binary array's line: its byte-count header and `n` values of `size`
    /// bytes (`push(i, out)` appends value `i`), as base64. The bytes are made
    /// and encoded piece by piece, in parallel batches written as they come
    /// (see `batch`): the array never exists whole as bytes or as base64.
    fn b64_values(&mut self, n: usize, size: usize, push: impl Fn(usize, &mut Vec<u8>) + Sync) -> WriteResult {
        // values per piece: a multiple of 3, so every piece but the last is a
        // whole number of base64 quanta and the pieces join with no padding
        const PIECE: usize = 3 << 14;
        let header = ((n * size) as u64).to_le_bytes();
        // joint: the header and the first values up to a whole number of
        // base64 quanta (at most two values: 8 + k * size is a multiple of 3
        // for some k < 3 as size is 1, 2, 4 or 8), then the rest in pieces
        let head = if self.joint {
            (0..3).find(|k| (8 + k * size).is_multiple_of(3)).unwrap_or(0).min(n)
        } else {
            0
        };
        if self.joint {
            let mut bytes = header.to_vec();
            for i in 0..head {
                push(i, &mut bytes);
            }
            self.w.write_all(B64.encode(bytes).as_bytes())?;
        } else {
            self.w.write_all(B64.encode(header).as_bytes())?;
        }
        write_pieces(self.w, n - head, PIECE, |range, out| {
            let range = range.start + head..range.end + head;
            let mut bytes = Vec::with_capacity(range.len() * size);
            for i in range {
                push(i, &mut bytes);
            }
            let start = out.len();
            out.resize(start + bytes.len().div_ceil(3) * 4, 0);
            B64.encode_slice(&bytes, &mut out[start..])
                .expect("the output holds the encoding");
        })?;
        writeln!(self.w)?;
        Ok(())
    }

    /// The tag and base64 line of a binary array of `n` values, for arrays
    /// read straight from the mesh (no `DataArray` copy of them).
    fn b64_array(
        &mut self,
        name: &str,
        ty: ValueType,
        components: usize,
        n: usize,
        push: impl Fn(usize, &mut Vec<u8>) + Sync,
    ) -> WriteResult {
        writeln!(
            self.w,
            "        <DataArray type=\"{}\" Name=\"{name}\" NumberOfComponents=\"{components}\" NumberOfTuples=\"{}\" format=\"binary\">",
            xml_type_name(ty),
            n / components
        )?;
        self.b64_values(n, ty.size(), push)?;
        writeln!(self.w, "        </DataArray>")?;
        Ok(())
    }
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], enc: Encoding) -> WriteResult {
    let n = mesh.num_points();
    let ne = mesh.num_elements();
    begin(w, "UnstructuredGrid", enc)?;
    let mut o = Out { w, enc, joint: false };
    o.field_data(&super::out_field_arrays(mesh))?;
    // the lower cells follow the elements (see `vtk_cells`)
    let nc = ne + mesh.lower.len();
    writeln!(o.w, "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{nc}\">")?;
    o.point_data(mesh)?;
    let ids = &mesh.conn[mesh.offsets[0]..mesh.offsets[ne]];
    let (lower_ids, lower_ends) = lower_connectivity(mesh, ids.len());
    let types: Vec<u8> = cell_types(mesh).collect();
    if enc == Encoding::Base64 {
        // straight from the mesh, with no copy of points, ids, offsets or types
        let le = |out: &mut Vec<u8>, b: &[u8]| out.extend_from_slice(b);
        writeln!(o.w, "      <Points>")?;
        o.b64_array("Points", ValueType::F64, 3, 3 * n, |i, out| {
            le(out, &mesh.points[i / 3][i % 3].to_le_bytes())
        })?;
        writeln!(o.w, "      </Points>")?;
        writeln!(o.w, "      <Cells>")?;
        let id = |i: usize| ids.get(i).copied().unwrap_or_else(|| lower_ids[i - ids.len()]);
        o.b64_array(
            "connectivity",
            ValueType::I64,
            1,
            ids.len() + lower_ids.len(),
            |i, out| le(out, &(id(i) as i64).to_le_bytes()),
        )?;
        let end = |c: usize| {
            if c < ne {
                mesh.offsets[c + 1]
            } else {
                lower_ends[c - ne]
            }
        };
        o.b64_array("offsets", ValueType::I64, 1, nc, |c, out| {
            le(out, &(end(c) as i64).to_le_bytes())
        })?;
        o.b64_array("types", ValueType::U8, 1, nc, |c, out| out.push(types[c]))?;
    } else {
        writeln!(o.w, "      <Points>")?;
        let pts = DataArray::new(
            "Points",
            ValueType::F64,
            3,
            Values::Float(mesh.points.par_iter().flatten_iter().copied().collect()),
        );
        o.array("        ", &pts)?;
        writeln!(o.w, "      </Points>")?;
        writeln!(o.w, "      <Cells>")?;
        let conn = ids.par_iter().chain(&lower_ids).map(|&v| v as i64).collect();
        let conn = DataArray::new("connectivity", ValueType::I64, 1, Values::Int(conn));
        let rows: Vec<usize> = mesh.offsets.iter().chain(&lower_ends).copied().collect();
        o.array_rows("        ", &conn, Some(&rows))?;
        let offs: Vec<i64> = rows[1..].iter().map(|&x| x as i64).collect();
        o.array(
            "        ",
            &DataArray::new("offsets", ValueType::I64, 1, Values::Int(offs)),
        )?;
        let types: Vec<i64> = types.iter().map(|&t| i64::from(t)).collect();
        o.array(
            "        ",
            &DataArray::new("types", ValueType::U8, 1, Values::Int(types)),
        )?;
    }
    if mesh.kinds.contains(&ElementKind::Polyhedron) {
        // VTK's first polyhedron layout, which every VTK since 5.8 reads
        // (9.4 writes `polyhedron_*` arrays but still reads these)
        let (mut stream, mut ends) = (Vec::new(), Vec::with_capacity(ne));
        for e in 0..ne {
            if mesh.kinds[e] != ElementKind::Polyhedron {
                ends.push(-1);
                continue;
            }
            stream.push(mesh.faces.of(e).count() as i64);
            for f in mesh.faces.of(e) {
                stream.push(f.len() as i64);
                stream.extend(f.iter().map(|&v| v as i64));
            }
            ends.push(stream.len() as i64);
        }
        ends.resize(nc, -1);
        o.array(
            "        ",
            &DataArray::new("faces", ValueType::I64, 1, Values::Int(stream)),
        )?;
        o.array(
            "        ",
            &DataArray::new("faceoffsets", ValueType::I64, 1, Values::Int(ends)),
        )?;
    }
    writeln!(o.w, "      </Cells>")?;
    check_cell_data(mesh, cell_data)?;
    o.cell_data(&out_cell_arrays(mesh, cell_data), None)?;
    o.end("UnstructuredGrid")
}

/// Writes a surface mesh as VTK XML PolyData (`.vtp`): its points-only and
/// line boundary cells as `Verts` and `Lines`, its triangles and
/// quadrilaterals as `Polys`, cell arrays in that order (VTK's), arrays in
/// `enc`. A mesh of volumes, or with boundary faces, is refused: a `.vtu`
/// holds it.
pub(crate) fn write_poly(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], enc: Encoding) -> WriteResult {
    let refuse = |what: String| {
        WriteError::Other(Error::InvalidArgument(format!(
            "VTK PolyData holds surfaces: {what}; write .vtu"
        )))
    };
    if let Some(e) = mesh.kinds.iter().position(|k| k.dim() != 2) {
        return Err(refuse(format!("element {e} is a {}", mesh.kinds[e].name())));
    }
    if let Some(c) = mesh
        .lower
        .iter()
        .position(|(k, _)| !matches!(k, LowerKind::Vertex | LowerKind::Line))
    {
        return Err(refuse(format!("boundary cell {c} is a face")));
    }
    check_cell_data(mesh, cell_data)?;
    let (n, ne) = (mesh.num_points(), mesh.num_elements());
    // VTK's cell order: vertices, lines, polygons
    let verts: Vec<usize> = (0..mesh.lower.len())
        .filter(|&c| mesh.lower[c].0 == LowerKind::Vertex)
        .collect();
    let lines: Vec<usize> = (0..mesh.lower.len())
        .filter(|&c| mesh.lower[c].0 == LowerKind::Line)
        .collect();
    let rows: Vec<usize> = verts.iter().chain(&lines).map(|&c| ne + c).chain(0..ne).collect();
    begin(w, "PolyData", enc)?;
    let mut o = Out { w, enc, joint: true };
    // the sets' elements by their cells' numbers in the file
    o.field_data(&super::out_field_arrays_from(mesh, verts.len() + lines.len()))?;
    writeln!(
        o.w,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{}\" NumberOfLines=\"{}\" NumberOfStrips=\"0\" NumberOfPolys=\"{ne}\">",
        verts.len(),
        lines.len()
    )?;
    o.point_data(mesh)?;
    o.cell_data(&out_cell_arrays(mesh, cell_data), Some(&rows))?;
    writeln!(o.w, "      <Points>")?;
    let pts = Values::Float(mesh.points.iter().flatten().copied().collect());
    o.array("        ", &DataArray::new("Points", ValueType::F64, 3, pts))?;
    writeln!(o.w, "      </Points>")?;
    let lower = |c: &[usize]| -> Vec<&[u32]> { c.iter().map(|&c| &mesh.lower[c].1[..]).collect() };
    let polys: Vec<&[u32]> = (0..ne).map(|e| mesh.element(e)).collect();
    for (tag, cells) in [("Verts", lower(&verts)), ("Lines", lower(&lines)), ("Polys", polys)] {
        writeln!(o.w, "      <{tag}>")?;
        let conn = Values::Int(cells.iter().flat_map(|c| c.iter().map(|&v| i64::from(v))).collect());
        o.array("        ", &DataArray::new("connectivity", ValueType::I64, 1, conn))?;
        let mut end = 0;
        let offs = Values::Int(
            cells
                .iter()
                .map(|c| {
                    end += c.len() as i64;
                    end
                })
                .collect(),
        );
        o.array("        ", &DataArray::new("offsets", ValueType::I64, 1, offs))?;
        writeln!(o.w, "      </{tag}>")?;
    }
    o.end("PolyData")
}

/// A `.pvtu` index over pieces shaped like `piece` (same arrays, as
/// [`write`] writes them), at `sources` (relative to the index).
pub(crate) fn write_index(w: &mut dyn Write, piece: &Mesh, cell_data: &[CellData], sources: &[String]) -> WriteResult {
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <PUnstructuredGrid GhostLevel=\"0\">")?;
    let header = |w: &mut dyn Write, name: &str, ty: ValueType, components: usize| -> std::io::Result<()> {
        let tag = if ty == ValueType::Str { "PArray" } else { "PDataArray" };
        writeln!(
            w,
            "      <{tag} type=\"{}\" Name=\"{}\" NumberOfComponents=\"{components}\"/>",
            xml_type_name(ty),
            xml_attr(name)
        )
    };
    let points_data: Vec<&DataArray> = piece.data.point.iter().filter(|a| a.name != "fixed").collect();
    if !piece.fixed.is_empty() || !points_data.is_empty() {
        writeln!(w, "    <PPointData>")?;
        if !piece.fixed.is_empty() {
            header(w, "fixed", ValueType::I32, 1)?;
        }
        for a in points_data {
            header(w, &a.name, a.ty, a.components)?;
        }
        writeln!(w, "    </PPointData>")?;
    }
    let cells = out_cell_arrays(piece, cell_data);
    if !cells.is_empty() {
        writeln!(w, "    <PCellData>")?;
        for a in &cells {
            header(w, &a.name, a.ty, a.components)?;
        }
        writeln!(w, "    </PCellData>")?;
    }
    writeln!(w, "    <PPoints>")?;
    header(w, "Points", ValueType::F64, 3)?;
    writeln!(w, "    </PPoints>")?;
    for s in sources {
        writeln!(w, "    <Piece Source=\"{}\"/>", xml_attr(s))?;
    }
    writeln!(w, "  </PUnstructuredGrid>")?;
    writeln!(w, "</VTKFile>")?;
    Ok(())
}
