// Per workgroup: the tree sum of a_i . b_i over its 64 vec3s and the largest
// b_i . b_i, as (sum, -, max, -) partials for `reduce`, so a dot product
// repeats bit for bit. CPU twin: backend/cpu/dot.rs (same per-vertex product;
// the CPU sums chunks sequentially, so the two differ by rounding only).

#import layout
#import tree

// n = vector length in vec3s
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> a: array<real>;
@group(0) @binding(2) var<storage, read> b: array<real>;
@group(0) @binding(3) var<storage, read_write> partials: array<vec4<real>>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = linear_group(wid, nwg);
    let i = group * 64u + lid;
    var v = tree_zero();
    if i < op.n {
        let k = 3u * i;
        v.x = a_get(k) * b_get(k) + a_get(k + 1u) * b_get(k + 1u) + a_get(k + 2u) * b_get(k + 2u);
        v.z = b_get(k) * b_get(k) + b_get(k + 1u) * b_get(k + 1u) + b_get(k + 2u) * b_get(k + 2u);
    }
    let total = tree_reduce(lid, v);
    if lid == 0u && group < (op.n + 63u) / 64u {
        partials[group] = total;
    }
}
