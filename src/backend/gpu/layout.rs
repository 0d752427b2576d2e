//! Host mirrors of the WGSL structs in `shaders/common/layout.wgsl` and
//! `shaders/bcd.wgsl`.

use super::shader::Real;
use crate::backend::{Coef, N_SLOTS, Slot};
use crate::metric::TetShape;
use crate::metric::corner_model::{Model, Template};
use crate::metric::smetric::MetricKind;
use crate::problem::Problem;
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Sizes {
    pub n_elements: u32,
    pub n_free: u32,
    pub n_obj_partials: u32,
    pub n_vert_partials: u32,
}
const _: () = assert!(std::mem::size_of::<Sizes>() == 16);

/// `struct Op` of `layout.wgsl`: the per-operation record, a 64-byte
/// header of u32s followed by `coef: vec4<real>` (written by `Op::bytes` in
/// the device precision).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Op {
    pub n: u32,
    pub slot: u32,
    pub aux: u32,
    pub aux2: u32,
    pub aux3: u32,
    pub guard: u32,
    pub flags: u32,
    pub offset: u32,
    /// `base`: the first part bound of each split binding, in table order.
    pub base: [u32; 4],
    pub a: Coef,
    pub b: Coef,
}

// `Op::base` is the WGSL `vec4<u32>`: one entry per split binding.
const _: () = assert!(super::shader::MAX_SPLIT == 4);

/// "No slot" in `Op` fields.
pub(crate) const NONE: u32 = u32::MAX;

fn slot_id(s: Option<Slot>) -> u32 {
    s.map_or(NONE, |s| s.0)
}

impl Op {
    pub const HEADER_BYTES: usize = 64;

    /// An operation over `n` items with nothing else set.
    pub fn n(n: usize) -> Op {
        Op {
            n: n as u32,
            slot: NONE,
            aux: NONE,
            aux2: NONE,
            aux3: NONE,
            guard: NONE,
            flags: 0,
            offset: 0,
            base: [0; 4],
            a: Coef::value(1.0),
            b: Coef::value(1.0),
        }
    }

    /// Bytes of the WGSL struct in precision `real`.
    pub fn size(real: Real) -> usize {
        Self::HEADER_BYTES + 4 * real.size()
    }

    pub fn slot(s: Option<Slot>) -> u32 {
        slot_id(s)
    }

    /// The record as the device reads it.
    pub fn bytes(&self, real: Real) -> Vec<u8> {
        let header: [u32; 16] = [
            self.n,
            self.slot,
            self.aux,
            self.aux2,
            self.aux3,
            self.guard,
            self.flags,
            self.offset,
            slot_id(self.a.num),
            slot_id(self.a.den),
            slot_id(self.b.num),
            slot_id(self.b.den),
            self.base[0],
            self.base[1],
            self.base[2],
            self.base[3],
        ];
        let mut out = bytemuck::cast_slice(&header).to_vec();
        let coef = [self.a.scale, self.b.scale, 0.0, 0.0];
        match real {
            Real::F64 => out.extend_from_slice(bytemuck::cast_slice(&coef)),
            Real::F32 => out.extend_from_slice(bytemuck::cast_slice(&coef.map(|c| c as f32))),
        }
        out
    }
}

/// Reals per corner in the Newton assembly buffer: the gradient (12) then
/// the 10 upper 3x3 blocks.
pub(crate) const ELEM_STRIDE: u32 = 102;
/// u32s per corner in the solver kernels: 4 vertex ids, then a `shapes` table index.
pub(crate) const CORNER_STRIDE: u32 = 5;
pub(crate) const METRIC_IMR: u32 = 0;
pub(crate) const METRIC_CN: u32 = 1;
pub(crate) const METRIC_TMP: u32 = 2;
pub(crate) const METRIC_RJ: u32 = 3;
pub(crate) const METRIC_SS: u32 = 4;
pub(crate) const TEMPLATE_HARMONIC: u32 = 0;
pub(crate) const TEMPLATE_AVERAGE: u32 = 1;
/// `ModelUniform::closed`: the structured general path, the tetrahedral
/// inverse mean ratio (`Model::fast`), the planar 2x2 forms (`Model::planar`),
/// a surface mesh's corners (`metric::surface`).
pub(crate) const CLOSED_NONE: u32 = 0;
pub(crate) const CLOSED_TET: u32 = 1;
pub(crate) const CLOSED_PLANAR: u32 = 2;
pub(crate) const CLOSED_SURFACE: u32 = 3;

/// The constants Rust and WGSL share, generated into every kernel's prelude
/// (`Real::prelude`); no WGSL file defines them.
pub(crate) const PRELUDE_CONSTANTS: &[(&str, u32)] = &[
    ("NONE", NONE),
    ("N_SLOTS", N_SLOTS as u32),
    ("CORNER_STRIDE", CORNER_STRIDE),
    ("ELEM_STRIDE", ELEM_STRIDE),
    ("METRIC_IMR", METRIC_IMR),
    ("METRIC_CN", METRIC_CN),
    ("METRIC_TMP", METRIC_TMP),
    ("METRIC_RJ", METRIC_RJ),
    ("METRIC_SS", METRIC_SS),
    ("TEMPLATE_HARMONIC", TEMPLATE_HARMONIC),
    ("TEMPLATE_AVERAGE", TEMPLATE_AVERAGE),
];

