//! Gmsh post-processing views: `$NodeData` and `$ElementData` sections.
//!
//! A view is read as a point or cell array named after the view (its first
//! string tag), of `f64` values with the view's number of components; a
//! node or cell the view does not list gets NaN (and is left out on
//! write). A view name that comes
//! again (later time steps) replaces the earlier one, so the last step is
//! kept. The writers write every numeric point array as `$NodeData` and
//! every numeric cell array but the tag arrays as `$ElementData` (strings
//! have no place in a view), one time step each.
//!
//! The layout is the same in versions 2.2 and 4.1: a text header (string,
//! real and integer tags), then one entry per node or element, its tag (a
//! 4-byte int in binary files of both versions, as Gmsh 4.8 writes them)
//! and its values.

use std::io::Write;

use super::{GMSH_ELEMENTARY, GMSH_PHYSICAL, Reader, TagMap};
use crate::error::Result;
use crate::io::lex::clip;
use crate::io::{WriteResult, fmt_f64};
use crate::mesh::data::GMSH_DIM_TAGS;
use crate::mesh::{DataArray, Mesh, ValueType, Values};

/// Which entities a view's entries name.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum On {
    Nodes,
    Elements,
}

impl On {
    fn section(self) -> &'static str {
        match self {
            On::Nodes => "$NodeData",
            On::Elements => "$ElementData",
        }
    }
}

impl Reader<'_> {
    /// One `$NodeData` or `$ElementData` section, stored as a point or cell
    /// array (replacing an earlier step of the same view).
    pub(super) fn view(&mut self, on: On) -> Result<()> {
        let section = on.section();
        let (needed, have) = match on {
            On::Nodes => ("$Nodes", self.has_nodes),
            On::Elements => ("$Elements", self.has_elements),
        };
        if !have {
            return Err(self.c.err(format!("{section} before {needed}")));
        }
        let strings = self.c.count("the number of string tags")?;
        let mut name = None;
        for _ in 0..strings {
            let (_, t) = self.c.line_tokens().ok_or_else(|| self.c.eof(section))?;
            let s = t.join(" ");
            name.get_or_insert_with(|| s.trim_matches('"').to_string());
        }
        let name = name.unwrap_or_else(|| "view".to_string());
        let reals = self.c.count("the number of real tags")?;
        for _ in 0..reals {
            self.c.parse::<f64>("a real tag")?;
        }
        let ints = self.c.count("the number of integer tags")?;
        let mut int_tags = Vec::with_capacity(ints.min(16));
        for _ in 0..ints {
            int_tags.push(self.c.parse::<i64>("an integer tag")?);
        }
        let (components, n) = match int_tags[..] {
            [_, k, n, ..] if k >= 1 && n >= 0 => (k as usize, n as usize),
            _ => {
                return Err(self.c.err(format!(
                    "{section} '{}': expected the integer tags 'time-step components count', found {int_tags:?}",
                    clip(&name)
                )));
            }
        };
        if self.binary {
            self.c.end_line();
        }
        // each entry holds at least a tag and its values
        let entries = n.saturating_mul(components);
        if components > self.c.remaining() || n.saturating_add(entries) > self.c.remaining() {
            return Err(self.err(format!(
                "{section} '{}' announces {n} entries of {components} values, more than the file could hold",
                clip(&name)
            )));
        }
        let rows = match on {
            On::Nodes => self.raw.points.len(),
            On::Elements => self.physical.len(),
        };
        let len = rows.saturating_mul(components);
        self.c.reserve(section, len, 1, 8)?;
        let mut values = vec![f64::NAN; len];
        if on == On::Elements && self.element_index.is_none() {
            self.element_index = Some(self.element_tags.index());
        }
        for _ in 0..n {
            let tag = self.uint(false, "a node or element tag")?;
            let id = match on {
                On::Nodes => self.tags.get(tag),
                On::Elements => self.element_index.as_ref().and_then(|m| m.get(tag)),
            };
            let Some(id) = id else {
                return Err(self.err(format!(
                    "{section} '{}' has a value for {} {tag}, which is not in {needed}",
                    clip(&name),
                    if on == On::Nodes { "node" } else { "element" }
                )));
            };
            let at = id as usize * components;
            for v in &mut values[at..at + components] {
                *v = self.coord("view values")?;
            }
        }
        self.end(&format!("$End{}", &section[1..]))?;
        let array = DataArray::new(name, ValueType::F64, components, Values::Float(values));
        let arrays = match on {
            On::Nodes => &mut self.raw.point_data,
            On::Elements => &mut self.raw.cell_data,
        };
        match arrays.iter_mut().find(|a| a.name == array.name) {
            Some(earlier) => *earlier = array,
            None => arrays.push(array),
        }
        Ok(())
    }
}

