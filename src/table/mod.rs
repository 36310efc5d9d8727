//! The RMSE-against-spp table (thesis Table 4.1, Fig. 4.1b): every variant × spp × repetition
//! rendered and compared with a cached reference.
//!
//! spec (JSON) → [`plan::TablePlan`] (validated) → [`runner::run`] → [`summary`] →
//! [`export`] / [`plot`] (pure) → one set of files, under `<results>/<name>/`, that replaces
//! the folder as a whole when the table is done ([`ResultFolder`]):
//!
//! - `rmse.csv` — stable raw data, one row per render;
//! - `table.csv`, `table.md` — mean RMSE (whole image and at edges) with its 95% Student-t
//!   interval, and coverage95 of the stated intervals;
//! - `rmse_vs_spp.svg` — mean RMSE against spp, log–log, with the intervals;
//! - `<variant>-<spp>spp.png` — the first repetition of each cell, tone-mapped, and
//!   `<variant>-<spp>spp-error.png` its error image (absolute scale 0–0.25),
//!   `<variant>-<spp>spp-sd.png` the sd it states (the same scale) and
//!   `<variant>-<spp>spp-coverage.png` where its 95% intervals hold the reference;
//! - `reference.png`, `manifest.json` (which lists every file of the set);
//! - `timings.csv`, `timings.md`, `rmse-cost.svg` — wall-clock seconds, the equal-time
//!   comparison and RMSE against seconds (machine-dependent; not committed).
//!
//! With `"adaptive"` ([`adaptive`]) the columns are target sds instead of spp: the same
//! reference, folder, manifest and timings files, with `rmse.csv`, `table.*`, `rmse_vs_spp.svg`
//! (against mean spp) and per-cell PNGs (`<variant>-sd<T>.png`, `-spp.png`, `-error.png`) of
//! their own.
//!
//! While the table runs, `rounds.partial.csv` in the folder holds the rows of every finished
//! round ([`shard::Rounds`]), so an interrupted table keeps what it measured and `--resume`
//! continues it; the finished table's folder does not have it.

pub mod adaptive;
pub mod export;
pub mod external;
pub mod plan;
pub mod plot;
pub mod reference;
#[cfg(test)]
mod replot;
pub mod runner;
pub mod shard;
pub mod spec;
pub mod summary;

pub use plan::{TablePlan, VariantPlan, coverage_png_name, error_png_name, load, png_name, sd_png_name};
pub use reference::{SCENE_VERSION, reference_key};
pub use runner::{Row, render_seed};
pub use summary::Cell;

use crate::files::result_folder::ResultFolder;
use crate::render::image::Image;
use crate::render::renderer::Renderer;
use crate::render::uncertainty::{PixelSds, coverage_map_png};
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};

