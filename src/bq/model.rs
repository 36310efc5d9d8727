//! The BMC model as a user writes it — kernel and its parameters, noise, kernel-mean mode —
//! with one parser and named defaults, shared by experiments (`estimators[i]`), render tables
//! (`model`) and the command line (`rule`, `render`).
//!
//! JSON: `"kernel": {"type": "sobolev", "s": 1.4}` or `{"type": "se", "sigma": 1, "length": 0.5}`,
//! `"noise": 0.01`, `"kernel_mean": "exact" | "mc" | "mc-shared"`, `"kernel_mean_samples": 10000`;
//! or a model fitted per weight set over a grid (math.md §9),
//! `"kernel": {"type": "fitted", "grid": {"s": [1.2, 1.6, 2.75, 3.75], "noise": [1e-2, 1e-8]}}`.

use crate::bq::factor::{NotPositiveDefinite, SpdWorkspace};
use crate::bq::kernel::{Kernel, PointsSoa, Sobolev, SquaredExponential};
use crate::bq::kernel_mean::{KernelMeanMode, KernelMeanTable, kernel_means_mc, kernel_means_mc_per_point};
use crate::bq::weights::{BmcWeights, bmc_weights, bmc_weights_on_rings};
use crate::sampling::{Density, Design, Structure};
use crate::util::geometry::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The thesis's observation noise σ_n², the default.
pub const DEFAULT_NOISE: f64 = crate::bq::weights::DEFAULT_NOISE;
/// Default σ_f of the squared-exponential kernel.
pub const DEFAULT_SE_SIGMA: f64 = 1.0;
/// Default length scale of the squared-exponential kernel.
pub const DEFAULT_SE_LENGTH: f64 = 0.5;

/// A BMC model: kernel, noise and kernel-mean mode; turns point sets into weights.
///
/// A fitted model ([`BmcModel::fitted`]) holds its grid's models as [`BmcModel::candidates`];
/// its own kernel and noise are the first candidate's and stand for it only where a single
/// model is unavoidable (a kernel-mean table for `V̂`); callers that estimate choose among the
/// candidates per weight set and integrand ([`crate::bq::fitted`]).
#[derive(Clone, Debug)]
pub struct BmcModel {
    pub kernel: Kernel,
    pub noise: f64,
    pub mode: KernelMeanMode,
    /// The grid of a fitted model, in grid order (`s` outer, noise inner); empty for a fixed one.
    candidates: Vec<BmcModel>,
    /// The exact `z(μ)` and `V̂`, tabulated once and shared between threads; used for the
    /// `z_i` in the exact mode, and for `V̂` in both (the MC mode estimates only the `z_i`, as
    /// the thesis did).
    table: Arc<KernelMeanTable>,
}

impl BmcModel {
    /// Builds the model, tabulating `z` once.
    pub fn new(kernel: Kernel, noise: f64, mode: KernelMeanMode) -> Self {
        let table = Arc::new(KernelMeanTable::new(&kernel));
        BmcModel {
            kernel,
            noise,
            mode,
            candidates: Vec::new(),
            table,
        }
    }

    /// A model fitted per weight set over `candidates` (math.md §9), each with exact kernel
    /// means.
    ///
    /// # Panics
    /// With no candidates.
    pub fn fitted(candidates: Vec<BmcModel>) -> Self {
        let first = candidates.first().expect("a fitted model has candidates").clone();
        BmcModel { candidates, ..first }
    }

    /// The grid of a fitted model (empty for a fixed model).
    pub fn candidates(&self) -> &[BmcModel] {
        &self.candidates
    }

    /// Whether the model is fitted per weight set over a grid.
    pub fn is_fitted(&self) -> bool {
        !self.candidates.is_empty()
    }

    /// A short name of a fixed model for tables: `s=2.75 noise=1e-8` (Sobolev) or
    /// `se(sigma=1, length=0.5) noise=0.01`.
    pub fn label(&self) -> String {
        match &self.kernel {
            Kernel::Sobolev(k) => format!("s={} noise={:e}", k.s(), self.noise),
            other => format!("{other} noise={:e}", self.noise),
        }
    }

