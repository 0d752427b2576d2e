//! WGSL composition: every kernel is one file in `shaders/` written against
//! the scalar alias `real`; a tiny `#import name` preprocessor (vello-style)
//! pulls in the shared files and a prelude instantiates the precision.

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

    fn prelude(self) -> &'static str {
        match self {
            Real::F32 => "alias real = f32;\nconst REAL_MAX: real = 3.40282347e38;\n",
            Real::F64 => "alias real = f64;\nconst REAL_MAX: real = 1.7976931348623157e308;\n",
        }
    }
}

/// Shared WGSL pulled in by `#import name`.
const SHARED: &[(&str, &str)] = &[
    ("cbrt", include_str!("../../../shaders/common/cbrt.wgsl")),
    ("mat3", include_str!("../../../shaders/common/mat3.wgsl")),
    ("layout", include_str!("../../../shaders/common/layout.wgsl")),
    ("corners", include_str!("../../../shaders/common/corners.wgsl")),
    ("mean_ratio", include_str!("../../../shaders/metric/mean_ratio.wgsl")),
    ("condition", include_str!("../../../shaders/metric/condition.wgsl")),
    ("target", include_str!("../../../shaders/metric/target.wgsl")),
    ("smetric", include_str!("../../../shaders/metric/smetric.wgsl")),
    (
        "corner_model",
        include_str!("../../../shaders/metric/corner_model.wgsl"),
    ),
];

/// The compute kernels, one per file, entry point `main`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    MeanRatioEval,
    Objective,
    VertexGradient,
    Reduce,
    Bcd,
    CbrtEval,
    HessianAssemble,
    HessianGather,
    GradientGather,
    BsrSpmv,
    BlockJacobi,
    Vector,
    Dot,
    DotFinal,
    LineSearch,
    /// The corner kernels again, for any metric, template and dimension: the
    /// plain ones are the tetrahedral inverse mean ratio's closed forms only,
    /// because lavapipe runs a kernel carrying the general path hundreds of
    /// times slower even when a uniform branch skips it.
    BcdGeneral,
    ObjectiveGeneral,
    HessianAssembleGeneral,
}

impl Kernel {
    pub const ALL: [Kernel; 18] = [
        Kernel::MeanRatioEval,
        Kernel::Objective,
        Kernel::VertexGradient,
        Kernel::Reduce,
        Kernel::Bcd,
        Kernel::CbrtEval,
        Kernel::HessianAssemble,
        Kernel::HessianGather,
        Kernel::GradientGather,
        Kernel::BsrSpmv,
        Kernel::BlockJacobi,
        Kernel::Vector,
        Kernel::Dot,
        Kernel::DotFinal,
        Kernel::LineSearch,
        Kernel::BcdGeneral,
        Kernel::ObjectiveGeneral,
        Kernel::HessianAssembleGeneral,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Kernel::MeanRatioEval => "mean_ratio_eval",
            Kernel::Objective => "objective",
            Kernel::VertexGradient => "vertex_gradient",
            Kernel::Reduce => "reduce",
            Kernel::Bcd => "bcd",
            Kernel::CbrtEval => "cbrt_eval",
            Kernel::HessianAssemble => "hessian_assemble",
            Kernel::HessianGather => "hessian_gather",
            Kernel::GradientGather => "gradient_gather",
            Kernel::BsrSpmv => "bsr_spmv",
            Kernel::BlockJacobi => "block_jacobi",
            Kernel::Vector => "vector",
            Kernel::Dot => "dot",
            Kernel::DotFinal => "dot_final",
            Kernel::LineSearch => "line_search",
            Kernel::BcdGeneral => "bcd_general",
            Kernel::ObjectiveGeneral => "objective_general",
            Kernel::HessianAssembleGeneral => "hessian_assemble_general",
        }
    }

    fn source(self) -> &'static str {
        match self {
            Kernel::MeanRatioEval => include_str!("../../../shaders/mean_ratio_eval.wgsl"),
            Kernel::Objective | Kernel::ObjectiveGeneral => include_str!("../../../shaders/objective.wgsl"),
            Kernel::VertexGradient => include_str!("../../../shaders/vertex_gradient.wgsl"),
            Kernel::Reduce => include_str!("../../../shaders/reduce.wgsl"),
            Kernel::Bcd | Kernel::BcdGeneral => include_str!("../../../shaders/bcd.wgsl"),
            Kernel::CbrtEval => include_str!("../../../shaders/cbrt_eval.wgsl"),
            Kernel::HessianAssemble | Kernel::HessianAssembleGeneral => {
                include_str!("../../../shaders/hessian_assemble.wgsl")
            }
            Kernel::HessianGather => include_str!("../../../shaders/hessian_gather.wgsl"),
            Kernel::GradientGather => include_str!("../../../shaders/gradient_gather.wgsl"),
            Kernel::BsrSpmv => include_str!("../../../shaders/bsr_spmv.wgsl"),
            Kernel::BlockJacobi => include_str!("../../../shaders/block_jacobi.wgsl"),
            Kernel::Vector => include_str!("../../../shaders/vector.wgsl"),
            Kernel::Dot => include_str!("../../../shaders/dot.wgsl"),
            Kernel::DotFinal => include_str!("../../../shaders/dot_final.wgsl"),
            Kernel::LineSearch => include_str!("../../../shaders/line_search.wgsl"),
        }
    }

    /// Whether `#if FAST` blocks are kept (the tetrahedral closed forms).
    pub fn fast(self) -> bool {
        !matches!(
            self,
            Kernel::BcdGeneral | Kernel::ObjectiveGeneral | Kernel::HessianAssembleGeneral
        )
    }

    /// The variant of a corner kernel for a problem's model.
    pub fn for_model(self, fast: bool) -> Kernel {
        match (self, fast) {
            (Kernel::Bcd, false) => Kernel::BcdGeneral,
            (Kernel::Objective, false) => Kernel::ObjectiveGeneral,
            (Kernel::HessianAssemble, false) => Kernel::HessianAssembleGeneral,
            (k, _) => k,
        }
    }

    /// The full WGSL source of this kernel in precision `real`.
    pub fn compose(self, real: Real) -> String {
        let mut out = String::from(real.prelude());
        let mut seen = HashSet::new();
        preprocess(self.source(), self.fast(), &mut seen, &mut out);
        out
    }
}

