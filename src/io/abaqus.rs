//! Abaqus input files (`.inp`), ASCII: nodes, linear elements and their sets.
//!
//! Read: `*NODE`, `*ELEMENT` of the linear types whose shape meshsmooth
//! has (solids C3D4, C3D6, C3D8 and their variants; planar, shell,
//! membrane and rigid triangles and quadrilaterals; trusses, beams and
//! rigid lines, which are lower cells), `*NSET`/`*ELSET` (lists, set
//! names, `GENERATE` ranges, `*NSET, ELSET=`), the `NSET=`/`ELSET=` of
//! `*NODE`/`*ELEMENT`, and `*INCLUDE` (relative to the including file, at
//! most [`MAX_INCLUDE_DEPTH`] deep, cycles refused). A part instanced once
//! with no translation or rotation (what most exporters write) reads as
//! that part, without the assembly's own nodes (reference points) and their
//! sets; more parts or instances are refused. Every other keyword
//! (materials, sections, steps, surfaces) is skipped with its data lines.
//! Quadratic elements, pyramids and types of no known shape are refused
//! with the type's name, the file and the line.
//!
//! Abaqus's corner orders are VTK's (and so meshsmooth's) for the linear
//! tetrahedron, wedge and hexahedron: faces 1-2-3(-4) with their normal
//! into the element, the second end 4-5-6(-7-8) above the first.
//!
//! Node and element numbers are kept as the point array `abaqus:node_id`
//! and the cell array `abaqus:element_id`, each cell's type as an index
//! (cell array `abaqus:type`) into the field array `abaqus:types` (see
//! [`ABAQUS_NODE_ID`](crate::mesh::data::ABAQUS_NODE_ID)), so a mesh
//! written back as `.inp`, even by way of a `.vtu`, has the input's numbers
//! and types. Writing, a mesh without them is numbered from 1 and takes
//! each kind's common type (C3D4, C3D8, C3D6, CPS3, CPS4, T3D2 or T2D2);
//! element sets, node sets and Gmsh physical groups become `*ELSET`s and
//! `*NSET`s. Elements are written in one `*ELEMENT` block per type, so a
//! mesh whose kinds interleave comes back grouped by type (each element
//! keeps its number). Lower point cells have no Abaqus element and are not written;
//! fixed vertices are written as the node set [`FIXED_SET`], which reads
//! back as fixed flags rather than as a set.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::gmsh::TagMap;
use super::lex::clip;
use super::limits::Budget;
use super::{CellData, RawMesh, Shape, WriteResult, check_cell_data, fmt_f64, is_planar_z0};
use crate::error::{Error, Location, Result};
use crate::mesh::data::{
    ABAQUS_ELEMENT_ID as ELEMENT_ID, ABAQUS_NODE_ID as NODE_ID, ABAQUS_TYPE as TYPE, ABAQUS_TYPES as TYPES,
    GMSH_PHYSICAL,
};
use crate::mesh::{DataArray, ElementKind, LowerKind, Mesh, NodeSet, ValueType, Values};

/// Includes nest at most this deep: deeper is a cycle in disguise or a bomb.
pub const MAX_INCLUDE_DEPTH: usize = 16;

/// Data lines of an element wrap after this many entries.
const WRAP: usize = 16;

/// Type-name families: the letters before the node count, and what the
/// count makes of them.
#[derive(Clone, Copy, PartialEq)]
enum Family {
    Solid,
    Surface,
    Line,
    Beam,
}

/// Longest first, so `SFM3D` wins over `S` and `CPEG` over `CPE`.
const FAMILIES: [(&str, Family); 22] = [
    ("SFM3D", Family::Surface),
    ("DCAX", Family::Surface),
    ("DC3D", Family::Solid),
    ("DC2D", Family::Surface),
    ("CGAX", Family::Surface),
    ("CPEG", Family::Surface),
    ("STRI", Family::Surface),
    ("RB3D", Family::Line),
    ("RB2D", Family::Line),
    ("C3D", Family::Solid),
    ("CPS", Family::Surface),
    ("CPE", Family::Surface),
    ("CAX", Family::Surface),
    ("M3D", Family::Surface),
    ("R3D", Family::Surface),
    ("R2D", Family::Line),
    ("T3D", Family::Line),
    ("T2D", Family::Line),
    ("SC", Family::Solid),
    ("DS", Family::Surface),
    ("S", Family::Surface),
    ("B", Family::Beam),
];

