// One thread per free vertex: y_i <- P_i y_i, a free-vertex vector
// restricted to the directions each vertex may move in (the gradient, where
// the boundary slides). CPU twin: backend/cpu/constrain.rs.

#import layout

// n = number of free vertices
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> slide_real: array<real>;
@group(0) @binding(2) var<storage, read> slide_idx: array<u32>;
@group(0) @binding(3) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(4) var<storage, read_write> y: array<real>;

#import boundary

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
    let r = mul_vec(projector(v), vec3<real>(y_get(3u * i), y_get(3u * i + 1u), y_get(3u * i + 2u)));
    for (var c = 0u; c < 3u; c++) {
        y_set(3u * i + c, r[c]);
    }
}
