//! `x^p` for `x ≥ 0` as `exp(p ln x)`, branch-free so that loops over it vectorise: the Sobolev
//! kernel's `‖x − y‖^(2s−2)` dominates the assembly of `Q`.
//!
//! Only IEEE add, multiply, divide, fused multiply–add (`f64::mul_add`, one rounding) and
//! integer bit operations are used, so a vectorised loop gives bit-for-bit the results of a
//! scalar one. `mul_add` is a single instruction where FMA is enabled (the vectorised kernel
//! loops, and [`pow`] through a run-time dispatch) and a correctly rounded library call
//! elsewhere, which is slow but gives the same bits.

use std::f64::consts::{LN_2, SQRT_2};

/// ln 2 split into a part with a short mantissa and a remainder, so `k·ln2` keeps full precision.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1.5·2^52: adding and removing it rounds to an integer, which then sits in the low mantissa bits.
const SHIFTER: f64 = 6_755_399_441_055_744.0;

/// `ln x` for finite `x > 0`: `x = m·2^e` with `m ∈ [√½, √2)`, then
/// `ln m = 2 atanh(r) = 2r · g(r²)`, `r = (m − 1)/(m + 1)`, `r² ≤ 0.0295`, where `g(t)` is the
/// degree-7 polynomial interpolating `atanh(√t)/√t = Σ t^k/(2k+1)` at the Chebyshev nodes of
/// `[0, 0.0295]` (near-minimax: truncation below 1.2e-18, against 2.3e-17 for the ten-term
/// Taylor series it replaces). Coefficients computed at 80 digits (`decimal`), rounded once.
#[inline(always)]
fn ln(x: f64) -> f64 {
    let (e, r) = ln_reduce(x);
    ln_from_reduced(e, r)
}

/// The first half of [`ln`]: `x = m·2^e`, `m ∈ [√½, √2)`, and `r = (m − 1)/(m + 1)`.
#[inline(always)]
fn ln_reduce(x: f64) -> (f64, f64) {
    let bits = x.to_bits();
    // The biased exponent as a double, without an int→float conversion (none in AVX2).
    let e_biased = f64::from_bits((bits >> 52) | 0x4330_0000_0000_0000) - 4_503_599_627_370_496.0;
    let m0 = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m0 > SQRT_2;
    let m = if big { 0.5 * m0 } else { m0 };
    let e = e_biased - 1023.0 + if big { 1.0 } else { 0.0 };
    (e, (m - 1.0) / (m + 1.0))
}

/// The second half of [`ln`]: `e ln 2 + 2r·g(r²)`.
#[inline(always)]
fn ln_from_reduced(e: f64, r: f64) -> f64 {
    const G: [f64; 8] = [
        1.0,
        0.333_333_333_333_338_26,
        0.199_999_999_996_509_55,
        0.142_857_143_803_691_4,
        0.111_110_985_232_021_37,
        0.090_918_161_208_085_13,
        0.076_562_565_573_691_5,
        0.074_049_337_861_565_31,
    ];
    let t = r * r;
    // Estrin's scheme with fused multiply–adds: short dependency chains, one rounding each.
    let t2 = t * t;
    let a = G[1].mul_add(t, G[0]);
    let b = G[3].mul_add(t, G[2]);
    let c = G[5].mul_add(t, G[4]);
    let d = G[7].mul_add(t, G[6]);
    let series = d.mul_add(t2, c).mul_add(t2 * t2, b.mul_add(t2, a));
    // e·LN2_HI is exact (LN2_HI has a short mantissa); the small parts are added first.
    e.mul_add(LN2_HI, (2.0 * r).mul_add(series, e * LN2_LO))
}

/// `exp y` for `y ∈ [−700, 700]`: `y = k ln2 + f`, `|f| ≤ ln2/2`, `e^f` by the degree-11
/// polynomial interpolating it at the Chebyshev nodes of `[−1.0001 ln2/2, 1.0001 ln2/2]`
/// (relative truncation below 4.3e-18, against 4e-18 for the degree-13 Taylor polynomial it
/// replaces), then scaling by `2^k` through the exponent bits.
#[inline(always)]
fn exp(y: f64) -> f64 {
    const P: [f64; 12] = [
        1.0,
        1.0,
        0.500_000_000_000_001_9,
        0.166_666_666_666_666_8,
        0.041_666_666_666_487_95,
        0.008_333_333_333_319_589,
        0.001_388_888_895_235_286_3,
        0.000_198_412_698_900_764_03,
        2.480_148_544_156_131_3e-5,
        2.755_724_088_722_987e-6,
        2.763_265_472_252_779e-7,
        2.511_004_920_481_865_8e-8,
    ];
    let shifted = y * (1.0 / LN_2) + SHIFTER;
    let k = shifted - SHIFTER;
    // y − k ln2 with one rounding for the large part.
    let f = (-k).mul_add(LN2_LO, (-k).mul_add(LN2_HI, y));
    let f2 = f * f;
    let f4 = f2 * f2;
    let q0 = P[3].mul_add(f, P[2]).mul_add(f2, P[1].mul_add(f, P[0]));
    let q1 = P[7].mul_add(f, P[6]).mul_add(f2, P[5].mul_add(f, P[4]));
    let q2 = P[11].mul_add(f, P[10]).mul_add(f2, P[9].mul_add(f, P[8]));
    let p = q2.mul_add(f4 * f4, q1.mul_add(f4, q0));
    // k sits in the low bits of `shifted`; move k + 1023 into the exponent field.
    let k_bits = shifted
        .to_bits()
        .wrapping_sub(SHIFTER.to_bits())
        .wrapping_add(1023);
    p * f64::from_bits(k_bits << 52)
}