/// The shape of an element type (`C3D8R`, `CPS3`, `B31`), or why it is refused.
fn shape_of(ty: &str) -> std::result::Result<Shape, String> {
    let upper = ty.to_ascii_uppercase();
    let unknown = || {
        format!(
            "element type {ty} is not supported: meshsmooth reads the linear solids (C3D4, C3D6, C3D8 \
             and their variants), triangles and quadrilaterals (CPS3, CPE3, CAX3, S3, M3D3, R3D3, CPS4, \
             CPE4, CAX4, S4, M3D4, R3D4, ...) and lines (T3D2, T2D2, B31, B21)"
        )
    };
    let quadratic = || {
        format!(
            "element type {ty} is quadratic (it has mid-edge nodes); meshsmooth smooths linear elements \
             only: convert the mesh to first order (C3D4, C3D6, C3D8, CPS3, CPS4, ...)"
        )
    };
    let Some(&(prefix, family)) = FAMILIES.iter().find(|(p, _)| upper.starts_with(p)) else {
        return Err(unknown());
    };
    let rest = &upper[prefix.len()..];
    let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
    let Ok(count) = rest[..digits].parse::<u32>() else {
        return Err(unknown());
    };
    if rest[digits..].bytes().any(|b| !b.is_ascii_alphanumeric()) {
        return Err(unknown());
    }
    Ok(match (family, count) {
        (Family::Solid, 4) => Shape::Elem(ElementKind::Tetrahedron),
        (Family::Solid, 6) => Shape::Elem(ElementKind::Prism),
        (Family::Solid, 8) => Shape::Elem(ElementKind::Hexahedron),
        (Family::Solid, 5) => {
            return Err(format!(
                "element type {ty} is a pyramid; pyramids are not supported: the corner-based metrics \
                 need exactly 3 edges at every corner"
            ));
        }
        (Family::Solid, 10 | 13 | 15 | 20 | 27) => return Err(quadratic()),
        (Family::Surface, 3) => Shape::Elem(ElementKind::Triangle),
        (Family::Surface, 4) => Shape::Elem(ElementKind::Quadrilateral),
        (Family::Surface, 6 | 8 | 9 | 65) => return Err(quadratic()),
        (Family::Line, 2) => Shape::Line,
        (Family::Line, 3) => return Err(quadratic()),
        // B31, B21: linear; B33, B23: cubic in the displacement, 2 nodes;
        // B32, B22: 3 nodes
        (Family::Beam, 21 | 31 | 23 | 33) => Shape::Line,
        (Family::Beam, 22 | 32) => return Err(quadratic()),
        _ => return Err(unknown()),
    })
}

/// The type written for a cell of this shape that has none from a file.
fn default_type(shape: Shape, planar: bool) -> &'static str {
    match shape {
        Shape::Elem(ElementKind::Triangle) => "CPS3",
        Shape::Elem(ElementKind::Quadrilateral) => "CPS4",
        Shape::Elem(ElementKind::Tetrahedron) => "C3D4",
        Shape::Elem(ElementKind::Hexahedron) => "C3D8",
        Shape::Elem(ElementKind::Prism) => "C3D6",
        Shape::Line if planar => "T2D2",
        Shape::Line => "T3D2",
        Shape::Vertex | Shape::Elem(ElementKind::Polyhedron) => unreachable!("not written as elements"),
    }
}

/// A keyword line: the keyword and its parameters, names in upper case
/// without blanks (Abaqus ignores both), values as written.
struct Keyword<'a> {
    name: String,
    params: Vec<(String, &'a str)>,
}

impl<'a> Keyword<'a> {
    fn parse(line: &'a str) -> Keyword<'a> {
        let mut parts = line[1..].split(',');
        let squeeze = |s: &str| -> String {
            s.chars()
                .filter(|c| !c.is_whitespace())
                .map(|c| c.to_ascii_uppercase())
                .collect()
        };
        let name = squeeze(parts.next().unwrap_or(""));
        let params = parts
            .filter(|p| !p.trim().is_empty())
            .map(|p| match p.split_once('=') {
                Some((k, v)) => (squeeze(k), v.trim().trim_matches('"')),
                None => (squeeze(p), ""),
            })
            .collect();
        Keyword { name, params }
    }

    fn get(&self, name: &str) -> Option<&'a str> {
        self.params.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }

    fn has(&self, name: &str) -> bool {
        self.params.iter().any(|(k, _)| k == name)
    }
}

/// Named sets as read: members in the order given (sorted and made
/// unique at the end), found by name in any case.
#[derive(Default)]
struct Sets {
    names: Vec<String>,
    members: Vec<Vec<u32>>,
    index: HashMap<String, usize>,
}

