// One thread per block of the BSR Hessian: the sum of its element
// contributions, each `corner * 16 + 4 a + b` (device corner, local pair
// (a, b)), listed in ascending device corner order. A pass adds those of the
// corners [aux2, aux3) to what the passes before it stored: one pass over all
// corners, or one per window of the split corner blocks where binding them
// all would pass the device's storage-binding count
// (`GpuBackend::record_windowed`); the windows ascend, so every split adds in
// the one-pass order and gives the same bits.
// CPU twin: backend/cpu/hessian_gather.rs.

#import layout

// n = number of blocks, [aux2, aux3) = the corners of this pass
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> contrib_offsets: array<u32>;
@group(0) @binding(2) var<storage, read> contrib_items: array<u32>;
// weighted per corner (`hessian_assemble.wgsl`)
@group(0) @binding(3) var<storage, read> elem: array<real>;
@group(0) @binding(4) var<storage, read_write> blocks: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let s = linear_group(wid, nwg) * 64u + lid;
    if s >= op.n {
        return;
    }
    var acc: array<real, 9>;
    for (var i = 0u; i < 9u; i++) {
        if op.aux2 == 0u {
            acc[i] = real(0.0);
        } else {
            acc[i] = blocks_get(9u * s + i);
        }
    }
    for (var it = contrib_offsets_get(s); it < contrib_offsets_get(s + 1u); it++) {
        let item = contrib_items_get(it);
        let e = item >> 4u;
        if e < op.aux2 {
            continue;
        }
        if e >= op.aux3 {
            break;
        }
        let a = (item >> 2u) & 3u;
        let b = item & 3u;
        let base = ELEM_STRIDE * e + 12u;
        if a <= b {
            let at = base + 9u * upper_block(a, b);
            for (var i = 0u; i < 9u; i++) {
                acc[i] += elem_get(at + i);
            }
        } else {
            let at = base + 9u * upper_block(b, a);
            for (var i = 0u; i < 3u; i++) {
                for (var q = 0u; q < 3u; q++) {
                    acc[3u * i + q] += elem_get(at + 3u * q + i);
                }
            }
        }
    }
    for (var i = 0u; i < 9u; i++) {
        blocks_set(9u * s + i, acc[i]);
    }
}
