//! Data arrays carried through a run untouched: the point, cell and field
//! arrays of the input file (VTK attributes, Gmsh tags), with their names,
//! value types and components, so the output can hold them again.

use crate::error::{Error, Result};

/// The value type an array had in its file; written back the same way where
/// the output format has that type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ValueType {
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 32-bit integer.
    I32,
    /// Unsigned 32-bit integer.
    U32,
    /// Signed 64-bit integer.
    I64,
    /// Unsigned 64-bit integer.
    U64,
    /// 32-bit float.
    F32,
    /// 64-bit float.
    F64,
    /// String.
    Str,
}

impl ValueType {
    /// True for `F32` and `F64`.
    pub fn is_float(self) -> bool {
        matches!(self, ValueType::F32 | ValueType::F64)
    }

    /// Bytes of one value (strings: 0, they have no fixed size).
    pub fn size(self) -> usize {
        match self {
            ValueType::I8 | ValueType::U8 => 1,
            ValueType::I16 | ValueType::U16 => 2,
            ValueType::I32 | ValueType::U32 | ValueType::F32 => 4,
            ValueType::I64 | ValueType::U64 | ValueType::F64 => 8,
            ValueType::Str => 0,
        }
    }
}

/// Values of an array, tuple after tuple. Integers are held as `i64`
/// (`u64` values above `i64::MAX` wrap and wrap back on write), floats as
/// `f64` (exact for `f32`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Values {
    /// Integer values (any integer `ValueType`).
    Int(Vec<i64>),
    /// Floating-point values (`F32` or `F64`).
    Float(Vec<f64>),
    /// String values.
    Str(Vec<String>),
}

impl Values {
    /// Number of values (not tuples).
    pub fn len(&self) -> usize {
        match self {
            Values::Int(v) => v.len(),
            Values::Float(v) => v.len(),
            Values::Str(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Tuples `idx` (of `k` values each), in that order.
    fn gather(&self, k: usize, idx: &[usize]) -> Values {
        fn pick<T: Clone>(v: &[T], k: usize, idx: &[usize]) -> Vec<T> {
            idx.iter()
                .flat_map(|&i| v[i * k..(i + 1) * k].iter().cloned())
                .collect()
        }
        match self {
            Values::Int(v) => Values::Int(pick(v, k, idx)),
            Values::Float(v) => Values::Float(pick(v, k, idx)),
            Values::Str(v) => Values::Str(pick(v, k, idx)),
        }
    }
}

/// One named array: `values.len() == tuples * components`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DataArray {
    /// The array's name in the file.
    pub name: String,
    /// The value type it had in the file.
    pub ty: ValueType,
    /// Values per tuple (at least 1).
    pub components: usize,
    /// The values, tuple after tuple.
    pub values: Values,
}

impl DataArray {
    /// An array; `components` below 1 counts as 1.
    pub fn new(name: impl Into<String>, ty: ValueType, components: usize, values: Values) -> Self {
        DataArray {
            name: name.into(),
            ty,
            components: components.max(1),
            values,
        }
    }

    /// Number of tuples: values / components.
    pub fn tuples(&self) -> usize {
        self.values.len() / self.components.max(1)
    }

    /// The array restricted to tuples `idx`, in that order (a permutation
    /// or a selection).
    pub fn select(&self, idx: &[usize]) -> DataArray {
        DataArray {
            name: self.name.clone(),
            ty: self.ty,
            components: self.components,
            values: self.values.gather(self.components.max(1), idx),
        }
    }

    /// Value `i` as f64 (strings: NaN).
    pub fn get_f64(&self, i: usize) -> f64 {
        match &self.values {
            Values::Int(v) => v[i] as f64,
            Values::Float(v) => v[i],
            Values::Str(_) => f64::NAN,
        }
    }

    /// Value `i` as an integer (floats truncated; strings: 0).
    pub fn get_i64(&self, i: usize) -> i64 {
        match &self.values {
            Values::Int(v) => v[i],
            Values::Float(v) => v[i] as i64,
            Values::Str(_) => 0,
        }
    }
}

/// A Gmsh physical group name.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PhysicalName {
    /// Dimension of the group's entities.
    pub dim: i32,
    /// The group's physical tag.
    pub tag: i32,
    /// The group's name.
    pub name: String,
}

/// A Gmsh 4.1 `$Entities` entry (a geometric point, curve, surface or
/// volume), kept so that a 4.1 output lists the input's entities, empty
/// ones too, as they were.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GmshEntity {
    /// 0 (point) to 3 (volume).
    pub dim: i32,
    /// The entity's tag (unique within its dimension).
    pub tag: i32,
    /// Bounding box: min x, y, z, then max x, y, z (a point's are equal).
    pub bounds: [f64; 6],
    /// The physical groups it belongs to.
    pub physical: Vec<i32>,
    /// Its bounding entities of dimension `dim - 1`, signed by orientation
    /// (none for points).
    pub bounding: Vec<i32>,
}

