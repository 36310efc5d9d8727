//! The kernel mean `z(x) = ∫_H k(x, ω) dω` and `V̂ = ∫_H ∫_H k dω dω'` (math.md §4).
//!
//! Both kernels are isotropic, so `z` depends only on `μ = x·n = cos θ_x`.

mod exact;
mod table;

pub use exact::{kernel_mean_exact, prior_variance_exact};
pub use table::KernelMeanTable;

use crate::bq::kernel::Kernel;
use crate::util::geometry::Vec3;

/// How the kernel means `z_i` of a sample set are obtained.
///
/// The two MC variants estimate every `z_i = ∫_H k(x_i, ω) dω` by
/// `ẑ_i = (2π/M) Σ_j k(x_i, ω_j)` with `M` uniform directions (pdf `1/(2π)`, math.md §2–§4); they
/// differ in which directions each point gets, and so in how the errors `ẑ_i − z_i` are
/// correlated (which is what reaches the BMC estimate `wᵀY` and the posterior variance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KernelMeanMode {
    /// The exact `z(μ)`, tabulated once per kernel (the default).
    Exact,
    /// The thesis's estimate: each `z_i` by plain MC with its own fresh set of `samples` uniform
    /// directions `ω_{i,1..M}`, `ẑ_i = (2π/M) Σ_j k(x_i, ω_{i,j})`, so the errors of different
    /// `z_i` are independent. This is what the thesis did: §3.2.4 "I computed it using the
    /// classical Monte Carlo method with 10000 samples and a uniform PDF", and its code calls
    /// `compute_z` once per sample point, drawing new directions on each call (issue 8,
    /// item 10). See [`kernel_means_mc_per_point`] for how the directions derive from the
    /// caller's rng.
    MonteCarlo { samples: usize },
    /// A variant of the thesis's estimate: one set of `samples` uniform directions `ω_{1..M}`,
    /// drawn per weight set and shared by every point, `ẑ_i = (2π/M) Σ_j k(x_i, ω_j)`. Cheaper
    /// (M direction draws instead of N·M; both take N·M kernel evaluations), but the errors of
    /// nearby `z_i` are almost perfectly correlated; it is not what the thesis did. It is what
    /// this workbench's `"mc"` mode computed before the per-point reading was added, kept so
    /// those numbers can be reproduced. See [`kernel_means_mc`].
    MonteCarloShared { samples: usize },
}

impl KernelMeanMode {
    /// The thesis's default number of MC samples per `z_i`.
    pub const THESIS_SAMPLES: usize = 10_000;
    /// Largest M: the directions of one weight set take 24 bytes each, per worker thread.
    pub const MAX_SAMPLES: usize = 10_000_000;

    /// The thesis's MC mode (fresh directions per point, [`KernelMeanMode::MonteCarlo`]) with
    /// `samples` directions, checked to lie in `1..=MAX_SAMPLES`.
    pub fn monte_carlo(samples: u64) -> Result<Self, String> {
        Ok(KernelMeanMode::MonteCarlo {
            samples: Self::check_samples(samples)?,
        })
    }

    /// The shared-directions MC mode ([`KernelMeanMode::MonteCarloShared`]) with `samples`
    /// directions, checked to lie in `1..=MAX_SAMPLES`.
    pub fn monte_carlo_shared(samples: u64) -> Result<Self, String> {
        Ok(KernelMeanMode::MonteCarloShared {
            samples: Self::check_samples(samples)?,
        })
    }

    /// M for the MC modes, `None` for the exact one.
    pub fn samples(&self) -> Option<usize> {
        match *self {
            KernelMeanMode::Exact => None,
            KernelMeanMode::MonteCarlo { samples } | KernelMeanMode::MonteCarloShared { samples } => {
                Some(samples)
            }
        }
    }

    fn check_samples(samples: u64) -> Result<usize, String> {
        if samples == 0 || samples > Self::MAX_SAMPLES as u64 {
            return Err(format!(
                "must be in 1..={} (M uniform directions take 24 bytes each per worker thread), got {samples}",
                Self::MAX_SAMPLES
            ));
        }
        Ok(samples as usize)
    }
}

/// `z(x) ≈ (2π/M) Σ_j k(x, ω_j)` over the given uniform directions (the thesis's mode).
///
/// # Panics
/// If there are no directions (the estimate is undefined; callers validate M ≥ 1).
pub fn kernel_mean_mc(kernel: &Kernel, x: &Vec3, uniform_directions: &[Vec3]) -> f64 {
    kernel_means_mc(
        kernel,
        std::slice::from_ref(x),
        &crate::bq::kernel::PointsSoa::new(uniform_directions),
    )[0]
}

