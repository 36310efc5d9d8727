//! One SVG per integrand, `<integrand>-cost.svg`: each estimator's mean absolute error against
//! its median wall-clock seconds per trial, log–log, one point per N — the equal-time comparison
//! ("is BMC worth it at equal time?"). An estimator below another at the same seconds is the
//! better buy. Each point is labelled with its N; each estimator has its face ([`crate::plot::faces`]). The median, not the mean, of the seconds: on a busy machine a preempted trial
//! takes milliseconds, which would swamp the mean of an estimator that needs microseconds.
//! Wall-clock, so machine-dependent: the file is written but never committed. Same
//! look as [`super::plot`].

use super::plan::Plan;
use super::summary::CellSummary;
use crate::plot::{self as style, Axis, LegendEntry, Swatch};
use plotters::prelude::*;

const CHART_HEIGHT: u32 = 560;

/// The figure (SVG and caption) for integrand `fi`.
pub fn cost_plot_svg(plan: &Plan, cells: &[CellSummary], fi: usize) -> crate::Result<style::Figure> {
    draw(plan, cells, fi).map_err(|e| crate::Error::Encode(format!("drawing the cost plot: {e}")))
}

/// Both coordinates can stand on a log axis (not an exact estimator, nor a time below the
/// clock's resolution).
fn drawable(c: &CellSummary) -> bool {
    style::on_log_axis(c.median_seconds) && style::on_log_axis(c.mean_abs_error)
}

fn draw(plan: &Plan, cells: &[CellSummary], fi: usize) -> style::FigureResult<style::Figure> {
    let name = plan.integrands[fi].display_name();
    let series: Vec<Vec<&CellSummary>> = (0..plan.estimators.len())
        .map(|ei| {
            let mut s: Vec<&CellSummary> = cells
                .iter()
                .filter(|c| c.integrand == fi && c.estimator == ei && drawable(c))
                .collect();
            s.sort_by_key(|c| c.n);
            s
        })
        .collect();
    let xs: Vec<f64> = series.iter().flatten().map(|c| c.median_seconds).collect();
    let ys: Vec<f64> = series.iter().flatten().map(|c| c.mean_abs_error).collect();
    let x = Axis::log_values(
        style::padded_log_range(&xs, 1.5),
        "median wall-clock seconds per trial  [s]",
    );
    let y = Axis::log_values(
        style::padded_log_range(&ys, 1.5),
        super::plot::error_axis_label("mean absolute error |Î − I|"),
    );

    let faces = super::plot::faces(&plan.estimators);
    let legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .enumerate()
        .map(|(ei, e)| {
            LegendEntry::key(
                Swatch::Styled(faces[ei]),
                match (series[ei].first(), series[ei].last()) {
                    (Some(a), Some(b)) => format!("{} (N = {} to {})", e.label, a.n, b.n),
                    _ => format!("{} (not drawn: error or time 0)", e.label),
                },
            )
        })
        .collect();
    let caption = [format!(
        "One point per N: mean |Î − I| over the {} trials against the median wall-clock seconds per trial \
             of the estimator alone (drawing its points, its weight set — shared sets counted in full for each \
             estimator — evaluating the integrand, combining); machine-dependent. The number beside a point \
             is its N.",
        plan.trials
    )];

    style::svg_figure(
        &format!("{}: error at equal cost", plan.title),
        &format!(
            "integrand {name}: mean absolute error against median seconds per trial; {} trials per N",
            plan.trials
        ),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &x, &y)?;
            for (ei, s) in series.iter().enumerate() {
                if s.is_empty() {
                    continue;
                }
                let line: Vec<(f64, f64)> = s.iter().map(|c| (c.median_seconds, c.mean_abs_error)).collect();
                style::draw_styled_line(&mut chart, root, faces[ei], &line)?;
                // N beside each point, up and to the right of its marker, in the series' colour.
                let font = (style::FONT, style::TICK_FONT - 3)
                    .into_font()
                    .color(&style::colour(faces[ei].colour));
                for (c, p) in s.iter().zip(&line) {
                    let (px, py) = chart.backend_coord(p);
                    root.draw(&Text::new(format!("{}", c.n), (px + 7, py - 18), font.clone()))?;
                }
            }
            Ok(())
        },
    )
}
