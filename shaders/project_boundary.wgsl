// One thread per free vertex: a sliding vertex is put at the closest point
// of its candidate primitives of the original boundary (after a trial step).
// CPU twin: backend/cpu/project_boundary.rs (`project`).

#import layout

// n = number of free vertices
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> slide_real: array<real>;
@group(0) @binding(2) var<storage, read> slide_idx: array<u32>;
@group(0) @binding(3) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(4) var<storage, read_write> x: array<real>;

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
    if !slides(v) {
        return;
    }
    let q = project_vertex(v, vec3<real>(x_get(3u * v), x_get(3u * v + 1u), x_get(3u * v + 2u)));
    for (var c = 0u; c < 3u; c++) {
        x_set(3u * v + c, q[c]);
    }
}