impl Sets {
    fn find(&self, name: &str) -> Option<usize> {
        let key = name.to_ascii_uppercase();
        self.index.get(&key).copied().or_else(|| {
            // `Instance.Set` at assembly level names the set of the one instance
            let (_, set) = key.rsplit_once('.')?;
            self.index.get(set).copied()
        })
    }

    fn get_or_add(&mut self, name: &str) -> usize {
        let key = name.to_ascii_uppercase();
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        self.names.push(name.to_string());
        self.members.push(Vec::new());
        self.index.insert(key, self.names.len() - 1);
        self.names.len() - 1
    }

    fn finish(self) -> Vec<(String, Vec<u32>)> {
        self.names
            .into_iter()
            .zip(self.members)
            .map(|(n, mut m)| {
                m.sort_unstable();
                m.dedup();
                (n, m)
            })
            .collect()
    }
}

/// What the data lines after the current keyword are.
enum Block {
    Skip,
    Nodes {
        nset: Option<usize>,
    },
    Elements {
        shape: Shape,
        nv: usize,
        ty: i64,
        name: String,
        elset: Option<usize>,
    },
    NodeSet {
        set: usize,
        generate: bool,
    },
    NodeSetOfElements,
    ElementSet {
        set: usize,
        generate: bool,
    },
    Instance,
}

/// Where a data line is: for errors.
#[derive(Clone, Copy)]
struct At<'p> {
    path: &'p Path,
    line: usize,
}

impl At<'_> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Line(self.line)), msg)
    }
}

struct Reader<'b> {
    budget: &'b Budget,
    raw: RawMesh,
    nodes: TagMap,
    node_ids: Vec<i64>,
    elements: TagMap,
    element_ids: Vec<i64>,
    cell_types: Vec<i64>,
    types: Vec<String>,
    nsets: Sets,
    elsets: Sets,
    block: Block,
    /// An element record begun on an earlier line: its entries and line.
    pending: Vec<i64>,
    pending_line: usize,
    parts: Vec<String>,
    instances: Vec<String>,
    /// Inside `*ASSEMBLY`, and inside its `*INSTANCE`.
    in_assembly: bool,
    in_instance: bool,
    /// The files being read, outermost first: an include of one is a cycle.
    open: Vec<PathBuf>,
}

pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let mut r = Reader {
        budget,
        raw: RawMesh::default(),
        nodes: TagMap::default(),
        node_ids: Vec::new(),
        elements: TagMap::default(),
        element_ids: Vec::new(),
        cell_types: Vec::new(),
        types: Vec::new(),
        nsets: Sets::default(),
        elsets: Sets::default(),
        block: Block::Skip,
        pending: Vec::new(),
        pending_line: 0,
        parts: Vec::new(),
        instances: Vec::new(),
        in_assembly: false,
        in_instance: false,
        open: Vec::new(),
    };
    r.file(path, data)?;
    if r.raw.points.is_empty() {
        return Err(Error::parse(path, None, "the file has no *NODE data"));
    }
    let Reader {
        mut raw,
        node_ids,
        element_ids,
        cell_types,
        types,
        nsets,
        elsets,
        ..
    } = r;
    raw.point_data
        .push(DataArray::new(NODE_ID, ValueType::I64, 1, Values::Int(node_ids)));
    if !element_ids.is_empty() {
        raw.cell_data
            .push(DataArray::new(ELEMENT_ID, ValueType::I64, 1, Values::Int(element_ids)));
        raw.cell_data
            .push(DataArray::new(TYPE, ValueType::I32, 1, Values::Int(cell_types)));
        raw.field_data
            .push(DataArray::new(TYPES, ValueType::Str, 1, Values::Str(types)));
    }
    for (name, vertices) in nsets.finish() {
        if name.eq_ignore_ascii_case(FIXED_SET) {
            vertices.iter().for_each(|&v| raw.fix(v as usize));
        } else {
            raw.node_sets.push(NodeSet { name, vertices });
        }
    }
    raw.cell_sets = elsets.finish();
    Ok(raw)
}

