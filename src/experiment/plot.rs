//! One SVG per integrand: absolute error against N on log–log axes (plotters), and its caption
//! file. Each estimator has its mean error (line and markers, in its face: [`crate::plot::faces`])
//! and, as `plot.bands` says ([`super::plan::resolve_bands`]; by default where it overlaps no
//! band drawn before it, [`non_overlapping`]), the 10–90% quantile band of its trials (light
//! fill, dashed edges); the legend gives its slope fitted over the stated range ([`super::fit`]),
//! or says that it is exact; a dashed N^(−1/2) guide goes through the MC series. A series that
//! lies on an earlier one is drawn over it, the earlier one wider, and the caption says where.
//! A tolerance estimator's points stand at the mean N its stopping rule used from each first
//! stage N₀ ([`drawn_n`]), not at N₀, and get no slope.

use super::adaptive::Cell as AdaptiveCell;
use super::fit::{PLATEAU_SLOPE, SeriesFit, SlopeFlag, fit_series, is_fittable};
use super::plan::Plan;
use super::summary::CellSummary;
use crate::plot::{self as style, Axis, LegendEntry, SeriesStyle, Swatch};
use crate::sampling::{Density, Design};
use plotters::prelude::*;

/// Height of the chart (axes and plotting area), between the title block and the legend.
const CHART_HEIGHT: u32 = 560;

/// The figure (SVG and caption) for integrand `fi`; `used` holds the tolerance estimators'
/// stopping cells (empty without them), which say where their points stand ([`drawn_n`]).
pub fn error_plot_svg(
    plan: &Plan,
    cells: &[CellSummary],
    used: &[AdaptiveCell],
    fi: usize,
) -> crate::Result<style::Figure> {
    draw(plan, cells, used, fi).map_err(|e| crate::Error::Encode(format!("drawing the error plot: {e}")))
}

/// Where cell `c` stands on an N axis: at its N, or, for a tolerance estimator, at the mean
/// number of points its stopping rule used from first stage N₀ = `c.n` (`mean_n_used` of
/// `stopping_summary.csv`): the N it actually spent (issue 43 item 5).
pub fn drawn_n(used: &[AdaptiveCell], c: &CellSummary) -> f64 {
    used.iter()
        .find(|u| u.integrand == c.integrand && u.estimator == c.estimator && u.first_n == c.n)
        .map_or(c.n as f64, |u| u.mean_n_used)
}

/// The N axis over `range` of a plot whose points may stand beyond the N grid `samples`
/// (tolerance estimators at the N they used), ticked as [`Axis::counts`] at the grid and, for
/// a grid of powers of two, at the powers of two of the range beyond it.
pub fn n_axis(samples: &[usize], range: (f64, f64)) -> Axis {
    let mut grid = samples.to_vec();
    let (lo, hi) = (grid.iter().min().copied(), grid.iter().max().copied());
    if let (Some(lo), Some(hi)) = (lo, hi)
        && grid.iter().all(|n| n.is_power_of_two())
    {
        // The largest power of two ≤ the range's top, the smallest ≥ its bottom.
        let top = 1usize << (range.1.max(1.0).log2().floor() as u32);
        let bottom = (range.0.max(1.0).ceil() as usize).next_power_of_two();
        if top > hi {
            grid.push(top);
        }
        if bottom < lo {
            grid.push(bottom);
        }
    }
    Axis::counts(&grid, range, "number of samples N")
}

/// The caption's sentence on tolerance estimators, when the figure has any.
pub fn tolerance_note(plan: &Plan, shown: impl Fn(usize) -> bool) -> Option<String> {
    let names: Vec<&str> = plan
        .estimators
        .iter()
        .enumerate()
        .filter(|(ei, e)| e.tolerance.is_some() && shown(*ei))
        .map(|(_, e)| e.label.as_str())
        .collect();
    (!names.is_empty()).then(|| {
        format!(
            "{} {} at a tolerance: each point stands at the mean N the stopping rule used from a first stage N₀ \
             (mean_n_used in stopping_summary.csv), not at N₀, and no slope is fitted to {}.",
            names.join(", "),
            if names.len() == 1 { "stops" } else { "stop" },
            if names.len() == 1 { "it" } else { "them" }
        )
    })
}

