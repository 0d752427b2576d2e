//! PLY (`.ply`): ASCII, binary little-endian and binary big-endian.
//!
//! The `vertex` element's `x`, `y`, `z` are the points and its other scalar
//! properties point arrays; the `face` element's `vertex_indices` (or
//! `vertex_index`) list holds 3 or 4 vertex ids and its other scalar
//! properties are cell arrays. Other elements (`edge`, `material`, ...) and
//! other list properties are read past and dropped. The writer writes the
//! points as doubles, numeric point and cell arrays (one property per
//! component, `NAME_0`, `NAME_1`, ... for several; 64-bit integers as
//! doubles, which PLY has no type for) and the faces as a `uchar`-counted
//! `int` list; strings, lower cells and sets are not written.

use std::io::Write;
use std::path::Path;

use super::lex::{Cursor, clip};
use super::limits::Budget;
use super::{CellData, RawMesh, Shape, WriteResult};
use crate::error::{Error, Location, Result};
use crate::mesh::{DataArray, ElementKind, Mesh, ValueType, Values};

#[derive(Clone, Copy, PartialEq)]
enum Enc {
    Ascii,
    Le,
    Be,
}

fn ty(name: &str) -> Option<ValueType> {
    Some(match name {
        "char" | "int8" => ValueType::I8,
        "uchar" | "uint8" => ValueType::U8,
        "short" | "int16" => ValueType::I16,
        "ushort" | "uint16" => ValueType::U16,
        "int" | "int32" => ValueType::I32,
        "uint" | "uint32" => ValueType::U32,
        "float" | "float32" => ValueType::F32,
        "double" | "float64" => ValueType::F64,
        _ => return None,
    })
}

fn ty_name(t: ValueType) -> &'static str {
    match t {
        ValueType::I8 => "char",
        ValueType::U8 => "uchar",
        ValueType::I16 => "short",
        ValueType::U16 => "ushort",
        ValueType::I32 => "int",
        ValueType::U32 => "uint",
        ValueType::F32 => "float",
        _ => "double",
    }
}

struct Prop {
    name: String,
    /// `Some(count type)` for a list property.
    list: Option<ValueType>,
    ty: ValueType,
}

struct Elem {
    name: String,
    count: usize,
    props: Vec<Prop>,
    line: usize,
}

/// Values one by one from the body, in either encoding.
struct Body<'a> {
    enc: Enc,
    c: Cursor<'a>,
    data: &'a [u8],
    pos: usize,
}

impl Body<'_> {
    fn value(&mut self, t: ValueType, what: &str) -> Result<f64> {
        if self.enc == Enc::Ascii {
            let tok = self.c.token().ok_or_else(|| self.c.eof(what))?;
            let x: f64 = tok
                .parse()
                .map_err(|_| self.c.err(format!("expected a number ({what}), found '{}'", clip(tok))))?;
            return Ok(x);
        }
        let n = t.size();
        let b = self.data.get(self.pos..self.pos + n).ok_or_else(|| {
            Error::parse(
                self.c.path,
                None,
                format!("unexpected end of file while reading {what}"),
            )
        })?;
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.enc == Enc::Be {
            a[..n].reverse();
        }
        Ok(match t {
            ValueType::I8 => f64::from(a[0] as i8),
            ValueType::U8 => f64::from(a[0]),
            ValueType::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            ValueType::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            ValueType::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            ValueType::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            ValueType::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            _ => f64::from_le_bytes(a),
        })
    }

    fn err(&self, msg: String) -> Error {
        match self.enc {
            Enc::Ascii => self.c.err(msg),
            _ => Error::parse(self.c.path, Some(Location::Byte(self.pos as u64)), msg),
        }
    }

    fn remaining(&self) -> usize {
        match self.enc {
            Enc::Ascii => self.c.remaining(),
            _ => self.data.len() - self.pos,
        }
    }
}

