//! Per-cell statistics of the table: mean RMSE with its 95% Student-t interval.

use super::plan::TablePlan;
use super::runner::Row;

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
    /// Mean RMSE over the edge mask and its 95% half-width.
    pub edges_mean: f64,
    pub edges_half_width: f64,
    /// Mean over the renders of each render's coverage95 (every render counts the same
    /// pixel-channels, so this is the pooled share), whole image and edge mask.
    pub coverage95: f64,
    pub coverage95_edges: f64,
    /// Mean wall-clock seconds per render (building the sets plus rendering); not part of the
    /// stable outputs.
    pub seconds: f64,
    /// Means of the measures against an external reference (tables with `"external"`):
    /// RMSE and mean L2 against theirs, mean L2 against ours.
    pub external: Option<[f64; 3]>,
    /// Mean over the renders of the shadow rays traced per hit pixel.
    pub rays_per_pixel: f64,
}

/// Mean, standard deviation and 95% Student-t half-width of the RMSE per (variant, spp), in
/// the order of the spec; a plain loop in row order.
pub fn summarise(plan: &TablePlan, rows: &[Row]) -> Vec<Cell> {
    use crate::util::stats::{mean, mean_ci95, sample_sd};
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
            let edges: Vec<f64> = cell.iter().map(|r| r.rmse_edges).collect();
            let (edges_lo, edges_hi) = mean_ci95(&edges);
            let coverage: Vec<f64> = cell.iter().map(|r| r.coverage95).collect();
            let coverage_edges: Vec<f64> = cell.iter().map(|r| r.coverage95_edges).collect();
            cells.push(Cell {
                variant: v,
                spp,
                n: rmse.len(),
                mean: mean(&rmse),
                sd: sample_sd(&rmse),
                half_width: 0.5 * (hi - lo),
                edges_mean: mean(&edges),
                edges_half_width: 0.5 * (edges_hi - edges_lo),
                coverage95: mean(&coverage),
                coverage95_edges: mean(&coverage_edges),
                seconds: mean(&seconds),
                rays_per_pixel: mean(&cell.iter().map(|r| r.rays_per_pixel).collect::<Vec<_>>()),
                external: plan.external.as_ref().map(|_| {
                    let of = |f: fn(&super::external::ExternalMeasures) -> f64| -> f64 {
                        let v: Vec<f64> = cell.iter().filter_map(|r| r.external.as_ref().map(f)).collect();
                        mean(&v)
                    };
                    [
                        of(|m| m.rmse_theirs),
                        of(|m| m.mean_l2_theirs),
                        of(|m| m.mean_l2_ours),
                    ]
                }),
            });
        }
    }
    cells
}
