//! Files written by other tools: VTK 9.7 (ParaView's writers), meshio 5.3 and
//! Gmsh 4.8. Each is read with the counts its manifest gives, written in every
//! output format, read back, and its cells (lower cells too), groups and data
//! arrays compared as far as the format holds them; meshio reads every VTK
//! and VTU output and Gmsh every `.msh` output with the same counts and
//! values, and Gmsh reads back every `.msh` meshsmooth writes with its
//! physical groups intact.
//!
//! `tests/data/interop/` holds a few of the files so the tests run anywhere;
//! the whole set is `../shared/interop/` (skipped with a message if absent).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::io::{self, Format};
use meshsmooth::mesh::data::{GMSH_DIM_TAGS, GMSH_ELEMENTARY, GMSH_PHYSICAL};
use meshsmooth::mesh::{DataArray, ElementKind, LowerKind, Mesh, ValueType, Values};

fn local_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop")
}

pub(crate) fn shared_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/interop");
    if d.join("MANIFEST.tsv").is_file() {
        Some(d)
    } else {
        eprintln!(
            "skipping the shared interop set: {} not found (it is beside the repository in CI)",
            d.display()
        );
        None
    }
}

/// One manifest row.
struct Row {
    file: String,
    points: usize,
    cells: BTreeMap<String, usize>,
    misoriented: bool,
    arrays: Vec<String>,
    groups: Vec<String>,
}

fn manifest(dir: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(dir.join("MANIFEST.tsv")).unwrap();
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let cells = f[3]
                .trim_matches(|c| c == '{' || c == '}')
                .split(',')
                .map(|kv| {
                    let (k, v) = kv.split_once(':').unwrap();
                    (k.trim().trim_matches('\'').to_string(), v.trim().parse().unwrap())
                })
                .collect();
            let list = |key: &str, sep: &str| -> Vec<String> {
                f[5].split(key)
                    .nth(1)
                    .map(|rest| {
                        rest.trim()
                            .trim_start_matches('[')
                            .split(']')
                            .next()
                            .unwrap()
                            .split(sep)
                            .map(|s| s.trim().trim_matches('\'').to_string())
                            .filter(|s| !s.is_empty())
                            .collect()
                    })
                    .unwrap_or_default()
            };
            Row {
                file: f[0].to_string(),
                points: f[2].parse().unwrap(),
                cells,
                misoriented: f[4].starts_with("no"),
                arrays: list("arrays:", ","),
                groups: list("physical groups:", ","),
            }
        })
        .collect()
}

fn ext(f: Format) -> &'static str {
    match f {
        Format::VtkAscii | Format::VtkBinary => "vtk",
        Format::VtuAscii | Format::VtuBinary | Format::VtuZlib => "vtu",
        Format::Medit => "mesh",
        Format::Exodus => "exo",
        Format::VtkHdf => "vtkhdf",
        _ => "msh",
    }
}

fn is_vtk(f: Format) -> bool {
    ext(f) == "vtk" || ext(f) == "vtu"
}

/// Cell counts by VTK type name, as VTK and meshio count them.
fn cell_counts(m: &Mesh) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for k in &m.kinds {
        let name = match k {
            ElementKind::Triangle => "triangle",
            ElementKind::Quadrilateral => "quad",
            ElementKind::Tetrahedron => "tetra",
            ElementKind::Hexahedron => "hexahedron",
            ElementKind::Prism => "wedge",
            ElementKind::Polyhedron => "polyhedron",
        };
        *out.entry(name.to_string()).or_insert(0) += 1;
    }
    for (k, _) in &m.lower {
        let name = match k {
            LowerKind::Vertex => "vertex",
            LowerKind::Line => "line",
            LowerKind::Triangle => "triangle",
            LowerKind::Quadrilateral => "quad",
        };
        *out.entry(name.to_string()).or_insert(0) += 1;
    }
    out
}

