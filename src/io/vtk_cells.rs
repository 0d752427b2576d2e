//! The cells of a VTK or VTU file as meshsmooth writes them: the elements,
//! then the lower cells (boundary faces and lines, points) in `Mesh::lower`
//! order, with cell arrays that cover both. The readers split them again
//! (`RawMesh::into_mesh`), so a round trip keeps the boundary and its data.

use std::borrow::Cow;

use super::CellData;
use crate::mesh::{DataArray, Mesh, ValueType, Values};

/// The lower cells' vertices, concatenated, and the end of each cell's run
/// counted from `base` (the elements' connectivity length): VTK's
/// connectivity and offsets after the elements'.
pub(crate) fn lower_connectivity(mesh: &Mesh, base: usize) -> (Vec<u32>, Vec<usize>) {
    let mut conn = Vec::with_capacity(mesh.lower.iter().map(|(_, vs)| vs.len()).sum());
    let mut ends = Vec::with_capacity(mesh.lower.len());
    for (_, vs) in &mesh.lower {
        conn.extend_from_slice(vs);
        ends.push(base + conn.len());
    }
    (conn, ends)
}

/// VTK type ids of every cell: the elements', then the lower cells'.
pub(crate) fn cell_types(mesh: &Mesh) -> impl Iterator<Item = u8> + '_ {
    mesh.kinds
        .iter()
        .map(|k| k.vtk_id())
        .chain(mesh.lower.iter().map(|(k, _)| k.vtk_id()))
}

/// The cell arrays a VTK/VTU writer writes, one tuple per cell (elements,
/// then lower cells): the input's, except those a quality array of the
/// same name replaces, then the quality arrays. Lower cells take their
/// values from `MeshData::lower`; where it has none (quality arrays, which
/// measure elements only, or a mesh whose lower cells came without data)
/// they get [`blank`] values.
pub(crate) fn out_cell_arrays<'a>(mesh: &'a Mesh, cell_data: &[CellData]) -> Vec<Cow<'a, DataArray>> {
    let nl = mesh.lower.len();
    let mut out: Vec<Cow<DataArray>> = mesh
        .data
        .cell
        .iter()
        .filter(|a| !cell_data.iter().any(|c| c.name == a.name))
        .map(|a| {
            if nl == 0 {
                return Cow::Borrowed(a);
            }
            let lower = mesh.data.lower_array(&a.name);
            Cow::Owned(append(a, lower, nl))
        })
        .collect();
    out.extend(cell_data.iter().map(|c| {
        let a = DataArray::new(c.name, ValueType::F64, 1, Values::Float(c.values.to_vec()));
        if nl == 0 {
            Cow::Owned(a)
        } else {
            Cow::Owned(append(&a, None, nl))
        }
    }));
    out
}

/// `a` followed by the `nl` tuples of `lower` (blank when `None`), in
/// `a`'s value type.
fn append(a: &DataArray, lower: Option<&DataArray>, nl: usize) -> DataArray {
    let n = nl * a.components.max(1);
    let lower = lower.filter(|l| l.components == a.components && l.tuples() == nl);
    let mut values = a.values.clone();
    match (&mut values, lower) {
        (Values::Int(v), Some(l)) => v.extend((0..n).map(|i| l.get_i64(i))),
        (Values::Float(v), Some(l)) => v.extend((0..n).map(|i| l.get_f64(i))),
        (
            Values::Str(v),
            Some(DataArray {
                values: Values::Str(l), ..
            }),
        ) => v.extend_from_slice(l),
        (values, _) => blank(values, n),
    }
    DataArray::new(a.name.clone(), a.ty, a.components, values)
}

/// `n` values that say "no value" for cells an array does not describe:
/// NaN for floats (VTK, ParaView and meshio read it, and no quality measure
/// is NaN), 0 for integers (Gmsh's "no physical group"), "" for strings.
fn blank(values: &mut Values, n: usize) {
    match values {
        Values::Int(v) => v.resize(v.len() + n, 0),
        Values::Float(v) => v.resize(v.len() + n, f64::NAN),
        Values::Str(v) => v.resize(v.len() + n, String::new()),
    }
}
