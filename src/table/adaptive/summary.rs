//! Per-cell statistics of an adaptive table: mean RMSE with its 95% Student-t interval, mean
//! spp and the shares, per (variant, target).

use super::runner::AdaptiveRow;
use crate::table::plan::TablePlan;

/// Summary of one (variant, target) cell.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveCell {
    pub variant: usize,
    pub column: usize,
    pub target: f64,
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    /// Half-width of the 95% interval `t_{0.975, n−1} · sd / √n` (NaN for `n = 1`).
    pub half_width: f64,
    /// Means over the renders (every render counts the same pixels, so these are pooled).
    pub mean_spp: f64,
    pub share_met: f64,
    pub within: f64,
    /// Mean wall-clock seconds per render; not part of the stable outputs.
    pub seconds: f64,
}

/// The cells in the order of the spec: variant, then target.
pub fn summarise(plan: &TablePlan, targets: &[f64], rows: &[AdaptiveRow]) -> Vec<AdaptiveCell> {
    use crate::util::stats::{mean, mean_ci95, sample_sd};
    let mut cells = Vec::new();
    for v in 0..plan.variants.len() {
        for (column, &target) in targets.iter().enumerate() {
            let cell: Vec<&AdaptiveRow> = rows
                .iter()
                .filter(|r| r.variant == v && r.column == column)
                .collect();
            if cell.is_empty() {
                continue;
            }
            let of = |f: fn(&AdaptiveRow) -> f64| cell.iter().map(|r| f(r)).collect::<Vec<f64>>();
            let rmse = of(|r| r.rmse);
            let (lo, hi) = mean_ci95(&rmse);
            cells.push(AdaptiveCell {
                variant: v,
                column,
                target,
                n: rmse.len(),
                mean: mean(&rmse),
                sd: sample_sd(&rmse),
                half_width: 0.5 * (hi - lo),
                mean_spp: mean(&of(|r| r.mean_spp)),
                share_met: mean(&of(|r| r.share_met)),
                within: mean(&of(|r| r.within)),
                seconds: mean(&of(|r| r.seconds)),
            });
        }
    }
    cells
}
