// The block-Jacobi preconditioner's factors, one thread per block row: an
// LDL^T of the diagonal block as (l10, l20, l21, 1/d0, 1/d1, 1/d2); a block
// that is not positive definite becomes its scaled identity.
// CPU twin: backend/cpu/block_jacobi.rs (`ldlt`, same order).

#import layout

// n = number of block rows
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> blocks: array<real>;
@group(0) @binding(2) var<storage, read> diag: array<u32>;
@group(0) @binding(3) var<storage, read_write> factors: array<real>;

fn factor(i: u32) {
    let h = 9u * diag[i];
    let d0 = blocks_get(h);
    let l10 = blocks_get(h + 3u) / d0;
    let l20 = blocks_get(h + 6u) / d0;
    let d1 = blocks_get(h + 4u) - l10 * l10 * d0;
    let l21 = (blocks_get(h + 7u) - l20 * l10 * d0) / d1;
    let d2 = blocks_get(h + 8u) - l20 * l20 * d0 - l21 * l21 * d1;
    let f = 6u * i;
    if d0 > real(0.0) && d1 > real(0.0) && d2 > real(0.0) && abs(l21) <= REAL_MAX {
        factors_set(f, l10);
        factors_set(f + 1u, l20);
        factors_set(f + 2u, l21);
        factors_set(f + 3u, real(1.0) / d0);
        factors_set(f + 4u, real(1.0) / d1);
        factors_set(f + 5u, real(1.0) / d2);
    } else {
        let s = (abs(blocks_get(h)) + abs(blocks_get(h + 4u)) + abs(blocks_get(h + 8u))) / real(3.0);
        var inv = real(1.0);
        if s > real(0.0) {
            inv = real(1.0) / s;
        }
        factors_set(f, real(0.0));
        factors_set(f + 1u, real(0.0));
        factors_set(f + 2u, real(0.0));
        factors_set(f + 3u, inv);
        factors_set(f + 4u, inv);
        factors_set(f + 5u, inv);
    }
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i < op.n {
        factor(i);
    }
}
