//! OpenFOAM polyMesh cases: hand-made cases (a perturbed hexahedral box
//! with walls, an inlet and an outlet; a cell of each kind around a
//! pentagonal prism) written here by a writer of the tests' own in every
//! encoding, read, smoothed by the CLI and written back with only the
//! points changed; VTK's vtkOpenFOAMReader reads the output; broken and
//! mutated cases end in errors that name the file.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use meshsmooth::ElementKind;
use meshsmooth::io::{self, Format, ReadLimits};
use meshsmooth::mesh::Mesh;

use crate::common;
use crate::common::cli::{meshsmooth, s, text};

/// How a case's files are encoded.
#[derive(Clone, Copy, Debug, Default)]
pub struct Style {
    pub binary: bool,
    pub gz: bool,
    pub compact: bool,
    pub label64: bool,
    pub scalar32: bool,
}

pub const STYLES: [Style; 6] = [
    Style {
        binary: false,
        gz: false,
        compact: false,
        label64: false,
        scalar32: false,
    },
    Style {
        binary: false,
        gz: false,
        compact: true,
        label64: false,
        scalar32: false,
    },
    Style {
        binary: false,
        gz: true,
        compact: false,
        label64: false,
        scalar32: false,
    },
    Style {
        binary: true,
        gz: false,
        compact: true,
        label64: false,
        scalar32: false,
    },
    Style {
        binary: true,
        gz: true,
        compact: true,
        label64: false,
        scalar32: false,
    },
    Style {
        binary: true,
        gz: false,
        compact: false,
        label64: true,
        scalar32: true,
    },
];

/// A case before it is written: points, and each cell as its faces turned
/// outward; a boundary face's patch is chosen from its centroid.
pub struct Case {
    pub points: Vec<[f64; 3]>,
    pub cells: Vec<Vec<Vec<u32>>>,
    /// Patch names and types, in file order.
    pub patches: Vec<(&'static str, &'static str)>,
    pub patch_of: fn([f64; 3]) -> usize,
}

/// What [`Case::write`] made: the polyMesh in OpenFOAM's order.
pub struct Faces {
    pub faces: Vec<Vec<u32>>,
    pub owner: Vec<u32>,
    pub neighbour: Vec<u32>,
    /// Per patch, (start, count).
    pub ranges: Vec<(usize, usize)>,
}

fn key(f: &[u32]) -> Vec<u32> {
    let mut k = f.to_vec();
    k.sort_unstable();
    k
}

impl Case {
    /// Faces in OpenFOAM's order: internal ones by owner then neighbour,
    /// then the boundary faces patch by patch.
    pub fn faces(&self) -> Faces {
        let mut seen: HashMap<Vec<u32>, usize> = HashMap::new();
        let mut all: Vec<(Vec<u32>, u32, Option<u32>)> = Vec::new();
        for (c, cell) in self.cells.iter().enumerate() {
            for f in cell {
                match seen.get(&key(f)) {
                    Some(&i) => all[i].2 = Some(c as u32),
                    None => {
                        seen.insert(key(f), all.len());
                        all.push((f.clone(), c as u32, None));
                    }
                }
            }
        }
        let mut internal: Vec<&(Vec<u32>, u32, Option<u32>)> = all.iter().filter(|f| f.2.is_some()).collect();
        internal.sort_by_key(|f| (f.1, f.2));
        let mut out = Faces {
            faces: internal.iter().map(|f| f.0.clone()).collect(),
            owner: internal.iter().map(|f| f.1).collect(),
            neighbour: internal.iter().map(|f| f.2.unwrap()).collect(),
            ranges: Vec::new(),
        };
        for p in 0..self.patches.len() {
            let start = out.faces.len();
            for f in all.iter().filter(|f| f.2.is_none()) {
                let mut c = [0.0; 3];
                for &v in &f.0 {
                    for i in 0..3 {
                        c[i] += self.points[v as usize][i] / f.0.len() as f64;
                    }
                }
                if (self.patch_of)(c) == p {
                    out.faces.push(f.0.clone());
                    out.owner.push(f.1);
                }
            }
            out.ranges.push((start, out.faces.len() - start));
        }
        out
    }

