// A line-search trial point: trial = x + alpha d at the free vertices (the
// fixed ones never move, so `trial` keeps them from its initial copy of x);
// `objective` and `reduce` then evaluate it, an infeasible trial counting as
// +inf. CPU twin: the trial loop of `Newton::step`.

#import layout

struct Step {
    // x = alpha
    alpha: vec4<real>,
}

@group(0) @binding(0) var<uniform> step: Step;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@group(0) @binding(2) var<storage, read> free_vertices: array<u32>;
@group(0) @binding(3) var<storage, read> x: array<real>;
@group(0) @binding(4) var<storage, read> d: array<real>;
@group(0) @binding(5) var<storage, read_write> trial: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i >= sizes.n_free {
        return;
    }
    let v = free_vertices[i];
    let alpha = step.alpha.x;
    for (var c = 0u; c < 3u; c++) {
        trial[3u * v + c] = x[3u * v + c] + alpha * d[3u * i + c];
    }
}
