//! One SVG per integrand: absolute error against N on log–log axes (plotters).

use super::plan::Plan;
use super::summary::CellSummary;
use crate::stats::log_log_slope;
use plotters::prelude::*;

/// Okabe–Ito colours (distinguishable with colour-vision deficiencies).
const PALETTE: [RGBColor; 6] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

/// Smallest error drawn: exact estimates (error 0) would have no place on a log axis.
const FLOOR: f64 = 1e-16;

/// The SVG for integrand `fi` as a string.
pub fn error_plot_svg(plan: &Plan, cells: &[CellSummary], fi: usize) -> crate::Result<String> {
    draw(plan, cells, fi).map_err(|e| crate::Error::Encode(format!("drawing the error plot: {e}")))
}

fn draw(plan: &Plan, cells: &[CellSummary], fi: usize) -> Result<String, Box<dyn std::error::Error>> {
    let mine: Vec<&CellSummary> = cells.iter().filter(|c| c.integrand == fi).collect();
    let (n_min, n_max) = (
        *plan.samples.iter().min().expect("samples") as f64,
        *plan.samples.iter().max().expect("samples") as f64,
    );
    let lo = mine
        .iter()
        .map(|c| c.q10_abs_error.max(FLOOR))
        .fold(f64::INFINITY, f64::min);
    let hi = mine
        .iter()
        .map(|c| c.q90_abs_error.max(c.mean_abs_error).max(FLOOR))
        .fold(0.0, f64::max);
    let integrand = plan.integrands[fi].name();

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 640)).into_drawing_area();
        root.fill(&WHITE)?;
        let caption = format!("{} — {} ({} trials)", plan.title, integrand, plan.trials);
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (n_min / 1.25..n_max * 1.25)
                    .log_scale()
                    .with_key_points(plan.samples.iter().map(|&n| n as f64).collect::<Vec<_>>()),
                (lo / 2.0..hi * 2.0).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("number of samples N")
            .y_desc(format!("absolute error |Î − I| of ∫ {integrand} dω  [sr]"))
            .x_label_formatter(&|x| format!("{}", x.round()))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .axis_desc_style(("sans-serif", 17))
            .label_style(("sans-serif", 14))
            .light_line_style(WHITE.mix(0.0))
            .draw()?;

        for (ei, e) in plan.estimators.iter().enumerate() {
            let color = PALETTE[ei % PALETTE.len()];
            let row: Vec<&&CellSummary> = mine.iter().filter(|c| c.estimator == ei).collect();
            let mut band: Vec<(f64, f64)> = row
                .iter()
                .map(|c| (c.n as f64, c.q90_abs_error.max(FLOOR)))
                .collect();
            band.extend(row.iter().rev().map(|c| (c.n as f64, c.q10_abs_error.max(FLOOR))));
            chart.draw_series(std::iter::once(Polygon::new(band, color.mix(0.15).filled())))?;
            let points: Vec<(f64, f64)> = row
                .iter()
                .map(|c| (c.n as f64, c.mean_abs_error.max(FLOOR)))
                .collect();
            let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
            let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
            let slope = if points.len() >= 2 {
                log_log_slope(&xs, &ys)
            } else {
                f64::NAN
            };
            let label = format!("{} mean, 10–90% band (slope {slope:.2})", e.label);
            let anno = chart
                .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
                .label(label);
            // The legend sample: the line with the estimator's marker in the middle.
            let line = move |x: i32, y: i32| {
                EmptyElement::at((x, y)) + PathElement::new(vec![(0, 0), (24, 0)], color.stroke_width(3))
            };
            // A distinct marker per estimator (six kinds), so the series stay apart in grey print.
            let square_style = if ei % 6 == 4 {
                color.filled()
            } else {
                color.stroke_width(2)
            };
            match ei % 6 {
                0 => anno.legend(move |(x, y)| line(x, y) + Circle::new((12, 0), 4, color.filled())),
                1 => anno.legend(move |(x, y)| line(x, y) + TriangleMarker::new((12, 0), 6, color.filled())),
                2 => anno.legend(move |(x, y)| line(x, y) + Cross::new((12, 0), 5, color.stroke_width(2))),
                3 => anno.legend(move |(x, y)| line(x, y) + Circle::new((12, 0), 5, color.stroke_width(2))),
                _ => anno.legend(move |(x, y)| line(x, y) + Rectangle::new([(8, -4), (16, 4)], square_style)),
            };
            match ei % 6 {
                0 => chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))?,
                1 => chart.draw_series(points.iter().map(|&p| TriangleMarker::new(p, 6, color.filled())))?,
                2 => chart.draw_series(points.iter().map(|&p| Cross::new(p, 5, color.stroke_width(2))))?,
                3 => chart.draw_series(points.iter().map(|&p| Circle::new(p, 5, color.stroke_width(2))))?,
                _ => chart.draw_series(
                    points
                        .iter()
                        .map(|&p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], square_style)),
                )?,
            };
        }

        // Reference ∝ N^(−1/2), through the first estimator's mean error at the smallest N.
        if let Some(first) = mine.iter().find(|c| c.estimator == 0 && c.n as f64 == n_min) {
            let a = first.mean_abs_error.max(FLOOR) * n_min.sqrt();
            let grey = RGBColor(110, 110, 110);
            let line: Vec<(f64, f64)> = [n_min, n_max].iter().map(|&n| (n, a / n.sqrt())).collect();
            chart
                .draw_series(DashedLineSeries::new(line, 6, 4, grey.stroke_width(2)))?
                .label("reference ∝ N^(−1/2)")
                .legend(move |(x, y)| {
                    // Dashed, as in the plot.
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (7, 0)], grey.stroke_width(2))
                        + PathElement::new(vec![(11, 0), (18, 0)], grey.stroke_width(2))
                        + PathElement::new(vec![(22, 0), (24, 0)], grey.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 15))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}
