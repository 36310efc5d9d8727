//! Adaptive render tables (docs/guide/render.md, "Adaptive render tables"): with `"adaptive": {"target_sd": [...],
//! "max_spp": M}` every variant (mc, mc-cos, bmc) renders each target `T` by
//! [`crate::render::adaptive`], and the table reports per (variant, target) the mean RMSE with
//! its interval, the mean spp, the share of pixels meeting `T` and the share of pixel-channels
//! within `1.96 T` of the reference. Seconds go to the uncommitted `timings.*` files only.
//!
//! plan (validation) → runner → summary → export / plot; [`run`] writes them into the table's
//! [`ResultFolder`], beside the fixed-spp tables' reference cache and manifest.

pub mod export;
pub mod plan;
pub mod plot;
pub mod runner;
pub mod summary;

use crate::files::result_folder::ResultFolder;
use crate::render::adaptive::AdaptiveImage;
use crate::render::image::{ColourMap, ErrorScale, Image};
use crate::render::renderer::Renderer;
use crate::table::plan::{TablePlan, png_name};
use crate::util::report::Reporter;
use plan::AdaptivePlan;
use runner::AdaptiveRow;
use summary::AdaptiveCell;

/// `BMC 4 GP` at target 0.02 with `suffix` `-spp` → `bmc-4-gp-sd0.02-spp.png`.
pub fn adaptive_png_name(label: &str, target: f64, suffix: &str) -> String {
    png_name(label, 0).replace("-0spp.png", &format!("-sd{target}{suffix}.png"))
}

/// What an adaptive table produced: its cells and the Markdown shown on stdout.
pub struct AdaptiveReport {
    pub cells: Vec<AdaptiveCell>,
    pub table_md: String,
    pub times_md: String,
}

/// Renders the adaptive table's units that `keep` takes (saving each cell's first render into
/// `folder`) and returns their rows.
pub fn render(
    plan: &TablePlan,
    adaptive_plan: &AdaptivePlan,
    renderer: &Renderer,
    reference: &Image,
    folder: &mut ResultFolder,
    reporter: &dyn Reporter,
    keep: &dyn Fn(usize) -> bool,
) -> crate::Result<Vec<AdaptiveRow>> {
    let mut sink = super::FileSink {
        plan,
        folder,
        reference,
    };
    runner::run(
        plan,
        adaptive_plan,
        renderer,
        reference,
        &mut sink,
        reporter,
        keep,
    )
}

/// Writes the adaptive table's files from every render's row (not the manifest, nor the first
/// renders' images) into `folder`: what one run and a merge of shards share.
pub fn write_outputs(
    plan: &TablePlan,
    adaptive_plan: &AdaptivePlan,
    folder: &mut ResultFolder,
    rows: &[AdaptiveRow],
) -> crate::Result<AdaptiveReport> {
    let targets = &adaptive_plan.targets;
    let cells = summary::summarise(plan, targets, rows);
    folder.write(
        "rmse.csv",
        "one row per adaptive render",
        &export::rmse_csv(plan, rows),
    )?;
    folder.write(
        "table.csv",
        "per (variant, target sd): mean RMSE with its 95% Student-t interval, mean spp, share of pixels meeting the target, share of pixel-channels within 1.96·T",
        &export::table_csv(plan, &cells),
    )?;
    let stages = adaptive_plan.settings(1.0).stages;
    let stages = format!(
        "stages {} spp",
        stages
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let table_md = export::table_md(plan, targets, &cells, &stages);
    folder.write(
        "table.md",
        "table.csv as three Markdown grids",
        table_md.as_bytes(),
    )?;
    crate::plot::write_figure(
        folder,
        "rmse_vs_spp.svg",
        "mean RMSE against mean spp per target, log-log, with the intervals",
        &plot::plot_svg(plan, targets, &cells)?,
    )?;
    let times_md = export::times_md(plan, targets, &cells);
    super::write_timings(folder, &export::timings_csv(plan, rows), &times_md)?;
    Ok(AdaptiveReport {
        cells,
        table_md,
        times_md,
    })
}

/// Saves the first render of each cell (image, spp map, error image) and the rows so far: the
/// fixed-spp table's sink, fed adaptive renders.
impl runner::AdaptiveSink for super::FileSink<'_> {
    fn first_image(&mut self, variant: usize, target: f64, image: &AdaptiveImage) -> crate::Result<()> {
        let label = &self.plan.variants[variant].label;
        self.folder.write(
            &adaptive_png_name(label, target, ""),
            &format!("the first render of {label} at target sd {target}, tone-mapped"),
            &image.image.to_png()?,
        )?;
        let (map, black) = image.spp_as_norms();
        let max_spp = self.plan.adaptive.as_ref().map_or(1, |a| a.max_spp);
        self.folder.write(
            &adaptive_png_name(label, target, "-spp"),
            &format!("its samples per pixel, viridis from 0 to max_spp = {max_spp}"),
            &crate::render::image::scalar_png(
                &map.error_norms(&black),
                map.width,
                map.height,
                ErrorScale::Absolute,
                max_spp as f64,
                ColourMap::Viridis,
                crate::render::image::SPP_TITLE,
            )?
            .png,
        )?;
        super::write_error_png(
            self.folder,
            &adaptive_png_name(label, target, "-error"),
            "",
            &image.image,
            self.reference,
        )
    }

    fn round_done(&mut self, rows: &[AdaptiveRow]) -> crate::Result<()> {
        self.folder
            .write_partial("rmse.partial.csv", &export::rmse_csv(self.plan, rows))
    }
}
