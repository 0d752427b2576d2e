//! Medit / INRIA `.mesh`, ASCII.
//!
//! Sections group cells by kind, so elements come back grouped by kind (in
//! the order of the sections). Fixed flags travel as RequiredVertices, lower
//! point cells as Corners.

use std::io::Write;
use std::path::Path;

use super::lex::Cursor;
use super::{CellData, RawMesh, Shape, WriteResult, check_cell_data, fmt_f64, is_planar_z0};
use crate::error::{Error, Result};
use crate::mesh::{ElementKind, LowerKind, Mesh};

fn section_shape(kw: &str) -> Option<Shape> {
    Some(match kw {
        "corners" => Shape::Vertex,
        "edges" => Shape::Line,
        "triangles" => Shape::Elem(ElementKind::Triangle),
        "quadrilaterals" => Shape::Elem(ElementKind::Quadrilateral),
        "tetrahedra" => Shape::Elem(ElementKind::Tetrahedron),
        "hexahedra" => Shape::Elem(ElementKind::Hexahedron),
        "prisms" => Shape::Elem(ElementKind::Prism),
        _ => return None,
    })
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &super::limits::Budget) -> Result<RawMesh> {
    let mut c = Cursor::new(path, data);
    c.budget = Some(budget);
    c.hash_comments = true;
    let mut dim: Option<usize> = None;
    let mut raw = RawMesh::default();
    let mut has_vertices = false;
    let mut required = Vec::new();
    while let Some(tok) = c.token() {
        let kw = tok.to_ascii_lowercase();
        match kw.as_str() {
            "meshversionformatted" => {
                c.parse::<i64>("MeshVersionFormatted")?;
            }
            "dimension" => {
                let d: usize = c.parse("Dimension")?;
                if d != 2 && d != 3 {
                    return Err(c.err(format!("Dimension must be 2 or 3, found {d}")));
                }
                dim = Some(d);
            }
            "vertices" => {
                let d = dim.ok_or_else(|| c.err("Vertices before Dimension"))?;
                if has_vertices {
                    return Err(c.err("a second Vertices section"));
                }
                has_vertices = true;
                let n = c.count("the number of Vertices")?;
                let total = n.checked_mul(d + 1).ok_or_else(|| c.err("Vertices count too large"))?;
                c.reserve("Vertices", n, 2 * (d + 1), 24)?;
                let vals: Vec<f64> = c.numbers(total, "Vertices")?;
                raw.points.reserve(n);
                for (i, v) in vals.chunks_exact(d + 1).enumerate() {
                    let p = [v[0], v[1], if d == 3 { v[2] } else { 0.0 }];
                    if p.iter().any(|x| !x.is_finite()) {
                        return Err(Error::parse(
                            path,
                            None,
                            format!("point {i} (vertex {}) has a non-finite coordinate {p:?}", i + 1),
                        ));
                    }
                    raw.points.push(p);
                }
            }
            "pyramids" => {
                return Err(c.err(
                    "the file has pyramids; pyramids are not supported: the corner-based \
                     metrics need exactly 3 edges at every corner",
                ));
            }
            "requiredvertices" => {
                let n = c.count("the number of RequiredVertices")?;
                required = c.numbers::<i64>(n, "RequiredVertices")?;
            }
            "end" => break,
            _ => {
                if let Some(shape) = section_shape(&kw) {
                    if !has_vertices {
                        return Err(c.err(format!("{tok} before Vertices: missing Vertices section")));
                    }
                    cells(&mut c, &mut raw, shape, tok)?;
                } else if tok.starts_with(|ch: char| ch.is_ascii_alphabetic()) {
                    // Unknown section (Ridges, Normals, ...): skip to the next keyword.
                    while c
                        .peek_token()
                        .is_some_and(|t| !t.starts_with(|ch: char| ch.is_ascii_alphabetic()))
                    {
                        c.token();
                    }
                } else {
                    return Err(c.err(format!("expected a section keyword, found '{tok}'")));
                }
            }
        }
    }
    if !has_vertices {
        return Err(Error::parse(path, None, "missing Vertices section"));
    }
    let n = raw.points.len();
    for v in required {
        let i = usize::try_from(v - 1).ok().filter(|&i| i < n).ok_or_else(|| {
            Error::parse(
                path,
                None,
                format!("RequiredVertices refers to vertex {v}, but the file has {n} vertices"),
            )
        })?;
        raw.fix(i);
    }
    Ok(raw)
}