/// `x^p` for `x ∈ [0, 4]` and `p ∈ (0, 1)` (the Sobolev kernel's range); `0^p = 0`.
///
/// Relative error below `1e-15 · (1 + |p ln x|)` (tested against `powf`; the largest seen over
/// 200 000 random cases is 4.2e-16 · (1 + |p ln x|)): a few ulps from the roundings, scaled by
/// the conditioning of `exp` at `p ln x`. Scalar callers get the fused multiply–adds as single
/// instructions when the CPU has them (chosen at run time); the bits are the same either way.
#[inline]
pub fn pow(x: f64, p: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU supports FMA, checked just above.
            return unsafe { pow_fma(x, p) };
        }
    }
    pow_inline(x, p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn pow_fma(x: f64, p: f64) -> f64 {
    pow_inline(x, p)
}

/// [`pow`] without the dispatch, for loops that are compiled with FMA (and vectorised) as a
/// whole.
#[inline(always)]
pub fn pow_inline(x: f64, p: f64) -> f64 {
    // Below 1e-290 `x^p` is far below anything the kernel resolves; 0 keeps exp in range.
    let tiny = x < 1e-290;
    let v = exp(p * ln(if tiny { 1.0 } else { x }));
    if tiny { 0.0 } else { v }
}

/// [`pow_inline`] of the first `lanes` entries of a block (`out` beyond them is left as it
/// was), in three stages over the lanes (reduce, `ln`, `exp`) rather than lane by lane: the
/// operations per lane are those of [`pow_inline`], so the bits are too, but each stage's lanes
/// are independent, so a vectorised loop keeps several vectors in flight instead of waiting on
/// one long dependency chain (assembly at N = 512 0.19 → 0.14 ms in `cargo bench --bench core`).
#[inline(always)]
pub fn pow_block<const B: usize>(x: &[f64; B], p: f64, out: &mut [f64; B], lanes: usize) {
    let lanes = lanes.min(B);
    let mut e = [0.0f64; B];
    let mut r = [0.0f64; B];
    for l in 0..lanes {
        let tiny = x[l] < 1e-290;
        (e[l], r[l]) = ln_reduce(if tiny { 1.0 } else { x[l] });
    }
    let mut y = [0.0f64; B];
    for l in 0..lanes {
        y[l] = p * ln_from_reduced(e[l], r[l]);
    }
    for l in 0..lanes {
        let tiny = x[l] < 1e-290;
        let v = exp(y[l]);
        out[l] = if tiny { 0.0 } else { v };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::stream;
    use rand::RngExt;

    /// The staged block gives [`pow_inline`]'s bits in every lane, whatever the lane count,
    /// zero and tiny arguments included.
    #[test]
    fn block_matches_the_scalar_pow_bit_for_bit() {
        let mut rng = stream(7, &[]);
        for lanes in [0, 1, 7, 8, 13, 32] {
            let mut x = [0.0f64; 32];
            for v in x.iter_mut() {
                *v = 4.0 * 10f64.powf(-20.0 * rng.random::<f64>());
            }
            x[0] = 0.0;
            x[3] = 1e-300;
            let mut out = [-1.0f64; 32];
            pow_block(&x, 0.4, &mut out, lanes);
            for l in 0..32 {
                let want = if l < lanes { pow_inline(x[l], 0.4) } else { -1.0 };
                assert_eq!(out[l].to_bits(), want.to_bits(), "lanes {lanes}, lane {l}");
            }
        }
    }

    #[test]
    fn agrees_with_powf_to_rounding() {
        let mut rng = stream(5, &[]);
        let mut worst: f64 = 0.0;
        let mut check = |x: f64, p: f64| {
            let want = x.powf(p);
            let rel = ((pow(x, p) - want) / want).abs();
            let scale = 1.0 + (p * x.ln()).abs();
            worst = worst.max(rel / scale);
            assert!(
                rel <= 1e-15 * scale,
                "x={x:e} p={p}: relative error {rel:e} > {:e}",
                1e-15 * scale
            );
            // The scalar path without the dispatch gives the same bits.
            assert_eq!(pow(x, p).to_bits(), pow_inline(x, p).to_bits());
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
        eprintln!("fast_pow: largest relative error / (1 + |p ln x|) = {worst:e}");
    }
}
