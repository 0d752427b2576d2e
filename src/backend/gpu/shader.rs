//! WGSL composition and the kernel table. Every kernel is one file in
//! `shaders/` written against the scalar alias `real`; a tiny `#import name`
//! preprocessor (vello-style) pulls in the shared files, and a prelude
//! generated from Rust instantiates the precision and every constant the two
//! sides share (`layout::PRELUDE_CONSTANTS`). `KERNELS` declares each kernel
//! the backend runs once, with its bindings and variants (`TEST_KERNELS` the
//! test-only probes): pipelines and bind-group layouts are built from it, the
//! backend binds arrays by the names it gives (`KernelDef::in_binding_order`),
//! and a test checks it against naga's reflection of the WGSL.

use super::context::{GpuContext, KernelForms};
use super::layout::{
    CLOSED_PLANAR, CLOSED_SURFACE, CLOSED_TET, METRIC_CN, METRIC_IMR, METRIC_RJ, METRIC_SS, METRIC_TMP, ModelUniform,
};
use std::collections::HashSet;

/// Floating-point precision of the device arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Real {
    F32,
    F64,
}

impl Real {
    pub fn size(self) -> usize {
        match self {
            Real::F32 => 4,
            Real::F64 => 8,
        }
    }

    fn prelude(self) -> String {
        let (ty, max) = match self {
            Real::F32 => ("f32", "3.40282347e38"),
            Real::F64 => ("f64", "1.7976931348623157e308"),
        };
        let mut s = format!("alias real = {ty};\nconst REAL_MAX: real = {max};\n");
        use crate::backend::cpu::project_boundary::{CREASE_SIN, MAPPING_EPS, MAPPING_STEP};
        s.push_str(&format!(
            "const MAPPING_STEP: real = {MAPPING_STEP:e};\nconst MAPPING_EPS: real = {MAPPING_EPS:e};\n\
             const CREASE_SIN: f32 = {CREASE_SIN:e};\n"
        ));
        for (name, value) in super::layout::PRELUDE_CONSTANTS {
            s.push_str(&format!("const {name}: u32 = {value}u;\n"));
        }
        s
    }
}

/// Shared WGSL pulled in by `#import name`.
const SHARED: &[(&str, &str)] = &[
    ("cbrt", include_str!("../../../shaders/common/cbrt.wgsl")),
    ("mat3", include_str!("../../../shaders/common/mat3.wgsl")),
    ("layout", include_str!("../../../shaders/common/layout.wgsl")),
    ("corners", include_str!("../../../shaders/common/corners.wgsl")),
    ("tree", include_str!("../../../shaders/common/tree.wgsl")),
    ("slots", include_str!("../../../shaders/common/slots.wgsl")),
    ("boundary", include_str!("../../../shaders/common/boundary.wgsl")),
    ("mean_ratio", include_str!("../../../shaders/metric/mean_ratio.wgsl")),
    ("condition", include_str!("../../../shaders/metric/condition.wgsl")),
    ("target", include_str!("../../../shaders/metric/target.wgsl")),
    (
        "reference_jacobian",
        include_str!("../../../shaders/metric/reference_jacobian.wgsl"),
    ),
    ("planar", include_str!("../../../shaders/metric/planar.wgsl")),
    ("surface", include_str!("../../../shaders/metric/surface.wgsl")),
    ("det_path", include_str!("../../../shaders/metric/det_path.wgsl")),
    ("shess", include_str!("../../../shaders/metric/shess.wgsl")),
    ("smetric", include_str!("../../../shaders/metric/smetric.wgsl")),
    (
        "corner_model",
        include_str!("../../../shaders/metric/corner_model.wgsl"),
    ),
];

/// How a kernel sees one binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Uniform,
    /// The per-operation `Op` record, a uniform bound at a dynamic offset.
    Op,
    Read,
    ReadWrite,
}

/// What one binding holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Elem {
    /// `array<real>`
    Real,
    /// `array<u32>`
    U32,
    /// `array<vec4<real>>`
    Vec4,
    /// A struct of that name (uniforms).
    Struct(&'static str),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub name: &'static str,
    pub access: Access,
    pub elem: Elem,
    /// May be spread over several buffers (`Variant::parts`): the kernel
    /// reaches it only through `NAME_get(i)` / `NAME_set(i, v)`, which
    /// `compose` generates.
    pub split: bool,
}

const fn b(name: &'static str, access: Access, elem: Elem) -> Binding {
    Binding {
        name,
        access,
        elem,
        split: false,
    }
}

/// A binding that grows with the mesh and may need several buffers.
const fn s(name: &'static str, access: Access, elem: Elem) -> Binding {
    Binding {
        name,
        access,
        elem,
        split: true,
    }
}

use Access::{Op as OpU, Read as R, ReadWrite as RW, Uniform as U};
use Elem::{Real as Re, Struct as St, U32 as Ui, Vec4 as V4};

