//! Renders every variant × spp × repetition of a table against its reference.

use super::external::ExternalMeasures;
use super::plan::TablePlan;
use crate::render::image::Image;
use crate::render::integrator::Integrator;
use crate::render::renderer::Renderer;
use crate::render::uncertainty::{PixelSds, coverage};
use crate::util::report::{Reporter, Silent};
use std::time::Instant;

/// One render of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub variant: usize,
    pub spp: usize,
    pub repetition: usize,
    pub seed: u64,
    pub rmse: f64,
    /// RMSE over the edge mask ([`crate::render::integrator::neighbours::edge_mask`]):
    /// silhouettes and creases, where a neighbour prior can mislead.
    pub rmse_edges: f64,
    /// Share of the hit pixel-channels whose 95% interval holds the reference (math.md §7),
    /// over the whole image and over the edge mask.
    pub coverage95: f64,
    pub coverage95_edges: f64,
    /// Wall-clock seconds (building the sets plus rendering); outside the stable outputs.
    pub seconds: f64,
    /// The measures against an external reference (tables with `"external"`).
    pub external: Option<ExternalMeasures>,
    /// Mean shadow rays traced per hit pixel ([`crate::render::integrator::RayCounter`]): `spp`
    /// for the estimators of the family, fewer for a light sampler whose samples fall below the
    /// horizon or where the light is black. In `rmse.csv` of tables with a renderer's baseline.
    pub rays_per_pixel: f64,
}

/// The seed of repetition `rep` at `spp`: the same for every variant (paired renders).
pub fn render_seed(seed: u64, spp: usize, rep: usize) -> u64 {
    crate::util::rng::mix(seed, &[spp as u64, rep as u64])
}

/// What the runner hands its caller as it goes: the first repetition's image of each cell and
/// the sds it states (to save), and the rows so far after each round of variants (so an interrupted
/// table keeps what it measured).
pub trait TableSink {
    fn first_image(&mut self, variant: usize, spp: usize, image: &Image, sds: &PixelSds)
    -> crate::Result<()>;
    fn round_done(&mut self, rows: &[Row]) -> crate::Result<()>;
}

/// Renders the table in spec order: spp, then repetition, then variant. Every render states
/// its sds (the variant's amplitude scale; MC its standard error), so each row has its
/// coverage; `edges` is the edge mask (row-major) of the edge columns. Only the units (rounds
/// of variants at one spp and repetition, numbered in that order: [`super::shard`]) that `keep`
/// takes are rendered.
pub fn run(
    plan: &TablePlan,
    renderer: &Renderer,
    reference: &Image,
    edges: &[bool],
    sink: &mut dyn TableSink,
    reporter: &dyn Reporter,
    keep: &dyn Fn(usize) -> bool,
) -> crate::Result<Vec<Row>> {
    let units = plan.repetitions.iter().sum::<usize>();
    let total: usize = (0..units).filter(|&u| keep(u)).count() * plan.variants.len();
    reporter.start("renders", total as u64);
    let mut rows = Vec::with_capacity(total);
    let mut unit = 0;
    for (&spp, &reps) in plan.spp.iter().zip(&plan.repetitions) {
        for rep in 0..reps {
            unit += 1;
            if !keep(unit - 1) {
                continue;
            }
            let seed = render_seed(plan.seed, spp, rep);
            for (v, variant) in plan.variants.iter().enumerate() {
                reporter.working_on(&format!("{} {spp} spp #{rep}", variant.label));
                let start = Instant::now();
                let integrator = Integrator::build(
                    variant.kind,
                    spp,
                    variant.gps,
                    variant.rotate,
                    plan.model_of(variant),
                    seed,
                )?
                .with_uncertainty(variant.scale, plan.model_of(variant))?;
                if rep == 0 {
                    for line in numerical_warnings(&integrator) {
                        reporter.note(&format!("warning: {} {spp} spp: {line}", variant.label));
                    }
                }
                let (image, sds) = renderer.render_with_sd(&integrator, seed, &Silent);
                let seconds = start.elapsed().as_secs_f64();
                rows.push(Row {
                    rays_per_pixel: integrator.counter.rays_per_pixel(),
                    variant: v,
                    spp,
                    repetition: rep,
                    seed,
                    rmse: image.rmse(reference),
                    rmse_edges: image.rmse_masked(reference, edges),
                    coverage95: coverage(&image, reference, &sds, None).coverage95,
                    coverage95_edges: coverage(&image, reference, &sds, Some(edges)).coverage95,
                    seconds,
                    external: plan
                        .external
                        .as_ref()
                        .map(|e| ExternalMeasures::of(&image, &e.reference, reference)),
                });
                if rep == 0 {
                    sink.first_image(v, spp, &image, &sds)?;
                }
                reporter.advance(1);
            }
            sink.round_done(&rows)?;
        }
    }
    reporter.finish();
    Ok(rows)
}

/// Each distinct numerical warning of an integrator's sample sets once, with its remedy.
pub fn numerical_warnings(integrator: &Integrator) -> Vec<String> {
    let mut seen: Vec<String> = Vec::new();
    if let Some(sets) = &integrator.sets {
        for (s, set) in sets.sets.iter().enumerate() {
            for w in &set.weights.diagnostics.warnings {
                let m = format!("sample set {s}: {}", w.message());
                if !seen.iter().any(|x| x.ends_with(&w.message())) {
                    seen.push(m);
                }
            }
        }
    }
    seen
}
