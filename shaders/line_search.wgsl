// A line-search trial point: trial = x + alpha d at the free vertices, alpha
// a slot expression (the fixed vertices never move, so `trial` keeps them
// from its initial copy of x); `objective` and `reduce` then evaluate it.
// CPU twin: backend/cpu/line_search.rs.

#import layout

// n = number of free vertices; alpha = coef.x * a_num / a_den
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> scalars: array<real>;
@group(0) @binding(2) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(3) var<storage, read> x: array<real>;
@group(0) @binding(4) var<storage, read> d: array<real>;
@group(0) @binding(5) var<storage, read_write> trial: array<real>;

#import slots

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i >= op.n {
        return;
    }
    let v = free_vertices[i];
    let alpha = coef(op.coef.x, op.a_num, op.a_den);
    for (var c = 0u; c < 3u; c++) {
        trial_set(3u * v + c, x_get(3u * v + c) + alpha * d_get(3u * i + c));
    }
}
