//! A Cholesky factor grown by blocks, for nested point sets (sequential BMC: math.md §4, §7; [`crate::bq::stages`]).
//!
//! When a sample set grows from `n` to `m` points and keeps its first `n`, `Q` grows by a block
//! border:
//!
//! ```text
//! Q = [Q₁₁ Q₂₁ᵀ]    L = [L₁₁  0 ]    L₂₁ = Q₂₁ L₁₁⁻ᵀ,
//!     [Q₂₁ Q₂₂ ]        [L₂₁ L₂₂]    L₂₂ = chol(Q₂₂ − L₂₁ L₂₁ᵀ),
//! ```
//!
//! so the factor of the larger set costs `n²(m − n) + (m − n)³/3` multiply–adds instead of
//! `m³/3` (Golub & Van Loan, *Matrix Computations*, 4th ed., §4.2.6, the bordered/block
//! Cholesky). With doubling stages the total work is `≈ 8/7` of factoring the last stage once.
//!
//! **Jitter.** The same ladder as [`crate::bq::factor`]: when a factorisation fails or its condition
//! estimate exceeds [`NUMERICALLY_SINGULAR`], `j` is added to the diagonal. A block extension
//! cannot add jitter to the new block alone (that would factor a different matrix from the one
//! the earlier stages used), so when the Schur complement `Q₂₂ − L₂₁L₂₁ᵀ` fails, the whole
//! `m × m` matrix is factored again with the ladder; the jitter found is then added to every new
//! diagonal block, so every stage factors `Q + jI` for one `j` (the jitter of a stage is never
//! smaller than that of the stage before). [`NestedCholesky::jitter`] reports it for the
//! warning.

use super::{
    FactorInfo, NUMERICALLY_SINGULAR, NotPositiveDefinite, condition_estimate, jitter_ladder,
    lower_inverse_diagonal,
};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::prelude::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, Par};

/// The lower Cholesky factor of the leading `n × n` block of a growing SPD matrix.
#[derive(Clone, Debug)]
pub struct NestedCholesky {
    /// The most rows it may grow to.
    capacity: usize,
    factor: Mat<f64>,
    n: usize,
    jitter: f64,
    /// Full refactorisations since the first stage (a failed Schur complement).
    refactorisations: usize,
}

impl NestedCholesky {
    /// An empty factor that may grow to `capacity` rows. Storage grows with the stages
    /// actually factored (a trial that stops early never touches the largest stage's n² buffer).
    pub fn with_capacity(capacity: usize) -> Self {
        NestedCholesky {
            capacity,
            factor: Mat::zeros(0, 0),
            n: 0,
            jitter: 0.0,
            refactorisations: 0,
        }
    }

    /// The size of the factored block.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The jitter on the diagonal of every factored stage (0 when none was needed).
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// How many extensions fell back to a full factorisation (their Schur complement failed).
    pub fn refactorisations(&self) -> usize {
        self.refactorisations
    }

    /// `(max L_ii / min L_ii)²` of the factored block ([`condition_estimate`]).
    pub fn condition_estimate(&self) -> f64 {
        condition_estimate((0..self.n).map(|i| self.factor[(i, i)]))
    }

    /// What the factor needed, for [`crate::bq::weights::Diagnostics`].
    pub fn info(&self) -> FactorInfo {
        FactorInfo {
            jitter: self.jitter,
            condition_estimate: self.condition_estimate(),
        }
    }