/// The point array of each node's Gmsh entity, as (dim, tag) pairs (meshio's
/// name): from 4.1 `$Nodes` blocks, written back as node blocks.
pub const GMSH_DIM_TAGS: &str = "gmsh:dim_tags";

/// Names of the cell arrays that hold Gmsh's tags (meshio's names, so a
/// meshio-written VTU keeps its groups through a `.msh` output).
pub const GMSH_PHYSICAL: &str = "gmsh:physical";
/// The cell array of Gmsh's elementary (geometrical entity) tags.
pub const GMSH_ELEMENTARY: &str = "gmsh:geometrical";

/// A named set of vertices (an Abaqus `*NSET`; an Exodus node set). Being
/// in a set fixes nothing: `--fix-group NAME` fixes its vertices,
/// `--free-group NAME` releases them from the lower cells that fixed them.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct NodeSet {
    /// The set's name.
    pub name: String,
    /// Its vertices (0-based point ids, ascending, no repeats).
    pub vertices: Vec<u32>,
}

/// A named set of cells (an Abaqus `*ELSET`): unlike a Gmsh physical tag,
/// of which a cell has one, a cell can be in any number of sets. A group
/// name given to `--fix-group`/`--free-group` stands for its cells as it
/// stands for the cells of a physical group of that name.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ElementSet {
    /// The set's name.
    pub name: String,
    /// Its elements (`Mesh::kinds` order, ascending, no repeats).
    pub elements: Vec<u32>,
    /// Its lower cells (`Mesh::lower` order, ascending, no repeats).
    pub lower: Vec<u32>,
}

/// The point array of an Abaqus file's node numbers (written back to `.inp`).
pub const ABAQUS_NODE_ID: &str = "abaqus:node_id";
/// The cell array of an Abaqus file's element numbers.
pub const ABAQUS_ELEMENT_ID: &str = "abaqus:element_id";
/// The cell array of each cell's index into [`ABAQUS_TYPES`].
pub const ABAQUS_TYPE: &str = "abaqus:type";
/// The field array of the Abaqus element type names (`C3D8R`) that
/// [`ABAQUS_TYPE`] indexes.
pub const ABAQUS_TYPES: &str = "abaqus:types";

/// Everything of a file beyond the geometry and the topology.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshData {
    /// One tuple per point.
    pub point: Vec<DataArray>,
    /// One tuple per element (`Mesh::kinds` order).
    pub cell: Vec<DataArray>,
    /// The same arrays as `cell` (names, order), one tuple per lower cell
    /// (`Mesh::lower` order); empty when the mesh has no lower cells.
    pub lower: Vec<DataArray>,
    /// Arrays of the whole data set (VTK field data), any length.
    pub field: Vec<DataArray>,
    /// Gmsh `$PhysicalNames`.
    pub physical_names: Vec<PhysicalName>,
    /// Gmsh 4.1 `$Entities` (empty when the input had none).
    #[serde(default)]
    pub gmsh_entities: Vec<GmshEntity>,
    /// Named vertex sets (Abaqus `*NSET`).
    #[serde(default)]
    pub node_sets: Vec<NodeSet>,
    /// Named cell sets (Abaqus `*ELSET`).
    #[serde(default)]
    pub element_sets: Vec<ElementSet>,
    /// The faces, owners, neighbours, patches and zones of an OpenFOAM
    /// polyMesh the mesh was read from (shared: copies of the mesh for a
    /// run do not copy it).
    #[serde(default)]
    pub polymesh: Option<std::sync::Arc<super::polymesh::PolyMesh>>,
}

impl MeshData {
    /// True when there are no arrays and no physical names.
    pub fn is_empty(&self) -> bool {
        self.point.is_empty()
            && self.cell.is_empty()
            && self.lower.is_empty()
            && self.field.is_empty()
            && self.physical_names.is_empty()
            && self.gmsh_entities.is_empty()
            && self.node_sets.is_empty()
            && self.element_sets.is_empty()
            && self.polymesh.is_none()
    }