/// What a finished table produced, for the caller to show.
pub struct TableReport {
    pub out_dir: PathBuf,
    pub cells: Vec<Cell>,
    /// The cells of an adaptive table (empty otherwise, as `cells` is for an adaptive one).
    pub adaptive_cells: Vec<adaptive::summary::AdaptiveCell>,
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
/// `results/cache/`). Everything that can be refused is refused before the first render; the
/// folder changes only when every output is written (apart from `rounds.partial.csv`, the log of
/// every finished round, [`shard::Rounds`]). With `resume`, the rounds an interrupted run's log
/// holds are kept and only the others rendered (and again each cell's first render, for its
/// images): the same files, byte for byte, as an uninterrupted run (the `timings*` aside).
pub fn run(
    plan: &TablePlan,
    results: &Path,
    resume: bool,
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<TableReport> {
    let out = output_dir(results, plan);
    let mut folder = prepare_folder(
        plan,
        results,
        &out,
        &out.display().to_string(),
        &format!(
            "use another {} (or another \"name\" in the spec)",
            names.results_dir
        ),
    )?;
    let rounds = shard::Rounds::open(plan, &folder, crate::job::Shard::WHOLE, resume, names)?;
    let renderer = Renderer::for_scene(plan.scene, plan.width, plan.height, plan.env.clone());

    let reference = reference::reference(plan, &renderer, results, reporter)?;
    folder.write(
        "reference.png",
        "the reference image, tone-mapped",
        &reference.to_png()?,
    )?;
    let rendered = rounds.render(plan, &renderer, &reference, &mut folder, reporter)?;
    let (cells, adaptive_cells, table_md, times_md) = match (&rendered.rows, &plan.adaptive) {
        (shard::Rows::Fixed(rows), _) => {
            let (cells, md, times) = write_outputs(plan, &mut folder, &reference, rows)?;
            (cells, Vec::new(), md, times)
        }
        (shard::Rows::Adaptive(rows), Some(a)) => {
            let report = adaptive::write_outputs(plan, a, &mut folder, rows)?;
            (Vec::new(), report.cells, report.table_md, report.times_md)
        }
        (shard::Rows::Adaptive(_), None) => unreachable!("adaptive rows come from an adaptive plan"),
    };
    let manifest: serde_json::Value =
        serde_json::from_slice(&export::manifest(plan, results)).expect("the manifest is JSON");
    folder.commit(
        manifest,
        serde_json::json!({ "plan_hash": export::plan_hash(plan) }),
    )?;
    Ok(TableReport {
        out_dir: out,
        cells,
        adaptive_cells,
        table_md,
        times_md,
    })
}

/// Prepares the folder `out` of a table's run or shard (`what` and `hint` name it in a refusal):
/// it must not be, nor replace, one of the table's inputs (its file, its reference cache, its
/// map), and the cache's folder must be writable when the reference is still to be rendered —
/// the reference is written there after it is rendered: fail now, not then.
pub(crate) fn prepare_folder(
    plan: &TablePlan,
    results: &Path,
    out: &Path,
    what: &str,
    hint: &str,
) -> crate::Result<ResultFolder> {
    let cache = reference::cache_path(plan, results);
    let mut inputs: Vec<(&str, &Path)> = vec![
        ("the render-table file", &plan.file),
        ("the reference cache", &cache),
    ];
    if !matches!(plan.env_arg.as_str(), "sky" | "white") {
        inputs.push(("the environment map", Path::new(&plan.env_arg)));
    }
    let folder = ResultFolder::prepare(out, what, hint, &inputs, export::legacy_manifest_files)?;
    if !cache.exists() {
        crate::files::atomic::check_writable_dir(cache.parent().unwrap_or(results))?;
    }
    Ok(folder)
}

/// Writes a table's wall-clock files (machine-dependent; not committed): `timings.csv`, one row
/// per render, and `timings.md`, the mean seconds per image — for both kinds of table.
pub(crate) fn write_timings(folder: &mut ResultFolder, csv: &[u8], times_md: &str) -> crate::Result<()> {
    folder.write_local(
        "timings.csv",
        "wall-clock seconds per render (machine-dependent; not committed)",
        csv,
    )?;
    folder.write_local(
        "timings.md",
        "mean seconds per image (machine-dependent; not committed)",
        times_md.as_bytes(),
    )
}

/// Writes a fixed-spp table's files from every render's row (not the manifest, nor
/// `reference.png` and the first renders' images) into `folder`, and returns its cells,
/// `table.md` and the times in Markdown: what one run and a merge of shards share.
pub fn write_outputs(
    plan: &TablePlan,
    folder: &mut ResultFolder,
    reference: &Image,
    rows: &[Row],
) -> crate::Result<(Vec<Cell>, String, String)> {
    let cells = summary::summarise(plan, rows);
    folder.write("rmse.csv", "one row per render", &export::rmse_csv(plan, rows))?;
    folder.write(
        "table.csv",
        "mean RMSE per (variant, spp) with its 95% Student-t interval",
        &export::table_csv(plan, &cells),
    )?;
    let mut table_md = export::table_md(plan, &cells);
    if let Some(e) = &plan.external {
        table_md.push_str(&external::external_md(e, reference));
        folder.write(
            "external.csv",
            "images made elsewhere against their reference and this table's",
            &external::external_csv(e, reference),
        )?;
        folder.write(
            "their-reference.png",
            "the external reference, tone-mapped",
            &e.reference.to_png()?,
        )?;
        let (png, description) = reference_error_png(&e.reference, reference)?;
        folder.write("reference-vs-theirs-error.png", &description, &png)?;
        for i in &e.images {
            let name = plan::slug(&i.label);
            folder.write(
                &format!("theirs-{name}.png"),
                &format!("{}, tone-mapped", i.label),
                &i.image.to_png()?,
            )?;
            write_error_png(
                folder,
                &format!("theirs-{name}-error.png"),
                &format!(" ({} against this table's reference)", i.label),
                &i.image,
                reference,
            )?;
        }
    }
    folder.write(
        "table.md",
        "table.csv laid out like thesis Table 4.1",
        table_md.as_bytes(),
    )?;
    crate::plot::write_figure(
        folder,
        "rmse_vs_spp.svg",
        "mean RMSE against spp, log-log, with the intervals",
        &plot::plot_svg(plan, &cells)?,
    )?;
    let times_md = export::times_md(plan, &cells);
    write_timings(folder, &export::timings_csv(plan, rows), &times_md)?;
    Ok((cells, table_md, times_md))
}

/// Saves the first image of each cell (into the set) and the rows so far (into
/// `rmse.partial.csv`, which outlives an interrupted table), as the runner goes; for both the
/// fixed-spp and the adaptive tables ([`adaptive`]).
struct FileSink<'a> {
    plan: &'a TablePlan,
    folder: &'a mut ResultFolder,
    reference: &'a Image,
}

impl runner::TableSink for FileSink<'_> {
    fn first_image(
        &mut self,
        variant: usize,
        spp: usize,
        image: &Image,
        sds: &PixelSds,
    ) -> crate::Result<()> {
        use crate::render::image::{ColourMap, DEFAULT_ERROR_MAX, ErrorScale, SD_TITLE, scalar_png};
        let label = &self.plan.variants[variant].label;
        self.folder.write(
            &png_name(label, spp),
            &format!("the first render of {label} at {spp} spp, tone-mapped"),
            &image.to_png()?,
        )?;
        write_error_png(
            self.folder,
            &error_png_name(label, spp),
            " (thesis Fig. 3.14, 4.3)",
            image,
            self.reference,
        )?;
        // The sd it states, on the error image's scale, so that the two compare colour for
        // colour: where the error image is brighter than the sd image, the interval is too short.
        let sd = scalar_png(
            &sds.norms(),
            image.width,
            image.height,
            ErrorScale::Absolute,
            DEFAULT_ERROR_MAX,
            ColourMap::Viridis,
            SD_TITLE,
        )?;
        self.folder.write(
            &sd_png_name(label, spp),
            &format!(
                "the sd that render states per pixel (‖sd‖₂ over channels, 0–{DEFAULT_ERROR_MAX}, the error image's scale)"
            ),
            &sd.png,
        )?;
        self.folder.write(
            &coverage_png_name(label, spp),
            "where its 95% intervals hold the reference: light grey all three channels, orange one or two, red none",
            &coverage_map_png(image, self.reference, sds, 0.95)?,
        )
    }

