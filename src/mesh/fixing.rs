//! Which vertices stay fixed, from what the file holds: Gmsh physical groups
//! (by name or number) and named element and node sets (Abaqus `*ELSET`,
//! `*NSET`; a node set fixes nothing until a rule names it), point-data arrays, lists of vertex ids. Applied to
//! `Mesh::fixed` before a problem is built; each rule reports how many
//! vertices it fixed (or released).
//!
//! A file's lower cells (Gmsh boundary faces, lines, points) fix their
//! vertices by default. `free_groups` releases the vertices of the lower
//! cells of those groups, and with a sliding boundary the lower cells that
//! are facets on the skin (faces of a volume mesh, lines of a planar one)
//! describe the boundary rather than fix it, so they release theirs too
//! (internal interfaces stay fixed, and so do the faces of an OpenFOAM
//! patch of type `wall`); a vertex also on another lower cell, or
//! flagged by a `fixed` point array, stays fixed. A node set given to
//! `free_groups` releases its vertices whatever lower cells hold them (but
//! not those a `fixed` array flags).

use super::data::{DataArray, ElementSet, GMSH_PHYSICAL, NodeSet, Values};
use super::{LowerKind, Mesh};
use crate::error::{Error, Result};
use std::collections::BTreeSet;

/// The rules, applied in this order: releases, then fixes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FixRules {
    /// Gmsh physical groups (names or numbers) whose vertices are fixed.
    pub fix_groups: Vec<String>,
    /// Gmsh physical groups whose lower cells do not fix their vertices.
    pub free_groups: Vec<String>,
    /// Point-data arrays: a vertex with any non-zero component is fixed.
    pub fixed_arrays: Vec<String>,
    /// Lists of vertex ids (0-based), each with where it came from (a file name).
    pub fixed_ids: Vec<(String, Vec<usize>)>,
    /// The boundary slides: facet lower cells do not fix their vertices.
    pub release_facets: bool,
}

/// What one rule did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RuleCount {
    /// The setting that made the rule (`fix_groups`, `free_groups`,
    /// `fixed_arrays`, `fixed_files`, `boundary`: the keys of
    /// [`Smoother`](crate::Smoother)).
    pub option: &'static str,
    /// What it named (`inlet`), and what it did where that is not fixing.
    pub value: String,
    /// Vertices it fixed (or, for releases, released).
    pub vertices: usize,
}

impl FixRules {
    /// True when there are no rules.
    pub fn is_empty(&self) -> bool {
        self.fix_groups.is_empty()
            && self.free_groups.is_empty()
            && self.fixed_arrays.is_empty()
            && self.fixed_ids.is_empty()
            && !self.release_facets
    }

