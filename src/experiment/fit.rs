//! The convergence fit of one error series: which points enter it and the log–log slope with
//! its 95% interval. The plots' legends use it; a table of fits (`fits.csv`) should call the same
//! functions so that the numbers agree with the figures.

use statrs::distribution::{ContinuousCDF, StudentsT};

/// Errors at or below this fraction of `|I|` count as exact. Estimates equal to the truth up to
/// floating-point rounding (cosine-weighted MC on cos θ, BMCP with the analytic prior on a
/// constant) have errors of 0 or a few ulps: on a log axis and in a fitted slope those would be
/// noise of the arithmetic, not convergence. 1e-12 is ~4500 ulps, room for the rounding of
/// sums over up to ~10⁷ points, and far below any error these estimators reach by converging.
pub const EXACT_RELATIVE: f64 = 1e-12;

/// Whether `error` (an absolute error, or a mean of them) is zero up to rounding for an integral
/// whose true value is `truth`.
pub fn is_exact(error: f64, truth: f64) -> bool {
    error.is_finite() && error <= EXACT_RELATIVE * truth.abs()
}

/// Whether `error` can stand on a log axis and enter a fit: finite and not exact.
pub fn is_fittable(error: f64, truth: f64) -> bool {
    error.is_finite() && !is_exact(error, truth)
}

/// The smallest N of the fitting range: the slope is fitted over the upper half of the grid,
/// the N values at or above the median of the sorted grid (for 4, 8, …, 512 that is N ≥ 64).
/// The pre-asymptotic small-N points bend every curve, so a fit over the whole grid would
/// mix two regimes; the upper half is a fixed rule that needs no tuning per estimator.
///
/// # Panics
/// If `samples` is empty (a plan never is).
pub fn fit_from(samples: &[usize]) -> usize {
    let mut sorted = samples.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    assert!(!sorted.is_empty(), "an empty grid has no fitting range");
    let m = sorted.len();
    let median = if m % 2 == 1 {
        sorted[m / 2] as f64
    } else {
        0.5 * (sorted[m / 2 - 1] as f64 + sorted[m / 2] as f64)
    };
    *sorted
        .iter()
        .find(|&&n| n as f64 >= median)
        .expect("the largest N is at least the median")
}

/// A fitted slope above this is a plateau ([`SlopeFlag::Plateau`]): error ∝ N^(−0.1) falls by
/// under 7% per doubling of N, far slower than any estimator here converges (MC: N^(−1/2)).
pub const PLATEAU_SLOPE: f64 = -0.1;

/// Why a fitted slope is no convergence rate to state (the plots say `slope n/a`, `fits.csv`
/// names the flag).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlopeFlag {
    /// The slope is above [`PLATEAU_SLOPE`]: over the range the mean error has levelled off
    /// (or rises), so the slope measures no rate of convergence.
    Plateau,
    /// The 95% interval is wider than the slope (half-width ≥ |slope|, so it holds 0): the fit
    /// cannot even tell whether the error falls — the points do not follow one power law over
    /// the range (a staircase, a bend), or are too noisy.
    WideInterval,
}

impl SlopeFlag {
    /// The name in `fits.csv`.
    pub fn name(self) -> &'static str {
        match self {
            SlopeFlag::Plateau => "plateau",
            SlopeFlag::WideInterval => "wide_interval",
        }
    }

    /// The flag of a slope with its interval, if it has one: plateau first.
    pub fn of(slope: f64, ci95: Option<(f64, f64)>) -> Option<SlopeFlag> {
        if slope > PLATEAU_SLOPE {
            return Some(SlopeFlag::Plateau);
        }
        let (lo, hi) = ci95?;
        (0.5 * (hi - lo) >= slope.abs()).then_some(SlopeFlag::WideInterval)
    }
}

/// A least-squares slope of `ln error` against `ln N`.
#[derive(Clone, Debug, PartialEq)]
pub struct SlopeFit {
    /// The convergence order: error ∝ N^slope.
    pub slope: f64,
    /// The 95% interval of the slope from the regression's residuals (Student t with
    /// `points − 2` degrees of freedom); `None` with two points, which leave no residual.
    /// The residuals are the points' departures from a straight line, so the interval says how
    /// well one power law describes the range, not only the trials' noise.
    pub ci95: Option<(f64, f64)>,
    /// The smallest N that entered the fit: at or above the range's start ([`fit_from`]),
    /// above it where that N is not on the grid or its mean is exact or not finite.
    pub from_n: usize,
    /// The largest N that entered the fit.
    pub to_n: usize,
    /// How many points entered the fit.
    pub points: usize,
    /// Why the slope is no rate to state, if it is not ([`SlopeFlag::of`]).
    pub flag: Option<SlopeFlag>,
}

