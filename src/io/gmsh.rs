//! Gmsh `.msh` versions 2.2 and 4.1, ASCII and binary (little-endian).
//!
//! Node tags are renumbered to dense 0-based ids in file order. Fixed flags
//! are stored as point elements (type 15), so a round trip keeps them.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use super::lex::Cursor;
use super::{CellData, RawMesh, Shape, WriteResult, check_cell_data, fmt_f64};
use crate::error::{Error, Result};
use crate::mesh::{ElementKind, LowerKind, Mesh};

fn type_name(t: i64) -> &'static str {
    match t {
        1 => "2-node line",
        2 => "triangle",
        3 => "quadrangle",
        4 => "tetrahedron",
        5 => "hexahedron",
        6 => "prism",
        7 => "pyramid",
        8 => "3-node line",
        9 => "6-node triangle",
        10 => "9-node quadrangle",
        11 => "10-node tetrahedron",
        12 => "27-node hexahedron",
        13 => "18-node prism",
        14 => "14-node pyramid",
        15 => "point",
        16 => "8-node quadrangle",
        17 => "20-node hexahedron",
        18 => "15-node prism",
        19 => "13-node pyramid",
        _ => "higher-order or unknown element",
    }
}

fn shape_of(tag: u64, t: i64) -> std::result::Result<Shape, String> {
    match t {
        15 => Ok(Shape::Vertex),
        1 => Ok(Shape::Line),
        7 => Err(format!(
            "element {tag} is a pyramid (Gmsh type 7); pyramids are not supported: \
             the corner-based metrics need exactly 3 edges at every corner"
        )),
        _ => u32::try_from(t)
            .ok()
            .and_then(ElementKind::from_gmsh_id)
            .map(Shape::Elem)
            .ok_or_else(|| {
                format!(
                    "element {tag} has Gmsh type {t} ({}), which is not supported; \
                     only linear points, lines, triangles, quadrangles, tetrahedra, \
                     hexahedra and prisms (types 15, 1-6) are",
                    type_name(t)
                )
            }),
    }
}

struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
    /// Bytes of a `size_t` in 4.1 binary files.
    dsize: usize,
    v4: bool,
    raw: RawMesh,
    tags: HashMap<u64, u32>,
    has_nodes: bool,
    has_elements: bool,
}

pub(crate) fn read(path: &Path, data: &[u8]) -> Result<RawMesh> {
    let mut c = Cursor::new(path, data);
    let (_, t) = c.line_tokens().ok_or_else(|| c.eof("$MeshFormat"))?;
    if t.first() != Some(&"$MeshFormat") {
        return Err(c.err("expected $MeshFormat at the start of a Gmsh file"));
    }
    let (_, t) = c.line_tokens().ok_or_else(|| c.eof("$MeshFormat"))?;
    if t.len() < 3 {
        return Err(c.err(format!(
            "expected 'version file-type data-size' in $MeshFormat, found '{}'",
            t.join(" ")
        )));
    }
    let v4 = match t[0] {
        "2" | "2.0" | "2.1" | "2.2" => false,
        "4.1" => true,
        v => {
            return Err(c.err(format!(
                "Gmsh format version {v} is not supported; save as version 2.2 or 4.1"
            )));
        }
    };
    let binary = match t[1] {
        "0" => false,
        "1" => true,
        f => {
            return Err(c.err(format!("file-type must be 0 (ASCII) or 1 (binary), found '{f}'")));
        }
    };
    let dsize = match t[2] {
        "4" => 4,
        "8" => 8,
        d => return Err(c.err(format!("data-size must be 4 or 8, found '{d}'"))),
    };
    if binary {
        let at = c.pos();
        let one = c.bytes(4, "the endianness marker")?;
        let v = i32::from_le_bytes([one[0], one[1], one[2], one[3]]);
        if v != 1 {
            let why = if v == 1 << 24 {
                "the file is big-endian, which is not supported".to_string()
            } else {
                format!("expected the integer 1, found {v}")
            };
            return Err(c.err_at_byte(at, format!("bad endianness marker in $MeshFormat: {why}")));
        }
    }
    let mut r = Reader {
        c,
        binary,
        dsize,
        v4,
        raw: RawMesh::default(),
        tags: HashMap::new(),
        has_nodes: false,
        has_elements: false,
    };
    r.end("$EndMeshFormat")?;
    while let Some((_, t)) = r.c.line_tokens() {
        match t[0] {
            "$Nodes" => r.nodes()?,
            "$Elements" => r.elements()?,
            s if s.starts_with('$') && !s.starts_with("$End") => {
                let end = format!("$End{}", &s[1..]);
                if !r.c.skip_past(end.as_bytes()) {
                    return Err(r.c.eof(&format!("section {s}: no {end}")));
                }
            }
            s => {
                return Err(r.c.err(format!("expected a section such as $Nodes, found '{s}'")));
            }
        }
    }
    let path = r.c.path;
    if !r.has_nodes {
        return Err(Error::parse(path, None, "missing $Nodes section"));
    }
    if !r.has_elements {
        return Err(Error::parse(path, None, "missing $Elements section"));
    }
    Ok(r.raw)
}