/// `struct Model` of `layout.wgsl`: four u32, then `eps` in the shader's
/// precision (so the struct's size depends on it: `ModelUniform::size`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct ModelUniform {
    pub dim: u32,
    pub metric: u32,
    pub tmpl: u32,
    /// Which closed forms the CPU takes for this model (`CLOSED_*`): the
    /// kernels never read it, `shader::Form::of` compiles them for it.
    pub closed: u32,
    pub eps: f64,
}
const _: () = assert!(std::mem::size_of::<ModelUniform>() == 24);

impl ModelUniform {
    /// Bytes of the u32 header before `eps`.
    pub const HEADER_BYTES: usize = 16;

    /// The WGSL struct's size in `real`.
    pub fn size(real: Real) -> usize {
        Self::HEADER_BYTES + real.size()
    }

    /// The uniform's bytes for `real`.
    pub fn bytes(&self, real: Real) -> Vec<u8> {
        let mut out = bytemuck::bytes_of(self)[..Self::HEADER_BYTES].to_vec();
        match real {
            Real::F64 => out.extend_from_slice(bytemuck::bytes_of(&self.eps)),
            Real::F32 => out.extend_from_slice(bytemuck::bytes_of(&(self.eps as f32))),
        }
        debug_assert_eq!(out.len(), Self::size(real));
        out
    }

    pub fn of(p: &Problem) -> ModelUniform {
        let mut m = Self::from_model(&p.model, p.dim);
        if p.surface_mesh {
            // every corner of a surface mesh is measured in its own plane
            m.closed = CLOSED_SURFACE;
        }
        m
    }

    /// The uniform of `m` in dimension `dim`.
    pub fn from_model(m: &Model, dim: usize) -> ModelUniform {
        ModelUniform {
            eps: m.eps,
            dim: dim as u32,
            metric: match m.metric {
                MetricKind::InverseMeanRatio => METRIC_IMR,
                MetricKind::ConditionNumber | MetricKind::ConditionNumberPaper => METRIC_CN,
                MetricKind::TargetShapeSize => METRIC_TMP,
                MetricKind::ReferenceJacobian => METRIC_RJ,
                MetricKind::ShapeSize => METRIC_SS,
            },
            tmpl: match m.template {
                Template::Harmonic => TEMPLATE_HARMONIC,
                Template::Average => TEMPLATE_AVERAGE,
            },
            // the closed forms `Model::blocks` and friends take on the CPU
            closed: if m.fast(dim) {
                CLOSED_TET
            } else if m.planar(dim) {
                CLOSED_PLANAR
            } else {
                CLOSED_NONE
            },
        }
    }
}

/// Reals per `shapes` table entry: four `vec4` rows, b_k in .xyz, the weight in
/// row 0's w, a surface corner's reference normal in rows 1-3's w.
const TABLE_ENTRY: usize = 16;

/// The corners as the solver kernels read them (`CORNER_STRIDE` u32 each:
/// the 4 vertex ids, then an index into the table) and the table of distinct
/// (B, weight) pairs: weights differ by element kind, so the table stays a
/// few entries long however many corners share it.
pub(crate) fn corner_tables(p: &Problem) -> (Vec<u32>, Vec<f64>) {
    let mut ids: HashMap<(u32, u64), u32> = HashMap::new();
    let mut table = Vec::new();
    let mut corners = Vec::with_capacity(CORNER_STRIDE as usize * p.num_corners());
    for (c, vs) in p.corners.iter().enumerate() {
        let (shape, w) = (p.corner_shape[c], p.corner_weight[c]);
        let id = *ids.entry((shape, w.to_bits())).or_insert_with(|| {
            let tet = &p.shapes[shape as usize].tet;
            for k in 0..4 {
                table.extend_from_slice(tet.b(k));
                // a surface corner's normal in rows 1-3's w (`corner_ref`)
                table.push(if k == 0 {
                    w
                } else {
                    p.shapes[shape as usize].normal[k - 1]
                });
            }
            (table.len() / TABLE_ENTRY - 1) as u32
        });
        corners.extend_from_slice(vs);
        corners.push(id);
    }
    (corners, table)
}

/// `struct Shape { b: array<vec4<real>, 4>, ls: vec4<real> }` as 20 reals
/// (the per-element test kernels; `ls` is unused there).
pub(crate) fn shape_values(shape: &TetShape) -> [f64; 20] {
    let mut v = [0.0; 20];
    for k in 0..4 {
        v[4 * k..4 * k + 3].copy_from_slice(shape.b(k));
    }
    v
}
