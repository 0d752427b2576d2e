// out[i] = cbrt(values[i]), to test the f64 cube root against the CPU's.

#import layout
#import cbrt

@group(0) @binding(0) var<uniform> sizes: Sizes;
@group(0) @binding(1) var<storage, read_write> values: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    if i < sizes.n_elements {
        values[i] = cbrt(values[i]);
    }
}