    /// Grows the factor from `n` to `m` rows: `fill(j, start, col)` writes `Q[start.., j]`
    /// (`col.len()` entries) and is asked only for entries on or below the diagonal. The first
    /// call (`n = 0`) is a plain factorisation with the jitter ladder.
    ///
    /// # Panics
    /// If `m` is below the current size or above the capacity.
    pub fn extend_to(
        &mut self,
        m: usize,
        mut fill: impl FnMut(usize, usize, &mut [f64]),
    ) -> Result<(), NotPositiveDefinite> {
        let n = self.n;
        assert!(
            m >= n && m <= self.capacity,
            "extend_to({m}) from {n}, capacity {}",
            self.capacity
        );
        if m == n {
            return Ok(());
        }
        if m > self.factor.nrows() {
            // Grow the buffer, keeping L₁₁ (the copy is O(n²), below the extension's cost).
            let mut grown = Mat::zeros(m, m);
            grown
                .as_mut()
                .submatrix_mut(0, 0, n, n)
                .copy_from(self.factor.as_ref().submatrix(0, 0, n, n));
            self.factor = grown;
        }
        if n == 0 {
            return self.factor_from_scratch(m, &mut fill);
        }
        // Q₂₁ below L₁₁, Q₂₂'s lower triangle beside it, the jitter of the earlier stages on
        // the new diagonal.
        for j in 0..m {
            let start = n.max(j);
            let col = self.column_mut(j);
            fill(j, start, &mut col[start..m]);
        }
        for j in n..m {
            self.factor[(j, j)] += self.jitter;
        }
        let (top, bottom) = self.factor.as_mut().split_at_row_mut(n);
        let l11 = top.rb().submatrix(0, 0, n, n);
        let (mut l21, mut s) = bottom.submatrix_mut(0, 0, m - n, m).split_at_col_mut(n);
        // L₂₁ᵀ = L₁₁⁻¹ Q₂₁ᵀ (forward substitution on the transposed view).
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            l11,
            l21.rb_mut().transpose_mut(),
            Par::Seq,
        );
        // S = Q₂₂ − L₂₁ L₂₁ᵀ (only its lower triangle is read below).
        faer::linalg::matmul::matmul(
            s.rb_mut(),
            Accum::Add,
            l21.rb(),
            l21.rb().transpose(),
            -1.0,
            Par::Seq,
        );
        let ok = cholesky(s.rb_mut()).is_ok();
        self.n = m;
        if ok && self.condition_estimate() <= NUMERICALLY_SINGULAR {
            return Ok(());
        }
        // The Schur complement failed: the whole matrix again, with the ladder.
        self.refactorisations += 1;
        self.n = 0;
        let keep = self.jitter;
        self.factor_from_scratch(m, &mut fill)?;
        self.jitter = self.jitter.max(keep);
        Ok(())
    }

    /// The leading `m × m` block factored from scratch with the jitter ladder of
    /// [`crate::bq::factor`], starting from the jitter already in use.
    fn factor_from_scratch(
        &mut self,
        m: usize,
        fill: &mut impl FnMut(usize, usize, &mut [f64]),
    ) -> Result<(), NotPositiveDefinite> {
        let mut assemble = |me: &mut Self, jitter: f64| {
            for j in 0..m {
                let col = me.column_mut(j);
                fill(j, j, &mut col[j..m]);
            }
            for j in 0..m {
                me.factor[(j, j)] += jitter;
            }
        };
        assemble(self, 0.0);
        let mean_diag = (0..m).map(|i| self.factor[(i, i)]).sum::<f64>() / m as f64;
        let first = self.jitter;
        if first > 0.0 {
            for j in 0..m {
                self.factor[(j, j)] += first;
            }
        }
        let outcome = jitter_ladder(mean_diag, first, |step, jitter| {
            if step > 0 {
                assemble(self, jitter);
            }
            let ok = cholesky(self.factor.as_mut().submatrix_mut(0, 0, m, m)).is_ok();
            self.n = m;
            ok.then(|| self.condition_estimate())
        });
        match outcome {
            Ok(info) => {
                self.jitter = info.jitter;
                Ok(())
            }
            Err(jitter) => {
                self.n = 0;
                Err(NotPositiveDefinite { n: m, jitter })
            }
        }
    }

    fn column_mut(&mut self, j: usize) -> &mut [f64] {
        self.factor
            .col_mut(j)
            .try_as_col_major_mut()
            .expect("faer Mat columns are contiguous")
            .as_slice_mut()
    }

    /// Solves `Q x = b` for the factored `n × n` block (in place in `b`).
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let n = self.n;
        assert_eq!(b.len(), n, "right-hand side length");
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, 1);
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq));
        let factor = self.factor.as_ref().submatrix(0, 0, n, n);
        llt::solve::solve_in_place(factor, rhs, Par::Seq, MemStack::new(&mut mem));
    }

    /// Solves `Q X = B` for the factored block, `columns` right-hand sides column-major.
    pub fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        let n = self.n;
        assert_eq!(
            b.len(),
            n * columns,
            "right-hand sides: n × columns, column-major"
        );
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, columns);
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, columns, Par::Seq));
        let factor = self.factor.as_ref().submatrix(0, 0, n, n);
        llt::solve::solve_in_place(factor, rhs, Par::Seq, MemStack::new(&mut mem));
    }

    /// Solves `Q_m x = b` for the leading `m × m` block (`m ≤ n`): its Cholesky factor is the
    /// leading block of `L`, so every earlier stage can be solved with the last factor.
    pub fn solve_leading_in_place(&self, m: usize, b: &mut [f64]) {
        assert!(m <= self.n && b.len() == m, "leading block {m} of {}", self.n);
        let rhs = faer::MatMut::from_column_major_slice_mut(b, m, 1);
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(m, 1, Par::Seq));
        let factor = self.factor.as_ref().submatrix(0, 0, m, m);
        llt::solve::solve_in_place(factor, rhs, Par::Seq, MemStack::new(&mut mem));
    }

    /// Forward substitution `L y = b` for rows `from..b.len()` given `y[..from]` already in
    /// `y` (`y.len() = b.len() ≤ n`): a nested right-hand side extends `L⁻¹b` as it grows, so
    /// `bᵀQ⁻¹b = ‖L⁻¹b‖²` costs O(m²) in all over every stage up to `m`.
    pub fn forward_extend(&self, b: &[f64], y: &mut [f64], from: usize) {
        assert!(b.len() == y.len() && b.len() <= self.n && from <= b.len());
        for i in from..b.len() {
            let mut acc = b[i];
            for (k, yk) in y[..i].iter().enumerate() {
                acc -= self.factor[(i, k)] * yk;
            }
            y[i] = acc / self.factor[(i, i)];
        }
    }

    /// `diag(Q⁻¹)` of the factored block, `(Q⁻¹)_ii = ‖L⁻¹ e_i‖²` (as
    /// [`crate::bq::factor::SpdWorkspace::inverse_diagonal`]); O(n³), for the `loo` amplitude.
    pub fn inverse_diagonal(&self) -> Vec<f64> {
        lower_inverse_diagonal(&self.factor, self.n)
    }

    /// `log det (Q + jI)` of the factored block, `2 Σ log L_ii` ([`super::lower_log_det`]).
    pub fn log_det(&self) -> f64 {
        super::lower_log_det((0..self.n).map(|i| self.factor[(i, i)]))
    }

    /// `L[i, j]` of the factored block (`j ≤ i < n`), for tests.
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        assert!(
            j <= i && i < self.n,
            "L[{i}, {j}] is outside the factored lower triangle"
        );
        self.factor[(i, j)]
    }
}