/// The estimator the N^(−1/2) guide goes through: the first `mc` estimator on uniform i.i.d.
/// points (the rate's textbook case), else the first `mc` one; tolerance estimators (which
/// stand at the N they used) only when no other is MC; `None` without MC.
pub fn guide_estimator(plan: &Plan) -> Option<usize> {
    let fixed = plan
        .estimators
        .iter()
        .any(|e| e.method.is_monte_carlo() && e.tolerance.is_none());
    let mc =
        |e: &&super::plan::PlannedEstimator| e.method.is_monte_carlo() && (e.tolerance.is_none() || !fixed);
    plan.estimators
        .iter()
        .position(|e| mc(&e) && e.design == Design::Iid(Density::Uniform))
        .or_else(|| plan.estimators.iter().position(|e| mc(&e)))
}

/// The legend text of a series labelled `label` with fit `fit`, e.g.
/// `BMC: slope −1.52 ± 0.11 (N ≥ 64)`, `BMC rings: slope n/a (wide interval, N ≥ 128)` or
/// `MC cosine: exact at every N`. The range starts at the smallest N fitted.
pub fn fit_label(label: &str, fit: &SeriesFit) -> String {
    let exact_note = |exact_at: &[usize]| match exact_at.len() {
        0 => String::new(),
        1..=3 => format!(
            "; exact at N = {}",
            exact_at
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        k => format!("; exact at {k} N"),
    };
    match fit {
        SeriesFit::Exact => format!("{label}: exact at every N"),
        SeriesFit::Slope { fit, exact_at } => {
            let slope = style::signed(fit.slope, 2);
            let body = match (fit.flag, fit.ci95) {
                (Some(flag), _) => format!(
                    "slope n/a ({}, N ≥ {})",
                    match flag {
                        SlopeFlag::Plateau => "plateau",
                        SlopeFlag::WideInterval => "wide interval",
                    },
                    fit.from_n
                ),
                (None, ci95) => match ci95 {
                    Some((lo, hi)) => format!(
                        "slope {slope} ± {} (N ≥ {})",
                        style::signed(0.5 * (hi - lo), 2),
                        fit.from_n
                    ),
                    None => format!("slope {slope} (N ≥ {}, {} points)", fit.from_n, fit.points),
                },
            };
            format!("{label}: {body}{}", exact_note(exact_at))
        }
        SeriesFit::TooFew { from_n, exact_at } => format!(
            "{label}: no slope (fewer than 2 nonzero means at N ≥ {from_n}){}",
            exact_note(exact_at)
        ),
    }
}

/// The default bands (`plot.bands` not given): per series (its cells as `(N, q10, q90)`), whether
/// its band is drawn — in series order, a band is drawn unless, at some N both have, its
/// interval `[q10, q90]` overlaps that of a band already drawn. So no two drawn bands cover each
/// other, and the first series keeps its band.
pub fn non_overlapping(series: &[Vec<(usize, f64, f64)>]) -> Vec<bool> {
    let mut drawn: Vec<bool> = Vec::with_capacity(series.len());
    for (i, s) in series.iter().enumerate() {
        let clash = (0..i).filter(|&j| drawn[j]).any(|j| {
            s.iter().any(|&(n, lo, hi)| {
                series[j]
                    .iter()
                    .find(|c| c.0 == n)
                    .is_some_and(|&(_, lo2, hi2)| lo.max(lo2) <= hi.min(hi2))
            })
        });
        drawn.push(!clash && !s.is_empty());
    }
    drawn
}

/// Maximal runs of consecutive indices `i` (in `0..len`) with `keep(i)`.
fn runs(len: usize, keep: impl Fn(usize) -> bool) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for i in 0..=len {
        match (start, i < len && keep(i)) {
            (None, true) => start = Some(i),
            (Some(s), false) => {
                out.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    out
}

fn draw(
    plan: &Plan,
    cells: &[CellSummary],
    used: &[AdaptiveCell],
    fi: usize,
) -> style::FigureResult<style::Figure> {
    let integrand = &plan.integrands[fi];
    let name = integrand.display_name();
    let truth = integrand.integral();
    let ok = |e: f64| is_fittable(e, truth);
    let from_n = plan.fit_from_n;
    let xn = |c: &CellSummary| drawn_n(used, c);
    let tolerance = |ei: usize| plan.estimators[ei].tolerance.is_some();

    // Each estimator's cells in N order, and what its points say about its rate.
    let series: Vec<Vec<&CellSummary>> = (0..plan.estimators.len())
        .map(|ei| {
            let mut s: Vec<&CellSummary> = cells
                .iter()
                .filter(|c| c.integrand == fi && c.estimator == ei)
                .collect();
            s.sort_by(|a, b| xn(a).total_cmp(&xn(b)));
            s
        })
        .collect();
    let fits: Vec<SeriesFit> = series
        .iter()
        .map(|s| {
            let points: Vec<(usize, f64)> = s.iter().map(|c| (c.n, c.mean_abs_error)).collect();
            fit_series(&points, truth, from_n)
        })
        .collect();
    let allowed = |ei: usize| plan.bands.get(ei).copied().unwrap_or(false);
    let bands_drawn: Vec<bool> = if plan.auto_bands {
        let intervals: Vec<Vec<(usize, f64, f64)>> = series
            .iter()
            .map(|s| {
                s.iter()
                    .map(|c| (c.n, c.q10_abs_error, c.q90_abs_error))
                    .collect()
            })
            .collect();
        non_overlapping(&intervals)
    } else {
        (0..plan.estimators.len()).map(allowed).collect()
    };
    let banded = |ei: usize| bands_drawn[ei];

    let n_min = *plan.samples.iter().min().expect("samples") as f64;
    let n_max = *plan.samples.iter().max().expect("samples") as f64;
    // The N the points stand at: the grid's, and the tolerance estimators' N used.
    let xs: Vec<f64> = [n_min, n_max]
        .into_iter()
        .chain(series.iter().flatten().map(|c| xn(c)))
        .collect();
    // The guide ∝ N^(−1/2) through the MC series' mean error at its first N (with an error).
    let guide = guide_estimator(plan).and_then(|ei| {
        let c = series[ei].iter().find(|c| ok(c.mean_abs_error))?;
        let a = c.mean_abs_error * xn(c).sqrt();
        Some((ei, a, vec![(n_min, a / n_min.sqrt()), (n_max, a / n_max.sqrt())]))
    });

    // Axis ranges from what is drawn: means, the bands drawn, and the guide.
    let drawn: Vec<f64> = series
        .iter()
        .enumerate()
        .flat_map(|(ei, s)| {
            s.iter().flat_map(move |c| {
                let mut v = vec![c.mean_abs_error];
                if banded(ei) {
                    v.extend([c.q10_abs_error, c.q90_abs_error]);
                }
                v
            })
        })
        .filter(|&e| ok(e))
        .chain(guide.iter().flat_map(|g| g.2.iter().map(|p| p.1)))
        .collect();
    let (y0, y1) = style::padded_log_range(&drawn, 1.5);
    let x = n_axis(&plan.samples, style::padded_log_range(&xs, 1.25));
    let y = Axis::log_values((y0, y1), error_axis_label("absolute error |Î − I|"));

    // Series that lie on an earlier one are drawn over it, the earlier wider (and said so).
    let means: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| {
            s.iter()
                .filter(|c| ok(c.mean_abs_error))
                .map(|c| (xn(c), c.mean_abs_error))
                .collect()
        })
        .collect();
    let labels: Vec<String> = plan.estimators.iter().map(|e| e.label.clone()).collect();
    let to_px = style::log_px((y0, y1), style::plot_height(CHART_HEIGHT));
    let found = style::coincidences(&labels, &means, &to_px, "N");
    let faces = super::plot::faces(&plan.estimators);
    let styles: Vec<SeriesStyle> = (0..means.len()).map(|ei| found.style(ei, faces[ei])).collect();
    let mut coincident = found.notes;
    if let Some((ei, a, _)) = &guide {
        let on_guide = |n: f64| a / n.sqrt();
        coincident.extend(style::guide_note(
            &means[*ei],
            on_guide,
            &to_px,
            &labels[*ei],
            "N",
        ));
    }

    let mut legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .zip(&fits)
        .enumerate()
        .map(|(ei, (e, fit))| {
            let text = if tolerance(ei) {
                format!("{}: at the mean N used", e.label)
            } else {
                fit_label(&e.label, fit)
            };
            LegendEntry::key(Swatch::Styled(styles[ei]), text)
        })
        .collect();
    if let Some((ei, _, _)) = &guide {
        legend.push(LegendEntry::key(
            Swatch::Guide,
            format!("∝ N^(−1/2) through {}", plan.estimators[*ei].label),
        ));
    }
    let any_band = (0..plan.estimators.len()).any(banded);
    if any_band {
        legend.push(LegendEntry::key(Swatch::Band, "10–90% quantiles of |Î − I|"));
    }

    let mut caption = vec![format!(
        "Lines and markers: the mean absolute error |Î − I| over the {} trials at each N, one series per estimator.",
        plan.trials
    )];
    let rule = if plan.auto_bands {
        "by default a band is drawn only where it overlaps no band drawn before it, in the legend's order, \
         so that no two bands cover each other; plot.bands chooses"
    } else {
        "plot.bands"
    };
    caption.push(if any_band {
        let which: Vec<&str> = labels
            .iter()
            .enumerate()
            .filter(|(ei, _)| banded(*ei))
            .map(|(_, l)| l.as_str())
            .collect();
        format!(
            "Bands (light fill, dashed edges in the series' colour): the 10–90% quantiles of |Î − I| over the {} \
             trials, drawn for {} ({rule}); every estimator's quantiles are in summary.csv.",
            plan.trials,
            if which.len() == labels.len() {
                "every estimator".to_string()
            } else {
                which.join(", ")
            }
        )
    } else {
        format!("No quantile bands are drawn ({rule}); the 10–90% quantiles of |Î − I| are in summary.csv.")
    });
    let fitted = || {
        fits.iter()
            .enumerate()
            .filter(|(ei, _)| !tolerance(*ei))
            .map(|p| p.1)
    };
    let any_exact = fitted().any(|f| match f {
        SeriesFit::Exact => true,
        SeriesFit::Slope { exact_at, .. } | SeriesFit::TooFew { exact_at, .. } => !exact_at.is_empty(),
    });
    // The reasons for "n/a" that this figure uses, each explained.
    let flagged = |flag: SlopeFlag| {
        fitted().any(|f| matches!(f, SeriesFit::Slope { fit, .. } if fit.flag == Some(flag)))
    };
    let mut reasons = Vec::new();
    if flagged(SlopeFlag::Plateau) {
        reasons.push(format!(
            "plateau: the slope is above {}, the error has levelled off",
            style::signed(PLATEAU_SLOPE, 1)
        ));
    }
    if flagged(SlopeFlag::WideInterval) {
        reasons.push("wide interval: the 95% interval is wider than the slope, so it holds 0".to_string());
    }
    caption.push(format!(
        "Slope: least-squares fit of ln(mean error) on ln N over N ≥ {from_n}{}, ± its 95% interval{}{}.",
        if from_n == super::fit::fit_from(&plan.samples) {
            " (the upper half of the N grid)"
        } else {
            " (fit_from_n)"
        },
        if reasons.is_empty() {
            String::new()
        } else {
            format!(
                "; n/a: no rate to state ({}; numbers in fits.csv)",
                reasons.join("; ")
            )
        },
        if any_exact {
            "; exact: error 0 up to rounding (≤ 1e-12·I), not drawn"
        } else {
            ""
        }
    ));
    if let Some((ei, _, _)) = &guide {
        caption.push(format!(
            "Dashed grey line: ∝ N^(−1/2), the Monte Carlo rate, through {}'s mean error at its smallest N.",
            labels[*ei]
        ));
    }
    caption.extend(tolerance_note(plan, |_| true));
    caption.extend(coincident);

    style::svg_figure(
        &plan.title,
        &subtitle(&name, truth, plan.trials),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &x, &y)?;

            // Bands first, so that no band covers another series' line or markers. Light fills
            // keep overlaps close to white; the dashed edges in the series' colour say whose band
            // is whose.
            for (ei, s) in series.iter().enumerate().filter(|(ei, _)| banded(*ei)) {
                let colour = style::colour(faces[ei].colour);
                let edge = colour.mix(0.8).stroke_width(1);
                for r in runs(s.len(), |i| ok(s[i].q90_abs_error)) {
                    let run = &s[r];
                    // A lower quantile of 0 (some trials exact) reaches below the axis: clamp to it.
                    let lower = |c: &CellSummary| if ok(c.q10_abs_error) { c.q10_abs_error } else { y0 };
                    let mut band: Vec<(f64, f64)> = run.iter().map(|c| (xn(c), c.q90_abs_error)).collect();
                    band.extend(run.iter().rev().map(|c| (xn(c), lower(c))));
                    chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.06).filled())))?;
                    let upper: Vec<(f64, f64)> = run.iter().map(|c| (xn(c), c.q90_abs_error)).collect();
                    chart.draw_series(DashedLineSeries::new(upper, 5, 4, edge))?;
                    for lr in runs(run.len(), |i| ok(run[i].q10_abs_error)) {
                        let low: Vec<(f64, f64)> = run[lr].iter().map(|c| (xn(c), c.q10_abs_error)).collect();
                        chart.draw_series(DashedLineSeries::new(low, 5, 4, edge))?;
                    }
                }
            }
            for (ei, s) in series.iter().enumerate() {
                let style = styles[ei];
                let colour = style::colour(style.colour);
                // Exact (or non-finite) means are gaps in the line, not points at an axis floor.
                for r in runs(s.len(), |i| ok(s[i].mean_abs_error)) {
                    let line: Vec<(f64, f64)> = s[r].iter().map(|c| (xn(c), c.mean_abs_error)).collect();
                    let stroke = colour.stroke_width(style.line_width());
                    if style.dashed {
                        chart.draw_series(DashedLineSeries::new(line, 8, 5, stroke))?;
                    } else {
                        chart.draw_series(LineSeries::new(line, stroke))?;
                    }
                }
            }
            // The guide over the lines (it lies on MC's), under the markers.
            if let Some((_, _, line)) = &guide {
                style::draw_guide(&mut chart, line.clone())?;
            }
            for (ei, s) in series.iter().enumerate() {
                for c in s.iter().filter(|c| ok(c.mean_abs_error)) {
                    let at = chart.backend_coord(&(xn(c), c.mean_abs_error));
                    style::draw_styled_marker(root, styles[ei], at)?;
                }
            }
            Ok(())
        },
    )
}

