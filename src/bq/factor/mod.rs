//! Factors of `Q = K + σ_n² I` (math.md §5): one [`Factor`] type over the three structures a
//! point set can have — dense ([`dense`]), nested stages grown by blocks ([`nested`]) and rings
//! ([`rings`]) — with one jitter ladder ([`jitter_ladder`]) and one condition estimate
//! ([`condition_estimate`]) for all of them.

pub mod dense;
pub mod nested;
pub mod rings;

pub use dense::{CholeskyFactor, SpdWorkspace};
pub use nested::NestedCholesky;
pub use rings::RingFactor;

use faer::Mat;

/// The jitter ladder: after a failed factorisation, `JITTER_START · mean(diag Q)` is added to the
/// diagonal, growing tenfold per step, at most `JITTER_STEPS` times (so up to `1e-4 · mean(diag)`).
pub const JITTER_START: f64 = 1e-12;
pub const JITTER_STEPS: usize = 9;

/// A condition estimate above this is reported as a warning.
pub const ILL_CONDITIONED: f64 = 1e12;

/// A factor whose condition estimate exceeds this is treated as failed: `Q` is numerically
/// singular (e.g. duplicate points without noise) and the solve would amplify rounding by
/// more than 1e14, so the jitter ladder is climbed instead.
pub const NUMERICALLY_SINGULAR: f64 = 1e14;

/// Cholesky failed even with the largest jitter: defined with the library's errors
/// ([`crate::error`]), the floor every room stands on, and named here where it arises.
pub use crate::error::NotPositiveDefinite;

/// What the factorisation needed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorInfo {
    /// Amount added to the diagonal (0 when none was needed).
    pub jitter: f64,
    /// `(max L_ii / min L_ii)²`: a lower bound on the 2-norm condition number of `Q`, and
    /// within a small factor of it in practice; it costs nothing once `L` is known.
    pub condition_estimate: f64,
}

/// The jitter ladder, the one every factorisation climbs: `attempt(step, jitter)` assembles and
/// factors `Q + jitter·I` (at step 0 with `floor`, normally no jitter) and returns the factor's
/// condition estimate, or `None` when Cholesky failed. From step 1 on the jitter is
/// `JITTER_START · 10^(step−1) · mean_diag`, at least `floor` (a nested factor keeps the jitter
/// of its earlier stages). A factor is accepted unless its estimate exceeds
/// [`NUMERICALLY_SINGULAR`] before the last step. On failure, the last jitter tried.
pub fn jitter_ladder(
    mean_diag: f64,
    floor: f64,
    mut attempt: impl FnMut(usize, f64) -> Option<f64>,
) -> Result<FactorInfo, f64> {
    let mut jitter = floor;
    for step in 0..=JITTER_STEPS {
        if step > 0 {
            let rung = JITTER_START * 10f64.powi(step as i32 - 1) * mean_diag;
            jitter = if floor > 0.0 { rung.max(floor) } else { rung };
        }
        if let Some(condition_estimate) = attempt(step, jitter)
            && (condition_estimate <= NUMERICALLY_SINGULAR || step == JITTER_STEPS)
        {
            return Ok(FactorInfo {
                jitter,
                condition_estimate,
            });
        }
    }
    Err(jitter)
}

/// `(max L_ii / min L_ii)²` over a factor's diagonal (1 for an empty one): a lower bound on the
/// 2-norm condition number of `Q`, within a small factor of it in practice, free once `L` is
/// known. For a ring factor the diagonal runs over every block (the blocks are `Q` in a unitary
/// basis, so the bound holds there too).
pub fn condition_estimate(diagonal: impl IntoIterator<Item = f64>) -> f64 {
    let (mut lo, mut hi, mut any) = (f64::INFINITY, 0.0f64, false);
    for d in diagonal {
        lo = lo.min(d);
        hi = hi.max(d);
        any = true;
    }
    if any { (hi / lo).powi(2) } else { 1.0 }
}

/// A kept factorisation of `Q`, whatever its structure: what a caller that solves with the
/// same `Q` later holds (the renderer's sample sets, a staged rule).
#[derive(Clone, Debug)]
pub enum Factor {
    Dense(CholeskyFactor),
    Nested(NestedCholesky),
    Rings(RingFactor),
}

impl Factor {
    /// `N`, the order of the factored `Q`.
    pub fn n(&self) -> usize {
        match self {
            Factor::Dense(f) => f.n(),
            Factor::Nested(f) => f.n(),
            Factor::Rings(f) => f.n(),
        }
    }

    /// Solves `Q X = B` in place for `columns` right-hand sides, column-major
    /// (`b.len() == n · columns`).
    pub fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        match self {
            Factor::Dense(f) => f.solve_columns_in_place(b, columns),
            Factor::Nested(f) => f.solve_columns_in_place(b, columns),
            Factor::Rings(f) => f.solve_columns_in_place(b, columns),
        }
    }

    /// `diag(Q⁻¹)`, for the leave-one-out amplitude (math.md §7).
    pub fn inverse_diagonal(&self) -> Vec<f64> {
        match self {
            Factor::Dense(f) => f.inverse_diagonal(),
            Factor::Nested(f) => f.inverse_diagonal(),
            Factor::Rings(f) => f.inverse_diagonal(),
        }
    }

    /// `log det Q` of the factored `Q` (jitter included), for the marginal likelihood (math.md §9).
    pub fn log_det(&self) -> f64 {
        match self {
            Factor::Dense(f) => f.log_det(),
            Factor::Nested(f) => lower_log_det((0..f.n()).map(|i| f.entry(i, i))),
            Factor::Rings(f) => f.log_det(),
        }
    }
}

/// `log det Q = 2 Σ log L_ii` from the diagonal of a Cholesky factor `Q = L Lᵀ`, summed in
/// index order.
pub fn lower_log_det(diagonal: impl IntoIterator<Item = f64>) -> f64 {
    2.0 * diagonal.into_iter().map(f64::ln).sum::<f64>()
}

/// `diag(Q⁻¹)` from the lower Cholesky factor `L` of `Q = L Lᵀ` held in the leading `n × n`
/// block of `factor`: `(Q⁻¹)_ii = ‖L⁻¹ e_i‖²`, each `L⁻¹ e_i` a forward substitution that starts
/// at row `i`, column-oriented over `L`'s contiguous columns (`N³/6` multiply–adds). The one
/// implementation behind [`SpdWorkspace::inverse_diagonal`], the kept factor and the nested one.
pub fn lower_inverse_diagonal(factor: &Mat<f64>, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    let mut x = vec![0.0; n];
    for i in 0..n {
        x[i..].fill(0.0);
        x[i] = 1.0;
        for j in i..n {
            let xj = x[j] / factor[(j, j)];
            x[j] = xj;
            if xj != 0.0 {
                let col = factor
                    .col(j)
                    .try_as_col_major()
                    .expect("faer Mat columns are contiguous")
                    .as_slice();
                for (xk, lk) in x[j + 1..n].iter_mut().zip(&col[j + 1..n]) {
                    *xk -= lk * xj;
                }
            }
        }
        out[i] = x[i..].iter().map(|v| v * v).sum();
    }
    out
}
