//! `rmse_vs_spp.svg` of an adaptive table: mean RMSE against the mean samples per pixel each
//! target took, log–log, one line per variant through its targets, with the 95% intervals as
//! bars (the plot style of [`crate::table::plot`]). Both axes are deterministic; seconds
//! are not drawn (they are machine-dependent, see `timings.md`).

use super::summary::AdaptiveCell;
use crate::plot::{self as style, Axis, LegendEntry, Swatch};
use crate::table::plan::TablePlan;
use crate::table::plot::{RMSE_AXIS, reference_caption, variant_entries, variant_faces};

const CHART_HEIGHT: u32 = 500;

/// Mean RMSE against mean spp, one line per variant, its points the targets.
pub fn plot_svg(plan: &TablePlan, targets: &[f64], cells: &[AdaptiveCell]) -> crate::Result<style::Figure> {
    draw(plan, targets, cells)
        .map_err(|e| crate::Error::Encode(format!("drawing the adaptive RMSE plot: {e}")))
}

fn draw(plan: &TablePlan, targets: &[f64], cells: &[AdaptiveCell]) -> style::FigureResult<style::Figure> {
    let drawn: Vec<&AdaptiveCell> = cells
        .iter()
        .filter(|c| style::on_log_axis(c.mean) && style::on_log_axis(c.mean_spp))
        .collect();
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
    let x = Axis::counts(
        &stages,
        (x0, x1),
        "mean samples per pixel (the stopping rule's choice; ticks at the stages)",
    );
    let y = Axis::log_values((y0, y1), RMSE_AXIS);

    let mut legend = variant_entries(plan);
    let faces = variant_faces(plan);
    let listed = targets
        .iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    legend.push(LegendEntry::key(Swatch::Bar, "95% interval of the mean RMSE"));
    let caption = [format!(
        "Points: the mean RMSE at each target sd T = {listed} (a smaller T takes more samples, further right); bars: \
             its 95% Student-t interval over the repetitions; x: mean samples per pixel the rule took."
    )];
    style::svg_figure(
        &format!(
            "{}: adaptive sampling, mean RMSE against mean samples per pixel",
            plan.title
        ),
        &reference_caption(plan),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &x, &y)?;
            for (v, face) in faces.iter().enumerate() {
                let mut mine: Vec<&&AdaptiveCell> = drawn.iter().filter(|c| c.variant == v).collect();
                mine.sort_by(|a, b| a.mean_spp.total_cmp(&b.mean_spp));
                let intervals = mine
                    .iter()
                    .filter_map(|c| bars(c).map(|(lo, hi)| (c.mean_spp, lo, hi)));
                style::draw_bars(&mut chart, face.colour, intervals)?;
                let points: Vec<(f64, f64)> = mine.iter().map(|c| (c.mean_spp, c.mean)).collect();
                style::draw_styled_line(&mut chart, root, *face, &points)?;
            }
            Ok(())
        },
    )
}