    /// Writes `CASE/constant/polyMesh` (and `CASE/case.foam`) in `style`,
    /// with a cell zone, a face zone and a point zone.
    pub fn write(&self, case: &Path, style: Style) -> Faces {
        let dir = case.join("constant/polyMesh");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(case.join("case.foam"), "").unwrap();
        let f = self.faces();
        let put = |name: &str, class: &str, body: &[u8]| {
            let mut text = format!(
                "/*--------------------------------*- C++ -*----------------------------------*\\\n\
                 | hand-made                                                                   |\n\
                 \\*---------------------------------------------------------------------------*/\n\
                 FoamFile\n{{\n    version 2.0;\n    format {};\n    arch \"LSB;label={};scalar={}\";\n    \
                 class {class};\n    location \"constant/polyMesh\";\n    object {name};\n}}\n\
                 // * * * //\n\n",
                if style.binary { "binary" } else { "ascii" },
                if style.label64 { 64 } else { 32 },
                if style.scalar32 { 32 } else { 64 },
            )
            .into_bytes();
            text.extend_from_slice(body);
            text.extend_from_slice(
                b"\n\n// ************************************************************************* //\n",
            );
            if style.gz {
                let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
                z.write_all(&text).unwrap();
                std::fs::write(dir.join(format!("{name}.gz")), z.finish().unwrap()).unwrap();
            } else {
                std::fs::write(dir.join(name), text).unwrap();
            }
        };
        let labels = |ls: &[u32]| -> Vec<u8> {
            let mut b = format!("{}\n(", ls.len()).into_bytes();
            if style.binary {
                for &l in ls {
                    if style.label64 {
                        b.extend_from_slice(&u64::from(l).to_le_bytes());
                    } else {
                        b.extend_from_slice(&l.to_le_bytes());
                    }
                }
            } else {
                b.push(b'\n');
                for l in ls {
                    b.extend_from_slice(format!("{l}\n").as_bytes());
                }
            }
            b.extend_from_slice(b")\n");
            b
        };
        let mut points = format!("{}\n(", self.points.len()).into_bytes();
        if style.binary {
            for c in self.points.iter().flatten() {
                if style.scalar32 {
                    points.extend_from_slice(&(*c as f32).to_le_bytes());
                } else {
                    points.extend_from_slice(&c.to_le_bytes());
                }
            }
        } else {
            points.push(b'\n');
            for p in &self.points {
                points.extend_from_slice(format!("({:?} {:?} {:?})\n", p[0], p[1], p[2]).as_bytes());
            }
        }
        points.extend_from_slice(b")\n");
        put("points", "vectorField", &points);
        if style.compact {
            let mut offsets = vec![0u32];
            let mut flat = Vec::new();
            for face in &f.faces {
                flat.extend_from_slice(face);
                offsets.push(flat.len() as u32);
            }
            let mut body = labels(&offsets);
            body.push(b'\n');
            body.extend(labels(&flat));
            put("faces", "faceCompactList", &body);
        } else {
            let mut body = format!("{}\n(\n", f.faces.len()).into_bytes();
            for face in &f.faces {
                if style.binary {
                    let mut l = labels(face);
                    l.pop();
                    body.extend(l);
                    body.push(b'\n');
                } else {
                    let vs: Vec<String> = face.iter().map(u32::to_string).collect();
                    body.extend_from_slice(format!("{}({})\n", face.len(), vs.join(" ")).as_bytes());
                }
            }
            body.extend_from_slice(b")\n");
            put("faces", "faceList", &body);
        }
        put("owner", "labelList", &labels(&f.owner));
        put("neighbour", "labelList", &labels(&f.neighbour));
        let mut boundary = format!("{}\n(\n", self.patches.len());
        for ((name, ty), (start, count)) in self.patches.iter().zip(&f.ranges) {
            boundary.push_str(&format!(
                "    {name}\n    {{\n        type            {ty};\n        inGroups        List<word> 1({ty});\n        \
                 nFaces          {count};\n        startFace       {start};\n    }}\n"
            ));
        }
        boundary.push_str(")\n");
        put("boundary", "polyBoundaryMesh", boundary.as_bytes());
        let zone = |kind: &str, key: &str, name: &str, ids: &[u32], flip: bool| -> Vec<u8> {
            let mut b = format!("1\n(\n{name}\n{{\n    type {kind};\n    {key} List<label> ").into_bytes();
            let mut l = labels(ids);
            l.pop();
            b.extend(l);
            b.extend_from_slice(b";\n");
            if flip {
                b.extend_from_slice(format!("    flipMap List<bool> {}(", ids.len()).as_bytes());
                if style.binary {
                    b.extend(std::iter::repeat_n(0u8, ids.len()));
                } else {
                    b.extend_from_slice(vec!["0"; ids.len()].join(" ").as_bytes());
                }
                b.extend_from_slice(b");\n");
            }
            b.extend_from_slice(b"}\n)\n");
            b
        };
        put(
            "cellZones",
            "regIOobject",
            &zone("cellZone", "cellLabels", "core", &[0, 2], false),
        );
        put(
            "faceZones",
            "regIOobject",
            &zone("faceZone", "faceLabels", "baffle", &[0], true),
        );
        put(
            "pointZones",
            "regIOobject",
            &zone("pointZone", "pointLabels", "corner", &[0], false),
        );
        f
    }
}

/// Outward faces of a VTK-ordered element.
pub fn outward(kind: ElementKind, vs: &[u32]) -> Vec<Vec<u32>> {
    let table: &[&[usize]] = match kind {
        ElementKind::Tetrahedron => &[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]],
        ElementKind::Hexahedron => &[
            &[0, 3, 2, 1],
            &[4, 5, 6, 7],
            &[0, 1, 5, 4],
            &[1, 2, 6, 5],
            &[2, 3, 7, 6],
            &[3, 0, 4, 7],
        ],
        ElementKind::Prism => &[&[0, 2, 1], &[3, 4, 5], &[0, 1, 4, 3], &[1, 2, 5, 4], &[2, 0, 3, 5]],
        k => panic!("{k:?}"),
    };
    table.iter().map(|f| f.iter().map(|&i| vs[i]).collect()).collect()
}