/// An error axis's description, `<what>  [sr]`: one style for every error plot (the subtitle
/// names the integrand and its integral).
pub(super) fn error_axis_label(what: &str) -> String {
    format!("{what}  [sr]")
}

/// The error plot's subtitle, the integrand named once (the title names the comparison):
/// `∫ f dω = I sr; T trials per N`, or, when a long name (a render-scene pixel) would make that
/// run past the figure, `integrand f; integral I sr; T trials per N`.
fn subtitle(name: &str, truth: f64, trials: usize) -> String {
    let full = format!("∫ {name} dω = {truth:.6} sr; {trials} trials per N");
    if style::estimated_width(&full, 18.0) <= (style::WIDTH - 40) as f64 {
        full
    } else {
        format!("integrand {name}; integral {truth:.6} sr; {trials} trials per N")
    }
}

/// The faces of an experiment's `estimators`, in their order: each estimator's method, kernel
/// and design through [`crate::plot::faces::faces_of`] (the rule of [`crate::plot::faces`]).
///
/// A light-aware estimator (`mc-light`, `mis`, …) is a Monte Carlo method (dashed) whose
/// identity — its method and options — takes a colour of its own, as another kernel would.
pub fn faces(estimators: &[super::plan::PlannedEstimator]) -> Vec<SeriesStyle> {
    use crate::bq::estimator::Method;
    let light: Vec<Option<serde_json::Value>> = estimators
        .iter()
        .map(|e| {
            e.light.map(|l| {
                let mut id = serde_json::json!({
                    "method": l.method.name(),
                    "heuristic": l.heuristic.name(),
                    "compensation": l.compensation,
                });
                if l.method == crate::bq::estimator::mis::LightMethod::BqPss {
                    id["order"] = l.pss.order.number().into();
                    id["weights"] = l.pss.weights.name().into();
                }
                id
            })
        })
        .collect();
    let identities: Vec<(Method, Option<&serde_json::Value>, Design)> = estimators
        .iter()
        .zip(&light)
        .map(|(e, l)| match (e.method.points(), l) {
            (Some(m), _) => (m, e.settings.kernel.as_ref(), e.design),
            (None, l) => (Method::Mc, l.as_ref(), e.design),
        })
        .collect();
    crate::plot::faces::faces_of(&identities)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::fit::SlopeFit;

    /// Default bands: a band that would overlap one drawn before it is left out; one that
    /// touches none is kept, whatever its place; series without cells get none.
    #[test]
    fn default_bands_never_overlap() {
        let mc = vec![(4, 0.1, 0.5), (16, 0.05, 0.2)];
        let bmc = vec![(4, 0.2, 0.6), (16, 0.001, 0.01)]; // overlaps MC at N = 4
        let far = vec![(4, 1e-4, 1e-3), (16, 1e-5, 1e-4)];
        let other_n = vec![(8, 0.1, 0.5)]; // no N in common with MC: no overlap
        assert_eq!(
            non_overlapping(&[mc.clone(), bmc.clone(), far.clone(), other_n, vec![]]),
            [true, false, true, true, false]
        );
        // Touching intervals overlap (they would share an edge).
        assert_eq!(
            non_overlapping(&[vec![(4, 0.1, 0.2)], vec![(4, 0.2, 0.3)]]),
            [true, false]
        );
        assert_eq!(non_overlapping(&[bmc, mc, far]), [true, false, true]);
    }

    /// A short integrand name appears in the integral; a render-scene pixel's is named once,
    /// so the subtitle fits the figure.
    #[test]
    fn subtitles_name_a_long_integrand_once() {
        let s = subtitle("cos³θ", std::f64::consts::FRAC_PI_2, 300);
        assert_eq!(s, "∫ cos³θ dω = 1.570796 sr; 300 trials per N");
        assert_eq!(s.matches("cos³θ").count(), 1);
        let name = "pixel (128, 168) of 256×256, sphere, sky, g";
        let s = subtitle(name, 0.046001, 300);
        assert_eq!(s.matches(name).count(), 1, "{s}");
        assert!(
            style::estimated_width(&s, 18.0) <= (style::WIDTH - 40) as f64,
            "{s}"
        );
    }

    #[test]
    fn runs_split_at_gaps() {
        let v = [1.0, 0.0, 2.0, 3.0, 0.0];
        assert_eq!(runs(v.len(), |i| v[i] > 0.0), [0..1, 2..4]);
        assert_eq!(runs(0, |_| true), []);
    }

    #[test]
    fn labels_state_the_range_and_never_a_zero_slope_for_exact_series() {
        let fit = SlopeFit {
            slope: -1.5234,
            ci95: Some((-1.6, -1.4)),
            from_n: 64,
            to_n: 512,
            points: 4,
            flag: None,
        };
        assert_eq!(
            fit_label(
                "BMC",
                &SeriesFit::Slope {
                    fit: fit.clone(),
                    exact_at: vec![]
                }
            ),
            "BMC: slope −1.52 ± 0.10 (N ≥ 64)"
        );
        assert_eq!(
            fit_label(
                "BMC",
                &SeriesFit::Slope {
                    fit,
                    exact_at: vec![4, 8]
                }
            ),
            "BMC: slope −1.52 ± 0.10 (N ≥ 64); exact at N = 4, 8"
        );
        assert_eq!(fit_label("MC cos", &SeriesFit::Exact), "MC cos: exact at every N");
        // Issue 21 item 5: a slope on a plateau or with an interval wider than itself was shown
        // as a rate (`slope −1.41 ± 2.23`); it is flagged instead.
        let flagged = |slope: f64, ci95: Option<(f64, f64)>| SeriesFit::Slope {
            fit: SlopeFit {
                slope,
                ci95,
                from_n: 128,
                to_n: 1024,
                points: 4,
                flag: crate::experiment::fit::SlopeFlag::of(slope, ci95),
            },
            exact_at: vec![],
        };
        assert_eq!(
            fit_label("BMC rings", &flagged(-1.405, Some((-3.637, 0.826)))),
            "BMC rings: slope n/a (wide interval, N ≥ 128)"
        );
        assert_eq!(
            fit_label("BMC (MC z)", &flagged(-0.04, None)),
            "BMC (MC z): slope n/a (plateau, N ≥ 128)"
        );
        assert_eq!(
            fit_label("MC", &flagged(-0.5, Some((-0.51, -0.49)))),
            "MC: slope −0.50 ± 0.01 (N ≥ 128)"
        );
        assert!(
            fit_label(
                "X",
                &SeriesFit::TooFew {
                    from_n: 64,
                    exact_at: vec![]
                }
            )
            .contains("no slope")
        );
    }
}

