//! One SVG per integrand, `<integrand>-tolerance.svg`, for experiments with tolerance
//! estimators ([`crate::bq::stages`]): above, the mean number of points used against the tolerance; below,
//! the share of trials whose actual error is within the tolerance, with the binomial 99% band
//! around 0.95. Estimators that differ only in their tolerance (a sweep over `tolerance.abs`) form
//! one series per first stage N₀ (the experiment's sample counts): coloured by method (the
//! series' name), told apart by N₀ with a line style and a marker shape. Each `max_n` cap is a
//! dashed grey line on the upper chart. Same look as [`super::coverage_plot`].

use super::adaptive::Cell;
use super::plan::Plan;
use super::summary::binomial_band;
use crate::plot::{self as style, Axis, Labels, LegendEntry, SeriesStyle, Swatch};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

const CHART_HEIGHT: u32 = 760;
const LEVEL: f64 = 0.95;

/// One series: the estimators (same settings but the tolerance) and their name.
struct Series {
    name: String,
    /// The method's name (the series' name without its N₀).
    method: String,
    /// Its estimators' face ([`crate::plot::faces`]): its colour, and its marker at the first stage.
    face: SeriesStyle,
    /// The index of its first stage N₀ among the plot's, which picks line style and marker.
    stage: usize,
    /// `(tolerance, mean N used, share within)`, by tolerance.
    points: Vec<(f64, f64, f64)>,
    /// The `max_n` caps of its estimators.
    max_n: Vec<usize>,
}

/// The marker of method `m` at its `stage`-th first stage: the method's own shape first, then
/// open shapes (square, circle), white inside with a coloured edge, which show over a
/// same-coloured filled marker of the first stage where the two coincide.
fn stage_marker(m: usize, stage: usize) -> usize {
    match stage {
        0 => m,
        k => [6, 3][(k - 1) % 2],
    }
}

/// How series are drawn: the colour of their estimators' face ([`crate::plot::faces`]), and per
/// first stage a line style (solid, dashed, alternating) and a marker ([`stage_marker`]: the
/// face's at the first).
fn styles(series: &[Series]) -> Vec<SeriesStyle> {
    series
        .iter()
        .map(|s| SeriesStyle {
            colour: s.face.colour,
            marker: stage_marker(s.face.marker, s.stage),
            dashed: s.stage % 2 == 1,
            grow: 0,
        })
        .collect()
}

/// The figure (SVG and caption) for integrand `fi`, or None when it has no tolerance cell.
pub fn tolerance_plot_svg(plan: &Plan, cells: &[Cell], fi: usize) -> crate::Result<Option<style::Figure>> {
    if !cells.iter().any(|c| c.integrand == fi) {
        return Ok(None);
    }
    draw(plan, cells, fi)
        .map(Some)
        .map_err(|e| crate::Error::Encode(format!("drawing the tolerance plot: {e}")))
}

/// The series of integrand `fi`: one per group of estimators and first stage.
fn series(plan: &Plan, cells: &[Cell], fi: usize) -> Vec<Series> {
    let stages: Vec<usize> = {
        let mut v: Vec<usize> = cells.iter().map(|c| c.first_n).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let mut out = Vec::new();
    for (k, &n) in stages.iter().enumerate() {
        for mut s in series_at(plan, cells, fi, n) {
            s.stage = k;
            if stages.len() > 1 {
                s.name = format!("{}, N₀ = {n}", s.name);
            }
            out.push(s);
        }
    }
    out
}

/// The series of integrand `fi` at first stage `first_n`.
fn series_at(plan: &Plan, cells: &[Cell], fi: usize, first_n: usize) -> Vec<Series> {
    let mut keys: Vec<String> = Vec::new();
    let mut labels: Vec<Vec<String>> = Vec::new();
    let mut out: Vec<Series> = Vec::new();
    let faces = super::plot::faces(&plan.estimators);
    for c in cells.iter().filter(|c| c.integrand == fi && c.first_n == first_n) {
        let e = &plan.estimators[c.estimator];
        let mut settings = serde_json::to_value(&e.settings).expect("settings serialize");
        settings["tolerance"]["abs"] = serde_json::Value::Null;
        let key = settings.to_string();
        let i = match keys.iter().position(|k| *k == key) {
            Some(i) => i,
            None => {
                keys.push(key);
                labels.push(Vec::new());
                out.push(Series {
                    name: String::new(),
                    method: String::new(),
                    face: faces[c.estimator],
                    stage: 0,
                    points: Vec::new(),
                    max_n: Vec::new(),
                });
                keys.len() - 1
            }
        };
        labels[i].push(e.label.clone());
        out[i].points.push((c.tolerance.abs, c.mean_n_used, c.within));
        out[i].max_n.push(c.tolerance.max_n);
    }
    for (s, l) in out.iter_mut().zip(&labels) {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
        s.max_n.sort_unstable();
        s.max_n.dedup();
        s.name = common_name(l);
        s.method = s.name.clone();
    }
    out
}

/// The labels' common prefix without a trailing tolerance placeholder's text (`"BMC tol="`
/// → `"BMC"`); the label itself for a single estimator.
fn common_name(labels: &[String]) -> String {
    if labels.len() == 1 {
        return labels[0].clone();
    }
    let first: Vec<char> = labels[0].chars().collect();
    let mut len = first.len();
    for l in &labels[1..] {
        len = len.min(first.iter().zip(l.chars()).take_while(|(a, b)| **a == *b).count());
    }
    let prefix: String = first[..len].iter().collect();
    // The placeholder's value starts where the labels differ: drop its common digits too.
    let trimmed = prefix
        .trim_end_matches(|c: char| c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | '=' | ' ' | ':'));
    let trimmed = trimmed
        .strip_suffix("tolerance")
        .or_else(|| trimmed.strip_suffix("tol"))
        .unwrap_or(trimmed)
        .trim_end();
    if trimmed.is_empty() {
        labels[0].clone()
    } else {
        trimmed.to_string()
    }
}

