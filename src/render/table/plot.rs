//! `rmse_vs_spp.svg`: mean RMSE against spp, log–log, one line per variant (distinct colour and
//! marker) with its 95% intervals as bars, a dashed spp^(−1/2) guide through MC, and a legend
//! below the chart that says what the bars and the reference are.

use super::plan::{ReferencePlan, TablePlan};
use super::summary::Cell;
use crate::plot::{self as style, Axis, LegendEntry, Swatch};
use crate::render::integrator::IntegratorKind;
use plotters::prelude::*;

/// Height of the chart (axes and plotting area), between the title block and the legend.
const CHART_HEIGHT: u32 = 500;

/// Mean RMSE against spp, log–log, one line per variant, with the 95% intervals as bars.
pub fn plot_svg(plan: &TablePlan, cells: &[Cell]) -> crate::Result<String> {
    draw(plan, cells).map_err(|e| crate::Error::Encode(format!("drawing the RMSE plot: {e}")))
}

/// The variant the spp^(−1/2) guide goes through: uniform MC, else any MC variant.
fn guide_variant(plan: &TablePlan) -> Option<usize> {
    plan.variants
        .iter()
        .position(|v| v.kind == IntegratorKind::MC)
        .or_else(|| plan.variants.iter().position(|v| v.kind.method.is_monte_carlo()))
}

/// The factor each variant's spp is drawn at: 1 ± k·step around the middle, the step 2%, less
/// with many variants so that the spread stays within ±6%.
fn dodge_factors(variants: usize) -> Vec<f64> {
    let step = 0.02f64.min(0.12 / variants.max(1) as f64);
    let middle = (variants as f64 - 1.0) / 2.0;
    (0..variants).map(|v| 1.0 + step * (v as f64 - middle)).collect()
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
/// side-by-side factors, the guide, and the axes.
struct Frame<'a> {
    per_variant: Vec<Vec<&'a Cell>>,
    dodge: Vec<f64>,
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
    let dodge = dodge_factors(plan.variants.len());
    // Drawn at the MC variant's shifted spp, so that it starts on MC's first point.
    let guide = guide_variant(plan).and_then(|v| {
        let c = per_variant[v].iter().find(|c| ok(c.mean))?;
        let a = c.mean * (c.spp as f64).sqrt();
        let d = dodge[v];
        Some((
            v,
            vec![(x_min * d, a / x_min.sqrt()), (x_max * d, a / x_max.sqrt())],
        ))
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
        dodge,
        guide,
        x: Axis::counts(&plan.spp, (x0, x1), "samples per pixel (spp)"),
        y: Axis::log_values((y0, y1), RMSE_AXIS),
    }
}

/// What the y axis of a table's RMSE plot shows.
pub const RMSE_AXIS: &str = "RMSE against the reference (linear RGB)";

/// One legend entry per variant, in its series' colour and marker.
pub fn variant_entries(plan: &TablePlan) -> Vec<LegendEntry> {
    plan.variants
        .iter()
        .enumerate()
        .map(|(v, variant)| LegendEntry::series(v, variant.label.clone()))
        .collect()
}

/// One entry per variant, the guide, and what the points and bars are.
fn legend(plan: &TablePlan, guide: &Option<(usize, Vec<(f64, f64)>)>) -> Vec<LegendEntry> {
    let mut legend = variant_entries(plan);
    if let Some((v, _)) = guide {
        legend.push(LegendEntry {
            swatch: Swatch::Guide,
            text: format!("∝ spp^(−1/2) through {}", plan.variants[*v].label),
            wide: false,
        });
    }
    let repetitions = plan
        .spp
        .iter()
        .zip(&plan.repetitions)
        .map(|(s, r)| format!("{r} at {s}"))
        .collect::<Vec<_>>()
        .join(", ");
    legend.push(LegendEntry::wide(
        Swatch::Bar,
        format!(
            "points: mean RMSE; bars: its 95% Student-t interval over the repetitions ({repetitions} spp); variants set side by side (spp × 1 ± {:.0}% at most) so that none hides another",
            100.0 * dodge_factors(plan.variants.len()).last().map_or(0.0, |d| d - 1.0)
        ),
    ));
    legend
}

/// The guide, then every variant's bars, then its line and markers (so no bar hides a marker).
fn draw_variants<'s, X: style::F64Coord, Y: style::F64Coord>(
    chart: &mut style::Chart<'_, SVGBackend<'s>, X, Y>,
    root: &style::SvgArea<'s>,
    per_variant: &[Vec<&Cell>],
    dodge: &[f64],
    guide: &Option<(usize, Vec<(f64, f64)>)>,
) -> style::FigureResult<()> {
    if let Some((_, line)) = &guide {
        style::draw_guide(chart, line.clone())?;
    }
    // Variants are set side by side — points, lines and bars shifted by a small factor in
    // spp — so that variants with equal RMSE (BMC and BMCP with the same sets) do not hide
    // each other's markers and intervals. The shift is at most ±6% and said in the legend.
    for (v, mine) in per_variant.iter().enumerate() {
        let bars = mine.iter().filter(|c| finite_interval(c)).map(|c| {
            (
                c.spp as f64 * dodge[v],
                c.mean - c.half_width,
                c.mean + c.half_width,
            )
        });
        style::draw_bars(chart, v, bars)?;
    }
    for (v, mine) in per_variant.iter().enumerate() {
        let points: Vec<(f64, f64)> = mine
            .iter()
            .filter(|c| ok(c.mean))
            .map(|c| (c.spp as f64 * dodge[v], c.mean))
            .collect();
        style::draw_line_with_markers(chart, root, v, &points)?;
    }
    Ok(())
}

fn draw(plan: &TablePlan, cells: &[Cell]) -> style::FigureResult<String> {
    let Frame {
        per_variant,
        dodge,
        guide,
        x,
        y,
    } = frame(plan, cells);
    let legend = legend(plan, &guide);
    style::svg_figure(
        &format!("{}: mean RMSE against samples per pixel", plan.name),
        &reference_caption(plan),
        CHART_HEIGHT,
        &legend,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &x, &y)?;
            draw_variants(&mut chart, root, &per_variant, &dodge, &guide)
        },
    )
}
