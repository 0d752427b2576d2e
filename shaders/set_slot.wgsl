// slots[slot] = a (a slot expression), skipped unless the guard passes; one
// thread. CPU twin: backend/cpu/set_slot.rs.

#import layout

@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read_write> scalars: array<real>;

#import slots

@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) lid: u32) {
    if lid == 0u && guard_passes(op.guard) {
        scalars[op.slot] = coef(op.coef.x, op.a_num, op.a_den);
    }
}
