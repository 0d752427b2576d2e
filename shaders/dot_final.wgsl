// The final pass of `dot`, in one workgroup: each thread sums a fixed strided
// slice of the partials (compensated, for f32), then a tree; the sum goes to
// scalar slot `slot` and, unless `aux` is 0xffffffff, the max to slot `aux`.
// CPU twin: the chunk sum of `solve::pcg::dot`.

#import layout

// n = vector length in vec3s (ceil(n / 64) partials)
@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read> partials: array<real>;
@group(0) @binding(2) var<storage, read_write> scalars: array<real>;

var<workgroup> sum_wg: array<real, 64>;
var<workgroup> max_wg: array<real, 64>;

@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) lid: u32) {
    let count = (dims.n + 63u) / 64u;
    var sum = real(0.0);
    var comp = real(0.0);
    var m = real(0.0);
    for (var i = lid; i < count; i += 64u) {
        let y = partials[2u * i] - comp;
        let t = sum + y;
        comp = (t - sum) - y;
        sum = t;
        m = max(m, partials[2u * i + 1u]);
    }
    sum_wg[lid] = sum;
    max_wg[lid] = m;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lid < stride {
            sum_wg[lid] += sum_wg[lid + stride];
            max_wg[lid] = max(max_wg[lid], max_wg[lid + stride]);
        }
    }
    if lid == 0u {
        scalars[dims.slot] = sum_wg[0];
        if dims.aux != 0xffffffffu {
            scalars[dims.aux] = max_wg[0];
        }
    }
}