/// Arrays equal in name, type, components and every value (bit for bit);
/// the message shows the first difference, not the whole array.
fn assert_arrays_eq(ctx: &str, got: &[DataArray], want: &[DataArray]) {
    let names = |a: &[DataArray]| a.iter().map(|x| x.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(got), names(want), "{ctx}: array names");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(
            (g.ty, g.components),
            (w.ty, w.components),
            "{ctx}: '{}' type/components",
            w.name
        );
        assert_eq!(g.values.len(), w.values.len(), "{ctx}: '{}' length", w.name);
        if g.values != w.values {
            let i = (0..w.values.len())
                .find(|&i| match (&g.values, &w.values) {
                    (Values::Str(a), Values::Str(b)) => a[i] != b[i],
                    _ => g.get_f64(i).to_bits() != w.get_f64(i).to_bits(),
                })
                .unwrap_or(0);
            let show = |a: &DataArray| match &a.values {
                Values::Str(v) => format!("{:?}", v[i]),
                Values::Int(v) => format!("int {}", v[i]),
                Values::Float(v) => format!("float {:?}", v[i]),
            };
            panic!("{ctx}: '{}' value {i}: got {}, want {}", w.name, show(g), show(w));
        }
    }
}

fn all_arrays(m: &Mesh) -> impl Iterator<Item = &DataArray> {
    m.data.point.iter().chain(&m.data.cell).chain(&m.data.field)
}

/// Read every file of a manifest, smooth it, write it in every format, read it
/// back and compare geometry and data; returns how many files were checked.
fn check_folder(dir: &Path) -> usize {
    let rows = manifest(dir);
    assert!(!rows.is_empty(), "{}: empty manifest", dir.display());
    let out = tempfile::tempdir().unwrap();
    // every output, read back by meshio or Gmsh once all are written
    let (mut check_by_meshio, mut check_by_gmsh) = (Vec::new(), Vec::new());
    for row in &rows {
        let path = dir.join(&row.file);
        let name = &row.file;
        if row.misoriented {
            // meshio's reversed wedges: refused, and the message says why
            let e = io::read(&path).expect_err(name).to_string();
            assert!(e.contains(name) && e.contains("meshio") && e.contains("wedge"), "{e}");
            continue;
        }
        let m = io::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.num_points(), row.points, "{name}: points");
        assert_eq!(cell_counts(&m), row.cells, "{name}: cells by type");
        for a in &row.arrays {
            assert!(all_arrays(&m).any(|x| &x.name == a), "{name}: array '{a}' not kept");
        }
        if !row.groups.is_empty() {
            let names: Vec<&str> = m.data.physical_names.iter().map(|p| p.name.as_str()).collect();
            for g in &row.groups {
                assert!(names.contains(&g.as_str()), "{name}: group {g} not in {names:?}");
            }
            let phys = m.data.cell_array(GMSH_PHYSICAL).expect("gmsh:physical");
            assert!(
                (0..m.num_elements()).all(|e| phys.get_i64(e) != 0),
                "{name}: untagged element"
            );
        }
        check_known_values(name, &m);
        // smoothed (the data must not notice), then written in every format
        let input = m.clone();
        let mut m = m;
        let mut params = meshsmooth::solve::Params::default();
        params.max_iter = 20;
        let opts = meshsmooth::solve::Options::cpu(meshsmooth::solve::Method::Newton, &params);
        let info = meshsmooth::solve::smooth_mesh(&mut m, &Default::default(), &opts, &mut |_| true)
            .unwrap_or_else(|e| panic!("{name}: smoothing: {e}"));
        assert!(info.objective <= info.history.first().unwrap().objective, "{name}");
        assert!(info.iterations > 0 && m.points != input.points, "{name}: nothing moved");
        assert!(m.data == input.data, "{name}: smoothing changed the data arrays");
        // OpenFOAM rebuilds each cell from its faces (its own tests in `openfoam`)
        for f in Format::ALL
            .into_iter()
            .filter(|f| !f.is_openfoam() && !f.is_surface_only())
        {
            let p = out.path().join(format!("{name}.{f}.{}", ext(f)));
            io::write(&p, &m, f, &[]).unwrap_or_else(|e| panic!("{name} as {f}: {e}"));
            let got = io::read(&p).unwrap_or_else(|e| panic!("{name} as {f}: {e}"));
            let ctx = format!("{name} as {f}");
            assert_eq!(got.points, m.points, "{ctx}: points");
            assert_eq!(got.kinds, m.kinds, "{ctx}: kinds");
            assert_eq!(got.conn, m.conn, "{ctx}: connectivity");
            check_lower_cells(&ctx, f, &got, &m);
            if is_vtk(f) || f == Format::VtkHdf {
                // every array, exactly: names, types, components, values
                assert_arrays_eq(&format!("{ctx}: point data"), &got.data.point, &m.data.point);
                assert_arrays_eq(&format!("{ctx}: cell data"), &got.data.cell, &m.data.cell);
                assert_arrays_eq(&format!("{ctx}: field data"), &got.data.field, &m.data.field);
                if !m.data.lower.is_empty() {
                    assert_arrays_eq(&format!("{ctx}: lower-cell data"), &got.data.lower, &m.data.lower);
                }
                if f != Format::VtkHdf {
                    check_by_meshio.push((p, got));
                }
            } else if matches!(f, Format::Abaqus | Format::Exodus) {
                // Gmsh's physical groups come back as element sets (Abaqus) or
                // blocks (Exodus) of the same name and members
                for p in &m.data.physical_names {
                    let members = |a: Option<&DataArray>, n: usize| -> Vec<u32> {
                        a.map_or(Vec::new(), |a| {
                            (0..n as u32)
                                .filter(|&i| a.get_i64(i as usize) == i64::from(p.tag))
                                .collect()
                        })
                    };
                    let set = got.data.element_sets.iter().find(|s| s.name == p.name);
                    let set = set.unwrap_or_else(|| panic!("{ctx}: no element set '{}'", p.name));
                    assert_eq!(
                        set.elements,
                        members(m.data.cell_array(GMSH_PHYSICAL), m.num_elements()),
                        "{ctx}: {}",
                        p.name
                    );
                    assert_eq!(
                        set.lower,
                        members(m.data.lower_array(GMSH_PHYSICAL), m.lower.len()),
                        "{ctx}: {}",
                        p.name
                    );
                }
            } else if f != Format::Medit {
                check_gmsh_data(&ctx, f, &got, &m);
                assert_eq!(got.data.physical_names, m.data.physical_names, "{ctx}: physical names");
                for tag in [GMSH_PHYSICAL, GMSH_ELEMENTARY] {
                    let want: Vec<i64> = match m.data.cell_array(tag) {
                        Some(a) => (0..m.num_elements()).map(|e| a.get_i64(e)).collect(),
                        None => vec![if tag == GMSH_PHYSICAL { 0 } else { 1 }; m.num_elements()],
                    };
                    let a = got.data.cell_array(tag).unwrap();
                    let have: Vec<i64> = (0..got.num_elements()).map(|e| a.get_i64(e)).collect();
                    assert_eq!(have, want, "{ctx}: {tag} of the elements");
                    if let Some(a) = m.data.lower_array(tag) {
                        let b = got.data.lower_array(tag).unwrap();
                        for i in 0..m.lower.len() {
                            assert_eq!(b.get_i64(i), a.get_i64(i), "{ctx}: {tag} of lower cell {i}");
                        }
                    }
                }
                check_by_gmsh.push((p, got));
            }
        }
    }
    meshio_reads_as_we_do(&check_by_meshio);
    gmsh_reads_as_we_do(&check_by_gmsh);
    rows.len()
}