impl Reader<'_> {
    /// End of file in a text file; binary data must not be skipped as whitespace.
    fn eof_text(&mut self) -> bool {
        !self.binary && self.c.at_eof()
    }

    /// Counts on their own text line; in binary files the data starts right after.
    fn text_count(&mut self, what: &str) -> Result<usize> {
        let n = self.c.count(what)?;
        if self.binary {
            self.c.end_line();
        }
        Ok(n)
    }

    fn end(&mut self, what: &str) -> Result<()> {
        match self.c.line_tokens() {
            Some((_, t)) if t.first() == Some(&what) => Ok(()),
            Some((_, t)) => Err(self.c.err(format!("expected {what}, found '{}'", t.join(" ")))),
            None => Err(self.c.eof(what)),
        }
    }

    /// A count or tag: text token, or binary int (`size_t` when `wide`).
    fn uint(&mut self, wide: bool, what: &str) -> Result<u64> {
        if !self.binary {
            return self.c.parse(what);
        }
        let n = if wide { self.dsize } else { 4 };
        let b = self.c.bytes(n, what)?;
        Ok(match n {
            8 => u64::from_le_bytes(b.try_into().unwrap_or([0; 8])),
            _ => i32::from_le_bytes(b.try_into().unwrap_or([0; 4])) as u32 as u64,
        })
    }

    /// A count read from the file, bounded so that a bad header can't make us
    /// loop or allocate beyond what the file could contain.
    fn count(&mut self, wide: bool, what: &str) -> Result<usize> {
        let n = self.uint(wide, what)?;
        if n > self.c.remaining() as u64 {
            return Err(self.err(format!(
                "{what} is {n}, more than the file could hold (truncated file?)"
            )));
        }
        Ok(n as usize)
    }

    fn err(&self, msg: String) -> Error {
        if self.binary {
            self.c.err_byte(msg)
        } else {
            self.c.err(msg)
        }
    }

    fn coord(&mut self, what: &str) -> Result<f64> {
        if !self.binary {
            return self.c.parse(what);
        }
        let b = self.c.bytes(8, what)?;
        Ok(f64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
    }

    fn truncated(&self, what: &str, want: usize, got: usize) -> Error {
        Error::parse(
            self.c.path,
            None,
            format!("unexpected end of file while reading {what}: expected {want} entries, found {got}"),
        )
    }

    fn node(&mut self, tag: u64, i: usize) -> Result<()> {
        let what = "node coordinates";
        let mut p = [0.0; 3];
        for x in &mut p {
            *x = self.coord(what)?;
        }
        if p.iter().any(|x| !x.is_finite()) {
            return Err(self.err(format!("point {i} (node {tag}) has a non-finite coordinate {p:?}")));
        }
        let id = self.raw.points.len() as u32;
        if self.tags.insert(tag, id).is_some() {
            return Err(self.err(format!("node tag {tag} appears twice")));
        }
        self.raw.points.push(p);
        Ok(())
    }

    fn nodes(&mut self) -> Result<()> {
        if self.has_nodes {
            return Err(self.c.err("a second $Nodes section"));
        }
        self.has_nodes = true;
        if !self.v4 {
            let n = self.text_count("the number of nodes")?;
            self.raw.points.reserve(self.c.cap(n, 8));
            for i in 0..n {
                if self.eof_text() {
                    return Err(self.truncated("$Nodes", n, i));
                }
                let tag = self.uint(false, "a node tag")?;
                self.node(tag, i)?;
            }
        } else {
            let blocks = self.count(true, "numEntityBlocks")?;
            let n = self.count(true, "numNodes")?;
            self.uint(true, "minNodeTag")?;
            self.uint(true, "maxNodeTag")?;
            self.raw.points.reserve(self.c.cap(n, 8));
            let mut read = 0;
            for _ in 0..blocks {
                if self.eof_text() {
                    return Err(self.truncated("$Nodes", n, read));
                }
                let dim = self.uint(false, "entityDim")?;
                self.uint(false, "entityTag")?;
                let parametric = self.uint(false, "parametric")?;
                let k = self.count(true, "numNodesInBlock")?;
                let extra = if parametric != 0 && (1..=2).contains(&dim) {
                    dim as usize
                } else {
                    0
                };
                let mut tags = Vec::with_capacity(self.c.cap(k, 1));
                for j in 0..k {
                    if self.eof_text() {
                        return Err(self.truncated("$Nodes", n, read + j));
                    }
                    tags.push(self.uint(true, "a node tag")?);
                }
                for (j, &tag) in tags.iter().enumerate() {
                    if self.eof_text() {
                        return Err(self.truncated("$Nodes coordinates", n, read + j));
                    }
                    self.node(tag, read + j)?;
                    for _ in 0..extra {
                        self.coord("parametric coordinates")?;
                    }
                }
                read += k;
            }
            if read != n {
                return Err(self
                    .c
                    .err(format!("$Nodes header announces {n} nodes but the blocks hold {read}")));
            }
        }
        self.end("$EndNodes")
    }

    fn element(&mut self, tag: u64, t: i64, wide: bool) -> Result<()> {
        let shape = shape_of(tag, t).map_err(|m| self.err(m))?;
        let mut vs = [0u32; 8];
        let k = shape.num_vertices();
        for v in vs.iter_mut().take(k) {
            let nt = self.uint(wide, "element nodes")?;
            *v = *self.tags.get(&nt).ok_or_else(|| {
                self.err(format!(
                    "element {tag} refers to node {nt}, which is not in $Nodes ({} nodes)",
                    self.tags.len()
                ))
            })?;
        }
        self.raw.push(shape, &vs[..k]);
        Ok(())
    }

    fn elements(&mut self) -> Result<()> {
        if !self.has_nodes {
            return Err(self.c.err("$Elements before $Nodes"));
        }
        if self.has_elements {
            return Err(self.c.err("a second $Elements section"));
        }
        self.has_elements = true;
        if !self.v4 {
            let m = self.text_count("the number of elements")?;
            let mut read = 0;
            while read < m {
                if self.eof_text() {
                    return Err(self.truncated("$Elements", m, read));
                }
                if self.binary {
                    let t = self.uint(false, "element type")? as i64;
                    let k = self.count(false, "elements in block")?;
                    let ntags = self.count(false, "number of tags")?;
                    for _ in 0..k {
                        let tag = self.uint(false, "element tag")?;
                        for _ in 0..ntags {
                            self.uint(false, "element tags")?;
                        }
                        self.element(tag, t, false)?;
                    }
                    read += k.max(1);
                } else {
                    let tag = self.uint(false, "element tag")?;
                    let t: i64 = self.c.parse("element type")?;
                    let ntags = self.count(false, "number of tags")?;
                    for _ in 0..ntags {
                        self.c.parse::<i64>("element tags")?;
                    }
                    self.element(tag, t, false)?;
                    read += 1;
                }
            }
            if read != m {
                return Err(self
                    .c
                    .err_byte(format!("$Elements announces {m} elements but the blocks hold {read}")));
            }
        } else {
            let blocks = self.count(true, "numEntityBlocks")?;
            let m = self.count(true, "numElements")?;
            self.uint(true, "minElementTag")?;
            self.uint(true, "maxElementTag")?;
            let mut read = 0;
            for _ in 0..blocks {
                if self.eof_text() {
                    return Err(self.truncated("$Elements", m, read));
                }
                self.uint(false, "entityDim")?;
                self.uint(false, "entityTag")?;
                let t = self.uint(false, "elementType")? as i64;
                let k = self.count(true, "numElementsInBlock")?;
                for j in 0..k {
                    if self.eof_text() {
                        return Err(self.truncated("$Elements", m, read + j));
                    }
                    let tag = self.uint(true, "element tag")?;
                    self.element(tag, t, true)?;
                }
                read += k;
            }
            if read != m {
                return Err(self.c.err(format!(
                    "$Elements header announces {m} elements but the blocks hold {read}"
                )));
            }
        }
        self.end("$EndElements")
    }
}

