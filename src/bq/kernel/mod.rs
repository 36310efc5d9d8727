//! Isotropic covariance kernels on the sphere (math.md §4, "Kernels").
//!
//! Both kernels depend on `x·y` only, through `‖x − y‖² = 2 − 2 x·y`; each is written as a
//! profile of the squared distance, `k(x, y) = κ(‖x − y‖²)`.

pub mod fast_pow;
pub mod primary;
mod sobolev;
mod squared_exponential;

pub use sobolev::{Sobolev, funk_hecke_power};
pub use squared_exponential::SquaredExponential;

use crate::util::geometry::Vec3;

/// A kernel parameter out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{kernel} kernel: {message}")]
pub struct KernelError {
    pub kernel: &'static str,
    pub message: String,
}

/// The kernels the workbench knows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    Sobolev(Sobolev),
    SquaredExponential(SquaredExponential),
}

impl Kernel {
    /// `κ(d²)`, the kernel as a function of the squared Euclidean distance `d² ∈ [0, 4]`.
    #[inline]
    pub fn of_squared_distance(&self, d2: f64) -> f64 {
        match self {
            Kernel::Sobolev(k) => k.of_squared_distance(d2),
            Kernel::SquaredExponential(k) => k.of_squared_distance(d2),
        }
    }

    /// `k(x, y)` for unit vectors. The distance is formed from the coordinates, not as
    /// `2 − 2x·y`, which loses all precision for nearby points.
    #[inline]
    pub fn eval(&self, x: &Vec3, y: &Vec3) -> f64 {
        // The same operations in the same order as `fill_column`, so both agree to the bit.
        let (dx, dy, dz) = (x.x - y.x, x.y - y.y, x.z - y.z);
        self.of_squared_distance(squared_norm(dx, dy, dz))
    }

    /// `k(x, x)`, the prior variance of one function value.
    pub fn diagonal(&self) -> f64 {
        self.of_squared_distance(0.0)
    }

    /// `∫_a^b κ(2 − 2t) dt`, in closed form; gives [`Kernel::sphere_mean`]. (It forms `1 − a`
    /// directly, so it loses relative precision for short intervals next to `t = ±1`; the exact
    /// kernel mean uses its own cancellation-free cap integral.)
    pub fn integral_over_t(&self, a: f64, b: f64) -> f64 {
        match self {
            Kernel::Sobolev(k) => k.integral_over_t(a, b),
            Kernel::SquaredExponential(k) => k.integral_over_t(a, b),
        }
    }

    /// `∫_{S²} k(x, y) dy`, the same for every `x`.
    pub fn sphere_mean(&self) -> f64 {
        self.integral_over_t(-1.0, 1.0) * std::f64::consts::TAU
    }

