//! Exodus II (`.exo`, `.e`), through the system's libnetCDF (the `netcdf`
//! crate, cargo feature `exodus`): netCDF-4/HDF5 and classic files as
//! Cubit, SEACAS and meshio write them.
//!
//! What is read:
//! - element blocks of tetrahedra, hexahedra, wedges, triangles and
//!   quadrilaterals (any spelling Exodus uses: `TETRA`, `TET4`, `HEX8`,
//!   `SHELL4`, ...), each a named cell set (`--fix-group BLOCK`) and its id
//!   in the cell array [`BLOCK_ID`]; bar and sphere blocks as lower cells;
//!   higher-order and polyhedral blocks are refused, naming the block;
//! - node sets as [`NodeSet`]s, side sets as boundary cells (the element
//!   sides they name) in a named cell set; their ids in the field arrays
//!   [`NODE_SET_IDS`] and [`SIDE_SET_IDS`];
//! - the last time step's nodal and element variables as point and cell
//!   arrays (an element variable a block does not have reads NaN there), and
//!   that step's time as the field array [`TIME`];
//! - the node and element number maps as [`NODE_ID`] and [`ELEMENT_ID`].
//!
//! The writer puts all of it back: elements grouped by [`BLOCK_ID`] (by Gmsh
//! physical group, else by kind, where the mesh has none), block names from
//! the cell set holding exactly a block's elements (else the physical
//! group's name); boundary cells (Gmsh's faces, lines and points) in blocks
//! of their own grouped the same way, except faces that only a side set
//! holds; other cell sets of boundary cells as side sets (each face found as
//! the side of its element); fixed vertices as the node set
//! `MESHSMOOTH_FIXED`, which reads back as fixed; every numeric point and
//! cell array (and the quality arrays) as nodal and element variables of one
//! time step, one component per variable (`NAMEX`, `NAMEY`, `NAMEZ` for
//! vectors, which read back joined, `NAME_0`, `NAME_1`, ... for more; element variables are not kept on boundary cells). netCDF writes to a
//! file, so the output is built in a private temporary file and copied to
//! the staged output (atomic, or streamed). Files are written as classic
//! 64-bit-offset netCDF, which every Exodus reader takes.
//!
//! A damaged classic file is refused; a damaged netCDF-4 file is read by
//! libHDF5, which may abort the process on some corruptions rather than
//! report them (a limit of that library, not of this reader).

use std::collections::HashMap;
use std::path::Path;

use netcdf::types::{NcTypeDescriptor, NcVariableType};

use super::limits::Budget;
use super::{CellData, RawMesh, Shape, WriteError, WriteResult};
use crate::error::{Error, Result};
use crate::mesh::data::GMSH_PHYSICAL;
use crate::mesh::{DataArray, ElementKind, ElementSet, LowerKind, Mesh, NodeSet, ValueType, Values};

/// The cell array of each element's block id (0 for boundary cells).
pub const BLOCK_ID: &str = "exodus:block_id";
/// The point array of the node number map.
pub const NODE_ID: &str = "exodus:node_id";
/// The cell array of the element number map.
pub const ELEMENT_ID: &str = "exodus:element_id";
/// The field array of the node sets' ids (`MeshData::node_sets` order).
pub const NODE_SET_IDS: &str = "exodus:node_set_ids";
/// The field array of the side sets' ids (in the order the sets were read).
pub const SIDE_SET_IDS: &str = "exodus:side_set_ids";
/// The field array of the time of the step read.
pub const TIME: &str = "exodus:time";

const LEN_NAME: usize = 33;

/// netCDF's text type (`NC_CHAR`), which Exodus's names are stored in.
#[repr(transparent)]
#[derive(Copy, Clone, Default)]
struct NcChar(u8);

// SAFETY: NcChar is one byte, as NC_CHAR is.
unsafe impl NcTypeDescriptor for NcChar {
    fn type_descriptor() -> NcVariableType {
        NcVariableType::Char
    }
}

/// Vertices (0-based, outward) of each side of an Exodus element, by side number - 1.
fn sides(kind: ElementKind) -> &'static [&'static [usize]] {
    match kind {
        ElementKind::Tetrahedron => &[&[0, 1, 3], &[1, 2, 3], &[0, 3, 2], &[0, 2, 1]],
        ElementKind::Hexahedron => &[
            &[0, 1, 5, 4],
            &[1, 2, 6, 5],
            &[2, 3, 7, 6],
            &[0, 4, 7, 3],
            &[0, 3, 2, 1],
            &[4, 5, 6, 7],
        ],
        ElementKind::Prism => &[&[0, 1, 4, 3], &[1, 2, 5, 4], &[0, 3, 5, 2], &[0, 2, 1], &[3, 4, 5]],
        ElementKind::Triangle => &[&[0, 1], &[1, 2], &[2, 0]],
        ElementKind::Quadrilateral => &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]],
        ElementKind::Polyhedron => &[],
    }
}

/// The shape of an Exodus element type with `nodes` nodes, if meshsmooth has it.
fn shape_of(elem_type: &str, nodes: usize) -> Option<Shape> {
    let t = elem_type.trim().to_ascii_uppercase();
    let base: String = t.chars().take_while(|c| c.is_ascii_alphabetic()).collect();
    let (shape, n) = match base.as_str() {
        "TETRA" | "TET" | "TETRAHEDRON" => (Shape::Elem(ElementKind::Tetrahedron), 4),
        "HEX" | "HEXAHEDRON" => (Shape::Elem(ElementKind::Hexahedron), 8),
        "WEDGE" => (Shape::Elem(ElementKind::Prism), 6),
        "TRI" | "TRIANGLE" | "TRISHELL" => (Shape::Elem(ElementKind::Triangle), 3),
        "QUAD" | "SHELL" => (Shape::Elem(ElementKind::Quadrilateral), 4),
        "BAR" | "BEAM" | "TRUSS" | "EDGE" => (Shape::Line, 2),
        "SPHERE" | "CIRCLE" => (Shape::Vertex, 1),
        "SHELL3" => (Shape::Elem(ElementKind::Triangle), 3),
        _ => return None,
    };
    // SHELL3 is a triangle, SHELL/SHELL4 a quadrilateral
    let (shape, n) = if base == "SHELL" && nodes == 3 {
        (Shape::Elem(ElementKind::Triangle), 3)
    } else {
        (shape, n)
    };
    (nodes == n).then_some(shape)
}