    /// Applies the rules to `mesh.fixed`.
    pub fn apply(&self, mesh: &mut Mesh) -> Result<Vec<RuleCount>> {
        let mut report = Vec::new();
        if self.is_empty() {
            return Ok(report);
        }
        let n = mesh.num_points();
        let mut fixed = if mesh.fixed.is_empty() {
            vec![false; n]
        } else {
            mesh.fixed.clone()
        };
        let facet_kinds: &[LowerKind] = if mesh.dim() == 3 {
            &[LowerKind::Triangle, LowerKind::Quadrilateral]
        } else {
            &[LowerKind::Line]
        };
        let freed: Vec<(String, Group)> = self
            .free_groups
            .iter()
            .map(|g| Ok((g.clone(), Group::resolve(mesh, g, "free_groups")?)))
            .collect::<Result<_>>()?;
        if !freed.is_empty() || self.release_facets {
            // a surface mesh's curves (its lines) are its boundary, wherever they run
            let surface = self.release_facets && super::plane::is_surface(mesh, &mesh.points);
            let skin = if surface {
                vec![true; n]
            } else if self.release_facets {
                super::topology::skin_vertices(mesh)
            } else {
                vec![false; n]
            };
            let freed_lower: Vec<Vec<bool>> = freed.iter().map(|(_, g)| g.lower_cells(mesh)).collect();
            // an OpenFOAM wall keeps its vertices when the boundary slides
            // (naming it in free_groups releases it)
            let walls = match &mesh.data.polymesh {
                Some(p) if self.release_facets => p.wall_lower_cells(mesh.lower.len()),
                _ => Vec::new(),
            };
            let released_by = |i: usize, kind: LowerKind, vs: &[u32]| -> Option<usize> {
                if let Some(k) = freed_lower.iter().position(|l| l[i]) {
                    return Some(k);
                }
                let on_skin = vs.iter().all(|&v| skin[v as usize]);
                let wall = walls.get(i).copied().unwrap_or(false);
                (self.release_facets && facet_kinds.contains(&kind) && on_skin && !wall).then_some(freed.len())
            };
            let mut keep = vec![false; n];
            if let Some(a) = mesh.data.point.iter().find(|a| a.name == "fixed") {
                for (v, k) in keep.iter_mut().enumerate() {
                    *k = nonzero(a, v);
                }
            }
            let flagged = keep.clone();
            let mut released: Vec<Option<usize>> = vec![None; n];
            for (i, (kind, vs)) in mesh.lower.iter().enumerate() {
                match released_by(i, *kind, vs) {
                    Some(k) => vs.iter().for_each(|&v| {
                        released[v as usize].get_or_insert(k);
                    }),
                    None => vs.iter().for_each(|&v| keep[v as usize] = true),
                }
            }
            let mut counts = vec![0usize; freed.len() + 1];
            for v in 0..n {
                if let Some(k) = released[v]
                    && !keep[v]
                    && fixed[v]
                {
                    fixed[v] = false;
                    counts[k] += 1;
                }
            }
            // a node set names its vertices: they are released whatever
            // lower cells hold them, unless a `fixed` array flags them
            for (k, (_, g)) in freed.iter().enumerate() {
                for &v in g.node_sets.iter().flat_map(|s| &s.vertices) {
                    let v = v as usize;
                    if fixed[v] && !flagged[v] {
                        fixed[v] = false;
                        counts[k] += 1;
                    }
                }
            }
            for (k, (g, _)) in freed.iter().enumerate() {
                report.push(RuleCount {
                    option: "free_groups",
                    value: format!("{g} (released)"),
                    vertices: counts[k],
                });
            }
            if self.release_facets && counts[freed.len()] > 0 {
                report.push(RuleCount {
                    option: "boundary",
                    value: "slide (boundary faces of the file released)".into(),
                    vertices: counts[freed.len()],
                });
            }
        }
        for g in &self.fix_groups {
            let hit = Group::resolve(mesh, g, "fix_groups")?.vertices(mesh);
            report.push(mark(&mut fixed, &hit, "fix_groups", g.clone()));
        }
        for name in &self.fixed_arrays {
            let a = mesh.data.point.iter().find(|a| &a.name == name).ok_or_else(|| {
                let names: Vec<&str> = mesh.data.point.iter().map(|a| a.name.as_str()).collect();
                Error::InvalidOption {
                    option: "fixed_arrays",
                    message: format!(
                        "{name}: the mesh has no point array of that name (its point arrays: {})",
                        if names.is_empty() {
                            "none".into()
                        } else {
                            names.join(", ")
                        }
                    ),
                }
            })?;
            if matches!(a.values, Values::Str(_)) {
                return Err(Error::InvalidOption {
                    option: "fixed_arrays",
                    message: format!("{name}: the array holds strings, not numbers"),
                });
            }
            let hit: Vec<bool> = (0..n).map(|v| nonzero(a, v)).collect();
            report.push(mark(&mut fixed, &hit, "fixed_arrays", name.clone()));
        }
        for (source, ids) in &self.fixed_ids {
            let mut hit = vec![false; n];
            for &v in ids {
                if v >= n {
                    return Err(Error::InvalidOption {
                        option: "fixed_files",
                        message: format!(
                            "{source}: vertex {v} does not exist (the mesh has {n} vertices, numbered from 0)"
                        ),
                    });
                }
                hit[v] = true;
            }
            report.push(mark(&mut fixed, &hit, "fixed_files", source.clone()));
        }
        mesh.fixed = if fixed.iter().any(|&f| f) { fixed } else { Vec::new() };
        Ok(report)
    }
}

fn nonzero(a: &DataArray, v: usize) -> bool {
    let k = a.components;
    (v * k..(v + 1) * k).any(|i| a.get_f64(i) != 0.0)
}

fn mark(fixed: &mut [bool], hit: &[bool], option: &'static str, value: String) -> RuleCount {
    let mut vertices = 0;
    for (f, &h) in fixed.iter_mut().zip(hit) {
        if h {
            *f = true;
            vertices += 1;
        }
    }
    RuleCount {
        option,
        value,
        vertices,
    }
}

