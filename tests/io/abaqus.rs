//! Abaqus `.inp`: small files written here read to the expected values,
//! round trips through `.inp` and `.vtu`, sets as groups of the CLI's
//! `--fix-group`, orientation of every kind, and errors that name the file
//! and the line.

use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::io::{self, Format};
use meshsmooth::mesh::data::{ABAQUS_ELEMENT_ID, ABAQUS_NODE_ID, ABAQUS_TYPE, ABAQUS_TYPES};
use meshsmooth::mesh::{DataArray, ElementKind, LowerKind, Mesh, Values};

use crate::common;
use crate::common::cli::{meshsmooth, s, text};

fn put(dir: &Path, name: &str, content: &str) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, content).unwrap();
    p
}

fn ints(a: &DataArray) -> Vec<i64> {
    (0..a.tuples()).map(|i| a.get_i64(i)).collect()
}

fn node_ids(m: &Mesh) -> Vec<i64> {
    ints(
        m.data
            .point
            .iter()
            .find(|a| a.name == ABAQUS_NODE_ID)
            .expect("node ids"),
    )
}

fn element_ids(m: &Mesh) -> Vec<i64> {
    ints(m.data.cell_array(ABAQUS_ELEMENT_ID).expect("element ids"))
}

/// The node numbers of a node set, ascending.
fn nset(m: &Mesh, name: &str) -> Vec<i64> {
    let ids = node_ids(m);
    let s = m
        .data
        .node_sets
        .iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("no node set {name}: {:?}", m.data.node_sets));
    let mut out: Vec<i64> = s.vertices.iter().map(|&v| ids[v as usize]).collect();
    out.sort_unstable();
    out
}

/// The element numbers of an element set's elements, ascending.
fn elset(m: &Mesh, name: &str) -> Vec<i64> {
    let ids = element_ids(m);
    let s = m
        .data
        .element_sets
        .iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("no element set {name}: {:?}", m.data.element_sets));
    let mut out: Vec<i64> = s.elements.iter().map(|&e| ids[e as usize]).collect();
    out.sort_unstable();
    out
}

fn types(m: &Mesh) -> Vec<String> {
    let Some(DataArray {
        values: Values::Str(names),
        ..
    }) = m.data.field.iter().find(|a| a.name == ABAQUS_TYPES)
    else {
        panic!("no type names")
    };
    let codes = ints(m.data.cell_array(ABAQUS_TYPE).expect("types"));
    codes.iter().map(|&c| names[c as usize].clone()).collect()
}

/// Two hexahedra side by side (x = 0..2, y and z = 0..1), nodes numbered
/// 5, 12, ... 82 (7 apart) and listed backwards; sets of every kind.
const TWO_HEXES: &str = "*Heading
** two hexahedra, sparse node numbers written out of order
*NODE, NSET=all
82, 2., 1., 1.
75, 1., 1., 1.
68, 0., 1., 1.
61, 2., 0., 1.
54, 1., 0., 1.
47, 0., 0., 1.
40, 2., 1., 0.
33, 1., 1., 0.
26, 0., 1., 0.
19, 2., 0., 0.
12, 1., 0., 0.
5, 0., 0., 0.
*Element, type=C3D8R, elset=LEFT
7, 5, 12, 33, 26,
   47, 54, 75, 68
*ELEMENT, TYPE=C3D8, ELSET=RIGHT
3, 12, 19, 40, 33, 54, 61, 82, 75
*Nset, nset=BOTTOM
5, 12, 19, 26, 33,
40
*NSET, NSET=TOPGEN, GENERATE
47, 82, 7
*Nset, nset=EDGES
BOTTOM, 47
*Elset, elset=BOTH
LEFT, RIGHT
*ELSET, ELSET=GEN, GENERATE
3, 7, 4
*Nset , Nset = rightnodes, elset=right
** a step: skipped with its data lines
*Step
*Static
0.1, 1.
*Boundary
BOTTOM, ENCASTRE
*End Step
";

