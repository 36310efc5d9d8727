//! The protocol's files in `results/<name>/`:
//!
//! - `irradiance.csv` — one row per estimator and N: `estimator,n,rms,rms_r,rms_g,rms_b`;
//! - `table.md` — the RMS table beside the published numbers, and the smallest N at which each
//!   estimator matches SH L2 (its RMS at or below SH L2's);
//! - `rms_vs_n.svg`, `rms_vs_n.caption.txt` — RMS against N, log–log, the published numbers as
//!   horizontal lines ([`super::plot`]);
//! - `exact.exr` — the exact irradiance over the grid (a `W × H` image, row 0 at the zenith);
//! - `manifest.json` — the plan, the published numbers, the exact irradiance's tolerance and
//!   largest error estimate, the smallest N per estimator; `timings.json` — wall-clock seconds
//!   (machine-dependent, not committed).

use super::{Exact, IrradiancePlan, Row};
use crate::files::result_folder::ResultFolder;
use crate::render::image::Image;
use std::fmt::Write as _;

/// The names an irradiance `manifest.json` accounts for beyond its `files`, or `None` if it is
/// not one ([`crate::files::result_folder::LegacyManifest`]).
pub fn legacy_manifest_files(manifest: &serde_json::Value) -> Option<Vec<String>> {
    manifest.get("irradiance")?;
    Some(vec![crate::files::result_folder::TIMINGS.into()])
}

/// `irradiance.csv`.
pub fn csv(plan: &IrradiancePlan, rows: &[Row]) -> String {
    let mut s = String::from("estimator,n,rms,rms_r,rms_g,rms_b\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:e},{:e},{:e},{:e}",
            plan.estimators[r.estimator].name,
            r.n,
            r.rms,
            r.rms_channel[0],
            r.rms_channel[1],
            r.rms_channel[2]
        );
    }
    s
}

/// The smallest N at which `estimator`'s RMS is at or below `target`.
pub fn smallest_n(rows: &[Row], estimator: usize, target: f64) -> Option<usize> {
    rows.iter()
        .filter(|r| r.estimator == estimator && r.rms <= target)
        .map(|r| r.n)
        .min()
}

/// `table.md`.
pub fn table_md(plan: &IrradiancePlan, exact: &Exact, rows: &[Row]) -> String {
    let mut s = format!("# {}\n\n", plan.title);
    let _ = writeln!(
        s,
        "Irradiance E(n) = (1/π)∫L max(0, n·ω)dω for every normal of a {}×{} lat-long grid (texel centres, \
         the whole sphere) under `{}`; RMS = √(mean over channels of the per-channel MSE over the grid) against the \
         exact texel sum (tolerance {:.1e} per normal and channel, largest error estimate {:.1e}). One rule per N, \
         rotated per normal; seed {}.\n",
        plan.width,
        plan.height,
        plan.env_name,
        plan.exact_tolerance(),
        exact.max_error,
        plan.seed
    );
    s.push_str("| N |");
    for e in &plan.estimators {
        let _ = write!(s, " {} |", e.name);
    }
    s.push_str("\n|---:|");
    s.push_str(&"---:|".repeat(plan.estimators.len()));
    s.push('\n');
    for &n in &plan.n {
        let _ = write!(s, "| {n} |");
        for e in 0..plan.estimators.len() {
            match rows.iter().find(|r| r.n == n && r.estimator == e) {
                Some(r) => {
                    let _ = write!(s, " {:.4e} |", r.rms);
                }
                None => s.push_str(" — |"),
            }
        }
        s.push('\n');
    }
    let lines = plan.published_lines();
    if lines.is_empty() {
        s.push_str("\nNo published numbers for this map.\n");
        return s;
    }
    let source = plan.published.source.as_deref().unwrap_or("the irradiance file");
    let _ = writeln!(
        s,
        "\nPublished on the same map ({source}; against a 20 000-sample importance-sampled MC reference, not the exact \
         irradiance):\n"
    );
    s.push_str("| representation | RMS |\n|---|---:|\n");
    for (k, v) in &lines {
        let _ = writeln!(s, "| {k} | {v} |");
    }
    s.push_str(
        "\nSmallest N at which each estimator's RMS is at or below each published number (`>` the largest N \
         run: not reached):\n\n| estimator |",
    );
    for (k, _) in &lines {
        let _ = write!(s, " {} |", k.split(" (").next().unwrap_or(k));
    }
    s.push_str("\n|---|");
    s.push_str(&"---:|".repeat(lines.len()));
    s.push('\n');
    for (e, est) in plan.estimators.iter().enumerate() {
        let _ = write!(s, "| {} |", est.name);
        for (_, v) in &lines {
            let n = smallest_n(rows, e, *v)
                .map_or(format!("> {}", plan.n.last().copied().unwrap_or(0)), |n| {
                    n.to_string()
                });
            let _ = write!(s, " {n} |");
        }
        s.push('\n');
    }
    s
}

