//! `x^p` for `x ≥ 0` as `exp(p ln x)`, branch-free so that loops over it vectorise: the Sobolev
//! kernel's `‖x − y‖^(2s−2)` dominates the assembly of `Q`.
//!
//! Only IEEE add, multiply, divide and integer bit operations are used, so a vectorised loop
//! gives bit-for-bit the results of a scalar one (Rust never contracts to FMA).

use std::f64::consts::{LN_2, SQRT_2};

/// ln 2 split into a part with a short mantissa and a remainder, so `k·ln2` keeps full precision.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1.5·2^52: adding and removing it rounds to an integer, which then sits in the low mantissa bits.
const SHIFTER: f64 = 6_755_399_441_055_744.0;

/// `ln x` for finite `x > 0`: `x = m·2^e` with `m ∈ [√½, √2)`, then
/// `ln m = 2 atanh(r) = 2 (r + r³/3 + … + r¹⁹/19)`, `r = (m − 1)/(m + 1)`, `|r| ≤ 0.1716`
/// (truncation below 1e-17 relative).
#[inline(always)]
fn ln(x: f64) -> f64 {
    let bits = x.to_bits();
    // The biased exponent as a double, without an int→float conversion (none in AVX2).
    let e_biased = f64::from_bits((bits >> 52) | 0x4330_0000_0000_0000) - 4_503_599_627_370_496.0;
    let m0 = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m0 > SQRT_2;
    let m = if big { 0.5 * m0 } else { m0 };
    let e = e_biased - 1023.0 + if big { 1.0 } else { 0.0 };
    let r = (m - 1.0) / (m + 1.0);
    let r2 = r * r;
    let r4 = r2 * r2;
    // Estrin's scheme: shorter dependency chains than Horner.
    let a = 1.0 + r2 * (1.0 / 3.0);
    let b = 1.0 / 5.0 + r2 * (1.0 / 7.0);
    let c = 1.0 / 9.0 + r2 * (1.0 / 11.0);
    let d = 1.0 / 13.0 + r2 * (1.0 / 15.0);
    let f = 1.0 / 17.0 + r2 * (1.0 / 19.0);
    let r8 = r4 * r4;
    let series = (a + r4 * b) + r8 * ((c + r4 * d) + r8 * f);
    e * LN2_HI + (2.0 * r * series + e * LN2_LO)
}

/// `exp y` for `y ∈ [−700, 700]`: `y = k ln2 + f`, `|f| ≤ ln2/2`, Taylor to `f¹³`
/// (truncation below 1e-17 relative), then scaling by `2^k` through the exponent bits.
#[inline(always)]
fn exp(y: f64) -> f64 {
    let shifted = y * (1.0 / LN_2) + SHIFTER;
    let k = shifted - SHIFTER;
    let f = (y - k * LN2_HI) - k * LN2_LO;
    let f2 = f * f;
    let f4 = f2 * f2;
    let f8 = f4 * f4;
    let t0 = 1.0 + f;
    let t1 = 1.0 / 2.0 + f * (1.0 / 6.0);
    let t2 = 1.0 / 24.0 + f * (1.0 / 120.0);
    let t3 = 1.0 / 720.0 + f * (1.0 / 5_040.0);
    let t4 = 1.0 / 40_320.0 + f * (1.0 / 362_880.0);
    let t5 = 1.0 / 3_628_800.0 + f * (1.0 / 39_916_800.0);
    let t6 = 1.0 / 479_001_600.0 + f * (1.0 / 6_227_020_800.0);
    let p = (t0 + f2 * t1) + f4 * (t2 + f2 * t3) + f8 * ((t4 + f2 * t5) + f4 * t6);
    // k sits in the low bits of `shifted`; move k + 1023 into the exponent field.
    let k_bits = shifted
        .to_bits()
        .wrapping_sub(SHIFTER.to_bits())
        .wrapping_add(1023);
    p * f64::from_bits(k_bits << 52)
}

/// `x^p` for `x ∈ [0, 4]` and `p ∈ (0, 1)` (the Sobolev kernel's range); `0^p = 0`.
///
/// Relative error below `1e-15 · (1 + |p ln x|)`: a few ulps from the ~10 roundings, scaled by
/// the conditioning of `exp` at `p ln x`.
#[inline(always)]
pub fn pow(x: f64, p: f64) -> f64 {
    // Below 1e-290 `x^p` is far below anything the kernel resolves; 0 keeps exp in range.
    let tiny = x < 1e-290;
    let v = exp(p * ln(if tiny { 1.0 } else { x }));
    if tiny { 0.0 } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use rand::RngExt;

    #[test]
    fn agrees_with_powf_to_rounding() {
        let mut rng = stream(5, &[]);
        let check = |x: f64, p: f64| {
            let want = x.powf(p);
            let rel = ((pow(x, p) - want) / want).abs();
            let bound = 1e-15 * (1.0 + (p * x.ln()).abs());
            assert!(rel <= bound, "x={x:e} p={p}: relative error {rel:e} > {bound:e}");
        };
        for _ in 0..200_000 {
            // Log-uniform over [1e-30, 4], exponents across the Sobolev range s − 1 ∈ (0, 1).
            let x = 4.0 * 10f64.powf(-30.0 * rng.random::<f64>());
            check(x, rng.random::<f64>().max(1e-3));
        }
        for x in [4.0f64, 2.0, 1.0, 0.5, SQRT_2, 1e-12, 1e-280] {
            check(x, 0.4);
        }
        assert_eq!(pow(0.0, 0.4), 0.0);
    }
}
