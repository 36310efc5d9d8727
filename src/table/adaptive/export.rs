//! An adaptive table's files, serialised to bytes (pure):
//!
//! - `rmse.csv` — stable raw data, one row per render;
//! - `table.csv`, `table.md` — per (variant, target): mean RMSE with its 95% Student-t
//!   interval, mean spp, share of pixels meeting the target, share of pixel-channels within
//!   `1.96 T` of the reference;
//! - `timings.csv`, `timings.md` — wall-clock seconds, machine-dependent and not committed.

use super::runner::AdaptiveRow;
use super::summary::AdaptiveCell;
use crate::table::export::{VARIANT_COLUMNS, num, variant_fields};
use crate::table::plan::TablePlan;
use std::fmt::Write as _;

/// Writing CSV into a `Vec` cannot fail.
const IN_MEMORY: &str = "writing CSV to memory";

/// `rmse.csv`: `variant,integrator,gps,rotate,target_sd,repetition,seed,rmse,mean_spp,share_met,
/// within`, one row per render, numbers in Rust's shortest round-trip form.
pub fn rmse_csv(plan: &TablePlan, rows: &[AdaptiveRow]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let head = [
        "target_sd",
        "repetition",
        "seed",
        "rmse",
        "mean_spp",
        "share_met",
        "within",
    ];
    w.write_record(VARIANT_COLUMNS.iter().chain(&head))
        .expect(IN_MEMORY);
    for r in rows {
        let rest = [
            num(r.target),
            r.repetition.to_string(),
            r.seed.to_string(),
            num(r.rmse),
            num(r.mean_spp),
            num(r.share_met),
            num(r.within),
        ];
        w.write_record(variant_fields(&plan.variants[r.variant]).iter().chain(&rest))
            .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

/// `table.csv`: `variant,integrator,gps,rotate,target_sd,repetitions,rmse_mean,rmse_sd,
/// rmse_ci95_low,rmse_ci95_high,mean_spp,share_met,within` per (variant, target), the interval
/// from Student's t (empty for one repetition), the others means over the renders.
pub fn table_csv(plan: &TablePlan, cells: &[AdaptiveCell]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let head = [
        "target_sd",
        "repetitions",
        "rmse_mean",
        "rmse_sd",
        "rmse_ci95_low",
        "rmse_ci95_high",
        "mean_spp",
        "share_met",
        "within",
    ];
    w.write_record(VARIANT_COLUMNS.iter().chain(&head))
        .expect(IN_MEMORY);
    for c in cells {
        let rest = [
            num(c.target),
            c.n.to_string(),
            num(c.mean),
            num(c.sd),
            num(c.mean - c.half_width),
            num(c.mean + c.half_width),
            num(c.mean_spp),
            num(c.share_met),
            num(c.within),
        ];
        w.write_record(variant_fields(&plan.variants[c.variant]).iter().chain(&rest))
            .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

/// `table.md`: three grids of variants × targets — mean RMSE, mean spp, and the shares.
pub fn table_md(plan: &TablePlan, targets: &[f64], cells: &[AdaptiveCell], stages: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Adaptive sampling ({stages}): mean RMSE (± half-width of the 95% Student-t interval) of {}×{} \
         renders against {}; repetitions per target: {}.\n",
        plan.width,
        plan.height,
        plan.reference.describe(),
        targets
            .iter()
            .zip(&plan.repetitions)
            .map(|(t, r)| format!("{r} at {t}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    grid(plan, targets, cells, &mut s, |c| {
        if c.half_width.is_finite() {
            format!("{:.5} ± {:.5}", c.mean, c.half_width)
        } else {
            format!("{:.5}", c.mean)
        }
    });
    let _ = writeln!(
        s,
        "\nMean samples per pixel (over the pixels that hit the scene):\n"
    );
    grid(plan, targets, cells, &mut s, |c| format!("{:.1}", c.mean_spp));
    let _ = writeln!(
        s,
        "\nShare of pixels whose every channel met the target / share of pixel-channels within 1.96·T of the \
         reference (0.95 if the target is met and the stated sds are calibrated):\n"
    );
    grid(plan, targets, cells, &mut s, |c| {
        format!("{:.3} / {:.3}", c.share_met, c.within)
    });
    s
}

/// Mean wall-clock seconds per image in Markdown (printed and written to the uncommitted
/// `timings.md`), beside each cell's mean spp and RMSE for the equal-time comparison.
pub fn times_md(plan: &TablePlan, targets: &[f64], cells: &[AdaptiveCell]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Mean time per image in seconds (building the nested sample sets plus rendering, wall clock):\n"
    );
    grid(plan, targets, cells, &mut s, |c| format!("{:.3}", c.seconds));
    s
}

/// `timings.csv`: `variant,target_sd,repetition,seconds` per render (machine-dependent).
pub fn timings_csv(plan: &TablePlan, rows: &[AdaptiveRow]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["variant", "target_sd", "repetition", "seconds"])
        .expect(IN_MEMORY);
    for r in rows {
        w.write_record([
            plan.variants[r.variant].label.clone(),
            num(r.target),
            r.repetition.to_string(),
            format!("{:.4}", r.seconds),
        ])
        .expect(IN_MEMORY);
    }
    w.into_inner().expect(IN_MEMORY)
}

/// A Markdown grid `| Method | T = 0.08 | … |` with `show(cell)` in each cell.
fn grid(
    plan: &TablePlan,
    targets: &[f64],
    cells: &[AdaptiveCell],
    s: &mut String,
    show: impl Fn(&AdaptiveCell) -> String,
) {
    let _ = write!(s, "| Method |");
    for t in targets {
        let _ = write!(s, " T = {t} |");
    }
    let _ = write!(s, "\n|---|");
    for _ in targets {
        let _ = write!(s, "---:|");
    }
    s.push('\n');
    for (v, variant) in plan.variants.iter().enumerate() {
        let _ = write!(s, "| {} |", variant.label);
        for column in 0..targets.len() {
            match cells.iter().find(|c| c.variant == v && c.column == column) {
                Some(c) => {
                    let _ = write!(s, " {} |", show(c));
                }
                None => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
}
