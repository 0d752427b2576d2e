// Coefficients and guards read from the scalar slots. A kernel importing
// this declares `scalars: array<real>` and `op: Op`.

#import layout

fn slot_or_one(s: u32) -> real {
    if s == NONE {
        return real(1.0);
    }
    return scalars[s];
}

// scale * slots[num] / slots[den], a missing slot counting as 1 (`Coef::eval`).
fn coef(scale: real, num: u32, den: u32) -> real {
    return scale * slot_or_one(num) / slot_or_one(den);
}

// NaN-safe: a NaN guard fails (`backend::guard_passes`).
fn guard_passes(g: u32) -> bool {
    return g == NONE || scalars[g] > real(0.0);
}