const OP: Binding = b("op", OpU, St("Op"));
const MODEL: Binding = b("model", U, St("Model"));
const SCALARS_R: Binding = b("scalars", R, Re);
const SCALARS_RW: Binding = b("scalars", RW, Re);
const SLIDE_REAL: Binding = b("slide_real", R, Re);
const SLIDE_IDX: Binding = b("slide_idx", R, Ui);

/// One kernel: its WGSL stem (file, CPU twin and tests share it), source,
/// bindings in order (group 0, binding i) and whether it has variants: the
/// closed forms (`#if FAST`, `#if PLANAR`) and a general instance per metric
/// (`Form`).
#[derive(Debug)]
pub struct KernelDef {
    pub stem: &'static str,
    source: &'static str,
    pub bindings: &'static [Binding],
    pub variants: bool,
}

impl KernelDef {
    /// The values of `named` (binding name, value) in this kernel's binding
    /// order, matched by name: every binding of the table exactly once and
    /// nothing else (so the list may be in any order), or a panic naming the
    /// kernel and the binding, a bug where the list is written.
    pub fn in_binding_order<T: Copy>(&self, named: &[(&str, T)]) -> Vec<T> {
        let names = || named.iter().map(|(n, _)| *n).collect::<Vec<_>>();
        let table = || self.bindings.iter().map(|b| b.name).collect::<Vec<_>>();
        assert_eq!(
            named.len(),
            self.bindings.len(),
            "{}: binds {:?}, the table has {:?}",
            self.stem,
            names(),
            table()
        );
        self.bindings
            .iter()
            .map(|b| match named.iter().find(|(n, _)| *n == b.name) {
                Some(&(_, value)) => value,
                None => panic!(
                    "{}: nothing bound to '{}' (binds {:?}, the table has {:?})",
                    self.stem,
                    b.name,
                    names(),
                    table()
                ),
            })
            .collect()
    }
}

macro_rules! kernels {
    (
        production: { $($kernel:ident = $stem:literal, variants: $v:expr, [$($bind:expr),* $(,)?];)* }
        tests: { $($tkernel:ident = $tstem:literal, [$($tbind:expr),* $(,)?];)* }
    ) => {
        /// The compute kernels, one per file, entry point `main`.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Kernel { $($kernel,)* $($tkernel,)* }

        /// The kernel table, what `GpuBackend` runs: the one place a
        /// binding list is written (the backend binds by these names).
        pub static KERNELS: &[(Kernel, KernelDef)] = &[$(
            (Kernel::$kernel, KernelDef {
                stem: $stem,
                source: include_str!(concat!("../../../shaders/", $stem, ".wgsl")),
                bindings: &[$($bind),*],
                variants: $v,
            }),
        )*];

        /// Kernels only tests run (`gpu::probes`): device twins of CPU
        /// functions, no part of a solve. Compiled and checked like the others.
        pub static TEST_KERNELS: &[(Kernel, KernelDef)] = &[$(
            (Kernel::$tkernel, KernelDef {
                stem: $tstem,
                source: include_str!(concat!("../../../shaders/", $tstem, ".wgsl")),
                bindings: &[$($tbind),*],
                variants: false,
            }),
        )*];
    };
}