/// `manifest.json` (the committed record; seconds are in `timings.json`).
pub fn manifest(plan: &IrradiancePlan, exact: &Exact, rows: &[Row]) -> serde_json::Value {
    let smallest: serde_json::Map<String, serde_json::Value> = plan
        .estimators
        .iter()
        .enumerate()
        .map(|(e, est)| {
            (
                est.name.clone(),
                plan.published.sh_l2.and_then(|l2| smallest_n(rows, e, l2)).into(),
            )
        })
        .collect();
    serde_json::json!({
        "irradiance": {
            "name": plan.name,
            "title": plan.title,
            "env": plan.env_name,
            "grid": [plan.width, plan.height],
            "n": plan.n,
            "seed": plan.seed,
            "estimators": plan.estimators.iter().map(|e| e.name.clone()).collect::<Vec<_>>(),
            "published": plan.published,
            "exact": {
                "method": crate::render::texel::VERSION,
                "tolerance": plan.exact_tolerance(),
                "max_error_estimate": exact.max_error,
            },
            "smallest_n_matching_sh_l2": smallest,
        }
    })
}

/// Writes every file but the manifest into the folder.
pub fn write(
    folder: &mut ResultFolder,
    plan: &IrradiancePlan,
    exact: &Exact,
    rows: &[Row],
) -> crate::Result<()> {
    folder.write(
        "irradiance.csv",
        "RMS per estimator and N (stable raw data)",
        csv(plan, rows).as_bytes(),
    )?;
    folder.write(
        "table.md",
        "the RMS table beside the published numbers, smallest N matching SH L2",
        table_md(plan, exact, rows).as_bytes(),
    )?;
    let figure = super::plot::plot_svg(plan, rows)?;
    folder.write(
        "rms_vs_n.svg",
        "RMS against N with the published numbers",
        figure.svg.as_bytes(),
    )?;
    folder.write(
        "rms_vs_n.caption.txt",
        "the figure's caption",
        figure.caption.as_bytes(),
    )?;
    let image = Image {
        width: plan.width,
        height: plan.height,
        data: exact.values.clone(),
    };
    folder.write(
        "exact.exr",
        "the exact irradiance over the grid of normals",
        &image.to_exr()?,
    )?;
    Ok(())
}

/// What `workbench run` prints: the RMS table and the smallest N matching SH L2.
pub fn summary(plan: &IrradiancePlan, rows: &[Row]) -> String {
    let mut s = format!(
        "{} — RMS over the {}×{} grid of normals\n",
        plan.name, plan.width, plan.height
    );
    let _ = write!(s, "{:>6}", "N");
    for e in &plan.estimators {
        let _ = write!(s, " {:>12}", e.name);
    }
    s.push('\n');
    for &n in &plan.n {
        let _ = write!(s, "{n:>6}");
        for e in 0..plan.estimators.len() {
            let v = rows
                .iter()
                .find(|r| r.n == n && r.estimator == e)
                .map_or(f64::NAN, |r| r.rms);
            let _ = write!(s, " {v:>12.4e}");
        }
        s.push('\n');
    }
    for (k, v) in plan.published_lines() {
        let _ = writeln!(s, "published {k}: {v}");
    }
    s
}