    fn round_done(&mut self, rows: &[Row]) -> crate::Result<()> {
        self.folder
            .write_partial("rmse.partial.csv", &export::rmse_csv(self.plan, rows))
    }
}

/// Writes `image`'s error image against `reference` as `name`: `‖render − reference‖₂` per
/// pixel on the absolute scale up to [`crate::render::image::DEFAULT_ERROR_MAX`], viridis — what
/// both kinds of table save beside a cell's first render (`note` ends the description).
fn write_error_png(
    folder: &mut ResultFolder,
    name: &str,
    note: &str,
    image: &Image,
    reference: &Image,
) -> crate::Result<()> {
    use crate::render::image::{ColourMap, DEFAULT_ERROR_MAX, ErrorScale};
    let error = image.error_png(
        reference,
        ErrorScale::Absolute,
        DEFAULT_ERROR_MAX,
        ColourMap::Viridis,
    )?;
    folder.write(
        name,
        &format!("its error image: ‖render − reference‖₂ per pixel, 0–{DEFAULT_ERROR_MAX}{note}"),
        &error.png,
    )
}

/// `reference-vs-theirs-error.png` and its description: the external reference's error
/// against this table's, per pixel, on a *normalised* scale — 0 to its own largest error, the
/// colour bar's top — with that largest error stated in the description. Two references differ
/// by far less than a render's error, so on the renders' fixed scale
/// ([`crate::render::image::DEFAULT_ERROR_MAX`]) the image is all one dark colour
/// (issue 43 item 5); the renders' error images keep the fixed scale, to compare with each other.
pub fn reference_error_png(theirs: &Image, ours: &Image) -> crate::Result<(Vec<u8>, String)> {
    use crate::render::image::{ColourMap, DEFAULT_ERROR_MAX, ErrorScale, short_number};
    let error = theirs.error_png(
        ours,
        ErrorScale::Normalised,
        DEFAULT_ERROR_MAX,
        ColourMap::Viridis,
    )?;
    let (x, y) = error.max_at;
    let description = format!(
        "its error image: ‖their reference − this table's‖₂ per pixel on a normalised scale, 0 to its largest error \
         {} (at pixel ({x}, {y}); the colour bar's top), not the renders' fixed 0–{DEFAULT_ERROR_MAX}: the two references \
         differ by far less than a render's error",
        short_number(error.max_error)
    );
    Ok((error.png, description))
}