/// A value that must be an integer id or count.
fn int(x: f64) -> Option<i64> {
    (x.fract() == 0.0 && x.abs() < 9.0e15).then_some(x as i64)
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let mut c = Cursor::new(path, data);
    c.budget = Some(budget);
    let (_, first) = c.line_tokens().ok_or_else(|| c.eof("the PLY header"))?;
    if first != ["ply"] {
        return Err(c.err("not a PLY file: the first line is not 'ply'"));
    }
    let mut enc = None;
    let mut elems: Vec<Elem> = Vec::new();
    loop {
        let (line, t) = c.line_tokens().ok_or_else(|| c.eof("the PLY header (no end_header)"))?;
        match t.first().copied() {
            Some("format") => {
                enc = Some(match t.get(1).copied() {
                    Some("ascii") => Enc::Ascii,
                    Some("binary_little_endian") => Enc::Le,
                    Some("binary_big_endian") => Enc::Be,
                    other => {
                        return Err(c.err(format!(
                            "unknown PLY format '{}': ascii, binary_little_endian or binary_big_endian",
                            clip(other.unwrap_or(""))
                        )));
                    }
                })
            }
            Some("comment" | "obj_info") => {}
            Some("element") => {
                let (Some(name), Some(n)) = (t.get(1), t.get(2)) else {
                    return Err(c.err("an element line needs a name and a count"));
                };
                let count = n
                    .parse()
                    .map_err(|_| c.err(format!("element {} has count '{}', not a count", clip(name), clip(n))))?;
                elems.push(Elem {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line,
                });
            }
            Some("property") => {
                let Some(e) = elems.last_mut() else {
                    return Err(c.err("a property before any element"));
                };
                let bad = |s: &str| c.err(format!("unknown PLY property type '{}'", clip(s)));
                let prop = if t.get(1) == Some(&"list") {
                    let (Some(ct), Some(it), Some(name)) = (t.get(2), t.get(3), t.get(4)) else {
                        return Err(c.err("a list property needs a count type, a value type and a name"));
                    };
                    let count_ty = ty(ct).ok_or_else(|| bad(ct))?;
                    if count_ty.is_float() {
                        return Err(c.err(format!("list '{}' is counted by a float type", clip(name))));
                    }
                    Prop {
                        name: name.to_string(),
                        list: Some(count_ty),
                        ty: ty(it).ok_or_else(|| bad(it))?,
                    }
                } else {
                    let (Some(tn), Some(name)) = (t.get(1), t.get(2)) else {
                        return Err(c.err("a property needs a type and a name"));
                    };
                    Prop {
                        name: name.to_string(),
                        list: None,
                        ty: ty(tn).ok_or_else(|| bad(tn))?,
                    }
                };
                e.props.push(prop);
            }
            Some("end_header") => break,
            Some(other) => return Err(c.err(format!("unexpected PLY header line '{}'", clip(other)))),
            None => {}
        }
    }
    let enc = enc.ok_or_else(|| Error::parse(path, None, "the PLY header has no format line"))?;
    // binary data starts right after the newline of end_header
    let pos = c.pos();
    let mut body = Body { enc, c, data, pos };
    let mut raw = RawMesh::default();
    let mut seen_vertex = false;
    let mut faces_at: Vec<Location> = Vec::new();
    for e in &elems {
        if e.count > 0 && !e.props.is_empty() && e.count > body.remaining() {
            return Err(Error::parse(
                path,
                Some(Location::Line(e.line)),
                format!(
                    "element {} declares {} entries but only {} bytes follow the header",
                    clip(&e.name),
                    e.count,
                    body.remaining()
                ),
            ));
        }
        let is_vertex = e.name == "vertex" && !seen_vertex;
        let is_face = e.name == "face" && raw.shapes.is_empty();
        seen_vertex |= is_vertex;
        let scalars: Vec<&Prop> = e.props.iter().filter(|p| p.list.is_none()).collect();
        let keep = is_vertex || is_face;
        let xyz: Vec<Option<usize>> = ["x", "y", "z"]
            .iter()
            .map(|n| scalars.iter().position(|p| p.name == *n))
            .collect();
        if is_vertex && (xyz[0].is_none() || xyz[1].is_none()) {
            return Err(Error::parse(
                path,
                Some(Location::Line(e.line)),
                "element vertex has no x or y property",
            ));
        }
        let idx_prop = e
            .props
            .iter()
            .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"));
        if is_face && idx_prop.is_none() {
            return Err(Error::parse(
                path,
                Some(Location::Line(e.line)),
                "element face has no vertex_indices (or vertex_index) list",
            ));
        }
        if e.props.is_empty() {
            // entries without properties take no bytes: counting through a
            // hostile 10^19 of them would never end
            continue;
        }
        let each = 8 * e.props.len() as u64 + if is_vertex { 24 } else { 16 };
        if keep {
            budget.charge(
                format_args!("element {} ({} declared)", e.name, e.count),
                (e.count as u64).saturating_mul(each),
            )?;
        }
        let mut arrays: Vec<Vec<f64>> = if keep {
            scalars.iter().map(|_| Vec::with_capacity(e.count)).collect()
        } else {
            Vec::new()
        };
        let mut corners = Vec::with_capacity(4);
        for i in 0..e.count {
            let mut si = 0;
            corners.clear();
            let start = body.pos;
            let mut p = [0.0; 3];
            for (k, prop) in e.props.iter().enumerate() {
                let what = format!("{} {i} property {}", e.name, prop.name);
                if let Some(ct) = prop.list {
                    let n = int(body.value(ct, &what)?).filter(|&n| n >= 0).ok_or_else(|| {
                        body.err(format!("{} {i}: list {} has a bad count", e.name, clip(&prop.name)))
                    })?;
                    let n = n as usize;
                    if n > body.remaining() {
                        return Err(body.err(format!(
                            "{} {i}: list {} of {n} values runs past the end of the file",
                            e.name,
                            clip(&prop.name)
                        )));
                    }
                    let take = is_face && Some(k) == idx_prop;
                    if take && !(3..=4).contains(&n) {
                        return Err(body.err(format!(
                            "face {i} has {n} vertices: only triangles and quadrilaterals are supported"
                        )));
                    }
                    for _ in 0..n {
                        let x = body.value(prop.ty, &what)?;
                        if take {
                            let v = int(x)
                                .and_then(|v| u32::try_from(v).ok())
                                .ok_or_else(|| body.err(format!("face {i} has vertex index {x}, not a vertex id")))?;
                            corners.push(v);
                        }
                    }
                } else {
                    let x = body.value(prop.ty, &what)?;
                    if keep {
                        arrays[si].push(x);
                    }
                    if is_vertex && let Some(j) = xyz.iter().position(|&q| q == Some(si)) {
                        p[j] = x;
                    }
                    si += 1;
                }
            }
            if is_vertex {
                if p.iter().any(|x| !x.is_finite()) {
                    return Err(body.err(format!("vertex {i} has a non-finite coordinate {p:?}")));
                }
                raw.points.push(p);
            }
            if is_face {
                let kind = if corners.len() == 3 {
                    ElementKind::Triangle
                } else {
                    ElementKind::Quadrilateral
                };
                raw.push(Shape::Elem(kind), &corners);
                faces_at.push(match enc {
                    Enc::Ascii => Location::Line(body.c.token_line()),
                    _ => Location::Byte(start as u64),
                });
            }
        }
        if keep {
            for (prop, vals) in scalars.iter().zip(arrays) {
                if is_vertex && ["x", "y", "z"].contains(&prop.name.as_str()) {
                    continue;
                }
                let values = if prop.ty.is_float() {
                    Values::Float(vals)
                } else {
                    Values::Int(vals.into_iter().map(|x| x as i64).collect())
                };
                let a = DataArray::new(prop.name.clone(), prop.ty, 1, values);
                if is_vertex {
                    raw.point_data.push(a);
                } else {
                    raw.cell_data.push(a);
                }
            }
        }
    }
    if enc == Enc::Ascii {
        if let Some(t) = body.c.token() {
            return Err(body
                .c
                .err(format!("'{}' after the last element the header declares", clip(t))));
        }
    } else if body.pos != data.len() {
        return Err(Error::parse(
            path,
            Some(Location::Byte(body.pos as u64)),
            format!(
                "{} bytes after the last element the header declares",
                data.len() - body.pos
            ),
        ));
    }
    let np = raw.points.len();
    for (f, at) in faces_at.iter().enumerate() {
        let vs = &raw.conn[raw.offsets[f]..raw.offsets[f + 1]];
        if let Some(&v) = vs.iter().find(|&&v| v as usize >= np) {
            return Err(Error::parse(
                path,
                Some(at.clone()),
                format!("face {f} refers to vertex {v}, but the file has {np} vertices"),
            ));
        }
    }
    Ok(raw)
}