/// The Exodus type name written for a kind.
fn type_name(kind: ElementKind) -> &'static str {
    match kind {
        ElementKind::Tetrahedron => "TETRA",
        ElementKind::Hexahedron => "HEX8",
        ElementKind::Prism => "WEDGE",
        ElementKind::Triangle => "TRI3",
        ElementKind::Quadrilateral => "QUAD4",
        ElementKind::Polyhedron => "NFACED",
    }
}

struct In<'a> {
    path: &'a Path,
    file: &'a netcdf::File,
    budget: &'a Budget,
}

impl In<'_> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, None, format!("Exodus II: {}", msg.into()))
    }

    fn dim(&self, name: &str) -> usize {
        self.file.dimension(name).map_or(0, |d| d.len())
    }

    fn charge(&self, what: &str, bytes: usize) -> Result<()> {
        self.budget.charge(what, bytes as u64)
    }

    fn ints(&self, name: &str) -> Result<Option<Vec<i64>>> {
        let Some(v) = self.file.variable(name) else {
            return Ok(None);
        };
        self.charge(name, v.len() * 8)?;
        v.get_values::<i64, _>(..)
            .map(Some)
            .map_err(|e| self.err(format!("variable {name}: {e}")))
    }

    fn floats(
        &self,
        name: &str,
        extents: impl TryInto<netcdf::Extents, Error = impl std::fmt::Display>,
    ) -> Result<Option<Vec<f64>>> {
        let Some(v) = self.file.variable(name) else {
            return Ok(None);
        };
        let extents = extents
            .try_into()
            .map_err(|e| self.err(format!("variable {name}: {e}")))?;
        v.get_values::<f64, _>(extents)
            .map(Some)
            .map_err(|e| self.err(format!("variable {name}: {e}")))
    }

    /// The rows of a `(n, len_name)` text variable, `n` of them ("" where absent).
    fn names(&self, name: &str, n: usize) -> Result<Vec<String>> {
        let Some(v) = self.file.variable(name) else {
            return Ok(vec![String::new(); n]);
        };
        let chars: Vec<NcChar> = v
            .get_values::<NcChar, _>(..)
            .map_err(|e| self.err(format!("variable {name}: {e}")))?;
        let width = v.dimensions().get(1).map_or(1, |d| d.len()).max(1);
        let mut out: Vec<String> = chars
            .chunks(width)
            .map(|row| {
                let bytes: Vec<u8> = row.iter().map(|c| c.0).take_while(|&b| b != 0).collect();
                String::from_utf8_lossy(&bytes).trim().to_string()
            })
            .collect();
        out.resize(n, String::new());
        Ok(out)
    }

    /// The ids of `n` blocks or sets from `prop1`, 1.. where there is none.
    fn ids(&self, prop: &str, n: usize) -> Result<Vec<i64>> {
        let mut ids = self.ints(prop)?.unwrap_or_default();
        ids.truncate(n);
        let next = ids.len() as i64;
        ids.extend((next..n as i64).map(|i| i + 1));
        Ok(ids)
    }

    /// The last time step's values of a variable `(time_step, count[, k])`:
    /// `count * k` values, node- or element-major.
    fn last_step(&self, name: &str, steps: usize) -> Result<Option<(Vec<f64>, usize)>> {
        let Some(v) = self.file.variable(name) else {
            return Ok(None);
        };
        let dims: Vec<usize> = v.dimensions().iter().map(|d| d.len()).collect();
        if dims.len() < 2 || steps == 0 {
            return Ok(None);
        }
        let per_step: usize = dims[1..].iter().product();
        self.charge(name, per_step * 8)?;
        let mut ext: Vec<netcdf::Extent> = vec![(steps - 1..steps).into()];
        ext.extend(dims[1..].iter().map(|&d| netcdf::Extent::from(0..d)));
        let values = self.floats(name, ext)?.unwrap_or_default();
        Ok(Some((values, dims.get(2).copied().unwrap_or(1))))
    }
}

/// Reads an Exodus II file (its bytes `data` already read from `path`).
pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    // the netcdf crate unwraps some of libnetCDF's errors (a corrupt file's
    // variable that cannot be inquired): those are this file's errors too
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read_file(path, data, budget))).unwrap_or_else(|p| {
        let why = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        Err(Error::parse(
            path,
            None,
            format!("Exodus II: libnetCDF cannot read the file, which is damaged ({why})"),
        ))
    })
}