#[cfg(test)]
mod face_tests {
    use super::*;
    use crate::experiment::plan;

    fn plan_of(estimators: &str) -> plan::Plan {
        let text = format!(
            r#"{{"name": "x", "integrands": ["cos3"], "estimators": {estimators}, "samples": [4], "trials": 2, "seed": 1}}"#
        );
        plan::resolve(&plan::parse(&text).unwrap()).unwrap()
    }

    /// The same estimator has the same face whatever else the run compares, and the first
    /// four methods are told apart by colour, their other variants by colours of their own, the
    /// designs by marker, MC by its dashed line.
    #[test]
    fn an_estimator_keeps_its_face_across_runs() {
        let a = plan_of(r#"[{"label": "MC", "method": "mc"}, {"label": "BMC", "method": "bmc"}]"#);
        let b = plan_of(
            r#"[{"label": "BSQ", "method": "bsq"}, {"label": "BMC", "method": "bmc"},
                {"label": "BMC sobol", "method": "bmc", "design": "sobol"}, {"label": "MC", "method": "mc"},
                {"label": "BMCP", "method": "bmcp"}]"#,
        );
        let (fa, fb) = (faces(&a.estimators), faces(&b.estimators));
        assert_eq!(fa[0], fb[3]);
        assert_eq!(fa[1], fb[1]);
        assert!(fa[0].dashed && !fa[1].dashed);
        // BMC on Sobol points: a colour of its own (not BMC's), Sobol's marker.
        assert_eq!(fb[1].colour, 1);
        assert_ne!(fb[2].colour, fb[1].colour);
        assert_ne!(fb[2].marker, fb[1].marker);
        // MC, BMC, BMCP, BSQ.
        let colours: Vec<usize> = [3, 1, 4, 0].map(|i| fb[i].colour).to_vec();
        assert_eq!(colours, [0, 1, 2, 3]);
    }

    /// Estimators the rule would draw alike (a noise sweep) still differ, each by a colour of
    /// its own; another kernel gets a colour other than the method's.
    #[test]
    fn estimators_alike_are_told_apart() {
        let p = plan_of(
            r#"[{"label": "BMC a", "method": "bmc", "noise": 0.01}, {"label": "BMC b", "method": "bmc", "noise": 0.001},
                {"label": "BMC s", "method": "bmc", "kernel": {"type": "sobolev", "s": 2.75}}]"#,
        );
        let f = faces(&p.estimators);
        for i in 0..f.len() {
            for j in 0..i {
                assert_ne!((f[i].colour, f[i].marker), (f[j].colour, f[j].marker), "{i} {j}");
            }
        }
        assert_ne!(f[2].colour, 1);
    }
}
