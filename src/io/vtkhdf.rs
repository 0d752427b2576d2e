//! VTKHDF (`.vtkhdf`, `.hdf`): VTK's HDF5 file format, as VTK 9.4+ and
//! ParaView 5.11+ read and write it, through the system's libHDF5 (the
//! `hdf5-metno` crate, cargo feature `vtkhdf`).
//!
//! What is read: an `UnstructuredGrid` of version 1 or 2, every piece (the
//! pieces' shared points merged as a `.pvtu`'s are, by `GlobalPointIds`
//! where the pieces have them, else by coordinates), its point, cell and
//! field arrays (numeric, and field strings), and the point array `fixed`.
//! Cells are those VTK/VTU files may hold; polyhedra (which VTKHDF stores
//! in face arrays of its own), `PolyData`, image data and temporal files
//! (`Steps`) are refused, saying so.
//!
//! What is written: one piece, the elements then the lower cells with cell
//! arrays over both (as in a VTU file), point, cell and field arrays, the
//! sets as field arrays (as in a VTU file). An MPI run writes its merged
//! mesh as one piece: several ranks writing one file needs a parallel
//! (MPI-IO) libHDF5, which the common serial builds are not; `--pieces`
//! writes `.pvtu` pieces. libHDF5 writes to a file, so the output is built
//! in a private temporary file and copied to the staged output.
//!
//! libHDF5 may abort the process on some corrupt files rather than report
//! them (a limit of that library, not of this reader).

use std::path::{Path, PathBuf};

use hdf5::types::{FixedAscii, FloatSize, IntSize, TypeDescriptor, VarLenAscii, VarLenUnicode};
use hdf5_metno as hdf5;

use super::limits::Budget;
use super::vtk_cells::{cell_types, lower_connectivity, out_cell_arrays};
use super::{CellData, RawMesh, WriteError, WriteResult};
use crate::error::{Error, Result};
use crate::mesh::{DataArray, ElementKind, Mesh, ValueType, Values};

/// The reader's context: the file (for errors) and the memory budget.
struct In<'a> {
    path: &'a Path,
    root: &'a hdf5::Group,
    budget: &'a Budget,
}

impl In<'_> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, None, format!("VTKHDF: {}", msg.into()))
    }

    fn dataset(&self, group: &hdf5::Group, name: &str) -> Result<hdf5::Dataset> {
        group
            .dataset(name)
            .map_err(|e| self.err(format!("no dataset {name} ({e})")))
    }

    /// A dataset's values as `T`, charged to the budget first.
    fn values<T: hdf5::H5Type>(&self, ds: &hdf5::Dataset, what: &str) -> Result<Vec<T>> {
        self.budget
            .charge(what, (ds.size() as u64).saturating_mul(std::mem::size_of::<T>() as u64))?;
        ds.read_raw::<T>().map_err(|e| self.err(format!("{what}: {e}")))
    }

    fn ints(&self, name: &str) -> Result<Vec<i64>> {
        let ds = self.dataset(self.root, name)?;
        self.values(&ds, name)
    }
}

fn string_attr(group: &hdf5::Group, name: &str) -> Option<String> {
    let a = group.attr(name).ok()?;
    a.read_scalar::<FixedAscii<255>>()
        .map(|s| s.as_str().to_string())
        .or_else(|_| a.read_scalar::<VarLenAscii>().map(|s| s.as_str().to_string()))
        .or_else(|_| a.read_scalar::<VarLenUnicode>().map(|s| s.as_str().to_string()))
        .ok()
}

