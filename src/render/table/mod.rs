//! The RMSE-against-spp table (thesis Table 4.1, Fig. 4.1b): every variant × spp × repetition
//! rendered and compared with a cached reference.
//!
//! spec (JSON) → [`plan::TablePlan`] (validated) → [`runner::run`] → [`summary`] →
//! [`export`] / [`plot`] (pure) → one atomic write per file, under `<results>/<name>/`:
//!
//! - `rmse.csv` — stable raw data, one row per render (re-written after every round);
//! - `table.csv`, `table.md` — mean RMSE with its 95% Student-t interval;
//! - `rmse_vs_spp.svg` — mean RMSE against spp, log–log, with the intervals;
//! - `<variant>-<spp>spp.png` — the first repetition of each cell, tone-mapped;
//! - `reference.png`, `manifest.json`;
//! - `timings.csv`, `timings.md` — wall-clock seconds (machine-dependent; not committed).

pub mod export;
pub mod plan;
pub mod plot;
pub mod reference;
pub mod runner;
pub mod spec;
pub mod summary;

pub use plan::{TablePlan, VariantPlan, load, png_name};
pub use reference::{SCENE_VERSION, reference_key};
pub use runner::{Row, render_seed};
pub use summary::Cell;

use crate::io::write_atomic;
use crate::render::image::Image;
use crate::render::renderer::Renderer;
use crate::report::Reporter;
use std::path::{Path, PathBuf};

/// What a finished table produced, for the caller to show.
pub struct TableReport {
    pub out_dir: PathBuf,
    pub cells: Vec<Cell>,
    /// `table.md`'s text.
    pub table_md: String,
    /// Mean seconds per image, in Markdown (also in `timings.md`).
    pub times_md: String,
}

/// Where `workbench render SPEC` puts its outputs.
pub fn output_dir(results: &Path, plan: &TablePlan) -> PathBuf {
    results.join(&plan.name)
}

/// Runs the table and writes its outputs under `results/<name>/` (the reference cache under
/// `results/cache/`).
pub fn run(plan: &TablePlan, results: &Path, reporter: &dyn Reporter) -> crate::Result<TableReport> {
    let out = output_dir(results, plan);
    // Fail on an unwritable folder now, not after the renders.
    crate::io::check_writable_dir(&out)?;
    let renderer = Renderer::new(plan.width, plan.height, plan.env.clone());

    let reference = reference::reference(plan, &renderer, results, reporter)?;
    write_atomic(&out.join("reference.png"), &reference.to_png()?)?;
    write_atomic(&out.join("manifest.json"), &export::manifest(plan, results))?;

    let mut sink = FileSink { plan, out: &out };
    let rows = runner::run(plan, &renderer, &reference, &mut sink, reporter)?;

    let cells = summary::summarise(plan, &rows);
    write_atomic(&out.join("table.csv"), &export::table_csv(plan, &cells))?;
    let table_md = export::table_md(plan, &cells);
    write_atomic(&out.join("table.md"), table_md.as_bytes())?;
    write_atomic(
        &out.join("rmse_vs_spp.svg"),
        plot::plot_svg(plan, &cells)?.as_bytes(),
    )?;
    let times_md = export::times_md(plan, &cells);
    write_atomic(&out.join("timings.csv"), &export::timings_csv(plan, &rows))?;
    write_atomic(&out.join("timings.md"), times_md.as_bytes())?;
    Ok(TableReport {
        out_dir: out,
        cells,
        table_md,
        times_md,
    })
}

/// Writes the first image of each cell and the rows so far, as the runner goes.
struct FileSink<'a> {
    plan: &'a TablePlan,
    out: &'a Path,
}

impl runner::TableSink for FileSink<'_> {
    fn first_image(&mut self, variant: usize, spp: usize, image: &Image) -> crate::Result<()> {
        let name = png_name(&self.plan.variants[variant].label, spp);
        write_atomic(&self.out.join(name), &image.to_png()?)
    }

    fn round_done(&mut self, rows: &[Row]) -> crate::Result<()> {
        write_atomic(&self.out.join("rmse.csv"), &export::rmse_csv(self.plan, rows))
    }
}

/// A human-readable account of a table plan (for `validate`), followed by the resolved JSON.
pub fn describe(plan: &TablePlan) -> String {
    let renders: usize = plan.repetitions.iter().sum::<usize>() * plan.variants.len();
    let mut s = format!(
        "{}: {} variant(s) × {} spp value(s) = {renders} renders of {}×{} against an MC reference with {} spp\n",
        plan.name,
        plan.variants.len(),
        plan.spp.len(),
        plan.width,
        plan.height,
        plan.reference.spp
    );
    let mut json: serde_json::Value =
        serde_json::from_slice(&export::manifest(plan, Path::new("results"))).expect("the manifest is JSON");
    if let Some(obj) = json.as_object_mut() {
        obj.remove("spec");
    }
    s += &serde_json::to_string_pretty(&json).expect("serialisable");
    s.push('\n');
    s
}