    /// Short name: `sobolev` or `se`.
    pub fn name(&self) -> &'static str {
        match self {
            Kernel::Sobolev(_) => "sobolev",
            Kernel::SquaredExponential(_) => "se",
        }
    }

    /// The kernel and its parameters as JSON, e.g. `{"type":"sobolev","s":1.4}`.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Kernel::Sobolev(k) => serde_json::json!({"type": "sobolev", "s": k.s()}),
            Kernel::SquaredExponential(k) => {
                serde_json::json!({"type": "se", "sigma": k.sigma(), "length": k.length()})
            }
        }
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Kernel::Sobolev(k) => write!(f, "sobolev(s={})", k.s()),
            Kernel::SquaredExponential(k) => write!(f, "se(sigma={}, length={})", k.sigma(), k.length()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Density;
    use crate::util::rng::stream;

    fn kernels() -> Vec<Kernel> {
        vec![
            Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
            Kernel::Sobolev(Sobolev::new(1.05).unwrap()),
            Kernel::Sobolev(Sobolev::new(1.95).unwrap()),
            Kernel::SquaredExponential(SquaredExponential::new(1.0, 0.5).unwrap()),
            Kernel::SquaredExponential(SquaredExponential::new(2.0, 0.2).unwrap()),
        ]
    }

    #[test]
    fn kernels_are_symmetric() {
        let mut rng = stream(3, &[]);
        for k in kernels() {
            let pts = Density::Uniform.sample_set(50, &mut rng);
            for x in &pts {
                for y in &pts {
                    assert_eq!(k.eval(x, y), k.eval(y, x));
                }
            }
        }
    }

    /// Gram matrices on random point sets are positive definite: Cholesky succeeds without
    /// noise for sets spread enough that the smallest eigenvalue is representable.
    #[test]
    fn gram_matrices_are_positive_definite() {
        let mut rng = stream(4, &[]);
        for k in kernels() {
            for n in [5, 20, 40] {
                let pts = Density::Uniform.sample_set(n, &mut rng);
                let g = nalgebra::DMatrix::from_fn(n, n, |i, j| k.eval(&pts[i], &pts[j]));
                let eig = g.symmetric_eigenvalues();
                assert!(eig.min() > -1e-12 * eig.max(), "{k} n={n}: λ_min = {}", eig.min());
                assert!(nalgebra::Cholesky::new(g + nalgebra::DMatrix::identity(n, n) * 1e-9).is_some());
            }
        }
    }

    /// The vectorised column fill gives exactly the scalar `eval`, bit for bit.
    #[test]
    fn fill_column_matches_eval_bit_for_bit() {
        let mut rng = stream(6, &[]);
        for k in kernels() {
            let pts = Density::Uniform.sample_set(67, &mut rng);
            let soa = PointsSoa::new(&pts);
            for j in [0, 5, 50, 66] {
                let mut col = vec![0.0; 67 - j];
                k.fill_column(&soa, j, j, &mut col);
                for (i, v) in col.iter().enumerate() {
                    assert_eq!(
                        v.to_bits(),
                        k.eval(&pts[j + i], &pts[j]).to_bits(),
                        "{k} ({}, {j})",
                        j + i
                    );
                }
            }
        }
    }

    /// The closed-form t-integral against a fine midpoint rule.
    #[test]
    fn integral_over_t_matches_quadrature() {
        for k in kernels() {
            for (a, b) in [(-1.0, 1.0), (0.3, 1.0), (-1.0, -0.2), (0.1, 0.9)] {
                let m = 200_000;
                let h = (b - a) / m as f64;
                let q: f64 = (0..m)
                    .map(|i| {
                        let t = a + (i as f64 + 0.5) * h;
                        k.of_squared_distance(2.0 - 2.0 * t)
                    })
                    .sum::<f64>()
                    * h;
                let exact = k.integral_over_t(a, b);
                assert!(
                    (q - exact).abs() < 1e-6 * exact.abs().max(1.0),
                    "{k} [{a},{b}]: {q} vs {exact}"
                );
            }
        }
    }
}

/// Below this many entries a Sobolev column is filled lane by lane, not in staged blocks
/// (measured: the blocks win from about 24 on).
const SHORT_COLUMN: usize = 24;

/// `dx² + dy² + dz²` with two fused multiply–adds (one rounding each), the same in the scalar
/// and the vectorised paths.
#[inline(always)]
fn squared_norm(dx: f64, dy: f64, dz: f64) -> f64 {
    dx.mul_add(dx, dy.mul_add(dy, dz * dz))
}

/// Points stored as three coordinate arrays, so that kernel columns vectorise.
#[derive(Clone, Debug, Default)]
pub struct PointsSoa {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
}

