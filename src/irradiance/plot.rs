//! `rms_vs_n.svg`: RMS against N, log–log, one line per estimator, the published numbers
//! (SH L2, SH L4, SG) as dashed horizontal lines.

use super::{IrradiancePlan, Row};
use crate::plot::{self as style, Axis, LegendEntry, SeriesStyle, Swatch};

const CHART_HEIGHT: u32 = 500;

pub fn plot_svg(plan: &IrradiancePlan, rows: &[Row]) -> crate::Result<style::Figure> {
    draw(plan, rows).map_err(|e| crate::Error::Encode(format!("drawing the RMS plot: {e}")))
}

fn draw(plan: &IrradiancePlan, rows: &[Row]) -> style::FigureResult<style::Figure> {
    let ne = plan.estimators.len();
    let series: Vec<Vec<(f64, f64)>> = (0..ne)
        .map(|e| {
            let mut p: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.estimator == e && style::on_log_axis(r.rms))
                .map(|r| (r.n as f64, r.rms))
                .collect();
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            p
        })
        .collect();
    let published = plan.published_lines();
    let values: Vec<f64> = series
        .iter()
        .flatten()
        .map(|p| p.1)
        .chain(published.iter().map(|p| p.1))
        .collect();
    let (y0, y1) = style::padded_log_range(&values, 1.12);
    let (nmin, nmax) = (
        *plan.n.first().expect("n") as f64,
        *plan.n.last().expect("n") as f64,
    );
    let (x0, x1) = style::padded_log_range(&[nmin, nmax.max(nmin * 2.0)], 1.12);
    let x = Axis::counts(&plan.n, (x0, x1), "samples per normal N");
    let y = Axis::log_values((y0, y1), "RMS irradiance error over the grid");
    let pub_style = |k: usize| SeriesStyle {
        colour: ne + k,
        marker: ne + k,
        dashed: true,
        grow: 0,
    };
    let mut legend: Vec<LegendEntry> = plan
        .estimators
        .iter()
        .enumerate()
        .map(|(e, est)| LegendEntry::series(e, est.name.clone()))
        .collect();
    for (k, (name, v)) in published.iter().enumerate() {
        legend.push(LegendEntry::key(
            Swatch::Styled(pub_style(k)),
            format!("published {name}: {v}"),
        ));
    }
    let caption = vec![
        format!(
            "Points: each estimator's RMS over the {}×{} grid of normals at each N (one rule per N, rotated per normal), \
             against the exact irradiance (texel sum).",
            plan.width, plan.height
        ),
        "Dashed horizontal lines: the published RMS of other representations on the same map (Probulator), measured \
         against a 20 000-sample MC reference."
            .to_string(),
    ];
    style::svg_figure(
        &format!("{}: RMS against N", plan.title),
        &format!("{} under {}", "irradiance of every normal", plan.env_name),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &x, &y)?;
            for (k, (_, v)) in published.iter().enumerate() {
                style::draw_styled_line(&mut chart, root, pub_style(k), &[(x0, *v), (x1, *v)])?;
            }
            for (e, points) in series.iter().enumerate() {
                style::draw_styled_line(&mut chart, root, SeriesStyle::of(e), points)?;
            }
            Ok(())
        },
    )
}