/// [`kernel_mean_mc`] for every point, sharing one set of directions (stored as arrays so the
/// kernel sums vectorise); the sums run in direction order, so results are reproducible.
/// This is [`KernelMeanMode::MonteCarloShared`].
pub fn kernel_means_mc(
    kernel: &Kernel,
    points: &[Vec3],
    directions: &crate::bq::kernel::PointsSoa,
) -> Vec<f64> {
    let m = directions.len();
    assert!(m > 0, "an MC kernel mean needs at least one direction");
    let mut row = vec![0.0; m];
    points
        .iter()
        .map(|x| {
            kernel.fill_against(directions, 0, x, &mut row);
            std::f64::consts::TAU * row.iter().sum::<f64>() / m as f64
        })
        .collect()
}

/// [`KernelMeanMode::MonteCarlo`]: every point `x_i` gets its own `samples` uniform directions,
/// `ẑ_i = (2π/M) Σ_j k(x_i, ω_{i,j})` (the thesis's reading, which draws new directions for each
/// `z_i`).
///
/// Exactly one `u64` is drawn from `rng` (a base seed `b`); point `i`'s directions come from
/// [`crate::util::rng::stream`]`(b, [i])`. So the result depends only on `rng`'s state and the points:
/// reproducible, and it would not change if the points were split between threads. One
/// direction buffer (as arrays, so the kernel sums vectorise) is reused for every point; the
/// cost is N·M direction draws and N·M kernel evaluations.
///
/// # Panics
/// If `samples` is 0 (the estimate is undefined; callers validate M ≥ 1).
pub fn kernel_means_mc_per_point<R: rand::Rng + ?Sized>(
    kernel: &Kernel,
    points: &[Vec3],
    samples: usize,
    rng: &mut R,
) -> Vec<f64> {
    use rand::RngExt;
    assert!(samples > 0, "an MC kernel mean needs at least one direction");
    let base: u64 = rng.random();
    let mut directions = crate::bq::kernel::PointsSoa {
        x: vec![0.0; samples],
        y: vec![0.0; samples],
        z: vec![0.0; samples],
    };
    let mut row = vec![0.0; samples];
    points
        .iter()
        .enumerate()
        .map(|(i, x)| {
            fill_uniform_directions(&mut crate::util::rng::stream(base, &[i as u64]), &mut directions);
            kernel.fill_against(&directions, 0, x, &mut row);
            std::f64::consts::TAU * row.iter().sum::<f64>() / samples as f64
        })
        .collect()
}

/// Overwrites `directions` with uniform directions on the hemisphere: the map of
/// [`crate::sampling::Density::Uniform`] (`cos θ = u1`, `φ = 2π u2`, with `u1, u2` drawn in the
/// same order as its `sample`), so the directions equal `Density::Uniform.map(u1, u2)` up to a
/// few units in the last place.
///
/// Why not call `Density::Uniform.sample`: `f64::sin_cos` is a library call that costs ~20 ns,
/// ten times the random numbers, and the per-point mode draws N·M directions. Here the numbers
/// are drawn first and the map runs as a separate loop with [`cos_sin_turn`], which vectorises.
fn fill_uniform_directions<R: rand::Rng + ?Sized>(
    rng: &mut R,
    directions: &mut crate::bq::kernel::PointsSoa,
) {
    use rand::RngExt;
    let crate::bq::kernel::PointsSoa { x, y, z } = directions;
    // u1 in z (it is cos θ), u2 in x until the second loop replaces it.
    for (u1, u2) in z.iter_mut().zip(x.iter_mut()) {
        *u1 = rng.random();
        *u2 = rng.random();
    }
    map_to_directions(x, y, z);
}

