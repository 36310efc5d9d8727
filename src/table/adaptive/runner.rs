//! Renders every variant × target × repetition of an adaptive table
//! ([`crate::render::adaptive::render`], the single image's renderer) against the reference.

use super::plan::AdaptivePlan;
use crate::render::adaptive::{self, AdaptiveImage, AdaptiveSampler};
use crate::render::image::Image;
use crate::render::renderer::Renderer;
use crate::table::plan::TablePlan;
use crate::util::report::{Reporter, Silent};
use std::time::Instant;

/// Stream family of the adaptive tables' render seeds (apart from the fixed-spp ones).
const ADAPTIVE_TABLE: u64 = 0xada7ab;

/// One adaptive render of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveRow {
    pub variant: usize,
    /// Index of the target in [`AdaptivePlan::targets`].
    pub column: usize,
    pub target: f64,
    pub repetition: usize,
    /// The render's seed: `render --target-sd T --seed SEED` renders the same image.
    pub seed: u64,
    pub rmse: f64,
    /// Mean samples per hit pixel ([`AdaptiveImage::mean_spp`]).
    pub mean_spp: f64,
    /// Share of hit pixels whose every channel met the target ([`AdaptiveImage::share_met`]).
    pub share_met: f64,
    /// Share of hit pixel-channels within `1.96 T` of the reference ([`AdaptiveImage::within`]).
    pub within: f64,
    /// Wall-clock seconds (building the nested sets plus rendering); outside the stable outputs.
    pub seconds: f64,
}

/// The seed of repetition `rep` at target `target`: the same for every variant (paired
/// renders), and independent of the other targets listed.
pub fn adaptive_render_seed(seed: u64, target: f64, rep: usize) -> u64 {
    crate::util::rng::mix(seed, &[ADAPTIVE_TABLE, target.to_bits(), rep as u64])
}

/// What the runner hands its caller as it goes: the first repetition of each cell, and the
/// rows so far after each round of variants.
pub trait AdaptiveSink {
    fn first_image(&mut self, variant: usize, target: f64, image: &AdaptiveImage) -> crate::Result<()>;
    fn round_done(&mut self, rows: &[AdaptiveRow]) -> crate::Result<()>;
}

/// Renders the table in spec order: target, then repetition, then variant; only the units
/// (rounds of variants at one target and repetition, numbered in that order) that `keep` takes.
pub fn run(
    plan: &TablePlan,
    adaptive_plan: &AdaptivePlan,
    renderer: &Renderer,
    reference: &Image,
    sink: &mut dyn AdaptiveSink,
    reporter: &dyn Reporter,
    keep: &dyn Fn(usize) -> bool,
) -> crate::Result<Vec<AdaptiveRow>> {
    let units = plan.repetitions.iter().sum::<usize>();
    let total: usize = (0..units).filter(|&u| keep(u)).count() * plan.variants.len();
    reporter.start("renders", total as u64);
    let mut rows = Vec::with_capacity(total);
    let mut unit = 0;
    for (column, (&target, &reps)) in adaptive_plan.targets.iter().zip(&plan.repetitions).enumerate() {
        let settings = adaptive_plan.settings(target);
        for rep in 0..reps {
            unit += 1;
            if !keep(unit - 1) {
                continue;
            }
            let seed = adaptive_render_seed(plan.seed, target, rep);
            for (v, variant) in plan.variants.iter().enumerate() {
                reporter.working_on(&format!("{} target sd {target} #{rep}", variant.label));
                let start = Instant::now();
                let model = plan.model_of(variant).filter(|_| variant.kind.uses_sets());
                let (sampler, jitter) =
                    AdaptiveSampler::new(variant.kind, &settings, variant.gps, variant.rotate, model, seed)?;
                if jitter > 0.0 && rep == 0 {
                    reporter.note(&format!(
                        "warning: {} target sd {target}: a nested sample set's Cholesky needed jitter \
                         {jitter:.3e} on the diagonal (every stage of that set uses it); increase the noise σ_n²",
                        variant.label
                    ));
                }
                let image = adaptive::render(renderer, &sampler, &settings, seed, &Silent);
                let seconds = start.elapsed().as_secs_f64();
                rows.push(AdaptiveRow {
                    variant: v,
                    column,
                    target,
                    repetition: rep,
                    seed,
                    rmse: image.image.rmse(reference),
                    mean_spp: image.mean_spp(),
                    share_met: image.share_met(),
                    within: image.within(reference),
                    seconds,
                });
                if rep == 0 {
                    sink.first_image(v, target, &image)?;
                }
                reporter.advance(1);
            }
            sink.round_done(&rows)?;
        }
    }
    reporter.finish();
    Ok(rows)
}
