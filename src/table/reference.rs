//! The table's reference image, cached as `<results>/cache/reference-<key>.exr` (with a `.json`
//! describing it), `key` a hash of everything that determines it, so tables share it.

use super::plan::{ReferencePlan, TablePlan};
use crate::files::atomic::write_atomic;
use crate::render::SceneKind;
use crate::render::image::Image;
use crate::render::integrator::Integrator;
use crate::render::renderer::Renderer;
use crate::sampling::Density;
use crate::util::report::Reporter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Version of the scene definition; part of the reference cache key.
pub const SCENE_VERSION: &str = "render-scene v1";

/// Version of the thesis scene's definition ([`crate::render::scene::thesis`]).
pub const THESIS_SCENE_VERSION: &str = "thesis-scene v1";

/// The version of `plan`'s scene, for the cache key and the manifest.
pub fn scene_version(plan: &TablePlan) -> &'static str {
    match plan.scene {
        SceneKind::Workbench => SCENE_VERSION,
        SceneKind::Thesis => THESIS_SCENE_VERSION,
    }
}

/// `(key, description)`: the description lists everything that determines the reference image;
/// the key is its 64-bit FNV-1a hash in hex.
pub fn reference_key(plan: &TablePlan) -> (String, String) {
    // The MC description is exactly the one used before exact references existed, so earlier
    // caches stay valid; the exact one adds the method, tolerance and quadrature version.
    let mut json = serde_json::json!({
        "scene": scene_version(plan),
        "env": plan.env.key(),
        "width": plan.width,
        "height": plan.height,
    });
    for (k, v) in plan.reference.json(&plan.env).as_object().expect("an object") {
        json[k] = v.clone();
    }
    let description = serde_json::to_string_pretty(&json).expect("serialisable");
    (
        format!("{:016x}", crate::util::rng::label_id(&description)),
        description,
    )
}

/// Where the reference of `plan` is cached under `results`.
pub fn cache_path(plan: &TablePlan, results: &Path) -> PathBuf {
    let (key, _) = reference_key(plan);
    results.join("cache").join(format!("reference-{key}.exr"))
}

/// The reference: read from the cache if present and sound, else rendered (exact, or uniform
/// MC) and cached. A damaged entry (unreadable, wrong size, non-finite pixels) is rendered again.
pub fn reference(
    plan: &TablePlan,
    renderer: &Renderer,
    results: &Path,
    reporter: &dyn Reporter,
) -> crate::Result<Image> {
    let path = cache_path(plan, results);
    if path.exists() {
        match Image::read(&path, "reference cache") {
            Ok(image) if (image.width, image.height) == (plan.width, plan.height) => {
                reporter.note(&format!("render: reference from cache {}", path.display()));
                return Ok(image);
            }
            Ok(_) => reporter.note(&format!(
                "warning: {} has the wrong size; rendering it again",
                path.display()
            )),
            Err(e) => reporter.note(&format!("warning: {e}; rendering it again")),
        }
    }
    let start = Instant::now();
    let (image, what) = match plan.reference {
        ReferencePlan::Mc { spp, seed } => {
            let integrator = Integrator::mc(Density::Uniform, spp);
            reporter.start(
                "rows (reference)",
                (renderer.passes(&integrator) * plan.height) as u64,
            );
            let image = renderer.render(&integrator, seed, reporter);
            reporter.finish();
            (image, format!("mc, {spp} spp"))
        }
        ReferencePlan::Exact { tolerance } => {
            reporter.start("rows (exact reference)", plan.height as u64);
            let (image, stats) = renderer.render_exact(tolerance, reporter);
            reporter.finish();
            (
                image,
                format!(
                    "exact, tolerance {tolerance:e}; largest error estimate {:.1e}",
                    stats.max_error
                ),
            )
        }
    };
    write_atomic(&path, &image.to_exr()?)?;
    write_atomic(&path.with_extension("json"), reference_key(plan).1.as_bytes())?;
    reporter.note(&format!(
        "render: reference ({what}) in {:.1} s → {}",
        start.elapsed().as_secs_f64(),
        path.display()
    ));
    // Use exactly what later tables will read back.
    Image::read(&path, "reference cache").map_err(Into::into)
}
