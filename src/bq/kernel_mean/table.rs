//! `z(μ)` tabulated once per kernel for O(1) lookups (math.md §4).
//!
//! `z` is analytic on `(0, 1]` but has an endpoint singularity at the horizon `μ = 0` (for the
//! Sobolev kernel a `μ^(2s)`-type term), so a single polynomial on `[0, 1]` converges slowly.
//! Instead `[0, 1]` is cut into octaves `[2^−(k+1), 2^−k]`, `k = 0..OCTAVES`, plus `[0, 2^−OCTAVES]`:
//! on each octave the singularity is one octave-width away, so Chebyshev interpolation converges
//! geometrically (factor `≈ 1/5.8` per node), and on the last panel the non-polynomial part is
//! `O(2^(−2s·OCTAVES))`, far below rounding. An octave is further split into `2^j` equal
//! sub-panels until the interpolant's trailing Chebyshev coefficients are negligible (needed for
//! squared-exponential kernels with short length scales). A lookup finds the octave from the
//! floating-point exponent of `μ` and the sub-panel by one multiplication.

use super::exact::kernel_mean_exact;
use crate::bq::kernel::Kernel;
use crate::util::quadrature::{chebyshev_coefficients, chebyshev_eval, chebyshev_integral, chebyshev_points};
use std::f64::consts::TAU;

/// Octaves `[2^−(k+1), 2^−k]` before the last panel `[0, 2^−OCTAVES]`.
const OCTAVES: usize = 26;
/// Chebyshev nodes per sub-panel.
const NODES: usize = 16;
/// Accept a sub-panel when its three trailing coefficients are below this times the largest
/// `|z|` on it (the interpolation error is a small multiple of the neglected coefficients).
const TAIL_TOLERANCE: f64 = 1e-14;
/// At most `2^MAX_SPLIT` sub-panels per octave.
const MAX_SPLIT: u32 = 8;

/// One octave: `[lo, lo + width]` in `count` equal sub-panels starting at `first`.
#[derive(Clone, Copy, Debug)]
struct Octave {
    lo: f64,
    /// `count / width`: maps `μ − lo` to the sub-panel index plus the fraction within it.
    scale: f64,
    first: usize,
    count: usize,
}

/// The exact kernel mean `z(μ) = ∫_H k(x, ω) dω`, `μ = x·n ∈ [0, 1]`, tabulated as piecewise
/// Chebyshev interpolants on octaves graded toward the horizon (math.md §4).
///
/// Built from [`kernel_mean_exact`] at the Chebyshev nodes (a few hundred evaluations, ~10 ms);
/// lookups are O(1) (~30 ns) with relative error ≲ 1e-14 everywhere on `[0, 1]`
/// (tested ≤ 1e-10 in `tests/it/bq/kernel_mean.rs`). Also holds `V̂ = 2π ∫_0^1 z(μ) dμ`, the integral of
/// the interpolant (Clenshaw–Curtis on the same exact values).
#[derive(Clone, Debug)]
pub struct KernelMeanTable {
    kernel: Kernel,
    /// Index `k` for octave `k`; index `OCTAVES` is the last panel `[0, 2^−OCTAVES]`.
    octaves: Vec<Octave>,
    /// Chebyshev coefficients of every sub-panel, `NODES` each, flattened.
    coefficients: Vec<f64>,
    prior_variance: f64,
    /// Octaves still unconverged at the split limit (0 for every kernel tested).
    unconverged: usize,
}

impl KernelMeanTable {
    /// Tabulates `z` for `kernel`.
    pub fn new(kernel: &Kernel) -> Self {
        let x = chebyshev_points(NODES);
        let mut octaves = Vec::with_capacity(OCTAVES + 1);
        let mut coefficients = Vec::new();
        let mut integral = 0.0;
        let mut unconverged = 0;
        for k in 0..=OCTAVES {
            let (lo, hi) = if k == OCTAVES {
                (0.0, 0.5f64.powi(OCTAVES as i32))
            } else {
                (0.5f64.powi(k as i32 + 1), 0.5f64.powi(k as i32))
            };
            let mut split = 0;
            let (panels, count) = loop {
                let count = 1usize << split;
                let w = (hi - lo) / count as f64;
                let panels: Vec<Vec<f64>> = (0..count)
                    .map(|j| {
                        let c = lo + (j as f64 + 0.5) * w;
                        let values: Vec<f64> = x
                            .iter()
                            .map(|&x| kernel_mean_exact(kernel, c + 0.5 * w * x))
                            .collect();
                        chebyshev_coefficients(&values)
                    })
                    .collect();
                if panels.iter().all(|c| converged(c)) {
                    break (panels, count);
                }
                if split == MAX_SPLIT {
                    unconverged += 1;
                    break (panels, count);
                }
                split += 1;
            };
            let w = (hi - lo) / count as f64;
            octaves.push(Octave {
                lo,
                scale: count as f64 / (hi - lo),
                first: coefficients.len() / NODES,
                count,
            });
            for c in panels {
                integral += 0.5 * w * chebyshev_integral(&c);
                coefficients.extend_from_slice(&c);
            }
        }
        KernelMeanTable {
            kernel: *kernel,
            octaves,
            coefficients,
            prior_variance: TAU * integral,
            unconverged,
        }
    }