/// Every format keeps the lower cells: in order, except that Medit groups
/// them by kind and Exodus by block.
fn check_lower_cells(ctx: &str, f: Format, got: &Mesh, want: &Mesh) {
    assert!(f.keeps_lower_cells(), "{ctx}");
    assert_eq!(
        cell_counts(got),
        cell_counts(want),
        "{ctx}: cells by type, lower cells too"
    );
    if matches!(f, Format::Medit | Format::Exodus) {
        let sorted = |m: &Mesh| {
            let mut v = m.lower.clone();
            v.sort_by_key(|(k, vs)| (format!("{k:?}"), vs.clone()));
            v
        };
        assert!(sorted(got) == sorted(want), "{ctx}: lower cells");
    } else {
        assert!(got.lower == want.lower, "{ctx}: lower cells");
    }
}

/// A Gmsh output keeps the numeric point and cell arrays as views (values
/// as f64), and a 4.1 output the entities and each node's entity.
fn check_gmsh_data(ctx: &str, f: Format, got: &Mesh, want: &Mesh) {
    let structure = [GMSH_PHYSICAL, GMSH_ELEMENTARY, GMSH_DIM_TAGS, "fixed"];
    for (what, have, arrays) in [
        ("point", &got.data.point, &want.data.point),
        ("cell", &got.data.cell, &want.data.cell),
    ] {
        for a in arrays
            .iter()
            .filter(|a| a.ty != ValueType::Str && !structure.contains(&a.name.as_str()))
        {
            let g = have
                .iter()
                .find(|g| g.name == a.name)
                .unwrap_or_else(|| panic!("{ctx}: {what} array '{}' not kept as a view", a.name));
            assert_eq!(
                (g.ty, g.components),
                (ValueType::F64, a.components),
                "{ctx}: '{}'",
                a.name
            );
            let same = (0..a.values.len()).all(|i| g.get_f64(i).to_bits() == a.get_f64(i).to_bits());
            assert!(same, "{ctx}: {what} array '{}' values", a.name);
        }
    }
    // (without entities of its own, a mesh gets those its cells use)
    if matches!(f, Format::Msh41Ascii | Format::Msh41Binary) && !want.data.gmsh_entities.is_empty() {
        assert_eq!(got.data.gmsh_entities, want.data.gmsh_entities, "{ctx}: entities");
        if let Some(a) = want.data.point.iter().find(|a| a.name == GMSH_DIM_TAGS) {
            let g = got
                .data
                .point
                .iter()
                .find(|g| g.name == GMSH_DIM_TAGS)
                .expect("gmsh:dim_tags");
            assert_eq!(g.values, a.values, "{ctx}: the entity of each node");
        }
    }
}

