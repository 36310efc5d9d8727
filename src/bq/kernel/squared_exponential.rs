use super::KernelError;

/// Squared-exponential kernel (math.md §4): `k(x, y) = σ_f² exp(−‖x − y‖² / (2 l²))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SquaredExponential {
    sigma: f64,
    length: f64,
    variance: f64,
    inv_two_l2: f64,
}

impl SquaredExponential {
    /// Validates `σ_f ∈ [1e-100, 1e100]` (so `σ_f²` is a finite, normal number) and
    /// `l ∈ [1e-3, 1e4]`: below, `1/(2l²)` overflows and no point set of the sizes allowed
    /// resolves the kernel (the mean spacing of 16384 points is ~0.02); above, the kernel is
    /// constant to machine precision over the hemisphere.
    pub fn new(sigma: f64, length: f64) -> Result<Self, KernelError> {
        let bad = |what: &str, range: &str, v: f64| KernelError {
            kernel: "se",
            message: format!("{what} must be in {range}, got {}", crate::util::shown::shown(v)),
        };
        if !(1e-100..=1e100).contains(&sigma) {
            return Err(bad("sigma", "[1e-100, 1e100]", sigma));
        }
        if !(1e-3..=1e4).contains(&length) {
            return Err(bad("length", "[0.001, 10000]", length));
        }
        Ok(SquaredExponential {
            sigma,
            length,
            variance: sigma * sigma,
            inv_two_l2: 0.5 / (length * length),
        })
    }

    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    pub fn length(&self) -> f64 {
        self.length
    }

    /// `σ_f² exp(−d² / (2 l²))`.
    #[inline(always)]
    pub fn of_squared_distance(&self, d2: f64) -> f64 {
        self.variance * (-d2 * self.inv_two_l2).exp()
    }

    /// `∫_a^b σ_f² exp(−(1 − t)/l²) dt = σ_f² l² [exp(−(1 − b)/l²) − exp(−(1 − a)/l²)]`.
    pub fn integral_over_t(&self, a: f64, b: f64) -> f64 {
        let l2 = self.length * self.length;
        self.variance * l2 * ((-(1.0 - b) / l2).exp() - (-(1.0 - a) / l2).exp())
    }
}