/// An n x n x n box of unit hexahedra, its interior points moved by up to
/// 0.3 of an edge: walls on y and z, an inlet at x = 0, an outlet at x = n.
pub fn hex_box(n: usize, seed: u64) -> Case {
    let mut m = meshsmooth::generate::hex_box(n, n, n, [n as f64; 3]);
    let mut rand = common::xorshift(seed);
    let nf = n as f64;
    for p in &mut m.points {
        if p.iter().all(|&c| c > 0.0 && c < nf) {
            for c in p.iter_mut() {
                *c += ((rand() % 2001) as f64 / 1000.0 - 1.0) * 0.3;
            }
        }
    }
    let cells = (0..m.num_elements())
        .map(|e| outward(m.kinds[e], m.element(e)))
        .collect();
    Case {
        points: m.points,
        cells,
        patches: vec![("walls", "wall"), ("inlet", "patch"), ("outlet", "patch")],
        patch_of: |c| {
            if c[0].abs() < 1e-9 {
                1
            } else if (c[0] - 4.0).abs() < 1e-9 {
                2
            } else {
                0
            }
        },
    }
}

/// One cell of each kind: a pentagonal prism (a polyhedron), a hexahedron
/// on one of its sides, a triangular prism on another, a tetrahedron on
/// the prism's top; the floor is a wall.
pub fn mixed() -> Case {
    use std::f64::consts::PI;
    let mut points = Vec::new();
    for z in [0.0, 1.0] {
        for k in 0..5 {
            let a = 2.0 * PI * k as f64 / 5.0;
            points.push([a.cos(), a.sin(), z]);
        }
    }
    let out = |k: usize, d: f64| {
        let a = 2.0 * PI * (k as f64 + 0.5) / 5.0;
        [d * a.cos(), d * a.sin()]
    };
    // the hexahedron beside side 0 (points 0, 1)
    let d = out(0, 0.8);
    for z in [0.0, 1.0] {
        for k in [0, 1] {
            let p: [f64; 3] = points[k];
            points.push([p[0] + d[0], p[1] + d[1], z]);
        }
    }
    // the prism's apex beside side 2 (points 2, 3)
    let q = out(2, 0.81 + 0.7);
    points.push([q[0], q[1], 0.0]);
    points.push([q[0], q[1], 1.0]);
    // the tetrahedron's apex above the prism's top (7, 15, 8)
    let t: [f64; 3] = std::array::from_fn(|i| (points[7][i] + points[15][i] + points[8][i]) / 3.0);
    points.push([t[0], t[1], 1.8]);
    let mut pent = vec![vec![4, 3, 2, 1, 0], vec![5, 6, 7, 8, 9]];
    for k in 0..5u32 {
        let j = (k + 1) % 5;
        pent.push(vec![k, j, j + 5, k + 5]);
    }
    let cells = vec![
        pent,
        outward(ElementKind::Hexahedron, &[0, 10, 11, 1, 5, 12, 13, 6]),
        outward(ElementKind::Prism, &[2, 14, 3, 7, 15, 8]),
        outward(ElementKind::Tetrahedron, &[7, 15, 8, 16]),
    ];
    Case {
        points,
        cells,
        patches: vec![("floor", "wall"), ("rest", "patch")],
        patch_of: |c| usize::from(c[2] > 1e-9),
    }
}

fn limits() -> ReadLimits {
    ReadLimits { max_bytes: 64 << 20 }
}

/// The points on faces of patch `p`.
fn patch_points(f: &Faces, p: usize) -> Vec<usize> {
    let (start, count) = f.ranges[p];
    let mut vs: Vec<usize> = f.faces[start..start + count]
        .iter()
        .flatten()
        .map(|&v| v as usize)
        .collect();
    vs.sort_unstable();
    vs.dedup();
    vs
}

