// One thread per free vertex: the gradient y restricted to the directions
// each vertex may move in, y_i <- P_i y_i, with P_i the projector of the
// constraint active at x for y_i (`active_projector`), which is also kept in
// the projector table for `constrain_blocks`. CPU twin:
// backend/cpu/constrain.rs with project_boundary.rs `active_projectors`.

#import layout

// n = number of free vertices
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read_write> slide_real: array<real>;
@group(0) @binding(2) var<storage, read> slide_idx: array<u32>;
@group(0) @binding(3) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(4) var<storage, read> x: array<real>;
@group(0) @binding(5) var<storage, read_write> y: array<real>;

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
    let g = vec3<real>(y_get(3u * i), y_get(3u * i + 1u), y_get(3u * i + 2u));
    let p = active_projector(v, vec3<real>(x_get(3u * v), x_get(3u * v + 1u), x_get(3u * v + 2u)), g);
    for (var r = 0u; r < 3u; r++) {
        for (var c = 0u; c < 3u; c++) {
            slide_real[9u * v + 3u * r + c] = p[r][c];
        }
    }
    let r = mul_vec(p, g);
    for (var c = 0u; c < 3u; c++) {
        y_set(3u * i + c, r[c]);
    }
}
