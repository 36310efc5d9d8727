//! `workbench render --target-sd T --max-spp M --out x.exr`: one adaptively sampled image
//! ([`workbench::render::adaptive`]), its PNG, the spp map `x-spp.png` and, with `--reference`,
//! the RMSE, the share of pixel channels within `1.96 T` and the error image.

use super::output::{status, stdout};
use super::progress::Bar;
use std::time::Instant;
use workbench::render::ImagePlan;
use workbench::render::adaptive::{self, AdaptiveSampler};
use workbench::render::image::{ColourMap, ErrorScale};
use workbench::render::plan::Method;
use workbench::util::report::Reporter;

/// Renders the adaptive plan and writes its image set.
pub fn single(plan: &ImagePlan, bar: &Bar) -> anyhow::Result<()> {
    let Method::Adaptive { kind, settings } = &plan.method else {
        unreachable!("render_adaptive::single takes adaptive plans")
    };
    let (kind, target_sd, first) = (*kind, settings.target_sd, settings.stages[0]);
    let labelled = plan.outputs.labelled(super::image_files::flag);
    let mut files = super::image_files::lock(&labelled)?;
    let (out, png, error_png) = (&plan.outputs.exr, &plan.outputs.png, &plan.outputs.error_png);
    let spp_png = plan
        .outputs
        .spp_png
        .as_ref()
        .expect("adaptive plans have an spp map");
    let start = Instant::now();
    let (sampler, jitter) = AdaptiveSampler::new(
        kind,
        settings,
        plan.gps,
        plan.rotate,
        plan.model.as_ref(),
        plan.seed,
    )?;
    if jitter > 0.0 {
        status!(
            "warning: a nested sample set's Cholesky needed jitter {jitter:.3e} on the diagonal (every \
             stage of that set uses it); increase the noise σ_n²"
        );
    }
    let pool = workbench::util::threads::pool(None)?;
    bar.start("rows", (sampler.passes() * plan.height) as u64);
    let result = pool.install(|| adaptive::render(&plan.renderer, &sampler, settings, plan.seed, bar));
    bar.finish();
    let seconds = start.elapsed().as_secs_f64();

    let (map, black) = result.spp_as_norms();
    let spp_image = workbench::render::image::scalar_png(
        &map.error_norms(&black),
        map.width,
        map.height,
        ErrorScale::Absolute,
        settings.max_spp() as f64,
        ColourMap::Viridis,
        workbench::render::image::SPP_TITLE,
    )?;
    files.stage(out, &result.image.to_exr()?)?;
    files.stage(png, &result.image.to_png()?)?;
    files.stage(spp_png, &spp_image.png)?;
    match &plan.reference {
        Some(r) => {
            let e = result
                .image
                .error_png(r, ErrorScale::Absolute, plan.error_max, plan.error_colours)?;
            files.stage(error_png, &e.png)?;
        }
        None => files.remove_stale(error_png),
    }
    super::image_files::commit_and_report_removed(files)?;
    status!(
        "render: {kind} adaptive, target sd {target_sd:e}, stages {}…{} spp, {}×{}: {seconds:.3} s (sample sets + \
         render) → {}, {}, {}",
        first,
        settings.max_spp(),
        plan.width,
        plan.height,
        out.display(),
        png.display(),
        spp_png.display()
    );
    if result.zero_evidence.contains(&true) {
        status!(
            "note: {:.2}% of the pixels had a stage with zero evidence (a channel's samples all alike, e.g. all 0: \
             MC sample sd or fitted amplitude exactly 0); such a stage never stops a pixel, so they doubled on",
            100.0 * result.share_zero_evidence()
        );
    }
    stdout(&format!(
        "mean spp = {:.2}\nshare of pixels meeting the target = {:.4}\nseconds = {seconds:.3}\n",
        result.mean_spp(),
        result.share_met()
    ))?;
    if let Some(r) = &plan.reference {
        stdout(&format!(
            "rmse = {:.6e}\nshare of pixel channels within 1.96·target = {:.4}\n",
            result.image.rmse(r),
            result.within(r)
        ))?;
    }
    Ok(())
}
