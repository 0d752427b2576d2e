//! Faces, owners and neighbours from the cells of a mesh that did not come
//! from a polyMesh: each element's faces turned outward, a face met twice
//! internal (its owner the lower cell), the internal faces in
//! upper-triangular order (by owner, then neighbour), the boundary faces
//! grouped into patches by the group of the lower cell on them.

use std::collections::HashMap;

use crate::error::{Error, Result};
use crate::mesh::data::GMSH_PHYSICAL;
use crate::mesh::polymesh::{Patch, PolyMesh};
use crate::mesh::{ElementKind, Mesh};

/// Where no lower cell names a boundary face's patch.
pub const DEFAULT_PATCH: &str = "defaultFaces";

/// Outward faces of the fixed kinds in VTK's vertex order.
fn outward(kind: ElementKind) -> &'static [&'static [usize]] {
    match kind {
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
        _ => &[],
    }
}

fn key(vs: &[u32]) -> Vec<u32> {
    let mut k = vs.to_vec();
    k.sort_unstable();
    k
}

/// The group that names each lower cell's patch: its physical group (by
/// name where the mesh has one), else the first element set holding it.
fn lower_groups(mesh: &Mesh) -> Vec<Option<String>> {
    let mut out = vec![None; mesh.lower.len()];
    if let Some(a) = mesh.data.lower_array(GMSH_PHYSICAL) {
        for (i, g) in out.iter_mut().enumerate() {
            let tag = a.get_i64(i);
            if tag == 0 {
                continue;
            }
            let named = mesh
                .data
                .physical_names
                .iter()
                .find(|p| p.dim == 2 && i64::from(p.tag) == tag);
            *g = Some(named.map_or_else(|| format!("patch{tag}"), |p| p.name.clone()));
        }
    }
    for s in &mesh.data.element_sets {
        for &c in &s.lower {
            if let Some(g @ None) = out.get_mut(c as usize) {
                *g = Some(s.name.clone());
            }
        }
    }
    out
}

/// The polyMesh topology of a volume mesh.
pub(super) fn build(mesh: &Mesh) -> Result<PolyMesh> {
    struct Rec {
        owner: u32,
        neighbour: u32,
        from: usize,
        to: usize,
    }
    let mut points: Vec<u32> = Vec::new();
    let mut recs: Vec<Rec> = Vec::new();
    let mut seen: HashMap<Vec<u32>, usize> = HashMap::new();
    for e in 0..mesh.num_elements() {
        let vs = mesh.element(e);
        let faces: Vec<Vec<u32>> = match mesh.kinds[e] {
            ElementKind::Polyhedron => mesh.faces.of(e).map(<[u32]>::to_vec).collect(),
            k => outward(k).iter().map(|f| f.iter().map(|&i| vs[i]).collect()).collect(),
        };
        for f in faces {
            match seen.get(&key(&f)) {
                Some(&r) if recs[r].neighbour != u32::MAX => {
                    return Err(Error::InvalidArgument(format!(
                        "cannot write an OpenFOAM polyMesh: elements {}, {} and {e} share the face {f:?} \
                         (a face has at most two cells)",
                        recs[r].owner, recs[r].neighbour
                    )));
                }
                Some(&r) => recs[r].neighbour = e as u32,
                None => {
                    seen.insert(key(&f), recs.len());
                    let from = points.len();
                    points.extend_from_slice(&f);
                    recs.push(Rec {
                        owner: e as u32,
                        neighbour: u32::MAX,
                        from,
                        to: points.len(),
                    });
                }
            }
        }
    }
    drop(seen);
    let mut by_lower: HashMap<Vec<u32>, String> = HashMap::new();
    for ((_, vs), g) in mesh.lower.iter().zip(lower_groups(mesh)) {
        if let Some(g) = g
            && vs.len() >= 3
        {
            by_lower.entry(key(vs)).or_insert(g);
        }
    }
    // patches in order of their first face, defaultFaces last
    let mut names: Vec<String> = Vec::new();
    let mut patch_of: Vec<usize> = Vec::new();
    let mut internal: Vec<usize> = Vec::new();
    let mut boundary: Vec<usize> = Vec::new();
    for (r, rec) in recs.iter().enumerate() {
        if rec.neighbour != u32::MAX {
            internal.push(r);
            continue;
        }
        let name = by_lower
            .get(&key(&points[rec.from..rec.to]))
            .map_or(DEFAULT_PATCH, String::as_str);
        let p = match names.iter().position(|n| n == name) {
            Some(p) => p,
            None => {
                names.push(name.to_string());
                names.len() - 1
            }
        };
        patch_of.push(p);
        boundary.push(r);
    }
    if let Some(d) = names.iter().position(|n| n == DEFAULT_PATCH) {
        let last = names.len() - 1;
        names.swap(d, last);
        for p in &mut patch_of {
            if *p == d {
                *p = last;
            } else if *p == last {
                *p = d;
            }
        }
    }
    internal.sort_by_key(|&r| (recs[r].owner, recs[r].neighbour));
    let mut order: Vec<(usize, usize)> = boundary.iter().copied().zip(patch_of.iter().copied()).collect();
    order.sort_by_key(|&(r, p)| (p, r));
    let mut poly = PolyMesh {
        face_offsets: vec![0],
        ..Default::default()
    };
    let push = |poly: &mut PolyMesh, r: usize| {
        poly.face_points.extend_from_slice(&points[recs[r].from..recs[r].to]);
        poly.face_offsets.push(poly.face_points.len());
        poly.owner.push(recs[r].owner);
    };
    for &r in &internal {
        push(&mut poly, r);
        poly.neighbour.push(recs[r].neighbour);
    }
    let mut start = internal.len();
    let mut rest = &order[..];
    for (p, name) in names.iter().enumerate() {
        let k = rest.iter().take_while(|&&(_, q)| q == p).count();
        for &(r, _) in &rest[..k] {
            push(&mut poly, r);
        }
        rest = &rest[k..];
        poly.patches.push(Patch {
            name: name.clone(),
            kind: "patch".into(),
            start,
            faces: k,
        });
        start += k;
    }
    Ok(poly)
}