/// The value type of a numeric dataset (`None`: not one meshsmooth keeps).
fn value_type(t: &TypeDescriptor) -> Option<ValueType> {
    Some(match t {
        TypeDescriptor::Integer(IntSize::U1) => ValueType::I8,
        TypeDescriptor::Integer(IntSize::U2) => ValueType::I16,
        TypeDescriptor::Integer(IntSize::U4) => ValueType::I32,
        TypeDescriptor::Integer(IntSize::U8) => ValueType::I64,
        TypeDescriptor::Unsigned(IntSize::U1) | TypeDescriptor::Boolean => ValueType::U8,
        TypeDescriptor::Unsigned(IntSize::U2) => ValueType::U16,
        TypeDescriptor::Unsigned(IntSize::U4) => ValueType::U32,
        TypeDescriptor::Unsigned(IntSize::U8) => ValueType::U64,
        TypeDescriptor::Float(FloatSize::U4) => ValueType::F32,
        TypeDescriptor::Float(FloatSize::U8) => ValueType::F64,
        _ => return None,
    })
}

/// The arrays of `group` (`PointData`, `CellData`, `FieldData`), each
/// `rows` tuples long where `rows` is given; `None` for a missing group.
fn arrays(r: &In, name: &str, rows: Option<usize>) -> Result<Vec<DataArray>> {
    let Ok(group) = r.root.group(name) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    let names = group.member_names().map_err(|e| r.err(format!("{name}: {e}")))?;
    for member in names {
        let Ok(ds) = group.dataset(&member) else { continue };
        let what = format!("{name}/{member}");
        let shape = ds.shape();
        let components = match shape.len() {
            1 => 1,
            2 => shape[1],
            _ => return Err(r.err(format!("{what} has {} dimensions; arrays have 1 or 2", shape.len()))),
        };
        let dtype = ds
            .dtype()
            .and_then(|t| t.to_descriptor())
            .map_err(|e| r.err(format!("{what}: {e}")))?;
        let values = match value_type(&dtype) {
            Some(ValueType::F32 | ValueType::F64) => Values::Float(r.values::<f64>(&ds, &what)?),
            Some(_) => Values::Int(r.values::<i64>(&ds, &what)?),
            None if rows.is_none() && matches!(dtype, TypeDescriptor::VarLenAscii | TypeDescriptor::VarLenUnicode) => {
                let s: Vec<String> = match dtype {
                    TypeDescriptor::VarLenAscii => r
                        .values::<VarLenAscii>(&ds, &what)?
                        .iter()
                        .map(|s| s.as_str().to_string())
                        .collect(),
                    _ => r
                        .values::<VarLenUnicode>(&ds, &what)?
                        .iter()
                        .map(|s| s.as_str().to_string())
                        .collect(),
                };
                out.push(DataArray::new(member, ValueType::Str, 1, Values::Str(s)));
                continue;
            }
            None => continue, // compound and other types: not data meshsmooth keeps
        };
        let ty = value_type(&dtype).expect("numeric");
        if let Some(rows) = rows
            && shape[0] != rows
        {
            return Err(r.err(format!("{what} has {} tuples for {rows}", shape[0])));
        }
        out.push(DataArray::new(member, ty, components.max(1), values));
    }
    Ok(out)
}

