//! The RMSE-against-spp table (thesis Table 4.1, Fig. 4.1b): every variant × spp × repetition
//! rendered and compared with a cached MC reference.
//!
//! Output layout under `<results>/<name>/`:
//!
//! - `rmse.csv` — stable raw data, one row per render (re-written after every render);
//! - `table.csv`, `table.md` — mean RMSE with its 95% Student-t interval, and mean seconds;
//! - `rmse_vs_spp.svg` — mean RMSE against spp, log–log, with the intervals;
//! - `<variant>-<spp>spp.png` — the first repetition of each cell, tone-mapped;
//! - `reference.png`, `manifest.json`.
//!
//! The reference lives in `<results>/cache/reference-<key>.exr`, `key` a hash of everything
//! that determines it (scene version, environment, size, spp, seed), so tables share it.

use super::cli::{progress_bar, warn_numerics};
use super::image::Image;
use super::integrator::Integrator;
use super::renderer::Renderer;
use super::spec::{TablePlan, VariantPlan};
use crate::io::write_atomic;
use crate::sampling::Design;
use anyhow::Context;
use indicatif::ProgressBar;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Version of the scene definition; part of the reference cache key.
pub const SCENE_VERSION: &str = "render-scene v1";

/// One render of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub variant: usize,
    pub spp: usize,
    pub repetition: usize,
    pub seed: u64,
    pub rmse: f64,
    pub seconds: f64,
}

/// Summary of one (variant, spp) cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub variant: usize,
    pub spp: usize,
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    /// Half-width of the 95% interval `t_{0.975, n−1} · sd / √n` (NaN for `n = 1`).
    pub half_width: f64,
    pub seconds: f64,
}

/// The seed of repetition `rep` at `spp`: the same for every variant (paired renders).
pub fn render_seed(seed: u64, spp: usize, rep: usize) -> u64 {
    crate::rng::mix(seed, &[spp as u64, rep as u64])
}

/// Runs the table and writes its outputs.
pub fn run(plan: &TablePlan, results: &Path, quiet: bool) -> anyhow::Result<()> {
    let out = output_dir(results, plan);
    // Fail on an unwritable folder now, not after the renders.
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let renderer = Renderer::new(plan.width, plan.height, plan.env.clone());

    let reference = reference(plan, &renderer, results, quiet)?;
    write_atomic(&out.join("reference.png"), &reference.to_png()?)?;
    write_atomic(&out.join("manifest.json"), &manifest(plan, results))?;

    let total: usize = plan.repetitions.iter().sum::<usize>() * plan.variants.len();
    let bar = progress_bar(quiet, "renders");
    bar.set_length(total as u64);
    let mut rows = Vec::with_capacity(total);
    for (&spp, &reps) in plan.spp.iter().zip(&plan.repetitions) {
        for rep in 0..reps {
            let seed = render_seed(plan.seed, spp, rep);
            for (v, variant) in plan.variants.iter().enumerate() {
                bar.set_message(format!("{} {spp} spp #{rep}", variant.label));
                let start = Instant::now();
                let integrator = Integrator::build(
                    variant.kind,
                    spp,
                    variant.gps,
                    variant.rotate,
                    plan.model.as_ref(),
                    seed,
                )?;
                if rep == 0 {
                    warn_numerics(&integrator);
                }
                let image = renderer.render(&integrator, seed, &ProgressBar::hidden());
                let seconds = start.elapsed().as_secs_f64();
                rows.push(Row {
                    variant: v,
                    spp,
                    repetition: rep,
                    seed,
                    rmse: image.rmse(&reference),
                    seconds,
                });
                if rep == 0 {
                    write_atomic(&out.join(png_name(&variant.label, spp)), &image.to_png()?)?;
                }
                bar.inc(1);
            }
            // After every round of variants, so an interrupted table keeps what it measured
            // (rewriting after every render made the I/O grow with the square of the renders).
            write_atomic(&out.join("rmse.csv"), &rmse_csv(plan, &rows)?)?;
        }
    }
    bar.finish_and_clear();

    let cells = summarise(plan, &rows);
    write_atomic(&out.join("table.csv"), &table_csv(plan, &cells)?)?;
    let md = table_md(plan, &cells);
    write_atomic(&out.join("table.md"), md.as_bytes())?;
    write_atomic(&out.join("rmse_vs_spp.svg"), plot_svg(plan, &cells)?.as_bytes())?;
    crate::io::stdout(&md)?;
    crate::status!("render: table → {}", out.display());
    Ok(())
}