/// faer's in-place Cholesky of a square view (lower triangle), sequential.
fn cholesky(a: faer::MatMut<'_, f64>) -> Result<(), ()> {
    let n = a.nrows();
    let mut scratch = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
        n,
        Par::Seq,
        Default::default(),
    ));
    llt::factor::cholesky_in_place(
        a,
        Default::default(),
        Par::Seq,
        MemStack::new(&mut scratch),
        Default::default(),
    )
    .map(|_| ())
    .map_err(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bq::factor::SpdWorkspace;

    /// A Sobolev-kernel Gram matrix plus noise on pseudo-random hemisphere points.
    fn gram(n: usize, noise: f64) -> impl Fn(usize, usize) -> f64 {
        let pts =
            crate::sampling::Density::Uniform.sample_set(n, &mut crate::util::rng::stream(5, &[n as u64]));
        let k = crate::bq::kernel::Kernel::Sobolev(crate::bq::kernel::Sobolev::new(1.4).unwrap());
        move |i, j| k.eval(&pts[i], &pts[j]) + if i == j { noise } else { 0.0 }
    }

    fn filler(q: &impl Fn(usize, usize) -> f64) -> impl FnMut(usize, usize, &mut [f64]) + '_ {
        move |j, start, col| {
            for (k, v) in col.iter_mut().enumerate() {
                *v = q(start + k, j);
            }
        }
    }

    /// Stages 8 → 16 → 32 → 64 → 100 give the factor of one full factorisation to 1e-12
    /// (relative to the largest entry), and the same solves.
    #[test]
    fn block_extension_matches_a_full_factorisation() {
        let q = gram(100, 0.01);
        let mut nested = NestedCholesky::with_capacity(100);
        for m in [8, 16, 32, 64, 100] {
            nested.extend_to(m, filler(&q)).unwrap();
        }
        assert_eq!(
            (nested.n(), nested.jitter(), nested.refactorisations()),
            (100, 0.0, 0)
        );
        let mut full = NestedCholesky::with_capacity(100);
        full.extend_to(100, filler(&q)).unwrap();
        let scale = (0..100).map(|i| full.entry(i, i).abs()).fold(0.0, f64::max);
        for j in 0..100 {
            for i in j..100 {
                let (a, b) = (nested.entry(i, j), full.entry(i, j));
                assert!((a - b).abs() <= 1e-12 * scale, "L[{i},{j}]: {a} vs {b}");
            }
        }
        // Against the project's own factorisation too, through a solve.
        let mut ws = SpdWorkspace::new();
        ws.factor_entries(100, &q).unwrap();
        let b: Vec<f64> = (0..100).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut x1, mut x2) = (b.clone(), b.clone());
        nested.solve_in_place(&mut x1);
        ws.solve_in_place(&mut x2);
        let norm = x2.iter().map(|v| v.abs()).fold(0.0, f64::max);
        for (a, b) in x1.iter().zip(&x2) {
            assert!((a - b).abs() <= 1e-10 * norm, "{a} vs {b}");
        }
    }

    /// Leading-block solves and the incremental `L⁻¹b` agree with a factor of the block itself.
    #[test]
    fn leading_blocks_solve_earlier_stages() {
        let q = gram(64, 0.01);
        let mut nested = NestedCholesky::with_capacity(64);
        nested.extend_to(16, filler(&q)).unwrap();
        nested.extend_to(64, filler(&q)).unwrap();
        let mut small = NestedCholesky::with_capacity(16);
        small.extend_to(16, filler(&q)).unwrap();
        let b: Vec<f64> = (0..64).map(|i| 1.0 + (i as f64).cos()).collect();
        let (mut x1, mut x2) = (b[..16].to_vec(), b[..16].to_vec());
        nested.solve_leading_in_place(16, &mut x1);
        small.solve_in_place(&mut x2);
        for (a, c) in x1.iter().zip(&x2) {
            assert!((a - c).abs() <= 1e-12 * c.abs().max(1.0), "{a} vs {c}");
        }
        // bᵀQ⁻¹b = ‖L⁻¹b‖², built in two steps.
        let mut y = vec![0.0; 64];
        nested.forward_extend(&b[..16], &mut y[..16], 0);
        let quad16: f64 = y[..16].iter().map(|v| v * v).sum();
        assert!((quad16 - b[..16].iter().zip(&x2).map(|(p, r)| p * r).sum::<f64>()).abs() <= 1e-10 * quad16);
        nested.forward_extend(&b, &mut y, 16);
        let mut x = b.clone();
        nested.solve_in_place(&mut x);
        let quad: f64 = y.iter().map(|v| v * v).sum();
        let direct: f64 = b.iter().zip(&x).map(|(p, r)| p * r).sum();
        assert!((quad - direct).abs() <= 1e-10 * direct, "{quad} vs {direct}");
    }

    /// diag(Q⁻¹) of an extended factor equals the workspace's of the full matrix.
    #[test]
    fn inverse_diagonal_after_extension() {
        let q = gram(40, 0.01);
        let mut nested = NestedCholesky::with_capacity(40);
        nested.extend_to(10, filler(&q)).unwrap();
        nested.extend_to(40, filler(&q)).unwrap();
        let mut ws = SpdWorkspace::new();
        ws.factor_entries(40, &q).unwrap();
        for (a, b) in nested.inverse_diagonal().iter().zip(ws.inverse_diagonal()) {
            assert!((a - b).abs() <= 1e-10 * b.abs(), "{a} vs {b}");
        }
    }

    /// A new point equal to an old one without noise makes the Schur complement singular: the
    /// extension falls back to a full factorisation with jitter, and every stage after it
    /// carries the same jitter on its new diagonal.
    #[test]
    fn a_singular_extension_refactors_with_jitter() {
        let base = gram(8, 0.0);
        // Points 8..16 repeat points 0..8: Q is exactly singular.
        let q = move |i: usize, j: usize| base(i % 8, j % 8);
        let mut nested = NestedCholesky::with_capacity(16);
        nested.extend_to(8, filler(&q)).unwrap();
        assert_eq!(nested.jitter(), 0.0);
        nested.extend_to(16, filler(&q)).unwrap();
        assert!(nested.jitter() > 0.0);
        assert_eq!(nested.refactorisations(), 1);
        // The result is the factor of Q + jI.
        let j = nested.jitter();
        let qj = |a: usize, b: usize| q(a, b) + if a == b { j } else { 0.0 };
        let mut direct = NestedCholesky::with_capacity(16);
        direct.extend_to(16, filler(&qj)).unwrap();
        assert_eq!(direct.jitter(), 0.0, "Q + jI factors without more jitter");
        for c in 0..16 {
            for r in c..16 {
                assert!(
                    (nested.entry(r, c) - direct.entry(r, c)).abs() <= 1e-9,
                    "L[{r},{c}]"
                );
            }
        }
    }
}