    /// The exact kernel-mean table of the model's kernel.
    pub fn table(&self) -> &KernelMeanTable {
        &self.table
    }

    /// `V̂ = ∫_H ∫_H k dω dω'` (exact).
    pub fn prior_variance(&self) -> f64 {
        self.table.prior_variance()
    }

    /// A warning if the kernel-mean table is less accurate than its target (see
    /// [`KernelMeanTable::accuracy_warning`]) or, for a fixed model or any model of a fitted grid,
    /// a Sobolev kernel's scale is below the noise ([`Sobolev::scale_warning`]); callers report
    /// it.
    pub fn accuracy_warning(&self) -> Option<String> {
        let models = if self.candidates.is_empty() {
            std::slice::from_ref(self)
        } else {
            &self.candidates[..]
        };
        let warnings: Vec<String> = self
            .table
            .accuracy_warning()
            .into_iter()
            .chain(models.iter().filter_map(|m| match &m.kernel {
                Kernel::Sobolev(k) => k.scale_warning(m.noise),
                _ => None,
            }))
            .collect();
        (!warnings.is_empty()).then(|| warnings.join("; "))
    }

    /// The kernel means `z_i` of `points` (points in the local frame, normal `+z`).
    /// `rng` is drawn from only in the MC modes: one `u64` for fresh directions per point
    /// ([`kernel_means_mc_per_point`]), `2M` numbers for shared ones.
    pub fn kernel_means<R: rand::Rng + ?Sized>(&self, points: &[Vec3], rng: &mut R) -> Vec<f64> {
        match self.mode {
            KernelMeanMode::Exact => points.iter().map(|p| self.table.z(p.z)).collect(),
            KernelMeanMode::MonteCarlo { samples } => {
                kernel_means_mc_per_point(&self.kernel, points, samples, rng)
            }
            KernelMeanMode::MonteCarloShared { samples } => {
                let dirs = Density::Uniform.sample_set(samples, rng);
                kernel_means_mc(&self.kernel, points, &PointsSoa::new(&dirs))
            }
        }
    }

    /// The weights for `points` drawn with `design`: on a ring set with exact kernel means by
    /// the ring solver ([`bmc_weights_on_rings`]), otherwise dense ([`BmcModel::weights`]).
    pub fn weights_for_design<R: rand::Rng + ?Sized>(
        &self,
        points: &[Vec3],
        design: Design,
        rng: &mut R,
        workspace: &mut SpdWorkspace,
    ) -> Result<BmcWeights, NotPositiveDefinite> {
        match design.structure() {
            Structure::Rings => {
                let z = self.kernel_means(points, rng);
                bmc_weights_on_rings(
                    points,
                    crate::sampling::rings::layout(points.len()),
                    &z,
                    self.prior_variance(),
                    &self.kernel,
                    self.noise,
                    workspace,
                )
            }
            Structure::Plain => self.weights(points, rng, workspace),
        }
    }

    /// The weights for `points`.
    pub fn weights<R: rand::Rng + ?Sized>(
        &self,
        points: &[Vec3],
        rng: &mut R,
        workspace: &mut SpdWorkspace,
    ) -> Result<BmcWeights, NotPositiveDefinite> {
        let z = self.kernel_means(points, rng);
        bmc_weights(
            points,
            &z,
            self.prior_variance(),
            &self.kernel,
            self.noise,
            workspace,
        )
    }
}

