//! CPU twin of `shaders/set_slot.wgsl`: a slot set to a slot expression
//! unless its guard fails.

use crate::backend::{Coef, Slot, guard_passes};

pub fn set_slot(slots: &mut [f64], dst: Slot, value: Coef, guard: Option<Slot>) {
    if guard_passes(slots, guard) {
        slots[dst.0 as usize] = value.eval(slots);
    }
}
