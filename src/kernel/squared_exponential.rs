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
    /// Validates `σ_f > 0` and `l > 0` (both finite).
    pub fn new(sigma: f64, length: f64) -> Result<Self, KernelError> {
        let bad = |what: &str, v: f64| KernelError {
            kernel: "se",
            message: format!("{what} must be finite and > 0, got {v}"),
        };
        if !(sigma > 0.0 && sigma.is_finite()) {
            return Err(bad("sigma", sigma));
        }
        if !(length > 0.0 && length.is_finite()) {
            return Err(bad("length", length));
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
