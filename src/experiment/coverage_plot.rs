//! One SVG per integrand, `<integrand>-coverage.svg`: each estimator's 95% coverage (the share
//! of trials whose interval holds the truth, math.md §7) against N, with the binomial 99% band
//! around 0.95 in which a calibrated estimator's coverage falls (the band of the calibration
//! check, [`super::summary::binomial_band`]). Same look as [`super::plot`].

use super::plan::Plan;
use super::summary::{CellSummary, binomial_band};
use crate::plot_style::{self as style, LegendEntry, Swatch};
use plotters::prelude::*;

const CHART_HEIGHT: u32 = 480;
const Y_LABEL_AREA: u32 = 84;
const MARGIN_LEFT: u32 = 16;
const MARGIN_RIGHT: u32 = 28;
/// The level the plot is about.
pub const LEVEL: f64 = 0.95;

/// The SVG for integrand `fi` as a string.
pub fn coverage_plot_svg(plan: &Plan, cells: &[CellSummary], fi: usize) -> crate::Result<String> {
    draw(plan, cells, fi).map_err(|e| crate::Error::Encode(format!("drawing the coverage plot: {e}")))
}

/// The legend label of an estimator: its label and, for methods with weights, the amplitude.
fn label(e: &super::plan::PlannedEstimator) -> String {
    match e.scale {
        Some(s) => format!("{} ({} scale)", e.label, s.name()),
        None => format!("{} (Student-t on the sample sd)", e.label),
    }
}

fn draw(plan: &Plan, cells: &[CellSummary], fi: usize) -> Result<String, Box<dyn std::error::Error>> {
    let integrand = &plan.integrands[fi];
    let name = integrand.display_name();
    let series: Vec<Vec<(usize, f64)>> = (0..plan.estimators.len())
        .map(|ei| {
            let mut s: Vec<(usize, f64)> = cells
                .iter()
                .filter(|c| c.integrand == fi && c.estimator == ei)
                .filter_map(|c| c.coverage.map(|cov| (c.n, cov[2])))
                .collect();
            s.sort_by_key(|p| p.0);
            s
        })
        .collect();
    let (band_lo, band_hi) = binomial_band(LEVEL, plan.trials);
    let lowest = series.iter().flatten().map(|p| p.1).fold(band_lo, f64::min);
    let y0 = (lowest - 0.05).max(0.0);
    let y1 = 1.02;
    let n_min = *plan.samples.iter().min().expect("samples") as f64;
    let n_max = *plan.samples.iter().max().expect("samples") as f64;
    let (x0, x1) = if n_min < n_max {
        (n_min / 1.25, n_max * 1.25)
    } else {
        (n_min / 2.0, n_max * 2.0)
    };
    let plot_px = (style::WIDTH - MARGIN_LEFT - MARGIN_RIGHT - Y_LABEL_AREA) as f64;
    let x_ticks = style::count_ticks(&plan.samples, x0, x1, plot_px);

    let mut legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .enumerate()
        .filter(|(ei, _)| !series[*ei].is_empty())
        .map(|(ei, e)| LegendEntry {
            swatch: Swatch::Series(ei),
            text: label(e),
            wide: false,
        })
        .collect();
    legend.push(LegendEntry {
        swatch: Swatch::Band,
        text: format!(
            "grey band: 99% binomial band around {LEVEL} for {} trials ({band_lo:.3}–{band_hi:.3}), \
             where a calibrated estimator's coverage falls; dashed line: {LEVEL}",
            plan.trials
        ),
        wide: true,
    });
    legend.push(LegendEntry {
        swatch: Swatch::Text,
        text: "coverage: share of trials whose 95% interval Î ± q·sd holds the truth (ml: Student-t; \
               unit, loo: normal; MC: Student-t with N − 1 dof on its standard error). Above the band: \
               intervals too wide; below: too narrow"
            .to_string(),
        wide: true,
    });

    let height = style::HEADER_HEIGHT + CHART_HEIGHT + style::legend_height(&legend);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (style::WIDTH, height)).into_drawing_area();
        let (header, chart_area, legend_area) = style::layout(&root, CHART_HEIGHT)?;
        style::draw_header(
            &header,
            &format!("{}: calibration", plan.title),
            &format!(
                "integrand {name}: 95% coverage against N; {} trials per N",
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
                y0..y1,
            )?;
        chart
            .configure_mesh()
            .x_desc("number of samples N")
            .y_desc("coverage of the 95% interval")
            .x_label_formatter(&|x| style::format_count(*x))
            .y_label_formatter(&|y| format!("{y:.2}"))
            .axis_desc_style((style::FONT, style::AXIS_FONT))
            .label_style((style::FONT, style::TICK_FONT))
            .bold_line_style(BLACK.mix(0.08))
            .light_line_style(TRANSPARENT)
            .set_all_tick_mark_size(6)
            .draw()?;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x0, band_lo.max(y0)), (x1, band_hi.min(y1))],
            style::GUIDE.mix(0.15).filled(),
        )))?;
        chart.draw_series(DashedLineSeries::new(
            vec![(x0, LEVEL), (x1, LEVEL)],
            8,
            5,
            style::GUIDE.stroke_width(2),
        ))?;
        for (ei, s) in series.iter().enumerate() {
            if s.is_empty() {
                continue;
            }
            let colour = style::colour(ei);
            let line: Vec<(f64, f64)> = s.iter().map(|&(n, c)| (n as f64, c)).collect();
            chart.draw_series(LineSeries::new(line, colour.stroke_width(2)))?;
            for &(n, c) in s {
                let at = chart.backend_coord(&(n as f64, c));
                style::draw_marker(&root, ei, at, colour)?;
            }
        }
        style::draw_legend(&legend_area, &legend)?;
        root.present()?;
    }
    Ok(svg)
}