fn read_file(path: &Path, data: &[u8], budget: &Budget) -> Result<RawMesh> {
    let (_copy, open_path) = super::on_disk(path, data)?;
    let open_path = open_path.as_path();
    if let Some(end) = super::netcdf_classic::data_end(data) {
        let (end, what) =
            end.map_err(|why| Error::parse(path, None, format!("Exodus II: a damaged netCDF header: {why}")))?;
        if (data.len() as u64) < end {
            return Err(Error::parse(
                path,
                None,
                format!(
                    "Exodus II: the file is cut: {what} needs {end} bytes, the file has {}",
                    data.len()
                ),
            ));
        }
    }
    let file = netcdf::open(open_path)
        .map_err(|e| Error::parse(path, None, format!("not a netCDF file that libnetCDF can open: {e}")))?;
    let r = In {
        path,
        file: &file,
        budget,
    };
    let mut raw = RawMesh::default();

    let n = r.dim("num_nodes");
    let num_dim = r.dim("num_dim");
    if n == 0 || !(2..=3).contains(&num_dim) {
        return Err(r.err(format!(
            "a mesh needs num_nodes > 0 and num_dim 2 or 3 (the file has num_nodes {n}, num_dim {num_dim}): is it an Exodus II file?"
        )));
    }
    r.charge("coordinates", n * 24)?;
    let mut xyz = vec![vec![0.0; n]; 3];
    if let Some(all) = r.floats("coord", ..)? {
        if all.len() != num_dim * n {
            return Err(r.err(format!(
                "coord has {} values, not num_dim x num_nodes = {}",
                all.len(),
                num_dim * n
            )));
        }
        for (k, c) in all.chunks(n).enumerate() {
            xyz[k] = c.to_vec();
        }
    } else {
        for (k, name) in ["coordx", "coordy", "coordz"].iter().take(num_dim).enumerate() {
            let c = r
                .floats(name, ..)?
                .ok_or_else(|| r.err(format!("no {name} (nor coord) variable")))?;
            if c.len() != n {
                return Err(r.err(format!("{name} has {} values for {n} nodes", c.len())));
            }
            xyz[k] = c;
        }
    }
    raw.points = (0..n).map(|i| [xyz[0][i], xyz[1][i], xyz[2][i]]).collect();
    drop(xyz);

    // element blocks
    let nblk = r.dim("num_el_blk");
    let block_ids = r.ids("eb_prop1", nblk)?;
    let block_names = r.names("eb_names", nblk)?;
    let mut elem_block = Vec::new();
    let mut block_sizes = Vec::with_capacity(nblk);
    // each file element's shape and first vertex in raw.conn
    let mut elems: Vec<(Shape, usize)> = Vec::new();
    for b in 0..nblk {
        let count = r.dim(&format!("num_el_in_blk{}", b + 1));
        block_sizes.push(count);
        let name = if block_names[b].is_empty() {
            format!("block_{}", block_ids[b])
        } else {
            block_names[b].clone()
        };
        if count == 0 {
            continue;
        }
        let var_name = format!("connect{}", b + 1);
        let var = file.variable(&var_name).ok_or_else(|| {
            r.err(format!(
                "block {} ({name}) has {count} elements but no {var_name}",
                block_ids[b]
            ))
        })?;
        let elem_type = match var.attribute_value("elem_type") {
            Some(Ok(netcdf::AttributeValue::Str(s))) => s,
            _ => String::new(),
        };
        let nodes = r.dim(&format!("num_nod_per_el{}", b + 1));
        let shape = shape_of(&elem_type, nodes).ok_or_else(|| {
            r.err(format!(
                "block {} ({name}) has elements of type {elem_type:?} with {nodes} nodes: meshsmooth reads linear \
                 tetrahedra, hexahedra, wedges, triangles and quadrilaterals (and bars and spheres as boundary cells)",
                block_ids[b]
            ))
        })?;
        let conn = r.ints(&var_name)?.unwrap_or_default();
        if conn.len() != count * nodes {
            return Err(r.err(format!(
                "{var_name} has {} entries for {count} elements of {nodes} nodes",
                conn.len()
            )));
        }
        let first = raw.shapes.len() as u32;
        for (e, vs) in conn.chunks(nodes).enumerate() {
            let mut ids = Vec::with_capacity(nodes);
            for &v in vs {
                if v < 1 || v as usize > n {
                    return Err(r.err(format!(
                        "element {} of block {} ({name}) refers to node {v}; the nodes are numbered 1 to {n}",
                        e + 1,
                        block_ids[b]
                    )));
                }
                ids.push(v as u32 - 1);
            }
            elems.push((shape, raw.conn.len()));
            raw.push(shape, &ids);
            elem_block.push(block_ids[b]);
        }
        raw.cell_sets.push((name, (first..raw.shapes.len() as u32).collect()));
    }
    if raw.shapes.is_empty() {
        return Err(r.err("the file has no elements (no element block with elements)"));
    }
    let num_elem = raw.shapes.len();

    // side sets: the element sides, as boundary cells
    let nss = r.dim("num_side_sets");
    let ss_ids = r.ids("ss_prop1", nss)?;
    let ss_names = r.names("ss_names", nss)?;
    // a side that a block of faces holds already is that face, not a new one
    let mut face_of: HashMap<Vec<u32>, u32> = HashMap::new();
    for (c, &(shape, at)) in elems.iter().enumerate() {
        let nodes = match shape {
            Shape::Line => 2,
            Shape::Elem(ElementKind::Triangle) => 3,
            Shape::Elem(ElementKind::Quadrilateral) => 4,
            _ => continue,
        };
        let mut key = raw.conn[at..at + nodes].to_vec();
        key.sort_unstable();
        face_of.entry(key).or_insert(c as u32);
    }
    for s in 0..nss {
        let name = if ss_names[s].is_empty() {
            format!("sideset_{}", ss_ids[s])
        } else {
            ss_names[s].clone()
        };
        let elem = r.ints(&format!("elem_ss{}", s + 1))?.unwrap_or_default();
        let side = r.ints(&format!("side_ss{}", s + 1))?.unwrap_or_default();
        if elem.len() != side.len() {
            return Err(r.err(format!(
                "side set {} ({name}): {} elements but {} sides",
                ss_ids[s],
                elem.len(),
                side.len()
            )));
        }
        let mut cells = Vec::with_capacity(elem.len());
        for (i, (&e, &k)) in elem.iter().zip(&side).enumerate() {
            let bad = |what: String| r.err(format!("side set {} ({name}), entry {}: {what}", ss_ids[s], i + 1));
            if e < 1 || e as usize > num_elem {
                return Err(bad(format!("element {e}; the elements are numbered 1 to {num_elem}")));
            }
            let (shape, at) = elems[e as usize - 1];
            let Shape::Elem(kind) = shape else {
                return Err(bad(format!("element {e} is a bar or sphere, which has no sides")));
            };
            let table = sides(kind);
            if k < 1 || k as usize > table.len() {
                return Err(bad(format!(
                    "side {k} of element {e}, which has sides 1 to {}",
                    table.len()
                )));
            }
            let vs: Vec<u32> = table[k as usize - 1].iter().map(|&j| raw.conn[at + j]).collect();
            let mut key = vs.clone();
            key.sort_unstable();
            let id = *face_of.entry(key).or_insert_with(|| {
                let shape = match vs.len() {
                    2 => Shape::Line,
                    3 => Shape::Elem(ElementKind::Triangle),
                    _ => Shape::Elem(ElementKind::Quadrilateral),
                };
                raw.push(shape, &vs);
                raw.shapes.len() as u32 - 1
            });
            cells.push(id);
        }
        cells.sort_unstable();
        cells.dedup();
        raw.cell_sets.push((name, cells));
    }
    let ncells = raw.shapes.len();

    // node sets
    let nns = r.dim("num_node_sets");
    let ns_ids = r.ids("ns_prop1", nns)?;
    let ns_names = r.names("ns_names", nns)?;
    let mut set_ids = Vec::with_capacity(nns);
    for s in 0..nns {
        let name = if ns_names[s].is_empty() {
            format!("nodeset_{}", ns_ids[s])
        } else {
            ns_names[s].clone()
        };
        let nodes = r.ints(&format!("node_ns{}", s + 1))?.unwrap_or_default();
        let mut vertices = Vec::with_capacity(nodes.len());
        for &v in &nodes {
            if v < 1 || v as usize > n {
                return Err(r.err(format!(
                    "node set {} ({name}) holds node {v}; the nodes are numbered 1 to {n}",
                    ns_ids[s]
                )));
            }
            vertices.push(v as u32 - 1);
        }
        vertices.sort_unstable();
        vertices.dedup();
        if name.eq_ignore_ascii_case(super::abaqus::FIXED_SET) {
            vertices.iter().for_each(|&v| raw.fix(v as usize));
        } else {
            raw.node_sets.push(NodeSet { name, vertices });
            set_ids.push(ns_ids[s]);
        }
    }
    if !set_ids.is_empty() {
        raw.field_data
            .push(DataArray::new(NODE_SET_IDS, ValueType::I64, 1, Values::Int(set_ids)));
    }
    if nss > 0 {
        raw.field_data
            .push(DataArray::new(SIDE_SET_IDS, ValueType::I64, 1, Values::Int(ss_ids)));
    }

    // number maps
    if let Some(map) = r.ints("node_num_map")?.filter(|m| m.len() == n) {
        raw.point_data
            .push(DataArray::new(NODE_ID, ValueType::I64, 1, Values::Int(map)));
    }
    let pad = |mut v: Vec<i64>| {
        v.resize(ncells, 0);
        v
    };
    if let Some(map) = r.ints("elem_num_map")?.filter(|m| m.len() == num_elem) {
        raw.cell_data
            .push(DataArray::new(ELEMENT_ID, ValueType::I64, 1, Values::Int(pad(map))));
    }
    raw.cell_data.push(DataArray::new(
        BLOCK_ID,
        ValueType::I32,
        1,
        Values::Int(pad(elem_block)),
    ));

    // the last time step's variables
    let steps = r.dim("time_step");
    if steps > 0 {
        if let Some(t) = r.floats("time_whole", [netcdf::Extent::from(steps - 1..steps)])? {
            raw.field_data
                .push(DataArray::new(TIME, ValueType::F64, 1, Values::Float(t)));
        }
        let nv = r.dim("num_nod_var");
        let names = r.names("name_nod_var", nv)?;
        for (j, name) in names.iter().enumerate() {
            let name = if name.is_empty() {
                format!("nodal_{}", j + 1)
            } else {
                name.clone()
            };
            if let Some((values, k)) = r.last_step(&format!("vals_nod_var{}", j + 1), steps)? {
                if values.len() == n * k {
                    raw.point_data
                        .push(DataArray::new(name, ValueType::F64, k, Values::Float(values)));
                }
            } else if let Some((values, _)) = r.last_step("vals_nod_var", steps)? {
                // the old layout: one variable (time_step, num_nod_var, num_nodes)
                if let Some(row) = values.chunks(n).nth(j) {
                    raw.point_data
                        .push(DataArray::new(name, ValueType::F64, 1, Values::Float(row.to_vec())));
                }
            }
        }
        let nv = r.dim("num_elem_var");
        let names = r.names("name_elem_var", nv)?;
        for (j, name) in names.iter().enumerate() {
            let name = if name.is_empty() {
                format!("element_{}", j + 1)
            } else {
                name.clone()
            };
            let mut values = Vec::with_capacity(ncells);
            let mut found = false;
            for (b, &count) in block_sizes.iter().enumerate() {
                match r.last_step(&format!("vals_elem_var{}eb{}", j + 1, b + 1), steps)? {
                    Some((v, 1)) if v.len() == count => {
                        found = true;
                        values.extend(v);
                    }
                    _ => values.extend(std::iter::repeat_n(f64::NAN, count)),
                }
            }
            if found {
                values.resize(ncells, f64::NAN);
                raw.cell_data
                    .push(DataArray::new(name, ValueType::F64, 1, Values::Float(values)));
            }
        }
    }
    raw.point_data = join_components(std::mem::take(&mut raw.point_data));
    raw.cell_data = join_components(std::mem::take(&mut raw.cell_data));
    Ok(raw)
}