/// `{"type": "sobolev", "s": 1.4}`, `{"type": "se", "sigma": 1, "length": 0.5}` or
/// `{"type": "fitted", "grid": {"s": [...], "noise": [...]}}`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(tag = "type", deny_unknown_fields)]
pub enum KernelSpec {
    /// The Sobolev kernel of math.md §4 (1 < s < 2) and §9 (2 < s < 3, 3 < s < 4).
    #[serde(rename = "sobolev")]
    Sobolev {
        /// Smoothness s in (1, 2), (2, 3) or (3, 4); default 1.4.
        #[serde(default)]
        s: Option<f64>,
    },
    /// The squared-exponential kernel σ_f² exp(−‖x − y‖² / (2 l²)).
    #[serde(rename = "se")]
    SquaredExponential {
        /// σ_f in [1e-100, 1e100]; default 1.
        #[serde(default)]
        sigma: Option<f64>,
        /// The length scale l in [0.001, 1e4]; default 0.5.
        #[serde(default)]
        length: Option<f64>,
    },
    /// Sobolev kernels and noises chosen per weight set and integrand by the profiled marginal
    /// likelihood (math.md §9); the grid defaults to s ∈ {1.2, 1.6, 2.75, 3.75} × σ_n² ∈
    /// {1e-2, 1e-8} (`DEFAULT_GRID_S`, `DEFAULT_GRID_NOISE`).
    #[serde(rename = "fitted")]
    Fitted {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        grid: Option<GridSpec>,
    },
}

/// The grid of a fitted model: every `s` with every noise σ_n².
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub s: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<Vec<f64>>,
}

/// [`GridSpec`]'s fields, read by serde's derived reader once the value is known to be an object.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridFields {
    #[serde(default)]
    s: Option<Vec<f64>>,
    #[serde(default)]
    noise: Option<Vec<f64>>,
}

// Read from an object only: serde's derived reader also takes a struct from a list, so
// `"grid": []` was the default grid, where the schema says it is invalid (issue 30).
impl<'de> Deserialize<'de> for GridSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Object;
        impl<'de> serde::de::Visitor<'de> for Object {
            type Value = GridSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("an object with a list \"s\" and/or a list \"noise\"")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<GridSpec, A::Error> {
                let f = GridFields::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(GridSpec {
                    s: f.s,
                    noise: f.noise,
                })
            }
        }
        d.deserialize_map(Object)
    }
}

/// The fitted model's default smoothnesses (math.md §9): two rough kernels (edged integrands)
/// and two smooth ones (analytic integrands).
pub const DEFAULT_GRID_S: [f64; 4] = [1.2, 1.6, 2.75, 3.75];
/// The fitted model's default noises σ_n² (math.md §9): the thesis's and a near-interpolating one.
pub const DEFAULT_GRID_NOISE: [f64; 2] = [1e-2, 1e-8];
/// Most models a grid may hold: each costs a factorisation per weight set.
pub const MAX_GRID_MODELS: usize = 64;

/// How the kernel means are obtained, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum KernelMeanName {
    /// The exact, tabulated `z(μ)` (math.md §4).
    Exact,
    /// The thesis's plain MC estimate of each `z_i`, with fresh directions per point.
    Mc,
    /// Plain MC with one set of directions shared by every `z_i` of a weight set (this
    /// workbench's earlier reading of the thesis; correlated errors, a higher floor).
    #[serde(rename = "mc-shared")]
    McShared,
}

impl KernelMeanName {
    pub fn name(self) -> &'static str {
        match self {
            KernelMeanName::Exact => "exact",
            KernelMeanName::Mc => "mc",
            KernelMeanName::McShared => "mc-shared",
        }
    }
}

/// The model fields as given; `None` means "the default".
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kernel: Option<KernelSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kernel_mean: Option<KernelMeanName>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kernel_mean_samples: Option<u64>,
}

/// Which field of a [`ModelSpec`] a problem is in; each context names it its own way (a JSON
/// path, a command-line flag).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelField {
    Kernel,
    Noise,
    KernelMean,
    KernelMeanSamples,
}

impl ModelField {
    /// The JSON field name.
    pub fn json(self) -> &'static str {
        match self {
            ModelField::Kernel => "kernel",
            ModelField::Noise => "noise",
            ModelField::KernelMean => "kernel_mean",
            ModelField::KernelMeanSamples => "kernel_mean_samples",
        }
    }
}

/// A rejected model value: the field and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub field: ModelField,
    pub message: String,
}