/// Reads every piece of the file; `names` are the pieces' names for
/// messages about merging them.
pub(crate) fn read(path: &Path, data: &[u8], budget: &Budget) -> Result<(Vec<RawMesh>, Vec<PathBuf>)> {
    let (_copy, open_path) = super::on_disk(path, data)?;
    let file = hdf5::File::open(&open_path)
        .map_err(|e| Error::parse(path, None, format!("not an HDF5 file that libHDF5 can open: {e}")))?;
    let root = file.group("VTKHDF").map_err(|_| {
        Error::parse(
            path,
            None,
            "an HDF5 file without a VTKHDF group: not a VTKHDF file (a netCDF-4 Exodus file is read by its extension .exo)",
        )
    })?;
    let r = In {
        path,
        root: &root,
        budget,
    };
    let ty = string_attr(&root, "Type").ok_or_else(|| r.err("the VTKHDF group has no Type attribute"))?;
    if ty != "UnstructuredGrid" {
        return Err(r.err(format!(
            "the file holds {ty}; meshsmooth reads VTKHDF UnstructuredGrid (write the mesh as one from ParaView or VTK)"
        )));
    }
    if let Ok(v) = root.attr("Version").and_then(|a| a.read_raw::<i64>())
        && v.first().is_some_and(|&major| major > 2)
    {
        return Err(r.err(format!(
            "version {v:?} is newer than the versions 1 and 2 this reader knows"
        )));
    }
    if root.link_exists("Steps") {
        return Err(
            r.err("a temporal file (a Steps group): meshsmooth reads one mesh; save one time step from ParaView")
        );
    }
    if root.link_exists("FaceConnectivity") || root.link_exists("PolyhedronToFaces") {
        return Err(r.err("polyhedra in VTKHDF are not read: write the mesh as VTU"));
    }
    let np = r.ints("NumberOfPoints")?;
    let nc = r.ints("NumberOfCells")?;
    let nk = r.ints("NumberOfConnectivityIds")?;
    if np.len() != nc.len() || np.len() != nk.len() || np.is_empty() {
        return Err(r.err(format!(
            "NumberOfPoints, NumberOfCells and NumberOfConnectivityIds must have one value per piece (they have {}, {}, {})",
            np.len(),
            nc.len(),
            nk.len()
        )));
    }
    let count = |v: &[i64], what: &str| -> Result<Vec<usize>> {
        v.iter()
            .enumerate()
            .map(|(p, &x)| usize::try_from(x).map_err(|_| r.err(format!("{what} of piece {p} is {x}"))))
            .collect()
    };
    let (np, nc, nk) = (
        count(&np, "NumberOfPoints")?,
        count(&nc, "NumberOfCells")?,
        count(&nk, "NumberOfConnectivityIds")?,
    );
    let total = |v: &[usize]| v.iter().try_fold(0usize, |a, &b| a.checked_add(b));
    let overflow = || r.err("the piece counts overflow");
    let (sum_p, sum_c, sum_k) = (
        total(&np).ok_or_else(overflow)?,
        total(&nc).ok_or_else(overflow)?,
        total(&nk).ok_or_else(overflow)?,
    );
    let points_ds = r.dataset(&root, "Points")?;
    if points_ds.shape() != [sum_p, 3] {
        return Err(r.err(format!(
            "Points has shape {:?}, not [{sum_p}, 3] (the pieces' points)",
            points_ds.shape()
        )));
    }
    let points = r.values::<f64>(&points_ds, "Points")?;
    let types = {
        let ds = r.dataset(&root, "Types")?;
        r.values::<u8>(&ds, "Types")?
    };
    let offsets = r.ints("Offsets")?;
    let conn = r.ints("Connectivity")?;
    let want = [
        ("Types", types.len(), sum_c),
        ("Offsets", offsets.len(), sum_c + np.len()),
        ("Connectivity", conn.len(), sum_k),
    ];
    for (what, got, want) in want {
        if got != want {
            return Err(r.err(format!("{what} has {got} values; the pieces' counts say {want}")));
        }
    }
    let point_data = arrays(&r, "PointData", Some(sum_p))?;
    let cell_data = arrays(&r, "CellData", Some(sum_c))?;
    let field_data = arrays(&r, "FieldData", None)?;

    let mut pieces = Vec::with_capacity(np.len());
    let (mut pb, mut cb, mut kb) = (0, 0, 0);
    for p in 0..np.len() {
        let mut raw = RawMesh::default();
        let pts = &points[3 * pb..3 * (pb + np[p])];
        for (i, c) in pts.chunks_exact(3).enumerate() {
            if c.iter().any(|x| !x.is_finite()) {
                return Err(r.err(format!("point {} has a non-finite coordinate {c:?}", pb + i)));
            }
            raw.points.push([c[0], c[1], c[2]]);
        }
        let offs = &offsets[cb + p..cb + p + nc[p] + 1];
        let ids = &conn[kb..kb + nk[p]];
        let mut vs = Vec::new();
        for c in 0..nc[p] {
            let cell = cb + c;
            let (start, end) = (offs[c], offs[c + 1]);
            if start < 0 || end < start || end as usize > ids.len() {
                return Err(r.err(format!(
                    "cell {cell}: offsets {start}..{end} outside its piece's {} connectivity ids",
                    ids.len()
                )));
            }
            let shape = super::vtk::vtk_shape(cell, i64::from(types[cell])).map_err(|m| r.err(m))?;
            if shape == super::Shape::Elem(ElementKind::Polyhedron) {
                return Err(r.err(format!(
                    "cell {cell} is a polyhedron, which this reader does not read: write VTU"
                )));
            }
            if (end - start) as usize != shape.num_vertices() {
                return Err(r.err(format!(
                    "cell {cell} (VTK type {}) has {} vertices, not {}",
                    types[cell],
                    end - start,
                    shape.num_vertices()
                )));
            }
            vs.clear();
            for &v in &ids[start as usize..end as usize] {
                if v < 0 || v as usize >= np[p] {
                    return Err(r.err(format!(
                        "cell {cell} refers to point {v} of its piece, which has {} points",
                        np[p]
                    )));
                }
                vs.push(v as u32);
            }
            raw.push(shape, &vs);
        }
        let rows = |a: &DataArray, from: usize, n: usize| {
            let k = a.components;
            let values = match &a.values {
                Values::Float(v) => Values::Float(v[from * k..(from + n) * k].to_vec()),
                Values::Int(v) => Values::Int(v[from * k..(from + n) * k].to_vec()),
                Values::Str(v) => Values::Str(v.clone()),
            };
            DataArray::new(&a.name, a.ty, k, values)
        };
        for a in &point_data {
            if a.name == "fixed" && a.components == 1 {
                (0..np[p])
                    .filter(|&v| a.get_f64(pb + v) != 0.0)
                    .for_each(|v| raw.fix(v));
            } else {
                raw.point_data.push(rows(a, pb, np[p]));
            }
        }
        raw.cell_data = cell_data.iter().map(|a| rows(a, cb, nc[p])).collect();
        raw.field_data = field_data.clone();
        pieces.push(raw);
        (pb, cb, kb) = (pb + np[p], cb + nc[p], kb + nk[p]);
    }
    let names = (0..pieces.len()).map(|p| PathBuf::from(format!("piece {p}"))).collect();
    Ok((pieces, names))
}