fn check_two_hexes(m: &Mesh) {
    assert_eq!((m.num_points(), m.num_elements()), (12, 2));
    assert!(m.kinds.iter().all(|&k| k == ElementKind::Hexahedron));
    let ids = node_ids(m);
    assert_eq!(ids, vec![82, 75, 68, 61, 54, 47, 40, 33, 26, 19, 12, 5]);
    let at = |id: i64| m.points[ids.iter().position(|&i| i == id).unwrap()];
    assert_eq!(at(61), [2.0, 0.0, 1.0]);
    assert_eq!(at(5), [0.0, 0.0, 0.0]);
    assert_eq!(element_ids(m), vec![7, 3]);
    let first: Vec<i64> = m.element(0).iter().map(|&v| ids[v as usize]).collect();
    assert_eq!(first, vec![5, 12, 33, 26, 47, 54, 75, 68]);
    assert_eq!(types(m), vec!["C3D8R", "C3D8"]);
    assert_eq!(nset(m, "all").len(), 12);
    assert_eq!(nset(m, "BOTTOM"), vec![5, 12, 19, 26, 33, 40]);
    assert_eq!(nset(m, "TOPGEN"), vec![47, 54, 61, 68, 75, 82]);
    assert_eq!(nset(m, "EDGES"), vec![5, 12, 19, 26, 33, 40, 47]);
    assert_eq!(nset(m, "rightnodes"), vec![12, 19, 33, 40, 54, 61, 75, 82]);
    assert_eq!(elset(m, "LEFT"), vec![7]);
    assert_eq!(elset(m, "RIGHT"), vec![3]);
    assert_eq!(elset(m, "BOTH"), vec![3, 7]);
    assert_eq!(elset(m, "GEN"), vec![3, 7]);
}

#[test]
fn a_hex_file_reads_with_its_numbers_types_and_sets() {
    let dir = tempfile::tempdir().unwrap();
    let p = put(dir.path(), "two.inp", TWO_HEXES);
    assert_eq!(Format::from_path(&p).unwrap(), Format::Abaqus);
    assert_eq!(Format::of_file(&p), Some(Format::Abaqus));
    assert_eq!(Format::from_name("abaqus"), Some(Format::Abaqus));
    check_two_hexes(&io::read(&p).unwrap());
}