kernels! {
production: {
    Objective = "objective", variants: true, [
        MODEL, OP, s("x", R, Re), s("corners", R, Ui), b("shapes", R, V4), s("grad", RW, Re),
        b("partials", RW, V4),
    ];
    Reduce = "reduce", variants: false, [OP, b("partials", R, V4), SCALARS_RW];
    Inversion = "inversion", variants: false, [
        MODEL, OP, s("x", R, Re), s("corners", R, Ui), b("shapes", R, V4), s("trial", R, Re),
        b("partials", RW, V4),
    ];
    GradientGather = "gradient_gather", variants: false, [
        OP, b("free_vertices", R, Ui), b("inc_offsets", R, Ui), s("inc_items", R, Ui), s("elem", R, Re),
        s("grad", RW, Re),
    ];
    Bcd = "bcd", variants: true, [
        MODEL, b("ls", U, V4), OP, s("x", RW, Re), s("corners", R, Ui), b("shapes", R, V4),
        b("inc_offsets", R, Ui), s("inc_items", R, Ui), b("colors", R, Ui), s("moves", RW, Re),
        SLIDE_REAL, SLIDE_IDX,
    ];
    ReferencePosition = "reference_position", variants: true, [
        MODEL, b("ls", U, V4), OP, s("x", R, Re), s("corners", R, Ui), b("shapes", R, V4),
        b("inc_offsets", R, Ui), s("inc_items", R, Ui), b("free_vertices", R, Ui), s("xr", RW, Re),
    ];
    HessianAssemble = "hessian_assemble", variants: true, [
        MODEL, OP, s("x", R, Re), s("corners", R, Ui), b("shapes", R, V4), s("elem", RW, Re),
    ];
    HessianGather = "hessian_gather", variants: false, [
        OP, s("contrib_offsets", R, Ui), s("contrib_items", R, Ui), s("elem", R, Re), s("blocks", RW, Re),
    ];
    BsrSpmv = "bsr_spmv", variants: false, [
        OP, b("row_offsets", R, Ui), s("cols", R, Ui), s("blocks", R, Re), s("x", R, Re), s("y", RW, Re),
    ];
    BlockJacobiFactor = "block_jacobi_factor", variants: false, [
        OP, s("blocks", R, Re), b("diag", R, Ui), s("factors", RW, Re),
    ];
    BlockJacobi = "block_jacobi", variants: false, [OP, s("factors", R, Re), s("x", R, Re), s("y", RW, Re)];
    Axpby = "axpby", variants: false, [OP, SCALARS_R, s("x", R, Re), s("y", RW, Re)];
    SetSlot = "set_slot", variants: false, [OP, SCALARS_RW];
    Dot = "dot", variants: false, [OP, s("a", R, Re), s("b", R, Re), b("partials", RW, V4)];
    HaloGather = "halo_gather", variants: false, [OP, b("idx", R, Ui), s("src", R, Re), b("dst", RW, Re)];
    HaloScatter = "halo_scatter", variants: false, [OP, b("idx", R, Ui), b("data", R, Re), s("dst", RW, Re)];
    LineSearch = "line_search", variants: false, [
        OP, SCALARS_R, b("free_vertices", R, Ui), s("x", R, Re), s("d", R, Re), s("trial", RW, Re),
    ];
    ProjectBoundary = "project_boundary", variants: false, [
        OP, SLIDE_REAL, SLIDE_IDX, b("free_vertices", R, Ui), s("x", RW, Re),
    ];
    Constrain = "constrain", variants: false, [
        OP, b("slide_real", RW, Re), SLIDE_IDX, b("free_vertices", R, Ui), s("x", R, Re), s("y", RW, Re),
    ];
    ConstrainBlocks = "constrain_blocks", variants: false, [
        OP, SLIDE_REAL, SLIDE_IDX, b("free_vertices", R, Ui), b("row_offsets", R, Ui), s("cols", R, Ui),
        b("diag", R, Ui), s("blocks", RW, Re),
    ];
}
tests: {
    MeanRatioEval = "mean_ratio_eval", [
        b("shape", U, St("Shape")), b("sizes", U, St("Sizes")), b("x", R, Re), b("tets", R, Ui),
        b("value", RW, Re), b("grad", RW, Re), b("hess", RW, Re),
    ];
    CbrtEval = "cbrt_eval", [b("sizes", U, St("Sizes")), b("values", RW, Re)];
}
}

/// Which instance of a kernel with variants is compiled: a closed form
/// (`#if FAST`, the tetrahedral inverse mean ratio; `#if PLANAR`, the planar
/// inverse mean ratio and condition number under the harmonic template,
/// `planar.wgsl`) or the general corner path for one metric. Each general instance carries only its own metric's
/// code (`#if IMR`, `#if CN`, ...), not a runtime branch over all of them:
/// less code per pipeline (llvmpipe gives all loops of one invocation a
/// shared budget of 65535 iterations, so code that is never run still
/// matters there when it sits in loops: see `shaders/metric/shess.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Form {
    Fast,
    Planar,
    /// A surface mesh's corners (`surface.wgsl`), which only it measures.
    Surface,
    Imr,
    Cn,
    Tmp,
    Rj,
    /// Shape and size against the targets (`smetric::shape_size`).
    Ss,
}

impl Form {
    pub const ALL: [Form; 8] = [
        Form::Fast,
        Form::Planar,
        Form::Surface,
        Form::Imr,
        Form::Cn,
        Form::Tmp,
        Form::Rj,
        Form::Ss,
    ];

    /// The instance the model uniform asks for (`ModelUniform::of`).
    pub(crate) fn of(model: &ModelUniform) -> Form {
        match model.closed {
            CLOSED_TET => return Form::Fast,
            CLOSED_PLANAR => return Form::Planar,
            _ => {}
        }
        Form::general(model)
    }

    /// The instance a context compiles for the model (`GpuOptions::forms`).
    pub(crate) fn on(model: &ModelUniform, ctx: &GpuContext) -> Form {
        match ctx.forms {
            KernelForms::Closed => Form::of(model),
            KernelForms::General => Form::general(model),
            KernelForms::Auto => match Form::of(model) {
                Form::Fast if !ctx.is_software() && !ctx.is_f64() => Form::general(model),
                form => form,
            },
        }
    }

    /// The general instance of the model's metric, closed forms or not; a
    /// surface mesh's, which no general instance measures, is `Surface`.
    pub(crate) fn general(model: &ModelUniform) -> Form {
        if model.closed == CLOSED_SURFACE {
            return Form::Surface;
        }
        match model.metric {
            METRIC_IMR => Form::Imr,
            METRIC_CN => Form::Cn,
            METRIC_TMP => Form::Tmp,
            METRIC_RJ => Form::Rj,
            METRIC_SS => Form::Ss,
            m => unreachable!("metric id {m} has no kernel form"),
        }
    }

