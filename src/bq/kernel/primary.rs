//! Product Sobolev kernels on the unit cube of primary samples (math.md §11 (a); Dick, Kuo &
//! Sloan, "High-dimensional integration: the quasi-Monte Carlo way", Acta Numerica 2013, §5.3).
//!
//! `k(u, u') = Π_j k₁(u_j, u'_j)` with the unanchored Sobolev kernels of smoothness `α`:
//! - order 1: `k₁(x, y) = 1 + B₁(x)B₁(y) + ½ B₂(|x − y|)`,
//! - order 2: `k₁(x, y) = 1 + B₁(x)B₁(y) + ¼ B₂(x)B₂(y) − (1/24) B₄(|x − y|)`,
//!
//! `B₁ = x − ½`, `B₂ = x² − x + 1/6`, `B₄ = x⁴ − 2x³ + x² − 1/30` (Bernoulli polynomials). Every
//! Bernoulli term integrates to 0 over `[0, 1]` in either argument (`B₂(|x − y|)` and `B₄(|x − y|)`
//! too: they are `B_k({x − y})` of the periodic extension), so `∫₀¹ k₁(x, y) dy = 1` and the
//! kernel mean `z(u) = ∫ k(u, u') du'` is the constant 1, as is `∫∫ k = 1`. The weights of a
//! point set therefore do not depend on the integrand: once per set, never per pixel.

/// The smoothness of a product Sobolev kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SobolevOrder {
    /// `α = 1`.
    One,
    /// `α = 2`.
    Two,
}

impl SobolevOrder {
    pub const ALL: [SobolevOrder; 2] = [SobolevOrder::One, SobolevOrder::Two];

    /// The order as a number (what the spec's `"order"` holds).
    pub fn number(self) -> u32 {
        match self {
            SobolevOrder::One => 1,
            SobolevOrder::Two => 2,
        }
    }

    /// Parses [`SobolevOrder::number`].
    pub fn from_number(n: u64) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.number() as u64 == n)
    }

    /// The one-dimensional factor `k₁(x, y)`, `x, y ∈ [0, 1]`.
    #[inline]
    pub fn k1(self, x: f64, y: f64) -> f64 {
        let t = (x - y).abs();
        match self {
            SobolevOrder::One => 1.0 + b1(x) * b1(y) + 0.5 * b2(t),
            SobolevOrder::Two => 1.0 + b1(x) * b1(y) + 0.25 * b2(x) * b2(y) - b4(t) / 24.0,
        }
    }

    /// The product kernel `k(u, u') = Π_j k₁(u_j, u'_j)` on `[0, 1]²`.
    #[inline]
    pub fn eval(self, u: &[f64; 2], v: &[f64; 2]) -> f64 {
        self.k1(u[0], v[0]) * self.k1(u[1], v[1])
    }

    /// The kernel mean `∫_{[0,1]²} k(u, u') du'` at any `u`: exactly 1 (module docs).
    pub const fn mean(self) -> f64 {
        1.0
    }

    /// `∫∫ k(u, u') du du'`: exactly 1, the prior variance of the integral.
    pub const fn initial_variance(self) -> f64 {
        1.0
    }
}

#[inline]
fn b1(x: f64) -> f64 {
    x - 0.5
}

#[inline]
fn b2(x: f64) -> f64 {
    x * x - x + 1.0 / 6.0
}

#[inline]
fn b4(x: f64) -> f64 {
    let x2 = x * x;
    x2 * x2 - 2.0 * x2 * x + x2 - 1.0 / 30.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::quadrature::gauss_legendre;

    /// `∫₀¹ k₁(x, y) dy` by Gauss–Legendre on `[0, x]` and `[x, 1]` (the kink of `|x − y|`
    /// splits it into polynomials of degree ≤ 4, which 8 nodes integrate exactly).
    fn k1_mean_by_quadrature(order: SobolevOrder, x: f64) -> f64 {
        let (nodes, weights) = gauss_legendre(8);
        let piece = |a: f64, b: f64| -> f64 {
            let (m, h) = ((a + b) / 2.0, (b - a) / 2.0);
            nodes
                .iter()
                .zip(&weights)
                .map(|(t, w)| w * h * order.k1(x, m + h * t))
                .sum()
        };
        piece(0.0, x) + piece(x, 1.0)
    }

    /// The kernel mean is 1 at every point to 1e-12, checked against an independent quadrature,
    /// and so is `∫∫ k`.
    #[test]
    fn product_sobolev_kernel_means_are_one() {
        for order in SobolevOrder::ALL {
            let mut total = 0.0;
            let (nodes, weights) = gauss_legendre(16);
            for x in [0.0, 1e-9, 0.1, 0.25, 0.5, 0.731, 0.999, 1.0] {
                let m = k1_mean_by_quadrature(order, x);
                assert!((m - order.mean()).abs() < 1e-12, "{order:?} x = {x}: {m}");
            }
            for (t, w) in nodes.iter().zip(&weights) {
                total += w / 2.0 * k1_mean_by_quadrature(order, (1.0 + t) / 2.0);
            }
            assert!(
                (total - order.initial_variance()).abs() < 1e-12,
                "{order:?}: {total}"
            );
            // The 2-D mean is the product of the 1-D ones.
            let u = [0.3, 0.8];
            let m2 = k1_mean_by_quadrature(order, u[0]) * k1_mean_by_quadrature(order, u[1]);
            assert!((m2 - 1.0).abs() < 1e-12);
        }
    }

    /// Symmetric and positive on the diagonal; the order-1 diagonal is `1 + B₁(x)² + 1/12`.
    #[test]
    fn kernels_are_symmetric_with_the_stated_diagonal() {
        for order in SobolevOrder::ALL {
            for (x, y) in [(0.1, 0.9), (0.4, 0.41), (0.0, 1.0)] {
                assert_eq!(order.k1(x, y), order.k1(y, x));
                assert!(order.k1(x, x) > 0.0);
            }
        }
        let x: f64 = 0.2;
        assert!((SobolevOrder::One.k1(x, x) - (1.0 + (x - 0.5).powi(2) + 1.0 / 12.0)).abs() < 1e-15);
        assert_eq!(SobolevOrder::from_number(2), Some(SobolevOrder::Two));
        assert_eq!(SobolevOrder::from_number(3), None);
    }
}