/// One element of each kind at the node coordinates of Abaqus's reference
/// element (its documentation's node numbering): read, none is inverted.
#[test]
fn every_kind_reads_with_abaqus_orientation_uninverted() {
    let cases: [(&str, &str, ElementKind); 6] = [
        (
            "C3D4",
            "1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1",
            ElementKind::Tetrahedron,
        ),
        (
            "C3D8I",
            "1, -1, -1, -1\n2, 1, -1, -1\n3, 1, 1, -1\n4, -1, 1, -1\n\
             5, -1, -1, 1\n6, 1, -1, 1\n7, 1, 1, 1\n8, -1, 1, 1",
            ElementKind::Hexahedron,
        ),
        (
            "C3D6",
            "1, 0, 0, -1\n2, 1, 0, -1\n3, 0, 1, -1\n4, 0, 0, 1\n5, 1, 0, 1\n6, 0, 1, 1",
            ElementKind::Prism,
        ),
        ("CPS3", "1, 0, 0\n2, 1, 0\n3, 0, 1", ElementKind::Triangle),
        (
            "CPE4R",
            "1, -1, -1\n2, 1, -1\n3, 1, 1\n4, -1, 1",
            ElementKind::Quadrilateral,
        ),
        (
            "S4R",
            "1, -1, -1, 0\n2, 1, -1, 0\n3, 1, 1, 0\n4, -1, 1, 0",
            ElementKind::Quadrilateral,
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (ty, nodes, kind) in cases {
        let n = kind.num_vertices().unwrap();
        let conn: Vec<String> = (1..=n).map(|i| i.to_string()).collect();
        let text = format!("*NODE\n{nodes}\n*ELEMENT, TYPE={ty}\n1, {}\n", conn.join(", "));
        let p = put(dir.path(), &format!("{ty}.inp"), &text);
        let m = io::read(&p).unwrap_or_else(|e| panic!("{ty}: {e}"));
        assert_eq!(m.kinds, vec![kind], "{ty}");
        assert!(meshsmooth::metric::inverted_elements(&m, &m.points).is_empty(), "{ty}");
        // and as meshsmooth writes it back
        let out = dir.path().join(format!("{ty}-out.inp"));
        io::write(&out, &m, Format::Abaqus, &[]).unwrap();
        let back = io::read(&out).unwrap();
        assert_eq!((&back.points, &back.conn), (&m.points, &m.conn), "{ty}");
        assert_eq!(types(&back), vec![ty.to_string()]);
    }
}

/// Surfaces and lines among solids are lower cells (their vertices fixed).
#[test]
fn surfaces_and_lines_among_solids_are_lower_cells() {
    let text = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n\
                *ELEMENT, TYPE=C3D4, ELSET=SOLID\n10, 1, 2, 3, 4\n\
                *ELEMENT, TYPE=R3D3, ELSET=FACE\n20, 1, 3, 2\n\
                *ELEMENT, TYPE=T3D2, ELSET=EDGE\n30, 1, 4\n";
    let dir = tempfile::tempdir().unwrap();
    let m = io::read(put(dir.path(), "mixed.inp", text)).unwrap();
    assert_eq!(m.kinds, vec![ElementKind::Tetrahedron]);
    let lower: Vec<LowerKind> = m.lower.iter().map(|(k, _)| *k).collect();
    assert_eq!(lower, vec![LowerKind::Triangle, LowerKind::Line]);
    let face = m.data.element_sets.iter().find(|s| s.name == "FACE").unwrap();
    assert_eq!((face.elements.len(), face.lower.clone()), (0, vec![0]));
    assert!((0..4).all(|v| m.is_fixed(v)));
    let out = dir.path().join("out.inp");
    io::write(&out, &m, Format::Abaqus, &[]).unwrap();
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.contains("*ELEMENT, TYPE=R3D3\n20, 1, 3, 2"), "{written}");
    assert!(written.contains("*ELEMENT, TYPE=T3D2\n30, 1, 4"), "{written}");
    let back = io::read(&out).unwrap();
    assert_eq!(back.lower, m.lower);
    assert_eq!(back.data.element_sets, m.data.element_sets);
}

/// A part instanced once in an assembly with a reference point of its own,
/// the part's nodes in an included file
/// (which includes another, relative to itself), sets at assembly level.
#[test]
fn parts_instances_and_includes_read_as_one_mesh() {
    let dir = tempfile::tempdir().unwrap();
    put(
        dir.path(),
        "mesh/nodes.inp",
        "1, 0., 0., 0.\n2, 1., 0., 0.\n*INCLUDE, INPUT=more.inp\n",
    );
    put(
        dir.path(),
        "mesh/more.inp",
        "** the rest of the nodes\n3, 0., 1., 0.\n4, 0., 0., 1.\n",
    );
    let main = put(
        dir.path(),
        "model.inp",
        "*Heading
*Part, name=Beam
*Node
*Include, input=mesh/nodes.inp
*Element, type=C3D4
1, 1, 2, 3, 4
*Nset, nset=Base
 1, 2, 3
*End Part
*Assembly, name=Assembly
*Instance, name=Beam-1, part=Beam
*End Instance
*Node
1, 5., 5., 5.
*Nset, nset=RP
1,
*Nset, nset=Tip, instance=Beam-1
 4,
*Elset, elset=Everything, instance=Beam-1
 Beam-1.Base,
*End Assembly
",
    )
    .to_path_buf();
    // an element set cannot hold node sets: the name is looked up among element sets
    let e = io::read(&main).unwrap_err().to_string();
    assert!(
        e.contains("model.inp") && e.contains("line 20") && e.contains("Beam-1.Base"),
        "{e}"
    );
    let text = std::fs::read_to_string(&main).unwrap().replace(" Beam-1.Base,", " 1,");
    std::fs::write(&main, text).unwrap();
    let m = io::read(&main).unwrap();
    assert_eq!((m.num_points(), m.num_elements()), (4, 1));
    assert_eq!(m.points[3], [0.0, 0.0, 1.0]);
    assert_eq!(nset(&m, "Base"), vec![1, 2, 3]);
    assert_eq!(nset(&m, "Tip"), vec![4]);
    assert_eq!(elset(&m, "Everything"), vec![1]);
    // the assembly's reference point is not a node of the mesh
    assert!(m.data.node_sets.iter().all(|s| s.name != "RP"));
}

/// `.inp` to `.inp` and to `.vtu` and back keeps the nodes (numbers and
/// coordinates), the elements (numbers, types, corners) and the sets.
#[test]
fn round_trips_through_inp_and_vtu_keep_nodes_elements_and_sets() {
    let dir = tempfile::tempdir().unwrap();
    let m = io::read(put(dir.path(), "two.inp", TWO_HEXES)).unwrap();
    let inp = dir.path().join("again.inp");
    io::write(&inp, &m, Format::Abaqus, &[]).unwrap();
    let back = io::read(&inp).unwrap();
    check_two_hexes(&back);
    assert_eq!(back.data.node_sets, m.data.node_sets);
    for format in [Format::VtuAscii, Format::VtuZlib, Format::VtkBinary] {
        let out = dir.path().join(format!(
            "two-{format}.{}",
            if format == Format::VtkBinary { "vtk" } else { "vtu" }
        ));
        io::write(&out, &m, format, &[]).unwrap();
        let v = io::read(&out).unwrap();
        assert_eq!(
            (&v.points, &v.conn, &v.kinds),
            (&m.points, &m.conn, &m.kinds),
            "{format}"
        );
        assert_eq!(v.data.node_sets, m.data.node_sets, "{format}");
        assert_eq!(v.data.element_sets, m.data.element_sets, "{format}");
        // and from there back to .inp with the file's numbers and types
        let inp = dir.path().join(format!("from-{format}.inp"));
        io::write(&inp, &v, Format::Abaqus, &[]).unwrap();
        check_two_hexes(&io::read(&inp).unwrap());
    }
}

/// A mesh from another format is numbered from 1, takes each kind's common
/// type and its Gmsh groups as element sets.
#[test]
fn other_meshes_write_with_default_numbers_types_and_groups() {
    let mut m = meshsmooth::generate::quad_grid(2, 1, [2.0, 1.0]);
    m.data.cell.push(DataArray::new(
        meshsmooth::mesh::data::GMSH_PHYSICAL,
        meshsmooth::mesh::ValueType::I32,
        1,
        Values::Int(vec![4, 9]),
    ));
    m.data.physical_names.push(meshsmooth::mesh::PhysicalName {
        dim: 2,
        tag: 4,
        name: "left plate".into(),
    });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("grid.inp");
    io::write(&out, &m, Format::Abaqus, &[]).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("*NODE\n1, 0.0, 0.0\n"), "{text}");
    assert!(text.contains("*ELEMENT, TYPE=CPS4\n1, "), "{text}");
    assert!(
        text.contains("*ELSET, ELSET=left_plate\n1\n*ELSET, ELSET=PHYSICAL9\n2\n"),
        "{text}"
    );
    let back = io::read(&out).unwrap();
    assert_eq!((&back.points, &back.conn), (&m.points, &m.conn));
    assert_eq!(elset(&back, "left_plate"), vec![1]);
}