/// What the writer writes of an array: numeric ones, per component.
fn columns(arrays: &[DataArray], skip: &[&str]) -> Vec<(String, ValueType, usize, usize)> {
    let mut out = Vec::new();
    for (i, a) in arrays.iter().enumerate() {
        if a.ty == ValueType::Str || matches!(a.values, Values::Str(_)) {
            continue;
        }
        for k in 0..a.components {
            let name = if a.components == 1 {
                a.name.clone()
            } else {
                format!("{}_{k}", a.name)
            };
            // names in a header line cannot hold spaces
            let name = name.replace(char::is_whitespace, "_");
            if skip.contains(&name.as_str()) {
                continue;
            }
            out.push((name, a.ty, i, k));
        }
    }
    out
}

fn put(w: &mut dyn Write, binary: bool, t: ValueType, x: f64) -> WriteResult {
    if !binary {
        if t.is_float() {
            write!(w, "{}", super::fmt_f64(x))?;
        } else {
            write!(w, "{}", x as i64)?;
        }
        return Ok(());
    }
    match t {
        ValueType::I8 => w.write_all(&(x as i8).to_le_bytes())?,
        ValueType::U8 => w.write_all(&(x as u8).to_le_bytes())?,
        ValueType::I16 => w.write_all(&(x as i16).to_le_bytes())?,
        ValueType::U16 => w.write_all(&(x as u16).to_le_bytes())?,
        ValueType::I32 => w.write_all(&(x as i32).to_le_bytes())?,
        ValueType::U32 => w.write_all(&(x as u32).to_le_bytes())?,
        ValueType::F32 => w.write_all(&(x as f32).to_le_bytes())?,
        _ => w.write_all(&x.to_le_bytes())?,
    }
    Ok(())
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let pcols = columns(&mesh.data.point, &["x", "y", "z"]);
    // the given cell data (quality measures) replace input arrays of the same name
    let mut skip: Vec<&str> = cell_data.iter().map(|c| c.name).collect();
    skip.push("vertex_indices");
    let ccols = columns(&mesh.data.cell, &skip);
    let given: Vec<String> = cell_data
        .iter()
        .map(|c| c.name.replace(char::is_whitespace, "_"))
        .collect();
    let ptype = |t: ValueType| {
        if matches!(t, ValueType::I64 | ValueType::U64) {
            ValueType::F64
        } else {
            t
        }
    };
    writeln!(
        w,
        "ply\nformat {} 1.0\ncomment written by meshsmooth",
        if binary { "binary_little_endian" } else { "ascii" }
    )?;
    writeln!(w, "element vertex {}", mesh.num_points())?;
    writeln!(w, "property double x\nproperty double y\nproperty double z")?;
    for (n, t, _, _) in &pcols {
        writeln!(w, "property {} {n}", ty_name(ptype(*t)))?;
    }
    writeln!(
        w,
        "element face {}\nproperty list uchar int vertex_indices",
        mesh.num_elements()
    )?;
    for (n, t, _, _) in &ccols {
        writeln!(w, "property {} {n}", ty_name(ptype(*t)))?;
    }
    for n in &given {
        writeln!(w, "property double {n}")?;
    }
    writeln!(w, "end_header")?;
    let sep = |w: &mut dyn Write| -> WriteResult {
        if !binary {
            write!(w, " ")?;
        }
        Ok(())
    };
    let eol = |w: &mut dyn Write| -> WriteResult {
        if !binary {
            writeln!(w)?;
        }
        Ok(())
    };
    for (v, p) in mesh.points.iter().enumerate() {
        for (k, &x) in p.iter().enumerate() {
            if k > 0 {
                sep(w)?;
            }
            put(w, binary, ValueType::F64, x)?;
        }
        for (_, t, a, k) in &pcols {
            sep(w)?;
            let arr = &mesh.data.point[*a];
            put(w, binary, ptype(*t), arr.get_f64(v * arr.components + k))?;
        }
        eol(w)?;
    }
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        put(w, binary, ValueType::U8, vs.len() as f64)?;
        for &v in vs {
            sep(w)?;
            put(w, binary, ValueType::I32, f64::from(v))?;
        }
        for (_, t, a, k) in &ccols {
            sep(w)?;
            let arr = &mesh.data.cell[*a];
            put(w, binary, ptype(*t), arr.get_f64(e * arr.components + k))?;
        }
        for cd in cell_data {
            sep(w)?;
            put(w, binary, ValueType::F64, cd.values[e])?;
        }
        eol(w)?;
    }
    Ok(())
}
