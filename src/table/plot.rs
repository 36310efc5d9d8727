//! `rmse_vs_spp.svg` and its caption: mean RMSE against spp, log–log, one line per variant
//! (in its face, as an experiment's estimators: [`crate::plot::faces`]) at its true spp
//! with its 95% intervals as bars, a dashed spp^(−1/2) guide through MC, and a legend below the
//! chart. Nothing is moved off its spp. Variants whose points lie on an earlier one's at every
//! spp are merged: drawn once, named together in the legend, and the caption says so
//! ([`merge_heads`]); a variant that lies on an earlier one along part of the range only is drawn
//! over it, the earlier one wider, and named in the caption. A table of one spp has no rate
//! to draw: it is a dot chart instead ([`draw_dots`]), one row per variant, its mean RMSE as a
//! dot on a linear axis from 0 with its interval as a bar.

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

/// The values a figure draws of its cells, for its axis range: each mean and, where it is
/// finite, its interval's ends; values a log axis cannot show left out.
fn drawn_values(cells: &[Cell]) -> impl Iterator<Item = f64> + '_ {
    cells
        .iter()
        .flat_map(|c| {
            let mut v = vec![c.mean];
            if finite_interval(c) {
                v.extend([c.mean - c.half_width, c.mean + c.half_width]);
            }
            v
        })
        .filter(|&y| ok(y))
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
    let drawn: Vec<f64> = drawn_values(cells)
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

/// Per variant, the variant it is drawn as: itself, or the earlier variant (a group's first)
/// whose drawn points its own lie on, within [`style::COINCIDENT_PX`], at every one of at least
/// two spp (and which has no others). Such variants are one line on the plot, and a stated
/// merge says so better than lines drawn over one another (issue 43 item 5).
pub fn merge_heads(points: &[Vec<(f64, f64)>], to_px: impl Fn(f64) -> f64) -> Vec<usize> {
    let mut heads: Vec<usize> = Vec::with_capacity(points.len());
    for (j, mine) in points.iter().enumerate() {
        let same = |i: usize| {
            let theirs = &points[i];
            mine.len() >= 2
                && theirs.len() == mine.len()
                && style::coincident_at(theirs, mine, &to_px, style::COINCIDENT_PX).len() == mine.len()
        };
        let head = (0..j).find(|&i| heads[i] == i && same(i)).unwrap_or(j);
        heads.push(head);
    }
    heads
}

/// The legend name of the group drawn as variant `head`: its variants' labels joined by ` = `.
fn group_name(plan: &TablePlan, heads: &[usize], head: usize) -> String {
    (0..heads.len())
        .filter(|&v| heads[v] == head)
        .map(|v| plan.variants[v].label.as_str())
        .collect::<Vec<_>>()
        .join(" = ")
}

/// The caption's sentence for each merged group: who lies on whom, how close their means are,
/// and that the line, markers and bars drawn are the first's.
fn merge_notes(plan: &TablePlan, heads: &[usize], per_variant: &[Vec<&Cell>]) -> Vec<String> {
    let mut notes = Vec::new();
    for head in 0..heads.len() {
        let members: Vec<usize> = (0..heads.len())
            .filter(|&v| v != head && heads[v] == head)
            .collect();
        if members.is_empty() {
            continue;
        }
        let label = |v: usize| plan.variants[v].label.as_str();
        let names: Vec<&str> = members.iter().map(|&v| label(v)).collect();
        let spread = members
            .iter()
            .flat_map(|&v| per_variant[v].iter())
            .filter_map(|c| {
                let h = per_variant[head].iter().find(|h| h.spp == c.spp)?;
                Some((c.mean - h.mean).abs() / h.mean)
            })
            .fold(0.0, f64::max);
        notes.push(format!(
            "Merged: {} {} on {} at every spp (markers within {} px; means within {:.1}% of {}'s): drawn as one line in \
             {}'s face, with its bars, and named together in the legend; table.csv has each variant's numbers.",
            names.join(" and "),
            if names.len() == 1 { "lies" } else { "lie" },
            label(head),
            style::COINCIDENT_PX,
            100.0 * spread,
            label(head),
            label(head)
        ));
    }
    notes
}

