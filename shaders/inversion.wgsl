// Per corner: the fraction of the way from the current positions to the
// trial at which its determinant first vanishes (`det_path.wgsl`); per
// workgroup the smallest, in the min lane, for `reduce`. CPU twin:
// backend/cpu/inversion.rs.

#import layout
#import corners
#import mean_ratio
#import det_path
#import tree

@group(0) @binding(0) var<uniform> model: Model;
// n = number of corners
@group(0) @binding(1) var<uniform> op: Op;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> corners: array<u32>;
@group(0) @binding(4) var<storage, read> shapes: array<vec4<real>>;
@group(0) @binding(5) var<storage, read> trial: array<real>;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<real>>;

fn trial_point(v: u32) -> vec3<real> {
    return vec3<real>(trial_get(3u * v), trial_get(3u * v + 1u), trial_get(3u * v + 2u));
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = linear_group(wid, nwg);
    let c = group * 64u + lid;
    var t = REAL_MAX;
    if c < op.n {
        let cr = corner_ref(c);
        let at = CORNER_STRIDE * c;
        let y = array<vec3<real>, 4>(
            trial_point(corners_get(at)),
            trial_point(corners_get(at + 1u)),
            trial_point(corners_get(at + 2u)),
            trial_point(corners_get(at + 3u)),
        );
        let s0 = s_of(corner_points(c), cr.b);
        let s1 = s_of(y, cr.b);
        if any(cr.n != vec3<real>(real(0.0))) {
            t = first_root(facing_coefficients(s0, s1 - s0, cr.n));
        } else {
            t = first_inversion(s0, s1 - s0, model.dim);
        }
    }
    let total = tree_reduce(lid, vec4<real>(real(0.0), t, -REAL_MAX, real(0.0)));
    if lid == 0u && group < (op.n + 63u) / 64u {
        partials[group] = total;
    }
}
