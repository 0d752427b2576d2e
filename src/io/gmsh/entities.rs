//! Gmsh 4.1 `$Entities` and the entity each node lies on.
//!
//! Read: every entity, with its bounding box, physical tags and bounding
//! entities, into `MeshData::gmsh_entities`, and each node's (dim, tag)
//! from its `$Nodes` block into the point array `gmsh:dim_tags`.
//!
//! Written: the input's entities in their order (empty ones too, their
//! boxes as read), then any entity the cells or nodes use that the input
//! did not list (its box from its points); Gmsh refuses element and node
//! blocks whose entity it does not know. Nodes are written in one block per
//! run of consecutive nodes on one entity of `gmsh:dim_tags`, so their
//! order and their entities survive; without that array every node goes in
//! one block on the first cell's entity.

use std::collections::HashMap;
use std::io::Write;
use std::ops::Range;

use rayon::prelude::*;

use super::{OutCell, Reader};
use crate::error::Result;
use crate::io::{WriteResult, fmt_f64};
use crate::mesh::Mesh;
use crate::mesh::data::{GMSH_DIM_TAGS, GmshEntity};

impl Reader<'_> {
    /// 4.1 `$Entities`: every entity, and the first physical tag of each,
    /// which its elements take.
    pub(super) fn entities(&mut self) -> Result<()> {
        let mut counts = [0usize; 4];
        for c in &mut counts {
            *c = self.count(true, "the number of entities")?;
        }
        for (dim, &n) in counts.iter().enumerate() {
            for _ in 0..n {
                if self.eof_text() {
                    return Err(self.c.eof("$Entities"));
                }
                let tag = self.int("entity tag")?;
                let mut bounds = [0.0; 6];
                let coords = if dim == 0 { 3 } else { 6 };
                for x in &mut bounds[..coords] {
                    *x = self.coord("entity bounds")?;
                }
                if dim == 0 {
                    bounds.copy_within(..3, 3);
                }
                let np = self.count(true, "numPhysicalTags")?;
                let mut physical = Vec::with_capacity(self.c.cap(np, 1));
                for _ in 0..np {
                    physical.push(self.int("physical tag")?);
                }
                let mut bounding = Vec::new();
                if dim > 0 {
                    let nb = self.count(true, "numBoundingEntities")?;
                    bounding.reserve(self.c.cap(nb, 1));
                    for _ in 0..nb {
                        bounding.push(self.int("bounding entity tag")?);
                    }
                }
                let first = physical.first().map_or(0, |&p| i64::from(p));
                self.entity_physical.insert((dim as i32, tag), first);
                self.raw.gmsh_entities.push(GmshEntity {
                    dim: dim as i32,
                    tag,
                    bounds,
                    physical,
                    bounding,
                });
            }
        }
        self.end("$EndEntities")
    }
}

/// An entity of a 4.1 file as written.
pub(super) struct Entity {
    pub dim: usize,
    pub tag: i32,
    pub physical: Vec<i32>,
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    pub bounding: Vec<i32>,
}

impl Entity {
    fn empty(dim: usize, tag: i32) -> Entity {
        Entity {
            dim,
            tag,
            physical: Vec::new(),
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
            bounding: Vec::new(),
        }
    }

    fn grow(&mut self, p: [f64; 3]) {
        for k in 0..3 {
            self.lo[k] = self.lo[k].min(p[k]);
            self.hi[k] = self.hi[k].max(p[k]);
        }
    }
}

/// A run of consecutive nodes on one entity: one `$Nodes` block.
pub(super) struct NodeBlock {
    pub dim: usize,
    pub tag: i32,
    pub nodes: Range<usize>,
}