/// Appends `src` to `out` with every `#import name` replaced by that shared
/// file (once per kernel, imports first), keeping `#if FAST` / `#if !FAST`
/// ... `#else` ... `#endif` blocks according to `fast`.
fn preprocess(src: &str, fast: bool, seen: &mut HashSet<&'static str>, out: &mut String) {
    // one entry per open #if: is its current branch kept?
    let mut keep: Vec<bool> = Vec::new();
    for line in src.lines() {
        let t = line.trim();
        match t {
            "#if FAST" | "#if !FAST" => {
                keep.push((t == "#if FAST") == fast);
                continue;
            }
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
                preprocess(text, fast, seen, out);
            }
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validate(k: Kernel, real: Real) -> naga::Module {
        let src = k.compose(real);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{} ({real:?}) does not parse:\n{}", k.name(), e.emit_to_string(&src)));
        let mut caps = naga::valid::Capabilities::default();
        if real == Real::F64 {
            caps |= naga::valid::Capabilities::FLOAT64;
        }
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{} ({real:?}) does not validate:\n{}", k.name(), e.emit_to_string(&src)));
        module
    }

    #[test]
    fn every_kernel_validates_in_both_precisions() {
        for k in Kernel::ALL {
            for real in [Real::F32, Real::F64] {
                let m = validate(k, real);
                let ep = m
                    .entry_points
                    .iter()
                    .find(|e| e.name == "main")
                    .unwrap_or_else(|| panic!("{} has no entry point main", k.name()));
                assert_eq!(ep.workgroup_size, [64, 1, 1], "{}", k.name());
                // bindings are numbered 0.. without gaps, all in group 0
                let mut bindings: Vec<u32> = m
                    .global_variables
                    .iter()
                    .filter_map(|(_, g)| g.binding.as_ref())
                    .map(|b| {
                        assert_eq!(b.group, 0, "{}", k.name());
                        b.binding
                    })
                    .collect();
                bindings.sort_unstable();
                assert_eq!(bindings, (0..bindings.len() as u32).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn imports_are_included_once() {
        let src = Kernel::Bcd.compose(Real::F32);
        assert_eq!(src.matches("fn det3(").count(), 1);
        assert!(!src.contains("#import"));
    }
}