/// meshio 5.3 reads each VTK/VTU file with the cells and numeric cell
/// arrays (elements, then lower cells) meshsmooth reads from it. meshio
/// reads no string arrays (neither in VTK's own files), so a mesh with one
/// is checked in a copy written without them.
fn meshio_reads_as_we_do(files: &[(PathBuf, Mesh)]) {
    let Some(python) = meshio_python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let paths: Vec<PathBuf> = files
        .iter()
        .enumerate()
        .map(|(i, (p, m))| {
            let strings = |a: &[DataArray]| a.iter().any(|a| a.ty == ValueType::Str);
            if !strings(&m.data.point) && !strings(&m.data.cell) && !strings(&m.data.field) {
                return p.clone();
            }
            let mut bare = m.clone();
            for arrays in [
                &mut bare.data.point,
                &mut bare.data.cell,
                &mut bare.data.lower,
                &mut bare.data.field,
            ] {
                arrays.retain(|a| a.ty != ValueType::Str);
            }
            let copy = dir
                .path()
                .join(format!("{i}.{}", p.file_name().unwrap().to_string_lossy()));
            io::write(&copy, &bare, Format::of_file(p).unwrap(), &[]).unwrap();
            copy
        })
        .collect();
    let script = [
        "import sys, json, meshio, numpy as np",
        "out = []",
        "for p in sys.argv[1:]:",
        "    m = meshio.read(p)",
        "    cells = {}",
        "    for c in m.cells:",
        "        cells[c.type] = cells.get(c.type, 0) + len(c.data)",
        "    data = {}",
        "    for k, blocks in m.cell_data.items():",
        "        if all(b.dtype.kind in 'iuf' for b in blocks):",
        "            v = np.concatenate([np.asarray(b, dtype=float).ravel() for b in blocks])",
        "            data[k] = [None if np.isnan(x) else float(x) for x in v]",
        "    out.append([len(m.points), cells, data])",
        "print(json.dumps(out))",
    ]
    .join("\n");
    type Read = (usize, BTreeMap<String, usize>, BTreeMap<String, Vec<Option<f64>>>);
    let o = Command::new(&python)
        .args(["-c", &script])
        .args(&paths)
        .output()
        .unwrap();
    assert!(o.status.success(), "meshio: {}", String::from_utf8_lossy(&o.stderr));
    let read: Vec<Read> = serde_json::from_slice(&o.stdout).unwrap();
    for ((path, m), (points, cells, data)) in files.iter().zip(read) {
        let ctx = format!("{} read by meshio", path.display());
        assert_eq!(points, m.num_points(), "{ctx}: points");
        assert_eq!(cells, cell_counts(m), "{ctx}: cells by type");
        for a in m.data.cell.iter().filter(|a| a.ty != ValueType::Str) {
            let lower = m.data.lower_array(&a.name);
            let want: Vec<Option<f64>> = (0..a.values.len())
                .map(|i| a.get_f64(i))
                .chain(lower.iter().flat_map(|l| (0..l.values.len()).map(|i| l.get_f64(i))))
                .map(|x| (!x.is_nan()).then_some(x))
                .collect();
            assert_eq!(data.get(&a.name), Some(&want), "{ctx}: cell array '{}'", a.name);
        }
    }
}