/// A validated model with every default filled in.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedModel {
    /// The kernel (a fitted model: its first candidate's).
    pub kernel: Kernel,
    /// The noise σ_n² (a fitted model: its first candidate's).
    pub noise: f64,
    pub kernel_mean: KernelMeanName,
    pub mode: KernelMeanMode,
    /// A fitted model's grid, `(kernel, noise)` in grid order (`s` outer, noise inner).
    pub grid: Option<Vec<(Kernel, f64)>>,
}

impl ModelSpec {
    /// The given fields, in file order, with their JSON names (for "not used by" messages).
    pub fn given_fields(&self) -> Vec<(ModelField, String)> {
        fn json<T: Serialize>(v: &T) -> String {
            serde_json::to_string(v).expect("model values serialize")
        }
        let mut out = Vec::new();
        if let Some(k) = &self.kernel {
            out.push((ModelField::Kernel, json(k)));
        }
        if let Some(n) = &self.noise {
            out.push((ModelField::Noise, json(n)));
        }
        if let Some(m) = &self.kernel_mean {
            out.push((ModelField::KernelMean, json(m)));
        }
        if let Some(m) = &self.kernel_mean_samples {
            out.push((ModelField::KernelMeanSamples, json(m)));
        }
        out
    }

    /// Checks every value and fills in the defaults: Sobolev `s = 1.4` (SE: σ = 1, l = 0.5),
    /// noise 0.01, exact kernel means (MC: M = 10 000).
    pub fn resolve(&self) -> Result<ResolvedModel, ModelError> {
        let fail = |field, message: String| ModelError { field, message };
        if let Some(KernelSpec::Fitted { grid }) = &self.kernel {
            return self.resolve_fitted(grid.as_ref());
        }
        let kernel = match self.kernel.clone().unwrap_or(KernelSpec::Sobolev { s: None }) {
            KernelSpec::Sobolev { s } => Sobolev::new(s.unwrap_or(Sobolev::DEFAULT_S)).map(Kernel::Sobolev),
            KernelSpec::SquaredExponential { sigma, length } => SquaredExponential::new(
                sigma.unwrap_or(DEFAULT_SE_SIGMA),
                length.unwrap_or(DEFAULT_SE_LENGTH),
            )
            .map(Kernel::SquaredExponential),
            KernelSpec::Fitted { .. } => unreachable!("resolved above"),
        }
        .map_err(|e| fail(ModelField::Kernel, e.to_string()))?;
        let noise = crate::bq::weights::validate_noise(self.noise.unwrap_or(DEFAULT_NOISE))
            .map_err(|m| fail(ModelField::Noise, m))?;
        let kernel_mean = self.kernel_mean.unwrap_or(KernelMeanName::Exact);
        let mode = match kernel_mean {
            KernelMeanName::Exact => {
                if self.kernel_mean_samples.is_some() {
                    return Err(fail(
                        ModelField::KernelMeanSamples,
                        "is only used with \"kernel_mean\": \"mc\" or \"mc-shared\"".into(),
                    ));
                }
                KernelMeanMode::Exact
            }
            KernelMeanName::Mc | KernelMeanName::McShared => {
                let m = self
                    .kernel_mean_samples
                    .unwrap_or(KernelMeanMode::THESIS_SAMPLES as u64);
                let mode = if kernel_mean == KernelMeanName::Mc {
                    KernelMeanMode::monte_carlo(m)
                } else {
                    KernelMeanMode::monte_carlo_shared(m)
                };
                mode.map_err(|msg| fail(ModelField::KernelMeanSamples, msg))?
            }
        };
        Ok(ResolvedModel {
            kernel,
            noise,
            kernel_mean,
            mode,
            grid: None,
        })
    }

