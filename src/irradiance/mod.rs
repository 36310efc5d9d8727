//! Probulator's irradiance protocol (math.md §10, "Irradiance protocol"; issue 28 item 2): for
//! every normal `n` of a `W × H` lat-long grid (texel centres under the `mitsuba` convention,
//! `ψ = 2π(i + ½)/W`, `θ = π(j + ½)/H`, the whole sphere), the irradiance
//! `E(n) = (1/π) ∫ L max(0, n·ω) dω` per channel, exactly by the texel sum (the `envmap` family's
//! Lambertian truth, [`texel::irradiance`]) and by each estimator at each N with **one** rule per
//! N (one weighted sample set, [`Integrator::build`] with one set) rotated per normal by a
//! random azimuth as the renderer rotates its sets, MC drawing fresh points per normal from the
//! normal's stream. RMS `= √(mean over channels of the per-channel MSE over the grid)`.
//!
//! A file of this kind has `"kind": "irradiance"` ([`crate::files::spec_json::SpecKind`]); `workbench
//! run` runs it into `results/<name>/` ([`export`] has the files).

pub mod export;
pub mod plot;
pub mod shard;

use crate::bq::model::{BmcModel, KernelSpec, ModelSpec};
use crate::error::InputError;
use crate::integrand::envmap::load_map;
use crate::render::env::{Environment, Lookup};
use crate::render::integrator::{Integrator, IntegratorKind, ShadingPoint, check_spp};
use crate::render::scene::Scene;
use crate::render::texel;
use crate::util::geometry::{Frame, Vec3};
use crate::util::report::Reporter;
use crate::util::rng::{splitmix64, stream};
use rayon::prelude::*;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

/// The exact irradiance's absolute tolerance per normal and channel, in units of the map's mean
/// texel value: far below any RMS the protocol reports (SH L4's is ~10⁻² of the mean).
pub const EXACT_TOLERANCE: f64 = 1e-7;

/// Largest grid side accepted.
pub const MAX_GRID: usize = 4096;

/// The `"kind"` of an irradiance file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Irradiance,
}

/// Published errors of other representations on the same map (Probulator's report), for the
/// table and the plot's horizontal lines.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Published {
    /// Spherical harmonics, 9 coefficients.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sh_l2: Option<f64>,
    /// Spherical harmonics, 25 coefficients.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sh_l4: Option<f64>,
    /// Spherical Gaussians, least squares.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sg: Option<f64>,
    /// Where the numbers come from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// An irradiance file as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IrradianceSpec {
    /// The JSON Schema this file follows (`workbench schema irradiance`), for editors; ignored.
    #[serde(rename = "$schema", default, skip_serializing)]
    pub schema: Option<String>,
    /// `"irradiance"`: what tells this kind of file from experiments and render tables.
    pub kind: Kind,
    /// The output folder's name, `results/<name>/`.
    #[schemars(regex(pattern = r"^[A-Za-z0-9_-][A-Za-z0-9._-]*$"), length(max = 100))]
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
    /// A catalogue map (`pisa-256`, `grace`, …) or a `.hdr`/`.exr` file; looked up as Mitsuba does.
    pub env: String,
    /// `[W, H]` normals (default `[256, 128]`, Probulator's).
    #[serde(default = "default_grid")]
    pub grid: [usize; 2],
    /// The sample counts N.
    pub n: Vec<usize>,
    pub seed: u64,
    /// Renderer integrators without a prior mean (`mc`, `mc-cos`, `bmc`, `bmc-sobol`, `bsq`, …),
    /// each optionally with `-fitted` (BMC/BSQ with the fitted kernel, math.md §9).
    pub estimators: Vec<String>,
    /// Published numbers; default: the built-in table for a catalogue map ([`builtin_published`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub published: Option<Published>,
}

fn default_grid() -> [usize; 2] {
    [256, 128]
}