    /// Whether `#if name` holds in this instance: its own flag, or
    /// [`GENERAL`] in an instance of the general corner path.
    fn satisfies(self, name: &str) -> bool {
        name == self.flag() || (name == GENERAL && !matches!(self, Form::Fast | Form::Planar | Form::Surface))
    }

    /// The preprocessor flag that `#if NAME` tests; every other form
    /// satisfies `#if !NAME`.
    fn flag(self) -> &'static str {
        match self {
            Form::Fast => "FAST",
            Form::Planar => "PLANAR",
            Form::Surface => "SURFACE",
            Form::Imr => "IMR",
            Form::Cn => "CN",
            Form::Tmp => "TMP",
            Form::Rj => "RJ",
            Form::Ss => "SS",
        }
    }
}

/// The condition every general instance satisfies (`#if GENERAL`): none of
/// the closed forms.
const GENERAL: &str = "GENERAL";

/// Split bindings one kernel may have (`Binding::split`).
pub const MAX_SPLIT: usize = 4;

/// A kernel as compiled: kernels without variants have the one `Form::Fast`
/// instance; `extra[j]` is how many buffers beyond the first the kernel's
/// j-th split binding spans (0 for a mesh whose arrays fit one binding each,
/// which compiles to plain indexing). `window`: the split bindings are bound
/// from part `op.base[j]` on rather than from their first part (one
/// dispatch per window of parts, `GpuBackend::record_windowed`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub kernel: Kernel,
    pub form: Form,
    pub extra: [u8; MAX_SPLIT],
    pub window: bool,
}

impl Kernel {
    pub fn def(self) -> &'static KernelDef {
        &KERNELS
            .iter()
            .chain(TEST_KERNELS)
            .find(|(k, _)| *k == self)
            .expect("every kernel is in a table")
            .1
    }

    pub fn name(self) -> &'static str {
        self.def().stem
    }

    /// Whether the kernel is one of the [`TEST_KERNELS`].
    pub fn is_test_only(self) -> bool {
        TEST_KERNELS.iter().any(|(k, _)| *k == self)
    }

    /// Every kernel, the test-only ones last.
    pub fn all() -> impl Iterator<Item = Kernel> {
        KERNELS.iter().chain(TEST_KERNELS).map(|(k, _)| *k)
    }

    /// The instance for `form`: kernels without variants have only the fast one.
    pub fn with(self, form: Form) -> Variant {
        Variant {
            kernel: self,
            form: if self.def().variants { form } else { Form::Fast },
            extra: [0; MAX_SPLIT],
            window: false,
        }
    }

    /// The one instance of a kernel without variants.
    pub fn plain(self) -> Variant {
        self.with(Form::Fast)
    }
}

impl Variant {
    /// Every compiled instance: each form of a kernel with variants, else one.
    pub fn all() -> impl Iterator<Item = Variant> {
        Kernel::all().flat_map(|k| {
            let forms: &[Form] = if k.def().variants { &Form::ALL } else { &[Form::Fast] };
            forms.iter().map(move |&form| k.with(form))
        })
    }

    pub fn label(self) -> String {
        match self.form {
            Form::Fast => self.kernel.name().to_string(),
            f => format!("{}_{}", self.kernel.name(), f.flag().to_lowercase()),
        }
    }

    /// The full WGSL source of this instance in precision `real`, its split
    /// bindings in one buffer each.
    pub fn compose(self, real: Real) -> String {
        self.compose_split(real, 31)
    }

    /// The full WGSL source with each split binding spread over
    /// `1 + extra[j]` buffers of `2^part_log2` bytes (all but the last full).
    pub fn compose_split(self, real: Real, part_log2: u32) -> String {
        let mut text = String::new();
        let mut seen = HashSet::new();
        preprocess(self.kernel.def().source, self.form, &mut seen, &mut text);
        let def = self.kernel.def();
        let mut out = real.prelude();
        let mut next = def.bindings.len();
        let mut accessors = String::new();
        let splits: Vec<&Binding> = def.bindings.iter().filter(|b| b.split).collect();
        assert!(splits.len() <= MAX_SPLIT, "{}: too many split bindings", def.stem);
        assert!(
            !self.window || def.bindings.contains(&OP),
            "{}: a windowed kernel reads its parts' bases from `op`",
            def.stem
        );
        let mut extra_decl: Vec<String> = vec![String::new(); splits.len()];
        for (j, b) in splits.iter().enumerate() {
            let parts = 1 + self.extra[j] as usize;
            let (ty, size) = match b.elem {
                Elem::Real => ("real", real.size()),
                Elem::U32 => ("u32", 4),
                e => panic!("{}: only array<real> and array<u32> split, not {e:?}", def.stem),
            };
            let access = if b.access == Access::ReadWrite {
                "read_write"
            } else {
                "read"
            };
            for k in 1..parts {
                extra_decl[j].push_str(&format!(
                    "@group(0) @binding({next}) var<storage, {access}> {}_p{k}: array<{ty}>;\n",
                    b.name
                ));
                next += 1;
            }
            let base = self.window.then_some(j);
            accessors.push_str(&split_accessors(b, ty, parts, part_log2 - size.trailing_zeros(), base));
        }
        for line in text.lines() {
            out.push_str(line);
            out.push('\n');
            if line.contains("var<storage")
                && let Some(j) = splits
                    .iter()
                    .position(|b| line.contains(&format!(" {}: array<", b.name)))
            {
                out.push_str(&extra_decl[j]);
            }
        }
        out.push_str(&accessors);
        out
    }
}

