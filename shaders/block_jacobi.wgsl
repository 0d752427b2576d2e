// Block-Jacobi preconditioner, one thread per block row.
// op 0: LDL^T of the diagonal block into (l10, l20, l21, 1/d0, 1/d1, 1/d2);
//       a block that is not positive definite becomes its scaled identity.
// op 1: y = L^-T D^-1 L^-1 x.
// CPU twin: `solve::pcg::BlockJacobi` (`ldlt` and `apply`, same order).

#import layout

// n = number of block rows, op as above
@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read> blocks: array<real>;
@group(0) @binding(2) var<storage, read> diag: array<u32>;
@group(0) @binding(3) var<storage, read_write> factors: array<real>;
@group(0) @binding(4) var<storage, read> x: array<real>;
@group(0) @binding(5) var<storage, read_write> y: array<real>;

fn factor(i: u32) {
    let h = 9u * diag[i];
    let d0 = blocks[h];
    let l10 = blocks[h + 3u] / d0;
    let l20 = blocks[h + 6u] / d0;
    let d1 = blocks[h + 4u] - l10 * l10 * d0;
    let l21 = (blocks[h + 7u] - l20 * l10 * d0) / d1;
    let d2 = blocks[h + 8u] - l20 * l20 * d0 - l21 * l21 * d1;
    let f = 6u * i;
    if d0 > real(0.0) && d1 > real(0.0) && d2 > real(0.0) && abs(l21) <= REAL_MAX {
        factors[f] = l10;
        factors[f + 1u] = l20;
        factors[f + 2u] = l21;
        factors[f + 3u] = real(1.0) / d0;
        factors[f + 4u] = real(1.0) / d1;
        factors[f + 5u] = real(1.0) / d2;
    } else {
        let s = (abs(blocks[h]) + abs(blocks[h + 4u]) + abs(blocks[h + 8u])) / real(3.0);
        var inv = real(1.0);
        if s > real(0.0) {
            inv = real(1.0) / s;
        }
        factors[f] = real(0.0);
        factors[f + 1u] = real(0.0);
        factors[f + 2u] = real(0.0);
        factors[f + 3u] = inv;
        factors[f + 4u] = inv;
        factors[f + 5u] = inv;
    }
}

fn apply(i: u32) {
    let f = 6u * i;
    let l10 = factors[f];
    let l20 = factors[f + 1u];
    let l21 = factors[f + 2u];
    let z0 = x[3u * i];
    let z1 = x[3u * i + 1u] - l10 * z0;
    let z2 = x[3u * i + 2u] - l20 * z0 - l21 * z1;
    let w0 = z0 * factors[f + 3u];
    let w1 = z1 * factors[f + 4u];
    let w2 = z2 * factors[f + 5u];
    let y2 = w2;
    let y1 = w1 - l21 * y2;
    let y0 = w0 - l10 * y1 - l20 * y2;
    y[3u * i] = y0;
    y[3u * i + 1u] = y1;
    y[3u * i + 2u] = y2;
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i >= dims.n {
        return;
    }
    if dims.op == 0u {
        factor(i);
    } else {
        apply(i);
    }
}
