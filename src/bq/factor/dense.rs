//! A kept Cholesky factor: the `L` of `Q = L Lᵀ` copied out of an [`SpdWorkspace`], for callers
//! that solve with the same `Q` long after the workspace has moved on (the renderer's sample
//! sets: one `Q` per set, one solve per pixel and channel for the fitted amplitude, math.md §7).

use super::SpdWorkspace;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};

/// The Cholesky factor `L` of an `n × n` symmetric positive-definite `Q` (jitter included, as
/// factored), owned.
#[derive(Clone, Debug)]
pub struct CholeskyFactor {
    l: Mat<f64>,
}

impl SpdWorkspace {
    /// A copy of the last factorisation's `L` (8 n² bytes), to solve with after the workspace
    /// is reused.
    pub fn keep_factor(&self) -> CholeskyFactor {
        // A structured factorisation (ring designs) has no dense factor to keep.
        assert!(
            self.structured.is_none(),
            "keep_factor after a structured factorisation"
        );
        CholeskyFactor {
            l: self.factor.as_ref().submatrix(0, 0, self.n, self.n).to_owned(),
        }
    }
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
        crate::bq::factor::lower_inverse_diagonal(&self.l, self.n())
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
}
