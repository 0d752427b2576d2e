// Per workgroup: the tree sum of a_i . b_i over its 64 vec3s and the largest
// b_i . b_i; `dot_final` adds the partials in a fixed order, so a dot product
// repeats bit for bit. CPU twin: `solve::pcg::dot` (same per-vertex product;
// the CPU sums chunks sequentially, so the two differ by rounding only).

#import layout

// n = vector length in vec3s
@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read> a: array<real>;
@group(0) @binding(2) var<storage, read> b: array<real>;
// per workgroup: (sum, max)
@group(0) @binding(3) var<storage, read_write> partials: array<real>;

var<workgroup> sum_wg: array<real, 64>;
var<workgroup> max_wg: array<real, 64>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = linear_group(wid, nwg);
    let i = group * 64u + lid;
    var s = real(0.0);
    var m = real(0.0);
    if i < dims.n {
        let k = 3u * i;
        s = a[k] * b[k] + a[k + 1u] * b[k + 1u] + a[k + 2u] * b[k + 2u];
        m = b[k] * b[k] + b[k + 1u] * b[k + 1u] + b[k + 2u] * b[k + 2u];
    }
    sum_wg[lid] = s;
    max_wg[lid] = m;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lid < stride {
            sum_wg[lid] += sum_wg[lid + stride];
            max_wg[lid] = max(max_wg[lid], max_wg[lid + stride]);
        }
    }
    if lid == 0u && group < (dims.n + 63u) / 64u {
        partials[2u * group] = sum_wg[0];
        partials[2u * group + 1u] = max_wg[0];
    }
}