/// `NAME_get(i)` (and `NAME_set(i, v)` where writable) over the `parts`
/// buffers of a split binding, `2^shift` elements each: part 0 is the
/// declared `NAME`, part k is `NAME_pk`. With `base = Some(j)` the buffers
/// bound are parts `op.base[j]` on of the array, and `i` must fall in them.
fn split_accessors(b: &Binding, ty: &str, parts: usize, shift: u32, base: Option<usize>) -> String {
    let n = b.name;
    let part = |k: usize| if k == 0 { n.to_string() } else { format!("{n}_p{k}") };
    let mut s = String::new();
    let writable = b.access == Access::ReadWrite;
    let mask = (1u64 << shift) - 1;
    if parts == 1 {
        // one part, the whole array or (windowed) the one the index falls in
        let at = if base.is_some() {
            format!("i & {mask}u")
        } else {
            "i".into()
        };
        s.push_str(&format!("fn {n}_get(i: u32) -> {ty} {{ return {n}[{at}]; }}\n"));
        if writable {
            s.push_str(&format!("fn {n}_set(i: u32, v: {ty}) {{ {n}[{at}] = v; }}\n"));
        }
        return s;
    }
    let p = match base {
        Some(j) => format!("(i >> {shift}u) - op.base[{j}]"),
        None => format!("i >> {shift}u"),
    };
    let head = format!("    let p = {p};\n    let j = i & {mask}u;\n");
    s.push_str(&format!("fn {n}_get(i: u32) -> {ty} {{\n{head}"));
    for k in 0..parts - 1 {
        s.push_str(&format!("    if p == {k}u {{ return {}[j]; }}\n", part(k)));
    }
    s.push_str(&format!("    return {}[j];\n}}\n", part(parts - 1)));
    if writable {
        s.push_str(&format!("fn {n}_set(i: u32, v: {ty}) {{\n{head}"));
        for k in 0..parts - 1 {
            s.push_str(&format!("    if p == {k}u {{ {}[j] = v; return; }}\n", part(k)));
        }
        s.push_str(&format!("    {}[j] = v;\n}}\n", part(parts - 1)));
    }
    s
}