/// Gmsh loads each `.msh` file (`-check`) with as many nodes and elements
/// (lower cells included) as meshsmooth reads from it.
fn gmsh_reads_as_we_do(files: &[(PathBuf, Mesh)]) {
    if files.is_empty() || !gmsh_available() {
        return;
    }
    for (path, m) in files {
        let log = run_gmsh(
            &format!("{} -check", path.display()),
            &[path.as_os_str(), "-check".as_ref()],
        );
        let count = |what: &str| {
            log.lines()
                .filter_map(|l| {
                    l.strip_prefix("Info    : ")?
                        .strip_suffix(what)?
                        .trim()
                        .parse::<usize>()
                        .ok()
                })
                .next_back()
                .unwrap_or_else(|| panic!("{}: no '{what}' count in:\n{log}", path.display()))
        };
        let ctx = format!("{} read by Gmsh", path.display());
        assert_eq!(count(" nodes"), m.num_points(), "{ctx}: nodes");
        assert_eq!(count(" elements"), m.num_elements() + m.lower.len(), "{ctx}: elements");
    }
}

/// Values VTK's files are known to hold (see the shared README): a
/// 3-component velocity (1, 2, 3), a region id per cell, a string note.
fn check_known_values(name: &str, m: &Mesh) {
    if !name.contains("_x_") {
        return;
    }
    let v = m.data.point.iter().find(|a| a.name == "velocity").unwrap();
    assert_eq!((v.components, v.ty), (3, ValueType::F64), "{name}");
    let Values::Float(vals) = &v.values else {
        panic!("{name}: velocity")
    };
    assert!(vals.chunks(3).all(|c| c == [1.0, 2.0, 3.0]), "{name}: velocity values");
    let r = m.data.cell_array("region").unwrap();
    assert_eq!(r.ty, ValueType::I32, "{name}");
    assert_eq!(
        r.values,
        Values::Int((0..m.num_elements() as i64).collect()),
        "{name}: region"
    );
    let t = m.data.point.iter().find(|a| a.name == "temperature").unwrap();
    assert_eq!(t.ty, ValueType::F32, "{name}");
    let note = m.data.field.iter().find(|a| a.name == "note").unwrap();
    assert_eq!(note.values, Values::Str(vec!["made by vtk".into()]), "{name}: note");
    let time = m.data.field.iter().find(|a| a.name == "TimeValue").unwrap();
    assert_eq!(time.values, Values::Float(vec![0.5]), "{name}: TimeValue");
}

#[test]
fn local_copies_of_other_tools_files_round_trip_with_their_data() {
    assert_eq!(check_folder(&local_dir()), 8);
}

/// Wedges with their base reversed, as Gmsh's VTK export writes them (its
/// `MPrism::getVertexVTK` maps 0,2,1,3,5,4) and meshio 5.3 too: the refusal
/// names both writers and the fix, not meshio alone.
#[test]
fn reversed_wedges_are_refused_naming_the_writers_that_reverse_them() {
    let mut mesh = meshsmooth::generate::prism::prism_mesh(false, 1);
    for e in 0..mesh.num_elements() {
        assert_eq!(mesh.kinds[e], ElementKind::Prism);
        let vs = &mut mesh.conn[mesh.offsets[e]..mesh.offsets[e + 1]];
        vs.swap(1, 2);
        vs.swap(4, 5);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gmsh-export.vtk");
    io::write(&path, &mesh, Format::VtkAscii, &[]).unwrap();
    let e = io::read(&path).expect_err("reversed wedges").to_string();
    assert!(
        e.contains("gmsh-export.vtk") && e.contains("base triangle reversed"),
        "{e}"
    );
    assert!(e.contains("Gmsh's VTK export") && e.contains("meshio"), "{e}");
    assert!(e.contains("(0,2,1,3,5,4)"), "{e}");
}

#[test]
fn every_shared_interop_file_round_trips_with_its_data() {
    if let Some(dir) = shared_dir() {
        assert!(check_folder(&dir) >= 38);
    }
}

#[test]
fn parsing_is_linear_in_the_number_of_elements() {
    // 100k sibling DataArrays used to take 17 s (a line count from the start per tag)
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n<UnstructuredGrid>\n\
         <Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<FieldData>\n",
    );
    for i in 0..100_000 {
        text.push_str(&format!(
            "<DataArray type=\"Int32\" Name=\"f{i}\" NumberOfTuples=\"1\" format=\"ascii\">{i}</DataArray>\n"
        ));
    }
    text.push_str(
        "</FieldData>\n<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\
         0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>\n<Cells>\
         <DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\
         <DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">4</DataArray>\
         <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray></Cells>\n\
         </Piece>\n</UnstructuredGrid>\n</VTKFile>\n",
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("many.vtu");
    std::fs::write(&p, &text).unwrap();
    let t = std::time::Instant::now();
    let m = io::read(&p).unwrap();
    let secs = t.elapsed().as_secs_f64();
    assert_eq!(m.data.field.len(), 100_000);
    assert_eq!(m.data.field[99_999].values, Values::Int(vec![99_999]));
    assert!(secs < 5.0, "reading 100k arrays took {secs:.1} s");
}

/// Cells keyed by their vertices' coordinates (node numbering may change;
/// Gmsh prints 16 significant digits, so compare to 1e-9), with their
/// physical tag; cells without a group are left out.
fn groups_by_geometry(m: &Mesh) -> HashMap<Vec<[i64; 3]>, i64> {
    let key = |vs: &[u32]| {
        let mut k: Vec<[i64; 3]> = vs
            .iter()
            .map(|&v| m.points[v as usize].map(|x| (x * 1e9).round() as i64))
            .collect();
        k.sort_unstable();
        k
    };
    let mut out = HashMap::new();
    if let Some(a) = m.data.cell_array(GMSH_PHYSICAL) {
        for e in 0..m.num_elements() {
            if a.get_i64(e) != 0 {
                out.insert(key(m.element(e)), a.get_i64(e));
            }
        }
    }
    if let Some(a) = m.data.lower_array(GMSH_PHYSICAL) {
        for (i, (_, vs)) in m.lower.iter().enumerate() {
            if a.get_i64(i) != 0 {
                out.insert(key(vs), a.get_i64(i));
            }
        }
    }
    out
}

pub(crate) fn gmsh_available() -> bool {
    let ok = Command::new("gmsh")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success() || !o.stderr.is_empty() || !o.stdout.is_empty());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "gmsh is not installed, and CI must run the Gmsh read-back test (see .ci/install-test-deps)"
        );
        eprintln!("skipping the Gmsh read-back test: gmsh is not installed (apt-get install gmsh)");
    }
    ok
}