/// Cells in output order: elements, lower cells, then point cells for fixed
/// vertices that no lower cell covers. Consecutive cells of one type form a run.
fn output_cells(mesh: &Mesh) -> Vec<(u32, usize, Vec<u32>)> {
    let mut cells: Vec<(u32, usize, Vec<u32>)> = (0..mesh.num_elements())
        .map(|e| (mesh.kinds[e].gmsh_id(), mesh.kinds[e].dim(), mesh.element(e).to_vec()))
        .collect();
    let mut covered = vec![false; mesh.num_points()];
    for (k, vs) in &mesh.lower {
        let (t, d) = match k {
            LowerKind::Vertex => (15, 0),
            LowerKind::Line => (1, 1),
            LowerKind::Triangle => (2, 2),
            LowerKind::Quadrilateral => (3, 2),
        };
        for &v in vs {
            covered[v as usize] = true;
        }
        cells.push((t, d, vs.clone()));
    }
    for (v, _) in mesh.fixed.iter().enumerate().filter(|&(v, &f)| f && !covered[v]) {
        cells.push((15, 0, vec![v as u32]));
    }
    cells
}

fn runs(cells: &[(u32, usize, Vec<u32>)]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=cells.len() {
        if i == cells.len() || cells[i].0 != cells[start].0 {
            out.push(start..i);
            start = i;
        }
    }
    out
}