    /// A fitted kernel: its grid checked (every `s` a Sobolev smoothness, every noise finite and
    /// ≥ 0, neither list empty) with exact kernel means; the noise comes from the grid.
    fn resolve_fitted(&self, grid: Option<&GridSpec>) -> Result<ResolvedModel, ModelError> {
        let fail = |field, message: String| ModelError { field, message };
        if let Some(noise) = self.noise {
            return Err(fail(
                ModelField::Noise,
                format!(
                    "{noise:?} is not used with a fitted kernel: its noises are the grid's \"noise\" list"
                ),
            ));
        }
        if let Some(mean) = self.kernel_mean.filter(|&m| m != KernelMeanName::Exact) {
            return Err(fail(
                ModelField::KernelMean,
                format!(
                    "{:?} cannot be used with a fitted kernel: the marginal likelihood needs exact kernel means",
                    mean.name()
                ),
            ));
        }
        if self.kernel_mean_samples.is_some() {
            return Err(fail(
                ModelField::KernelMeanSamples,
                "is only used with \"kernel_mean\": \"mc\" or \"mc-shared\"".into(),
            ));
        }
        let s = grid.and_then(|g| g.s.clone()).unwrap_or(DEFAULT_GRID_S.to_vec());
        let noises = grid
            .and_then(|g| g.noise.clone())
            .unwrap_or(DEFAULT_GRID_NOISE.to_vec());
        for (name, list) in [("s", &s), ("noise", &noises)] {
            if list.is_empty() {
                return Err(fail(
                    ModelField::Kernel,
                    format!("grid.{name} is empty; give at least one value or leave it out for the default"),
                ));
            }
        }
        if s.len() * noises.len() > MAX_GRID_MODELS {
            return Err(fail(
                ModelField::Kernel,
                format!(
                    "the grid has {} × {} = {} models; at most {MAX_GRID_MODELS} (each costs a factorisation per weight set)",
                    s.len(),
                    noises.len(),
                    s.len() * noises.len()
                ),
            ));
        }
        let mut models = Vec::with_capacity(s.len() * noises.len());
        for &si in &s {
            let kernel = Sobolev::new(si)
                .map(Kernel::Sobolev)
                .map_err(|e| fail(ModelField::Kernel, format!("grid.s: {e}")))?;
            for &noise in &noises {
                let noise = crate::bq::weights::validate_noise(noise)
                    .map_err(|m| fail(ModelField::Kernel, format!("grid.{m}")))?;
                models.push((kernel, noise));
            }
        }
        let (kernel, noise) = models[0];
        Ok(ResolvedModel {
            kernel,
            noise,
            kernel_mean: KernelMeanName::Exact,
            mode: KernelMeanMode::Exact,
            grid: Some(models),
        })
    }
}

impl ResolvedModel {
    /// The model, with its kernel-mean table (about 10 ms to tabulate).
    pub fn build(&self) -> BmcModel {
        match &self.grid {
            Some(grid) => BmcModel::fitted(
                grid.iter()
                    .map(|&(kernel, noise)| BmcModel::new(kernel, noise, self.mode))
                    .collect(),
            ),
            None => BmcModel::new(self.kernel, self.noise, self.mode),
        }
    }

    /// Whether the model is fitted per weight set over a grid.
    pub fn is_fitted(&self) -> bool {
        self.grid.is_some()
    }

    /// The resolved fields as JSON (kernel with its parameters, noise, kernel mean and, for
    /// MC kernel means, their sample count), for manifests and `validate`.
    pub fn to_json(&self) -> serde_json::Value {
        if let Some(grid) = &self.grid {
            let mut s: Vec<f64> = Vec::new();
            let mut noise: Vec<f64> = Vec::new();
            for (k, n) in grid {
                if let Kernel::Sobolev(k) = k
                    && !s.contains(&k.s())
                {
                    s.push(k.s());
                }
                if !noise.contains(n) {
                    noise.push(*n);
                }
            }
            return serde_json::json!({
                "kernel": {"type": "fitted", "grid": {"s": s, "noise": noise}},
                "kernel_mean": self.kernel_mean,
            });
        }
        let mut json = serde_json::json!({
            "kernel": self.kernel.to_json(),
            "noise": self.noise,
            "kernel_mean": self.kernel_mean,
        });
        if let Some(m) = self.samples() {
            json["kernel_mean_samples"] = m.into();
        }
        json
    }

    /// M for MC kernel means.
    pub fn samples(&self) -> Option<u64> {
        self.mode.samples().map(|m| m as u64)
    }
}