#[test]
fn hand_made_cases_read_in_every_encoding() {
    let dir = tempfile::tempdir().unwrap();
    for (name, case) in [("box", hex_box(4, 7)), ("mixed", mixed())] {
        let mut first: Option<Mesh> = None;
        for (k, style) in STYLES.iter().enumerate() {
            let ctx = format!("{name} {style:?}");
            let path = dir.path().join(format!("{name}{k}"));
            let f = case.write(&path, *style);
            // the case folder, its polyMesh folder and its marker name the same mesh
            let m = io::read_with_limits(&path, &limits()).unwrap_or_else(|e| panic!("{ctx}: {e}"));
            for other in [path.join("constant/polyMesh"), path.join("case.foam")] {
                let o = io::read(&other).unwrap_or_else(|e| panic!("{ctx}: {e}"));
                assert_eq!((&o.points, &o.conn), (&m.points, &m.conn), "{ctx}");
            }
            assert_eq!(m.num_points(), case.points.len(), "{ctx}");
            assert_eq!(m.num_elements(), case.cells.len(), "{ctx}");
            if name == "mixed" {
                use ElementKind::*;
                assert_eq!(m.kinds, vec![Polyhedron, Hexahedron, Prism, Tetrahedron], "{ctx}");
                assert_eq!(key(m.element(1)), key(&[0, 10, 11, 1, 5, 12, 13, 6]), "{ctx}");
                assert_eq!(m.faces.of(0).count(), 7, "{ctx}");
                // the pentagons became 3 triangles each: 9 on the pentagonal
                // prism, 5 on the hexahedron, 3 each on the prism and tetrahedron
                assert_eq!(m.lower.len(), 9 + 5 + 3 + 3, "{ctx}");
            } else {
                assert!(m.kinds.iter().all(|&k| k == ElementKind::Hexahedron), "{ctx}");
                assert_eq!(m.lower.len(), 6 * 16, "{ctx}");
            }
            let bad = meshsmooth::metric::inverted_elements(&m, &m.points);
            assert!(bad.is_empty(), "{ctx}: inverted {bad:?}");
            let names: Vec<&str> = m.data.physical_names.iter().map(|p| p.name.as_str()).collect();
            let want: Vec<&str> = case.patches.iter().map(|p| p.0).collect();
            assert_eq!(names, want, "{ctx}");
            // every boundary point is fixed, no other
            let boundary: Vec<usize> = (0..case.patches.len()).flat_map(|p| patch_points(&f, p)).collect();
            for v in 0..m.num_points() {
                assert_eq!(m.is_fixed(v), boundary.contains(&v), "{ctx}: point {v}");
            }
            let set = |n: &str| {
                m.data
                    .element_sets
                    .iter()
                    .find(|s| s.name == n)
                    .map(|s| s.elements.clone())
            };
            assert_eq!(set("core"), Some(vec![0, 2]), "{ctx}");
            let nodes = |n: &str| {
                m.data
                    .node_sets
                    .iter()
                    .find(|s| s.name == n)
                    .map(|s| s.vertices.clone())
            };
            assert_eq!(nodes("corner"), Some(vec![0]), "{ctx}");
            assert_eq!(nodes("baffle"), Some(key(&f.faces[0])), "{ctx}");
            let poly = m.data.polymesh.as_ref().unwrap();
            assert_eq!((&poly.owner, &poly.neighbour), (&f.owner, &f.neighbour), "{ctx}");
            assert_eq!(poly.style.binary, style.binary, "{ctx}");
            assert_eq!(poly.style.compressed, style.gz, "{ctx}");
            assert_eq!(poly.style.label64, style.label64, "{ctx}");
            match &first {
                None => first = Some(m),
                Some(a) => {
                    assert_eq!((&a.kinds, &a.conn, &a.lower), (&m.kinds, &m.conn, &m.lower), "{ctx}");
                    let tol = if style.scalar32 { 1e-6 } else { 0.0 };
                    assert!(common::max_abs_diff(&a.points, &m.points) <= tol, "{ctx}");
                }
            }
        }
    }
}

/// Whether `v`'s coordinates are bit for bit `w`'s.
fn same(v: &[f64; 3], w: &[f64; 3]) -> bool {
    common::bits(v) == common::bits(w)
}