/// Runs `gmsh` with `args`, asserting that it succeeds without an error
/// (`ctx` says what for); its output.
pub(crate) fn run_gmsh<S: AsRef<std::ffi::OsStr>>(ctx: &str, args: &[S]) -> String {
    let o = Command::new("gmsh").args(args).output().unwrap();
    let log = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !log.contains("Error"),
        "{ctx}: gmsh failed:\n{log}"
    );
    log
}

/// Gmsh loads every `.msh` meshsmooth writes (`-check`), and saves it again
/// with the same physical groups on the same cells.
#[test]
fn gmsh_reads_back_every_msh_meshsmooth_writes() {
    if !gmsh_available() {
        return;
    }
    let mut sources = vec![local_dir().join("gmsh_box_phys_msh41a.msh")];
    if let Some(d) = shared_dir() {
        for f in [
            "gmsh_box_phys_msh22a.msh",
            "gmsh_box_phys_msh41b.msh",
            "meshio_tetbox_vtu_zlib.vtu",
            "meshio_trirect_vtu_zlib.vtu",
        ] {
            sources.push(d.join(f));
        }
    }
    let dir = tempfile::tempdir().unwrap();
    for src in &sources {
        let m = io::read(src).unwrap();
        let want = groups_by_geometry(&m);
        assert!(!want.is_empty(), "{}: no groups", src.display());
        for f in [
            Format::Msh22Ascii,
            Format::Msh22Binary,
            Format::Msh41Ascii,
            Format::Msh41Binary,
        ] {
            let name = src.file_name().unwrap().to_string_lossy().to_string();
            let out = dir.path().join(format!("{name}.{f}.msh"));
            io::write(&out, &m, f, &[]).unwrap();
            run_gmsh(&format!("{name} as {f}: -check"), &[out.as_os_str(), "-check".as_ref()]);
            let resaved = dir.path().join(format!("{name}.{f}.resaved.msh"));
            let save = ["-save", "-format", "msh22", "-o"].map(std::ffi::OsStr::new);
            run_gmsh(
                &format!("{name} as {f}: -save"),
                &[&[out.as_os_str()], &save[..], &[resaved.as_os_str()]].concat(),
            );
            let back = io::read(&resaved).unwrap_or_else(|e| panic!("{name} as {f}, saved by Gmsh: {e}"));
            assert_eq!(groups_by_geometry(&back), want, "{name} as {f}: groups after Gmsh");
            let mut names = back.data.physical_names.clone();
            let mut want_names = m.data.physical_names.clone();
            names.sort_by_key(|p| (p.dim, p.tag));
            want_names.sort_by_key(|p| (p.dim, p.tag));
            assert_eq!(names, want_names, "{name} as {f}: physical names after Gmsh");
        }
    }
}