/// The names of component `c` of `k` as variables: `X`, `Y`, `Z` for
/// vectors (`velocityX`, which VTK and meshio read as one vector
/// `velocity`), else `_0`, `_1`, ...
fn component_suffix(c: usize, k: usize) -> String {
    if k <= 3 {
        ["X", "Y", "Z"][c].to_string()
    } else {
        format!("_{c}")
    }
}

/// Consecutive one-component variables `NAMEX`, `NAMEY`(, `NAMEZ`) (also
/// lower case, also `NAME_X`) or `NAME_0`, `NAME_1`, ... joined into one
/// array of several components.
fn join_components(arrays: Vec<DataArray>) -> Vec<DataArray> {
    let floats = |a: &DataArray| match &a.values {
        Values::Float(v) if a.components == 1 => Some(v.len()),
        _ => None,
    };
    // the length of the run of components starting at `i`, and its base name
    let run = |i: usize| -> Option<(usize, String)> {
        let a = &arrays[i];
        let len = floats(a)?;
        let (base, style) = [("X", 0), ("x", 1), ("_0", 2)]
            .iter()
            .find_map(|&(s, style)| a.name.strip_suffix(s).map(|b| (b, style)))
            .filter(|(b, _)| !b.is_empty())?;
        let name = |c: usize| match style {
            0 => format!("{base}{}", ["X", "Y", "Z"][c]),
            1 => format!("{base}{}", ["x", "y", "z"][c]),
            _ => format!("{base}_{c}"),
        };
        let k = (0..arrays.len() - i)
            .take_while(|&c| {
                (style == 2 || c < 3) && arrays[i + c].name == name(c) && floats(&arrays[i + c]) == Some(len)
            })
            .count();
        let base = base.strip_suffix('_').filter(|b| !b.is_empty()).unwrap_or(base);
        (k >= 2).then(|| (k, base.to_string()))
    };
    let runs: Vec<Option<(usize, String)>> = (0..arrays.len()).map(run).collect();
    let mut out = Vec::with_capacity(arrays.len());
    let mut arrays = arrays.into_iter().enumerate();
    while let Some((i, a)) = arrays.next() {
        let Some((k, base)) = runs[i].clone() else {
            out.push(a);
            continue;
        };
        let parts: Vec<DataArray> = std::iter::once(a)
            .chain(arrays.by_ref().take(k - 1).map(|p| p.1))
            .collect();
        let len = parts[0].values.len();
        let mut joined = vec![0.0; len * k];
        for (c, p) in parts.iter().enumerate() {
            for j in 0..len {
                joined[j * k + c] = p.get_f64(j);
            }
        }
        out.push(DataArray::new(base, ValueType::F64, k, Values::Float(joined)));
    }
    out
}