/// Through the CLI: `--fix-group` on a node set and on an element set
/// keeps their vertices where they were; other vertices move.
#[test]
fn smooth_fixes_the_vertices_of_a_named_node_or_element_set() {
    let dir = tempfile::tempdir().unwrap();
    let inp = dir.path().join("box.inp");
    crate::common::cli::generate_box(&inp, [4, 4, 4], "random:0.3", 7);
    let m = io::read(&inp).unwrap();
    let skin = meshsmooth::mesh::topology::skin_vertices(&m);
    let interior: Vec<usize> = (0..m.num_points()).filter(|&v| !skin[v]).collect();
    assert!(interior.len() >= 20);
    // a node set of 5 interior vertices; an element set of the elements of another
    let pinned: Vec<usize> = interior[..5].to_vec();
    let ids = node_ids(&m);
    let of_elem = (0..m.num_elements())
        .find(|&e| {
            m.element(e)
                .iter()
                .all(|&v| !skin[v as usize] && !pinned.contains(&(v as usize)))
        })
        .expect("an element of interior vertices");
    let mut body = std::fs::read_to_string(&inp).unwrap();
    let list: Vec<String> = pinned.iter().map(|&v| ids[v].to_string()).collect();
    body.push_str(&format!("*NSET, NSET=Pin\n{}\n", list.join(", ")));
    body.push_str(&format!("*ELSET, ELSET=Core\n{}\n", element_ids(&m)[of_elem]));
    std::fs::write(&inp, body).unwrap();
    for (group, held) in [
        ("Pin", pinned.clone()),
        ("Core", m.element(of_elem).iter().map(|&v| v as usize).collect()),
    ] {
        let out = dir.path().join(format!("out-{group}.inp"));
        let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out), "--fix-group", group, "-q"]);
        assert!(o.status.success(), "{group}: {}", text(&o));
        let after = io::read(&out).unwrap();
        assert_eq!(node_ids(&after), ids);
        for &v in &held {
            assert_eq!(after.points[v], m.points[v], "{group}: vertex {v} moved");
        }
        let moved = interior.iter().filter(|&&v| after.points[v] != m.points[v]).count();
        assert!(moved > interior.len() / 2, "{group}: only {moved} vertices moved");
        assert_eq!(after.data.node_sets, io::read(&inp).unwrap().data.node_sets);
    }
    // a node set fixes nothing unless named
    let out = dir.path().join("out.inp");
    let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out), "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let after = io::read(&out).unwrap();
    assert!(pinned.iter().any(|&v| after.points[v] != m.points[v]));
    let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out), "--fix-group", "Nowhere"]);
    let t = text(&o);
    assert!(
        !o.status.success() && t.contains("Pin (node set)") && t.contains("Core (element set)"),
        "{t}"
    );
}

