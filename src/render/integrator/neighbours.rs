//! BMCP in the renderer (thesis §3.2.5, math.md §4): the constant prior of a pixel from its
//! neighbours.
//!
//! Pass 1 renders every other pixel (checkerboard, `(i + j)` even) with plain BMC; pass 2
//! renders the rest with the constant prior `c = mean(available 4-neighbour estimates) / (2π)`
//! per channel. The neighbours estimate the same integral `∫ f dω`, and `2πc` is the integral
//! of the constant `c`, so `c` is the constant with the neighbours' integral.

use crate::render::scene::Rgb;
use std::f64::consts::TAU;

/// Whether pixel `(i, j)` belongs to the first (plain BMC) pass.
#[inline]
pub fn first_pass(i: usize, j: usize) -> bool {
    (i + j).is_multiple_of(2)
}

/// `c` for pixel `(i, j)` from the first-pass `estimates` (row-major, `None` where the primary
/// ray hit nothing and there is no integral): the mean of the available neighbours left, right,
/// above and below, divided by `2π`; zero (plain BMC) when none is available.
pub fn neighbour_prior(estimates: &[Option<Rgb>], width: usize, height: usize, i: usize, j: usize) -> Rgb {
    let mut sum = [0.0; 3];
    let mut n = 0usize;
    let mut add = |ii: usize, jj: usize| {
        if let Some(e) = estimates[jj * width + ii] {
            for c in 0..3 {
                sum[c] += e[c];
            }
            n += 1;
        }
    };
    if i > 0 {
        add(i - 1, j);
    }
    if i + 1 < width {
        add(i + 1, j);
    }
    if j > 0 {
        add(i, j - 1);
    }
    if j + 1 < height {
        add(i, j + 1);
    }
    if n == 0 {
        return [0.0; 3];
    }
    sum.map(|s| s / n as f64 / TAU)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prior_is_the_neighbour_mean_over_two_pi() {
        // 3×2 image; pixel (1, 0) has neighbours (0, 0), (2, 0), (1, 1); (2, 0) has no hit.
        let e = vec![
            Some([1.0, 2.0, 3.0]),
            None,
            None,
            None,
            Some([3.0, 4.0, 5.0]),
            None,
        ];
        let c = neighbour_prior(&e, 3, 2, 1, 0);
        assert_eq!(c, [2.0 / TAU, 3.0 / TAU, 4.0 / TAU]);
        assert_eq!(neighbour_prior(&[None; 6], 3, 2, 1, 0), [0.0; 3]);
        assert!(first_pass(0, 0) && !first_pass(1, 0) && first_pass(1, 1));
    }
}
