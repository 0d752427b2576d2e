// Step 1 of reference-Jacobian rezoning, one thread per free vertex: up to
// op.aux2 safeguarded Newton steps (the BCD step: Cholesky on the 3x3 block,
// Armijo backtracking) on the objective of the vertex's corners, every other
// vertex at its position in `x`, which nothing writes; the vertex's virtual
// reference position goes to `xr`. CPU twin: backend/cpu/reference_position.rs
// (with `bcd::patch_step`: same arithmetic, same order).

#import layout
#import corners
#import corner_model

@group(0) @binding(0) var<uniform> model: Model;
// x = beta, y = sigma
@group(0) @binding(1) var<uniform> ls: vec4<real>;
// n = free vertices, aux = most backtracks, aux2 = most Newton steps,
// coef.x = STEP_TOL^2 (Newton stops on a direction below STEP_TOL local sizes)
@group(0) @binding(2) var<uniform> op: Op;
@group(0) @binding(3) var<storage, read> x: array<real>;
@group(0) @binding(4) var<storage, read> corners: array<u32>;
@group(0) @binding(5) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(6) var<storage, read> inc_offsets: array<u32>;
@group(0) @binding(7) var<storage, read> inc_items: array<u32>;
@group(0) @binding(8) var<storage, read> free_vertices: array<u32>;
// reference positions, 3 reals per vertex (fixed vertices: copied from x)
@group(0) @binding(9) var<storage, read_write> xr: array<real>;

// S without the vertex's term of incidence item `it` (recomputed: the
// corners a vertex has under the paper's measure outnumber any private cache).
fn rest_of(it: u32, first: u32) -> mat3x3<real> {
    let packed = inc_items_get(it);
    return s_rest(corner_points(packed >> 2u), corner_ref(packed >> 2u).b, packed & 3u);
}

// `Patch::value`
fn patch_value(v: u32, at: vec3<real>) -> Eta {
    var sum = real(0.0);
    let first = inc_offsets[v];
    for (var it = first; it < inc_offsets[v + 1u]; it++) {
        let packed = inc_items_get(it);
        let cr = corner_ref(packed >> 2u);
        let r = model_value_of_s(model, s_with(rest_of(it, first), cr.b[packed & 3u], at), model_aux(model, cr));
        if !r.ok {
            return Eta(real(0.0), false);
        }
        sum += cr.w * r.eta;
    }
    return Eta(sum, true);
}

struct Step {
    y: vec3<real>,
    ok: bool,
}

// `bcd::patch_step`
fn patch_step(v: u32, xv: vec3<real>, min_step_sq: real) -> Step {
    var out = Step(xv, false);
    var f0 = real(0.0);
    var g = vec3<real>(real(0.0));
    var h = mat3x3<real>();
    let first = inc_offsets[v];
    for (var it = first; it < inc_offsets[v + 1u]; it++) {
        let packed = inc_items_get(it);
        let k = packed & 3u;
        let cr = corner_ref(packed >> 2u);
        let r = model_vertex_gh(model, s_with(rest_of(it, first), cr.b[k], xv), cr.b[k], model_aux(model, cr));
        if !r.ok {
            return out;
        }
        let w = cr.w;
        f0 += w * r.eta;
        g += w * r.grad;
        h += w * r.hess;
    }
    let d = newton_direction(g, h);
    let slope = dot3(g, d);
    if !(slope < real(0.0)) || dot3(d, d) <= min_step_sq {
        return out;
    }
    var alpha = real(1.0);
    for (var n = 0u; n <= op.aux; n++) {
        let trial = vec3<real>(xv[0] + alpha * d[0], xv[1] + alpha * d[1], xv[2] + alpha * d[2]);
        let f = patch_value(v, trial);
        if f.ok && f.eta <= f0 + ls.y * alpha * slope {
            return Step(trial, true);
        }
        alpha *= ls.x;
    }
    return out;
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = linear_group(wid, nwg) * 64u + lid;
    if t >= op.n {
        return;
    }
    let v = free_vertices[t];
    let first = inc_offsets[v];
    var y = corner_point(v);
    // `reference_position::local_size_sq`
    var h = real(0.0);
    for (var it = first; it < inc_offsets[v + 1u]; it++) {
        let pts = corner_points(inc_items_get(it) >> 2u);
        for (var q = 0u; q < 4u; q++) {
            let e = vec3<real>(pts[q][0] - y[0], pts[q][1] - y[1], pts[q][2] - y[2]);
            h = max(h, e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        }
    }
    let min_step_sq = op.coef.x * h;
    for (var i = 0u; i < op.aux2; i++) {
        let step = patch_step(v, y, min_step_sq);
        if !step.ok {
            break;
        }
        y = step.y;
    }
    xr_set(3u * v, y[0]);
    xr_set(3u * v + 1u, y[1]);
    xr_set(3u * v + 2u, y[2]);
}
