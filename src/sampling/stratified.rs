//! A jittered grid in `(u1, u2)` (stratified sampling, math.md §2): `N = m1 × m2` cells with
//! `m1` the largest divisor of `N` not above `√N`, one uniform point in each cell, mapped like
//! uniform sampling. Each point is uniform on the hemisphere (a random cell, then uniform in it),
//! so MC stays unbiased; its variance is `(1/N²) Σ_cells Var_cell(f/p)`, `O(N^−2)` for smooth
//! integrands instead of `σ²/N`.

/// `(m1, m2)` with `m1 · m2 = n`, `m1 ≤ m2`, `m1` as large as possible.
pub fn grid(n: usize) -> (usize, usize) {
    let mut m1 = (n as f64).sqrt() as usize;
    while m1 > 1 && !n.is_multiple_of(m1) {
        m1 -= 1;
    }
    let m1 = m1.max(1);
    (m1, n / m1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_are_as_square_as_the_count_allows() {
        assert_eq!(grid(1), (1, 1));
        assert_eq!(grid(16), (4, 4));
        assert_eq!(grid(512), (16, 32));
        assert_eq!(grid(12), (3, 4));
        assert_eq!(grid(13), (1, 13));
    }
}