impl PointsSoa {
    pub fn new(points: &[Vec3]) -> Self {
        PointsSoa {
            x: points.iter().map(|p| p.x).collect(),
            y: points.iter().map(|p| p.y).collect(),
            z: points.iter().map(|p| p.z).collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}

impl Kernel {
    /// `out[k] = k(p_{start + k}, p_j)` for `k < out.len()`: part of column `j` of the Gram matrix.
    ///
    /// On x86-64 with AVX-512F or AVX2 (and FMA) the loop runs vectorised; it performs the same IEEE
    /// operations (fused multiply–adds included) in the same order as the scalar loop, so the
    /// results do not depend on the vector width.
    pub fn fill_column(&self, pts: &PointsSoa, j: usize, start: usize, out: &mut [f64]) {
        self.fill_against(pts, start, &Vec3::new(pts.x[j], pts.y[j], pts.z[j]), out);
    }

    /// `out[k] = k(p_{start + k}, q)` for `k < out.len()`; vectorised like [`Kernel::fill_column`].
    pub fn fill_against(&self, pts: &PointsSoa, start: usize, q: &Vec3, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        {
            let fma = std::arch::is_x86_feature_detected!("fma");
            if fma && std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512F and FMA, checked just above.
                unsafe { self.fill_against_avx512(pts, start, q, out) };
                return;
            }
            if fma && std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 and FMA, checked just above.
                unsafe { self.fill_against_avx2(pts, start, q, out) };
                return;
            }
        }
        self.fill_against_generic(pts, start, q, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    unsafe fn fill_against_avx512(&self, pts: &PointsSoa, start: usize, q: &Vec3, out: &mut [f64]) {
        self.fill_against_generic(pts, start, q, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fill_against_avx2(&self, pts: &PointsSoa, start: usize, q: &Vec3, out: &mut [f64]) {
        self.fill_against_generic(pts, start, q, out);
    }

    #[inline(always)]
    fn fill_against_generic(&self, pts: &PointsSoa, start: usize, q: &Vec3, out: &mut [f64]) {
        let (qx, qy, qz) = (q.x, q.y, q.z);
        let end = start + out.len();
        let (xs, ys, zs) = (&pts.x[start..end], &pts.y[start..end], &pts.z[start..end]);
        match self {
            // Short columns (ring solver rows, small weight sets, the first columns of every
            // set) lane by lane: the staged blocks below cost ~50 ns a call whatever the
            // length, more than a short column takes this way. Same bits either way.
            Kernel::Sobolev(k) if out.len() < SHORT_COLUMN => {
                for i in 0..out.len() {
                    let (dx, dy, dz) = (xs[i] - qx, ys[i] - qy, zs[i] - qz);
                    let d2 = squared_norm(dx, dy, dz);
                    out[i] = k.combine(d2, fast_pow::pow_inline(d2, k.half_exponent()));
                }
            }
            Kernel::Sobolev(k) => {
                // Blocks of B lanes through the staged `pow_block` (see there for why); the
                // last block computes its lanes rounded up to a whole vector (the padding lanes
                // hold d² = 0 and are discarded), not a scalar remainder loop, which cost ~10%
                // of the assembly at N = 512.
                const B: usize = 64;
                let n = out.len();
                let mut i = 0;
                while i < n {
                    let m = (n - i).min(B);
                    let mut d2 = [0.0f64; B];
                    let mut v = [0.0f64; B];
                    if m == B {
                        for l in 0..B {
                            let (dx, dy, dz) = (xs[i + l] - qx, ys[i + l] - qy, zs[i + l] - qz);
                            d2[l] = squared_norm(dx, dy, dz);
                        }
                        fast_pow::pow_block(&d2, k.half_exponent(), &mut v, B);
                    } else {
                        for l in 0..m {
                            let (dx, dy, dz) = (xs[i + l] - qx, ys[i + l] - qy, zs[i + l] - qz);
                            d2[l] = squared_norm(dx, dy, dz);
                        }
                        fast_pow::pow_block(&d2, k.half_exponent(), &mut v, m.next_multiple_of(8));
                    }
                    for l in 0..m {
                        out[i + l] = k.combine(d2[l], v[l]);
                    }
                    i += m;
                }
            }
            Kernel::SquaredExponential(k) => {
                for i in 0..out.len() {
                    let (dx, dy, dz) = (xs[i] - qx, ys[i] - qy, zs[i] - qz);
                    out[i] = k.of_squared_distance(squared_norm(dx, dy, dz));
                }
            }
        }
    }
}
