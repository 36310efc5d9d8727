//! Dense symmetric positive-definite solves by Cholesky (faer), with a jitter ladder.
//!
//! faer's factorisation runs at ≈ 3× nalgebra's on this project's sizes (see `benches/core.rs`
//! and the README). It always runs sequentially here: parallelism is over trials, pixels or
//! sample sets, and a fixed operation order keeps results independent of the thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};

mod dense;
pub use dense::CholeskyFactor;
pub mod nested;
pub mod rings;

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

/// Cholesky failed even with the largest jitter.
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "Q is not positive definite even with jitter {jitter:.3e} added to its diagonal \
     (n = {n}); increase the noise σ_n² or remove duplicate points"
)]
pub struct NotPositiveDefinite {
    pub n: usize,
    pub jitter: f64,
}

/// A factorisation of `Q` that exploits its structure (e.g. [`crate::bq::factor::rings::RingFactor`]
/// for ring designs), held by a [`SpdWorkspace`] in place of the dense factor.
pub trait StructuredFactor: Send {
    /// `N`, the order of `Q`.
    fn len(&self) -> usize;
    /// Whether `Q` is empty.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Solves `Q x = b` in place in `b`.
    fn solve_in_place(&self, b: &mut [f64]);
    /// `diag(Q⁻¹)`.
    fn inverse_diagonal(&self) -> Vec<f64>;
}

/// Reusable storage for `Q` and its Cholesky factor, in one matrix.
///
/// `Q` is assembled (lower triangle) straight into the buffer the factorisation overwrites, so
/// a worker holds one `n_max²` matrix (8 n² bytes), not a copy of `Q` beside its factor; a
/// jitter retry assembles `Q` again, which costs less than keeping the copy. The buffer grows to
/// the largest `n` seen and is then reused as an `n × n` view, so a worker that alternates
/// between sample counts never reallocates.
///
/// A structured factorisation ([`SpdWorkspace::hold_structured`]) replaces the dense one until
/// the next [`SpdWorkspace::factor_with`]: the solves then go through it.
pub struct SpdWorkspace {
    factor: Mat<f64>,
    n: usize,
    structured: Option<Box<dyn StructuredFactor>>,
    scratch: Option<MemBuffer>,
    scratch_n: usize,
}

/// What the factorisation needed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorInfo {
    /// Amount added to the diagonal (0 when none was needed).
    pub jitter: f64,
    /// `(max L_ii / min L_ii)²`: a lower bound on the 2-norm condition number of `Q`, and
    /// within a small factor of it in practice; it costs nothing once `L` is known.
    pub condition_estimate: f64,
}

impl Default for SpdWorkspace {
    fn default() -> Self {
        Self::new()
    }
}

impl SpdWorkspace {
    pub fn new() -> Self {
        SpdWorkspace {
            factor: Mat::zeros(0, 0),
            n: 0,
            structured: None,
            scratch: None,
            scratch_n: 0,
        }
    }

    /// Fills the lower triangle of the `n × n` matrix `Q` column by column into the factor's
    /// buffer: `fill(j, col)` writes `Q[j.., j]` into `col`. (Timing and tests; the solves use
    /// [`SpdWorkspace::factor_with`], which assembles and factors.)
    pub fn assemble_lower_by_columns(&mut self, n: usize, mut fill: impl FnMut(usize, &mut [f64])) {
        self.structured = None;
        if self.factor.nrows() < n {
            self.factor = Mat::zeros(n, n);
        }
        self.n = n;
        for j in 0..n {
            let col = self
                .factor
                .col_mut(j)
                .try_as_col_major_mut()
                .expect("faer Mat columns are contiguous");
            fill(j, &mut col.as_slice_mut()[j..n]);
        }
    }

    /// Assembles `Q` with `entry(i, j)` (`j ≤ i`) and factors it (see [`SpdWorkspace::factor_with`]).
    pub fn factor_entries(
        &mut self,
        n: usize,
        mut entry: impl FnMut(usize, usize) -> f64,
    ) -> Result<FactorInfo, NotPositiveDefinite> {
        self.factor_with(n, |j, col| {
            for (k, v) in col.iter_mut().enumerate() {
                *v = entry(j + k, j);
            }
        })
    }