impl Reader<'_> {
    fn file(&mut self, path: &Path, data: &[u8]) -> Result<()> {
        self.open.push(path.to_path_buf());
        let mut line_no = 0;
        for bytes in data.split(|&b| b == b'\n') {
            line_no += 1;
            let at = At { path, line: line_no };
            let text = std::str::from_utf8(bytes).map_err(|_| at.err("the line is not text (UTF-8)"))?;
            let line = text.trim();
            if line.is_empty() || line.starts_with("**") {
                continue;
            }
            if line.starts_with('*') {
                self.end_record(at)?;
                self.keyword(at, line)?;
                continue;
            }
            if matches!(self.block, Block::Skip) {
                continue;
            }
            // a line ending with a comma goes on on the next: set and node
            // lines read the same line by line, element records are joined
            // in `element`
            let comma = line.ends_with(',');
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let fields = match fields.split_last() {
                Some((&"", head)) => head,
                _ => &fields[..],
            };
            self.data(at, fields, comma)?;
        }
        self.end_record(At { path, line: line_no })?;
        self.open.pop();
        Ok(())
    }

    fn keyword(&mut self, at: At, line: &str) -> Result<()> {
        let kw = Keyword::parse(line);
        let param = |name: &str| {
            kw.get(name)
                .filter(|v| !v.is_empty())
                .ok_or_else(|| at.err(format!("*{} needs {name}=", kw.name)))
        };
        // nodes of the assembly itself (reference points) and sets of them
        // are no part of the instance's mesh: their numbers are their own
        let of_assembly = self.in_assembly && !self.in_instance;
        self.block = match kw.name.as_str() {
            "ASSEMBLY" | "ENDASSEMBLY" => {
                self.in_assembly = kw.name == "ASSEMBLY";
                Block::Skip
            }
            "ENDINSTANCE" => {
                self.in_instance = false;
                Block::Skip
            }
            "NODE" | "ELEMENT" if of_assembly => Block::Skip,
            "NSET" | "ELSET" if of_assembly && !kw.has("INSTANCE") => Block::Skip,
            "NODE" => Block::Nodes {
                nset: kw.get("NSET").map(|n| self.nsets.get_or_add(n)),
            },
            "ELEMENT" => {
                let ty = param("TYPE")?;
                let shape = shape_of(ty).map_err(|m| at.err(m))?;
                let code = match self.types.iter().position(|t| t.eq_ignore_ascii_case(ty)) {
                    Some(i) => i,
                    None => {
                        self.types.push(ty.to_ascii_uppercase());
                        self.types.len() - 1
                    }
                };
                Block::Elements {
                    shape,
                    nv: shape.num_vertices(),
                    ty: code as i64,
                    name: ty.to_string(),
                    elset: kw.get("ELSET").map(|n| self.elsets.get_or_add(n)),
                }
            }
            "NSET" => {
                let set = self.nsets.get_or_add(param("NSET")?);
                match kw.get("ELSET") {
                    Some(_) => {
                        // *NSET, NSET=A, ELSET=B: the nodes of B's elements
                        let of = param("ELSET")?;
                        let e = self.elsets.find(of).ok_or_else(|| {
                            at.err(format!(
                                "*NSET refers to element set '{}', which is not defined before it",
                                clip(of)
                            ))
                        })?;
                        self.add_element_nodes(at, set, e)?;
                        Block::NodeSetOfElements
                    }
                    None => Block::NodeSet {
                        set,
                        generate: kw.has("GENERATE"),
                    },
                }
            }
            "ELSET" => Block::ElementSet {
                set: self.elsets.get_or_add(param("ELSET")?),
                generate: kw.has("GENERATE"),
            },
            "INCLUDE" => {
                // the included lines stand where the keyword does: data
                // lines in them go on the block before it
                return self.include(at, param("INPUT")?);
            }
            "PART" => {
                if let Some(first) = self.parts.first() {
                    return Err(at.err(format!(
                        "a second part ('{}' after '{}'): only a single part, instanced once, is read",
                        clip(kw.get("NAME").unwrap_or("")),
                        clip(first)
                    )));
                }
                self.parts.push(kw.get("NAME").unwrap_or("").to_string());
                Block::Skip
            }
            "INSTANCE" => {
                if let Some(first) = self.instances.first() {
                    return Err(at.err(format!(
                        "a second instance ('{}' after '{}'): only a single part, instanced once, is read",
                        clip(kw.get("NAME").unwrap_or("")),
                        clip(first)
                    )));
                }
                self.instances.push(kw.get("NAME").unwrap_or("").to_string());
                self.in_instance = true;
                Block::Instance
            }
            _ => Block::Skip,
        };
        Ok(())
    }

    fn include(&mut self, at: At, name: &str) -> Result<()> {
        let base = at.path.parent().unwrap_or(Path::new(""));
        let target = base.join(name);
        if self.open.len() >= MAX_INCLUDE_DEPTH {
            return Err(at.err(format!(
                "*INCLUDE of {} nests more than {MAX_INCLUDE_DEPTH} files deep",
                target.display()
            )));
        }
        let canon = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        let me = canon(&target);
        if self.open.iter().any(|p| canon(p) == me) {
            let chain: Vec<String> = self
                .open
                .iter()
                .chain([&target])
                .map(|p| p.display().to_string())
                .collect();
            return Err(at.err(format!("*INCLUDE cycle: {}", chain.join(" includes "))));
        }
        if !target.is_file() {
            return Err(at.err(format!("*INCLUDE of {}: no such file", target.display())));
        }
        // each included file is charged to the read's budget and stays
        // charged: a tree of includes cannot read more than it allows
        let data = super::input::read_file(&target, self.budget).map_err(|e| match e {
            Error::Parse { msg, .. } => at.err(format!("*INCLUDE of {}: {msg}", target.display())),
            other => other,
        })?;
        self.file(&target, &data)
    }

    /// Charges `n` more set members or cells to the budget.
    fn charge(&self, at: At, what: &str, n: usize, each: u64) -> Result<()> {
        self.budget
            .charge(format_args!("{what}"), (n as u64).saturating_mul(each))
            .map_err(|e| match e {
                Error::Parse { msg, .. } => at.err(msg),
                other => other,
            })
    }

    fn data(&mut self, at: At, fields: &[&str], comma: bool) -> Result<()> {
        match self.block {
            Block::Skip => Ok(()),
            Block::Nodes { nset } => self.node(at, fields, nset),
            Block::Elements { .. } => self.element(at, fields, comma),
            Block::NodeSet { set, generate } => self.set_line(at, fields, set, generate, true),
            Block::ElementSet { set, generate } => self.set_line(at, fields, set, generate, false),
            Block::NodeSetOfElements => Err(at.err("*NSET with ELSET= takes no data lines")),
            Block::Instance => {
                // a translation (3 numbers) or a rotation (7) of the instance
                let moved = fields.iter().any(|f| number(f).is_none_or(|x| x != 0.0));
                if moved {
                    Err(at.err("the instance is translated or rotated; only an instance placed as its part is read"))
                } else {
                    Ok(())
                }
            }
        }
    }

    fn node(&mut self, at: At, fields: &[&str], nset: Option<usize>) -> Result<()> {
        if fields.len() < 2 {
            return Err(at.err(format!(
                "a node line needs a number and 2 or 3 coordinates, found '{}'",
                clip(&fields.join(","))
            )));
        }
        let id = label(at, fields[0], "node")?;
        let mut p = [0.0; 3];
        for (k, f) in fields[1..].iter().take(3).enumerate() {
            p[k] = number(f).ok_or_else(|| at.err(format!("node {id}: '{}' is not a coordinate", clip(f))))?;
        }
        if p.iter().any(|x| !x.is_finite()) {
            return Err(at.err(format!("node {id} has a non-finite coordinate {p:?}")));
        }
        let v = self.raw.points.len() as u32;
        if !self.nodes.insert(id as u64, v) {
            return Err(at.err(format!("node {id} is defined twice")));
        }
        self.raw.points.push(p);
        self.node_ids.push(id);
        if let Some(s) = nset {
            self.nsets.members[s].push(v);
        }
        Ok(())
    }

    fn element(&mut self, at: At, fields: &[&str], comma: bool) -> Result<()> {
        let Block::Elements { nv, .. } = self.block else {
            unreachable!()
        };
        if self.pending.is_empty() {
            self.pending_line = at.line;
        }
        for f in fields {
            let what = if self.pending.is_empty() { "element" } else { "node" };
            self.pending.push(label(at, f, what)?);
        }
        let entries = fields.len();
        let short = self.pending.len() < nv + 1;
        // a record goes on where its line ends with a comma or is full
        if short && (comma || entries >= WRAP) {
            return Ok(());
        }
        self.end_record(at)
    }

    /// Ends the element record begun on an earlier line, if any.
    fn end_record(&mut self, at: At) -> Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let Block::Elements {
            shape,
            nv,
            ty,
            ref name,
            elset,
        } = self.block
        else {
            unreachable!("records are begun by element lines")
        };
        let at = At {
            line: self.pending_line,
            ..at
        };
        let id = self.pending[0];
        if self.pending.len() != nv + 1 {
            return Err(at.err(format!(
                "element {id} of type {name} lists {} nodes; the type has {nv}",
                self.pending.len() - 1
            )));
        }
        let mut vs = [0u32; 8];
        for (k, &n) in self.pending[1..].iter().enumerate() {
            vs[k] = self.nodes.get(n as u64).ok_or_else(|| {
                at.err(format!(
                    "element {id} refers to node {n}, which no *NODE before it defines"
                ))
            })?;
        }
        let c = self.raw.shapes.len() as u32;
        if !self.elements.insert(id as u64, c) {
            return Err(at.err(format!("element {id} is defined twice")));
        }
        self.raw.push(shape, &vs[..nv]);
        self.element_ids.push(id);
        self.cell_types.push(ty);
        if let Some(s) = elset {
            self.elsets.members[s].push(c);
        }
        self.pending.clear();
        Ok(())
    }

    fn set_line(&mut self, at: At, fields: &[&str], set: usize, generate: bool, nodes: bool) -> Result<()> {
        let (what, article, map) = if nodes {
            ("node", "a", &self.nodes)
        } else {
            ("element", "an", &self.elements)
        };
        let name = if nodes {
            &self.nsets.names[set]
        } else {
            &self.elsets.names[set]
        };
        let find = |id: i64| {
            map.get(id as u64).ok_or_else(|| {
                at.err(format!(
                    "set '{}' refers to {what} {id}, which is not defined before it",
                    clip(name)
                ))
            })
        };
        let mut add: Vec<u32> = Vec::new();
        if generate {
            if !(2..=3).contains(&fields.len()) {
                return Err(at.err(format!(
                    "a GENERATE line of set '{}' takes first, last[, step]; found '{}'",
                    clip(name),
                    clip(&fields.join(","))
                )));
            }
            let first = label(at, fields[0], what)?;
            let last = label(at, fields[1], what)?;
            let step = match fields.get(2) {
                Some(s) => label(at, s, "step")?,
                None => 1,
            };
            if last < first {
                return Err(at.err(format!(
                    "GENERATE from {first} down to {last}: the last is below the first"
                )));
            }
            let count = ((last - first) / step + 1) as usize;
            // every id of the range must exist: a range longer than the ids
            // defined cannot, and is refused before it is walked
            if count > map.len() {
                return Err(at.err(format!(
                    "GENERATE {first}, {last}, {step} of set '{}' covers {count} {what}s; the file defines {}",
                    clip(name),
                    map.len()
                )));
            }
            self.charge(at, &format!("set '{}'", clip(name)), count, 4)?;
            add.reserve(count);
            for k in 0..count as i64 {
                add.push(find(first + k * step)?);
            }
        } else {
            for f in fields {
                if let Ok(id) = f.parse::<i64>() {
                    add.push(find(id)?);
                    continue;
                }
                let sets = if nodes { &self.nsets } else { &self.elsets };
                let other = sets.find(f).ok_or_else(|| {
                    at.err(format!(
                        "'{}' is neither {article} {what} number nor {article} {what} set defined before this line",
                        clip(f)
                    ))
                })?;
                let members = &sets.members[other];
                self.charge(at, &format!("set '{}'", clip(name)), members.len(), 4)?;
                add.extend_from_slice(members);
            }
        }
        let sets = if nodes { &mut self.nsets } else { &mut self.elsets };
        sets.members[set].extend(add);
        Ok(())
    }

    fn add_element_nodes(&mut self, at: At, set: usize, elset: usize) -> Result<()> {
        let cells = &self.elsets.members[elset];
        let raw = &self.raw;
        let n: usize = cells
            .iter()
            .map(|&c| raw.offsets[c as usize + 1] - raw.offsets[c as usize])
            .sum();
        self.charge(at, &format!("set '{}'", clip(&self.nsets.names[set])), n, 4)?;
        let vs: Vec<u32> = cells
            .iter()
            .flat_map(|&c| &raw.conn[raw.offsets[c as usize]..raw.offsets[c as usize + 1]])
            .copied()
            .collect();
        self.nsets.members[set].extend(vs);
        Ok(())
    }
}