/// `--free-group` on a node set releases the vertices lower cells fixed.
#[test]
fn a_freed_node_set_releases_what_lower_cells_fixed() {
    let text = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n\
                *ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*ELEMENT, TYPE=S3\n2, 1, 2, 3\n\
                *NSET, NSET=loose\n2\n";
    let dir = tempfile::tempdir().unwrap();
    let mut m = io::read(put(dir.path(), "t.inp", text)).unwrap();
    assert!(m.is_fixed(1));
    let rules = meshsmooth::mesh::fixing::FixRules {
        free_groups: vec!["LOOSE".into()],
        ..Default::default()
    };
    let report = rules.apply(&mut m).unwrap();
    assert_eq!(report[0].vertices, 1);
    assert_eq!((0..4).filter(|&v| m.is_fixed(v)).collect::<Vec<_>>(), vec![0, 2]);
}

fn expect_err(dir: &Path, name: &str, content: &str, needles: &[&str]) {
    let p = put(dir, name, content);
    let e = io::read(&p).unwrap_err().to_string();
    assert!(e.contains(name), "{name}: the error does not name the file: {e}");
    for n in needles {
        assert!(e.contains(n), "{name}: the error lacks '{n}': {e}");
    }
}

#[test]
fn bad_files_are_refused_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let nodes = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n";
    let with = |tail: &str| format!("{nodes}{tail}");
    expect_err(
        d,
        "unknown.inp",
        &with("*ELEMENT, TYPE=SPRINGA\n1, 1, 2\n"),
        &["line 6", "SPRINGA", "not supported"],
    );
    expect_err(
        d,
        "quadratic.inp",
        &with("*ELEMENT, TYPE=C3D10\n1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10\n"),
        &["line 6", "C3D10", "quadratic"],
    );
    expect_err(
        d,
        "pyramid.inp",
        &with("*ELEMENT, TYPE=C3D5\n"),
        &["line 6", "C3D5", "pyramid"],
    );
    expect_err(
        d,
        "missing.inp",
        &with("*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 9\n"),
        &["line 7", "node 9"],
    );
    expect_err(
        d,
        "word.inp",
        "*NODE\n1, 0, 0, 0\n2, 1.0, abc, 0\n",
        &["line 3", "'abc' is not a coordinate"],
    );
    expect_err(
        d,
        "badid.inp",
        &with("*ELEMENT, TYPE=C3D4\n1, 1, 2, x3, 4\n"),
        &["line 7", "'x3' is not a node number"],
    );
    expect_err(
        d,
        "truncated.inp",
        &with("*ELEMENT, TYPE=C3D4\n1, 1, 2, 3"),
        &["line 7", "element 1 of type C3D4 lists 3 nodes; the type has 4"],
    );
    expect_err(
        d,
        "notype.inp",
        &with("*ELEMENT\n1, 1, 2, 3, 4\n"),
        &["line 6", "TYPE="],
    );
    expect_err(
        d,
        "twice.inp",
        &with("*NODE\n2, 5, 5, 5\n"),
        &["line 7", "node 2 is defined twice"],
    );
    expect_err(
        d,
        "noset.inp",
        &with("*NSET, NSET=A\nB\n"),
        &["line 7", "'B' is neither a node number nor a node set"],
    );
    expect_err(
        d,
        "range.inp",
        &with("*NSET, NSET=A, GENERATE\n1, 1000000000000, 1\n"),
        &["line 7", "covers 1000000000000 nodes; the file defines 4"],
    );
    expect_err(
        d,
        "gap.inp",
        "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n4, 0, 1, 0\n5, 0, 0, 1\n*NSET, NSET=G, GENERATE\n1, 4\n",
        &["line 7", "set 'G' refers to node 3, which is not defined"],
    );
    expect_err(
        d,
        "moved.inp",
        &with("*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*ASSEMBLY, NAME=A\n*INSTANCE, NAME=I, PART=P\n1., 0., 0.\n"),
        &["line 10", "translated or rotated"],
    );
    expect_err(
        d,
        "two.inp",
        "*PART, NAME=P\n*END PART\n*PART, NAME=Q\n",
        &["line 3", "a second part ('Q' after 'P')"],
    );
    expect_err(d, "nonodes.inp", "*HEADING\nnothing\n", &["no *NODE"]);
    // includes: a cycle, a missing file, and an error inside an included file
    put(d, "a.inp", "*INCLUDE, INPUT=b.inp\n");
    put(d, "b.inp", "*NODE\n1, 0, 0, 0\n*INCLUDE, INPUT=a.inp\n");
    expect_err(
        d,
        "top.inp",
        "*INCLUDE, INPUT=a.inp\n",
        &["b.inp: line 3", "*INCLUDE cycle", "a.inp includes"],
    );
    expect_err(
        d,
        "lost.inp",
        "*INCLUDE, INPUT=nowhere.inp\n",
        &["line 1", "nowhere.inp: no such file"],
    );
    put(d, "bad-nodes.inp", "1, 0, 0, 0\n2, 0, zero, 0\n");
    let p = put(d, "outer.inp", "*NODE\n*INCLUDE, INPUT=bad-nodes.inp\n");
    let e = io::read(&p).unwrap_err().to_string();
    assert!(e.contains("bad-nodes.inp: line 2") && e.contains("zero"), "{e}");
}

