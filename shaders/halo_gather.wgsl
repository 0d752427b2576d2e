// The send side of a halo exchange: the listed vec3 entries of an array
// (positions by device vertex, or a vector by free index) packed in list
// order, so a halo leaves the device in one read-back of n entries.
// CPU twin: backend/cpu/halo_gather.rs.

#import layout

// n = entries in the list
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> idx: array<u32>;
@group(0) @binding(2) var<storage, read> src: array<real>;
@group(0) @binding(3) var<storage, read_write> dst: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = linear_group(wid, nwg) * 64u + lid;
    if t >= op.n {
        return;
    }
    let i = idx[t];
    for (var k = 0u; k < 3u; k++) {
        dst[3u * t + k] = src_get(3u * i + k);
    }
}