fn cells(c: &mut Cursor, raw: &mut RawMesh, shape: Shape, section: &str) -> Result<()> {
    let np = raw.points.len();
    let n = c.count(&format!("the number of {section}"))?;
    let k = shape.num_vertices();
    // Corners list bare vertex ids; other sections end each entry with a reference.
    let width = if shape == Shape::Vertex { 1 } else { k + 1 };
    let total = n
        .checked_mul(width)
        .ok_or_else(|| c.err(format!("{section} count too large")))?;
    let vals: Vec<i64> = c.numbers(total, section)?;
    let mut vs = Vec::with_capacity(k);
    for (i, cell) in vals.chunks_exact(width).enumerate() {
        vs.clear();
        for &v in &cell[..k] {
            let id = usize::try_from(v - 1).ok().filter(|&id| id < np).ok_or_else(|| {
                Error::parse(
                    c.path,
                    None,
                    format!(
                        "{section} entry {} refers to vertex {v}, but the file has {np} vertices",
                        i + 1
                    ),
                )
            })?;
            vs.push(id as u32);
        }
        raw.push(shape, &vs);
    }
    Ok(())
}

fn keyword(k: ElementKind) -> &'static str {
    match k {
        ElementKind::Triangle => "Triangles",
        ElementKind::Quadrilateral => "Quadrilaterals",
        ElementKind::Tetrahedron => "Tetrahedra",
        ElementKind::Hexahedron => "Hexahedra",
        ElementKind::Prism => "Prisms",
        ElementKind::Polyhedron => unreachable!("polyhedra are refused before any writer runs (io::write)"),
    }
}

fn section<'m>(w: &mut dyn Write, name: &str, cells: impl Iterator<Item = &'m [u32]> + Clone) -> WriteResult {
    writeln!(w, "{name}\n{}", cells.clone().count())?;
    for vs in cells {
        for v in vs {
            write!(w, "{} ", v + 1)?;
        }
        writeln!(w, "0")?;
    }
    Ok(())
}

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    let d = if is_planar_z0(mesh) { 2 } else { 3 };
    writeln!(
        w,
        "MeshVersionFormatted 2\nDimension {d}\nVertices\n{}",
        mesh.num_points()
    )?;
    for p in &mesh.points {
        for x in &p[..d] {
            write!(w, "{} ", fmt_f64(*x))?;
        }
        writeln!(w, "0")?;
    }
    let mut kinds: Vec<ElementKind> = Vec::new();
    for &k in &mesh.kinds {
        if !kinds.contains(&k) {
            kinds.push(k);
        }
    }
    for k in kinds {
        let els = (0..mesh.num_elements())
            .filter(move |&e| mesh.kinds[e] == k)
            .map(|e| mesh.element(e));
        section(w, keyword(k), els)?;
    }
    let mut lkinds: Vec<LowerKind> = Vec::new();
    for (k, _) in &mesh.lower {
        if !lkinds.contains(k) {
            lkinds.push(*k);
        }
    }
    for k in lkinds {
        let name = match k {
            LowerKind::Vertex => "Corners",
            LowerKind::Line => "Edges",
            // In a 2D mesh these would be read back as elements.
            _ if mesh.dim() == 2 => continue,
            LowerKind::Triangle => "Triangles",
            LowerKind::Quadrilateral => "Quadrilaterals",
        };
        let cells = mesh.lower.iter().filter(move |(lk, _)| *lk == k).map(|(_, vs)| &vs[..]);
        if k == LowerKind::Vertex {
            // Corners carry no reference number.
            writeln!(w, "Corners\n{}", cells.clone().count())?;
            for vs in cells {
                writeln!(w, "{}", vs[0] + 1)?;
            }
        } else {
            section(w, name, cells)?;
        }
    }
    let fixed: Vec<usize> = (0..mesh.num_points()).filter(|&v| mesh.is_fixed(v)).collect();
    if !fixed.is_empty() {
        writeln!(w, "RequiredVertices\n{}", fixed.len())?;
        for v in fixed {
            writeln!(w, "{}", v + 1)?;
        }
    }
    check_cell_data(mesh, cell_data)?;
    writeln!(w, "End")?;
    Ok(())
}
