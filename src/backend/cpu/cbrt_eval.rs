//! CPU twin of `shaders/cbrt_eval.wgsl`: the cube root the f64 kernels seed
//! in f32 and refine; on the CPU, the correctly rounded `f64::cbrt`.

pub fn cbrt_eval(values: &[f64]) -> Vec<f64> {
    values.iter().map(|v| v.cbrt()).collect()
}
