//! The table's files, serialised to bytes (pure; [`super::run`] writes them):
//!
//! - `rmse.csv` — stable raw data, one row per render;
//! - `table.csv`, `table.md` — mean RMSE with its 95% Student-t interval per cell;
//! - `manifest.json` — the resolved plan;
//! - `timings.csv`, `timings.md` — wall-clock seconds, machine-dependent and not committed.

use super::plan::{TablePlan, VariantPlan};
use super::reference::{cache_path, scene_version};
use super::runner::Row;
use super::summary::Cell;
use std::fmt::Write as _;
use std::path::Path;

/// Writing CSV into a `Vec` cannot fail.
const IN_MEMORY: &str = "writing CSV to memory";

/// The names a table's `manifest.json` accounts for beyond its `files`, or `None` if it is not
/// one (see [`crate::files::result_folder::LegacyManifest`]): the machine-dependent files
/// (`timings.*`), and for a manifest written before manifests listed their files every file of
/// its table (one PNG per variant and spp). Passed to
/// [`crate::files::result_folder::ResultFolder::prepare`].
pub fn legacy_manifest_files(manifest: &serde_json::Value) -> Option<Vec<String>> {
    use crate::files::result_folder::{MANIFEST, TIMINGS};
    manifest.get("scene")?;
    let mut names: Vec<String> = ["timings.csv", "timings.md", TIMINGS].map(String::from).into();
    if manifest.pointer(&format!("/files/{MANIFEST}")).is_none()
        && let (Some(variants), Some(spp)) = (
            manifest.get("variants").and_then(|v| v.as_array()),
            manifest.get("spp").and_then(|s| s.as_array()),
        )
    {
        names.extend(
            [
                "reference.png",
                "rmse.csv",
                "table.csv",
                "table.md",
                "rmse_vs_spp.svg",
                MANIFEST,
            ]
            .map(String::from),
        );
        for v in variants {
            let label = v.get("label")?.as_str()?;
            for s in spp {
                names.push(super::plan::png_name(label, s.as_u64()? as usize));
            }
        }
    }
    Some(names)
}

/// A hash (FNV-1a, 16 hex digits) of the table's resolved plan: its [`manifest`] without the
/// spec's path and the reference cache's, which name where it ran, not what. `timings.json`
/// records it, so that `reproduce` estimates a table's time only from the timings of the same
/// plan.
pub fn plan_hash(plan: &TablePlan) -> String {
    let mut v: serde_json::Value =
        serde_json::from_slice(&manifest(plan, Path::new(""))).expect("the manifest is JSON");
    if let Some(o) = v.as_object_mut() {
        o.remove("spec");
    }
    if let Some(o) = v.get_mut("reference").and_then(|r| r.as_object_mut()) {
        o.remove("cache");
    }
    let bytes = serde_json::to_vec(&v).expect("serialisable");
    crate::util::hash::fnv1a_hex(bytes)
}