fn draw(plan: &Plan, cells: &[Cell], fi: usize) -> style::FigureResult<style::Figure> {
    let integrand = &plan.integrands[fi];
    let series = series(plan, cells, fi);
    let styles = styles(&series);
    let caps: Vec<usize> = {
        let mut v: Vec<usize> = series.iter().flat_map(|s| s.max_n.iter().copied()).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let tolerances: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    let used: Vec<f64> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .chain(caps.iter().map(|&m| m as f64))
        .collect();
    let (x0, x1) = style::padded_log_range(&tolerances, 1.4);
    let (y0, y1) = style::padded_log_range(&used, 1.4);
    let x = Axis::log_values((x0, x1), "tolerance on the half-width");
    let used_axis = Axis {
        range: (y0, y1),
        ticks: style::log_ticks(y0, y1),
        desc: "mean N used".into(),
        labels: Labels::Count,
    };
    let (band_lo, band_hi) = binomial_band(LEVEL, plan.trials);
    let lowest = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.2))
        .fold(band_lo, f64::min);
    let share_axis = Axis::shares(((lowest - 0.05).max(0.0), 1.02), "share with |Î − I| ≤ tolerance");

    let mut legend: Vec<LegendEntry> = series
        .iter()
        .zip(&styles)
        .map(|(s, st)| LegendEntry::key(Swatch::Styled(*st), s.name.clone()))
        .collect();
    if !caps.is_empty() {
        legend.push(LegendEntry::key(Swatch::Guide, "max_n: the cap on N (above)"));
    }
    legend.push(LegendEntry::key(
        Swatch::Band,
        format!("99% binomial band around {LEVEL} (below)"),
    ));
    let mut caption = vec![
        format!(
            "Colour: the method; line style and marker shape: the first stage N₀ ({}). Above: the mean N a \
             trial used; each dashed grey line marks a max_n cap ({}), where trials stop whatever their half-width.",
            plan.samples
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(" or "),
            caps.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(", ")
        ),
        format!(
            "Grey band (below): the 99% binomial band around {LEVEL} for {} trials ({band_lo:.3}–{band_hi:.3}); \
             the within_tolerance check judges the share among the trials the rule stopped (stopping_summary.csv).",
            plan.trials
        ),
        format!(
            "Each trial starts at N₀ = {} (or its pilot min_n if larger) and doubles N (keeping its points) until \
             its half-width is at most the tolerance, never on zero evidence, or N would pass max_n; the rule sees \
             the interval, never the truth.",
            plan.samples
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        ),
    ];
    let names: Vec<String> = series.iter().map(|s| s.name.clone()).collect();
    let top_points: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| s.points.iter().map(|p| (p.0, p.1)).collect())
        .collect();
    let bottom_points: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| s.points.iter().map(|p| (p.0, p.2)).collect())
        .collect();
    let half = style::plot_height(CHART_HEIGHT / 2);
    let top_found = style::coincidences(&names, &top_points, style::log_px((y0, y1), half), "tolerance");
    let (s0, s1) = share_axis.range;
    let bottom_found = style::coincidences(
        &names,
        &bottom_points,
        move |v| (v - s0) / (s1 - s0) * half,
        "tolerance",
    );
    // The line style says N₀ already; a series with others on it, above or below, has larger
    // markers in both charts.
    let styles: Vec<SeriesStyle> = styles
        .iter()
        .enumerate()
        .map(|(i, st)| SeriesStyle {
            grow: top_found.under[i].max(bottom_found.under[i]),
            ..*st
        })
        .collect();
    caption.extend(top_found.notes.iter().map(|n| format!("Above: {n}")));
    caption.extend(bottom_found.notes.iter().map(|n| format!("Below: {n}")));

    style::svg_figure(
        &format!("{}: samples needed", plan.title),
        &format!(
            "integrand {}: samples used and share within the tolerance; {} trials per point",
            integrand.display_name(),
            plan.trials
        ),
        CHART_HEIGHT,
        &legend,
        &caption,
        |root, area| {
            let (upper, lower) = area.split_vertically(CHART_HEIGHT / 2);
            // Minor ticks on the log axes, as `log_log_chart` draws them: the tolerances sit
            // between the labelled decades.
            let mut top = style::chart_on(&upper, x.log_coord(), used_axis.log_coord())?;
            style::draw_mesh(&mut top, &x, &used_axis)?;
            style::chart_minor_ticks(
                root,
                &top,
                &x.ticks.minor,
                &used_axis.ticks.minor,
                (x.range.0, used_axis.range.0),
            )?;
            // The caps, labelled at their right end, under the series.
            for &cap in &caps {
                let m = cap as f64;
                style::draw_guide(&mut top, vec![(x.range.0, m), (x.range.1, m)])?;
                let (px, py) = top.backend_coord(&(x.range.1, m));
                root.draw(&Text::new(
                    format!("max_n = {cap}"),
                    (px - 6, py - 4),
                    (style::FONT, style::TICK_FONT)
                        .into_font()
                        .color(&style::GUIDE)
                        .pos(Pos::new(HPos::Right, VPos::Bottom)),
                ))?;
            }
            let mut bottom = style::chart_on(&lower, x.log_coord(), share_axis.linear_coord())?;
            style::draw_mesh(&mut bottom, &x, &share_axis)?;
            style::chart_minor_ticks(
                root,
                &bottom,
                &x.ticks.minor,
                &[],
                (x.range.0, share_axis.range.0),
            )?;
            style::draw_level_band(&mut bottom, x.range, share_axis.range, (band_lo, band_hi), LEVEL)?;
            for (i, s) in series.iter().enumerate() {
                let st = styles[i];
                let colour = style::colour(st.colour);
                let top_line: Vec<(f64, f64)> = s.points.iter().map(|p| (p.0, p.1)).collect();
                let bottom_line: Vec<(f64, f64)> = s.points.iter().map(|p| (p.0, p.2)).collect();
                if st.dashed {
                    top.draw_series(DashedLineSeries::new(top_line, 8, 5, colour.stroke_width(2)))?;
                    bottom.draw_series(DashedLineSeries::new(bottom_line, 8, 5, colour.stroke_width(2)))?;
                } else {
                    top.draw_series(LineSeries::new(top_line, colour.stroke_width(2)))?;
                    bottom.draw_series(LineSeries::new(bottom_line, colour.stroke_width(2)))?;
                }
                // Markers after both lines, top and bottom point by point (the figure's order).
                for p in &s.points {
                    style::draw_styled_marker(root, st, top.backend_coord(&(p.0, p.1)))?;
                    style::draw_styled_marker(root, st, bottom.backend_coord(&(p.0, p.2)))?;
                }
            }
            Ok(())
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(name: &str, stage: usize) -> Series {
        let method = if name == "MC" {
            crate::bq::estimator::Method::Mc
        } else {
            crate::bq::estimator::Method::Bmc
        };
        Series {
            name: format!("{name}, N₀ = {stage}"),
            method: name.into(),
            face: crate::plot::faces::faces_of(&[(method, None, crate::plot::faces::UNIFORM)])[0],
            stage,
            points: Vec::new(),
            max_n: Vec::new(),
        }
    }

    /// Issue 22 item 4: colour follows the method, not the (method, N₀) pair; N₀ changes the
    /// line style and the marker.
    #[test]
    fn series_are_coloured_by_method_and_told_apart_by_first_stage() {
        let s = [
            series("MC", 0),
            series("BMC", 0),
            series("MC", 1),
            series("BMC", 1),
        ];
        let st = styles(&s);
        assert_eq!(st.iter().map(|s| s.colour).collect::<Vec<_>>(), [0, 1, 0, 1]);
        assert_eq!(
            st.iter().map(|s| s.dashed).collect::<Vec<_>>(),
            [false, false, true, true]
        );
        assert_ne!(st[0].marker, st[2].marker);
        assert_ne!(st[1].marker, st[3].marker);
        // The later stage's markers are open shapes, visible over the first stage's.
        assert_eq!((st[2].marker, st[3].marker), (6, 6));
    }

    #[test]
    fn series_names_drop_the_tolerance_placeholder() {
        let l = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(common_name(&l(&["BMC tol=0.01", "BMC tol=0.001"])), "BMC");
        assert_eq!(common_name(&l(&["BMC tol=0.3", "BMC tol=0.1"])), "BMC");
        assert_eq!(common_name(&l(&["MC abs 0.3", "MC abs 0.1"])), "MC abs");
        assert_eq!(common_name(&l(&["only"])), "only");
    }
}