/// `(x, y, z) ← (sin θ cos φ, sin θ sin φ, u1)` from `(u2, ·, u1)`, `cos θ = u1`, `φ = 2π u2`.
///
/// Like [`Kernel::fill_against`], it runs with AVX-512F or AVX2 when the CPU has them; the same
/// IEEE operations in the same order (no fused multiply–add), so the result does not depend on
/// the vector width.
fn map_to_directions(x: &mut [f64], y: &mut [f64], z: &[f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            unsafe { map_to_directions_avx512(x, y, z) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { map_to_directions_avx2(x, y, z) };
            return;
        }
    }
    map_to_directions_generic(x, y, z);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn map_to_directions_avx512(x: &mut [f64], y: &mut [f64], z: &[f64]) {
    map_to_directions_generic(x, y, z);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn map_to_directions_avx2(x: &mut [f64], y: &mut [f64], z: &[f64]) {
    map_to_directions_generic(x, y, z);
}

#[inline(always)]
fn map_to_directions_generic(x: &mut [f64], y: &mut [f64], z: &[f64]) {
    for ((x, y), z) in x.iter_mut().zip(y.iter_mut()).zip(z.iter()) {
        let sin_theta = (1.0 - z * z).max(0.0).sqrt();
        let (c, s) = cos_sin_turn(*x);
        *x = sin_theta * c;
        *y = sin_theta * s;
    }
}

/// `(cos 2πv, sin 2πv)` for `v ∈ [0, 1]`, within a few ulps of `f64::sin_cos`, without branches
/// or library calls (so loops over it vectorise).
///
/// Reduction: `k = round(4v)`, `f = v − k/4 ∈ [−1/8, 1/8]` (exact in floating point for
/// `v ∈ [0, 1]`), `θ = 2πf ∈ [−π/4, π/4]`; `sin θ` and `cos θ` by their Taylor series to
/// `θ¹⁵` and `θ¹⁶` (truncation below `(π/4)¹⁷/17! < 5e-17`); then the quarter turns `k`:
/// `(cos, sin)(θ + kπ/2)` is `(c, s)`, `(−s, c)`, `(−c, −s)`, `(s, −c)` for `k mod 4 = 0..3`.
#[inline(always)]
fn cos_sin_turn(v: f64) -> (f64, f64) {
    // round(4v) by the 1.5·2⁵² trick (exact for |4v| < 2⁵¹): `f64::round` is a library call
    // on baseline x86-64 and would stop the loop from vectorising.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let k = (4.0 * v + ROUND) - ROUND;
    let t = std::f64::consts::TAU * (v - 0.25 * k);
    let t2 = t * t;
    // 1/n! for n = 2..16, written out so they are compile-time constants.
    const F2: f64 = 1.0 / 2.0;
    const F3: f64 = F2 / 3.0;
    const F4: f64 = F3 / 4.0;
    const F5: f64 = F4 / 5.0;
    const F6: f64 = F5 / 6.0;
    const F7: f64 = F6 / 7.0;
    const F8: f64 = F7 / 8.0;
    const F9: f64 = F8 / 9.0;
    const F10: f64 = F9 / 10.0;
    const F11: f64 = F10 / 11.0;
    const F12: f64 = F11 / 12.0;
    const F13: f64 = F12 / 13.0;
    const F14: f64 = F13 / 14.0;
    const F15: f64 = F14 / 15.0;
    const F16: f64 = F15 / 16.0;
    let s = t * (1.0 - t2 * (F3 - t2 * (F5 - t2 * (F7 - t2 * (F9 - t2 * (F11 - t2 * (F13 - t2 * F15)))))));
    let c =
        1.0 - t2 * (F2 - t2 * (F4 - t2 * (F6 - t2 * (F8 - t2 * (F10 - t2 * (F12 - t2 * (F14 - t2 * F16)))))));
    // k ∈ {0, …, 4}; 4 is a full turn.
    let odd = k == 1.0 || k == 3.0;
    let (a, b) = if odd { (s, c) } else { (c, s) };
    let cos = if k == 1.0 || k == 2.0 { -a } else { a };
    let sin = if k == 2.0 || k == 3.0 { -b } else { b };
    (cos, sin)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The polynomial turn agrees with `sin_cos` to a few ulps over `[0, 1]`, including the
    /// quadrant edges and the ends.
    #[test]
    fn cos_sin_turn_matches_the_library() {
        let mut worst: f64 = 0.0;
        let edges = (0..=8).map(|k| k as f64 / 8.0);
        let grid = (0..=200_000).map(|i| i as f64 / 200_000.0);
        let near = (0..=8).flat_map(|k| {
            let e = k as f64 / 8.0;
            [e - 1e-12, e + 1e-12, e - f64::EPSILON, e + f64::EPSILON]
        });
        for v in edges.chain(grid).chain(near).filter(|v| (0.0..=1.0).contains(v)) {
            let (c, s) = cos_sin_turn(v);
            let (s0, c0) = (std::f64::consts::TAU * v).sin_cos();
            worst = worst.max((c - c0).abs()).max((s - s0).abs());
        }
        // sin_cos itself is off by up to ~1e-16·|2πv| from rounding 2πv; a few ulps of 1.
        assert!(worst < 1e-15, "max |Δ| = {worst:e}");
    }

    /// The directions are `Density::Uniform`'s for the same random numbers, to a few ulps.
    #[test]
    fn fill_uniform_directions_is_the_uniform_design() {
        let m = 10_000;
        let want = crate::sampling::Density::Uniform.sample_set(m, &mut crate::util::rng::stream(5, &[]));
        let mut got = crate::bq::kernel::PointsSoa::new(&vec![Vec3::new(0.0, 0.0, 0.0); m]);
        fill_uniform_directions(&mut crate::util::rng::stream(5, &[]), &mut got);
        for (j, w) in want.iter().enumerate() {
            let d = (got.x[j] - w.x).abs().max((got.y[j] - w.y).abs());
            assert!(d < 1e-15 && got.z[j] == w.z, "direction {j}: {d:e}");
        }
    }
}
