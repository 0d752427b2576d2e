// y = M^-1 x with the block-Jacobi factors (`block_jacobi_factor`): y =
// L^-T D^-1 L^-1 x per block row, one thread each.
// CPU twin: backend/cpu/block_jacobi.rs (`BlockJacobi::apply`, same order).

#import layout

// n = number of block rows
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> factors: array<real>;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read_write> y: array<real>;

fn apply(i: u32) {
    let f = 6u * i;
    let l10 = factors_get(f);
    let l20 = factors_get(f + 1u);
    let l21 = factors_get(f + 2u);
    let z0 = x_get(3u * i);
    let z1 = x_get(3u * i + 1u) - l10 * z0;
    let z2 = x_get(3u * i + 2u) - l20 * z0 - l21 * z1;
    let w0 = z0 * factors_get(f + 3u);
    let w1 = z1 * factors_get(f + 4u);
    let w2 = z2 * factors_get(f + 5u);
    let y2 = w2;
    let y1 = w1 - l21 * y2;
    let y0 = w0 - l10 * y1 - l20 * y2;
    y_set(3u * i, y0);
    y_set(3u * i + 1u, y1);
    y_set(3u * i + 2u, y2);
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i < op.n {
        apply(i);
    }
}