#[test]
fn smooth_writes_the_case_back_with_only_the_points_changed() {
    let dir = tempfile::tempdir().unwrap();
    let case = hex_box(4, 3);
    for (k, style) in [STYLES[0], STYLES[4], STYLES[5]].into_iter().enumerate() {
        let ctx = format!("{style:?}");
        let input = dir.path().join(format!("in{k}"));
        let f = case.write(&input, style);
        // a file the writer does not make is copied
        std::fs::create_dir(input.join("constant/polyMesh/sets")).unwrap();
        std::fs::write(input.join("constant/polyMesh/sets/mine"), "kept\n").unwrap();
        let before = io::read(&input).unwrap();
        let out = dir.path().join(format!("out{k}"));
        let o = meshsmooth(&["smooth", s(&input.join("case.foam")), "-o", s(&out), "--quiet"]);
        assert!(o.status.success(), "{ctx}: {}", text(&o));
        let poly_out = out.join("constant/polyMesh");
        let gz = if style.gz { ".gz" } else { "" };
        for name in ["points", "faces", "owner", "neighbour", "boundary", "cellZones"] {
            assert!(poly_out.join(format!("{name}{gz}")).is_file(), "{ctx}: {name}{gz}");
        }
        assert_eq!(std::fs::read_to_string(poly_out.join("sets/mine")).unwrap(), "kept\n");
        // boundary and zones byte for byte
        for name in ["boundary", "cellZones", "faceZones", "pointZones"] {
            let file = format!("{name}{gz}");
            let a = std::fs::read(input.join("constant/polyMesh").join(&file)).unwrap();
            let b = std::fs::read(poly_out.join(&file)).unwrap();
            if !style.gz {
                assert!(a == b, "{ctx}: {file} changed");
            }
        }
        let after = io::read(&out).unwrap_or_else(|e| panic!("{ctx}: {e}"));
        let (p, q) = (
            before.data.polymesh.as_ref().unwrap(),
            after.data.polymesh.as_ref().unwrap(),
        );
        assert_eq!(
            (&p.face_offsets, &p.face_points),
            (&q.face_offsets, &q.face_points),
            "{ctx}"
        );
        assert_eq!(
            (&p.owner, &p.neighbour, &p.patches),
            (&q.owner, &q.neighbour, &q.patches),
            "{ctx}"
        );
        assert_eq!(q.style.binary, style.binary, "{ctx}: the input's encoding");
        assert_eq!(q.style.compressed, style.gz, "{ctx}");
        assert_eq!(q.style.label64, style.label64, "{ctx}");
        assert_eq!(q.style.scalar32, style.scalar32, "{ctx}");
        assert_eq!((&after.kinds, &after.conn), (&before.kinds, &before.conn), "{ctx}");
        // every boundary point stays; the interior moved and got better
        let mut moved = 0;
        for v in 0..before.num_points() {
            if before.is_fixed(v) {
                assert!(
                    same(&after.points[v], &before.points[v]),
                    "{ctx}: boundary point {v} moved"
                );
            } else if !same(&after.points[v], &before.points[v]) {
                moved += 1;
            }
        }
        assert_eq!(moved, 27, "{ctx}: the 3 x 3 x 3 interior points move");
        let q0 = meshsmooth::report::quality_report(&before, &before.points);
        let q1 = meshsmooth::report::quality_report(&after, &after.points);
        assert!(
            q1.eta.max < q0.eta.max && q1.eta.avg < q0.eta.avg,
            "{ctx}: {:?} -> {:?}",
            q0.eta,
            q1.eta
        );
        assert_eq!(f.ranges.len(), q.patches.len());
        // the library reads what it wrote in the output's own style
        assert_eq!(
            Format::of_file(&out),
            Some(if style.binary {
                Format::OpenFoamBinary
            } else {
                Format::OpenFoam
            })
        );
    }
}

#[test]
fn a_sliding_boundary_keeps_the_walls() {
    let dir = tempfile::tempdir().unwrap();
    let case = hex_box(4, 5);
    let input = dir.path().join("in");
    let f = case.write(&input, STYLES[0]);
    let before = io::read(&input).unwrap();
    let out = dir.path().join("out");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--boundary", "slide", "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    let after = io::read(&out).unwrap();
    for v in patch_points(&f, 0) {
        assert!(same(&after.points[v], &before.points[v]), "wall point {v} moved");
    }
    // the inlet's inner points slide within x = 0
    let inlet: Vec<usize> = patch_points(&f, 1)
        .into_iter()
        .filter(|v| !patch_points(&f, 0).contains(v))
        .collect();
    assert_eq!(inlet.len(), 9);
    assert!(inlet.iter().all(|&v| after.points[v][0].abs() < 1e-12));
    assert!(
        inlet.iter().any(|&v| !same(&after.points[v], &before.points[v])),
        "no inlet point slid"
    );
    // naming the walls frees them
    let out2 = dir.path().join("out2");
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out2),
        "--boundary",
        "slide",
        "--free-group",
        "walls",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let freed = io::read(&out2).unwrap();
    let walls = patch_points(&f, 0);
    assert!(
        walls.iter().any(|&v| !same(&freed.points[v], &before.points[v])),
        "no wall point slid"
    );
    // --fix-group by patch name
    let out3 = dir.path().join("out3");
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out3),
        "--boundary",
        "slide",
        "--fix-group",
        "inlet",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let fixed = io::read(&out3).unwrap();
    assert!(inlet.iter().all(|&v| same(&fixed.points[v], &before.points[v])));
}

#[test]
fn the_input_case_is_never_written() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    case_files(&input);
    let listing = || snapshot(&input);
    let was = listing();
    for out in [input.clone(), input.join("case.foam"), input.join("constant/polyMesh")] {
        for inp in [input.clone(), input.join("case.foam")] {
            let o = meshsmooth(&["smooth", s(&inp), "-o", s(&out)]);
            assert_eq!(o.status.code(), Some(1), "{}", text(&o));
            assert!(text(&o).contains("never overwrites its input"), "{}", text(&o));
        }
    }
    // the library refuses too, the mesh knowing where it came from
    let m = io::read(&input).unwrap();
    let e = io::write(&input.join("other.foam"), &m, Format::OpenFoam, &[]).unwrap_err();
    assert!(e.to_string().contains("never overwrites its input"), "{e}");
    assert!(listing() == was, "the input case changed");
}