/// `manifest.json`: the resolved plan, with the reference and how render seeds are derived.
pub fn manifest(plan: &TablePlan, results: &Path) -> Vec<u8> {
    let variants: Vec<_> = plan
        .variants
        .iter()
        .map(|v| {
            let mut j =
                serde_json::json!({"label": v.label, "integrator": v.kind, "gps": v.gps, "rotate": v.rotate});
            j["sd"] = if v.kind.uses_sets() {
                serde_json::json!({"scale": v.scale.name()})
            } else if v.kind.has_posterior() {
                "the posterior sd of its rule, amplitude fitted by ml to the pixel's values (bq-pss, math.md §11 (a)), Student-t".into()
            } else {
                "the standard error of the mean, Student-t with spp − 1 degrees of freedom".into()
            };
            if let Some(model) = &v.model {
                j["model"] = model.json.clone();
            }
            j
        })
        .collect();
    let mut reference_json = plan.reference.json(&plan.env);
    reference_json["cache"] = cache_path(plan, results).display().to_string().into();
    let json = serde_json::json!({
        "spec": plan.file.display().to_string(),
        "title": plan.title,
        "scene": scene_version(plan),
        "seed": plan.seed,
        "width": plan.width,
        "height": plan.height,
        "env": plan.env_arg,
        "spp": plan.spp,
        "repetitions": plan.repetitions,
        "reference": reference_json,
        "model": plan.model_json,
        "variants": variants,
        "render_seed": "mix(seed, [spp, repetition]), the same for every variant",
        "coverage95": "share of the hit pixels' channels with |render − reference| ≤ q·sd, q the 95% quantile of the variant's interval law",
        "edges": {
            "mask": "hit pixels with a 4-neighbour that is background, has a normal more than 30° away, or a relative depth jump above the tolerance",
            "depth_tolerance": crate::render::integrator::neighbours::EDGE_DEPTH_TOLERANCE,
            "bmcp_edge_normal_exponent": crate::render::integrator::neighbours::EDGE_NORMAL_EXPONENT,
        },
    });
    let mut json = json;
    if plan.scene != crate::render::SceneKind::Workbench {
        json["scene_name"] = plan.scene.name().into();
    }
    if let Some(e) = &plan.external {
        json["external"] = serde_json::json!({
            "reference": e.reference_arg,
            "images": e.images.iter().map(|i| serde_json::json!({"label": i.label, "image": i.arg})).collect::<Vec<_>>(),
            "measures": "rmse over pixels × channels; mean_l2 the mean over pixels of the per-pixel RGB L2 norm",
        });
    }
    if let crate::render::Environment::Map(m) = &plan.env
        && m.lookup_kind() != crate::render::env::Lookup::Mitsuba
    {
        json["lookup"] = m.lookup_kind().name().into();
    }
    if let Some(c) = plan.clamp {
        json["clamp"] = c.into();
    }
    if let Some(a) = &plan.adaptive {
        // An adaptive table's columns are its targets: no spp list, its own render seeds.
        if let Some(obj) = json.as_object_mut() {
            obj.remove("spp");
            obj.remove("coverage95");
        }
        json["adaptive"] = a.json();
        json["render_seed"] =
            "mix(seed, [0xada7ab, target_sd's f64 bits, repetition]), the same for every variant".into();
        json["within"] =
            "share of the hit pixels' channels with |render − reference| ≤ 1.96·target_sd".into();
    }
    let mut bytes = serde_json::to_vec_pretty(&json).expect("serialisable");
    bytes.push(b'\n');
    bytes
}

/// The columns that say which variant a row belongs to.
pub const VARIANT_COLUMNS: [&str; 4] = ["variant", "integrator", "gps", "rotate"];

/// A variant's label, integrator, and for integrators with weights its sets and rotation
/// (empty otherwise).
pub fn variant_fields(v: &VariantPlan) -> [String; 4] {
    let (gps, rotate) = if v.kind.uses_sets() {
        (v.gps.to_string(), v.rotate.to_string())
    } else if v.kind.takes_gps() {
        (v.gps.to_string(), String::new())
    } else {
        (String::new(), String::new())
    };
    [v.label.clone(), v.kind.name(), gps, rotate]
}