/// An element variable: its name and values on the elements and on the
/// boundary cells, where the mesh has them.
type Var = (String, Option<Vec<f64>>, Option<Vec<f64>>);

/// Internal arrays of this and other formats: not written as variables.
fn internal(name: &str) -> bool {
    name.contains(':') || name == "fixed"
}

/// One block of the output: its id, name, Exodus type and cells (mesh
/// order): elements, or lower cells in a block of their own (`lower`).
struct Block {
    id: i64,
    name: String,
    elem_type: &'static str,
    nodes: usize,
    lower: bool,
    cells: Vec<usize>,
}

/// The integer array called `name` with one value per cell, if any.
fn int_values(arrays: &[DataArray], name: &str, len: usize) -> Option<Vec<i64>> {
    arrays
        .iter()
        .find(|a| a.name == name && a.components == 1)
        .and_then(|a| match &a.values {
            Values::Int(v) if v.len() == len => Some(v.clone()),
            _ => None,
        })
}

fn lower_type(kind: LowerKind) -> (&'static str, usize) {
    match kind {
        LowerKind::Vertex => ("SPHERE", 1),
        LowerKind::Line => ("BAR2", 2),
        LowerKind::Triangle => ("TRI3", 3),
        LowerKind::Quadrilateral => ("QUAD4", 4),
    }
}

/// The blocks of the output: elements by [`BLOCK_ID`] (by Gmsh physical
/// group, else by kind, where the mesh has none), then the lower cells the
/// same way, except the faces that are only the sides of a side set (a
/// block id of 0), which the side sets hold.
fn blocks(mesh: &Mesh) -> Vec<Block> {
    let ne = mesh.num_elements();
    let nl = mesh.lower.len();
    let keys = |arrays: &[DataArray], len: usize| {
        let ids = int_values(arrays, BLOCK_ID, len);
        let by_id = ids.is_some();
        (ids.or_else(|| int_values(arrays, GMSH_PHYSICAL, len)), by_id)
    };
    let (elem_keys, elem_by_id) = keys(&mesh.data.cell, ne);
    let (lower_keys, lower_by_id) = keys(&mesh.data.lower, nl);
    let in_side_set: Vec<bool> = {
        let mut v = vec![false; nl];
        for s in mesh.data.element_sets.iter().filter(|s| s.elements.is_empty()) {
            s.lower.iter().for_each(|&c| v[c as usize] = true);
        }
        v
    };
    let mut out: Vec<Block> = Vec::new();
    // (lower, key, type) -> block; a block holds one type
    let mut at: HashMap<(bool, i64, &'static str), usize> = HashMap::new();
    let mut add = |lower: bool, key: i64, (elem_type, nodes): (&'static str, usize), c: usize| {
        let i = *at.entry((lower, key, elem_type)).or_insert_with(|| {
            out.push(Block {
                id: key,
                name: String::new(),
                elem_type,
                nodes,
                lower,
                cells: Vec::new(),
            });
            out.len() - 1
        });
        out[i].cells.push(c);
    };
    for e in 0..ne {
        let kind = mesh.kinds[e];
        let t = (type_name(kind), kind.num_vertices().unwrap_or(0));
        add(false, elem_keys.as_ref().map_or(0, |v| v[e]), t, e);
    }
    for (c, (kind, _)) in mesh.lower.iter().enumerate() {
        let key = lower_keys.as_ref().map_or(0, |v| v[c]);
        if lower_by_id && key == 0 && in_side_set[c] && *kind != LowerKind::Vertex {
            continue;
        }
        add(true, key, lower_type(*kind), c);
    }
    let mut used = std::collections::HashSet::new();
    for (i, b) in out.iter_mut().enumerate() {
        let by_id = if b.lower { lower_by_id } else { elem_by_id };
        let wanted = if by_id { b.id } else { i as i64 + 1 };
        let physical = (!by_id).then_some(b.id).filter(|&t| t > 0);
        b.id = if wanted > 0 && used.insert(wanted) {
            wanted
        } else {
            (1..).find(|&k| used.insert(k)).expect("a free id")
        };
        let same = |members: &[u32]| {
            members.len() == b.cells.len() && members.iter().zip(&b.cells).all(|(&a, &c)| a as usize == c)
        };
        let set = mesh.data.element_sets.iter().find(|s| {
            if b.lower {
                s.elements.is_empty() && same(&s.lower)
            } else {
                s.lower.is_empty() && same(&s.elements)
            }
        });
        let dim = if b.lower {
            [0, 0, 1, 2, 2][b.nodes]
        } else {
            mesh.dim() as i32
        };
        let group = physical.and_then(|t| {
            mesh.data
                .physical_names
                .iter()
                .find(|p| i64::from(p.tag) == t && p.dim == dim)
        });
        b.name = match (set, group) {
            (Some(s), _) => s.name.clone(),
            (None, Some(p)) => p.name.clone(),
            (None, None) => format!("block_{}", b.id),
        };
    }
    out
}

fn nc(e: netcdf::Error) -> WriteError {
    WriteError::Other(Error::InvalidArgument(format!("Exodus II: libnetCDF: {e}")))
}

fn text_rows(rows: &[String]) -> Vec<NcChar> {
    let mut out = vec![NcChar(0); rows.len() * LEN_NAME];
    for (i, r) in rows.iter().enumerate() {
        for (j, b) in r.bytes().take(LEN_NAME - 1).enumerate() {
            out[i * LEN_NAME + j] = NcChar(b);
        }
    }
    out
}

/// Values to write once every dimension and variable is defined: a classic
/// netCDF file takes data only after its header is complete.
type Pending = Vec<Box<dyn FnOnce(&mut netcdf::FileMut) -> WriteResult>>;

/// Defines `var` and queues its values, the whole variable or (`step`) the
/// first time step's row.
fn put<T: NcTypeDescriptor + Copy + 'static>(
    f: &mut netcdf::FileMut,
    pending: &mut Pending,
    var: &str,
    dims: &[&str],
    values: Vec<T>,
    step: bool,
) -> WriteResult {
    f.add_variable::<T>(var, dims).map_err(nc)?;
    let var = var.to_string();
    pending.push(Box::new(move |f| {
        let mut v = f.variable_mut(&var).expect("defined before");
        if step {
            v.put_values(&values, [0..1, 0..values.len()])
        } else {
            v.put_values(&values, ..)
        }
        .map_err(nc)
    }));
    Ok(())
}