/// The reference: read from the cache if present, else rendered (MC, uniform) and cached.
fn reference(plan: &TablePlan, renderer: &Renderer, results: &Path, quiet: bool) -> anyhow::Result<Image> {
    let (key, description) = reference_key(plan);
    let path = results.join("cache").join(format!("reference-{key}.exr"));
    if path.exists() {
        match Image::read(&path, "reference cache") {
            Ok(image) if (image.width, image.height) == (plan.width, plan.height) => {
                crate::status!("render: reference from cache {}", path.display());
                return Ok(image);
            }
            // A damaged cache entry is replaced, not fatal.
            Ok(_) => crate::status!(
                "warning: {} has the wrong size; rendering it again",
                path.display()
            ),
            Err(e) => crate::status!("warning: {e}; rendering it again"),
        }
    }
    let start = Instant::now();
    let bar = progress_bar(quiet, "rows (reference)");
    let image = renderer.render(
        &Integrator::mc(Design::Uniform, plan.reference.spp),
        plan.reference.seed,
        &bar,
    );
    bar.finish_and_clear();
    write_atomic(&path, &image.to_exr()?)?;
    write_atomic(&path.with_extension("json"), description.as_bytes())?;
    crate::status!(
        "render: reference (mc, {} spp) in {:.1} s → {}",
        plan.reference.spp,
        start.elapsed().as_secs_f64(),
        path.display()
    );
    // Use exactly what later tables will read back.
    Image::read(&path, "reference cache").map_err(Into::into)
}

/// `(key, description)`: the description lists everything that determines the reference image;
/// the key is its 64-bit FNV-1a hash in hex.
pub fn reference_key(plan: &TablePlan) -> (String, String) {
    let description = serde_json::to_string_pretty(&serde_json::json!({
        "scene": SCENE_VERSION,
        "env": plan.env.key(),
        "width": plan.width,
        "height": plan.height,
        "integrator": "mc",
        "spp": plan.reference.spp,
        "seed": plan.reference.seed,
    }))
    .expect("serialisable");
    (
        format!("{:016x}", crate::rng::label_id(&description)),
        description,
    )
}

fn manifest(plan: &TablePlan, results: &Path) -> Vec<u8> {
    let (key, _) = reference_key(plan);
    let variants: Vec<_> = plan
        .variants
        .iter()
        .map(
            |v| serde_json::json!({"label": v.label, "integrator": v.kind, "gps": v.gps, "rotate": v.rotate}),
        )
        .collect();
    let json = serde_json::json!({
        "spec": plan.file.display().to_string(),
        "scene": SCENE_VERSION,
        "seed": plan.seed,
        "width": plan.width,
        "height": plan.height,
        "env": plan.env_arg,
        "spp": plan.spp,
        "repetitions": plan.repetitions,
        "reference": {"integrator": "mc", "spp": plan.reference.spp, "seed": plan.reference.seed,
                      "cache": results.join("cache").join(format!("reference-{key}.exr")).display().to_string()},
        "model": plan.model_json,
        "variants": variants,
        "render_seed": "mix(seed, [spp, repetition]), the same for every variant",
    });
    let mut bytes = serde_json::to_vec_pretty(&json).expect("serialisable");
    bytes.push(b'\n');
    bytes
}

/// `BMC 4 GP (no rotation)` at 40 spp → `bmc-4-gp-no-rotation-40spp.png`.
pub fn png_name(label: &str, spp: usize) -> String {
    let mut slug = String::new();
    for c in label.chars() {
        if c.is_ascii_alphanumeric() {
            slug.push(c.to_ascii_lowercase());
        } else if !slug.ends_with('-') && !slug.is_empty() {
            slug.push('-');
        }
    }
    format!("{}-{spp}spp.png", slug.trim_end_matches('-'))
}

fn gps_field(v: &VariantPlan) -> String {
    if v.kind.uses_sets() {
        v.gps.to_string()
    } else {
        String::new()
    }
}

fn rotate_field(v: &VariantPlan) -> String {
    if v.kind.uses_sets() {
        v.rotate.to_string()
    } else {
        String::new()
    }
}

/// `variant,integrator,gps,rotate,spp,repetition,seed,rmse,seconds`; RMSE in Rust's shortest
/// round-trip form (exact, like the `run` CSVs), seconds (building the sets plus rendering, wall
/// clock) in `%.4f`.
pub fn rmse_csv(plan: &TablePlan, rows: &[Row]) -> anyhow::Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "variant",
        "integrator",
        "gps",
        "rotate",
        "spp",
        "repetition",
        "seed",
        "rmse",
        "seconds",
    ])?;
    for r in rows {
        let v = &plan.variants[r.variant];
        w.write_record([
            v.label.clone(),
            v.kind.name().into(),
            gps_field(v),
            rotate_field(v),
            r.spp.to_string(),
            r.repetition.to_string(),
            r.seed.to_string(),
            format!("{:?}", r.rmse),
            format!("{:.4}", r.seconds),
        ])?;
    }
    Ok(w.into_inner()?)
}

