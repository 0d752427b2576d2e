// Per corner: its weighted term and gradient (kept on the device for the
// vertex gather); per workgroup: a tree sum of the terms, the smallest
// det(S) and the infeasible count. CPU twin: `objective::gradient` (value part).

#import layout
#import corners
#import corner_model

@group(0) @binding(0) var<uniform> model: Model;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> corners: array<u32>;
@group(0) @binding(4) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(5) var<storage, read_write> grad: array<real>;
// per workgroup: (sum of terms, min det S, infeasible count)
@group(0) @binding(6) var<storage, read_write> partials: array<real>;

var<workgroup> sum_wg: array<real, 64>;
var<workgroup> min_wg: array<real, 64>;
var<workgroup> bad_wg: array<u32, 64>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = linear_group(wid, nwg);
    let c = group * 64u + lid;
    var term = real(0.0);
    var dmin = REAL_MAX;
    var bad = 0u;
    if c < sizes.n_elements {
        let cr = corner_ref(c);
        let s = s_of(corner_points(c), cr.b);
        dmin = det_n(s, model.dim);
        var ok = false;
        var g_s = mat3x3<real>();
#if FAST
        let p = parts_of_s(s);
        ok = p.ok;
        term = p.eta;
        g_s = p.grad_s;
#else
        let m = model_eval(model, s, false);
        ok = m.ok;
        term = m.v;
        g_s = m.g;
#endif
        if ok {
            term = cr.w * term;
        } else {
            term = real(0.0);
            bad = 1u;
        }
        for (var k = 0u; k < 4u; k++) {
            var g = vec3<real>(real(0.0));
            if ok {
#if FAST
                g = mul_vec(g_s, cr.b[k]);
#else
                g = contract_g(g_s, cr.b[k], model.dim);
#endif
            }
            for (var i = 0u; i < 3u; i++) {
                grad[12u * c + 3u * k + i] = g[i] * cr.w;
            }
        }
    }
    sum_wg[lid] = term;
    min_wg[lid] = dmin;
    bad_wg[lid] = bad;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lid < stride {
            sum_wg[lid] += sum_wg[lid + stride];
            min_wg[lid] = min(min_wg[lid], min_wg[lid + stride]);
            bad_wg[lid] += bad_wg[lid + stride];
        }
    }
    if lid == 0u && group < sizes.n_obj_partials {
        partials[3u * group] = sum_wg[0];
        partials[3u * group + 1u] = min_wg[0];
        partials[3u * group + 2u] = real(bad_wg[0]);
    }
}
