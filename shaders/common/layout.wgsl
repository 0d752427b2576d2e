// Buffer layouts shared by the kernels; the Rust mirrors are in
// src/backend/gpu/layout.rs.

// B of the reference shape (row k = how vertex k enters S) and the line search.
struct Shape {
    // b[k].xyz, w unused
    b: array<vec4<real>, 4>,
    // x = beta, y = sigma, z = 1 / number of elements, w unused
    ls: vec4<real>,
}

struct Sizes {
    // elements (test kernels) or corners (solver kernels)
    n_elements: u32,
    n_free: u32,
    n_obj_partials: u32,
    n_vert_partials: u32,
}

// Workgroups are dispatched in 2D (at most 65,535 per dimension).
fn linear_group(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}

fn shape_b(s: Shape) -> array<vec3<real>, 4> {
    return array<vec3<real>, 4>(s.b[0].xyz, s.b[1].xyz, s.b[2].xyz, s.b[3].xyz);
}

// Per-dispatch parameters, one record per recorded operation in a uniform
// buffer bound at a dynamic offset; what each field means is stated in the
// kernel that reads it. A slot field equal to NONE means "no slot".
// Rust mirror: `layout::Op` (the constants NONE, N_SLOTS, CORNER_STRIDE,
// ELEM_STRIDE, METRIC_* and TEMPLATE_* come from Rust in the prelude).
struct Op {
    n: u32,
    slot: u32,
    aux: u32,
    aux2: u32,
    aux3: u32,
    guard: u32,
    flags: u32,
    offset: u32,
    a_num: u32,
    a_den: u32,
    b_num: u32,
    b_den: u32,
    // the first part bound of each split binding (in table order) when the
    // kernel runs in windows (`GpuBackend::record_windowed`); 0 otherwise
    base: vec4<u32>,
    // x = scale of coefficient a, y = scale of coefficient b
    coef: vec4<real>,
}

// Metric dimension and what turns a corner's S into its term; `closed` names
// the closed forms the CPU takes (the tetrahedral inverse mean ratio of
// `mean_ratio.wgsl`, the planar ones of `planar.wgsl`), which the compiled
// instance already is (`shader::Form`), so no kernel reads it. Rust mirror:
// `layout::ModelUniform`.
struct Model {
    dim: u32,
    metric: u32,
    tmpl: u32,
    closed: u32,
    // untangling's regularisation (`Model::eps`); 0 = the barrier metric
    eps: real,
}

// `shapes`-indexed B tables: rows b_k in .xyz (k = 0..3), the corner's weight
// in F in b_0.w. Corners hold 4 vertex ids then that index (CORNER_STRIDE).
// The Newton assembly buffer holds per corner the gradient (12 reals, vertex
// k at 3 k) then the upper Hessian blocks (k, l), k <= l, 9 reals each,
// row-major (ELEM_STRIDE).

// Position of block (k, l), k <= l, among the 10 upper blocks.
fn upper_block(k: u32, l: u32) -> u32 {
    return k * (9u - k) / 2u + (l - k);
}
