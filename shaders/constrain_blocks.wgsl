// One thread per block row (free vertex i): H_ij <- P_i H_ij P_j, and
// I - P_i added to the diagonal block, the Hessian restricted to the
// directions the vertices may move in. CPU twin: backend/cpu/constrain_blocks.rs.

#import layout

// n = number of free vertices (block rows)
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> slide_real: array<real>;
@group(0) @binding(2) var<storage, read> slide_idx: array<u32>;
@group(0) @binding(3) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(4) var<storage, read> row_offsets: array<u32>;
@group(0) @binding(5) var<storage, read> cols: array<u32>;
@group(0) @binding(6) var<storage, read> diag: array<u32>;
@group(0) @binding(7) var<storage, read_write> blocks: array<real>;

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
    let pi = projector(free_vertices[i]);
    for (var s = row_offsets[i]; s < row_offsets[i + 1u]; s++) {
        let pj = projector(free_vertices[cols_get(s)]);
        var b = mat3x3<real>();
        for (var r = 0u; r < 3u; r++) {
            for (var q = 0u; q < 3u; q++) {
                b[r][q] = blocks_get(9u * s + 3u * r + q);
            }
        }
        var c = mul3x3(pi, mul3x3(b, pj));
        if s == diag[i] {
            for (var r = 0; r < 3; r++) {
                for (var q = 0; q < 3; q++) {
                    var e = real(0.0);
                    if r == q {
                        e = real(1.0);
                    }
                    c[r][q] += e - pi[r][q];
                }
            }
        }
        for (var r = 0u; r < 3u; r++) {
            for (var q = 0u; q < 3u; q++) {
                blocks_set(9u * s + 3u * r + q, c[r][q]);
            }
        }
    }
}