fn h5(e: hdf5::Error) -> WriteError {
    WriteError::Other(Error::InvalidArgument(format!("VTKHDF: libHDF5: {e}")))
}

/// Writes `mesh` as VTKHDF (one piece) to `w`.
pub(crate) fn write(w: &mut dyn std::io::Write, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    super::check_cell_data(mesh, cell_data)?;
    if let Some(e) = mesh.kinds.iter().position(|&k| k == ElementKind::Polyhedron) {
        return Err(WriteError::Other(Error::InvalidArgument(format!(
            "VTKHDF: element {e} is a polyhedron, which this writer does not write (write VTU or OpenFOAM)"
        ))));
    }
    super::through_file(w, |path| build(path, mesh, cell_data))
}

fn dataset<T: hdf5::H5Type>(g: &hdf5::Group, name: &str, shape: &[usize], values: &[T]) -> WriteResult {
    g.new_dataset::<T>()
        .shape(shape)
        .create(name)
        .and_then(|d| d.write_raw(values))
        .map_err(h5)
}

/// One array as a dataset of `g`; a `/` in its name (which HDF5 takes for a
/// group) is written as `_`.
fn array(g: &hdf5::Group, a: &DataArray) -> WriteResult {
    let name = a.name.replace('/', "_");
    let a = &DataArray::new(name, a.ty, a.components, a.values.clone());
    let n = a.values.len() / a.components.max(1);
    let shape: &[usize] = if a.components == 1 { &[n] } else { &[n, a.components] };
    match (&a.values, a.ty) {
        (Values::Float(v), ValueType::F32) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as f32).collect::<Vec<_>>())
        }
        (Values::Float(v), _) => dataset(g, &a.name, shape, v),
        (Values::Int(v), ValueType::I8) => dataset(g, &a.name, shape, &v.iter().map(|&x| x as i8).collect::<Vec<_>>()),
        (Values::Int(v), ValueType::U8) => dataset(g, &a.name, shape, &v.iter().map(|&x| x as u8).collect::<Vec<_>>()),
        (Values::Int(v), ValueType::I16) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as i16).collect::<Vec<_>>())
        }
        (Values::Int(v), ValueType::U16) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as u16).collect::<Vec<_>>())
        }
        (Values::Int(v), ValueType::I32) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as i32).collect::<Vec<_>>())
        }
        (Values::Int(v), ValueType::U32) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as u32).collect::<Vec<_>>())
        }
        (Values::Int(v), ValueType::U64) => {
            dataset(g, &a.name, shape, &v.iter().map(|&x| x as u64).collect::<Vec<_>>())
        }
        (Values::Int(v), _) => dataset(g, &a.name, shape, v),
        (Values::Str(v), _) => {
            let s: Vec<VarLenUnicode> = v.iter().map(|s| s.replace('\0', "").parse().expect("no NUL")).collect();
            dataset(g, &a.name, &[s.len()], &s)
        }
    }
}