pub(crate) fn write22(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    writeln!(w, "$MeshFormat\n2.2 {} 8", binary as u8)?;
    if binary {
        w.write_all(&1i32.to_le_bytes())?;
        writeln!(w)?;
    }
    writeln!(w, "$EndMeshFormat\n$Nodes\n{n}")?;
    let mut buf = Vec::new();
    for (i, p) in mesh.points.iter().enumerate() {
        if binary {
            buf.extend_from_slice(&(i as i32 + 1).to_le_bytes());
            p.iter().for_each(|c| buf.extend_from_slice(&c.to_le_bytes()));
        } else {
            writeln!(w, "{} {} {} {}", i + 1, fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
        buf.clear();
    }
    let cells = output_cells(mesh);
    writeln!(w, "$EndNodes\n$Elements\n{}", cells.len())?;
    let mut tag = 0i32;
    for run in runs(&cells) {
        let t = cells[run.start].0 as i32;
        if binary {
            for x in [t, run.len() as i32, 2] {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        }
        for (_, _, vs) in &cells[run] {
            tag += 1;
            if binary {
                for x in [tag, 0, 1] {
                    buf.extend_from_slice(&x.to_le_bytes());
                }
                vs.iter()
                    .for_each(|&v| buf.extend_from_slice(&(v as i32 + 1).to_le_bytes()));
            } else {
                write!(w, "{tag} {t} 2 0 1")?;
                for v in vs {
                    write!(w, " {}", v + 1)?;
                }
                writeln!(w)?;
            }
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
    }
    check_cell_data(mesh, cell_data)?;
    writeln!(w, "$EndElements")?;
    Ok(())
}

pub(crate) fn write41(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    let mut buf: Vec<u8> = Vec::new();
    // Header numbers go to `buf` in binary (as i32 or u64), else as text.
    let nums = |w: &mut dyn Write, buf: &mut Vec<u8>, ints: &[i32], sizes: &[u64]| -> std::io::Result<()> {
        if binary {
            ints.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
            sizes.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
            Ok(())
        } else {
            let all: Vec<String> = ints
                .iter()
                .map(|x| x.to_string())
                .chain(sizes.iter().map(|x| x.to_string()))
                .collect();
            writeln!(w, "{}", all.join(" "))
        }
    };
    writeln!(w, "$MeshFormat\n4.1 {} 8", binary as u8)?;
    if binary {
        w.write_all(&1i32.to_le_bytes())?;
        writeln!(w)?;
    }
    writeln!(w, "$EndMeshFormat\n$Nodes")?;
    let nblocks = u64::from(n > 0);
    nums(w, &mut buf, &[], &[nblocks, n as u64, 1.min(n as u64), n as u64])?;
    if n > 0 {
        nums(w, &mut buf, &[mesh.dim() as i32, 1, 0], &[n as u64])?;
        for i in 1..=n as u64 {
            nums(w, &mut buf, &[], &[i])?;
        }
        for p in &mesh.points {
            if binary {
                p.iter().for_each(|c| buf.extend_from_slice(&c.to_le_bytes()));
            } else {
                writeln!(w, "{} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
            }
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
        buf.clear();
    }
    writeln!(w, "$EndNodes\n$Elements")?;
    let cells = output_cells(mesh);
    let runs = runs(&cells);
    let m = cells.len() as u64;
    nums(w, &mut buf, &[], &[runs.len() as u64, m, 1.min(m), m])?;
    let mut tag = 0u64;
    for run in runs {
        let (t, dim, _) = &cells[run.start];
        nums(w, &mut buf, &[*dim as i32, 1, *t as i32], &[run.len() as u64])?;
        for (_, _, vs) in &cells[run] {
            tag += 1;
            let mut row = vec![tag];
            row.extend(vs.iter().map(|&v| v as u64 + 1));
            nums(w, &mut buf, &[], &row)?;
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
    }
    check_cell_data(mesh, cell_data)?;
    writeln!(w, "$EndElements")?;
    Ok(())
}