/// Appends `src` to `out` with every `#import name` replaced by that shared
/// file (once per kernel, imports first), keeping `#if NAME` / `#if !NAME`
/// ... `#else` ... `#endif` blocks according to `form` (NAME one of FAST,
/// PLANAR, SURFACE, IMR, CN, TMP, RJ, SS, or GENERAL: any of the general
/// instances).
fn preprocess(src: &str, form: Form, seen: &mut HashSet<&'static str>, out: &mut String) {
    // one entry per open #if: is its current branch kept?
    let mut keep: Vec<bool> = Vec::new();
    for line in src.lines() {
        let t = line.trim();
        if let Some(cond) = t.strip_prefix("#if ") {
            let (negated, name) = match cond.trim().strip_prefix('!') {
                Some(n) => (true, n.trim()),
                None => (false, cond.trim()),
            };
            assert!(
                name == GENERAL || Form::ALL.iter().any(|f| f.flag() == name),
                "unknown WGSL condition '{name}'"
            );
            keep.push(form.satisfies(name) != negated);
            continue;
        }
        match t {
            "#else" => {
                let k = keep.last_mut().expect("#else without #if");
                *k = !*k;
                continue;
            }
            "#endif" => {
                keep.pop().expect("#endif without #if");
                continue;
            }
            _ => {}
        }
        if keep.iter().any(|k| !k) {
            continue;
        }
        if let Some(name) = t.strip_prefix("#import ") {
            let name = name.trim();
            let (key, text) = SHARED
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap_or_else(|| panic!("unknown WGSL import '{name}'"));
            if seen.insert(key) {
                preprocess(text, form, seen, out);
            }
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert!(keep.is_empty(), "#if without #endif");
}

/// Checks a kernel's declared bindings against naga's reflection of its
/// composed WGSL: names, address spaces and element types, in order.
pub fn check_bindings_reflect(declared: &[Binding], module: &naga::Module) -> Result<(), String> {
    use naga::{AddressSpace, Scalar, ScalarKind, StorageAccess, TypeInner, VectorSize};
    let mut found: Vec<(u32, &naga::GlobalVariable)> = Vec::new();
    for (_, g) in module.global_variables.iter() {
        if let Some(b) = &g.binding {
            if b.group != 0 {
                return Err(format!(
                    "'{}' is in group {}",
                    g.name.as_deref().unwrap_or("?"),
                    b.group
                ));
            }
            found.push((b.binding, g));
        }
    }
    found.sort_by_key(|(i, _)| *i);
    if found.len() != declared.len() {
        return Err(format!(
            "{} bindings in the WGSL, {} declared",
            found.len(),
            declared.len()
        ));
    }
    let is_real = |s: &Scalar| s.kind == ScalarKind::Float;
    for (k, ((index, g), d)) in found.iter().zip(declared).enumerate() {
        let name = g.name.as_deref().unwrap_or("?");
        if *index != k as u32 {
            return Err(format!("binding {k} is missing (next is {index})"));
        }
        if name != d.name {
            return Err(format!(
                "binding {k} is '{name}' in the WGSL, '{}' in the table",
                d.name
            ));
        }
        let space_ok = match (d.access, g.space) {
            (Access::Uniform | Access::Op, AddressSpace::Uniform) => true,
            (Access::Read, AddressSpace::Storage { access }) => access == StorageAccess::LOAD,
            (Access::ReadWrite, AddressSpace::Storage { access }) => {
                access == StorageAccess::LOAD | StorageAccess::STORE
            }
            _ => false,
        };
        if !space_ok {
            return Err(format!(
                "binding {k} ('{name}'): {:?} in the WGSL, {:?} in the table",
                g.space, d.access
            ));
        }
        let ty = &module.types[g.ty];
        let elem_ok = match (&ty.inner, d.elem) {
            (TypeInner::Array { base, .. }, e) => match (&module.types[*base].inner, e) {
                (TypeInner::Scalar(s), Elem::Real) => is_real(s),
                (TypeInner::Scalar(s), Elem::U32) => *s == Scalar::U32,
                (
                    TypeInner::Vector {
                        size: VectorSize::Quad,
                        scalar,
                    },
                    Elem::Vec4,
                ) => is_real(scalar),
                _ => false,
            },
            (TypeInner::Struct { .. }, Elem::Struct(n)) => ty.name.as_deref() == Some(n),
            (
                TypeInner::Vector {
                    size: VectorSize::Quad,
                    scalar,
                },
                Elem::Vec4,
            ) => is_real(scalar),
            _ => false,
        };
        if !elem_ok {
            return Err(format!(
                "binding {k} ('{name}'): {:?} in the WGSL, {:?} in the table",
                ty.inner, d.elem
            ));
        }
    }
    Ok(())
}

/// Checks that the composed module's shared constants have Rust's values.
pub fn check_constants(module: &naga::Module, expected: &[(&str, u32)]) -> Result<(), String> {
    for &(name, value) in expected {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .ok_or_else(|| format!("constant {name} is not in the WGSL"))?;
        let got = match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v,
            ref e => return Err(format!("constant {name} is {e:?}, not a u32 literal")),
        };
        if got != value {
            return Err(format!("constant {name} is {got} in the WGSL, {value} in Rust"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::gpu::layout::PRELUDE_CONSTANTS;

    fn parse(v: Variant, real: Real) -> naga::Module {
        let src = v.compose(real);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{} ({real:?}) does not parse:\n{}", v.label(), e.emit_to_string(&src)));
        let mut caps = naga::valid::Capabilities::default();
        if real == Real::F64 {
            caps |= naga::valid::Capabilities::FLOAT64;
        }
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&module)
            .unwrap_or_else(|e| {
                panic!(
                    "{} ({real:?}) does not validate:\n{}",
                    v.label(),
                    e.emit_to_string(&src)
                )
            });
        module
    }

    #[test]
    fn every_kernel_validates_in_both_precisions_with_the_table_bindings() {
        for v in Variant::all() {
            for real in [Real::F32, Real::F64] {
                let m = parse(v, real);
                let ep = m
                    .entry_points
                    .iter()
                    .find(|e| e.name == "main")
                    .unwrap_or_else(|| panic!("{} has no entry point main", v.label()));
                assert_eq!(
                    ep.workgroup_size,
                    [super::super::buffers::WORKGROUP, 1, 1],
                    "{}",
                    v.label()
                );
                check_bindings_reflect(v.kernel.def().bindings, &m)
                    .unwrap_or_else(|e| panic!("{} ({real:?}): {e}", v.label()));
                check_constants(&m, PRELUDE_CONSTANTS).unwrap_or_else(|e| panic!("{}: {e}", v.label()));
            }
        }
    }

    fn validate_source(src: &str, real: Real) -> naga::Module {
        let m = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
        let mut caps = naga::valid::Capabilities::default();
        if real == Real::F64 {
            caps |= naga::valid::Capabilities::FLOAT64;
        }
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&m)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
        m
    }

    #[test]
    fn windowed_bindings_index_from_their_base_part() {
        for real in [Real::F32, Real::F64] {
            let mut v = Kernel::HessianGather.plain();
            v.extra = [0, 0, 2, 0];
            v.window = true;
            let src = v.compose_split(real, 8);
            validate_source(&src, real);
            let shift = 8 - real.size().trailing_zeros();
            // elem (the third split binding) spans three parts from op.base[2]
            assert!(src.contains(&format!("let p = (i >> {shift}u) - op.base[2];")), "{src}");
            // a one-part window still finds the element within its part
            assert!(src.contains("return contrib_offsets[i & 63u];"), "{src}");
            assert!(!src.contains("op.base[0]"));
        }
    }

    #[test]
    fn split_bindings_validate_with_their_extra_parts_after_the_table() {
        for real in [Real::F32, Real::F64] {
            let mut v = Kernel::HessianGather.plain();
            v.extra = [1, 2, 3, 2];
            let src = v.compose_split(real, 8);
            let m = validate_source(&src, real);
            let bound: Vec<(u32, String)> = m
                .global_variables
                .iter()
                .filter_map(|(_, g)| Some((g.binding.as_ref()?.binding, g.name.clone()?)))
                .collect();
            // the table's 5, then 1 + 2 + 3 + 2 extra parts in table order
            assert_eq!(bound.len(), 13);
            assert!(bound.contains(&(5, "contrib_offsets_p1".into())), "{bound:?}");
            assert!(bound.contains(&(12, "blocks_p2".into())), "{bound:?}");
            // 256-byte parts: 64 u32s, 256 / size reals
            let shift = 8 - real.size().trailing_zeros();
            assert!(src.contains(&format!("let p = i >> {shift}u;")));
            assert!(src.contains("let p = i >> 6u;"));
            assert!(src.contains("fn blocks_set("));
            assert!(!src.contains("fn elem_set("));
        }
    }

    #[test]
    fn a_deliberate_binding_mismatch_is_caught() {
        let m = parse(Kernel::Axpby.plain(), Real::F32);
        let good = Kernel::Axpby.def().bindings;
        assert!(check_bindings_reflect(good, &m).is_ok());
        let mut wrong_access = good.to_vec();
        wrong_access[3].access = Access::Read;
        assert!(check_bindings_reflect(&wrong_access, &m).unwrap_err().contains("'y'"));
        let mut wrong_name = good.to_vec();
        wrong_name[2].name = "z";
        assert!(check_bindings_reflect(&wrong_name, &m).is_err());
        let mut wrong_elem = good.to_vec();
        wrong_elem[2].elem = Elem::U32;
        assert!(check_bindings_reflect(&wrong_elem, &m).is_err());
        assert!(check_bindings_reflect(&good[..3], &m).is_err());
    }

    #[test]
    fn bindings_are_matched_by_name_in_any_order() {
        let def = Kernel::Axpby.def();
        let named = [("y", 3), ("op", 0), ("x", 2), ("scalars", 1)];
        assert_eq!(def.in_binding_order(&named), vec![0, 1, 2, 3]);
        let wrong = |named: &[(&str, i32)]| {
            let named = named.to_vec();
            std::panic::catch_unwind(move || def.in_binding_order(&named))
                .unwrap_err()
                .downcast::<String>()
                .map(|s| *s)
                .unwrap_or_default()
        };
        // a misspelt name, a binding given twice (so another is missing), one missing
        assert!(wrong(&[("y", 3), ("op", 0), ("z", 2), ("scalars", 1)]).contains("nothing bound to 'x'"));
        assert!(wrong(&[("y", 3), ("op", 0), ("y", 2), ("scalars", 1)]).contains("nothing bound to 'x'"));
        assert!(wrong(&[("y", 3), ("op", 0), ("x", 2)]).contains("axpby: binds"));
        // the test-only kernels are no part of the backend's table
        assert!(Kernel::CbrtEval.is_test_only() && Kernel::MeanRatioEval.is_test_only());
        assert!(KERNELS.iter().all(|(k, _)| !k.is_test_only()));
        assert_eq!(Kernel::all().count(), KERNELS.len() + TEST_KERNELS.len());
    }

    #[test]
    fn a_deliberate_constant_mismatch_is_caught() {
        let m = parse(Kernel::Objective.with(Form::Cn), Real::F64);
        assert!(check_constants(&m, &[("ELEM_STRIDE", 102)]).is_ok());
        assert!(
            check_constants(&m, &[("ELEM_STRIDE", 101)])
                .unwrap_err()
                .contains("ELEM_STRIDE")
        );
    }

    #[test]
    fn shared_constants_are_defined_only_in_rust() {
        // a WGSL file redefining one would clash with Rust's value; the
        // prelude is the only definition
        for (_, def) in KERNELS.iter().chain(TEST_KERNELS) {
            for (name, _) in PRELUDE_CONSTANTS {
                assert!(
                    !def.source.contains(&format!("const {name}:")),
                    "{} defines {name}",
                    def.stem
                );
            }
        }
        for (file, text) in SHARED {
            for (name, _) in PRELUDE_CONSTANTS {
                assert!(!text.contains(&format!("const {name}:")), "{file} defines {name}");
            }
        }
    }

    #[test]
    fn struct_layouts_match_the_rust_mirrors() {
        use crate::backend::gpu::layout::{ModelUniform, Op, Sizes};
        for real in [Real::F32, Real::F64] {
            let m = parse(Kernel::Objective.with(Form::Cn), real);
            let find = |m: &naga::Module, name: &str| -> (Vec<naga::StructMember>, usize) {
                let (_, ty) = m.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).unwrap();
                match &ty.inner {
                    naga::TypeInner::Struct { members, span } => (members.clone(), *span as usize),
                    _ => unreachable!(),
                }
            };
            let (members, span) = find(&m, "Op");
            assert_eq!(span, Op::size(real), "{real:?}");
            let coef = members.iter().find(|m| m.name.as_deref() == Some("coef")).unwrap();
            assert_eq!(coef.offset as usize, Op::HEADER_BYTES);
            let (members, span) = find(&m, "Model");
            assert_eq!(span, ModelUniform::size(real), "{real:?}");
            let eps = members.iter().find(|m| m.name.as_deref() == Some("eps")).unwrap();
            assert_eq!(eps.offset as usize, ModelUniform::HEADER_BYTES);
            let m2 = parse(Kernel::CbrtEval.plain(), real);
            assert_eq!(find(&m2, "Sizes").1, std::mem::size_of::<Sizes>());
        }
    }

    #[test]
    fn closed_form_instances_are_compiled_wherever_the_cpu_takes_closed_forms() {
        use crate::metric::corner_model::{Model, Template};
        use crate::metric::smetric::MetricKind;
        let metrics = [
            MetricKind::InverseMeanRatio,
            MetricKind::ConditionNumber,
            MetricKind::TargetShapeSize,
            MetricKind::ConditionNumberPaper,
            MetricKind::ReferenceJacobian,
            MetricKind::ShapeSize,
        ];
        let mut planar = 0;
        for metric in metrics {
            for template in [Template::Harmonic, Template::Average] {
                for eps in [0.0, 1e-3] {
                    for dim in [2, 3] {
                        let m = Model { metric, template, eps };
                        let form = Form::of(&ModelUniform::from_model(&m, dim));
                        assert_eq!(form == Form::Fast, m.fast(dim), "{m:?} in {dim}D: {form:?}");
                        assert_eq!(form == Form::Planar, m.planar(dim), "{m:?} in {dim}D: {form:?}");
                        planar += m.planar(dim) as usize;
                    }
                }
            }
        }
        assert_eq!(planar, 3, "imr, cn and cn-paper under the harmonic template");
        // only the planar instance carries the planar forms
        for v in Variant::all() {
            let src = v.compose(Real::F64);
            assert_eq!(
                src.contains("fn planar_parts("),
                v.form == Form::Planar,
                "{}",
                v.label()
            );
            assert_eq!(
                src.contains("fn surface_parts("),
                v.form == Form::Surface,
                "{}",
                v.label()
            );
        }
    }

    #[test]
    fn imports_are_included_once() {
        let src = Kernel::Bcd.with(Form::Fast).compose(Real::F32);
        assert_eq!(src.matches("fn det3(").count(), 1);
        assert!(!src.contains("#import"));
    }

    #[test]
    fn one_workgroup_reduction() {
        // the tree reduction lives in common/tree.wgsl alone
        for (_, def) in KERNELS.iter().chain(TEST_KERNELS) {
            assert!(!def.source.contains("stride >>= 1u"), "{} has its own tree", def.stem);
        }
    }

    #[test]
    fn every_kernel_has_a_same_stem_cpu_twin_and_tests() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let tests: String = ["tests/gpu/kernels.rs", "tests/gpu/gpu_matches_cpu.rs"]
            .iter()
            .map(|f| std::fs::read_to_string(root.join(f)).unwrap())
            .collect();
        for (_, def) in KERNELS.iter().chain(TEST_KERNELS) {
            let twin = root.join(format!("src/backend/cpu/{}.rs", def.stem));
            assert!(twin.exists(), "{} has no CPU twin at {}", def.stem, twin.display());
            for p in ["f32", "f64"] {
                let name = format!("fn {}_matches_cpu_{p}", def.stem);
                let by_macro = format!("{}_matches_cpu_{p}(", def.stem);
                assert!(
                    tests.contains(&name) || tests.contains(&by_macro),
                    "{} has no test {}_matches_cpu_{p}",
                    def.stem,
                    def.stem
                );
            }
        }
    }
}
