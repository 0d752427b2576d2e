// Per corner: the weighted gradient and upper 4x4 blocks (3x3 each) of the
// Hessian of its term, for `hessian_gather` and `gradient_gather` to sum
// without float atomics; a lower block is the transpose of its upper one.
// CPU twin: backend/cpu/hessian_assemble.rs (`Model::blocks`: the folded
// closed form of `TetShape::hessian_blocks`, the planar 2x2 forms of
// `planar.rs`, or the structured S-Hessian contracted with B), each entry
// times the corner weight.

#import layout
#import corners
#import corner_model

@group(0) @binding(0) var<uniform> model: Model;
// the corners [offset, n): all of them, or one window of the split arrays
// (`GpuBackend::record_windowed`)
@group(0) @binding(1) var<uniform> op: Op;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> corners: array<u32>;
@group(0) @binding(4) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(5) var<storage, read_write> elem: array<real>;

fn store_block(base: u32, k: u32, l: u32, blk: mat3x3<real>, w: real) {
    let at = base + 12u + 9u * upper_block(k, l);
    for (var i = 0u; i < 3u; i++) {
        for (var q = 0u; q < 3u; q++) {
            elem_set(at + 3u * i + q, blk[i][q] * w);
        }
    }
}

// `Model::blocks` through the structured S-Hessian.
fn general_blocks(base: u32, s: mat3x3<real>, cr: CornerRef) -> bool {
    let b = cr.b;
    let w = cr.w;
    let n = model.dim;
    let m = model_eval(model, s, model_aux(model, cr), true);
    if !m.ok {
        return false;
    }
    let nv = n + 1u;
    var rows: array<SRow, 4>;
    for (var l = 0u; l < nv; l++) {
        rows[l] = shess_row(m.h, b[l]);
        let g = mul_vec(m.g, b[l]);
        elem_set(base + 3u * l, g[0] * w);
        elem_set(base + 3u * l + 1u, g[1] * w);
        elem_set(base + 3u * l + 2u, g[2] * w);
    }
    for (var k = 0u; k < 4u; k++) {
        for (var l = k; l < 4u; l++) {
            var blk = mat3x3<real>();
            if l < nv {
                blk = shess_block(m.h, rows[k], rows[l]);
                if n == 2u && k == l {
                    blk[2][2] = real(1.0);
                }
            }
            store_block(base, k, l, blk, w);
        }
    }
    return true;
}

#if PLANAR
// `corner_model::planar_blocks`: three vertices, the fourth's blocks zero.
fn planar_blocks(base: u32, s: mat3x3<real>, b: array<vec3<real>, 4>, w: real) -> bool {
    let p = planar_parts(s);
    if !p.ok {
        return false;
    }
    for (var k = 0u; k < 4u; k++) {
        let g = planar_gradient(p, b[k]);
        elem_set(base + 3u * k, g[0] * w);
        elem_set(base + 3u * k + 1u, g[1] * w);
        elem_set(base + 3u * k + 2u, g[2] * w);
        for (var l = k; l < 4u; l++) {
            var blk = mat3x3<real>();
            if l < 3u {
                blk = planar_block(p, b[k], b[l]);
                if k == l {
                    blk[2][2] = real(1.0);
                }
            }
            store_block(base, k, l, blk, w);
        }
    }
    return true;
}
#endif

#if SURFACE
// `corner_model::three_vertex_blocks` of a surface corner: three vertices
// moving in 3D, the fourth's blocks zero.
fn surface_blocks(base: u32, s: mat3x3<real>, cr: CornerRef) -> bool {
    let p = surface_parts(model.tmpl, s, cr.n);
    if !p.ok {
        return false;
    }
    for (var k = 0u; k < 4u; k++) {
        var g = vec3<real>(real(0.0));
        if k < 3u {
            g = surface_gradient(p, cr.b[k]);
        }
        elem_set(base + 3u * k, g[0] * cr.w);
        elem_set(base + 3u * k + 1u, g[1] * cr.w);
        elem_set(base + 3u * k + 2u, g[2] * cr.w);
        for (var l = k; l < 4u; l++) {
            var blk = mat3x3<real>();
            if l < 3u {
                blk = surface_block(p, cr.b[k], cr.b[l]);
            }
            store_block(base, k, l, blk, cr.w);
        }
    }
    return true;
}
#endif

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    // the closed-form variant never reads the model; binding it in both keeps
    // one bind-group layout for the two
    _ = model;
    let e = op.offset + linear_group(wid, nwg) * 64u + lid;
    if e >= op.n {
        return;
    }
    let cr = corner_ref(e);
    let b = cr.b;
    let w = cr.w;
    let s = s_of(corner_points(e), b);
    let base = ELEM_STRIDE * e;
    var ok = true;
#if PLANAR
    ok = planar_blocks(base, s, b, w);
#endif
#if SURFACE
    ok = surface_blocks(base, s, cr);
#endif
#if GENERAL
    ok = general_blocks(base, s, cr);
#endif
#if !FAST
    if ok {
        return;
    }
#endif
    let p = parts_of_s(s);
    if !p.ok || !ok {
        // assembly runs at accepted (feasible) points only; zeros keep the sums finite
        for (var i = 0u; i < ELEM_STRIDE; i++) {
            elem_set(base + i, real(0.0));
        }
        return;
    }
    // the folded form of `TetShape::hessian_blocks`:
    // block (k,l) = u_k c_l^T + c_k v_l^T + diag (b_k.b_l) I + skew [S (b_k x b_l)]_x
    // with v = cross s and u = v + cc c
    let dm53 = p.h / p.d;
    let dm83 = dm53 / p.d;
    let diag = real(2.0) * p.h / real(3.0);
    let cross = real(-(4.0 / 9.0)) * dm53;
    let cc = real(10.0 / 27.0) * p.f * dm83;
    let skew = real(-(2.0 / 9.0)) * p.f * dm53;
    var u: array<vec3<real>, 4>;
    var v: array<vec3<real>, 4>;
    var cv: array<vec3<real>, 4>;
    for (var k = 0u; k < 4u; k++) {
        let g = mul_vec(p.grad_s, b[k]);
        for (var i = 0u; i < 3u; i++) {
            elem_set(base + 3u * k + i, g[i] * w);
        }
        let sk = mul_vec(p.s, b[k]);
        cv[k] = mul_vec(p.cof, b[k]);
        for (var i = 0u; i < 3u; i++) {
            v[k][i] = cross * sk[i];
            u[k][i] = v[k][i] + cc * cv[k][i];
        }
    }
    for (var k = 0u; k < 4u; k++) {
        for (var l = k; l < 4u; l++) {
            let bk = b[k];
            let bl = b[l];
            let bkl = bk[0] * bl[0] + bk[1] * bl[1] + bk[2] * bl[2];
            var blk = mat3x3<real>();
            for (var i = 0u; i < 3u; i++) {
                for (var q = 0u; q < 3u; q++) {
                    blk[i][q] = u[k][i] * cv[l][q] + cv[k][i] * v[l][q];
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
            store_block(base, k, l, blk, w);
        }
    }
}