/// meshio 5.3 reads the `.inp` meshsmooth writes with the same points,
/// cells and sets, and meshsmooth reads the `.inp` meshio writes. Gmsh
/// 4.8 writes `.inp` but does not read it, so it has no such test.
#[test]
fn meshio_reads_our_inp_and_we_read_meshios() {
    let Some(python) = crate::interop::meshio_python() else {
        eprintln!("skipped: no Python with meshio (set MESHSMOOTH_PYTHON)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let m = io::read(put(dir.path(), "two.inp", TWO_HEXES)).unwrap();
    let ours = dir.path().join("ours.inp");
    io::write(&ours, &m, Format::Abaqus, &[]).unwrap();
    let theirs = dir.path().join("theirs.inp");
    let script = "import sys, json, meshio\n\
                  m = meshio.read(sys.argv[1])\n\
                  meshio.write(sys.argv[2], m)\n\
                  print(json.dumps({'points': m.points.tolist(), \
                  'cells': [[c.type, c.data.tolist()] for c in m.cells], \
                  'point_sets': {k: sorted(v.tolist()) for k, v in m.point_sets.items()}}))";
    let o = Command::new(&python)
        .args(["-c", script])
        .arg(&ours)
        .arg(&theirs)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let points: Vec<[f64; 3]> = serde_json::from_value(got["points"].clone()).unwrap();
    assert_eq!(points, m.points);
    let cells: Vec<(String, Vec<Vec<u32>>)> = serde_json::from_value(got["cells"].clone()).unwrap();
    let conn: Vec<u32> = cells.iter().flat_map(|(_, c)| c.iter().flatten().copied()).collect();
    assert!(cells.iter().all(|(t, _)| t == "hexahedron"), "{cells:?}");
    assert_eq!(conn, m.conn);
    // meshio numbers points from 0 in file order: our vertex ids
    let bottom: Vec<u32> = serde_json::from_value(got["point_sets"]["BOTTOM"].clone()).unwrap();
    let want = &m.data.node_sets.iter().find(|s| s.name == "BOTTOM").unwrap().vertices;
    let mut want = want.clone();
    want.sort_unstable();
    assert_eq!(&bottom, &want);
    let back = io::read(&theirs).unwrap();
    assert_eq!((&back.points, &back.conn, &back.kinds), (&m.points, &m.conn, &m.kinds));
    let mut got = back
        .data
        .node_sets
        .iter()
        .find(|s| s.name == "BOTTOM")
        .unwrap()
        .vertices
        .clone();
    got.sort_unstable();
    assert_eq!(got, want);
}

/// Every prefix of a valid file with sets and an include, and many mutants
/// (bytes changed, numbers made huge, the include pointed back at the file)
/// read within a small budget to a mesh or to an error naming a file:
/// never a panic, never slowly.
#[test]
fn prefixes_and_mutants_read_or_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let limits = io::ReadLimits { max_bytes: 64 << 20 };
    let base = TWO_HEXES.replace("*Nset, nset=BOTTOM", "*INCLUDE, INPUT=part.inp\n*Nset, nset=BOTTOM");
    put(dir.path(), "part.inp", "*ELSET, ELSET=MORE, GENERATE\n3, 7, 4\n");
    let p = dir.path().join("fuzz.inp");
    let check = |bytes: &[u8], what: &str| {
        std::fs::write(&p, bytes).unwrap();
        let start = std::time::Instant::now();
        if let Err(e) = io::read_with_limits(&p, &limits) {
            let e = e.to_string();
            assert!(e.contains("fuzz.inp") || e.contains("part.inp"), "{what}: {e}");
        }
        assert!(start.elapsed().as_secs_f64() < 2.0, "{what}: slow");
    };
    let bytes = base.as_bytes();
    for cut in 0..bytes.len() {
        check(&bytes[..cut], &format!("cut at {cut}"));
    }
    let mut rand = common::xorshift(0x9e37_79b9_7f4a_7c15u64);
    for k in 0..400 {
        let mut b = bytes.to_vec();
        let i = rand() as usize % b.len();
        match k % 5 {
            0 => b[i] = rand() as u8,
            1 => b[i] = b',',
            2 => b[i] = b'\n',
            3 => {
                // a number made huge
                b.splice(i..i, *b"99999999999999999999");
            }
            _ => {
                let text = base.replacen("part.inp", "fuzz.inp", 1);
                b = text.into_bytes();
                let at = i % b.len();
                b[at] = rand() as u8;
            }
        }
        check(&b, &format!("mutant {k} at byte {i}"));
    }
}
