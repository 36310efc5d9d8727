//! `rmse_vs_spp.svg` and its caption: mean RMSE against spp, log–log, one line per variant
//! (in its face, as an experiment's estimators: [`crate::plot::faces`]) at its true spp
//! with its 95% intervals as bars, a dashed spp^(−1/2) guide through MC, and a legend below the
//! chart. Variants that lie on an earlier one are drawn over it, the earlier one wider, and
//! named in the caption; nothing is moved off its spp.

use super::plan::{ReferencePlan, TablePlan};
use super::summary::Cell;
use crate::plot::{self as style, Axis, LegendEntry, SeriesStyle, Swatch};
use crate::render::integrator::IntegratorKind;
use plotters::prelude::*;

/// Height of the chart (axes and plotting area), between the title block and the legend.
const CHART_HEIGHT: u32 = 500;

/// Mean RMSE against spp, log–log, one line per variant, with the 95% intervals as bars.
pub fn plot_svg(plan: &TablePlan, cells: &[Cell]) -> crate::Result<style::Figure> {
    draw(plan, cells).map_err(|e| crate::Error::Encode(format!("drawing the RMSE plot: {e}")))
}

/// The variant the spp^(−1/2) guide goes through: uniform MC, else any MC variant.
fn guide_variant(plan: &TablePlan) -> Option<usize> {
    plan.variants
        .iter()
        .position(|v| v.kind == IntegratorKind::MC)
        .or_else(|| plan.variants.iter().position(|v| v.kind.method.is_monte_carlo()))
}

/// The caption's second line: what the RMSE is measured against.
pub fn reference_caption(plan: &TablePlan) -> String {
    match plan.reference {
        ReferencePlan::Exact { tolerance } => format!(
            "{}×{} renders against the exact reference (certified quadrature, every pixel to ±{tolerance:e})",
            plan.width, plan.height
        ),
        ReferencePlan::Mc { spp, .. } => format!(
            "{}×{} renders against a reference rendered with uniform MC at {spp} spp (its own noise is in every RMSE)",
            plan.width, plan.height
        ),
    }
}

/// What the plot shows, computed before drawing: each variant's cells in spp order, the
/// guide, and the axes.
struct Frame<'a> {
    per_variant: Vec<Vec<&'a Cell>>,
    guide: Option<(usize, Vec<(f64, f64)>)>,
    x: Axis,
    y: Axis,
}

/// Whether a cell's interval can stand on a log axis.
fn finite_interval(c: &Cell) -> bool {
    c.half_width.is_finite() && c.mean - c.half_width > 0.0
}

use style::on_log_axis as ok;

fn frame<'a>(plan: &TablePlan, cells: &'a [Cell]) -> Frame<'a> {
    let per_variant: Vec<Vec<&Cell>> = (0..plan.variants.len())
        .map(|v| {
            let mut s: Vec<&Cell> = cells.iter().filter(|c| c.variant == v).collect();
            s.sort_by_key(|c| c.spp);
            s
        })
        .collect();
    let x_min = *plan.spp.iter().min().expect("spp") as f64;
    let x_max = *plan.spp.iter().max().expect("spp") as f64;
    // Through the MC variant's first point.
    let guide = guide_variant(plan).and_then(|v| {
        let c = per_variant[v].iter().find(|c| ok(c.mean))?;
        let a = c.mean * (c.spp as f64).sqrt();
        Some((v, vec![(x_min, a / x_min.sqrt()), (x_max, a / x_max.sqrt())]))
    });
    let drawn: Vec<f64> = cells
        .iter()
        .flat_map(|c| {
            let mut v = vec![c.mean];
            if finite_interval(c) {
                v.extend([c.mean - c.half_width, c.mean + c.half_width]);
            }
            v
        })
        .filter(|&y| ok(y))
        .chain(guide.iter().flat_map(|g| g.1.iter().map(|p| p.1)))
        .collect();
    let (y0, y1) = style::padded_log_range(&drawn, 1.12);
    let (x0, x1) = style::padded_log_range(&[x_min, x_max], 1.12);
    Frame {
        per_variant,
        guide,
        x: Axis::counts(&plan.spp, (x0, x1), "samples per pixel (spp)"),
        y: Axis::log_values((y0, y1), RMSE_AXIS),
    }
}

/// What the y axis of a table's RMSE plot shows.
pub const RMSE_AXIS: &str = "RMSE against the reference (linear RGB)";

/// One legend entry per variant, in its face.
pub fn variant_entries(plan: &TablePlan) -> Vec<LegendEntry> {
    let faces = variant_faces(plan);
    plan.variants
        .iter()
        .enumerate()
        .map(|(v, variant)| LegendEntry::key(Swatch::Styled(faces[v]), variant.label.clone()))
        .collect()
}

/// Each variant's face: its method, its own model's kernel, its points' design
/// ([`crate::plot::faces::faces_of`]).
pub fn variant_faces(plan: &TablePlan) -> Vec<SeriesStyle> {
    let series: Vec<_> = plan
        .variants
        .iter()
        .map(|v| {
            let kernel = v.model.as_ref().and_then(|m| m.json.get("kernel"));
            (v.kind.method, kernel, v.kind.design())
        })
        .collect();
    crate::plot::faces::faces_of(&series)
}