/// The legend (one entry per drawn variant or merged group, in its face, wider where a later one
/// lies on it, the guide, the bars) and the caption (what the points, bars and guide are; which
/// variants are merged or coincide).
fn legend_and_caption(
    plan: &TablePlan,
    frame: &Frame,
    drawn: &[(usize, String, SeriesStyle)],
    coincident: Vec<String>,
) -> (Vec<LegendEntry>, Vec<String>) {
    let mut legend: Vec<LegendEntry> = drawn
        .iter()
        .map(|(_, name, face)| LegendEntry::key(Swatch::Styled(*face), name.clone()))
        .collect();
    if let Some((v, _)) = &frame.guide {
        legend.push(LegendEntry::key(
            Swatch::Guide,
            format!("∝ spp^(−1/2) through {}", plan.variants[*v].label),
        ));
    }
    legend.push(LegendEntry::key(Swatch::Bar, "95% interval of the mean RMSE"));
    let mut caption = vec![format!(
        "Points: the mean RMSE of each variant at each spp, drawn at that spp; bars: its 95% Student-t \
         interval over the repetitions ({}). Variants share the spp values; their markers differ \
         in shape as well as colour.",
        repetitions_text(plan)
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

/// `80 at 20, 40 at 40 spp`: the repetitions at each spp.
fn repetitions_text(plan: &TablePlan) -> String {
    let listed = plan
        .spp
        .iter()
        .zip(&plan.repetitions)
        .map(|(s, r)| format!("{r} at {s}"))
        .collect::<Vec<_>>()
        .join(", ");
    format!("{listed} spp")
}

/// The drawn variants' bars, then their lines and markers (so no bar hides a marker), all at
/// the variants' true spp, then the guide.
fn draw_variants<'s, X: style::F64Coord, Y: style::F64Coord>(
    chart: &mut style::Chart<'_, SVGBackend<'s>, X, Y>,
    root: &style::SvgArea<'s>,
    per_variant: &[Vec<&Cell>],
    drawn: &[(usize, String, SeriesStyle)],
    guide: &Option<(usize, Vec<(f64, f64)>)>,
) -> style::FigureResult<()> {
    for (v, _, face) in drawn {
        let bars = per_variant[*v]
            .iter()
            .filter(|c| finite_interval(c))
            .map(|c| (c.spp as f64, c.mean - c.half_width, c.mean + c.half_width));
        style::draw_bars(chart, face.colour, bars)?;
    }
    let points = points_of(per_variant);
    for (v, _, face) in drawn {
        style::draw_styled_line(chart, root, *face, &points[*v])?;
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
    if plan.spp.len() == 1 {
        return draw_dots(plan, cells);
    }
    let frame = frame(plan, cells);
    let to_px = style::log_px(frame.y.range, style::plot_height(CHART_HEIGHT));
    let points = points_of(&frame.per_variant);
    let heads = merge_heads(&points, &to_px);
    let shown: Vec<usize> = (0..heads.len()).filter(|&v| heads[v] == v).collect();
    let names: Vec<String> = shown.iter().map(|&v| group_name(plan, &heads, v)).collect();
    let shown_points: Vec<Vec<(f64, f64)>> = shown.iter().map(|&v| points[v].clone()).collect();
    let found = style::coincidences(&names, &shown_points, &to_px, "spp");
    let mut coincident = merge_notes(plan, &heads, &frame.per_variant);
    coincident.extend(found.notes.clone());
    if let Some((v, line)) = &frame.guide {
        let (x0, y0) = line[0];
        let on_guide = |x: f64| y0 * (x0 / x).sqrt();
        let label = &plan.variants[*v].label;
        coincident.extend(style::guide_note(&points[*v], on_guide, &to_px, label, "spp"));
    }
    let faces = variant_faces(plan);
    let drawn: Vec<(usize, String, SeriesStyle)> = shown
        .iter()
        .zip(names)
        .enumerate()
        .map(|(k, (&v, name))| (v, name, found.style(k, faces[v])))
        .collect();
    let (legend, caption) = legend_and_caption(plan, &frame, &drawn, coincident);
    style::svg_figure(
        &format!("{}: mean RMSE against samples per pixel", plan.title),
        &reference_caption(plan),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let mut chart = style::log_log_chart(root, area, &frame.x, &frame.y)?;
            draw_variants(&mut chart, root, &frame.per_variant, &drawn, &frame.guide)
        },
    )
}

/// Height in pixels of a dot chart's row.
const DOT_ROW: u32 = 34;

/// A table of one spp: a dot chart (Cleveland's), one row per variant in the table's order
/// top to bottom, labelled on the left with the variant's name; its mean RMSE a marker in its
/// face on a linear axis from 0, its 95% interval a bar in its colour. A chart against spp would be a
/// single column of points, one on another.
fn draw_dots(plan: &TablePlan, cells: &[Cell]) -> style::FigureResult<style::Figure> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let spp = plan.spp[0];
    let rows = plan.variants.len();
    let cell_of = |v: usize| cells.iter().find(|c| c.variant == v);
    let values: Vec<f64> = drawn_values(cells).collect();
    // A linear axis from 0, so that the bars' lengths compare as ratios (a log axis over the
    // narrow range of one spp holds one tick label or none).
    let x1 = 1.06 * values.iter().copied().fold(0.0, f64::max);
    let x1 = if x1 > 0.0 { x1 } else { 1.0 };
    let x0 = 0.0;
    let decimals = (-(x1 / 5.0).log10().floor()).max(0.0) as usize;
    let x = Axis {
        range: (x0, x1),
        ticks: style::Ticks::default(),
        desc: RMSE_AXIS.into(),
        labels: style::Labels::Fixed(decimals),
    };
    let faces = variant_faces(plan);
    let labels: Vec<&str> = plan.variants.iter().map(|v| v.label.as_str()).collect();
    let label_area = labels
        .iter()
        .map(|l| style::estimated_width(l, style::TICK_FONT as f64))
        .fold(0.0, f64::max)
        .ceil() as u32
        + 24;
    // The rows, and the chart's own margins: 8 px above, 52 px of x labels below.
    let chart_height = rows as u32 * DOT_ROW + 8 + 52;
    let legend = [LegendEntry::key(Swatch::Bar, "95% interval of the mean RMSE")];
    let caption = [format!(
        "One spp ({spp}), so a dot chart rather than a line against spp: one row per variant, in the table's order \
             top to bottom; the marker (in the variant's face) at its mean RMSE over the repetitions ({}), the bar its \
             95% Student-t interval. The RMSE axis is linear from 0, so lengths compare as ratios.",
        repetitions_text(plan)
    )];
    style::svg_figure(
        &format!("{}: mean RMSE at {spp} samples per pixel", plan.title),
        &reference_caption(plan),
        chart_height,
        &legend,
        &caption,
        |root, area| {
            let mut chart = ChartBuilder::on(area)
                .margin_left(style::MARGIN_LEFT)
                .margin_right(style::MARGIN_RIGHT)
                .margin_top(8)
                .x_label_area_size(52)
                .y_label_area_size(label_area)
                .build_cartesian_2d(x.linear_coord(), -0.5..rows as f64 - 0.5)?;
            let x_format = |v: &f64| x.labels.format(*v);
            chart
                .configure_mesh()
                .x_desc(x.desc.as_str())
                .x_label_formatter(&x_format)
                .axis_desc_style((style::FONT, style::AXIS_FONT))
                .label_style((style::FONT, style::TICK_FONT))
                .bold_line_style(BLACK.mix(0.08))
                .light_line_style(TRANSPARENT)
                .set_all_tick_mark_size(6)
                .disable_y_mesh()
                .y_labels(0)
                .draw()?;
            let font = (style::FONT, style::TICK_FONT)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Right, VPos::Center));
            for (v, label) in labels.iter().enumerate() {
                // The first variant on top.
                let row = (rows - 1 - v) as f64;
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x0, row), (x1, row)],
                    BLACK.mix(0.12).stroke_width(1),
                )))?;
                if let Some(c) = cell_of(v) {
                    let colour = style::colour(faces[v].colour);
                    if finite_interval(c) {
                        let (lo, hi) = (c.mean - c.half_width, c.mean + c.half_width);
                        chart.draw_series(std::iter::once(PathElement::new(
                            vec![(lo, row), (hi, row)],
                            colour.stroke_width(3),
                        )))?;
                    }
                    if ok(c.mean) {
                        style::draw_styled_marker(root, faces[v], chart.backend_coord(&(c.mean, row)))?;
                    }
                }
                let (left, y) = chart.backend_coord(&(x0, row));
                root.draw(&Text::new(label.to_string(), (left - 10, y), font.clone()))?;
            }
            Ok(())
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
            rays_per_pixel: spp as f64,
        }
    }

    fn plan_of(spp: &str, variants: &str) -> TablePlan {
        let text = format!(
            r#"{{ "name": "t", "seed": 1, "width": 8, "height": 6, "spp": {spp}, "repetitions": 4,
                 "reference": {{"spp": 32}}, "variants": {variants} }}"#
        );
        super::super::plan::parse(&text, std::path::Path::new("t.json")).unwrap()
    }

    const THREE: &str = r#"[ {"label": "MC", "integrator": "mc"}, {"label": "BMC", "integrator": "bmc", "gps": 1},
                             {"label": "BMCP", "integrator": "bmcp", "gps": 1} ]"#;

    /// The `<text>` contents of an SVG, each with its `y` attribute.
    fn texts(svg: &str) -> Vec<(String, f64)> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let y = t.split("y=\"").nth(1)?.split('"').next()?.parse().ok()?;
                let body = t.split_once('>')?.1.split("</text>").next()?;
                Some((body.trim().to_string(), y))
            })
            .collect()
    }

    /// Issue 43 item 5: a variant equal to an earlier one at every spp is merged into it: one
    /// legend entry names both, the caption says so, and it is not drawn a second time; one
    /// that differs stays its own series.
    #[test]
    fn variants_equal_at_every_spp_are_a_stated_merge() {
        let plan = plan_of("[20, 40, 80]", THREE);
        let mut cells = Vec::new();
        for (k, spp) in [20, 40, 80].into_iter().enumerate() {
            let mean = 0.1 / (1 << k) as f64;
            cells.push(cell(0, spp, 2.0 * mean));
            cells.push(cell(1, spp, mean));
            cells.push(cell(2, spp, mean * 1.001));
        }
        let figure = plot_svg(&plan, &cells).unwrap();
        let t = texts(&figure.svg);
        assert!(t.iter().any(|(s, _)| s == "BMC = BMCP"), "{t:?}");
        assert!(!t.iter().any(|(s, _)| s == "BMCP"), "{t:?}");
        assert!(t.iter().any(|(s, _)| s == "MC"));
        assert!(
            figure.caption.contains(
                "Merged: BMCP lies on BMC at every spp (markers within 4 px; means within 0.1% of BMC's)"
            ),
            "{}",
            figure.caption
        );
        assert!(!figure.caption.contains("drawn wider"), "{}", figure.caption);
        // Apart at one spp: no merge.
        cells[8].mean = 0.05;
        let figure = plot_svg(&plan, &cells).unwrap();
        assert!(!figure.caption.contains("Merged"), "{}", figure.caption);
        assert!(texts(&figure.svg).iter().any(|(s, _)| s == "BMCP"));
    }

    /// Issue 43 item 5: a table of one spp is a dot chart: each variant's name on its own row,
    /// left of the chart, above the x axis's tick labels (not only in a legend below), in the
    /// table's order top to bottom, each with its own marker at a different height.
    #[test]
    fn one_spp_is_a_dot_chart_by_variant() {
        let plan = plan_of("[30]", THREE);
        let cells = [cell(0, 30, 0.036), cell(1, 30, 0.026), cell(2, 30, 0.027)];
        let figure = plot_svg(&plan, &cells).unwrap();
        let t = texts(&figure.svg);
        let y_of = |label: &str| {
            t.iter()
                .find(|(s, _)| s == label)
                .unwrap_or_else(|| panic!("{label}: {t:?}"))
                .1
        };
        let lowest_tick = t
            .iter()
            .filter(|(s, _)| crate::plot::parse_tick(s).is_some())
            .map(|p| p.1)
            .fold(0.0, f64::max);
        let ys = [y_of("MC"), y_of("BMC"), y_of("BMCP")];
        assert!(ys[0] < ys[1] && ys[1] < ys[2], "{ys:?}");
        assert!(ys.iter().all(|&y| y < lowest_tick), "{ys:?} below {lowest_tick}");
        assert!(
            t.iter()
                .any(|(s, _)| s.contains("mean RMSE at 30 samples per pixel"))
        );
        assert!(
            !t.iter().any(|(s, _)| s.contains("samples per pixel (spp)")),
            "{t:?}"
        );
        assert!(figure.caption.contains("dot chart"), "{}", figure.caption);
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