    /// A warning with its remedy if some octave of the table did not reach its tolerance (the
    /// kernel varies on a scale far below the panels, e.g. an SE length scale ≪ 0.05).
    pub fn accuracy_warning(&self) -> Option<String> {
        // The remedy depends on why: an SE kernel varies too fast; a Sobolev kernel just above
        // s = 2 or 3 has lost its scale (math.md §9), and no length scale is involved.
        let remedy = match &self.kernel {
            Kernel::Sobolev(_) => {
                "use an s farther from 2 or 3 (math.md §9: the kernel's scale vanishes there)"
            }
            _ => "use a longer length scale",
        };
        (self.unconverged > 0).then(|| {
            format!(
                "the kernel-mean table of {} did not converge on {} of its {} octaves, so z may be \
                 less accurate than 1e-10 there; {remedy}",
                self.kernel,
                self.unconverged,
                OCTAVES + 1
            )
        })
    }

    /// The kernel this table belongs to.
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// `z(μ)` for `μ ∈ [0, 1]` (clamped into it; NaN gives NaN). O(1): the octave comes from the
    /// binary exponent of `μ`, the sub-panel from one multiplication, then Clenshaw.
    #[inline]
    pub fn z(&self, mu: f64) -> f64 {
        let mu = mu.clamp(0.0, 1.0);
        // μ ∈ [2^−(k+1), 2^−k) has biased exponent 1022 − k; μ = 1 belongs to octave 0, and
        // anything below 2^−OCTAVES (including 0 and subnormals) to the last panel.
        let biased = ((mu.to_bits() >> 52) & 0x7ff) as i64;
        let k = (1022 - biased).clamp(0, OCTAVES as i64) as usize;
        let o = &self.octaves[k];
        let s = (mu - o.lo) * o.scale;
        // `as usize` saturates (NaN → 0), so the index is always in range.
        let j = (s as usize).min(o.count - 1);
        let t = 2.0 * (s - j as f64) - 1.0;
        let start = (o.first + j) * NODES;
        chebyshev_eval(&self.coefficients[start..start + NODES], t)
    }

    /// `V̂ = ∫_H ∫_H k dω dω' = 2π ∫_0^1 z(μ) dμ`.
    pub fn prior_variance(&self) -> f64 {
        self.prior_variance
    }
}

/// Whether a sub-panel's interpolant has resolved `z`: the last three coefficients (three, so
/// that an accidental zero from parity cannot fool the test) are negligible relative to `c_0`,
/// which is about the mean of `z > 0` on the panel.
fn converged(c: &[f64]) -> bool {
    let scale = c[0].abs();
    c[c.len() - 3..]
        .iter()
        .all(|&t| t.abs() <= TAIL_TOLERANCE * scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bq::kernel::{Sobolev, SquaredExponential};

    #[test]
    fn table_is_clone_debug_send_sync() {
        fn check<T: Clone + std::fmt::Debug + Send + Sync>() {}
        check::<KernelMeanTable>();
    }

    /// The octave lookup puts every μ into the panel that contains it.
    #[test]
    fn lookup_finds_the_containing_panel() {
        let t = KernelMeanTable::new(&Kernel::Sobolev(Sobolev::new(1.4).unwrap()));
        for mu in [
            1.0,
            0.75,
            0.5,
            0.4999999,
            0.25,
            1e-3,
            2f64.powi(-26),
            2f64.powi(-27),
            1e-300,
            0.0,
        ] {
            let k = (1022 - ((mu.to_bits() >> 52) & 0x7ff) as i64).clamp(0, OCTAVES as i64) as usize;
            let o = &t.octaves[k];
            let hi = o.lo + o.count as f64 / o.scale;
            assert!(o.lo <= mu && mu <= hi, "μ={mu}: octave {k} = [{}, {hi}]", o.lo);
        }
    }

    #[test]
    fn short_length_scale_splits_octaves() {
        let t = KernelMeanTable::new(&Kernel::SquaredExponential(
            SquaredExponential::new(1.0, 0.1).unwrap(),
        ));
        assert!(t.octaves.iter().any(|o| o.count > 1));
        assert!(t.z(f64::NAN).is_nan());
    }
}
