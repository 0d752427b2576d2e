//! d^(-2/3), the mean ratio's size factor in 3D, without a libm cube root:
//! `f64::cbrt` was 8-12% of Newton's time on tetrahedra and hexahedra (one
//! call per corner per evaluation). An exponent-thirding seed and Newton
//! steps on r = d^(-1/3) need multiplications only.
//!
//! The result is within about one ulp of d^(-2/3), scales exactly (d times
//! 8^k gives r times 2^-k bit for bit, so the unit-free frame changes
//! nothing) and is exact at the cubes of powers of two, where ideal
//! elements sit.

/// Seed of d^(-1/3) from the bits of d: thirds the exponent (Moroz et al.'s
/// constant for the inverse cube root), within a few percent.
const MAGIC: u64 = 0x553e_f0ff_289d_d796;

/// d^(-2/3) for positive finite d (libm below the normal range, where the
/// seed does not hold).
#[inline]
pub fn inv_cbrt_sq(d: f64) -> f64 {
    if !(d >= f64::MIN_POSITIVE) || d == f64::INFINITY {
        let c = d.cbrt();
        return 1.0 / (c * c);
    }
    let mut r = f64::from_bits(MAGIC - d.to_bits() / 3);
    // quadratic steps: a few percent, 2e-3, 6e-6, 1e-10 ...
    for _ in 0..3 {
        r *= (4.0 - d * r * r * r) * (1.0 / 3.0);
    }
    // ... and a last one on the residual, where the rounding is smallest
    let e = 1.0 - d * r * r * r;
    r += r * e * (1.0 / 3.0);
    r * r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, exact: f64) -> f64 {
        ((a - exact) / exact).abs() / f64::EPSILON
    }

    #[test]
    fn within_two_ulps_of_libm_over_the_normal_range() {
        let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut worst: f64 = 0.0;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let e = (s % 1200) as i32 - 600;
            let d = (1.0 + (s >> 11) as f64 / (1u64 << 53) as f64) * 2f64.powi(e);
            let c = d.cbrt();
            worst = worst.max(ulps(inv_cbrt_sq(d), 1.0 / (c * c)));
        }
        // libm's own cube root and the division round too
        assert!(worst < 3.0, "worst {worst} ulps");
    }

    #[test]
    fn scales_exactly_and_is_exact_at_ideal_sizes() {
        for d in [1.0, 8.0, 0.125, 64.0, 2f64.powi(-300), 2f64.powi(300)] {
            let c = d.cbrt();
            assert_eq!(inv_cbrt_sq(d), 1.0 / (c * c), "d = {d}");
        }
        for d in [0.3, 1.7, 123.456, 1e-9] {
            assert_eq!(inv_cbrt_sq(d * 8.0), inv_cbrt_sq(d) / 4.0, "d = {d}");
            assert_eq!(inv_cbrt_sq(d / 512.0), inv_cbrt_sq(d) * 64.0, "d = {d}");
        }
    }

    #[test]
    fn below_the_normal_range_falls_back_to_libm() {
        // 2^-1032: d^(-2/3) = 2^688
        let d = f64::MIN_POSITIVE / 1024.0;
        assert_eq!(inv_cbrt_sq(d), 2f64.powi(688));
        assert!(ulps(inv_cbrt_sq(d * 3.0), inv_cbrt_sq(3.0) * 2f64.powi(688)) < 3.0);
        assert_eq!(inv_cbrt_sq(f64::INFINITY), 0.0);
    }
}
