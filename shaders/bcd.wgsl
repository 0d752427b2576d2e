// One colour of a block coordinate descent sweep, one thread per vertex: a
// safeguarded Newton step on the vertex's 3x3 block with Armijo backtracking.
// The vertices of a colour share no element, so they move independently.
// CPU twin: backend/cpu/bcd.rs (`newton_step`, same arithmetic, same order).

#import layout
#import corners
#import corner_model

@group(0) @binding(0) var<uniform> model: Model;
// x = beta, y = sigma
@group(0) @binding(1) var<uniform> ls: vec4<real>;
// n = vertices of the colour, offset = its start in `colors`, aux = most backtracks
@group(0) @binding(2) var<uniform> op: Op;
@group(0) @binding(3) var<storage, read_write> x: array<real>;
@group(0) @binding(4) var<storage, read> corners: array<u32>;
@group(0) @binding(5) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(6) var<storage, read> inc_offsets: array<u32>;
@group(0) @binding(7) var<storage, read> inc_items: array<u32>;
@group(0) @binding(8) var<storage, read> colors: array<u32>;
// each vertex's move in this sweep (0 when it stayed), 3 reals per vertex
@group(0) @binding(9) var<storage, read_write> moves: array<real>;
// sliding-boundary constraints (`boundary.wgsl`); no vertex slides when the
// candidate offsets are all zero
@group(0) @binding(10) var<storage, read> slide_real: array<real>;
@group(0) @binding(11) var<storage, read> slide_idx: array<u32>;

#import boundary

// The vertex's S-without-its-term per corner, as the CPU's `Patch` keeps
// them; vertices with more corners than this recompute them per trial.
const CACHE: u32 = 32u;
#if PLANAR
// The planar forms read only the leading 2x2 block of S, so only it is
// kept: llvmpipe holds this array on the stack, and the z row and column
// would more than double the traffic (and keep their loads alive).
var<private> rest_cache: array<vec4<real>, CACHE>;

fn cache_put(i: u32, rest: mat3x3<real>) {
    rest_cache[i] = vec4<real>(rest[0][0], rest[0][1], rest[1][0], rest[1][1]);
}

fn cache_get(i: u32) -> mat3x3<real> {
    let r = rest_cache[i];
    return mat3x3<real>(vec3<real>(r.x, r.y, real(0.0)), vec3<real>(r.z, r.w, real(0.0)), vec3<real>(real(0.0)));
}
#else
var<private> rest_cache: array<mat3x3<real>, CACHE>;

fn cache_put(i: u32, rest: mat3x3<real>) {
    rest_cache[i] = rest;
}

fn cache_get(i: u32) -> mat3x3<real> {
    return rest_cache[i];
}
#endif

// S without vertex k's term of corner c (`TetShape::s_rest`).
fn corner_rest(c: u32, b: array<vec3<real>, 4>, k: u32) -> mat3x3<real> {
#if PLANAR
    return planar_s_rest(corner_points(c), b, k);
#else
    return s_rest(corner_points(c), b, k);
#endif
}

// `Patch::value`: the weighted terms of the vertex's corners with it at `at`.
fn patch_value(v: u32, at: vec3<real>) -> Eta {
    var sum = real(0.0);
    let first = inc_offsets[v];
    let cached = inc_offsets[v + 1u] - first <= CACHE;
    for (var it = first; it < inc_offsets[v + 1u]; it++) {
        let packed = inc_items_get(it);
        let k = packed & 3u;
        let cr = corner_ref(packed >> 2u);
        var rest: mat3x3<real>;
        if cached {
            rest = cache_get(it - first);
        } else {
            rest = corner_rest(packed >> 2u, cr.b, k);
        }
        let r = model_value_of_s(model, s_with(rest, cr.b[k], at), model_aux(model, cr));
        if !r.ok {
            return Eta(real(0.0), false);
        }
        sum += cr.w * r.eta;
    }
    return Eta(sum, true);
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
    let v = colors[op.offset + t];
    for (var i = 0u; i < 3u; i++) {
        moves_set(3u * v + i, real(0.0));
    }
    let xv = corner_point(v);

    // `Patch::gradient_hessian`
    var f0 = real(0.0);
    var g = vec3<real>(real(0.0));
    var h = mat3x3<real>();
    let first = inc_offsets[v];
    for (var it = first; it < inc_offsets[v + 1u]; it++) {
        let packed = inc_items_get(it);
        let k = packed & 3u;
        let cr = corner_ref(packed >> 2u);
        let rest = corner_rest(packed >> 2u, cr.b, k);
        if it - first < CACHE {
            cache_put(it - first, rest);
        }
        let r = model_vertex_gh(model, s_with(rest, cr.b[k], xv), cr.b[k], model_aux(model, cr));
        if !r.ok {
            return;
        }
        let w = cr.w;
        f0 += w * r.eta;
        g += w * r.grad;
        h += w * r.hess;
    }
    // a sliding vertex: the step in its tangent space, each trial put back on the boundary
    let slide = slides(v);
    if slide {
        let p = active_projector(v, xv, g);
        g = mul_vec(p, g);
        h = constrain_hessian(p, h);
    }
    let d = newton_direction(g, h);
    let slope = dot3(g, d);
    if !(slope < real(0.0)) {
        return;
    }
    let beta = ls.x;
    let sigma = ls.y;
    var alpha = real(1.0);
    for (var n = 0u; n <= op.aux; n++) {
        var trial = vec3<real>(xv[0] + alpha * d[0], xv[1] + alpha * d[1], xv[2] + alpha * d[2]);
        if slide {
            trial = project_vertex(v, trial);
        }
        let f = patch_value(v, trial);
        if f.ok && f.eta <= f0 + sigma * alpha * slope {
            x_set(3u * v, trial[0]);
            x_set(3u * v + 1u, trial[1]);
            x_set(3u * v + 2u, trial[2]);
            for (var i = 0u; i < 3u; i++) {
                moves_set(3u * v + i, trial[i] - xv[i]);
            }
            return;
        }
        alpha *= beta;
    }
}