fn case_files(path: &Path) -> Faces {
    hex_box(4, 9).write(path, STYLES[0])
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn other_meshes_get_faces_built_from_their_cells() {
    let dir = tempfile::tempdir().unwrap();
    // tetrahedra, prisms and hexahedra, with the bottom's faces in a physical group
    let mut m = meshsmooth::generate::mixed_block(2, 2);
    let mut bottom = Vec::new();
    for e in 0..m.num_elements() {
        for f in outward(m.kinds[e], m.element(e)) {
            if f.iter().all(|&v| m.points[v as usize][2] == 0.0) {
                bottom.push(f);
            }
        }
    }
    use meshsmooth::mesh::data::{DataArray, GMSH_PHYSICAL, PhysicalName, ValueType, Values};
    use meshsmooth::mesh::{ElementSet, LowerKind};
    for f in &bottom {
        let kind = if f.len() == 3 {
            LowerKind::Triangle
        } else {
            LowerKind::Quadrilateral
        };
        m.lower.push((kind, f.clone()));
    }
    m.data.cell = vec![DataArray::new(
        GMSH_PHYSICAL,
        ValueType::I32,
        1,
        Values::Int(vec![0; m.num_elements()]),
    )];
    m.data.lower = vec![DataArray::new(
        GMSH_PHYSICAL,
        ValueType::I32,
        1,
        Values::Int(vec![4; bottom.len()]),
    )];
    m.data.physical_names = vec![PhysicalName {
        dim: 2,
        tag: 4,
        name: "bottom".into(),
    }];
    m.data.element_sets.push(ElementSet {
        name: "first".into(),
        elements: vec![0, 1],
        lower: Vec::new(),
    });
    for binary in [false, true] {
        let format = if binary {
            Format::OpenFoamBinary
        } else {
            Format::OpenFoam
        };
        let out = dir.path().join(format!("case-{binary}"));
        io::write(&out, &m, format, &[]).unwrap();
        let got = io::read(&out).unwrap();
        assert_eq!(got.points, m.points);
        assert_eq!(got.kinds, m.kinds);
        for e in 0..m.num_elements() {
            assert_eq!(key(got.element(e)), key(m.element(e)), "element {e}");
        }
        assert!(meshsmooth::metric::inverted_elements(&got, &got.points).is_empty());
        let poly = got.data.polymesh.as_ref().unwrap();
        let names: Vec<(&str, usize)> = poly.patches.iter().map(|p| (p.name.as_str(), p.faces)).collect();
        assert_eq!(names[0], ("bottom", bottom.len()));
        assert_eq!(names[1].0, "defaultFaces");
        // upper-triangular: internal faces by owner, then neighbour
        let pairs: Vec<(u32, u32)> = poly.owner.iter().copied().zip(poly.neighbour.iter().copied()).collect();
        assert!(pairs.windows(2).all(|w| w[0] <= w[1]) && pairs.iter().all(|(o, n)| o < n));
        let first = got.data.element_sets.iter().find(|s| s.name == "first").unwrap();
        assert_eq!(first.elements, vec![0, 1]);
    }
    // polyhedra too
    let v = common::voronoi_box(2, 10.0, 1);
    let out = dir.path().join("voronoi");
    io::write(&out, &v, Format::OpenFoam, &[]).unwrap();
    let got = io::read(&out).unwrap();
    assert_eq!(got.num_elements(), v.num_elements());
    for e in 0..v.num_elements() {
        assert_eq!(key(got.element(e)), key(v.element(e)), "element {e}");
    }
    // a planar mesh is refused, naming why
    let planar = meshsmooth::generate::quad_grid(2, 2, [1.0, 1.0]);
    let e = io::write(&dir.path().join("flat"), &planar, Format::OpenFoam, &[]).unwrap_err();
    assert!(e.to_string().contains("three-dimensional"), "{e}");
    assert!(!dir.path().join("flat").exists());
}

/// A copy of the ASCII box case with `file` edited by `edit`.
fn broken(root: &Path, name: &str, file: &str, edit: impl Fn(&str) -> String) -> PathBuf {
    let case = root.join(name);
    case_files(&case);
    let p = case.join("constant/polyMesh").join(file);
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, edit(&text)).unwrap();
    case
}

#[test]
fn broken_cases_are_refused_with_the_file_and_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(PathBuf, &[&str])> = vec![
        (
            broken(d, "range", "faces", |t| {
                // the first face's last point
                let i = t.find("\n4(").unwrap() + 3;
                let j = i + t[i..].find(')').unwrap();
                let k = i + t[i..j].rfind(' ').unwrap() + 1;
                format!("{}999{}", &t[..k], &t[j..])
            }),
            &["faces", "line", "999", "outside 0..125"],
        ),
        (
            broken(d, "count", "owner", |t| {
                t.replacen("\n(\n0\n", "\n(\n", 1).replacen("\n240\n(", "\n239\n(", 1)
            }),
            &["owner", "239 entries", "240 faces"],
        ),
        (
            broken(d, "open", "owner", |t| {
                // the last boundary face given to another cell: two cells open
                let mut lines: Vec<&str> = t.lines().collect();
                let last = lines.iter().rposition(|l| l.trim().parse::<u32>().is_ok()).unwrap();
                lines[last] = "0";
                lines.join("\n")
            }),
            &["not closed"],
        ),
        (
            broken(d, "patch", "boundary", |t| {
                t.replacen("startFace       144;", "startFace       145;", 1)
            }),
            &["boundary", "line", "'walls' starts at face 145"],
        ),
        (
            broken(d, "word", "points", |t| {
                t.replacen("(0.0 0.0 0.0)", "(0.0 zero 0.0)", 1)
            }),
            &["points", "line 17", "'zero'"],
        ),
        (
            broken(d, "arch", "points", |t| t.replacen("label=32", "label=16", 1)),
            &["points", "line", "label=16"],
        ),
    ];
    for (case, needles) in cases {
        let e = io::read(&case).unwrap_err().to_string();
        for n in needles {
            assert!(e.contains(n), "{}: '{n}' not in: {e}", case.display());
        }
        assert!(e.contains(s(&case)), "{e}");
    }
    let missing = d.join("missing");
    case_files(&missing);
    std::fs::remove_file(missing.join("constant/polyMesh/owner")).unwrap();
    let e = io::read(&missing).unwrap_err().to_string();
    assert!(e.contains("no 'owner' file"), "{e}");
}