fn meshsmooth(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(args)
        .output()
        .unwrap()
}

/// The arrays of a VTK file survive a smoothing run, next to the quality
/// array; `--drop-data` writes the bare mesh.
#[test]
fn smoothing_keeps_every_array_unless_told_not_to() {
    let src = local_dir().join("vtk_tri_x_xml_default.vtu");
    let m = io::read(&src).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (fmt, ext) in [("vtu-zlib", "vtu"), ("vtk-binary", "vtk"), ("vtu", "vtu")] {
        let out = dir.path().join(format!("out-{fmt}.{ext}"));
        let o = meshsmooth(&[
            "smooth".as_ref(),
            src.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--format".as_ref(),
            fmt.as_ref(),
            "--device".as_ref(),
            "cpu".as_ref(),
            "--max-iter".as_ref(),
            "3".as_ref(),
            "-q".as_ref(),
        ]);
        assert!(o.status.success(), "{fmt}: {}", String::from_utf8_lossy(&o.stderr));
        let got = io::read(&out).unwrap();
        assert_arrays_eq(&format!("{fmt}: point data"), &got.data.point, &m.data.point);
        assert_arrays_eq(&format!("{fmt}: field data"), &got.data.field, &m.data.field);
        assert_arrays_eq(&format!("{fmt}: cell data"), &got.data.cell[..1], &m.data.cell);
        let q = got.data.cell_array("inverse_mean_ratio").expect("quality array");
        assert!(
            (0..got.num_elements()).all(|e| q.get_f64(e) >= 1.0),
            "{fmt}: quality values"
        );
        assert_ne!(got.points, m.points, "{fmt}: the mesh was smoothed");
    }
    let bare = dir.path().join("bare.vtu");
    let o = meshsmooth(&[
        "smooth".as_ref(),
        src.as_os_str(),
        "-o".as_ref(),
        bare.as_os_str(),
        "--drop-data".as_ref(),
        "--device".as_ref(),
        "cpu".as_ref(),
        "--max-iter".as_ref(),
        "1".as_ref(),
        "-q".as_ref(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = io::read(&bare).unwrap();
    assert!(got.data.point.is_empty() && got.data.field.is_empty());
    let names: Vec<&str> = got.data.cell.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["inverse_mean_ratio"]);
}

#[test]
fn data_arrays_follow_a_reordering() {
    let mut m = io::read(local_dir().join("vtk_tri_x_leg42b.vtk")).unwrap();
    let n = m.num_points();
    let order: Vec<usize> = (0..n).rev().collect();
    let before = m.data.point.clone();
    m.data.permute_points(&order);
    for (a, b) in m.data.point.iter().zip(&before) {
        let k = a.components;
        for i in 0..n {
            for c in 0..k {
                assert_eq!(a.get_f64(i * k + c).to_bits(), b.get_f64((n - 1 - i) * k + c).to_bits());
            }
        }
    }
}

/// A Python with meshio (see [`crate::common::python_with`]).
pub(crate) fn meshio_python() -> Option<PathBuf> {
    crate::common::python_with("meshio", "the meshio read-back tests")
}

/// meshio 5.3 reads the legacy VTK files meshsmooth writes, ASCII and
/// binary, with every integer array type (it has no `vtktypeint64` or
/// `signed_char`, which meshsmooth used to write), values and types kept.
#[test]
fn meshio_reads_our_legacy_vtk_arrays() {
    let Some(python) = meshio_python() else {
        return;
    };
    let mut m = Mesh::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    m.push_element(ElementKind::Tetrahedron, &[0, 1, 2, 3]);
    let ints = |v: &[i64]| Values::Int(v.to_vec());
    let arrays = [
        ("i8", ValueType::I8, ints(&[-3, 0, 5, 127]), "int8"),
        ("u8", ValueType::U8, ints(&[0, 1, 200, 255]), "uint8"),
        ("i16", ValueType::I16, ints(&[-300, 0, 5, 32767]), "int16"),
        ("i32", ValueType::I32, ints(&[-70000, 0, 5, 1 << 30]), "int32"),
        ("i64", ValueType::I64, ints(&[-(1 << 40), 0, 5, 1 << 50]), "int64"),
        ("u64", ValueType::U64, ints(&[0, 1, 1 << 40, 1 << 62]), "uint64"),
        (
            "f64",
            ValueType::F64,
            Values::Float(vec![0.5, -1.25, 3.0, 1e-7]),
            "float64",
        ),
    ];
    for (name, ty, values, _) in &arrays {
        m.data.point.push(DataArray::new(*name, *ty, 1, values.clone()));
    }
    let dir = tempfile::tempdir().unwrap();
    for format in [Format::VtkAscii, Format::VtkBinary] {
        let p = dir.path().join(format!("{format}.vtk"));
        io::write(&p, &m, format, &[]).unwrap();
        let script = "import sys, json, meshio\n\
                      m = meshio.read(sys.argv[1])\n\
                      print(json.dumps({k: [str(v.dtype.newbyteorder('=')), v.ravel().tolist()] for k, v in m.point_data.items()}))";
        let o = Command::new(&python).args(["-c", script]).arg(&p).output().unwrap();
        assert!(o.status.success(), "{format}: {}", String::from_utf8_lossy(&o.stderr));
        let got: HashMap<String, (String, Vec<f64>)> = serde_json::from_slice(&o.stdout).unwrap();
        for (name, _, values, dtype) in &arrays {
            let want: Vec<f64> = match values {
                Values::Int(v) => v.iter().map(|&x| x as f64).collect(),
                Values::Float(v) => v.clone(),
                Values::Str(_) => unreachable!(),
            };
            let (t, v) = &got[*name];
            assert_eq!((t.as_str(), v), (*dtype, &want), "{format}: array {name}");
        }
    }
}

/// meshio 5.3.5's own Exodus (netCDF-4) and Abaqus files of one box, with
/// the point set `wall` (`tests/data/interop/meshio`, `make_meshio.py`):
/// each reads as the box, with its set (and the Exodus file its nodal
/// variable `heat` = x + 2y + 3z); smoothed with the set fixed and written
/// back in its own format, the set stays put and is kept, the variable too,
/// and the quality improves.
#[test]
fn meshio_s_exodus_and_abaqus_files_are_smoothed_keeping_their_set() {
    use crate::common::cli::{meshsmooth as cli, s, text};
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/interop/meshio");
    let whole = io::read(dir.join("box.vtu")).unwrap();
    let x0 = whole.points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let wall: Vec<u32> = (0..whole.num_points() as u32)
        .filter(|&v| whole.points[v as usize][0] == x0)
        .collect();
    let mut files = vec!["box.inp"];
    if cfg!(feature = "exodus") {
        files.push("box.exo");
    }
    let out_dir = tempfile::tempdir().unwrap();
    let q = |m: &Mesh| meshsmooth::report::quality_report(m, &m.points).objective.unwrap();
    for name in files {
        let src = dir.join(name);
        let m = io::read(&src).unwrap();
        assert_eq!(m.points, whole.points, "{name}");
        assert_eq!((&m.kinds, &m.conn), (&whole.kinds, &whole.conn), "{name}");
        let set = |m: &Mesh| {
            let s = m.data.node_sets.iter().find(|s| s.name == "wall");
            s.unwrap_or_else(|| panic!("{name}: no set wall")).vertices.clone()
        };
        assert_eq!(set(&m), wall, "{name}");
        let heat = |m: &Mesh| -> Vec<f64> {
            let a = m.data.point.iter().find(|a| a.name == "heat").expect("heat");
            (0..m.num_points()).map(|v| a.get_f64(v)).collect()
        };
        if name.ends_with(".exo") {
            let want: Vec<f64> = m.points.iter().map(|p| p[0] + 2.0 * p[1] + 3.0 * p[2]).collect();
            assert_eq!(heat(&m), want, "{name}");
        }
        let out = out_dir.path().join(format!("out-{name}"));
        let o = cli(&["smooth", s(&src), "-o", s(&out), "--fix-group", "wall"]);
        assert!(o.status.success(), "{name}: {}", text(&o));
        let got = io::read(&out).unwrap();
        assert_eq!(Format::of_file(&out), Format::of_file(&src), "{name}: same format");
        assert_eq!(set(&got), wall, "{name}: the set kept");
        assert!(
            wall.iter().all(|&v| got.points[v as usize] == m.points[v as usize]),
            "{name}"
        );
        assert!(q(&got) < q(&m) - 1e-3, "{name}: {} vs {}", q(&got), q(&m));
        if name.ends_with(".exo") {
            assert_eq!(heat(&got), heat(&m), "{name}: the variable kept");
        }
    }
}
