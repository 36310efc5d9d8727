//! Dense factors of `Q`: the per-thread [`SpdWorkspace`] that assembles `Q` straight into its
//! factor's buffer and climbs the jitter ladder, and the owned [`CholeskyFactor`] copied out of
//! it for callers that solve with the same `Q` later (the renderer's sample sets: one `Q` per
//! set, one solve per pixel and channel for the fitted amplitude, math.md §7).
//!
//! faer's factorisation runs at ≈ 3× nalgebra's on this project's sizes (see `benches/core.rs`
//! and docs/guide/performance.md). It always runs sequentially here: parallelism is over
//! trials, pixels or sample sets, and a fixed operation order keeps results independent of the
//! thread count.

use super::rings::RingFactor;
use super::{
    Factor, FactorInfo, NotPositiveDefinite, condition_estimate, jitter_ladder, lower_inverse_diagonal,
};
use crate::bq::kernel::{Kernel, PointsSoa};
use crate::util::geometry::Vec3;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};

/// Reusable storage for `Q` and its Cholesky factor, in one matrix.
///
/// `Q` is assembled (lower triangle) straight into the buffer the factorisation overwrites, so
/// a worker holds one `n_max²` matrix (8 n² bytes), not a copy of `Q` beside its factor; a
/// jitter retry assembles `Q` again, which costs less than keeping the copy. The buffer grows to
/// the largest `n` seen and is then reused as an `n × n` view, so a worker that alternates
/// between sample counts never reallocates.
///
/// A ring factorisation ([`SpdWorkspace::hold_rings`]) replaces the dense one until the next
/// [`SpdWorkspace::factor_with`]: the solves then go through it.
pub struct SpdWorkspace {
    factor: Mat<f64>,
    n: usize,
    rings: Option<RingFactor>,
    scratch: Option<MemBuffer>,
    scratch_n: usize,
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
            rings: None,
            scratch: None,
            scratch_n: 0,
        }
    }

    /// Fills the lower triangle of the `n × n` matrix `Q` column by column into the factor's
    /// buffer: `fill(j, col)` writes `Q[j.., j]` into `col`. (Timing and tests; the solves use
    /// [`SpdWorkspace::factor_with`], which assembles and factors.)
    pub fn assemble_lower_by_columns(&mut self, n: usize, mut fill: impl FnMut(usize, &mut [f64])) {
        self.rings = None;
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
        jitter_ladder(mean_diag, 0.0, |step, jitter| {
            if step > 0 {
                self.assemble_lower_by_columns(n, &mut fill);
                for j in 0..n {
                    self.factor[(j, j)] += jitter;
                }
            }
            let stack = MemStack::new(self.scratch.as_mut().expect("scratch allocated above"));
            llt::factor::cholesky_in_place(
                self.factor.as_mut().submatrix_mut(0, 0, n, n),
                Default::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .is_ok()
            .then(|| condition_estimate((0..n).map(|i| self.factor[(i, i)])))
        })
        .map_err(|jitter| NotPositiveDefinite { n, jitter })
    }

    /// Assembles `Q = K + σ_n² I` of `points` (lower triangle, column by column over
    /// structure-of-arrays points, so the kernel loop vectorises) straight into the factor's
    /// buffer and factors it, as [`SpdWorkspace::factor_with`].
    pub fn factor_gram(
        &mut self,
        points: &[Vec3],
        kernel: &Kernel,
        noise: f64,
    ) -> Result<FactorInfo, NotPositiveDefinite> {
        let diag = kernel.diagonal() + noise;
        let soa = PointsSoa::new(points);
        self.factor_with(points.len(), |j, col| {
            kernel.fill_column(&soa, j, j, col);
            col[0] = diag;
        })
    }

    /// Makes the ring factor `factor` the current factorisation: the solves and
    /// [`SpdWorkspace::inverse_diagonal`] use it until the next dense one.
    pub fn hold_rings(&mut self, factor: RingFactor) {
        self.n = factor.n();
        self.rings = Some(factor);
    }

    /// The current factorisation, owned, to solve with after the workspace is reused: a copy
    /// of the dense `L` (8 n² bytes) or of the held ring factor.
    pub fn keep_factor(&self) -> Factor {
        match &self.rings {
            Some(rings) => Factor::Rings(rings.clone()),
            None => Factor::Dense(CholeskyFactor {
                l: self.factor.as_ref().submatrix(0, 0, self.n, self.n).to_owned(),
            }),
        }
    }

    /// Solves `Q x = b` with the last factorisation (in place in `b`).
    pub fn solve_in_place(&self, b: &mut [f64]) {
        if let Some(f) = &self.rings {
            return f.solve_columns_in_place(b, 1);
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
        if let Some(f) = &self.rings {
            return f.inverse_diagonal();
        }
        lower_inverse_diagonal(&self.factor, self.n)
    }

    /// `log det Q` of the last factorisation (jitter included), for the marginal likelihood
    /// (math.md §9): `2 Σ log L_ii` (dense) or the sum over the ring factor's blocks.
    pub fn log_det(&self) -> f64 {
        if let Some(f) = &self.rings {
            return f.log_det();
        }
        super::lower_log_det((0..self.n).map(|i| self.factor[(i, i)]))
    }
}

/// The Cholesky factor `L` of an `n × n` symmetric positive-definite `Q` (jitter included, as
/// factored), owned.
#[derive(Clone, Debug)]
pub struct CholeskyFactor {
    l: Mat<f64>,
}

impl CholeskyFactor {
    /// `n`, the order of `Q`.
    pub fn n(&self) -> usize {
        self.l.nrows()
    }

    /// Solves `Q X = B` in place for `B` of `columns` right-hand sides, column-major
    /// (`b.len() == n · columns`), by forward and back substitution with `L`: O(n²) per column.
    pub fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        let n = self.n();
        assert_eq!(
            b.len(),
            n * columns,
            "right-hand sides: n × columns, column-major"
        );
        let mut rhs = faer::MatMut::from_column_major_slice_mut(b, n, columns);
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, columns, Par::Seq));
        llt::solve::solve_in_place(self.l.as_ref(), rhs.as_mut(), Par::Seq, MemStack::new(&mut mem));
    }

    /// `diag(Q⁻¹)`, `(Q⁻¹)_ii = ‖L⁻¹ e_i‖²` (see [`SpdWorkspace::inverse_diagonal`]): O(n³),
    /// for the leave-one-out amplitude.
    pub fn inverse_diagonal(&self) -> Vec<f64> {
        lower_inverse_diagonal(&self.l, self.n())
    }

    /// `log det Q = 2 Σ log L_ii`.
    pub fn log_det(&self) -> f64 {
        super::lower_log_det((0..self.n()).map(|i| self.l[(i, i)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kept factor solves like the workspace did, for several right-hand sides at once,
    /// after the workspace has factored another matrix; its `diag(Q⁻¹)` is the workspace's.
    #[test]
    fn kept_factor_solves_after_the_workspace_moves_on() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let mut ws = SpdWorkspace::new();
        ws.factor_entries(3, |i, j| a[i][j]).unwrap();
        let kept = ws.keep_factor();
        let Factor::Dense(kept) = kept else {
            panic!("a dense factorisation keeps a dense factor")
        };
        let diag = ws.inverse_diagonal();
        ws.factor_entries(2, |i, j| if i == j { 7.0 } else { 1.0 })
            .unwrap();
        let x = [[1.0, -2.0, 0.5], [0.0, 3.0, -1.0]];
        let mut b: Vec<f64> = x
            .iter()
            .flat_map(|col| (0..3).map(move |i| (0..3).map(|j| a[i][j] * col[j]).sum::<f64>()))
            .collect();
        kept.solve_columns_in_place(&mut b, 2);
        for (got, want) in b.iter().zip(x.iter().flatten()) {
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
        for (got, want) in kept.inverse_diagonal().iter().zip(&diag) {
            assert!((got - want).abs() < 1e-15 * want.abs(), "{got} vs {want}");
        }
    }

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