    /// The sets restricted to the vertices `keep` of `points` and the
    /// lower cells `lower` of `cells` (both ascending), renumbered in that
    /// order: what is not kept leaves its sets.
    pub fn keep_in_sets(&mut self, points: usize, keep: &[usize], cells: usize, lower: &[usize]) {
        fn renumber(ids: &mut Vec<u32>, local: &[u32]) {
            ids.retain_mut(|v| {
                *v = local.get(*v as usize).copied().unwrap_or(u32::MAX);
                *v != u32::MAX
            });
        }
        fn local(n: usize, kept: &[usize]) -> Vec<u32> {
            let mut local = vec![u32::MAX; n];
            for (l, &v) in kept.iter().enumerate() {
                local[v] = l as u32;
            }
            local
        }
        if !self.node_sets.is_empty() {
            let map = local(points, keep);
            self.node_sets.iter_mut().for_each(|s| renumber(&mut s.vertices, &map));
        }
        if !self.element_sets.is_empty() && lower.len() != cells {
            let map = local(cells, lower);
            self.element_sets.iter_mut().for_each(|s| renumber(&mut s.lower, &map));
        }
    }

    /// The element array called `name`, if any.
    pub fn cell_array(&self, name: &str) -> Option<&DataArray> {
        self.cell.iter().find(|a| a.name == name)
    }

    /// The lower-cell array called `name`, if any.
    pub fn lower_array(&self, name: &str) -> Option<&DataArray> {
        self.lower.iter().find(|a| a.name == name)
    }

    /// Reorder points: new point `i` is old point `order[i]`.
    pub fn permute_points(&mut self, order: &[usize]) {
        for a in &mut self.point {
            *a = a.select(order);
        }
    }

    /// Reorder elements: new element `i` is old element `order[i]`.
    pub fn permute_cells(&mut self, order: &[usize]) {
        for a in &mut self.cell {
            *a = a.select(order);
        }
    }

    /// Lengths agree with a mesh of `points` points, `elements` elements and
    /// `lower` lower cells.
    pub fn check(&self, points: usize, elements: usize, lower: usize) -> Result<()> {
        let bad = |what: &str, a: &DataArray, want: usize| {
            Error::InvalidMesh(format!(
                "{what} array '{}' has {} values, expected {want} ({} components)",
                a.name,
                a.values.len(),
                a.components
            ))
        };
        for a in self
            .point
            .iter()
            .chain(&self.cell)
            .chain(&self.lower)
            .chain(&self.field)
        {
            if a.components == 0 || a.values.len() % a.components != 0 {
                return Err(bad("data", a, a.components * a.tuples()));
            }
        }
        for a in &self.point {
            if a.tuples() != points {
                return Err(bad("point", a, points * a.components));
            }
        }
        for a in &self.cell {
            if a.tuples() != elements {
                return Err(bad("cell", a, elements * a.components));
            }
        }
        if lower > 0 && !self.lower.is_empty() {
            if self.lower.len() != self.cell.len() || self.lower.iter().zip(&self.cell).any(|(l, c)| l.name != c.name) {
                return Err(Error::InvalidMesh(
                    "lower-cell arrays must have the names of the cell arrays, in the same order".into(),
                ));
            }
            for a in &self.lower {
                if a.tuples() != lower {
                    return Err(bad("lower-cell", a, lower * a.components));
                }
            }
        } else if lower == 0 && !self.lower.is_empty() {
            return Err(Error::InvalidMesh("lower-cell arrays but no lower cells".into()));
        }
        let past = |what: &str, name: &str, id: u32, n: usize| {
            Error::InvalidMesh(format!("{what} set '{name}' holds {id}, but there are {n}"))
        };
        for s in &self.node_sets {
            if let Some(&v) = s.vertices.iter().find(|&&v| v as usize >= points) {
                return Err(past("node", &s.name, v, points));
            }
        }
        for s in &self.element_sets {
            if let Some(&e) = s.elements.iter().find(|&&e| e as usize >= elements) {
                return Err(past("element", &s.name, e, elements));
            }
            if let Some(&c) = s.lower.iter().find(|&&c| c as usize >= lower) {
                return Err(past("element", &s.name, c, lower));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn select_gathers_whole_tuples() {
        let a = DataArray::new("v", ValueType::F64, 2, Values::Float(vec![0., 1., 10., 11., 20., 21.]));
        assert_eq!(a.select(&[2, 0]).values, Values::Float(vec![20., 21., 0., 1.]));
        let s = DataArray::new("s", ValueType::Str, 1, Values::Str(vec!["a".into(), "b".into()]));
        assert_eq!(s.select(&[1, 1]).values, Values::Str(vec!["b".into(), "b".into()]));
    }

    #[test]
    fn check_counts_tuples() {
        let mut d = MeshData::default();
        d.point
            .push(DataArray::new("t", ValueType::I32, 1, Values::Int(vec![1, 2, 3])));
        assert!(d.check(3, 0, 0).is_ok());
        assert!(d.check(4, 0, 0).is_err());
    }
}
