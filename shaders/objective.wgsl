// Per element: eta and its gradient (kept on the device for the vertex
// gather); per workgroup: a tree sum of eta, the smallest det(S) and the
// infeasible count. CPU twin: `objective::gradient` (value part).

#import layout
#import mean_ratio

@group(0) @binding(0) var<uniform> shape: Shape;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read> tets: array<u32>;
@group(0) @binding(4) var<storage, read_write> grad: array<real>;
// per workgroup: (sum of eta, min det S, infeasible count)
@group(0) @binding(5) var<storage, read_write> partials: array<real>;

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
    let e = group * 64u + lid;
    var eta = real(0.0);
    var dmin = REAL_MAX;
    var bad = 0u;
    if e < sizes.n_elements {
        let b = shape_b(shape);
        var pts: array<vec3<real>, 4>;
        for (var k = 0u; k < 4u; k++) {
            let v = tets[4u * e + k];
            pts[k] = vec3<real>(x[3u * v], x[3u * v + 1u], x[3u * v + 2u]);
        }
        let s = s_of(pts, b);
        dmin = det3(s);
        let p = parts_of_s(s);
        if p.ok {
            eta = p.eta;
        } else {
            bad = 1u;
        }
        for (var k = 0u; k < 4u; k++) {
            var g = vec3<real>(real(0.0));
            if p.ok {
                g = mul_vec(p.grad_s, b[k]);
            }
            for (var i = 0u; i < 3u; i++) {
                grad[12u * e + 3u * k + i] = g[i];
            }
        }
    }
    sum_wg[lid] = eta;
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
