//! One SVG per integrand, `<integrand>-cost.svg`: each estimator's mean absolute error against
//! its median wall-clock seconds per trial, log–log, one point per N — the equal-time comparison
//! ("is BMC worth it at equal time?"). An estimator below another at the same seconds is the
//! better buy. The median, not the mean, of the seconds: on a busy machine a preempted trial
//! takes milliseconds, which would swamp the mean of an estimator that needs microseconds.
//! Wall-clock, so machine-dependent: the file is written but never committed. Same
//! look as [`super::plot`].

use super::plan::Plan;
use super::summary::CellSummary;
use crate::plot_style::{self as style, LegendEntry, Swatch};
use plotters::prelude::*;

const CHART_HEIGHT: u32 = 560;
const Y_LABEL_AREA: u32 = 84;
const MARGIN_LEFT: u32 = 16;
const MARGIN_RIGHT: u32 = 28;

/// The SVG for integrand `fi` as a string.
pub fn cost_plot_svg(plan: &Plan, cells: &[CellSummary], fi: usize) -> crate::Result<String> {
    draw(plan, cells, fi).map_err(|e| crate::Error::Encode(format!("drawing the cost plot: {e}")))
}

/// Both coordinates positive and finite (a log axis cannot show 0: an exact estimator, or a
/// time below the clock's resolution).
fn drawable(c: &CellSummary) -> bool {
    let ok = |v: f64| v.is_finite() && v > 0.0;
    ok(c.median_seconds) && ok(c.mean_abs_error)
}

fn draw(plan: &Plan, cells: &[CellSummary], fi: usize) -> Result<String, Box<dyn std::error::Error>> {
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
    let (x0, x1) = style::padded_log_range(&xs, 1.5);
    let (y0, y1) = style::padded_log_range(&ys, 1.5);
    let (x_ticks, y_ticks) = (style::log_ticks(x0, x1), style::log_ticks(y0, y1));
    let (x_decimal, y_decimal) = (style::decimal_axis(x0, x1), style::decimal_axis(y0, y1));

    let mut legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .enumerate()
        .map(|(ei, e)| LegendEntry {
            swatch: Swatch::Series(ei),
            text: match (series[ei].first(), series[ei].last()) {
                (Some(a), Some(b)) => format!("{} (N = {} to {})", e.label, a.n, b.n),
                _ => format!("{} (not drawn: error or time 0)", e.label),
            },
            wide: false,
        })
        .collect();
    legend.push(LegendEntry {
        swatch: Swatch::Text,
        text: format!(
            "one point per N: mean |Î − I| over the {} trials against the median wall-clock seconds per trial \
             of the estimator alone (drawing its points, its weight set — shared sets counted in full for each \
             estimator — evaluating the integrand, combining); machine-dependent",
            plan.trials
        ),
        wide: true,
    });

    let height = style::HEADER_HEIGHT + CHART_HEIGHT + style::legend_height(&legend);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (style::WIDTH, height)).into_drawing_area();
        let (header, chart_area, legend_area) = style::layout(&root, CHART_HEIGHT)?;
        style::draw_header(
            &header,
            &format!("{}: error at equal cost", plan.title),
            &format!(
                "integrand {name}: mean absolute error against median seconds per trial; {} trials per N",
                plan.trials
            ),
        )?;
        let mut chart = ChartBuilder::on(&chart_area)
            .margin_left(MARGIN_LEFT)
            .margin_right(MARGIN_RIGHT)
            .margin_top(8)
            .x_label_area_size(52)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(x_ticks.labelled.clone()),
                (y0..y1).log_scale().with_key_points(y_ticks.labelled.clone()),
            )?;
        chart
            .configure_mesh()
            .x_desc("median wall-clock seconds per trial  [s]")
            .y_desc(format!("mean absolute error |Î − I| of ∫ {name} dω  [sr]"))
            .x_label_formatter(&|x| style::format_tick(*x, x_decimal))
            .y_label_formatter(&|y| style::format_tick(*y, y_decimal))
            .axis_desc_style((style::FONT, style::AXIS_FONT))
            .label_style((style::FONT, style::TICK_FONT))
            .bold_line_style(BLACK.mix(0.08))
            .light_line_style(TRANSPARENT)
            .set_all_tick_mark_size(6)
            .draw()?;
        style::chart_minor_ticks(&root, &chart, &x_ticks.minor, &y_ticks.minor, (x0, y0))?;
        for (ei, s) in series.iter().enumerate() {
            if s.is_empty() {
                continue;
            }
            let colour = style::colour(ei);
            let line: Vec<(f64, f64)> = s.iter().map(|c| (c.median_seconds, c.mean_abs_error)).collect();
            chart.draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))?;
            for p in line {
                let at = chart.backend_coord(&p);
                style::draw_marker(&root, ei, at, colour)?;
            }
        }
        style::draw_legend(&legend_area, &legend)?;
        root.present()?;
    }
    Ok(svg)
}