/// The node blocks of a 4.1 output (see the module doc).
pub(super) fn node_blocks(mesh: &Mesh, cells: &[OutCell<'_>]) -> Vec<NodeBlock> {
    let n = mesh.num_points();
    let dim_tags = mesh
        .data
        .point
        .iter()
        .find(|a| a.name == GMSH_DIM_TAGS && a.components == 2 && a.tuples() == n)
        .filter(|a| (0..n).all(|i| (0..=3).contains(&a.get_i64(2 * i))));
    let Some(a) = dim_tags else {
        let (dim, tag) = cells.first().map_or((mesh.dim(), 1), |c| (c.dim, c.elementary));
        return if n == 0 {
            Vec::new()
        } else {
            vec![NodeBlock { dim, tag, nodes: 0..n }]
        };
    };
    let of = |i: usize| (a.get_i64(2 * i) as usize, a.get_i64(2 * i + 1) as i32);
    let mut out: Vec<NodeBlock> = Vec::new();
    for i in 0..n {
        let (dim, tag) = of(i);
        match out.last_mut() {
            Some(b) if (b.dim, b.tag) == (dim, tag) => b.nodes.end = i + 1,
            _ => out.push(NodeBlock {
                dim,
                tag,
                nodes: i..i + 1,
            }),
        }
    }
    out
}

/// The entities of a 4.1 output (see the module doc).
pub(super) fn entities(mesh: &Mesh, cells: &[OutCell<'_>], blocks: &[NodeBlock]) -> Vec<Entity> {
    let mut used = used_entities(mesh, cells);
    let mut index: HashMap<(usize, i32), usize> = used.iter().enumerate().map(|(i, e)| ((e.dim, e.tag), i)).collect();
    for b in blocks {
        let i = *index.entry((b.dim, b.tag)).or_insert_with(|| {
            used.push(Entity::empty(b.dim, b.tag));
            used.len() - 1
        });
        for v in b.nodes.clone() {
            used[i].grow(mesh.points[v]);
        }
    }
    if mesh.data.gmsh_entities.is_empty() {
        used.sort_by_key(|e| (e.dim, e.tag));
        return used;
    }
    let mut out: Vec<Entity> = mesh
        .data
        .gmsh_entities
        .iter()
        .map(|g| {
            let b = g.bounds;
            Entity {
                dim: g.dim.clamp(0, 3) as usize,
                tag: g.tag,
                physical: g.physical.clone(),
                lo: [b[0], b[1], b[2]],
                hi: [b[3], b[4], b[5]],
                bounding: g.bounding.clone(),
            }
        })
        .collect();
    let listed: HashMap<(usize, i32), usize> = out.iter().enumerate().map(|(i, e)| ((e.dim, e.tag), i)).collect();
    used.sort_by_key(|e| (e.dim, e.tag));
    for u in used {
        match listed.get(&(u.dim, u.tag)) {
            Some(&i) => {
                for p in u.physical {
                    if !out[i].physical.contains(&p) {
                        out[i].physical.push(p);
                    }
                }
            }
            None => out.push(u),
        }
    }
    // the section lists points, then curves, surfaces and volumes
    out.sort_by_key(|e| e.dim);
    out
}

/// Every (dim, elementary tag) the cells use, with the physical tags of its
/// cells (in order of first appearance) and the bounding box of their
/// vertices.
fn used_entities(mesh: &Mesh, cells: &[OutCell<'_>]) -> Vec<Entity> {
    // each cell's entity, numbered in order of first appearance; runs of one
    // entity (the usual case) skip the map
    let mut index: HashMap<(usize, i32), usize> = HashMap::new();
    let mut out: Vec<Entity> = Vec::new();
    let mut of = Vec::with_capacity(cells.len());
    let mut last: Option<((usize, i32), usize)> = None;
    for c in cells {
        let key = (c.dim, c.elementary);
        let i = match last {
            Some((k, i)) if k == key => i,
            _ => *index.entry(key).or_insert_with(|| {
                out.push(Entity::empty(c.dim, c.elementary));
                out.len() - 1
            }),
        };
        last = Some((key, i));
        of.push(i as u32);
    }
    // physical tags in order of first appearance and bounding boxes, per
    // fixed chunk in parallel, merged in chunk order (min and max are exact)
    const CHUNK: usize = 1 << 14;
    let parts: Vec<Vec<Entity>> = cells
        .par_chunks(CHUNK)
        .zip(of.par_chunks(CHUNK))
        .map(|(cs, is)| {
            let mut ents: Vec<Entity> = out.iter().map(|e| Entity::empty(e.dim, e.tag)).collect();
            for (c, &i) in cs.iter().zip(is) {
                let e = &mut ents[i as usize];
                if c.physical != 0 && !e.physical.contains(&c.physical) {
                    e.physical.push(c.physical);
                }
                for &v in c.vs.iter() {
                    e.grow(mesh.points[v as usize]);
                }
            }
            ents
        })
        .collect();
    for part in parts {
        for (e, p) in out.iter_mut().zip(part) {
            for ph in p.physical {
                if !e.physical.contains(&ph) {
                    e.physical.push(ph);
                }
            }
            for k in 0..3 {
                e.lo[k] = e.lo[k].min(p.lo[k]);
                e.hi[k] = e.hi[k].max(p.hi[k]);
            }
        }
    }
    out
}

/// The `$Entities` section.
pub(super) fn write_entities(w: &mut dyn Write, ents: &[Entity], binary: bool) -> WriteResult {
    writeln!(w, "$Entities")?;
    let count = |d: usize| ents.iter().filter(|e| e.dim == d).count() as u64;
    let counts = [count(0), count(1), count(2), count(3)];
    let mut buf: Vec<u8> = Vec::new();
    if binary {
        counts.iter().for_each(|c| buf.extend_from_slice(&c.to_le_bytes()));
    } else {
        writeln!(w, "{} {} {} {}", counts[0], counts[1], counts[2], counts[3])?;
    }
    for e in ents {
        let reals: Vec<f64> = if e.dim == 0 {
            e.lo.to_vec()
        } else {
            e.lo.iter().chain(&e.hi).copied().collect()
        };
        // a point has no bounding entities, not even their count
        let lists: &[&[i32]] = if e.dim == 0 {
            &[&e.physical]
        } else {
            &[&e.physical, &e.bounding]
        };
        if binary {
            buf.extend_from_slice(&e.tag.to_le_bytes());
            reals.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
            for list in lists {
                buf.extend_from_slice(&(list.len() as u64).to_le_bytes());
                list.iter().for_each(|p| buf.extend_from_slice(&p.to_le_bytes()));
            }
        } else {
            let mut line = e.tag.to_string();
            for x in reals {
                line.push(' ');
                line.push_str(&fmt_f64(x));
            }
            for list in lists {
                line.push_str(&format!(" {}", list.len()));
                for p in *list {
                    line.push_str(&format!(" {p}"));
                }
            }
            writeln!(w, "{line}")?;
        }
    }
    if binary {
        w.write_all(&buf)?;
        writeln!(w)?;
    }
    writeln!(w, "$EndEntities")?;
    Ok(())
}