/// Every prefix of each file of an ASCII and a binary case, and many
/// mutants (bytes changed, numbers made huge), read within a small budget
/// to a mesh or to an error naming the case: never a panic, never slowly.
#[test]
fn prefixes_and_mutants_read_or_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut rand = common::xorshift(0x9e37_79b9_7f4a_7c15u64);
    for (k, style) in [STYLES[1], STYLES[3], STYLES[4]].into_iter().enumerate() {
        let case = dir.path().join(format!("fuzz{k}"));
        mixed().write(&case, style);
        let poly = case.join("constant/polyMesh");
        let files: Vec<PathBuf> = std::fs::read_dir(&poly).unwrap().map(|e| e.unwrap().path()).collect();
        for file in &files {
            let good = std::fs::read(file).unwrap();
            let check = |bytes: &[u8], what: &str| {
                std::fs::write(file, bytes).unwrap();
                let start = std::time::Instant::now();
                if let Err(e) = io::read_with_limits(&case, &limits()) {
                    let e = e.to_string();
                    assert!(e.contains(s(&case)) && !e.contains("panicked"), "{what}: {e}");
                }
                assert!(start.elapsed().as_secs_f64() < 2.0, "{what}: slow");
            };
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            for cut in (0..good.len()).step_by(if style.gz { 7 } else { 3 }) {
                check(&good[..cut], &format!("{name} cut at {cut}"));
            }
            for m in 0..60 {
                let mut b = good.clone();
                let i = rand() as usize % b.len();
                match m % 4 {
                    0 => b[i] = rand() as u8,
                    1 => b[i] = b"()0;{}"[rand() as usize % 6],
                    2 => {
                        b.splice(i..i, *b"99999999999");
                    }
                    _ => b[i] = 0xff,
                };
                check(&b, &format!("{name} mutant {m} at byte {i}"));
            }
            std::fs::write(file, &good).unwrap();
        }
    }
}

/// A Python with VTK (see [`common::python_with`]).
fn vtk_python() -> Option<PathBuf> {
    common::python_with("vtk", "the vtkOpenFOAMReader tests")
}