/// A node or element number: a positive integer.
fn label(at: At, f: &str, what: &str) -> Result<i64> {
    match f.parse::<i64>() {
        Ok(id) if id > 0 => Ok(id),
        _ => Err(at.err(format!("'{}' is not a {what} number (a positive integer)", clip(f)))),
    }
}

/// A real number, with a Fortran `D` exponent allowed.
fn number(f: &str) -> Option<f64> {
    f.parse().ok().or_else(|| f.replace(['d', 'D'], "e").parse().ok())
}

/// Ids to write: the array's, where every one is positive and none
/// repeats; else 1, 2, ... from `from`.
fn ids_to_write(array: Option<&DataArray>, n: usize, from: i64) -> Vec<i64> {
    if let Some(a) = array.filter(|a| a.tuples() == n && a.components == 1 && !a.ty.is_float())
        && let Values::Int(v) = &a.values
    {
        let mut sorted = v.clone();
        sorted.sort_unstable();
        if sorted.first().is_none_or(|&f| f > 0) && sorted.windows(2).all(|w| w[0] < w[1]) {
            return v.clone();
        }
    }
    (from..from + n as i64).collect()
}

/// Numbers, 16 a line, as Abaqus's set data lines hold them.
fn id_lines(w: &mut dyn Write, ids: impl Iterator<Item = i64>) -> WriteResult {
    let ids: Vec<i64> = ids.collect();
    for chunk in ids.chunks(WRAP) {
        let line: Vec<String> = chunk.iter().map(i64::to_string).collect();
        writeln!(w, "{}", line.join(", "))?;
    }
    Ok(())
}