/// A human-readable account of a table plan (for `validate`), followed by the resolved JSON.
pub fn describe(plan: &TablePlan) -> String {
    let renders: usize = plan.repetitions.iter().sum::<usize>() * plan.variants.len();
    let columns = match &plan.adaptive {
        Some(a) => format!(
            "{} adaptive target sd(s) (stages {}…{} spp)",
            a.targets.len(),
            a.first_spp,
            a.max_spp
        ),
        None => format!("{} spp value(s)", plan.spp.len()),
    };
    let mut s = format!(
        "{}: {} variant(s) × {columns} = {renders} renders of {}×{} against {}\n",
        plan.name,
        plan.variants.len(),
        plan.width,
        plan.height,
        plan.reference.describe()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::image::viridis;

    /// Issue 43 item 5: two references 0.004 apart at most gave an image all of one dark colour
    /// on the renders' fixed 0–0.25 scale; normalised, the largest difference is the bar's top
    /// colour and the description states the scale and the largest error.
    #[test]
    fn the_reference_comparison_is_on_a_normalised_stated_scale() {
        let (w, h) = (8, 4);
        let ours = Image {
            width: w,
            height: h,
            data: vec![[0.5; 3]; w * h],
        };
        let mut theirs = ours.clone();
        for (i, p) in theirs.data.iter_mut().enumerate() {
            p[0] += 0.001 * (i % w) as f64 / (w - 1) as f64;
        }
        theirs.data[3 * w + 5][1] += 0.004;
        let (png, description) = reference_error_png(&theirs, &ours).unwrap();
        let img = ::image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(img.get_pixel(5, 3).0, viridis(1.0));
        assert_eq!(img.get_pixel(0, 0).0, viridis(0.0));
        assert!(
            description.contains("normalised scale, 0 to its largest error 0.00406"),
            "{description}"
        );
        assert!(description.contains("at pixel (5, 3)"), "{description}");
    }
}