fn build(path: &Path, mesh: &Mesh, cell_data: &[CellData]) -> WriteResult {
    let n = mesh.num_points();
    let ne = mesh.num_elements();
    let nc = ne + mesh.lower.len();
    // HDF5 1.8's format has checksums on the file's metadata, so a damaged
    // copy is refused by them rather than misread (every HDF5 since 1.8 reads it)
    let file = hdf5::File::with_options()
        .with_fapl(|p| p.libver_v18())
        .create(path)
        .map_err(h5)?;
    let root = file.create_group("VTKHDF").map_err(h5)?;
    root.new_attr::<i64>()
        .shape([2])
        .create("Version")
        .and_then(|a| a.write_raw(&[2i64, 0]))
        .map_err(h5)?;
    let ty = FixedAscii::<16>::from_ascii("UnstructuredGrid").expect("ASCII");
    root.new_attr::<FixedAscii<16>>()
        .create("Type")
        .and_then(|a| a.write_scalar(&ty))
        .map_err(h5)?;
    let ids = &mesh.conn[mesh.offsets[0]..mesh.offsets[ne]];
    let (lower_ids, lower_ends) = lower_connectivity(mesh, ids.len());
    let conn: Vec<i64> = ids.iter().chain(&lower_ids).map(|&v| i64::from(v)).collect();
    let offsets: Vec<i64> = mesh.offsets[..=ne]
        .iter()
        .map(|&o| (o - mesh.offsets[0]) as i64)
        .chain(lower_ends.iter().map(|&o| o as i64))
        .collect();
    let types: Vec<u8> = cell_types(mesh).collect();
    dataset(&root, "NumberOfPoints", &[1], &[n as i64])?;
    dataset(&root, "NumberOfCells", &[1], &[nc as i64])?;
    dataset(&root, "NumberOfConnectivityIds", &[1], &[conn.len() as i64])?;
    let pts: Vec<f64> = mesh.points.iter().flatten().copied().collect();
    dataset(&root, "Points", &[n, 3], &pts)?;
    dataset(&root, "Connectivity", &[conn.len()], &conn)?;
    dataset(&root, "Offsets", &[offsets.len()], &offsets)?;
    dataset(&root, "Types", &[types.len()], &types)?;

    let point = root.create_group("PointData").map_err(h5)?;
    if mesh.fixed.iter().any(|&f| f) {
        let f = DataArray::new(
            "fixed",
            ValueType::I32,
            1,
            Values::Int(mesh.fixed.iter().map(|&f| i64::from(f)).collect()),
        );
        array(&point, &f)?;
    }
    for a in mesh.data.point.iter().filter(|a| a.name != "fixed") {
        array(&point, a)?;
    }
    let cell = root.create_group("CellData").map_err(h5)?;
    for a in out_cell_arrays(mesh, cell_data) {
        array(&cell, &a)?;
    }
    let field = root.create_group("FieldData").map_err(h5)?;
    for a in super::out_field_arrays(mesh) {
        array(&field, &a)?;
    }
    file.close().map_err(h5)
}
