use super::KernelError;

/// Sobolev kernel on the sphere (Marques et al. 2019; math.md §4):
///
/// `k(x, y) = 2^(2s−1)/s − ‖x − y‖^(2s−2)`, smoothness `1 < s < 2` (thesis: `s = 1.4`).
///
/// Its mean over the whole sphere is `4π · 2^(2s−2)/s` for every `x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sobolev {
    s: f64,
    constant: f64,
    half_exponent: f64,
}

impl Sobolev {
    /// The thesis's smoothness.
    pub const DEFAULT_S: f64 = 1.4;

    /// Validates `1 < s < 2`.
    pub fn new(s: f64) -> Result<Self, KernelError> {
        if !(s > 1.0 && s < 2.0) {
            return Err(KernelError {
                kernel: "sobolev",
                message: format!("s must be in (1, 2), got {s}"),
            });
        }
        Ok(Sobolev {
            s,
            constant: 2f64.powf(2.0 * s - 1.0) / s,
            half_exponent: s - 1.0,
        })
    }

    /// `s − 1`, the exponent of `d²` (for the vectorised assembly).
    pub(crate) fn half_exponent(&self) -> f64 {
        self.half_exponent
    }

    /// `2^(2s−1)/s`, the kernel at `d² = 0`.
    pub(crate) fn constant(&self) -> f64 {
        self.constant
    }

    pub fn s(&self) -> f64 {
        self.s
    }

    /// `2^(2s−1)/s − (d²)^(s−1)`.
    #[inline]
    pub fn of_squared_distance(&self, d2: f64) -> f64 {
        // d² = 0 gives the constant exactly (pow(0, p) = 0).
        self.constant - super::fast_pow::pow(d2, self.half_exponent)
    }

    /// `∫_a^b [c − (2 − 2t)^(s−1)] dt = c (b − a) − [(2 − 2a)^s − (2 − 2b)^s] / (2s)`.
    pub fn integral_over_t(&self, a: f64, b: f64) -> f64 {
        let s = self.s;
        self.constant * (b - a) - ((2.0 - 2.0 * a).powf(s) - (2.0 - 2.0 * b).powf(s)) / (2.0 * s)
    }
}
