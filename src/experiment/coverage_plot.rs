//! One SVG per integrand, `<integrand>-coverage.svg`: each estimator's 95% coverage (the share
//! of trials whose interval holds the truth, math.md §7) against N, with the binomial 99% band
//! around 0.95 in which a calibrated estimator's coverage falls (the band of the calibration
//! check, [`super::summary::binomial_band`]). Same look as [`super::plot`], whose rule puts a
//! tolerance estimator's points at the mean N it used ([`super::plot::drawn_n`]).

use super::adaptive::Cell as AdaptiveCell;
use super::plan::Plan;
use super::summary::{CellSummary, binomial_band};
use crate::plot::{self as style, Axis, LegendEntry, Swatch};

const CHART_HEIGHT: u32 = 480;
/// The level the plot is about.
pub const LEVEL: f64 = 0.95;

/// The figure (SVG and caption) for integrand `fi`; `used` as for
/// [`super::plot::error_plot_svg`].
pub fn coverage_plot_svg(
    plan: &Plan,
    cells: &[CellSummary],
    used: &[AdaptiveCell],
    fi: usize,
) -> crate::Result<style::Figure> {
    draw(plan, cells, used, fi).map_err(|e| crate::Error::Encode(format!("drawing the coverage plot: {e}")))
}

/// The legend label of an estimator: its label and, for methods with weights, the amplitude.
fn label(e: &super::plan::PlannedEstimator) -> String {
    match e.scale {
        Some(s) => format!("{} ({} scale)", e.label, s.name()),
        None => format!("{} (Student-t on the sample sd)", e.label),
    }
}

fn draw(
    plan: &Plan,
    cells: &[CellSummary],
    used: &[AdaptiveCell],
    fi: usize,
) -> style::FigureResult<style::Figure> {
    let integrand = &plan.integrands[fi];
    let name = integrand.display_name();
    let series: Vec<Vec<(f64, f64)>> = (0..plan.estimators.len())
        .map(|ei| {
            let mut s: Vec<(f64, f64)> = cells
                .iter()
                .filter(|c| c.integrand == fi && c.estimator == ei)
                .filter_map(|c| c.coverage.map(|cov| (super::plot::drawn_n(used, c), cov[2])))
                .collect();
            s.sort_by(|a, b| a.0.total_cmp(&b.0));
            s
        })
        .collect();
    let (band_lo, band_hi) = binomial_band(LEVEL, plan.trials);
    let lowest = series.iter().flatten().map(|p| p.1).fold(band_lo, f64::min);
    let y0 = (lowest - 0.05).max(0.0);
    let y1 = 1.02;
    // The grid's ends, or beyond them the N a tolerance estimator used.
    let n_min = series
        .iter()
        .flatten()
        .map(|p| p.0)
        .fold(*plan.samples.iter().min().expect("samples") as f64, f64::min);
    let n_max = series
        .iter()
        .flatten()
        .map(|p| p.0)
        .fold(*plan.samples.iter().max().expect("samples") as f64, f64::max);
    let (x0, x1) = if n_min < n_max {
        (n_min / 1.25, n_max * 1.25)
    } else {
        (n_min / 2.0, n_max * 2.0)
    };
    let x = super::plot::n_axis(&plan.samples, (x0, x1));
    let y = Axis::shares((y0, y1), "coverage of the 95% interval");

    let mut legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .enumerate()
        .filter(|(ei, _)| !series[*ei].is_empty())
        .map(|(ei, e)| LegendEntry::series(ei, label(e)))
        .collect();
    legend.push(LegendEntry::key(
        Swatch::Band,
        format!("99% binomial band around {LEVEL}"),
    ));
    // Series that lie on an earlier one are drawn over it, the earlier wider (and said so).
    let points: Vec<Vec<(f64, f64)>> = series.clone();
    let names: Vec<String> = plan.estimators.iter().map(|e| e.label.clone()).collect();
    let height = style::plot_height(CHART_HEIGHT);
    let to_px = move |v: f64| (v - y0) / (y1 - y0) * height;
    let found = style::coincidences(&names, &points, to_px, "N");
    let faces = super::plot::faces(&plan.estimators);
    for entry in legend.iter_mut() {
        if let Swatch::Series(ei) = entry.swatch {
            entry.swatch = Swatch::Styled(found.style(ei, faces[ei]));
        }
    }
    let coincident = found.notes.clone();
    let mut caption = vec![format!(
        "Grey band: the 99% binomial band around {LEVEL} for {} trials ({band_lo:.3}–{band_hi:.3}), \
             where a calibrated estimator's coverage falls; dashed grey line: {LEVEL}.",
        plan.trials
    )];
    caption.push(
        "Coverage: the share of trials whose 95% interval Î ± q·sd holds the truth (ml: Student-t; \
         unit, loo: normal; MC: Student-t with N − 1 dof on its standard error). Above the band: \
         intervals too wide; below: too narrow."
            .to_string(),
    );
    caption.extend(super::plot::tolerance_note(plan, |ei| !series[ei].is_empty()));
    caption.extend(coincident);

    style::svg_figure(
        &format!("{}: calibration", plan.title),
        &format!(
            "integrand {name}: 95% coverage against N; {} trials per N",
            plan.trials
        ),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::chart_on(area, x.log_coord(), y.linear_coord())?;
            style::draw_mesh(&mut chart, &x, &y)?;
            // The N grid's unlabelled values (a dense grid labels every s-th), as in the error plot.
            style::chart_minor_ticks(root, &chart, &x.ticks.minor, &[], (x.range.0, y.range.0))?;
            style::draw_level_band(&mut chart, x.range, y.range, (band_lo, band_hi), LEVEL)?;
            for (ei, s) in series.iter().enumerate() {
                if s.is_empty() {
                    continue;
                }
                style::draw_styled_line(&mut chart, root, found.style(ei, faces[ei]), &points[ei])?;
            }
            Ok(())
        },
    )
}