/// A set name Abaqus takes: no commas, blanks, quotes or line breaks, a
/// letter or an underscore (its internal sets) first.
fn set_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        s
    } else {
        format!("S{s}")
    }
}

/// The node set that carries meshsmooth's fixed flags through `.inp` files.
pub const FIXED_SET: &str = "MESHSMOOTH_FIXED";

pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    let planar = is_planar_z0(mesh);
    let d = if planar { 2 } else { 3 };
    let ne = mesh.num_elements();
    let nodes = ids_to_write(mesh.data.point.iter().find(|a| a.name == NODE_ID), mesh.num_points(), 1);
    let elems = ids_to_write(mesh.data.cell_array(ELEMENT_ID), ne, 1);
    let mut lower = ids_to_write(mesh.data.lower_array(ELEMENT_ID), mesh.lower.len(), ne as i64 + 1);
    // lower cells numbered apart from the elements must not reuse their numbers
    let mut all: Vec<i64> = elems.iter().chain(&lower).copied().collect();
    all.sort_unstable();
    if all.windows(2).any(|w| w[0] == w[1]) {
        let top = elems.iter().max().copied().unwrap_or(0);
        lower = (top + 1..top + 1 + mesh.lower.len() as i64).collect();
    }
    writeln!(w, "*HEADING\nmeshsmooth\n*NODE")?;
    for (p, id) in mesh.points.iter().zip(&nodes) {
        let xs: Vec<String> = p[..d].iter().map(|&x| fmt_f64(x)).collect();
        writeln!(w, "{id}, {}", xs.join(", "))?;
    }
    let names: Vec<String> = match mesh.data.field.iter().find(|a| a.name == TYPES) {
        Some(DataArray {
            values: Values::Str(v), ..
        }) => v.clone(),
        _ => Vec::new(),
    };
    // each cell's type: the file's where it names the cell's shape
    let type_of = |array: Option<&DataArray>, i: usize, shape: Shape| -> &str {
        array
            .and_then(|a| usize::try_from(a.get_i64(i)).ok())
            .and_then(|t| names.get(t))
            .map(String::as_str)
            .filter(|t| shape_of(t).is_ok_and(|s| s == shape))
            .unwrap_or(default_type(shape, planar))
    };
    let mut cells: Vec<(&str, i64, &[u32])> = Vec::with_capacity(ne + mesh.lower.len());
    let types = mesh.data.cell_array(TYPE);
    for e in 0..ne {
        let shape = Shape::Elem(mesh.kinds[e]);
        cells.push((type_of(types, e, shape), elems[e], mesh.element(e)));
    }
    let types = mesh.data.lower_array(TYPE);
    for (i, (kind, vs)) in mesh.lower.iter().enumerate() {
        let shape = match kind {
            // points have no element type meshsmooth reads back
            LowerKind::Vertex => continue,
            LowerKind::Line => Shape::Line,
            LowerKind::Triangle => Shape::Elem(ElementKind::Triangle),
            LowerKind::Quadrilateral => Shape::Elem(ElementKind::Quadrilateral),
        };
        cells.push((type_of(types, i, shape), lower[i], vs));
    }
    let mut order: Vec<&str> = Vec::new();
    for &(t, _, _) in &cells {
        if !order.contains(&t) {
            order.push(t);
        }
    }
    for ty in order {
        writeln!(w, "*ELEMENT, TYPE={ty}")?;
        for (_, id, vs) in cells.iter().filter(|(t, _, _)| *t == ty) {
            let line: Vec<String> = vs.iter().map(|&v| nodes[v as usize].to_string()).collect();
            writeln!(w, "{id}, {}", line.join(", "))?;
        }
    }
    for s in &mesh.data.node_sets {
        writeln!(w, "*NSET, NSET={}", set_name(&s.name))?;
        id_lines(w, s.vertices.iter().map(|&v| nodes[v as usize]))?;
    }
    if mesh.fixed.iter().any(|&f| f) {
        writeln!(w, "*NSET, NSET={FIXED_SET}")?;
        id_lines(w, (0..mesh.num_points()).filter(|&v| mesh.fixed[v]).map(|v| nodes[v]))?;
    }
    for s in &mesh.data.element_sets {
        writeln!(w, "*ELSET, ELSET={}", set_name(&s.name))?;
        let ids = s.elements.iter().map(|&e| elems[e as usize]);
        id_lines(w, ids.chain(s.lower.iter().map(|&c| lower[c as usize])))?;
    }
    physical_sets(w, mesh, &elems, &lower)?;
    check_cell_data(mesh, cell_data)?;
    Ok(())
}