/// Probulator's published errors (its `Reports/<probe>/report.html`, as listed in the data
/// folder's README) for the catalogue's 256×128 probes it was measured on.
pub fn builtin_published(env: &str) -> Option<Published> {
    let source = Some("Probulator (kayru/Probulator, Reports/<probe>/report.html)".to_string());
    match env {
        "pisa-256" => Some(Published {
            sh_l2: Some(0.00510512),
            sh_l4: Some(0.00175382),
            sg: Some(0.0181831),
            source,
        }),
        "grace" => Some(Published {
            sh_l2: Some(0.0132446),
            sh_l4: Some(0.00580368),
            sg: None,
            source,
        }),
        _ => None,
    }
}

/// One estimator of the protocol.
#[derive(Clone, Debug)]
pub struct EstimatorPlan {
    /// As the file names it (`bmc-fitted`).
    pub name: String,
    pub kind: IntegratorKind,
    pub fitted: bool,
}

/// A validated irradiance file.
#[derive(Clone, Debug)]
pub struct IrradiancePlan {
    pub name: String,
    pub title: String,
    pub env_name: String,
    pub width: usize,
    pub height: usize,
    pub n: Vec<usize>,
    pub seed: u64,
    pub estimators: Vec<EstimatorPlan>,
    pub published: Published,
    env: Arc<Environment>,
}

/// Reads and validates an irradiance file (errors name the file and the field).
pub fn load(path: &Path) -> Result<IrradiancePlan, InputError> {
    let text = crate::files::spec_json::read_spec(path)?;
    let file = path.display().to_string();
    let spec: IrradianceSpec = crate::files::spec_json::parse(&text, "the irradiance file")
        .map_err(|m| InputError::new(format!("{file}: {m}")))?;
    resolve(&spec).map_err(|m| InputError::new(format!("{file}: {m}")))
}

/// Checks every value (the map is read here: a missing or altered map is refused before work).
pub fn resolve(spec: &IrradianceSpec) -> Result<IrradiancePlan, String> {
    let name_ok = !spec.name.is_empty()
        && spec.name.len() <= 100
        && !spec.name.starts_with('.')
        && spec
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !name_ok {
        return Err(format!(
            "name: {:?} is not a usable folder name (1 to 100 letters, digits, '-', '_', '.'; no leading '.')",
            spec.name
        ));
    }
    let [w, h] = spec.grid;
    if !(1..=MAX_GRID).contains(&w) || !(1..=MAX_GRID).contains(&h) {
        return Err(format!(
            "grid: [{w}, {h}]: each side must be from 1 to {MAX_GRID}"
        ));
    }
    let counts: Vec<u64> = spec.n.iter().map(|&k| k as u64).collect();
    crate::files::spec_json::check_counts("n", &counts)?;
    if spec.estimators.is_empty() {
        return Err("estimators: give at least one (e.g. \"mc\", \"bmc\")".into());
    }
    let mut estimators = Vec::new();
    for (i, e) in spec.estimators.iter().enumerate() {
        let (base, fitted) = match e.strip_suffix("-fitted") {
            Some(b) => (b, true),
            None => (e.as_str(), false),
        };
        let kind = IntegratorKind::from_name(base)
            .filter(|k| !k.method.uses_prior() && (!fitted || k.uses_sets()))
            .ok_or_else(|| {
                format!(
                    "estimators[{i}]: unknown estimator {e:?}; use a renderer integrator without a prior mean \
                     (mc, mc-cos, bmc, bmc-sobol, bsq, …), estimators with weights optionally with -fitted"
                )
            })?;
        if estimators.iter().any(|x: &EstimatorPlan| x.name == *e) {
            return Err(format!("estimators[{i}]: {e:?} is listed twice"));
        }
        estimators.push(EstimatorPlan {
            name: e.clone(),
            kind,
            fitted,
        });
    }
    let mut n = spec.n.clone();
    for (i, &k) in n.iter().enumerate() {
        for e in &estimators {
            check_spp(e.kind, k, &format!("n[{i}]")).map_err(|m| m.0.to_string())?;
        }
    }
    n.sort_unstable();
    let env = load_map(&spec.env, Lookup::Mitsuba)?;
    let published = spec
        .published
        .clone()
        .or_else(|| builtin_published(&spec.env))
        .unwrap_or_default();
    for (field, v) in [
        ("sh_l2", published.sh_l2),
        ("sh_l4", published.sh_l4),
        ("sg", published.sg),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return Err(format!(
                "published.{field}: must be a positive number, got {}",
                crate::util::shown::shown(v)
            ));
        }
    }
    Ok(IrradiancePlan {
        name: spec.name.clone(),
        title: spec
            .title
            .clone()
            .unwrap_or_else(|| format!("Irradiance under {} (Probulator's protocol)", spec.env)),
        env_name: spec.env.clone(),
        width: w,
        height: h,
        n,
        seed: spec.seed,
        estimators,
        published,
        env,
    })
}

