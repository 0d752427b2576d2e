// y = A x for the symmetric block matrix stored with both triangles, one
// thread per block row, so no two threads write one entry.
// CPU twin: backend/cpu/bsr_spmv.rs (same sum order).

#import layout

// n = number of block rows
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> row_offsets: array<u32>;
@group(0) @binding(2) var<storage, read> cols: array<u32>;
@group(0) @binding(3) var<storage, read> blocks: array<real>;
@group(0) @binding(4) var<storage, read> x: array<real>;
@group(0) @binding(5) var<storage, read_write> y: array<real>;

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
    var acc = vec3<real>(real(0.0));
    for (var s = row_offsets[i]; s < row_offsets[i + 1u]; s++) {
        let j = cols_get(s);
        let xj = vec3<real>(x_get(3u * j), x_get(3u * j + 1u), x_get(3u * j + 2u));
        for (var r = 0u; r < 3u; r++) {
            let b = 9u * s + 3u * r;
            acc[r] += blocks_get(b) * xj[0] + blocks_get(b + 1u) * xj[1] + blocks_get(b + 2u) * xj[2];
        }
    }
    y_set(3u * i, acc[0]);
    y_set(3u * i + 1u, acc[1]);
    y_set(3u * i + 2u, acc[2]);
}