fn put_names(f: &mut netcdf::FileMut, pending: &mut Pending, var: &str, dim: &str, rows: &[String]) -> WriteResult {
    put(f, pending, var, &[dim, "len_name"], text_rows(rows), false)
}

fn put_ints(f: &mut netcdf::FileMut, pending: &mut Pending, var: &str, dims: &[&str], values: &[i32]) -> WriteResult {
    put(f, pending, var, dims, values.to_vec(), false)
}

fn to_i32(v: i64, what: &str) -> std::result::Result<i32, WriteError> {
    i32::try_from(v).map_err(|_| {
        WriteError::Other(Error::InvalidArgument(format!(
            "Exodus II: {what} {v} does not fit a 32-bit integer"
        )))
    })
}

/// A side set: its id, name and (element, side) pairs, 1-based.
type SideSet = (i64, String, Vec<(i32, i32)>);

/// Cell sets of boundary cells as side sets: each face is the side of an
/// element with the same vertices.
fn side_sets(mesh: &Mesh, file_pos: &[usize], blocks: &[Block]) -> std::result::Result<Vec<SideSet>, WriteError> {
    // a set that is exactly a block of boundary cells is that block already
    let is_block = |s: &ElementSet| {
        blocks.iter().any(|b| {
            b.lower
                && b.name == s.name
                && b.cells.len() == s.lower.len()
                && b.cells.iter().zip(&s.lower).all(|(&c, &l)| c == l as usize)
        })
    };
    let sets: Vec<_> = mesh
        .data
        .element_sets
        .iter()
        .filter(|s| s.elements.is_empty() && !s.lower.is_empty() && !is_block(s))
        .collect();
    if sets.is_empty() {
        return Ok(Vec::new());
    }
    let mut side_of: HashMap<Vec<u32>, (i32, i32)> = HashMap::new();
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        for (k, side) in sides(mesh.kinds[e]).iter().enumerate() {
            let mut key: Vec<u32> = side.iter().map(|&j| vs[j]).collect();
            key.sort_unstable();
            side_of.entry(key).or_insert((file_pos[e] as i32 + 1, k as i32 + 1));
        }
    }
    let ids: Vec<i64> = mesh
        .data
        .field
        .iter()
        .find(|a| a.name == SIDE_SET_IDS)
        .and_then(|a| match &a.values {
            Values::Int(v) if v.len() == sets.len() => Some(v.clone()),
            _ => None,
        })
        .unwrap_or_else(|| (1..=sets.len() as i64).collect());
    let mut out = Vec::new();
    for (s, &id) in sets.iter().zip(&ids) {
        let mut pairs = Vec::with_capacity(s.lower.len());
        for &c in &s.lower {
            let (kind, vs) = &mesh.lower[c as usize];
            if matches!(kind, LowerKind::Vertex) {
                continue;
            }
            let mut key = vs.clone();
            key.sort_unstable();
            let pair = side_of.get(&key).ok_or_else(|| {
                WriteError::Other(Error::InvalidArgument(format!(
                    "Exodus II: set {}: boundary cell {c} is no element's side, and a side set holds element sides",
                    s.name
                )))
            })?;
            pairs.push(*pair);
        }
        out.push((id, s.name.clone(), pairs));
    }
    Ok(out)
}

/// Writes `mesh` as Exodus II (netCDF-4) to `w`.
pub(crate) fn write(w: &mut dyn std::io::Write, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    super::check_cell_data(mesh, cell_data)?;
    if let Some(e) = mesh.kinds.iter().position(|&k| k == ElementKind::Polyhedron) {
        return Err(WriteError::Other(Error::InvalidArgument(format!(
            "Exodus II: element {e} is a polyhedron, which this writer does not write (write VTK or OpenFOAM)"
        ))));
    }
    super::through_file(w, |path| build(path, mesh, cell_data))
}

