// The one workgroup reduction: every kernel that reduces puts a vec4 per
// thread (sum, min, max, count) and combines them in a fixed tree, so a
// result repeats bit for bit. All 64 threads must call `tree_reduce`
// (it holds barriers); thread 0 gets the workgroup's total.

var<workgroup> tree_wg: array<vec4<real>, 64>;

// The identity of `combine`.
fn tree_zero() -> vec4<real> {
    return vec4<real>(real(0.0), REAL_MAX, -REAL_MAX, real(0.0));
}

fn combine(a: vec4<real>, b: vec4<real>) -> vec4<real> {
    return vec4<real>(a.x + b.x, min(a.y, b.y), max(a.z, b.z), a.w + b.w);
}

fn tree_reduce(lid: u32, v: vec4<real>) -> vec4<real> {
    tree_wg[lid] = v;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lid < stride {
            tree_wg[lid] = combine(tree_wg[lid], tree_wg[lid + stride]);
        }
    }
    workgroupBarrier();
    return tree_wg[0];
}