/// Mean, standard deviation and 95% Student-t half-width of the RMSE per (variant, spp), in
/// the order of the spec; a plain loop in row order.
pub fn summarise(plan: &TablePlan, rows: &[Row]) -> Vec<Cell> {
    use crate::stats::{mean, mean_ci95, sample_sd};
    let mut cells = Vec::new();
    for v in 0..plan.variants.len() {
        for &spp in &plan.spp {
            let cell: Vec<&Row> = rows.iter().filter(|r| r.variant == v && r.spp == spp).collect();
            if cell.is_empty() {
                continue;
            }
            let rmse: Vec<f64> = cell.iter().map(|r| r.rmse).collect();
            let seconds: Vec<f64> = cell.iter().map(|r| r.seconds).collect();
            // Both NaN for a single repetition, where neither is defined.
            let (lo, hi) = mean_ci95(&rmse);
            cells.push(Cell {
                variant: v,
                spp,
                n: rmse.len(),
                mean: mean(&rmse),
                sd: sample_sd(&rmse),
                half_width: 0.5 * (hi - lo),
                seconds: mean(&seconds),
            });
        }
    }
    cells
}

fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else {
        String::new()
    }
}

/// `variant,integrator,gps,rotate,spp,repetitions,rmse_mean,rmse_sd,rmse_ci95_low,rmse_ci95_high,seconds_mean`.
pub fn table_csv(plan: &TablePlan, cells: &[Cell]) -> anyhow::Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "variant",
        "integrator",
        "gps",
        "rotate",
        "spp",
        "repetitions",
        "rmse_mean",
        "rmse_sd",
        "rmse_ci95_low",
        "rmse_ci95_high",
        "seconds_mean",
    ])?;
    for c in cells {
        let v = &plan.variants[c.variant];
        w.write_record([
            v.label.clone(),
            v.kind.name().into(),
            gps_field(v),
            rotate_field(v),
            c.spp.to_string(),
            c.n.to_string(),
            num(c.mean),
            num(c.sd),
            num(c.mean - c.half_width),
            num(c.mean + c.half_width),
            format!("{:.4}", c.seconds),
        ])?;
    }
    Ok(w.into_inner()?)
}

/// The table in Markdown, laid out like the thesis's Table 4.1 (methods × spp), then the mean
/// time per image.
pub fn table_md(plan: &TablePlan, cells: &[Cell]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Mean RMSE (± half-width of the 95% Student-t interval) of {}×{} renders against an MC \
         reference with {} spp; repetitions per spp: {}.\n",
        plan.width,
        plan.height,
        plan.reference.spp,
        plan.spp
            .iter()
            .zip(&plan.repetitions)
            .map(|(s, r)| format!("{r} at {s}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let header = |s: &mut String, first: &str| {
        let _ = write!(s, "| {first} |");
        for spp in &plan.spp {
            let _ = write!(s, " {spp} spp |");
        }
        let _ = write!(s, "\n|---|");
        for _ in &plan.spp {
            let _ = write!(s, "---:|");
        }
        s.push('\n');
    };
    let cell = |v: usize, spp: usize| cells.iter().find(|c| c.variant == v && c.spp == spp);
    header(&mut s, "Method");
    for (v, variant) in plan.variants.iter().enumerate() {
        let _ = write!(s, "| {} |", variant.label);
        for &spp in &plan.spp {
            match cell(v, spp) {
                Some(c) if c.half_width.is_finite() => {
                    let _ = write!(s, " {:.5} ± {:.5} |", c.mean, c.half_width);
                }
                Some(c) => {
                    let _ = write!(s, " {:.5} |", c.mean);
                }
                None => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "\nMean time per image in seconds (building the sample sets plus rendering, wall clock):\n"
    );
    header(&mut s, "Method");
    for (v, variant) in plan.variants.iter().enumerate() {
        let _ = write!(s, "| {} |", variant.label);
        for &spp in &plan.spp {
            match cell(v, spp) {
                Some(c) => {
                    let _ = write!(s, " {:.3} |", c.seconds);
                }
                None => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
    s
}

/// Mean RMSE against spp, log–log, one line per variant, with the 95% intervals as bars.
pub fn plot_svg(plan: &TablePlan, cells: &[Cell]) -> anyhow::Result<String> {
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

/// Where `workbench render SPEC` puts its outputs.
pub fn output_dir(results: &Path, plan: &TablePlan) -> PathBuf {
    results.join(&plan.name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_names_are_slugs() {
        assert_eq!(
            png_name("BMC 4 GP (no rotation)", 40),
            "bmc-4-gp-no-rotation-40spp.png"
        );
        assert_eq!(png_name("MC", 20), "mc-20spp.png");
    }
}
