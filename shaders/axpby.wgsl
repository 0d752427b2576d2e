// y = a x + b y on vec3 arrays, a and b slot expressions (`coef`), skipped
// unless the guard slot is > 0; b = 0 overwrites y without reading it, and
// flags bit 0 says x is y (bound once, as y). CPU twin: backend/cpu/axpby.rs.

#import layout

// n = vector length in vec3s; a = coef.x * a_num / a_den, b likewise
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> scalars: array<real>;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read_write> y: array<real>;

#import slots

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i >= op.n || !guard_passes(op.guard) {
        return;
    }
    let a = coef(op.coef.x, op.a_num, op.a_den);
    let b = coef(op.coef.y, op.b_num, op.b_den);
    let aliased = (op.flags & 1u) != 0u;
    for (var k = 3u * i; k < 3u * i + 3u; k++) {
        var xk = real(0.0);
        if aliased {
            xk = y_get(k);
        } else {
            xk = x_get(k);
        }
        if b == real(0.0) {
            y_set(k, a * xk);
        } else {
            y_set(k, a * xk + b * y_get(k));
        }
    }
}
