// The final pass over per-workgroup partials (sum, min, max, count) in one
// workgroup: each thread folds a fixed strided slice (the sums compensated,
// for f32), then the tree; the results go to the scalar slots `slot` (sum),
// `aux` (min), `aux2` (max) and `aux3` (count), each unless NONE. The order
// never changes, so a run repeats bit for bit.
// CPU twin: backend/cpu/reduce.rs (the fixed-chunk sums of the CPU backend).

#import layout
#import tree

// n = number of partials
@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> partials: array<vec4<real>>;
@group(0) @binding(2) var<storage, read_write> scalars: array<real>;

struct Kahan {
    sum: real,
    c: real,
}

fn kahan_add(k: Kahan, v: real) -> Kahan {
    let y = v - k.c;
    let t = k.sum + y;
    return Kahan(t, (t - k.sum) - y);
}

@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) lid: u32) {
    var sum = Kahan(real(0.0), real(0.0));
    var count = Kahan(real(0.0), real(0.0));
    var acc = tree_zero();
    for (var i = lid; i < op.n; i += 64u) {
        let p = partials[i];
        sum = kahan_add(sum, p.x);
        count = kahan_add(count, p.w);
        acc = combine(acc, vec4<real>(real(0.0), p.y, p.z, real(0.0)));
    }
    let total = tree_reduce(lid, vec4<real>(sum.sum, acc.y, acc.z, count.sum));
    if lid == 0u {
        if op.slot != NONE {
            scalars[op.slot] = total.x;
        }
        if op.aux != NONE {
            scalars[op.aux] = total.y;
        }
        if op.aux2 != NONE {
            scalars[op.aux2] = total.z;
        }
        if op.aux3 != NONE {
            scalars[op.aux3] = total.w;
        }
    }
}
