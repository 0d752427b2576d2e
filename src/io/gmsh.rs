//! Gmsh `.msh` versions 2.2 and 4.1, ASCII and binary (little-endian).
//!
//! Node tags are renumbered to dense 0-based ids in file order. Fixed flags
//! are stored as point elements (type 15), so a round trip keeps them.
//!
//! Each element's physical and elementary tags become the cell arrays
//! `gmsh:physical` and `gmsh:geometrical` (meshio's names; in 4.1 files the
//! physical tag is the first of its entity's, from `$Entities`), and
//! `$PhysicalNames` is kept; the writers put them back. 4.1 entities and
//! the entity of each node are kept too (`entities`), and `$NodeData` /
//! `$ElementData` views become point and cell arrays and back (`views`).

mod entities;
mod views;

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use super::batch::write_records;
use super::lex::{Cursor, clip};
use super::{CellData, RawMesh, Shape, WriteResult, check_cell_data, fmt_f64};
use crate::error::{Error, Result};
use crate::mesh::data::{GMSH_DIM_TAGS, GMSH_ELEMENTARY, GMSH_PHYSICAL};
use crate::mesh::{DataArray, ElementKind, LowerKind, Mesh, PhysicalName, ValueType, Values};
use views::{ElementTags, On};

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

/// Node tag to point id. Gmsh numbers nodes 1..n almost always, so tags up
/// to about twice the node count index a table; only tags far beyond it (a
/// sparse numbering) go to a hash map, which keeps memory linear in the
/// nodes and the hash out of the element loop.
#[derive(Default)]
pub(crate) struct TagMap {
    dense: Vec<u32>,
    sparse: HashMap<u64, u32>,
    len: usize,
}

impl TagMap {
    const NONE: u32 = u32::MAX;

    /// False if `tag` is already there.
    pub(crate) fn insert(&mut self, tag: u64, id: u32) -> bool {
        if !self.sparse.is_empty() && self.sparse.contains_key(&tag) {
            return false;
        }
        let bound = 2 * (self.len as u64 + 1) + (1 << 16);
        if tag >= self.dense.len() as u64 && tag < bound {
            let want = (tag as usize + 1).max((2 * self.dense.len()).min(bound as usize));
            self.dense.resize(want, Self::NONE);
        }
        match usize::try_from(tag).ok().and_then(|t| self.dense.get_mut(t)) {
            Some(slot) => {
                if *slot != Self::NONE {
                    return false;
                }
                *slot = id;
            }
            _ => {
                self.sparse.insert(tag, id);
            }
        }
        self.len += 1;
        true
    }

