// Per element: value, gradient (12) and Hessian (144) of the inverse mean
// ratio, for testing against the CPU (`TetShape::hessian`). An infeasible
// element gets value -1 and zero derivatives.

#import layout
#import mean_ratio

@group(0) @binding(0) var<uniform> shape: Shape;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> tets: array<u32>;
@group(0) @binding(4) var<storage, read_write> value: array<real>;
@group(0) @binding(5) var<storage, read_write> grad: array<real>;
@group(0) @binding(6) var<storage, read_write> hess: array<real>;

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
    if !p.ok {
        value[e] = real(-1.0);
        for (var i = 0u; i < 12u; i++) {
            grad[12u * e + i] = real(0.0);
        }
        for (var i = 0u; i < 144u; i++) {
            hess[144u * e + i] = real(0.0);
        }
        return;
    }
    value[e] = p.eta;
    for (var k = 0u; k < 4u; k++) {
        let g = mul_vec(p.grad_s, b[k]);
        for (var i = 0u; i < 3u; i++) {
            grad[12u * e + 3u * k + i] = g[i];
        }
    }
    let h9 = hess_s(p);
    // Hess_X[(k,i),(l,q)] = sum_{j,n} H[(i,j),(q,n)] b_k[j] b_l[n]
    for (var k = 0u; k < 4u; k++) {
        for (var l = k; l < 4u; l++) {
            for (var i = 0u; i < 3u; i++) {
                for (var q = 0u; q < 3u; q++) {
                    var v = real(0.0);
                    for (var j = 0u; j < 3u; j++) {
                        let row = h9[3u * i + j];
                        let t = row[3u * q] * b[l][0] + row[3u * q + 1u] * b[l][1] + row[3u * q + 2u] * b[l][2];
                        v += b[k][j] * t;
                    }
                    hess[144u * e + 12u * (3u * k + i) + 3u * l + q] = v;
                    hess[144u * e + 12u * (3u * l + q) + 3u * k + i] = v;
                }
            }
        }
    }
}