fn build(path: &Path, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    let n = mesh.num_points();
    let num_dim = if mesh.dim() == 3 || mesh.points.iter().any(|p| p[2] != 0.0) {
        3
    } else {
        2
    };
    let blocks = blocks(mesh);
    let num_elem: usize = blocks.iter().map(|b| b.cells.len()).sum();
    // file order: element blocks come first, block by block
    let order: Vec<usize> = blocks
        .iter()
        .filter(|b| !b.lower)
        .flat_map(|b| b.cells.iter().copied())
        .collect();
    let mut file_pos = vec![0; mesh.num_elements()];
    for (i, &e) in order.iter().enumerate() {
        file_pos[e] = i;
    }
    let sides = side_sets(mesh, &file_pos, &blocks)?;
    let node_sets = &mesh.data.node_sets;

    // classic 64-bit-offset netCDF, not netCDF-4: every Exodus reader takes it,
    // and libnetcdf's classic reader refuses corrupt files where HDF5's may crash
    let mut f = netcdf::create_with(path, netcdf::Options::_64BIT_OFFSET).map_err(nc)?;
    let mut pending: Pending = Vec::new();
    f.add_attribute("title", "meshsmooth").map_err(nc)?;
    f.add_attribute("api_version", 8.03f32).map_err(nc)?;
    f.add_attribute("version", 8.03f32).map_err(nc)?;
    f.add_attribute("floating_point_word_size", 8i32).map_err(nc)?;
    f.add_attribute("file_size", 1i32).map_err(nc)?;
    f.add_attribute("maximum_name_length", (LEN_NAME - 1) as i32)
        .map_err(nc)?;
    f.add_attribute("int64_status", 0i32).map_err(nc)?;
    for (name, len) in [
        ("len_string", 33),
        ("len_line", 81),
        ("four", 4),
        ("len_name", LEN_NAME),
        ("num_dim", num_dim),
        ("num_nodes", n),
        ("num_elem", num_elem),
        ("num_el_blk", blocks.len()),
    ] {
        f.add_dimension(name, len).map_err(nc)?;
    }
    f.add_unlimited_dimension("time_step").map_err(nc)?;
    let time = mesh
        .data
        .field
        .iter()
        .find(|a| a.name == TIME)
        .and_then(|a| match &a.values {
            Values::Float(v) => v.first().copied(),
            _ => None,
        })
        .unwrap_or(0.0);
    f.add_variable::<f64>("time_whole", &["time_step"]).map_err(nc)?;
    pending.push(Box::new(move |f| {
        f.variable_mut("time_whole")
            .expect("defined before")
            .put_values(&[time], [netcdf::Extent::from(0..1)])
            .map_err(nc)
    }));

    for (k, name) in ["coordx", "coordy", "coordz"].iter().take(num_dim).enumerate() {
        let c: Vec<f64> = mesh.points.iter().map(|p| p[k]).collect();
        put(&mut f, &mut pending, name, &["num_nodes"], c, false)?;
    }
    put_names(
        &mut f,
        &mut pending,
        "coor_names",
        "num_dim",
        &["X", "Y", "Z"][..num_dim]
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>(),
    )?;

    let ids: Vec<i32> = blocks
        .iter()
        .map(|b| to_i32(b.id, "block id"))
        .collect::<std::result::Result<_, _>>()?;
    put_ints(
        &mut f,
        &mut pending,
        "eb_status",
        &["num_el_blk"],
        &vec![1; blocks.len()],
    )?;
    put_ints(&mut f, &mut pending, "eb_prop1", &["num_el_blk"], &ids)?;
    f.variable_mut("eb_prop1")
        .expect("just added")
        .put_attribute("name", "ID")
        .map_err(nc)?;
    put_names(
        &mut f,
        &mut pending,
        "eb_names",
        "num_el_blk",
        &blocks.iter().map(|b| b.name.clone()).collect::<Vec<_>>(),
    )?;
    for (i, b) in blocks.iter().enumerate() {
        let (de, dn) = (format!("num_el_in_blk{}", i + 1), format!("num_nod_per_el{}", i + 1));
        f.add_dimension(&de, b.cells.len()).map_err(nc)?;
        f.add_dimension(&dn, b.nodes).map_err(nc)?;
        let vertices = |c: usize| -> &[u32] { if b.lower { &mesh.lower[c].1 } else { mesh.element(c) } };
        let conn: Vec<i32> = b
            .cells
            .iter()
            .flat_map(|&c| vertices(c).iter().map(|&v| v as i32 + 1))
            .collect();
        let name = format!("connect{}", i + 1);
        put_ints(&mut f, &mut pending, &name, &[&de, &dn], &conn)?;
        f.variable_mut(&name)
            .expect("just added")
            .put_attribute("elem_type", b.elem_type)
            .map_err(nc)?;
    }

    if let Some(map) = int_values(&mesh.data.point, NODE_ID, n) {
        let map: Vec<i32> = map
            .iter()
            .map(|&v| to_i32(v, "node number"))
            .collect::<std::result::Result<_, _>>()?;
        put_ints(&mut f, &mut pending, "node_num_map", &["num_nodes"], &map)?;
    }
    if let Some(map) = int_values(&mesh.data.cell, ELEMENT_ID, mesh.num_elements()) {
        // boundary cells keep their numbers where they have them, else follow
        let lower = int_values(&mesh.data.lower, ELEMENT_ID, mesh.lower.len());
        let mut next = map.iter().copied().max().unwrap_or(0);
        let mut numbers = order.iter().map(|&e| map[e]).collect::<Vec<_>>();
        for b in blocks.iter().filter(|b| b.lower) {
            for &c in &b.cells {
                numbers.push(match lower.as_ref().map(|l| l[c]) {
                    Some(k) if k > 0 => k,
                    _ => {
                        next += 1;
                        next
                    }
                });
            }
        }
        let numbers: Vec<i32> = numbers
            .iter()
            .map(|&v| to_i32(v, "element number"))
            .collect::<std::result::Result<_, _>>()?;
        put_ints(&mut f, &mut pending, "elem_num_map", &["num_elem"], &numbers)?;
    }

    // a netCDF dimension of length 0 is unlimited: empty sets are not written
    let ns_ids = int_values(&mesh.data.field, NODE_SET_IDS, node_sets.len())
        .unwrap_or_else(|| (1..=node_sets.len() as i64).collect());
    let mut node_sets: Vec<(i64, &NodeSet)> = ns_ids
        .into_iter()
        .zip(node_sets)
        .filter(|(_, s)| !s.vertices.is_empty())
        .collect();
    // fixed vertices as a node set of their own, which reads back as fixed
    let fixed = NodeSet {
        name: super::abaqus::FIXED_SET.to_string(),
        vertices: (0..n as u32)
            .filter(|&v| mesh.fixed.get(v as usize) == Some(&true))
            .collect(),
    };
    if !fixed.vertices.is_empty() {
        let id = node_sets.iter().map(|s| s.0).max().unwrap_or(0) + 1;
        node_sets.push((id, &fixed));
    }
    if !node_sets.is_empty() {
        f.add_dimension("num_node_sets", node_sets.len()).map_err(nc)?;
        let ids: Vec<i32> = node_sets
            .iter()
            .map(|&(v, _)| to_i32(v, "node set id"))
            .collect::<std::result::Result<_, _>>()?;
        put_ints(
            &mut f,
            &mut pending,
            "ns_status",
            &["num_node_sets"],
            &vec![1; node_sets.len()],
        )?;
        put_ints(&mut f, &mut pending, "ns_prop1", &["num_node_sets"], &ids)?;
        f.variable_mut("ns_prop1")
            .expect("just added")
            .put_attribute("name", "ID")
            .map_err(nc)?;
        put_names(
            &mut f,
            &mut pending,
            "ns_names",
            "num_node_sets",
            &node_sets.iter().map(|s| s.1.name.clone()).collect::<Vec<_>>(),
        )?;
        for (i, (_, s)) in node_sets.iter().enumerate() {
            let d = format!("num_nod_ns{}", i + 1);
            f.add_dimension(&d, s.vertices.len()).map_err(nc)?;
            let vs: Vec<i32> = s.vertices.iter().map(|&v| v as i32 + 1).collect();
            put_ints(&mut f, &mut pending, &format!("node_ns{}", i + 1), &[&d], &vs)?;
        }
    }
    let sides: Vec<SideSet> = sides.into_iter().filter(|s| !s.2.is_empty()).collect();
    if !sides.is_empty() {
        f.add_dimension("num_side_sets", sides.len()).map_err(nc)?;
        let ids: Vec<i32> = sides
            .iter()
            .map(|s| to_i32(s.0, "side set id"))
            .collect::<std::result::Result<_, _>>()?;
        put_ints(
            &mut f,
            &mut pending,
            "ss_status",
            &["num_side_sets"],
            &vec![1; sides.len()],
        )?;
        put_ints(&mut f, &mut pending, "ss_prop1", &["num_side_sets"], &ids)?;
        f.variable_mut("ss_prop1")
            .expect("just added")
            .put_attribute("name", "ID")
            .map_err(nc)?;
        put_names(
            &mut f,
            &mut pending,
            "ss_names",
            "num_side_sets",
            &sides.iter().map(|s| s.1.clone()).collect::<Vec<_>>(),
        )?;
        for (i, (_, _, pairs)) in sides.iter().enumerate() {
            let d = format!("num_side_ss{}", i + 1);
            f.add_dimension(&d, pairs.len()).map_err(nc)?;
            put_ints(
                &mut f,
                &mut pending,
                &format!("elem_ss{}", i + 1),
                &[&d],
                &pairs.iter().map(|p| p.0).collect::<Vec<_>>(),
            )?;
            put_ints(
                &mut f,
                &mut pending,
                &format!("side_ss{}", i + 1),
                &[&d],
                &pairs.iter().map(|p| p.1).collect::<Vec<_>>(),
            )?;
        }
    }

    // variables: one component each
    let split = |a: &DataArray| -> Vec<(String, Vec<f64>)> {
        let values: Vec<f64> = match &a.values {
            Values::Float(v) => v.clone(),
            Values::Int(v) => v.iter().map(|&x| x as f64).collect(),
            Values::Str(_) => return Vec::new(),
        };
        let k = a.components;
        if k == 1 {
            return vec![(a.name.clone(), values)];
        }
        (0..k)
            .map(|c| {
                (
                    format!("{}{}", a.name, component_suffix(c, k)),
                    values.iter().skip(c).step_by(k).copied().collect(),
                )
            })
            .collect()
    };
    let nodal: Vec<(String, Vec<f64>)> = mesh
        .data
        .point
        .iter()
        .filter(|a| !internal(&a.name))
        .flat_map(split)
        .collect();
    if !nodal.is_empty() {
        f.add_dimension("num_nod_var", nodal.len()).map_err(nc)?;
        put_names(
            &mut f,
            &mut pending,
            "name_nod_var",
            "num_nod_var",
            &nodal.iter().map(|v| v.0.clone()).collect::<Vec<_>>(),
        )?;
        for (j, (_, values)) in nodal.iter().enumerate() {
            put(
                &mut f,
                &mut pending,
                &format!("vals_nod_var{}", j + 1),
                &["time_step", "num_nodes"],
                values.clone(),
                true,
            )?;
        }
    }
    // element variables: values on the elements and on the boundary cells,
    // each where the mesh has them (the truth table says which blocks)
    let mut element: Vec<Var> = cell_data
        .iter()
        .map(|c| (c.name.to_string(), Some(c.values.to_vec()), None))
        .collect();
    for (lower, arrays) in [(false, &mesh.data.cell), (true, &mesh.data.lower)] {
        for a in arrays.iter().filter(|a| !internal(&a.name)) {
            for (name, values) in split(a) {
                let at = match element.iter().position(|e| e.0 == name) {
                    Some(at) => at,
                    None => {
                        element.push((name, None, None));
                        element.len() - 1
                    }
                };
                let slot = if lower { &mut element[at].2 } else { &mut element[at].1 };
                slot.get_or_insert(values);
            }
        }
    }
    fn values_of<'a>(v: &'a Var, b: &Block) -> Option<&'a Vec<f64>> {
        if b.lower { v.2.as_ref() } else { v.1.as_ref() }
    }
    if !element.is_empty() {
        f.add_dimension("num_elem_var", element.len()).map_err(nc)?;
        put_names(
            &mut f,
            &mut pending,
            "name_elem_var",
            "num_elem_var",
            &element.iter().map(|v| v.0.clone()).collect::<Vec<_>>(),
        )?;
        put_ints(
            &mut f,
            &mut pending,
            "elem_var_tab",
            &["num_el_blk", "num_elem_var"],
            &blocks
                .iter()
                .flat_map(|b| element.iter().map(|v| i32::from(values_of(v, b).is_some())))
                .collect::<Vec<_>>(),
        )?;
        for (j, var) in element.iter().enumerate() {
            for (i, b) in blocks.iter().enumerate() {
                let Some(values) = values_of(var, b) else { continue };
                let v: Vec<f64> = b.cells.iter().map(|&c| values[c]).collect();
                put(
                    &mut f,
                    &mut pending,
                    &format!("vals_elem_var{}eb{}", j + 1, i + 1),
                    &["time_step", &format!("num_el_in_blk{}", i + 1)],
                    v,
                    true,
                )?;
            }
        }
    }
    f.enddef().map_err(nc)?;
    for write in pending {
        write(&mut f)?;
    }
    f.close().map_err(nc)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(name: &str, v: &[f64]) -> DataArray {
        DataArray::new(name, ValueType::F64, 1, Values::Float(v.to_vec()))
    }

    #[test]
    fn components_join_by_their_suffixes_and_nothing_else() {
        let arrays = vec![
            one("dX", &[1.0, 2.0]),
            one("dY", &[3.0, 4.0]),
            one("dZ", &[5.0, 6.0]),
            one("AX", &[0.0, 0.0]),
            one("t_0", &[1.0, 1.0]),
            one("t_1", &[2.0, 2.0]),
            one("t_2", &[3.0, 3.0]),
            one("t_3", &[4.0, 4.0]),
            one("q_x", &[7.0, 8.0]),
            one("q_y", &[9.0, 10.0]),
            one("rX", &[1.0]),
            one("rY", &[1.0, 2.0]),
        ];
        let got = join_components(arrays);
        let names: Vec<(&str, usize)> = got.iter().map(|a| (a.name.as_str(), a.components)).collect();
        assert_eq!(names, [("d", 3), ("AX", 1), ("t", 4), ("q", 2), ("rX", 1), ("rY", 1)]);
        assert_eq!(got[0].values, Values::Float(vec![1.0, 3.0, 5.0, 2.0, 4.0, 6.0]));
        assert_eq!(
            got[2].values,
            Values::Float(vec![1.0, 2.0, 3.0, 4.0, 1.0, 2.0, 3.0, 4.0])
        );
        // and what the writer names is what the reader joins
        let names: Vec<String> = (0..3).map(|c| format!("v{}", component_suffix(c, 3))).collect();
        let got = join_components(names.iter().map(|n| one(n, &[1.0])).collect());
        assert_eq!((got[0].name.as_str(), got[0].components), ("v", 3));
    }
}