/// What a group name (or physical number) stands for: the physical tags
/// of that name or number, and the element and node sets of that name.
struct Group<'m> {
    tags: BTreeSet<i64>,
    element_sets: Vec<&'m ElementSet>,
    node_sets: Vec<&'m NodeSet>,
}

impl<'m> Group<'m> {
    fn resolve(mesh: &'m Mesh, group: &str, option: &'static str) -> Result<Group<'m>> {
        let mut present: BTreeSet<i64> = BTreeSet::new();
        for a in [
            mesh.data.cell_array(GMSH_PHYSICAL),
            mesh.data.lower_array(GMSH_PHYSICAL),
        ]
        .into_iter()
        .flatten()
        {
            present.extend((0..a.tuples()).map(|i| a.get_i64(i)));
        }
        let data = &mesh.data;
        let names = &data.physical_names;
        let tags: BTreeSet<i64> = match group.trim().parse::<i64>() {
            Ok(t) => [t].into_iter().filter(|t| present.contains(t)).collect(),
            Err(_) => names.iter().filter(|p| p.name == group).map(|p| p.tag as i64).collect(),
        };
        // set names as the file spells them, else in any case (Abaqus's
        // names are case-insensitive)
        let named = |name: &str| name == group;
        let any_case = |name: &str| name.eq_ignore_ascii_case(group);
        let pick = |same: &dyn Fn(&str) -> bool| Group {
            tags: tags.clone(),
            element_sets: data.element_sets.iter().filter(|s| same(&s.name)).collect(),
            node_sets: data.node_sets.iter().filter(|s| same(&s.name)).collect(),
        };
        let mut found = pick(&named);
        if found.element_sets.is_empty() && found.node_sets.is_empty() {
            found = pick(&any_case);
        }
        if !found.tags.is_empty() || !found.element_sets.is_empty() || !found.node_sets.is_empty() {
            return Ok(found);
        }
        let mut list: Vec<String> = names.iter().map(|p| format!("{} ({})", p.name, p.tag)).collect();
        list.extend(
            present
                .iter()
                .filter(|t| !names.iter().any(|p| p.tag as i64 == **t))
                .map(|t| t.to_string()),
        );
        list.extend(data.element_sets.iter().map(|s| format!("{} (element set)", s.name)));
        list.extend(data.node_sets.iter().map(|s| format!("{} (node set)", s.name)));
        let known = if list.is_empty() {
            "none".to_string()
        } else {
            list.join(", ")
        };
        Err(Error::InvalidOption {
            option,
            message: format!("no physical group or set '{group}' in the mesh (its groups: {known})"),
        })
    }

    /// Per lower cell, whether the group holds it.
    fn lower_cells(&self, mesh: &Mesh) -> Vec<bool> {
        let mut hit = vec![false; mesh.lower.len()];
        if let Some(a) = mesh.data.lower_array(GMSH_PHYSICAL) {
            for (i, h) in hit.iter_mut().enumerate() {
                *h = self.tags.contains(&a.get_i64(i));
            }
        }
        for s in &self.element_sets {
            s.lower.iter().for_each(|&c| hit[c as usize] = true);
        }
        hit
    }

    /// Per vertex, whether a cell or node set of the group holds it.
    fn vertices(&self, mesh: &Mesh) -> Vec<bool> {
        let mut hit = vec![false; mesh.num_points()];
        let mut cover = |vs: &[u32]| vs.iter().for_each(|&v| hit[v as usize] = true);
        if let Some(a) = mesh.data.cell_array(GMSH_PHYSICAL) {
            for e in 0..mesh.num_elements() {
                if self.tags.contains(&a.get_i64(e)) {
                    cover(mesh.element(e));
                }
            }
        }
        for s in &self.element_sets {
            s.elements.iter().for_each(|&e| cover(mesh.element(e as usize)));
        }
        for (c, in_group) in self.lower_cells(mesh).into_iter().enumerate() {
            if in_group {
                cover(&mesh.lower[c].1);
            }
        }
        for s in &self.node_sets {
            cover(&s.vertices);
        }
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::data::{PhysicalName, ValueType};
    use crate::{ElementKind, generate};

    /// A 2x2 quad grid with its four boundary sides as tagged lines 1..4.
    fn tagged_grid() -> Mesh {
        let mut m = generate::quad_grid(2, 2, [2.0, 2.0]);
        let sides: [[u32; 3]; 4] = [[0, 1, 2], [2, 5, 8], [8, 7, 6], [6, 3, 0]];
        let mut tags = Vec::new();
        for (k, s) in sides.iter().enumerate() {
            for w in s.windows(2) {
                m.lower.push((LowerKind::Line, w.to_vec()));
                tags.push(k as i64 + 1);
            }
        }
        let cell = DataArray::new(GMSH_PHYSICAL, ValueType::I32, 1, Values::Int(vec![9; m.num_elements()]));
        m.data.lower = vec![DataArray::new(GMSH_PHYSICAL, ValueType::I32, 1, Values::Int(tags))];
        m.data.cell = vec![cell];
        m.data.physical_names = vec![
            PhysicalName {
                dim: 1,
                tag: 1,
                name: "bottom".into(),
            },
            PhysicalName {
                dim: 2,
                tag: 9,
                name: "plate".into(),
            },
        ];
        m.fixed = vec![true; 9];
        m.fixed[4] = false;
        assert_eq!(m.kinds[0], ElementKind::Quadrilateral);
        m
    }

    #[test]
    fn groups_by_name_and_number_fix_and_release() {
        let mut m = tagged_grid();
        let rules = FixRules {
            free_groups: vec!["bottom".into(), "2".into()],
            ..Default::default()
        };
        let report = rules.apply(&mut m).unwrap();
        // bottom releases 1 (vertex 1; 0 and 2 are also on sides 4 and 2... 2 is on freed side 2)
        let free: Vec<usize> = (0..9).filter(|&v| !m.is_fixed(v)).collect();
        assert_eq!(free, vec![1, 2, 4, 5]);
        assert_eq!(report[0].vertices + report[1].vertices, 3);
        let rules = FixRules {
            fix_groups: vec!["plate".into()],
            ..Default::default()
        };
        let report = rules.apply(&mut m).unwrap();
        assert_eq!(report[0].vertices, 9);
        assert!((0..9).all(|v| m.is_fixed(v)));
        let err = FixRules {
            fix_groups: vec!["inlet".into()],
            ..Default::default()
        }
        .apply(&mut m)
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("inlet") && err.contains("bottom (1)") && err.contains("plate (9)"),
            "{err}"
        );
    }

    #[test]
    fn sliding_releases_facets_but_not_flagged_vertices() {
        let mut m = tagged_grid();
        m.data.point.push(DataArray::new(
            "fixed",
            ValueType::U8,
            1,
            Values::Int((0..9).map(|v| i64::from(v == 1)).collect()),
        ));
        let rules = FixRules {
            release_facets: true,
            ..Default::default()
        };
        rules.apply(&mut m).unwrap();
        let fixed: Vec<usize> = (0..9).filter(|&v| m.is_fixed(v)).collect();
        assert_eq!(fixed, vec![1]);
    }

    #[test]
    fn arrays_and_id_lists_fix_and_bad_names_are_refused() {
        let mut m = generate::quad_grid(2, 2, [2.0, 2.0]);
        m.data.point.push(DataArray::new(
            "pin",
            ValueType::F64,
            2,
            Values::Float((0..18).map(|i| if i == 9 { 0.5 } else { 0.0 }).collect()),
        ));
        let rules = FixRules {
            fixed_arrays: vec!["pin".into()],
            fixed_ids: vec![("ids.txt".into(), vec![4, 8])],
            ..Default::default()
        };
        let report = rules.apply(&mut m).unwrap();
        assert_eq!(report.iter().map(|r| r.vertices).collect::<Vec<_>>(), vec![1, 2]);
        let fixed: Vec<usize> = (0..9).filter(|&v| m.is_fixed(v)).collect();
        assert_eq!(fixed, vec![4, 8]);
        let bad = FixRules {
            fixed_arrays: vec!["nope".into()],
            ..Default::default()
        };
        assert!(bad.apply(&mut m).unwrap_err().to_string().contains("pin"));
        let bad = FixRules {
            fixed_ids: vec![("ids.txt".into(), vec![9])],
            ..Default::default()
        };
        assert!(bad.apply(&mut m).unwrap_err().to_string().contains("ids.txt"));
    }
}