/// The legend (one entry per variant, in its face, wider where a later one lies on it, the
/// guide, the bars) and the caption (what the points, bars and guide are; which variants coincide).
fn legend_and_caption(
    plan: &TablePlan,
    frame: &Frame,
    found: &style::Coincidences,
    coincident: Vec<String>,
) -> (Vec<LegendEntry>, Vec<String>) {
    let faces = variant_faces(plan);
    let mut legend: Vec<LegendEntry> = variant_entries(plan)
        .into_iter()
        .enumerate()
        .map(|(v, e)| LegendEntry::key(Swatch::Styled(found.style(v, faces[v])), e.text))
        .collect();
    if let Some((v, _)) = &frame.guide {
        legend.push(LegendEntry::key(
            Swatch::Guide,
            format!("∝ spp^(−1/2) through {}", plan.variants[*v].label),
        ));
    }
    legend.push(LegendEntry::key(Swatch::Bar, "95% interval of the mean RMSE"));
    let repetitions = plan
        .spp
        .iter()
        .zip(&plan.repetitions)
        .map(|(s, r)| format!("{r} at {s}"))
        .collect::<Vec<_>>()
        .join(", ");
    let mut caption = vec![format!(
        "Points: the mean RMSE of each variant at each spp, drawn at that spp; bars: its 95% Student-t \
         interval over the repetitions ({repetitions} spp). Variants share the spp values; their markers differ \
         in shape as well as colour."
    )];
    if let Some((v, _)) = &frame.guide {
        caption.push(format!(
            "Dashed grey line: ∝ spp^(−1/2), the Monte Carlo rate, through {}'s mean RMSE at its smallest spp.",
            plan.variants[*v].label
        ));
    }
    caption.extend(coincident);
    (legend, caption)
}

/// Every variant's bars, then its line and markers (so no bar hides a marker), all at the
/// variants' true spp, then the guide.
fn draw_variants<'s, X: style::F64Coord, Y: style::F64Coord>(
    chart: &mut style::Chart<'_, SVGBackend<'s>, X, Y>,
    root: &style::SvgArea<'s>,
    per_variant: &[Vec<&Cell>],
    found: &style::Coincidences,
    faces: &[SeriesStyle],
    guide: &Option<(usize, Vec<(f64, f64)>)>,
) -> style::FigureResult<()> {
    for (v, mine) in per_variant.iter().enumerate() {
        let bars = mine
            .iter()
            .filter(|c| finite_interval(c))
            .map(|c| (c.spp as f64, c.mean - c.half_width, c.mean + c.half_width));
        style::draw_bars(chart, faces[v].colour, bars)?;
    }
    for (v, points) in points_of(per_variant).iter().enumerate() {
        style::draw_styled_line(chart, root, found.style(v, faces[v]), points)?;
    }
    // Over the lines: it lies on MC's.
    if let Some((_, line)) = &guide {
        style::draw_guide(chart, line.clone())?;
    }
    Ok(())
}

/// Each variant's drawn points: `(spp, mean RMSE)` at its true spp, where the mean can stand on
/// the log axis.
fn points_of(per_variant: &[Vec<&Cell>]) -> Vec<Vec<(f64, f64)>> {
    per_variant
        .iter()
        .map(|mine| {
            mine.iter()
                .filter(|c| ok(c.mean))
                .map(|c| (c.spp as f64, c.mean))
                .collect()
        })
        .collect()
}

fn draw(plan: &TablePlan, cells: &[Cell]) -> style::FigureResult<style::Figure> {
    let frame = frame(plan, cells);
    let names: Vec<String> = plan.variants.iter().map(|v| v.label.clone()).collect();
    let to_px = style::log_px(frame.y.range, style::plot_height(CHART_HEIGHT));
    let found = style::coincidences(&names, &points_of(&frame.per_variant), &to_px, "spp");
    let mut coincident = found.notes.clone();
    if let Some((v, line)) = &frame.guide {
        let (x0, y0) = line[0];
        let on_guide = |x: f64| y0 * (x0 / x).sqrt();
        let mine = &points_of(&frame.per_variant)[*v];
        coincident.extend(style::guide_note(mine, on_guide, &to_px, &names[*v], "spp"));
    }
    let (legend, caption) = legend_and_caption(plan, &frame, &found, coincident);
    let faces = variant_faces(plan);
    style::svg_figure(
        &format!("{}: mean RMSE against samples per pixel", plan.title),
        &reference_caption(plan),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &frame.x, &frame.y)?;
            draw_variants(&mut chart, root, &frame.per_variant, &found, &faces, &frame.guide)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(variant: usize, spp: usize, mean: f64) -> Cell {
        Cell {
            external: None,
            variant,
            spp,
            n: 4,
            mean,
            sd: 0.01,
            half_width: 0.005,
            edges_mean: mean,
            edges_half_width: 0.005,
            coverage95: 0.95,
            coverage95_edges: 0.95,
            seconds: 1.0,
        }
    }

    /// Issue 22 item 7: every variant's points are drawn at their true spp (no side offsets),
    /// equal means included; the variants stay apart by line style and marker instead.
    #[test]
    fn points_sit_at_their_true_spp() {
        let cells = [
            cell(0, 20, 0.2),
            cell(1, 20, 0.2),
            cell(0, 40, 0.1),
            cell(1, 40, 0.1),
        ];
        let per_variant: Vec<Vec<&Cell>> = (0..2)
            .map(|v| cells.iter().filter(|c| c.variant == v).collect())
            .collect();
        let points = points_of(&per_variant);
        assert_eq!(points[0], [(20.0, 0.2), (40.0, 0.1)]);
        assert_eq!(points[1], points[0]);
        let found = style::coincidences(
            &["MC".into(), "BMC".into()],
            &points,
            style::log_px((0.05, 0.5), 400.0),
            "spp",
        );
        assert_eq!(
            (found.over.clone(), found.under.clone()),
            (vec![false, true], vec![1, 0])
        );
        assert!(
            found.notes[0].starts_with("BMC lies on MC at spp = 20, 40"),
            "{}",
            found.notes[0]
        );
        assert_ne!(
            found.style(0, SeriesStyle::of(0)),
            found.style(1, SeriesStyle::of(1))
        );
    }
}