/// Gmsh physical groups as element sets, named by `$PhysicalNames` (a
/// group without a name as `PHYSICAL<tag>`), unless an element set has
/// that name already.
fn physical_sets(w: &mut dyn Write, mesh: &Mesh, elems: &[i64], lower: &[i64]) -> WriteResult {
    let cell = mesh.data.cell_array(GMSH_PHYSICAL);
    let low = mesh.data.lower_array(GMSH_PHYSICAL);
    let mut tags: Vec<i64> = Vec::new();
    let mut members: HashMap<i64, Vec<i64>> = HashMap::new();
    let mut add = |tag: i64, id: i64| {
        if !members.contains_key(&tag) {
            tags.push(tag);
        }
        members.entry(tag).or_default().push(id);
    };
    if let Some(a) = cell {
        (0..mesh.num_elements()).for_each(|e| add(a.get_i64(e), elems[e]));
    }
    if let Some(a) = low {
        for (i, (kind, _)) in mesh.lower.iter().enumerate() {
            if *kind != LowerKind::Vertex {
                add(a.get_i64(i), lower[i]);
            }
        }
    }
    for tag in tags {
        if tag <= 0 {
            continue;
        }
        let name = match mesh.data.physical_names.iter().find(|p| p.tag as i64 == tag) {
            Some(p) => set_name(&p.name),
            None => format!("PHYSICAL{tag}"),
        };
        if mesh.data.element_sets.iter().any(|s| set_name(&s.name) == name) {
            continue;
        }
        writeln!(w, "*ELSET, ELSET={name}")?;
        id_lines(w, members[&tag].iter().copied())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_map_to_shapes_or_say_why_not() {
        for (ty, shape) in [
            ("C3D8R", Shape::Elem(ElementKind::Hexahedron)),
            ("c3d8i", Shape::Elem(ElementKind::Hexahedron)),
            ("SC8R", Shape::Elem(ElementKind::Hexahedron)),
            ("C3D4H", Shape::Elem(ElementKind::Tetrahedron)),
            ("C3D6", Shape::Elem(ElementKind::Prism)),
            ("CPE4R", Shape::Elem(ElementKind::Quadrilateral)),
            ("S4R", Shape::Elem(ElementKind::Quadrilateral)),
            ("SFM3D3", Shape::Elem(ElementKind::Triangle)),
            ("CAX3", Shape::Elem(ElementKind::Triangle)),
            ("R3D4", Shape::Elem(ElementKind::Quadrilateral)),
            ("T3D2", Shape::Line),
            ("B31", Shape::Line),
        ] {
            assert_eq!(shape_of(ty), Ok(shape), "{ty}");
        }
        for (ty, why) in [
            ("C3D10", "quadratic"),
            ("C3D20R", "quadratic"),
            ("S8R", "quadratic"),
            ("B32", "quadratic"),
            ("C3D5", "pyramid"),
            ("SPRINGA", "not supported"),
            ("C3D", "not supported"),
            ("CPS7", "not supported"),
        ] {
            let e = shape_of(ty).unwrap_err();
            assert!(e.contains(why) && e.contains(ty), "{ty}: {e}");
        }
    }

    #[test]
    fn keywords_ignore_case_and_blanks() {
        let k = Keyword::parse("*Element , type = C3D8R, ELSET=\"Part 1\"");
        assert_eq!(k.name, "ELEMENT");
        assert_eq!(k.get("TYPE"), Some("C3D8R"));
        assert_eq!(k.get("ELSET"), Some("Part 1"));
        assert!(Keyword::parse("*nset,nset=a, Generate").has("GENERATE"));
    }
}
