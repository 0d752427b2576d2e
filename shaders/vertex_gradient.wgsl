// Per free vertex: its gradient of F gathered over its incident corners (a
// gather, so the sum order is fixed), squared; per workgroup: the tree sum of
// those squares and the largest squared displacement of the last sweep.
// CPU twin: `objective::gradient` (gather part) and `objective::norm`.

#import layout

@group(0) @binding(0) var<uniform> sizes: Sizes;
@group(0) @binding(1) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(2) var<storage, read> inc_offsets: array<u32>;
@group(0) @binding(3) var<storage, read> inc_items: array<u32>;
// per corner, weighted (`objective.wgsl`)
@group(0) @binding(4) var<storage, read> grad: array<real>;
@group(0) @binding(5) var<storage, read> disp: array<real>;
// per workgroup: (sum of squared gradient components, max squared displacement)
@group(0) @binding(6) var<storage, read_write> partials: array<real>;

var<workgroup> sq_wg: array<real, 64>;
var<workgroup> disp_wg: array<real, 64>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = linear_group(wid, nwg);
    let t = group * 64u + lid;
    var sq = real(0.0);
    var moved = real(0.0);
    if t < sizes.n_free {
        let v = free_vertices[t];
        var acc = vec3<real>(real(0.0));
        for (var it = inc_offsets[v]; it < inc_offsets[v + 1u]; it++) {
            let packed = inc_items[it];
            let base = 12u * (packed >> 2u) + 3u * (packed & 3u);
            acc = vec3<real>(acc[0] + grad[base], acc[1] + grad[base + 1u], acc[2] + grad[base + 2u]);
        }
        sq = acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2];
        moved = disp[v];
    }
    sq_wg[lid] = sq;
    disp_wg[lid] = moved;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if lid < stride {
            sq_wg[lid] += sq_wg[lid + stride];
            disp_wg[lid] = max(disp_wg[lid], disp_wg[lid + stride]);
        }
    }
    if lid == 0u && group < sizes.n_vert_partials {
        partials[2u * group] = sq_wg[0];
        partials[2u * group + 1u] = disp_wg[0];
    }
}
