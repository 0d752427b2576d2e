// Per element: the gradient and the upper 4x4 blocks (3x3 each) of the
// Hessian of eta, for `hessian_gather` and `gradient_gather` to sum without
// float atomics; a lower block is the transpose of its upper one.
// CPU twin: `TetShape::hessian_blocks` (same formula, same sum order).

#import layout
#import mean_ratio

@group(0) @binding(0) var<uniform> shape: Shape;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> tets: array<u32>;
@group(0) @binding(4) var<storage, read_write> elem: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let e = linear_group(wid, nwg) * 64u + lid;
    if e >= sizes.n_elements {
        return;
    }
    let b = shape_b(shape);
    var pts: array<vec3<real>, 4>;
    for (var k = 0u; k < 4u; k++) {
        let v = tets[4u * e + k];
        pts[k] = vec3<real>(x[3u * v], x[3u * v + 1u], x[3u * v + 2u]);
    }
    let p = parts_of_s(s_of(pts, b));
    let base = ELEM_STRIDE * e;
    if !p.ok {
        // assembly runs at accepted (feasible) points only; zeros keep the sums finite
        for (var i = 0u; i < ELEM_STRIDE; i++) {
            elem[base + i] = real(0.0);
        }
        return;
    }
    var sv: array<vec3<real>, 4>;
    var cv: array<vec3<real>, 4>;
    for (var k = 0u; k < 4u; k++) {
        let g = mul_vec(p.grad_s, b[k]);
        for (var i = 0u; i < 3u; i++) {
            elem[base + 3u * k + i] = g[i];
        }
        sv[k] = mul_vec(p.s, b[k]);
        cv[k] = mul_vec(p.cof, b[k]);
    }
    let dm53 = p.h / p.d;
    let dm83 = dm53 / p.d;
    let diag = real(2.0) * p.h / real(3.0);
    let cross = real(-(4.0 / 9.0)) * dm53;
    let cc = real(10.0 / 27.0) * p.f * dm83;
    let skew = real(-(2.0 / 9.0)) * p.f * dm53;
    for (var k = 0u; k < 4u; k++) {
        for (var l = k; l < 4u; l++) {
            let bk = b[k];
            let bl = b[l];
            let bkl = bk[0] * bl[0] + bk[1] * bl[1] + bk[2] * bl[2];
            var blk = mat3x3<real>();
            for (var i = 0u; i < 3u; i++) {
                for (var q = 0u; q < 3u; q++) {
                    blk[i][q] = cross * (sv[k][i] * cv[l][q] + cv[k][i] * sv[l][q]) + cc * cv[k][i] * cv[l][q];
                }
                blk[i][i] += diag * bkl;
            }
            if k != l {
                let bx = vec3<real>(
                    bk[1] * bl[2] - bk[2] * bl[1],
                    bk[2] * bl[0] - bk[0] * bl[2],
                    bk[0] * bl[1] - bk[1] * bl[0],
                );
                let sw = mul_vec(p.s, bx);
                let w = vec3<real>(sw[0] * skew, sw[1] * skew, sw[2] * skew);
                blk[0][1] += w[2];
                blk[1][0] -= w[2];
                blk[1][2] += w[0];
                blk[2][1] -= w[0];
                blk[2][0] += w[1];
                blk[0][2] -= w[1];
            }
            let at = base + 12u + 9u * upper_block(k, l);
            for (var i = 0u; i < 3u; i++) {
                for (var q = 0u; q < 3u; q++) {
                    elem[at + 3u * i + q] = blk[i][q];
                }
            }
        }
    }
}
