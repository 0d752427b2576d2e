// One thread per free vertex: its gradient of F summed over its incident
// corners in ascending device corner order (a gather, so the sum order is
// fixed), from per-corner gradients `aux` reals apart (12 from `objective`,
// ELEM_STRIDE from `hessian_assemble`). A pass adds the corners [aux2, aux3)
// to what the passes before it stored, as in `hessian_gather.wgsl`.
// CPU twin: backend/cpu/gradient_gather.rs.

#import layout

// n = number of free vertices, aux = stride of the per-corner data,
// [aux2, aux3) = the corners of this pass; inc_* sorted by device corner
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(2) var<storage, read> inc_offsets: array<u32>;
@group(0) @binding(3) var<storage, read> inc_items: array<u32>;
// weighted per corner
@group(0) @binding(4) var<storage, read> elem: array<real>;
@group(0) @binding(5) var<storage, read_write> grad: array<real>;

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
    var acc = vec3<real>(real(0.0));
    if op.aux2 != 0u {
        acc = vec3<real>(grad_get(3u * i), grad_get(3u * i + 1u), grad_get(3u * i + 2u));
    }
    for (var it = inc_offsets[v]; it < inc_offsets[v + 1u]; it++) {
        let packed = inc_items_get(it);
        let corner = packed >> 2u;
        if corner < op.aux2 {
            continue;
        }
        if corner >= op.aux3 {
            break;
        }
        let at = op.aux * corner + 3u * (packed & 3u);
        for (var c = 0u; c < 3u; c++) {
            acc[c] += elem_get(at + c);
        }
    }
    for (var c = 0u; c < 3u; c++) {
        grad_set(3u * i + c, acc[c]);
    }
}
