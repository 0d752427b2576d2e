//! Data arrays carried through a run untouched: the point, cell and field
//! arrays of the input file (VTK attributes, Gmsh tags), with their names,
//! value types and components, so the output can hold them again.

use crate::error::{Error, Result};

/// The value type an array had in its file; written back the same way where
/// the output format has that type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ValueType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    Str,
}

impl ValueType {
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
    Int(Vec<i64>),
    Float(Vec<f64>),
    Str(Vec<String>),
}

impl Values {
    pub fn len(&self) -> usize {
        match self {
            Values::Int(v) => v.len(),
            Values::Float(v) => v.len(),
            Values::Str(v) => v.len(),
        }
    }

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
    pub name: String,
    pub ty: ValueType,
    pub components: usize,
    pub values: Values,
}

impl DataArray {
    pub fn new(name: impl Into<String>, ty: ValueType, components: usize, values: Values) -> Self {
        DataArray {
            name: name.into(),
            ty,
            components: components.max(1),
            values,
        }
    }

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
    pub dim: i32,
    pub tag: i32,
    pub name: String,
}

/// Names of the cell arrays that hold Gmsh's tags (meshio's names, so a
/// meshio-written VTU keeps its groups through a `.msh` output).
pub const GMSH_PHYSICAL: &str = "gmsh:physical";
pub const GMSH_ELEMENTARY: &str = "gmsh:geometrical";

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
}

impl MeshData {
    pub fn is_empty(&self) -> bool {
        self.point.is_empty()
            && self.cell.is_empty()
            && self.lower.is_empty()
            && self.field.is_empty()
            && self.physical_names.is_empty()
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