/// `rmse.csv`: `variant,integrator,gps,rotate,spp,repetition,seed,rmse,rmse_edges,coverage95,
/// coverage95_edges`, one row per render, numbers in Rust's shortest round-trip form (exact,
/// like the `run` CSVs).
pub fn rmse_csv(plan: &TablePlan, rows: &[Row]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let head = [
        "spp",
        "repetition",
        "seed",
        "rmse",
        "rmse_edges",
        "coverage95",
        "coverage95_edges",
    ];
    let external = plan.external.is_some();
    let more: &[&str] = if external { &EXTERNAL_ROW_COLUMNS } else { &[] };
    let rays: &[&str] = if plan.counts_rays() { &[RAYS_COLUMN] } else { &[] };
    w.write_record(VARIANT_COLUMNS.iter().chain(&head).chain(more).chain(rays))
        .expect(IN_MEMORY);
    for r in rows {
        let mut rest = vec![
            r.spp.to_string(),
            r.repetition.to_string(),
            r.seed.to_string(),
            format!("{:?}", r.rmse),
            num(r.rmse_edges),
            num(r.coverage95),
            num(r.coverage95_edges),
        ];
        if let Some(m) = &r.external {
            rest.extend([m.rmse_theirs, m.mean_l2_theirs, m.mean_l2_ours].map(num));
        }
        if plan.counts_rays() {
            rest.push(num(r.rays_per_pixel));
        }
        w.write_record(variant_fields(&plan.variants[r.variant]).iter().chain(&rest))
            .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

/// The column `rmse.csv` gains (after any external ones) in a table with a renderer's baseline
/// ([`TablePlan::counts_rays`]): the mean shadow rays traced per hit pixel.
pub const RAYS_COLUMN: &str = "rays_per_pixel";

/// The columns `rmse.csv` gains in a table with `"external"`: each render's RMSE and mean
/// per-pixel L2 against the external reference, and its mean L2 against the table's.
pub const EXTERNAL_ROW_COLUMNS: [&str; 3] = ["rmse_theirs", "mean_l2_theirs", "mean_l2"];

/// The columns `table.csv` gains in a table with `"external"`: the variant's model (kernel,
/// noise, kernel means; empty for MC) and the means of [`EXTERNAL_ROW_COLUMNS`].
pub const EXTERNAL_CELL_COLUMNS: [&str; 4] =
    ["model", "rmse_theirs_mean", "mean_l2_theirs_mean", "mean_l2_mean"];

/// A variant's resolved model as compact JSON (its own, or the table's), empty without weights.
fn model_field(plan: &TablePlan, v: &VariantPlan) -> String {
    if !v.kind.uses_sets() {
        return String::new();
    }
    let json = v.model.as_ref().map(|m| &m.json).unwrap_or(&plan.model_json);
    serde_json::to_string(json).expect("serialisable")
}

/// `x` in Rust's shortest round-trip form, empty when not finite.
pub fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else {
        String::new()
    }
}

/// `table.csv`: `variant,integrator,gps,rotate,spp,repetitions,rmse_mean,rmse_sd,rmse_ci95_low,
/// rmse_ci95_high,rmse_edges_mean,rmse_edges_ci95_low,rmse_edges_ci95_high,coverage95,
/// coverage95_edges` per (variant, spp), the intervals from Student's t (empty for one
/// repetition), the coverages the mean over the renders.
pub fn table_csv(plan: &TablePlan, cells: &[Cell]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let head = [
        "spp",
        "repetitions",
        "rmse_mean",
        "rmse_sd",
        "rmse_ci95_low",
        "rmse_ci95_high",
        "rmse_edges_mean",
        "rmse_edges_ci95_low",
        "rmse_edges_ci95_high",
        "coverage95",
        "coverage95_edges",
    ];
    let more: &[&str] = if plan.external.is_some() {
        &EXTERNAL_CELL_COLUMNS
    } else {
        &[]
    };
    w.write_record(VARIANT_COLUMNS.iter().chain(&head).chain(more))
        .expect(IN_MEMORY);
    for c in cells {
        let mut rest = vec![
            c.spp.to_string(),
            c.n.to_string(),
            num(c.mean),
            num(c.sd),
            num(c.mean - c.half_width),
            num(c.mean + c.half_width),
            num(c.edges_mean),
            num(c.edges_mean - c.edges_half_width),
            num(c.edges_mean + c.edges_half_width),
            num(c.coverage95),
            num(c.coverage95_edges),
        ];
        if let Some(m) = &c.external {
            rest.push(model_field(plan, &plan.variants[c.variant]));
            rest.extend(m.map(num));
        }
        w.write_record(variant_fields(&plan.variants[c.variant]).iter().chain(&rest))
            .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

pub fn table_md(plan: &TablePlan, cells: &[Cell]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Mean RMSE (± half-width of the 95% Student-t interval) of {}×{} renders against {}; \
         repetitions per spp: {}.\n",
        plan.width,
        plan.height,
        plan.reference.describe(),
        plan.spp
            .iter()
            .zip(&plan.repetitions)
            .map(|(s, r)| format!("{r} at {s}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    md_grid(plan, cells, &mut s, |c| mean_pm(c.mean, c.half_width));
    let _ = writeln!(
        s,
        "\nMean RMSE at edges (pixels with a 4-neighbour on another surface or the background):\n"
    );
    md_grid(plan, cells, &mut s, |c| mean_pm(c.edges_mean, c.edges_half_width));
    let _ = writeln!(
        s,
        "\nCoverage95, whole image / edges: share of pixel-channels whose 95% interval holds the \
         reference (posterior sd for BMC-type variants, Student-t standard error for MC):\n"
    );
    md_grid(plan, cells, &mut s, |c| {
        format!("{:.3} / {:.3}", c.coverage95, c.coverage95_edges)
    });
    if plan.counts_rays() {
        let _ = writeln!(
            s,
            "\nShadow rays traced per hit pixel (mean over the renders; light samples below the \
             horizon or where the light is black trace none):\n"
        );
        md_grid(plan, cells, &mut s, |c| format!("{:.2}", c.rays_per_pixel));
    }
    if let Some(grid) = strongest_md(plan, cells) {
        s.push('\n');
        s.push_str(&grid);
    }
    if let Some(e) = &plan.external {
        let _ = writeln!(
            s,
            "\nAgainst their reference ({}): mean RMSE / mean of the mean per-pixel RGB L2 norm; \
             then the mean L2 against this table's reference:\n",
            e.reference_arg
        );
        md_grid(plan, cells, &mut s, |c| match c.external {
            Some([rmse, l2, l2_ours]) => format!("{rmse:.5} / {l2:.5}; {l2_ours:.5}"),
            None => String::new(),
        });
    }
    s
}

/// The table's candidates for its strongest baseline (issue 40.3): its `mis` variants with the
/// power heuristic — plain, with compensation, with Sobol samples, or both.
pub fn baseline_variants(plan: &TablePlan) -> Vec<usize> {
    use crate::bq::estimator::mis::{Heuristic, LightMethod};
    (0..plan.variants.len())
        .filter(|&v| {
            plan.variants[v]
                .kind
                .light
                .is_some_and(|l| l.method == LightMethod::Mis && l.heuristic == Heuristic::Power)
        })
        .collect()
}

/// The strongest baseline at `spp`: the [`baseline_variants`] of least mean RMSE there.
fn strongest_at<'a>(plan: &TablePlan, cells: &'a [Cell], spp: usize) -> Option<&'a Cell> {
    baseline_variants(plan)
        .into_iter()
        .filter_map(|v| cells.iter().find(|c| c.variant == v && c.spp == spp))
        .filter(|c| c.mean.is_finite())
        .min_by(|a, b| a.mean.total_cmp(&b.mean))
}

/// Each variant's mean RMSE at equal spp divided by the strongest baseline's at that spp (a
/// grid of `table.md`), with the baseline's name per column; None without a baseline.
fn strongest_md(plan: &TablePlan, cells: &[Cell]) -> Option<String> {
    if baseline_variants(plan).is_empty() {
        return None;
    }
    let mut s = String::new();
    let names: Vec<String> = plan
        .spp
        .iter()
        .map(|&spp| match strongest_at(plan, cells, spp) {
            Some(b) => format!("{spp}: {}", plan.variants[b.variant].label),
            None => format!("{spp}: none"),
        })
        .collect();
    let _ = writeln!(
        s,
        "RMSE at equal spp relative to the strongest baseline, the best of the mis variants with \
         the power heuristic (plain, compensated, Sobol) at each spp ({}); below 1 is better:\n",
        names.join(", ")
    );
    md_grid(plan, cells, &mut s, |c| match strongest_at(plan, cells, c.spp) {
        Some(b) if b.mean > 0.0 => format!("{:.3}", c.mean / b.mean),
        _ => String::new(),
    });
    Some(s)
}

/// `0.05586 ± 0.00137`, or the mean alone without an interval (one repetition).
fn mean_pm(mean: f64, half_width: f64) -> String {
    if half_width.is_finite() {
        format!("{mean:.5} ± {half_width:.5}")
    } else {
        format!("{mean:.5}")
    }
}

/// A Markdown grid of variants × spp with `show(cell)` in each cell.
fn md_grid(plan: &TablePlan, cells: &[Cell], s: &mut String, show: impl Fn(&Cell) -> String) {
    let cell = |v: usize, spp: usize| cells.iter().find(|c| c.variant == v && c.spp == spp);
    md_header(plan, s, "Method");
    for (v, variant) in plan.variants.iter().enumerate() {
        let _ = write!(s, "| {} |", variant.label);
        for &spp in &plan.spp {
            match cell(v, spp) {
                Some(c) => {
                    let _ = write!(s, " {} |", show(c));
                }
                None => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
}

/// Mean wall-clock seconds per image (building the sample sets plus rendering) in Markdown:
/// printed and written to the uncommitted `timings.md`, never into the stable outputs.
pub fn times_md(plan: &TablePlan, cells: &[Cell]) -> String {
    let mut s = String::new();
    let cell = |v: usize, spp: usize| cells.iter().find(|c| c.variant == v && c.spp == spp);
    let _ = writeln!(
        s,
        "Mean time per image in seconds (building the sample sets plus rendering, wall clock):\n"
    );
    md_header(plan, &mut s, "Method");
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
    if let Some(text) = equal_time_md(plan, cells) {
        s.push('\n');
        s.push_str(&text);
    }
    s
}

/// The equal-time comparison, in Markdown (part of the uncommitted `timings.md`): for each
/// spp column, the time `t*` uniform MC took per image there, and each variant's RMSE at `t*`
/// divided by MC's, read off the variant's own measured RMSE-against-seconds curve (linear in
/// log RMSE against log seconds between its spp points; blank where `t*` lies outside the times
/// it was measured at — no extrapolation). Below 1 the variant wins at equal time. `None`
/// without a uniform MC variant.
pub fn equal_time_md(plan: &TablePlan, cells: &[Cell]) -> Option<String> {
    let mc = plan
        .variants
        .iter()
        .position(|v| v.kind == crate::render::integrator::IntegratorKind::MC)?;
    let cell = |v: usize, spp: usize| cells.iter().find(|c| c.variant == v && c.spp == spp);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "RMSE at equal time, relative to {} (each variant's RMSE interpolated, log–log, at the \
         seconds {} took per image at that spp; below 1 is better; blank outside the measured times):\n",
        plan.variants[mc].label, plan.variants[mc].label
    );
    md_header(plan, &mut s, "Method");
    for (v, variant) in plan.variants.iter().enumerate() {
        let mut curve: Vec<(f64, f64)> = plan
            .spp
            .iter()
            .filter_map(|&spp| cell(v, spp))
            .map(|c| (c.seconds, c.mean))
            .filter(|&(t, r)| t > 0.0 && r > 0.0 && t.is_finite() && r.is_finite())
            .collect();
        curve.sort_by(|a, b| a.0.total_cmp(&b.0));
        let _ = write!(s, "| {} |", variant.label);
        for &spp in &plan.spp {
            let ratio = cell(mc, spp).and_then(|m| Some(log_log_at(&curve, m.seconds)? / m.mean));
            match ratio {
                Some(r) => {
                    let _ = write!(s, " {r:.3} |");
                }
                None => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
    if !baseline_variants(plan).is_empty() {
        let _ = writeln!(
            s,
            "\nRMSE at equal time, relative to the strongest baseline (at each spp the mis variant \
             of least RMSE there, as in table.md; each variant's RMSE interpolated, log–log, at \
             the seconds that baseline took per image; below 1 is better):\n"
        );
        md_header(plan, &mut s, "Method");
        for v in 0..plan.variants.len() {
            let curve = time_curve(plan, cells, v);
            let _ = write!(s, "| {} |", plan.variants[v].label);
            for &spp in &plan.spp {
                let ratio = strongest_at(plan, cells, spp)
                    .and_then(|b| Some(log_log_at(&curve, b.seconds)? / b.mean));
                match ratio {
                    Some(r) => {
                        let _ = write!(s, " {r:.3} |");
                    }
                    None => s.push_str(" |"),
                }
            }
            s.push('\n');
        }
    }
    Some(s)
}

/// Variant `v`'s (seconds, mean RMSE) points, sorted by time, for [`log_log_at`].
fn time_curve(plan: &TablePlan, cells: &[Cell], v: usize) -> Vec<(f64, f64)> {
    let mut curve: Vec<(f64, f64)> = plan
        .spp
        .iter()
        .filter_map(|&spp| cells.iter().find(|c| c.variant == v && c.spp == spp))
        .map(|c| (c.seconds, c.mean))
        .filter(|&(t, r)| t > 0.0 && r > 0.0 && t.is_finite() && r.is_finite())
        .collect();
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    curve
}

/// `y(x)` on the piecewise-linear interpolant of `ln y` against `ln x` through `points` (sorted
/// by x); `None` outside `[x_first, x_last]`.
fn log_log_at(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let first = points.first()?;
    let last = points.last()?;
    if !(first.0..=last.0).contains(&x) {
        return None;
    }
    for w in points.windows(2) {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        if (x0..=x1).contains(&x) {
            if x1 == x0 {
                return Some(y0);
            }
            let t = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
            return Some((y0.ln() + t * (y1.ln() - y0.ln())).exp());
        }
    }
    Some(first.1)
}

/// A Markdown header row `| first | 20 spp | … |` and its rule.
fn md_header(plan: &TablePlan, s: &mut String, first: &str) {
    let _ = write!(s, "| {first} |");
    for spp in &plan.spp {
        let _ = write!(s, " {spp} spp |");
    }
    let _ = write!(s, "\n|---|");
    for _ in &plan.spp {
        let _ = write!(s, "---:|");
    }
    s.push('\n');
}

/// `timings.csv`: `variant,spp,repetition,seconds` per render (wall clock; machine-dependent,
/// so outside the stable outputs and not committed).
pub fn timings_csv(plan: &TablePlan, rows: &[Row]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["variant", "spp", "repetition", "seconds"])
        .expect(IN_MEMORY);
    for r in rows {
        w.write_record([
            plan.variants[r.variant].label.clone(),
            r.spp.to_string(),
            r.repetition.to_string(),
            format!("{:.4}", r.seconds),
        ])
        .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal time reads the variant's own curve: on `y = 1/√x` through two points, the
    /// interpolant at x = 4 is 1/2 exactly (a power law is a line log–log), and nothing is
    /// extrapolated past the measured range.
    #[test]
    fn equal_time_interpolates_log_log_and_never_extrapolates() {
        let curve = [(1.0, 1.0), (16.0, 0.25)];
        assert!((log_log_at(&curve, 4.0).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(log_log_at(&curve, 1.0), Some(1.0));
        assert_eq!(log_log_at(&curve, 0.5), None);
        assert_eq!(log_log_at(&curve, 17.0), None);
        assert_eq!(log_log_at(&[], 1.0), None);
    }

    #[test]
    fn results_folder_holds_one_run_legacy_manifests_are_read_by_content() {
        let table = serde_json::json!({
            "scene": "render-scene v1", "spp": [4, 8],
            "variants": [{"label": "BMC 2 GP"}],
        });
        assert!(
            legacy_manifest_files(&table)
                .unwrap()
                .contains(&"bmc-2-gp-8spp.png".to_string())
        );
        assert!(legacy_manifest_files(&serde_json::json!({"files": {"a": "b"}})).is_none());
    }
}