    /// Assembles `Q` in place (`fill` as in [`SpdWorkspace::assemble_lower_by_columns`]) and
    /// factors it, `Q = L Lᵀ`, climbing the jitter ladder when Cholesky fails or its factor is
    /// numerically singular (condition estimate above [`NUMERICALLY_SINGULAR`]): each retry
    /// assembles `Q` again, since the failed attempt overwrote it, and adds the jitter.
    pub fn factor_with(
        &mut self,
        n: usize,
        mut fill: impl FnMut(usize, &mut [f64]),
    ) -> Result<FactorInfo, NotPositiveDefinite> {
        if self.scratch.is_none() || self.scratch_n < n {
            let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default());
            self.scratch = Some(MemBuffer::new(req));
            self.scratch_n = n;
        }
        self.assemble_lower_by_columns(n, &mut fill);
        let mean_diag = (0..n).map(|i| self.factor[(i, i)]).sum::<f64>() / n.max(1) as f64;
        let mut jitter = 0.0;
        for step in 0..=JITTER_STEPS {
            if step > 0 {
                jitter = JITTER_START * 10f64.powi(step as i32 - 1) * mean_diag;
                self.assemble_lower_by_columns(n, &mut fill);
                for j in 0..n {
                    self.factor[(j, j)] += jitter;
                }
            }
            let stack = MemStack::new(self.scratch.as_mut().expect("scratch allocated above"));
            let ok = llt::factor::cholesky_in_place(
                self.factor.as_mut().submatrix_mut(0, 0, n, n),
                Default::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .is_ok();
            if ok {
                let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
                for i in 0..n {
                    let d = self.factor[(i, i)];
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
                let condition_estimate = if n == 0 { 1.0 } else { (hi / lo).powi(2) };
                if condition_estimate <= NUMERICALLY_SINGULAR || step == JITTER_STEPS {
                    return Ok(FactorInfo {
                        jitter,
                        condition_estimate,
                    });
                }
            }
        }
        Err(NotPositiveDefinite { n, jitter })
    }

    /// Makes `factor` the current factorisation: the solves and [`SpdWorkspace::inverse_diagonal`]
    /// use it until the next dense one.
    pub fn hold_structured(&mut self, factor: Box<dyn StructuredFactor>) {
        self.n = factor.len();
        self.structured = Some(factor);
    }

    /// Solves `Q x = b` with the last factorisation (in place in `b`).
    pub fn solve_in_place(&self, b: &mut [f64]) {
        if let Some(f) = &self.structured {
            return f.solve_in_place(b);
        }
        let n = self.n;
        assert_eq!(b.len(), n, "right-hand side length");
        let mut rhs = faer::MatMut::from_column_major_slice_mut(b, n, 1);
        // The LLᵀ solve needs no scratch (faer's requirement is empty), so none is allocated.
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq));
        // Only the leading n × n block holds the current factor: the buffers keep the size of the
        // largest n this workspace has seen.
        let factor = self.factor.as_ref().submatrix(0, 0, n, n);
        llt::solve::solve_in_place(factor, rhs.as_mut(), Par::Seq, MemStack::new(&mut mem));
    }

    /// The diagonal of `Q⁻¹` from the last factorisation, without forming `Q⁻¹`:
    /// `(Q⁻¹)_ii = ‖L⁻¹ e_i‖²` because `Q⁻¹ = L⁻ᵀ L⁻¹`. Each `L⁻¹ e_i` is a forward substitution
    /// that starts at row `i` (the rows above are zero), column-oriented over `L`'s contiguous
    /// columns, so the whole diagonal costs `N³/6` multiply–adds: O(N³), like the factorisation
    /// itself (it is what a leave-one-out amplitude needs, math.md §7).
    pub fn inverse_diagonal(&self) -> Vec<f64> {
        if let Some(f) = &self.structured {
            return f.inverse_diagonal();
        }
        lower_inverse_diagonal(&self.factor, self.n)
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_spd_system() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let mut ws = SpdWorkspace::new();
        let info = ws.factor_entries(3, |i, j| a[i][j]).unwrap();
        assert_eq!(info.jitter, 0.0);
        let x_true = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i][j] * x_true[j]).sum())
            .collect();
        ws.solve_in_place(&mut b);
        for i in 0..3 {
            assert!((b[i] - x_true[i]).abs() < 1e-14);
        }
    }

    /// A singular matrix (two equal rows) needs jitter and says how much.
    #[test]
    fn singular_matrix_climbs_the_jitter_ladder() {
        let mut ws = SpdWorkspace::new();
        let info = ws.factor_entries(2, |_, _| 1.0).unwrap();
        assert!(info.jitter > 0.0);
        assert!(info.condition_estimate > 1e3);
    }

    /// A workspace that has held a larger system solves a smaller one (regression: the solve
    /// once used the whole buffer and panicked on faer's size check).
    #[test]
    fn workspace_reused_at_a_smaller_n() {
        let mut ws = SpdWorkspace::new();
        for n in [8, 4, 6, 1] {
            let a = |i: usize, j: usize| {
                if i == j {
                    2.0 + i as f64
                } else {
                    1.0 / (1.0 + i as f64 + j as f64)
                }
            };
            ws.factor_entries(n, a).unwrap();
            let x_true: Vec<f64> = (0..n).map(|i| 1.0 - 0.3 * i as f64).collect();
            let mut b: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| a(i, j) * x_true[j]).sum())
                .collect();
            ws.solve_in_place(&mut b);
            for i in 0..n {
                assert!(
                    (b[i] - x_true[i]).abs() < 1e-13,
                    "n={n}: x[{i}] = {} vs {}",
                    b[i],
                    x_true[i]
                );
            }
        }
    }

    /// `diag(Q⁻¹)` against the explicit inverse of a 3 × 3 matrix (adjugate / determinant).
    #[test]
    fn inverse_diagonal_matches_the_adjugate() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let mut ws = SpdWorkspace::new();
        // A larger system first, so the buffers are bigger than n (as in a reused workspace).
        ws.factor_entries(5, |i, j| if i == j { 3.0 } else { 0.1 })
            .unwrap();
        ws.factor_entries(3, |i, j| a[i][j]).unwrap();
        let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
        let expected = [
            (a[1][1] * a[2][2] - a[1][2] * a[2][1]) / det,
            (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det,
            (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det,
        ];
        for (got, want) in ws.inverse_diagonal().iter().zip(expected) {
            assert!((got - want).abs() < 1e-14 * want.abs(), "{got} vs {want}");
        }
    }

    #[test]
    fn indefinite_matrix_is_an_error_not_a_panic() {
        let mut ws = SpdWorkspace::new();
        let e = ws
            .factor_entries(2, |i, j| if i == j { 1.0 } else { -3.0 })
            .unwrap_err();
        assert!(e.to_string().contains("not positive definite"));
    }
}
