//! `rmse_vs_spp.svg`: mean RMSE against spp, log–log, one line per variant with its intervals.

use super::plan::TablePlan;
use super::summary::Cell;

/// Mean RMSE against spp, log–log, one line per variant, with the 95% intervals as bars.
pub fn plot_svg(plan: &TablePlan, cells: &[Cell]) -> crate::Result<String> {
    draw(plan, cells).map_err(|e| crate::Error::Encode(format!("drawing the RMSE plot: {e}")))
}

fn draw(plan: &TablePlan, cells: &[Cell]) -> Result<String, Box<dyn std::error::Error>> {
    use plotters::coord::combinators::BindKeyPoints;
    use plotters::prelude::*;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (820, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let lo = |c: &Cell| {
            if c.half_width.is_finite() {
                c.mean - c.half_width
            } else {
                c.mean
            }
        };
        let hi = |c: &Cell| {
            if c.half_width.is_finite() {
                c.mean + c.half_width
            } else {
                c.mean
            }
        };
        let y_min = cells
            .iter()
            .map(lo)
            .filter(|y| *y > 0.0)
            .fold(f64::INFINITY, f64::min);
        let y_max = cells.iter().map(hi).fold(0.0, f64::max);
        let x_min = *plan.spp.iter().min().expect("spp") as f64;
        let x_max = *plan.spp.iter().max().expect("spp") as f64;
        let (x0, x1) = if x_min < x_max {
            (x_min / 1.1, x_max * 1.1)
        } else {
            (x_min / 2.0, x_max * 2.0)
        };
        let (y0, y1) = if y_min < y_max {
            (y_min / 1.1, y_max * 1.1)
        } else {
            (y_min / 2.0, y_max.max(1e-12) * 2.0)
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "{}: RMSE against an MC {}-spp reference ({}×{})",
                    plan.name, plan.reference.spp, plan.width, plan.height
                ),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0..x1)
                    .log_scale()
                    .with_key_points(plan.spp.iter().map(|&s| s as f64).collect()),
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )?;
        chart
            .configure_mesh()
            .x_desc("samples per pixel (spp)")
            .y_desc("RMSE")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.3}"))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        for (v, variant) in plan.variants.iter().enumerate() {
            let colour = PALETTE[v % PALETTE.len()].to_rgba();
            let mine: Vec<&Cell> = cells.iter().filter(|c| c.variant == v).collect();
            let points: Vec<(f64, f64)> = mine.iter().map(|c| (c.spp as f64, c.mean)).collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?
                .label(variant.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
            chart.draw_series(mine.iter().filter(|c| c.half_width.is_finite()).map(|c| {
                // Bars side by side: a small per-variant offset in log x.
                let x = c.spp as f64 * (1.0 + 0.008 * (v as f64 - (plan.variants.len() - 1) as f64 / 2.0));
                PathElement::new(vec![(x, lo(c)), (x, hi(c))], colour.stroke_width(2))
            }))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}

/// Distinguishable line colours (Okabe–Ito, without the yellow that is unreadable on white).
const PALETTE: [plotters::style::RGBColor; 7] = [
    plotters::style::RGBColor(0, 0, 0),
    plotters::style::RGBColor(230, 159, 0),
    plotters::style::RGBColor(86, 180, 233),
    plotters::style::RGBColor(0, 158, 115),
    plotters::style::RGBColor(0, 114, 178),
    plotters::style::RGBColor(213, 94, 0),
    plotters::style::RGBColor(204, 121, 167),
];

/// Tick values `m·10^k`, `m ∈ {1, 1.5, 2, 3, 4, 5, 6, 8}`, inside `[lo, hi]` (`0 < lo < hi`).
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in [1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0] {
            let t = m * decade;
            if t >= lo && t <= hi {
                ticks.push(t);
            }
        }
        decade *= 10.0;
    }
    ticks
}