/// Element tags in file order, as runs of consecutive tags: Gmsh numbers
/// elements 1..m, so this is a handful of runs, kept whether or not a view
/// follows; the tag map is built only for an `$ElementData` section.
#[derive(Default)]
pub(super) struct ElementTags {
    /// (first tag, first cell, cells)
    runs: Vec<(u64, u32, u32)>,
}

impl ElementTags {
    /// Element `cell` (the next one) has tag `tag`.
    pub fn push(&mut self, tag: u64, cell: usize) {
        if let Some((t, c, k)) = self.runs.last_mut()
            && *t + u64::from(*k) == tag
            && (*c + *k) as usize == cell
        {
            *k += 1;
            return;
        }
        self.runs.push((tag, cell as u32, 1));
    }

    fn index(&self) -> TagMap {
        let mut map = TagMap::default();
        for &(t, c, k) in &self.runs {
            for i in 0..k {
                // a repeated tag keeps its first element, as Gmsh does
                map.insert(t + u64::from(i), c + i);
            }
        }
        map
    }
}

/// The arrays a writer writes as views: numeric, and not the arrays that
/// are the file's structure (tags, node entities, fixed flags).
fn viewable(a: &DataArray) -> bool {
    a.ty != ValueType::Str && ![GMSH_PHYSICAL, GMSH_ELEMENTARY, GMSH_DIM_TAGS, "fixed"].contains(&a.name.as_str())
}

/// `$NodeData` for every point array and `$ElementData` for every cell
/// array [`viewable`] of `mesh`; element tags are 1.. over the elements,
/// then the lower cells, as the writers number them.
pub(super) fn write_views(w: &mut dyn Write, mesh: &Mesh, binary: bool) -> WriteResult {
    let ne = mesh.num_elements();
    for a in mesh.data.point.iter().filter(|a| viewable(a)) {
        let rows: Vec<(u64, &DataArray, usize)> = (0..a.tuples()).map(|i| (i as u64 + 1, a, i)).collect();
        write_view(w, On::Nodes, a, &rows, binary)?;
    }
    for a in mesh.data.cell.iter().filter(|a| viewable(a)) {
        let mut rows: Vec<(u64, &DataArray, usize)> = (0..ne).map(|e| (e as u64 + 1, a, e)).collect();
        if let Some(l) = mesh.data.lower_array(&a.name).filter(|l| l.components == a.components) {
            rows.extend((0..l.tuples()).map(|i| ((ne + i) as u64 + 1, l, i)));
        }
        write_view(w, On::Elements, a, &rows, binary)?;
    }
    Ok(())
}

/// One view: `rows` are (tag, array, tuple) entries; tuples of NaN only
/// (what a view that does not list an entity reads as) are left out, and
/// so is a view left with no entries.
fn write_view(
    w: &mut dyn Write,
    on: On,
    a: &DataArray,
    rows: &[(u64, &DataArray, usize)],
    binary: bool,
) -> WriteResult {
    let section = on.section();
    let name: String = a.name.chars().filter(|&c| c != '"' && c != '\n').collect();
    let k = a.components;
    let rows: Vec<_> = rows
        .iter()
        .filter(|&&(_, arr, i)| (0..k).any(|c| !arr.get_f64(i * k + c).is_nan()))
        .collect();
    if rows.is_empty() {
        return Ok(());
    }
    writeln!(w, "{section}\n1\n\"{name}\"\n1\n0\n3\n0\n{k}\n{}", rows.len())?;
    let mut buf = Vec::new();
    for &&(tag, arr, i) in &rows {
        let values = (0..k).map(|c| arr.get_f64(i * k + c));
        if binary {
            buf.extend_from_slice(&(tag as i32).to_le_bytes());
            values.for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
        } else {
            let text: Vec<String> = values.map(fmt_f64).collect();
            writeln!(w, "{tag} {}", text.join(" "))?;
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
    }
    writeln!(w, "$End{}", &section[1..])?;
    Ok(())
}