/// What vtkOpenFOAMReader reads of a case: the internal mesh's points and
/// cells, and each patch's faces.
fn vtk_read(python: &Path, case: &Path) -> serde_json::Value {
    let script = r#"
import sys, json, os, vtk
case = sys.argv[1]
marker = os.path.join(case, "vtk.foam")
open(marker, "a").close()
r = vtk.vtkOpenFOAMReader()
r.SetFileName(marker)
if hasattr(r, "SetDecomposePolyhedra"):
    r.SetDecomposePolyhedra(0)
r.UpdateInformation()
r.EnableAllPatchArrays()
r.Update()
out = {"patches": {}}
def walk(block, name):
    if block is None:
        return
    if block.IsA("vtkMultiBlockDataSet"):
        for i in range(block.GetNumberOfBlocks()):
            n = block.GetMetaData(i).Get(vtk.vtkCompositeDataSet.NAME()) if block.HasMetaData(i) else str(i)
            walk(block.GetBlock(i), n)
    elif name == "internalMesh":
        out["points"] = block.GetNumberOfPoints()
        out["cells"] = block.GetNumberOfCells()
        pts = block.GetPoints()
        out["first"] = list(pts.GetPoint(0))
        out["last"] = list(pts.GetPoint(block.GetNumberOfPoints() - 1))
    else:
        out["patches"][name] = block.GetNumberOfCells()
walk(r.GetOutput(), "")
os.remove(marker)
print(json.dumps(out))
"#;
    let o = Command::new(python).args(["-c", script]).arg(case).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn vtk_reads_the_cases_we_write() {
    let Some(python) = vtk_python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (name, case) in [("box", hex_box(4, 11)), ("mixed", mixed())] {
        for (k, style) in [STYLES[0], STYLES[4]].into_iter().enumerate() {
            let ctx = format!("{name} {style:?}");
            let input = dir.path().join(format!("{name}-in{k}"));
            let f = case.write(&input, style);
            let out = dir.path().join(format!("{name}-out{k}"));
            let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--quiet"]);
            assert!(o.status.success(), "{ctx}: {}", text(&o));
            let got = vtk_read(&python, &out);
            let m = io::read(&out).unwrap();
            assert_eq!(got["points"], m.num_points(), "{ctx}: {got}");
            assert_eq!(got["cells"], m.num_elements(), "{ctx}: {got}");
            // VTK holds the points as 32-bit floats
            let last: Vec<f64> = serde_json::from_value(got["last"].clone()).unwrap();
            let want = m.points[m.num_points() - 1];
            assert!(
                last.iter()
                    .zip(want)
                    .all(|(a, b)| (a - b).abs() <= 1e-6 * b.abs().max(1.0)),
                "{ctx}: {last:?}"
            );
            for (p, (pname, _)) in case.patches.iter().enumerate() {
                assert_eq!(got["patches"][pname], f.ranges[p].1, "{ctx}: patch {pname}: {got}");
            }
        }
    }
    // a mesh of another format, its faces built here
    let m = meshsmooth::generate::mixed_block(2, 1);
    let out = dir.path().join("built");
    io::write(&out, &m, Format::OpenFoamBinary, &[]).unwrap();
    let got = vtk_read(&python, &out);
    assert_eq!(got["points"], m.num_points(), "{got}");
    assert_eq!(got["cells"], m.num_elements(), "{got}");
    assert!(got["patches"]["defaultFaces"].as_u64().unwrap() > 0, "{got}");
}

/// Python's `read` and `write` go through the library: a case folder reads,
/// and a mesh written with `format="openfoam"` is a case.
#[test]
fn cases_go_through_the_python_interface_paths() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    case_files(&input);
    let m = io::read(&input).unwrap();
    let flat = Mesh {
        data: Default::default(),
        fixed: Vec::new(),
        lower: Vec::new(),
        ..m.clone()
    };
    let out = dir.path().join("flat");
    io::write_mesh(&out, &flat, Format::from_name("openfoam").unwrap()).unwrap();
    let back = io::read(&out).unwrap();
    assert_eq!(back.points, m.points);
    let poly = back.data.polymesh.as_ref().unwrap();
    assert_eq!(poly.patches.len(), 1);
    assert_eq!(poly.patches[0].name, "defaultFaces");
    assert_eq!(poly.patches[0].faces, 96);
}

/// Names under `dir` (recursively), sorted.
fn names(dir: &Path) -> Vec<String> {
    snapshot_names(dir, dir)
}

fn snapshot_names(root: &Path, dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        out.push(p.strip_prefix(root).unwrap().display().to_string());
        if p.is_dir() && !p.is_symlink() {
            out.extend(snapshot_names(root, &p));
        }
    }
    out.sort();
    out
}

#[cfg(unix)]
#[test]
fn a_write_replaces_a_case_whole_or_leaves_it() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    case_files(&input);
    let m = io::read(&input).unwrap();
    let out = dir.path().join("out");
    io::write(&out, &m, Format::OpenFoam, &[]).unwrap();
    let first = names(&out);
    assert!(first.contains(&"constant/polyMesh/points".to_string()), "{first:?}");
    // written again with other points: replaced, nothing left beside it
    let mut moved = m.clone();
    moved.points[31][0] += 0.01;
    io::write(&out, &moved, Format::OpenFoamBinary, &[]).unwrap();
    assert_eq!(names(&out), first);
    assert_eq!(io::read(&out).unwrap().points, moved.points);
    assert_eq!(Format::of_file(&out), Some(Format::OpenFoamBinary));
    // a FIFO where a file would go is never replaced: nothing changes
    let fifo_case = dir.path().join("fifo");
    std::fs::create_dir_all(fifo_case.join("constant/polyMesh")).unwrap();
    common::fifo(&fifo_case.join("constant/polyMesh/points"));
    let before = names(&fifo_case);
    let e = io::write(&fifo_case, &m, Format::OpenFoam, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("points") && e.contains("never replaces"), "{e}");
    assert_eq!(names(&fifo_case), before);
    // a link to a polyMesh folder: the folder it leads to is replaced, the link stays
    let real = dir.path().join("real");
    std::fs::create_dir_all(&real).unwrap();
    let linked = dir.path().join("linked");
    std::fs::create_dir_all(linked.join("constant")).unwrap();
    std::os::unix::fs::symlink(&real, linked.join("constant/polyMesh")).unwrap();
    io::write(&linked.join("case.foam"), &m, Format::OpenFoam, &[]).unwrap();
    assert!(
        std::fs::symlink_metadata(linked.join("constant/polyMesh"))
            .unwrap()
            .is_symlink()
    );
    assert!(linked.join("case.foam").is_file());
    assert_eq!(io::read(&linked).unwrap().points, m.points);
    assert!(dir.path().join("real").exists());
    // a stream cannot hold a case
    let e = io::write_to(&mut Vec::new(), Path::new("-"), &m, Format::OpenFoam, &[]).unwrap_err();
    assert!(e.to_string().contains("folder"), "{e}");
}
