// Per corner: its weighted term and gradient (kept on the device for
// `gradient_gather`); per workgroup: (sum of the terms, smallest det(S), -,
// infeasible count) for `reduce`. CPU twin: backend/cpu/objective.rs.

#import layout
#import corners
#import corner_model
#import tree

@group(0) @binding(0) var<uniform> model: Model;
// the corners [offset, n): all of them, or one window of the split arrays
// (offset a multiple of 64, so that each workgroup and its partial are the
// one-pass ones: `GpuBackend::record_windowed`)
@group(0) @binding(1) var<uniform> op: Op;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> corners: array<u32>;
@group(0) @binding(4) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(5) var<storage, read_write> grad: array<real>;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<real>>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = op.offset / 64u + linear_group(wid, nwg);
    let c = group * 64u + lid;
    var term = real(0.0);
    var dmin = REAL_MAX;
    var bad = 0u;
    if c < op.n {
        let cr = corner_ref(c);
        let s = s_of(corner_points(c), cr.b);
#if SURFACE
        dmin = surface_facing_area(s, cr.n);
#else
        dmin = det_n(s, model.dim);
#endif
        var ok = false;
        var g_s = mat3x3<real>();
#if FAST
        let p = parts_of_s(s);
        ok = p.ok;
        term = p.eta;
        g_s = p.grad_s;
#endif
#if PLANAR
        // b_k has no z entry in 2D, so the zero third column adds exact zeros
        let p = planar_parts(s);
        ok = p.ok;
        term = p.eta;
        g_s = mat3x3<real>(vec3<real>(p.g0, real(0.0)), vec3<real>(p.g1, real(0.0)), vec3<real>(real(0.0)));
#endif
#if SURFACE
        let p = surface_parts(model.tmpl, s, cr.n);
        ok = p.ok;
        term = p.value;
        g_s = surface_grad_s(p);
#endif
#if GENERAL
        let m = model_eval(model, s, model_aux(model, cr), false);
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
                g = mul_vec(g_s, cr.b[k]);
            }
            for (var i = 0u; i < 3u; i++) {
                grad_set(12u * c + 3u * k + i, g[i] * cr.w);
            }
        }
    }
    let total = tree_reduce(lid, vec4<real>(term, dmin, -REAL_MAX, real(bad)));
    if lid == 0u && group < (op.n + 63u) / 64u {
        partials[group] = total;
    }
}