/// What can be said about one series' convergence.
#[derive(Clone, Debug, PartialEq)]
pub enum SeriesFit {
    /// Every point is exact ([`is_exact`]): there is no rate to fit.
    Exact,
    /// A slope over the range; `exact_at` lists the N (anywhere in the grid) left out as exact.
    Slope { fit: SlopeFit, exact_at: Vec<usize> },
    /// Fewer than two fittable points with N ≥ `from_n`: no slope.
    TooFew { from_n: usize, exact_at: Vec<usize> },
}

/// Fits `points` — (N, mean absolute error) of one series — for an integral whose true value
/// is `truth`, over N ≥ `from_n` (normally [`fit_from`] of the plan's grid). Exact and
/// non-finite points are left out.
pub fn fit_series(points: &[(usize, f64)], truth: f64, from_n: usize) -> SeriesFit {
    let exact_at: Vec<usize> = points
        .iter()
        .filter(|p| is_exact(p.1, truth))
        .map(|p| p.0)
        .collect();
    if !points.is_empty() && exact_at.len() == points.len() {
        return SeriesFit::Exact;
    }
    let fitted: Vec<&(usize, f64)> = points
        .iter()
        .filter(|p| p.0 >= from_n && is_fittable(p.1, truth))
        .collect();
    let used: Vec<(f64, f64)> = fitted.iter().map(|p| ((p.0 as f64).ln(), p.1.ln())).collect();
    if used.len() < 2 {
        return SeriesFit::TooFew { from_n, exact_at };
    }
    let k = used.len() as f64;
    let mx = used.iter().map(|p| p.0).sum::<f64>() / k;
    let my = used.iter().map(|p| p.1).sum::<f64>() / k;
    let sxx: f64 = used.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = used.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    let ci95 = (used.len() > 2).then(|| {
        let residual: f64 = used.iter().map(|p| (p.1 - my - slope * (p.0 - mx)).powi(2)).sum();
        let se = (residual / (k - 2.0) / sxx).sqrt();
        let t = StudentsT::new(0.0, 1.0, k - 2.0)
            .expect("dof > 0")
            .inverse_cdf(0.975);
        (slope - t * se, slope + t * se)
    });
    SeriesFit::Slope {
        fit: SlopeFit {
            slope,
            ci95,
            from_n: fitted.iter().map(|p| p.0).min().expect("two points"),
            to_n: fitted.iter().map(|p| p.0).max().expect("two points"),
            points: used.len(),
            flag: SlopeFlag::of(slope, ci95),
        },
        exact_at,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_is_the_upper_half_of_the_grid() {
        assert_eq!(fit_from(&[4, 8, 16, 32, 64, 128, 256, 512]), 64);
        // Odd length: the median itself is in.
        assert_eq!(fit_from(&[4, 8, 16, 32, 64]), 16);
        // Unsorted, uneven grids: N at or above the median of the sorted grid.
        assert_eq!(fit_from(&[1000, 10, 100, 30]), 100);
        assert_eq!(fit_from(&[7]), 7);
    }

    #[test]
    fn a_power_law_is_recovered_over_the_range_only() {
        // N^(-1/2) above 64, anything below: the fit must not see the small N.
        let grid = [4, 8, 16, 32, 64, 128, 256, 512];
        let pts: Vec<(usize, f64)> = grid
            .iter()
            .map(|&n| (n, if n >= 64 { 3.0 / (n as f64).sqrt() } else { 1.0 }))
            .collect();
        match fit_series(&pts, 1.0, fit_from(&grid)) {
            SeriesFit::Slope { fit, exact_at } => {
                assert!((fit.slope + 0.5).abs() < 1e-12, "{fit:?}");
                assert_eq!((fit.from_n, fit.to_n, fit.points), (64, 512, 4));
                assert_eq!(fit.flag, None);
                let (lo, hi) = fit.ci95.unwrap();
                assert!(lo <= fit.slope && fit.slope <= hi && hi - lo < 1e-9);
                assert!(exact_at.is_empty());
            }
            other => panic!("{other:?}"),
        }
    }

    /// A noisy line: the interval holds the slope and has the textbook width.
    #[test]
    fn the_interval_is_the_regression_interval() {
        let pts = [
            (1, 1.0f64.exp()),
            (10, 0.5f64.exp()),
            (100, 0.2f64.exp()),
            (1000, (-0.4f64).exp()),
        ];
        let SeriesFit::Slope { fit, .. } = fit_series(&pts, 100.0, 1) else {
            panic!()
        };
        let x: Vec<f64> = [1.0f64, 10.0, 100.0, 1000.0].iter().map(|v| v.ln()).collect();
        let y = [1.0, 0.5, 0.2, -0.4];
        assert!(
            (fit.slope - crate::util::stats::log_log_slope(&[1.0, 10.0, 100.0, 1000.0], &pts.map(|p| p.1)))
                .abs()
                < 1e-12
        );
        let mx = x.iter().sum::<f64>() / 4.0;
        let my = y.iter().sum::<f64>() / 4.0;
        let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
        let rss: f64 = x
            .iter()
            .zip(y)
            .map(|(a, b)| (b - my - fit.slope * (a - mx)).powi(2))
            .sum();
        // t_{0.975, 2} = 4.302653 (tables).
        let half = 4.302_652_729_911_275 * (rss / 2.0 / sxx).sqrt();
        let (lo, hi) = fit.ci95.unwrap();
        assert!((lo - (fit.slope - half)).abs() < 1e-9 && (hi - (fit.slope + half)).abs() < 1e-9);
    }

    /// Issue 21 item 5: `fits.csv`'s `from_n` echoed the requested start of the range, not the
    /// smallest N fitted, and a slope on a plateau or with an interval wider than itself was
    /// reported like any other.
    #[test]
    fn fits_report_the_range_fitted_and_flag_plateaus_and_wide_intervals() {
        // The range starts at 50, the grid's first N above it is 64, and 64 is exact.
        let pts = [
            (16, 0.5),
            (32, 0.3),
            (64, 0.0),
            (128, 0.1),
            (256, 0.05),
            (512, 0.025),
        ];
        let SeriesFit::Slope { fit, .. } = fit_series(&pts, 1.0, 50) else {
            panic!()
        };
        assert_eq!((fit.from_n, fit.to_n, fit.points), (128, 512, 3));
        assert_eq!(fit.flag, None);
        // Levelled off: the slope is about 0 (the thesis's shared-direction kernel means).
        let flat = [(128, 1.70e-2), (256, 1.35e-2), (512, 1.36e-2)];
        let SeriesFit::Slope { fit, .. } = fit_series(&flat, 1.0, 256) else {
            panic!()
        };
        assert_eq!(
            (fit.points, fit.ci95, fit.flag),
            (2, None, Some(SlopeFlag::Plateau))
        );
        // A staircase (rings at N that are not squares): the interval holds 0.
        let stairs = [(128, 1.86e-2), (256, 3.16e-3), (512, 5.35e-3), (1024, 6.06e-4)];
        let SeriesFit::Slope { fit, .. } = fit_series(&stairs, 1.0, 128) else {
            panic!()
        };
        let (lo, hi) = fit.ci95.unwrap();
        assert!(fit.slope < -1.0 && lo < 0.0 && hi > 0.0, "{fit:?}");
        assert_eq!(fit.flag, Some(SlopeFlag::WideInterval));
        // The rules at their edges.
        assert_eq!(SlopeFlag::of(-0.1, None), None);
        assert_eq!(SlopeFlag::of(-0.099, None), Some(SlopeFlag::Plateau));
        assert_eq!(SlopeFlag::of(0.3, Some((0.2, 0.4))), Some(SlopeFlag::Plateau));
        assert_eq!(
            SlopeFlag::of(-1.0, Some((-2.0, 0.0))),
            Some(SlopeFlag::WideInterval)
        );
        assert_eq!(SlopeFlag::of(-1.0, Some((-1.9, -0.1))), None);
    }

    #[test]
    fn exact_points_are_left_out_and_named() {
        // All zero: exact, never a slope of 0.
        assert_eq!(
            fit_series(&[(4, 0.0), (8, 0.0), (16, 0.0)], 2.0, 8),
            SeriesFit::Exact
        );
        // Rounding-level errors are exact too.
        assert_eq!(
            fit_series(&[(4, 4e-16), (8, 0.0)], std::f64::consts::PI, 4),
            SeriesFit::Exact
        );
        // A series exact in part: the exact N are left out of the fit and listed.
        match fit_series(&[(4, 0.0), (8, 0.1), (16, 0.05), (32, 0.0)], 1.0, 4) {
            SeriesFit::Slope { fit, exact_at } => {
                assert_eq!(exact_at, [4, 32]);
                assert_eq!(fit.points, 2);
                assert!((fit.slope + 1.0).abs() < 1e-12);
                assert_eq!(fit.ci95, None);
            }
            other => panic!("{other:?}"),
        }
        // One fittable point in the range: no slope.
        assert_eq!(
            fit_series(&[(4, 0.3), (8, 0.1), (16, 0.05), (32, 0.0)], 1.0, 16),
            SeriesFit::TooFew {
                from_n: 16,
                exact_at: vec![32]
            }
        );
        // Non-finite means are neither exact nor fitted.
        assert_eq!(
            fit_series(&[(4, f64::NAN), (8, 0.1)], 1.0, 4),
            SeriesFit::TooFew {
                from_n: 4,
                exact_at: vec![]
            }
        );
    }
}
