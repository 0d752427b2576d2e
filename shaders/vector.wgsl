// The vector updates of PCG on free-vertex vec3 arrays, their scalars read
// from the device's scalar slots (so a CG iteration needs no upload) and
// skipped once p^T A p <= 0 was met, which leaves d and p as the host needs
// them to return. CPU twin: the updates inside `solve::pcg::pcg`.
// op 0: d += alpha p, r -= alpha q, alpha = rz / curvature   (a = p, b = q, c = d, e = r)
// op 1: p = z + beta p, beta = rz_new / rz                    (a = z, c = p)
// op 2: rz = rz_new (one thread)
// op 3: c = sign(p^T b) a, the direction of negative curvature (a = p, c = d)

#import layout

const SLOT_RZ: u32 = 1u;
const SLOT_CURVATURE: u32 = 2u;
const SLOT_RZ_NEW: u32 = 4u;
const SLOT_PB: u32 = 5u;

// n = vector length in vec3s, op as above
@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read_write> scalars: array<real>;
@group(0) @binding(2) var<storage, read> a: array<real>;
@group(0) @binding(3) var<storage, read> b: array<real>;
@group(0) @binding(4) var<storage, read_write> c: array<real>;
@group(0) @binding(5) var<storage, read_write> e: array<real>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = linear_group(wid, nwg) * 64u + lid;
    let positive = scalars[SLOT_CURVATURE] > real(0.0);
    if dims.op == 2u {
        if i == 0u && positive {
            scalars[SLOT_RZ] = scalars[SLOT_RZ_NEW];
        }
        return;
    }
    if i >= dims.n {
        return;
    }
    if dims.op == 0u {
        if positive {
            let alpha = scalars[SLOT_RZ] / scalars[SLOT_CURVATURE];
            for (var k = 3u * i; k < 3u * i + 3u; k++) {
                c[k] += alpha * a[k];
                e[k] += -alpha * b[k];
            }
        }
    } else if dims.op == 1u {
        if positive {
            let beta = scalars[SLOT_RZ_NEW] / scalars[SLOT_RZ];
            for (var k = 3u * i; k < 3u * i + 3u; k++) {
                c[k] = a[k] + beta * c[k];
            }
        }
    } else if dims.op == 3u {
        var sign = real(-1.0);
        if scalars[SLOT_PB] >= real(0.0) {
            sign = real(1.0);
        }
        for (var k = 3u * i; k < 3u * i + 3u; k++) {
            c[k] = sign * a[k];
        }
    }
}