    pub(crate) fn get(&self, tag: u64) -> Option<u32> {
        match usize::try_from(tag).ok().and_then(|t| self.dense.get(t)) {
            Some(&id) if id != Self::NONE => Some(id),
            _ if self.sparse.is_empty() => None,
            _ => self.sparse.get(&tag).copied(),
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.len
    }
}

struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
    /// Bytes of a `size_t` in 4.1 binary files.
    dsize: usize,
    v4: bool,
    raw: RawMesh,
    tags: TagMap,
    has_nodes: bool,
    has_elements: bool,
    /// Physical and elementary tag of every cell read.
    physical: Vec<i64>,
    elementary: Vec<i64>,
    /// 4.1: the first physical tag of each (dim, entity tag).
    entity_physical: HashMap<(i32, i32), i64>,
    /// 4.1: each node's entity, (dim, tag) after (dim, tag).
    node_dim_tags: Vec<i64>,
    /// The tag of every cell read.
    element_tags: ElementTags,
    /// Element tag to cell, built for the first `$ElementData`.
    element_index: Option<TagMap>,
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &super::limits::Budget) -> Result<RawMesh> {
    let mut c = Cursor::new(path, data);
    c.budget = Some(budget);
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
        tags: TagMap::default(),
        has_nodes: false,
        has_elements: false,
        physical: Vec::new(),
        elementary: Vec::new(),
        entity_physical: HashMap::new(),
        node_dim_tags: Vec::new(),
        element_tags: ElementTags::default(),
        element_index: None,
    };
    r.end("$EndMeshFormat")?;
    while let Some((_, t)) = r.c.line_tokens() {
        match t[0] {
            "$Nodes" => r.nodes()?,
            "$Elements" => r.elements()?,
            "$PhysicalNames" => r.physical_names()?,
            "$Entities" if r.v4 => r.entities()?,
            "$NodeData" => r.view(On::Nodes)?,
            "$ElementData" => r.view(On::Elements)?,
            s if s.starts_with('$') && !s.starts_with("$End") => {
                let end = format!("$End{}", &s[1..]);
                if !r.c.skip_past(end.as_bytes()) {
                    return Err(r.c.eof(&format!("section {s}: no {end}")));
                }
            }
            s => {
                return Err(r
                    .c
                    .err(format!("expected a section such as $Nodes, found '{}'", clip(s))));
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
    let mut raw = r.raw;
    if r.v4 && r.node_dim_tags.len() == 2 * raw.points.len() {
        raw.point_data.retain(|a| a.name != GMSH_DIM_TAGS);
        raw.point_data.insert(
            0,
            DataArray::new(GMSH_DIM_TAGS, ValueType::I32, 2, Values::Int(r.node_dim_tags)),
        );
    }
    // the tags first, then the views (a view named like a tag array gives way)
    let views = std::mem::take(&mut raw.cell_data);
    raw.cell_data.push(DataArray::new(
        GMSH_PHYSICAL,
        ValueType::I32,
        1,
        Values::Int(r.physical),
    ));
    raw.cell_data.push(DataArray::new(
        GMSH_ELEMENTARY,
        ValueType::I32,
        1,
        Values::Int(r.elementary),
    ));
    raw.cell_data.extend(
        views
            .into_iter()
            .filter(|a| a.name != GMSH_PHYSICAL && a.name != GMSH_ELEMENTARY),
    );
    Ok(raw)
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
        if !self.tags.insert(tag, id) {
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
            self.raw.points.reserve(self.c.reserve("$Nodes", n, 8, 24)?);
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
            self.raw.points.reserve(self.c.reserve("$Nodes", n, 8, 24)?);
            let mut read = 0;
            for _ in 0..blocks {
                if self.eof_text() {
                    return Err(self.truncated("$Nodes", n, read));
                }
                let dim = self.uint(false, "entityDim")?;
                let entity = self.int("entityTag")?;
                let parametric = self.uint(false, "parametric")?;
                let k = self.count(true, "numNodesInBlock")?;
                for _ in 0..k {
                    self.node_dim_tags.extend([dim as i64, i64::from(entity)]);
                }
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
                if self.binary && extra == 0 && self.bulk_nodes(&tags)? {
                    read += k;
                    continue;
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

    fn element(&mut self, tag: u64, t: i64, wide: bool, physical: i64, elementary: i64) -> Result<()> {
        self.element_tags.push(tag, self.physical.len());
        self.physical.push(physical);
        self.elementary.push(elementary);
        let shape = shape_of(tag, t).map_err(|m| self.err(m))?;
        let mut vs = [0u32; 8];
        let k = shape.num_vertices();
        for v in vs.iter_mut().take(k) {
            let nt = self.uint(wide, "element nodes")?;
            *v = self.tags.get(nt).ok_or_else(|| {
                self.err(format!(
                    "element {tag} refers to node {nt}, which is not in $Nodes ({} nodes)",
                    self.tags.len()
                ))
            })?;
        }
        self.raw.push(shape, &vs[..k]);
        Ok(())
    }

    /// The coordinates of a binary 4.1 node block read at once and decoded
    /// in parallel; false (nothing consumed) when the block is short or has
    /// a non-finite coordinate, which the node-by-node loop then reports.
    fn bulk_nodes(&mut self, tags: &[u64]) -> Result<bool> {
        let k = tags.len();
        if k == 0 || k.saturating_mul(24) > self.c.remaining() {
            return Ok(false);
        }
        let save = self.c.clone();
        let bytes = self.c.bytes(k * 24, "node coordinates")?;
        let f = |b: &[u8]| f64::from_le_bytes(b.try_into().unwrap_or([0; 8]));
        let points: Vec<[f64; 3]> = bytes
            .par_chunks_exact(24)
            .map(|b| [f(&b[..8]), f(&b[8..16]), f(&b[16..])])
            .collect();
        if !points.par_iter().all(|p| p.iter().all(|x| x.is_finite())) {
            self.c = save;
            return Ok(false);
        }
        let base = self.raw.points.len() as u32;
        for (j, &tag) in tags.iter().enumerate() {
            if !self.tags.insert(tag, base + j as u32) {
                // where the node-by-node loop stops: after this node's coordinates
                self.c = save;
                self.c.bytes((j + 1) * 24, "node coordinates")?;
                return Err(self.err(format!("node tag {tag} appears twice")));
            }
        }
        self.raw.points.extend_from_slice(&points);
        Ok(true)
    }

    /// A binary 4.1 block of `k` elements of type `t` read at once, the node
    /// tags looked up in parallel. False (nothing consumed) when the block
    /// is short or names an unknown node or type: the element-by-element
    /// loop then reads it and names the culprit.
    fn bulk_elements(&mut self, k: usize, t: i64, physical: i64, elementary: i64) -> bool {
        let Ok(shape) = shape_of(0, t) else {
            return false;
        };
        let (nv, d) = (shape.num_vertices(), self.dsize);
        let rec = (1 + nv) * d;
        let Some(len) = k.checked_mul(rec).filter(|&l| l <= self.c.remaining() && k > 0) else {
            return false;
        };
        let save = self.c.clone();
        let Ok(bytes) = self.c.bytes(len, "elements") else {
            self.c = save;
            return false;
        };
        let word = |b: &[u8]| match d {
            8 => u64::from_le_bytes(b.try_into().unwrap_or([0; 8])),
            _ => i32::from_le_bytes(b.try_into().unwrap_or([0; 4])) as u32 as u64,
        };
        let mut ids = vec![0u32; k * nv];
        let tags = &self.tags;
        let found = ids
            .par_chunks_mut(nv.max(1))
            .zip(bytes.par_chunks_exact(rec))
            .with_min_len(1 << 12)
            .all(|(out, r)| {
                out.iter_mut()
                    .zip(r[d..].chunks_exact(d))
                    .all(|(o, b)| match tags.get(word(b)) {
                        Some(id) => {
                            *o = id;
                            true
                        }
                        None => false,
                    })
            });
        if !found {
            self.c = save;
            return false;
        }
        self.raw.push_block(shape, nv, ids);
        for (i, r) in bytes.chunks_exact(rec).enumerate() {
            self.element_tags.push(word(&r[..d]), self.physical.len() + i);
        }
        self.physical.resize(self.physical.len() + k, physical);
        self.elementary.resize(self.elementary.len() + k, elementary);
        true
    }

    /// A signed int (text, or 4 binary bytes): entity tags can be negative.
    fn int(&mut self, what: &str) -> Result<i32> {
        if !self.binary {
            return self.c.parse(what);
        }
        Ok(self.uint(false, what)? as u32 as i32)
    }

    /// `$PhysicalNames` (text even in binary files): `dim tag "name"` lines.
    fn physical_names(&mut self) -> Result<()> {
        let n = self.c.count("the number of physical names")?;
        for _ in 0..n {
            let (_, t) = self.c.line_tokens().ok_or_else(|| self.c.eof("$PhysicalNames"))?;
            let bad = || {
                self.c.err(format!(
                    "expected 'dim tag \"name\"' in $PhysicalNames, found '{}'",
                    clip(&t.join(" "))
                ))
            };
            if t.len() < 3 {
                return Err(bad());
            }
            let dim: i32 = t[0].parse().map_err(|_| bad())?;
            let tag: i32 = t[1].parse().map_err(|_| bad())?;
            let quoted = t[2..].join(" ");
            // Gmsh itself crashes on a group of another dimension: refuse it
            // here rather than copy it into every output
            if !(0..=3).contains(&dim) {
                return Err(self.c.err(format!(
                    "$PhysicalNames: physical group {tag} has dimension {dim}; a dimension is 0, 1, 2 or 3"
                )));
            }
            if tag <= 0 {
                return Err(self.c.err(format!(
                    "$PhysicalNames: physical tag {tag} (dimension {dim}) is not positive"
                )));
            }
            let name = match quoted.strip_prefix('"').and_then(|q| q.strip_suffix('"')) {
                Some(name) => name.to_string(),
                None => {
                    return Err(self.c.err(format!(
                        "$PhysicalNames: the name of physical group {tag} (dimension {dim}) is not in double \
                         quotes: {}",
                        clip(&quoted)
                    )));
                }
            };
            self.raw.physical_names.push(PhysicalName { dim, tag, name });
        }
        self.end("$EndPhysicalNames")
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
                        let mut tags = [0i64, 0];
                        for i in 0..ntags {
                            let v = self.uint(false, "element tags")? as u32 as i32 as i64;
                            if i < 2 {
                                tags[i] = v;
                            }
                        }
                        self.element(tag, t, false, tags[0], tags[1])?;
                    }
                    read += k.max(1);
                } else {
                    let tag = self.uint(false, "element tag")?;
                    let t: i64 = self.c.parse("element type")?;
                    let ntags = self.count(false, "number of tags")?;
                    let mut tags = [0i64, 0];
                    for i in 0..ntags {
                        let v = self.c.parse::<i64>("element tags")?;
                        if i < 2 {
                            tags[i] = v;
                        }
                    }
                    self.element(tag, t, false, tags[0], tags[1])?;
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
                let dim = self.int("entityDim")?;
                let entity = self.int("entityTag")?;
                let physical = self.entity_physical.get(&(dim, entity)).copied().unwrap_or(0);
                let t = self.uint(false, "elementType")? as i64;
                let k = self.count(true, "numElementsInBlock")?;
                if self.binary && self.bulk_elements(k, t, physical, entity as i64) {
                    read += k;
                    continue;
                }
                for j in 0..k {
                    if self.eof_text() {
                        return Err(self.truncated("$Elements", m, read + j));
                    }
                    let tag = self.uint(true, "element tag")?;
                    self.element(tag, t, true, physical, entity as i64)?;
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

/// One cell to write: Gmsh type, dimension, vertices, physical and elementary tag.
struct OutCell<'a> {
    t: u32,
    dim: usize,
    vs: std::borrow::Cow<'a, [u32]>,
    physical: i32,
    elementary: i32,
}

/// Cells in output order: elements, lower cells, then point cells for fixed
/// vertices that no lower cell covers. Tags come from the `gmsh:physical` /
/// `gmsh:geometrical` arrays where the mesh has them (physical 0 = none,
/// elementary 1 otherwise).
fn output_cells(mesh: &Mesh) -> Vec<OutCell<'_>> {
    let tag = |a: Option<&DataArray>, i: usize, default: i32| a.map_or(default, |a| a.get_i64(i) as i32);
    let (ep, ee) = (
        mesh.data.cell_array(GMSH_PHYSICAL),
        mesh.data.cell_array(GMSH_ELEMENTARY),
    );
    let (lp, le) = (
        mesh.data.lower_array(GMSH_PHYSICAL),
        mesh.data.lower_array(GMSH_ELEMENTARY),
    );
    let mut cells: Vec<OutCell> = (0..mesh.num_elements())
        .into_par_iter()
        .with_min_len(1 << 12)
        .map(|e| OutCell {
            // polyhedra are refused before any writer runs (`io::write`)
            t: mesh.kinds[e].gmsh_id().unwrap_or(0),
            dim: mesh.kinds[e].dim(),
            vs: mesh.element(e).into(),
            physical: tag(ep, e, 0),
            elementary: tag(ee, e, 1),
        })
        .collect();
    let mut covered = vec![false; mesh.num_points()];
    for (i, (k, vs)) in mesh.lower.iter().enumerate() {
        let (t, dim) = match k {
            LowerKind::Vertex => (15, 0),
            LowerKind::Line => (1, 1),
            LowerKind::Triangle => (2, 2),
            LowerKind::Quadrilateral => (3, 2),
        };
        for &v in vs {
            covered[v as usize] = true;
        }
        cells.push(OutCell {
            t,
            dim,
            vs: vs.as_slice().into(),
            physical: tag(lp, i, 0),
            elementary: tag(le, i, 1),
        });
    }
    for (v, _) in mesh.fixed.iter().enumerate().filter(|&(v, &f)| f && !covered[v]) {
        cells.push(OutCell {
            t: 15,
            dim: 0,
            vs: vec![v as u32].into(),
            physical: 0,
            elementary: 1,
        });
    }
    cells
}

/// Runs of consecutive cells with the same type (and, for 4.1 blocks, the
/// same elementary entity).
fn runs(cells: &[OutCell<'_>], by_entity: bool) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=cells.len() {
        if i == cells.len()
            || cells[i].t != cells[start].t
            || (by_entity && cells[i].elementary != cells[start].elementary)
        {
            out.push(start..i);
            start = i;
        }
    }
    out
}

fn write_physical_names(w: &mut dyn Write, mesh: &Mesh) -> WriteResult {
    let names = &mesh.data.physical_names;
    if names.is_empty() {
        return Ok(());
    }
    // what the reader refuses (Gmsh 4.8 crashes on a bad dimension) is not written either
    if let Some(p) = names.iter().find(|p| !(0..=3).contains(&p.dim) || p.tag <= 0) {
        return Err(Error::InvalidMesh(format!(
            "cannot write physical group '{}' (dimension {}, tag {}): a Gmsh group has a dimension 0 to 3 and a positive tag",
            p.name, p.dim, p.tag
        ))
        .into());
    }
    writeln!(w, "$PhysicalNames\n{}", names.len())?;
    for p in names {
        let name: String = p.name.chars().filter(|&c| c != '"' && c != '\n').collect();
        writeln!(w, "{} {} \"{name}\"", p.dim, p.tag)?;
    }
    writeln!(w, "$EndPhysicalNames")?;
    Ok(())
}

pub(crate) fn write22(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    writeln!(w, "$MeshFormat\n2.2 {} 8", binary as u8)?;
    if binary {
        w.write_all(&1i32.to_le_bytes())?;
        writeln!(w)?;
    }
    writeln!(w, "$EndMeshFormat")?;
    write_physical_names(w, mesh)?;
    writeln!(w, "$Nodes\n{n}")?;
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
    for run in runs(&cells, false) {
        let t = cells[run.start].t as i32;
        if binary {
            for x in [t, run.len() as i32, 2] {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        }
        for c in &cells[run] {
            tag += 1;
            if binary {
                for x in [tag, c.physical, c.elementary] {
                    buf.extend_from_slice(&x.to_le_bytes());
                }
                c.vs.iter()
                    .for_each(|&v| buf.extend_from_slice(&(v as i32 + 1).to_le_bytes()));
            } else {
                write!(w, "{tag} {t} 2 {} {}", c.physical, c.elementary)?;
                for v in c.vs.iter() {
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
    views::write_views(w, mesh, binary)
}

pub(crate) fn write41(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData], binary: bool) -> WriteResult {
    let n = mesh.num_points();
    let mut buf: Vec<u8> = Vec::new();
    // Numbers go to `buf` in binary (ints as i32, sizes as u64, reals as f64),
    // else as one text line.
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
    let flush = |w: &mut dyn Write, buf: &mut Vec<u8>| -> std::io::Result<()> {
        if binary {
            w.write_all(buf)?;
            writeln!(w)?;
            buf.clear();
        }
        Ok(())
    };
    writeln!(w, "$MeshFormat\n4.1 {} 8", binary as u8)?;
    if binary {
        w.write_all(&1i32.to_le_bytes())?;
        writeln!(w)?;
    }
    writeln!(w, "$EndMeshFormat")?;
    write_physical_names(w, mesh)?;
    let cells = output_cells(mesh);
    let blocks = entities::node_blocks(mesh, &cells);
    entities::write_entities(w, &entities::entities(mesh, &cells, &blocks), binary)?;
    writeln!(w, "$Nodes")?;
    nums(
        w,
        &mut buf,
        &[],
        &[blocks.len() as u64, n as u64, 1.min(n as u64), n as u64],
    )?;
    for b in &blocks {
        let (start, k) = (b.nodes.start, b.nodes.len());
        nums(w, &mut buf, &[b.dim as i32, b.tag, 0], &[k as u64])?;
        if binary {
            // tags and coordinates encoded in parallel batches
            w.write_all(&buf)?;
            buf.clear();
            write_records(w, k, 8, |i, out| {
                out.copy_from_slice(&((start + i) as u64 + 1).to_le_bytes())
            })?;
            write_records(w, k, 24, |i, out| {
                for (c, x) in mesh.points[start + i].iter().enumerate() {
                    out[8 * c..8 * c + 8].copy_from_slice(&x.to_le_bytes());
                }
            })?;
        } else {
            for i in b.nodes.clone() {
                nums(w, &mut buf, &[], &[i as u64 + 1])?;
            }
            for p in &mesh.points[b.nodes.clone()] {
                writeln!(w, "{} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]))?;
            }
        }
    }
    flush(w, &mut buf)?;
    writeln!(w, "$EndNodes\n$Elements")?;
    let runs = runs(&cells, true);
    let m = cells.len() as u64;
    nums(w, &mut buf, &[], &[runs.len() as u64, m, 1.min(m), m])?;
    let mut tag = 0u64;
    for run in runs {
        let c0 = &cells[run.start];
        nums(
            w,
            &mut buf,
            &[c0.dim as i32, c0.elementary, c0.t as i32],
            &[run.len() as u64],
        )?;
        let nv = c0.vs.len();
        let cs = &cells[run.clone()];
        if binary && cs.par_iter().all(|c| c.vs.len() == nv) {
            // a run's cells have one type, so rows of one length: encoded in
            // parallel, each row at its own offset
            w.write_all(&buf)?;
            buf.clear();
            write_records(w, cs.len(), 8 * (nv + 1), |i, out| {
                out[..8].copy_from_slice(&(tag + 1 + i as u64).to_le_bytes());
                for (k, &v) in cs[i].vs.iter().enumerate() {
                    out[8 * k + 8..8 * k + 16].copy_from_slice(&(v as u64 + 1).to_le_bytes());
                }
            })?;
            tag += cs.len() as u64;
            continue;
        }
        for c in &cells[run] {
            tag += 1;
            let mut row = vec![tag];
            row.extend(c.vs.iter().map(|&v| v as u64 + 1));
            nums(w, &mut buf, &[], &row)?;
        }
    }
    flush(w, &mut buf)?;
    check_cell_data(mesh, cell_data)?;
    writeln!(w, "$EndElements")?;
    views::write_views(w, mesh, binary)
}

#[cfg(test)]
mod tests {
    use super::TagMap;

    #[test]
    fn tag_map_finds_dense_and_sparse_tags_and_refuses_repeats() {
        let mut m = TagMap::default();
        let tags = [1u64, 2, 3, 1 << 40, 7, 500_000, 4];
        for (i, &t) in tags.iter().enumerate() {
            assert!(m.insert(t, i as u32), "tag {t}");
        }
        for (i, &t) in tags.iter().enumerate() {
            assert_eq!(m.get(t), Some(i as u32), "tag {t}");
        }
        assert_eq!(m.get(5), None);
        assert_eq!(m.get(u64::MAX), None);
        assert!(!m.insert(1 << 40, 9));
        assert!(!m.insert(3, 9));
        // a tag first stored sparsely is still found once the table has grown past it
        for t in 8..200_000u64 {
            assert!(m.insert(t, t as u32));
        }
        assert!(!m.insert(500_000, 1));
        assert_eq!(m.get(500_000), Some(5));
        assert_eq!(m.len(), tags.len() + 200_000 - 8);
    }
}