/// What `validate` prints.
pub fn describe(plan: &IrradiancePlan) -> String {
    format!(
        "{}: irradiance protocol under {} on a {}×{} grid of normals; estimators {}; N = {}\n",
        plan.name,
        plan.env_name,
        plan.width,
        plan.height,
        plan.estimators
            .iter()
            .map(|e| e.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        plan.n
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The normal of grid cell `(i, j)`: `ψ = 2π(i + ½)/W`, `θ = π(j + ½)/H`,
/// `n = (sin θ sin ψ, cos θ, −sin θ cos ψ)` (the map's own angles, math.md §10).
pub fn normal(i: usize, j: usize, w: usize, h: usize) -> Vec3 {
    let psi = std::f64::consts::TAU * (i as f64 + 0.5) / w as f64;
    let theta = std::f64::consts::PI * (j as f64 + 0.5) / h as f64;
    Vec3::new(theta.sin() * psi.sin(), theta.cos(), -theta.sin() * psi.cos())
}

/// One row of the results: an estimator at one N.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub estimator: usize,
    pub n: usize,
    /// Per channel RMS over the grid.
    pub rms_channel: [f64; 3],
    /// `√(mean over channels of the per-channel MSE)`.
    pub rms: f64,
}

/// The exact irradiance over the grid (row-major, `j` outer) and the largest error estimate.
pub struct Exact {
    pub values: Vec<[f64; 3]>,
    pub max_error: f64,
}

impl IrradiancePlan {
    /// The published numbers given, named as the table and the plot name them.
    pub fn published_lines(&self) -> Vec<(&'static str, f64)> {
        let p = &self.published;
        [
            ("SH L2 (9 coefficients)", p.sh_l2),
            ("SH L4 (25 coefficients)", p.sh_l4),
            ("spherical Gaussians (least squares)", p.sg),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect()
    }

    fn map(&self) -> &crate::render::env::EnvMap {
        match self.env.as_ref() {
            Environment::Map(m) => m,
            _ => unreachable!("load_map returns maps only"),
        }
    }

    /// The absolute tolerance of the exact irradiance.
    pub fn exact_tolerance(&self) -> f64 {
        let m = self.map();
        let mut sum = 0.0;
        for r in 0..m.height {
            for c in 0..m.width {
                sum += m.texel(r, c).iter().map(|&v| v as f64).sum::<f64>();
            }
        }
        EXACT_TOLERANCE * (sum / (3 * m.width * m.height) as f64).max(f64::MIN_POSITIVE)
    }

    fn point(&self, k: usize) -> ShadingPoint {
        ShadingPoint {
            origin: Vec3::zeros(),
            frame: Frame::from_normal(normal(k % self.width, k / self.width, self.width, self.height)),
            albedo: [1.0; 3],
        }
    }

    /// The number of normals, `W·H`; normal `k` is grid cell `(k mod W, ⌊k / W⌋)`.
    pub fn normals(&self) -> usize {
        self.width * self.height
    }

    /// The content of the map (its size and a hash of its texels, [`Environment::key`]): what a
    /// shard's identity adds to [`plan_hash`], so that shards of another map under the same
    /// name are never merged.
    pub fn map_key(&self) -> String {
        self.env.key()
    }

    /// One rule per (N, estimator), in (N, estimator) order: one set drawn from the seed and N
    /// ([`Integrator::build`] with one set), rotated per normal when used.
    pub fn rules(&self) -> crate::Result<Vec<Integrator>> {
        let default_model = ModelSpec::default()
            .resolve()
            .expect("the default model resolves")
            .build();
        let fitted_model = ModelSpec {
            kernel: Some(KernelSpec::Fitted { grid: None }),
            ..Default::default()
        }
        .resolve()
        .expect("the default fitted model resolves")
        .build();
        let mut rules = Vec::with_capacity(self.n.len() * self.estimators.len());
        for &n in &self.n {
            for est in &self.estimators {
                let model: &BmcModel = if est.fitted { &fitted_model } else { &default_model };
                let set_seed = splitmix64(splitmix64(self.seed) ^ n as u64);
                rules.push(Integrator::build(est.kind, n, 1, true, Some(model), set_seed)?);
            }
        }
        Ok(rules)
    }

    /// Normal `k`'s numbers: `E(n)` by the texel sum (to `tolerance`, [`Self::exact_tolerance`])
    /// and every rule's estimate, MC drawing from the normal's own stream `(seed, N, k)` — so
    /// they do not depend on which normals are computed together, or in which order.
    pub fn normal_values(
        &self,
        k: usize,
        rules: &[Integrator],
        tolerance: f64,
        scene: &Scene,
    ) -> NormalValues {
        let point = self.point(k);
        let q = texel::irradiance(point.frame.n, &self.env, self.map(), tolerance);
        let ne = self.estimators.len();
        let estimates = rules
            .iter()
            .enumerate()
            .map(|(r, rule)| {
                let n = self.n[r / ne];
                let mut rng = stream(self.seed, &[n as u64, k as u64]);
                rule.estimate(&point, scene, &self.env, &mut rng, [0.0; 3])
            })
            .collect();
        NormalValues {
            exact: q.value,
            error: q.error,
            estimates,
        }
    }

    /// The values of the normals `normals`, in parallel (in the caller's pool), in order.
    pub fn values(
        &self,
        normals: &[usize],
        rules: &[Integrator],
        tolerance: f64,
        reporter: &dyn Reporter,
    ) -> Vec<NormalValues> {
        let scene = texel::unoccluded();
        normals
            .par_iter()
            .map(|&k| {
                let v = self.normal_values(k, rules, tolerance, &scene);
                reporter.advance(1);
                v
            })
            .collect()
    }
}

/// One normal's numbers: the exact irradiance, its error estimate, and every (N, estimator)'s
/// estimate in (N, estimator) order.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalValues {
    pub exact: [f64; 3],
    pub error: f64,
    pub estimates: Vec<[f64; 3]>,
}

/// The results, from every normal's values taken in grid order (`k = 0, 1, …`): the sums of
/// squared errors are added in that order whether the normals come from one run, a resumed
/// run's log or the shards' logs, so the RMS are the same bytes.
pub struct Totals {
    values: Vec<[f64; 3]>,
    max_error: f64,
    sq: Vec<[f64; 3]>,
}

impl Totals {
    pub fn new(plan: &IrradiancePlan) -> Totals {
        Totals {
            values: Vec::with_capacity(plan.normals()),
            max_error: 0.0,
            sq: vec![[0.0; 3]; plan.n.len() * plan.estimators.len()],
        }
    }

    /// Adds the next normal.
    pub fn push(&mut self, v: &NormalValues) {
        self.values.push(v.exact);
        self.max_error = self.max_error.max(v.error);
        for (sq, got) in self.sq.iter_mut().zip(&v.estimates) {
            for c in 0..3 {
                let d = got[c] - v.exact[c];
                sq[c] += d * d;
            }
        }
    }

    /// The exact irradiance and the rows in (N, estimator) order; every normal must be in.
    pub fn finish(self, plan: &IrradiancePlan) -> (Exact, Vec<Row>) {
        assert_eq!(self.values.len(), plan.normals(), "every normal is added");
        let count = plan.normals() as f64;
        let ne = plan.estimators.len();
        let rows = self
            .sq
            .iter()
            .enumerate()
            .map(|(r, sq)| {
                let mse = sq.map(|s| s / count);
                Row {
                    estimator: r % ne,
                    n: plan.n[r / ne],
                    rms_channel: mse.map(f64::sqrt),
                    rms: (mse.iter().sum::<f64>() / 3.0).sqrt(),
                }
            })
            .collect();
        (
            Exact {
                values: self.values,
                max_error: self.max_error,
            },
            rows,
        )
    }
}

/// The hash of what determines the results (name, map, grid, N, seed, estimators, published
/// numbers; FNV-1a of their JSON, hex): `reproduce`'s key for earlier timings and its built-in
/// estimate.
pub fn plan_hash(plan: &IrradiancePlan) -> String {
    let v = serde_json::json!({
        "name": plan.name, "env": plan.env_name, "grid": [plan.width, plan.height], "n": plan.n,
        "seed": plan.seed, "estimators": plan.estimators.iter().map(|e| e.name.clone()).collect::<Vec<_>>(),
        "published": plan.published,
    });
    crate::util::hash::fnv1a_hex(serde_json::to_vec(&v).expect("serialisable"))
}

/// What a run wrote.
pub struct Report {
    pub out_dir: std::path::PathBuf,
    pub rows: Vec<Row>,
    pub wall_seconds: f64,
    pub threads: usize,
    /// Units (rows of the grid) read back from the log of an interrupted run.
    pub resumed: usize,
}

/// Runs the protocol and writes `out` ([`export`]); everything that can be refused is refused
/// before the work. The normals' values go to `out/irradiance.partial.csv` as they are computed
/// ([`shard`]); with `resume`, the units that log holds are read back instead of computed.
pub fn run(
    plan: &IrradiancePlan,
    out: &Path,
    spec_path: Option<&Path>,
    threads: Option<usize>,
    resume: bool,
    names: &crate::job::SettingNames,
    reporter: &dyn Reporter,
) -> crate::Result<Report> {
    use crate::files::result_folder::ResultFolder;
    let inputs: Vec<(&str, &Path)> = spec_path.iter().map(|p| ("the irradiance file", *p)).collect();
    let mut folder = ResultFolder::prepare(
        out,
        &out.display().to_string(),
        &format!("use another {}", names.out),
        &inputs,
        export::legacy_manifest_files,
    )?;
    let pool = crate::util::threads::pool(threads)?;
    let threads = pool.current_num_threads();
    let start = std::time::Instant::now();
    let log = folder.partial_path(shard::PARTIAL_LOG)?;
    let mut totals = Totals::new(plan);
    let resumed = pool.install(|| {
        shard::compute(
            plan,
            crate::job::Shard::WHOLE,
            &log,
            resume,
            names,
            reporter,
            &mut |v| totals.push(v),
        )
    })?;
    let (exact, rows) = totals.finish(plan);
    let wall_seconds = start.elapsed().as_secs_f64();
    export::write(&mut folder, plan, &exact, &rows)?;
    folder.commit(
        export::manifest(plan, &exact, &rows),
        serde_json::json!({ "wall_seconds": wall_seconds, "threads": threads, "plan_hash": plan_hash(plan) }),
    )?;
    Ok(Report {
        out_dir: out.to_path_buf(),
        rows,
        wall_seconds,
        threads,
        resumed,
    })
}
