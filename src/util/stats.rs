//! Summary statistics (math.md §6): means with Student-t intervals, quantiles, the paired test
//! of the checks, log–log slopes. Shared by `run` and `render`.

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// Arithmetic mean.
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Sample standard deviation (denominator n − 1); NaN for fewer than 2 values.
pub fn sample_sd(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return f64::NAN;
    }
    let m = mean(x);
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// Two-sided 95% confidence interval of the mean from Student's t with n − 1 degrees of freedom.
pub fn mean_ci95(x: &[f64]) -> (f64, f64) {
    if x.len() < 2 {
        return (f64::NAN, f64::NAN);
    }
    let t = StudentsT::new(0.0, 1.0, (x.len() - 1) as f64)
        .expect("dof > 0")
        .inverse_cdf(0.975);
    let half = t * sample_sd(x) / (x.len() as f64).sqrt();
    let m = mean(x);
    (m - half, m + half)
}

/// The two-sided quantile of an interval `m ± q · sd` at `level ∈ (0, 1)`: Student-t with
/// `dof` degrees of freedom, or the standard normal for None (or 0 degrees of freedom, which
/// has no t law: then the interval is unbounded, `q = ∞`).
pub fn interval_quantile(dof: Option<usize>, level: f64) -> f64 {
    let p = 0.5 + 0.5 * level;
    match dof {
        None => Normal::new(0.0, 1.0).expect("standard normal").inverse_cdf(p),
        Some(0) => f64::INFINITY,
        Some(d) => StudentsT::new(0.0, 1.0, d as f64)
            .expect("dof > 0")
            .inverse_cdf(p),
    }
}

/// Quantile `p ∈ [0, 1]` of sorted data by linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy).
///
/// Between two equal order statistics the quantile is that value, so infinities (an interval
/// of width 0 around a wrong estimate gives `|err|/sd = ∞`) give `∞`, not the `NaN` of
/// `∞ + 0·(∞ − ∞)`.
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = h.ceil() as usize;
    if sorted[lo] == sorted[hi] {
        return sorted[lo];
    }
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Result of the one-sided paired t-test of H0 "A is no better than B" (mean of `a − b` ≥ 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairedTest {
    pub mean_difference: f64,
    pub t: f64,
    pub p_value: f64,
}

/// One-sided paired t-test on the per-trial differences `d_i = a_i − b_i` against `mean(d) < 0`.
pub fn paired_t_less(a: &[f64], b: &[f64]) -> PairedTest {
    assert_eq!(a.len(), b.len(), "paired samples");
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let m = mean(&d);
    let se = sample_sd(&d) / (d.len() as f64).sqrt();
    let t = m / se;
    let p_value = if se > 0.0 {
        StudentsT::new(0.0, 1.0, (d.len() - 1) as f64)
            .expect("dof > 0")
            .cdf(t)
    } else if m < 0.0 {
        0.0
    } else {
        1.0
    };
    PairedTest {
        mean_difference: m,
        t,
        p_value,
    }
}

/// Least-squares slope of `ln y` against `ln x` (the convergence order on a log–log plot).
pub fn log_log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let (mx, my) = (mean(&lx), mean(&ly));
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile_sorted(&x, 0.5), 3.0);
        assert_eq!(quantile_sorted(&x, 0.1), 1.4);
        assert_eq!(quantile_sorted(&x, 1.0), 5.0);
    }

    /// t_{0.975, 9} = 2.262157 (tables).
    #[test]
    fn ci_uses_student_t() {
        let x: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let (lo, hi) = mean_ci95(&x);
        let half = 2.262_157_162_740_992 * sample_sd(&x) / 10f64.sqrt();
        assert!((lo - (4.5 - half)).abs() < 1e-9 && (hi - (4.5 + half)).abs() < 1e-9);
    }

    #[test]
    fn paired_test_detects_a_clear_difference_and_not_a_null_one() {
        let b: Vec<f64> = (0..50).map(|i| 1.0 + (i % 7) as f64 * 0.1).collect();
        let better: Vec<f64> = b
            .iter()
            .enumerate()
            .map(|(i, v)| v - 0.05 - (i % 3) as f64 * 0.01)
            .collect();
        assert!(paired_t_less(&better, &b).p_value < 1e-6);
        let worse: Vec<f64> = b
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.05 + (i % 3) as f64 * 0.01)
            .collect();
        assert!(paired_t_less(&worse, &b).p_value > 0.99);
    }

    #[test]
    fn slope_of_a_power_law() {
        let x = [4.0, 8.0, 16.0, 32.0];
        let y: Vec<f64> = x.iter().map(|v: &f64| 3.0 * v.powf(-0.5)).collect();
        assert!((log_log_slope(&x, &y) + 0.5).abs() < 1e-12);
    }

    /// Regression (issue 20): the median of ratios that are mostly `∞` is `∞`, not NaN; finite
    /// data interpolate as before.
    #[test]
    fn quantiles_of_infinities_are_infinite() {
        let inf = f64::INFINITY;
        assert_eq!(quantile_sorted(&[0.5, inf, inf], 0.5), inf);
        assert_eq!(quantile_sorted(&[0.5, 1.0, inf, inf], 0.5), inf);
        assert_eq!(quantile_sorted(&[inf, inf], 0.3), inf);
        assert_eq!(quantile_sorted(&[1.0, 2.0, 4.0, 8.0], 0.5), 3.0);
        assert_eq!(quantile_sorted(&[1.0, 2.0, 2.0, 8.0], 0.5), 2.0);
    }
}
