//! `rmse_vs_spp.svg` of an adaptive table: mean RMSE against the mean samples per pixel each
//! target took, log–log, one line per variant through its targets, with the 95% intervals as
//! bars (the plot style of [`crate::render::table::plot`]). Both axes are deterministic; seconds
//! are not drawn (they are machine-dependent, see `timings.md`).

use super::summary::AdaptiveCell;
use crate::plot_style::{self as style, LegendEntry, Swatch};
use crate::render::table::plan::TablePlan;
use crate::render::table::plot::reference_caption;
use plotters::prelude::*;

const CHART_HEIGHT: u32 = 500;
const Y_LABEL_AREA: u32 = 84;

/// Whether a value can stand on a log axis.
fn ok(y: f64) -> bool {
    y.is_finite() && y > 0.0
}

/// Mean RMSE against mean spp, one line per variant, its points the targets.
pub fn plot_svg(plan: &TablePlan, targets: &[f64], cells: &[AdaptiveCell]) -> crate::Result<String> {
    draw(plan, targets, cells)
        .map_err(|e| crate::Error::Encode(format!("drawing the adaptive RMSE plot: {e}")))
}

fn draw(
    plan: &TablePlan,
    targets: &[f64],
    cells: &[AdaptiveCell],
) -> Result<String, Box<dyn std::error::Error>> {
    let drawn: Vec<&AdaptiveCell> = cells.iter().filter(|c| ok(c.mean) && ok(c.mean_spp)).collect();
    let bars = |c: &AdaptiveCell| {
        (c.half_width.is_finite() && c.mean - c.half_width > 0.0)
            .then_some((c.mean - c.half_width, c.mean + c.half_width))
    };
    let ys: Vec<f64> = drawn
        .iter()
        .flat_map(|c| {
            let mut v = vec![c.mean];
            if let Some((lo, hi)) = bars(c) {
                v.extend([lo, hi]);
            }
            v
        })
        .collect();
    let xs: Vec<f64> = drawn.iter().map(|c| c.mean_spp).collect();
    let (y0, y1) = style::padded_log_range(&ys, 1.12);
    let (x0, x1) = style::padded_log_range(&xs, 1.15);
    // The stages label the x axis: the counts a pixel can stop at.
    let stages = plan
        .adaptive
        .as_ref()
        .map_or_else(Vec::new, |a| a.settings(1.0).stages);
    let plot_px = (style::WIDTH - 16 - 28 - Y_LABEL_AREA) as f64;
    let (x_ticks, y_ticks) = (
        style::count_ticks(&stages, x0, x1, plot_px),
        style::log_ticks(y0, y1),
    );
    let y_decimal = style::decimal_axis(y0, y1);

    let mut legend: Vec<LegendEntry> = plan
        .variants
        .iter()
        .enumerate()
        .map(|(v, variant)| LegendEntry {
            swatch: Swatch::Series(v),
            text: variant.label.clone(),
            wide: false,
        })
        .collect();
    let listed = targets
        .iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    legend.push(LegendEntry {
        swatch: Swatch::Bar,
        text: format!(
            "points: mean RMSE at each target sd T = {listed} (a smaller T takes more samples, further right); bars: \
             its 95% Student-t interval over the repetitions; x: mean samples per pixel the rule took"
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
            &format!(
                "{}: adaptive sampling, mean RMSE against mean samples per pixel",
                plan.name
            ),
            &reference_caption(plan),
        )?;
        let mut chart = ChartBuilder::on(&chart_area)
            .margin_left(16)
            .margin_right(28)
            .margin_top(8)
            .x_label_area_size(52)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(x_ticks.labelled.clone()),
                (y0..y1).log_scale().with_key_points(y_ticks.labelled.clone()),
            )?;
        chart
            .configure_mesh()
            .x_desc("mean samples per pixel (the stopping rule's choice; ticks at the stages)")
            .y_desc("RMSE against the reference (linear RGB)")
            .x_label_formatter(&|x| style::format_count(*x))
            .y_label_formatter(&|y| style::format_tick(*y, y_decimal))
            .axis_desc_style((style::FONT, style::AXIS_FONT))
            .label_style((style::FONT, style::TICK_FONT))
            .bold_line_style(BLACK.mix(0.08))
            .light_line_style(TRANSPARENT)
            .set_all_tick_mark_size(6)
            .draw()?;
        style::chart_minor_ticks(&root, &chart, &x_ticks.minor, &y_ticks.minor, (x0, y0))?;
        for v in 0..plan.variants.len() {
            let colour = style::colour(v);
            let mut mine: Vec<&&AdaptiveCell> = drawn.iter().filter(|c| c.variant == v).collect();
            mine.sort_by(|a, b| a.mean_spp.total_cmp(&b.mean_spp));
            chart.draw_series(mine.iter().filter_map(|c| {
                bars(c).map(|(lo, hi)| {
                    PathElement::new(vec![(c.mean_spp, lo), (c.mean_spp, hi)], colour.stroke_width(2))
                })
            }))?;
            let points: Vec<(f64, f64)> = mine.iter().map(|c| (c.mean_spp, c.mean)).collect();
            chart.draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?;
            for p in &points {
                style::draw_marker(&root, v, chart.backend_coord(p), colour)?;
            }
        }
        style::draw_legend(&legend_area, &legend)?;
        root.present()?;
    }
    Ok(svg)
}
