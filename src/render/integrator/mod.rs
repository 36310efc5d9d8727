//! Estimators of a pixel's illumination integral (render-scene.md, "Shading"):
//!
//! `L_o = ∫_{H(n)} f(ω) dω`, `f(ω) = L_i(ω) · (albedo/π) · (ω·n)` per colour channel,
//! with `L_i(ω) = env(ω)` when the ray from `x + 1e-4 n` towards `ω` escapes and 0 otherwise.
//!
//! The estimators are the experiments' own ([`crate::bq::estimator::Method`]), applied once per
//! channel to the integrand's values at the pixel's sample directions: a new estimator is a
//! render integrator as soon as it is a [`Method`]. What the renderer adds is where the samples
//! come from — fresh per pixel for MC ([`Density::Uniform`] or [`Density::Cosine`]), re-used
//! rotated sets for estimators with weights ([`sets`]) — and, for estimators with a prior mean,
//! the checkerboard neighbours that supply it ([`neighbours`]).

pub mod light;
pub mod neighbours;
pub mod pss;
pub mod sets;

use super::env::Environment;
use super::scene::{Hit, Rgb, Scene};
use crate::bq::estimator::bq_pss::{PssOptions, PssWeights};
use crate::bq::estimator::mis::{Heuristic, LightEstimator, LightMethod};
use crate::bq::estimator::{Method, Uncertainty};
use crate::bq::kernel::primary::SobolevOrder;
use crate::bq::model::BmcModel;
use crate::bq::rule::{Rule, Values};
use crate::bq::weights::Solved;
use crate::bq::weights::{BmcWeights, Scale};
use crate::error::InputError;
use crate::sampling::primary::Sampler;
use crate::sampling::{Density, Design};
use crate::util::geometry::{Frame, Vec3};
use crate::util::rng::WorkbenchRng;
pub use neighbours::NeighbourPrior;
pub use pss::PssSets;
pub use sets::{BmcSets, SampleSet};
use std::f64::consts::PI;

/// A render integrator: an estimator, the density of its fresh samples (MC only) and the design
/// of its weighted sample sets (estimators with weights only).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct IntegratorKind {
    pub method: Method,
    /// The density of MC's fresh samples (uniform for the estimators with weights).
    pub density: Density,
    /// How the weighted sample sets are drawn: independent uniform points
    /// ([`Design::Iid`]`(Uniform)`, the default and the only one for MC) or rings
    /// ([`Design::Rings`], weights by the `J × J` ring solver, [`crate::bq::factor::rings`]).
    pub set_design: Design,
    /// How an estimator with a prior mean (`bmcp`) gets its constant from the neighbours
    /// ([`NeighbourPrior`]); [`NeighbourPrior::Mean`] for every other estimator.
    pub neighbours: NeighbourPrior,
    /// The renderer's baselines (`mc-light`, `mc-bsdf`, `mis` and their options, [`light`]):
    /// the estimator that replaces `method` (then [`Method::Mc`], with cosine `density` for
    /// the figures' markers). None for the estimators of the family.
    pub light: Option<LightEstimator>,
}

impl IntegratorKind {
    /// `mc`: uniform samples, fresh per pixel (math.md §3).
    pub const MC: Self = Self::uniform(Method::Mc);
    /// `mc-cos`: cosine-weighted samples, the standard importance-sampled baseline.
    pub const MC_COS: Self = IntegratorKind {
        method: Method::Mc,
        density: Density::Cosine,
        set_design: UNIFORM_SETS,
        neighbours: NeighbourPrior::Mean,
        light: None,
    };
    /// `bmc`: precomputed sample sets rotated to the normal (math.md §4–5).
    pub const BMC: Self = Self::uniform(Method::Bmc);
    /// `bmcp`: BMC with a constant prior from the checkerboard neighbours (thesis §3.2.5).
    pub const BMCP: Self = Self::uniform(Method::Bmcp);
    /// `bmcp-edge`: BMCP whose neighbour prior is weighted by normal and depth similarity
    /// ([`NeighbourPrior::EdgeAware`]).
    pub const BMCP_EDGE: Self = IntegratorKind {
        method: Method::Bmcp,
        density: Density::Uniform,
        set_design: UNIFORM_SETS,
        neighbours: NeighbourPrior::EdgeAware,
        light: None,
    };

    const fn uniform(method: Method) -> Self {
        IntegratorKind {
            method,
            density: Density::Uniform,
            set_design: UNIFORM_SETS,
            neighbours: NeighbourPrior::Mean,
            light: None,
        }
    }

    /// A renderer's baseline ([`light`]).
    pub const fn light(estimator: LightEstimator) -> Self {
        IntegratorKind {
            method: Method::Mc,
            density: Density::Cosine,
            set_design: UNIFORM_SETS,
            neighbours: NeighbourPrior::Mean,
            light: Some(estimator),
        }
    }

    /// The renderer's baselines ([`LightMethod::BASELINES`]), in the order of the docs:
    /// `mc-light`, `mc-bsdf`, then `mis` with the power heuristic, with the balance heuristic,
    /// each without and with compensation; all of these first on independent, then on Sobol
    /// primary samples.
    pub fn light_baselines() -> Vec<Self> {
        let mut all = Vec::new();
        for sampler in Sampler::ALL {
            for method in LightMethod::BASELINES {
                let options: &[(Heuristic, bool)] = match method {
                    LightMethod::Mis => &[
                        (Heuristic::Power, false),
                        (Heuristic::Balance, false),
                        (Heuristic::Power, true),
                        (Heuristic::Balance, true),
                    ],
                    _ => &[(Heuristic::Power, false)],
                };
                for &(heuristic, compensation) in options {
                    all.push(Self::light(LightEstimator {
                        method,
                        heuristic,
                        compensation,
                        sampler,
                        pss: Default::default(),
                    }));
                }
            }
        }
        all
    }

    /// The Bayesian quadratures that compose with light sampling ([`LightMethod::QUADRATURES`],
    /// math.md §11 (a)), in the order of the docs: `bq-pss` of kernel order 1, then 2, each with
    /// the weights `bmc`, `bsq`, `equal`, `cv`, first on Sobol (its default sampler, as in `run`),
    /// then on independent primary samples ([`pss`]).
    pub fn light_quadratures() -> Vec<Self> {
        let mut all = Vec::new();
        for sampler in [Sampler::Sobol, Sampler::Uniform] {
            for order in SobolevOrder::ALL {
                for weights in PssWeights::ALL {
                    all.push(Self::light(LightEstimator {
                        method: LightMethod::BqPss,
                        heuristic: Heuristic::default(),
                        compensation: false,
                        sampler,
                        pss: PssOptions { order, weights },
                    }));
                }
            }
        }
        all
    }

    /// Whether the integrator is a light-aware quadrature with precomputed point sets
    /// (`bq-pss`, [`pss`]): it takes `gps` (its number of sets) but no model or rotation.
    pub fn uses_point_sets(self) -> bool {
        self.light.is_some_and(|l| !l.method.is_baseline())
    }

    /// Whether the integrator takes a number of sets (`gps`): the estimators with weights'
    /// hemisphere sets ([`IntegratorKind::uses_sets`]) or `bq-pss`'s point sets.
    pub fn takes_gps(self) -> bool {
        self.uses_sets() || self.uses_point_sets()
    }

    /// Every integrator, in the order of the docs: each estimator of [`Method::ALL`] on
    /// uniform samples, those without weights also on cosine-weighted ones, those with a
    /// prior mean also with the edge-aware neighbour prior; then every estimator with weights
    /// (and neighbour prior) again on the sets of every other design of [`Design::ALL`]
    /// (fibonacci, stratified, sobol, rings).
    pub fn all() -> Vec<Self> {
        let mut all = Vec::new();
        for method in Method::ALL {
            all.push(Self::uniform(method));
            if !method.needs_weights() {
                all.push(IntegratorKind {
                    method,
                    density: Density::Cosine,
                    set_design: UNIFORM_SETS,
                    neighbours: NeighbourPrior::Mean,
                    light: None,
                });
            }
            if method.uses_prior() {
                all.push(IntegratorKind {
                    neighbours: NeighbourPrior::EdgeAware,
                    ..Self::uniform(method)
                });
            }
        }
        // Every other set design the sampling module offers, so that a new design reaches the
        // renderer without an edit here. (I.i.d. designs are MC's densities, not sample sets.)
        let with_sets: Vec<Self> = all.iter().filter(|k| k.uses_sets()).copied().collect();
        for set_design in Design::ALL {
            if set_design == UNIFORM_SETS || matches!(set_design, Design::Iid(_)) {
                continue;
            }
            all.extend(with_sets.iter().map(|k| IntegratorKind { set_design, ..*k }));
        }
        all.extend(Self::light_baselines());
        all.extend(Self::light_quadratures());
        all
    }

    /// The name on the command line and in files: the estimator's, with `-cos` for
    /// cosine-weighted samples, `-edge` for the edge-aware neighbour prior and `-rings` for
    /// ring sample sets (`mc`, `mc-cos`, `bmc`, `bmcp`, `bmcp-edge`, `bsq`, `bmc-rings`,
    /// `bmcp-rings`, `bmcp-edge-rings`, `bsq-rings`). A renderer's baseline is its
    /// estimator's name with `-balance` for the balance heuristic, `-comp` for compensation and
    /// `-sobol` for Sobol primary samples, in that order (`mc-light`, `mis`, `mis-balance`,
    /// `mis-comp`, `mis-balance-comp-sobol`, `mc-bsdf-sobol`). `bq-pss` names the options of
    /// `run`'s spec that differ from their defaults (order 1, weights `bmc`, sampler `sobol`):
    /// `-order2`, then `-bsq`, `-equal` or `-cv`, then `-uniform` (`bq-pss`, `bq-pss-cv`,
    /// `bq-pss-order2-bsq-uniform`).
    pub fn name(self) -> String {
        if let Some(l) = self.light.filter(|l| l.method == LightMethod::BqPss) {
            let mut name = l.method.name().to_string();
            if l.pss.order != SobolevOrder::One {
                name.push_str(&format!("-order{}", l.pss.order.number()));
            }
            if l.pss.weights != PssWeights::Bmc {
                name.push('-');
                name.push_str(l.pss.weights.name());
            }
            if l.sampler != Sampler::Sobol {
                name.push('-');
                name.push_str(l.sampler.name());
            }
            return name;
        }
        if let Some(l) = self.light {
            let mut name = l.method.name().to_string();
            if l.heuristic == Heuristic::Balance {
                name.push_str("-balance");
            }
            if l.compensation {
                name.push_str("-comp");
            }
            if l.sampler == Sampler::Sobol {
                name.push_str("-sobol");
            }
            return name;
        }
        let base = match self.density {
            Density::Uniform => self.method.name().to_string(),
            Density::Cosine => format!("{}-cos", self.method.name()),
        };
        let base = match self.neighbours {
            NeighbourPrior::Mean => base,
            NeighbourPrior::EdgeAware => format!("{base}-edge"),
        };
        match self.set_design {
            UNIFORM_SETS => base,
            other => format!("{base}-{}", other.name()),
        }
    }

    /// Parses [`IntegratorKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::all().into_iter().find(|k| k.name() == name)
    }

    /// The names of [`IntegratorKind::all`], for messages and `--help`.
    pub fn names() -> String {
        Self::names_where(|_| true).join(", ")
    }

    /// The names of the integrators of [`IntegratorKind::all`] for which `keep` holds, in order,
    /// for messages that list what an option accepts.
    pub fn names_where(keep: impl Fn(&Self) -> bool) -> Vec<String> {
        Self::all()
            .into_iter()
            .filter(|k| keep(k))
            .map(Self::name)
            .collect()
    }

    /// Whether the integrator uses BMC sample sets (and so the `gps`/`rotate`/model options).
    pub fn uses_sets(self) -> bool {
        self.method.needs_weights()
    }

    /// The design of the points its estimates use: MC's fresh samples drawn from its density
    /// (uniform or cosine), the sample sets' design for the estimators with weights. This is what
    /// a figure's marker shows ([`crate::plot::faces`]), so cosine MC in a render table
    /// looks as it does in an experiment.
    pub fn design(self) -> Design {
        if self.uses_sets() {
            self.set_design
        } else {
            Design::Iid(self.density)
        }
    }

    /// Whether the integrator can sample adaptively ([`crate::render::adaptive`]): MC always; an
    /// estimator with weights when its sets nest, so that each stage extends the one before it
    /// (uniform sets do, ring sets do not).
    pub fn adaptive(self) -> bool {
        self.light.is_none() && (!self.uses_sets() || self.set_design.is_nested())
    }

    /// The integrators that can sample adaptively, by name, for messages.
    pub fn adaptive_names() -> String {
        Self::names_where(|k| k.adaptive()).join(", ")
    }

    /// Whether the integrator states a posterior sd per pixel and channel (`render --sd-out`):
    /// its estimator has a posterior ([`Method::has_posterior`]), or it is `bq-pss` with kernel
    /// weights (`bmc`, `bsq`; its ablations state a standard error, as MC).
    pub fn has_posterior(self) -> bool {
        match self.light {
            Some(l) => l.method == LightMethod::BqPss && l.pss.weights.needs_kernel(),
            None => self.method.has_posterior(),
        }
    }
}

impl std::fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl serde::Serialize for IntegratorKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

/// The sets of [`IntegratorKind::set_design`] by default: independent uniform points.
const UNIFORM_SETS: Design = Design::Iid(Density::Uniform);

/// Most samples per pixel for MC (ten times the thesis's 3000-spp reference would already take
/// minutes per image).
pub const MAX_MC_SPP: usize = 1_000_000;
/// Sample sets of integrators with weights when none is given.
pub const DEFAULT_GPS: usize = 4;
/// Most sample sets.
pub const MAX_GPS: usize = 1024;

/// Validates the sample count of `kind` (`what` names the option or field): ring sets also
/// need `spp = J·M` with `J` near `√spp` ([`crate::sampling::rings::check`]).
pub fn check_spp(kind: IntegratorKind, spp: usize, what: &str) -> Result<(), InputError> {
    if kind.uses_sets() {
        crate::bq::rule::check_point_count(spp, what)?;
        kind.set_design
            .check_count(spp)
            .map_err(|m| InputError::new(format!("{what}: got {spp} for {kind}; {m}")))
    } else if spp == 0 {
        Err(InputError::new(format!("{what}: must be at least 1, got 0")))
    } else if let Some(Err(m)) = kind.light.map(|l| l.method.check_count(spp)) {
        Err(InputError::new(format!("{what}: got {spp} for {kind}; {m}")))
    } else if kind.uses_point_sets() {
        // Its spp/2 points are factored once per set, as a weight set's are.
        crate::bq::rule::check_point_count(spp / 2, what)
    } else if spp > MAX_MC_SPP {
        Err(InputError::new(format!(
            "{what}: at most {MAX_MC_SPP} samples per pixel, got {spp}"
        )))
    } else {
        Ok(())
    }
}

/// The memory guard of a render with `kind` at `spp` and `gps` sets on a `pixels`-pixel image
/// (issue 30: one estimate, one guard, before anything is allocated): the image and BMCP's
/// first pass (48 bytes a pixel), and for an integrator with sets the one weight set being
/// computed ([`crate::bq::rule::weight_set_bytes`]) plus the factors the sets keep — one per
/// grid model per set for a fitted model, one per set for per-pixel sds (`with_sd`). `what`
/// names the flag or field (`--spp 4096`, `spp`); exit 2 naming it, the bytes and the budget.
pub fn check_memory(
    what: &str,
    kind: IntegratorKind,
    spp: usize,
    gps: usize,
    model: Option<&BmcModel>,
    with_sd: bool,
    pixels: usize,
) -> Result<(), InputError> {
    let image = 48u64.saturating_mul(pixels as u64);
    let image_text = format!("a {pixels}-pixel image");
    if kind.uses_point_sets() {
        let sets = PssSets::bytes(spp / 2, gps);
        return crate::bq::rule::check_memory(
            &format!(
                "{what}: {image_text} and {gps} point sets of {} points for {kind}",
                spp / 2
            ),
            image.saturating_add(sets),
        );
    }
    let Some(model) = model.filter(|_| kind.uses_sets()) else {
        return crate::bq::rule::check_memory(&format!("{what}: {image_text}"), image);
    };
    let exact = model.mode == crate::bq::kernel_mean::KernelMeanMode::Exact;
    let per_set = model.candidates().len() + usize::from(with_sd);
    let kept = (gps as u64).saturating_mul(per_set as u64);
    let mut kept_for = Vec::new();
    if model.is_fitted() {
        kept_for.push("one per set and grid model");
    }
    if with_sd {
        kept_for.push("one per set for the sds");
    }
    let sets = format!(
        "{gps} sample set{} of {spp} points for {kind}",
        if gps == 1 { "" } else { "s" }
    );
    crate::bq::rule::check_factor_memory(
        what,
        &crate::bq::rule::FactorMemory {
            subject: if kept == 0 {
                format!("{sets}, computed one at a time,")
            } else {
                sets
            },
            factor_bytes: crate::bq::rule::weight_set_bytes(spp, kind.set_design, exact),
            kept,
            kept_for: kept_for.join(", "),
            besides: Some((image_text, image)),
        },
    )
}

/// Validates a renderer's baseline against its light (`what` names the option or field): the
/// environment must have power to sample (for any light technique), and `-comp` needs a light
/// that is not constant (Karlík et al.'s compensated density is otherwise empty,
/// [`crate::sampling::light::LightDistribution::has_compensation`]).
pub fn check_light(kind: IntegratorKind, env: &Environment, what: &str) -> Result<(), InputError> {
    let Some(l) = kind.light else { return Ok(()) };
    if l.method != LightMethod::McBsdf && env.light().is_black() {
        return Err(InputError::new(format!(
            "{what}: {kind} samples the light, but the environment {} is black",
            env.key()
        )));
    }
    if l.compensation && !env.light().has_compensation() {
        return Err(InputError::new(format!(
            "{what}: {kind} uses compensation, but the environment {} is constant (mean luminance within 1% of \
             its minimum): the compensated density is empty; use {}",
            env.key(),
            IntegratorKind::light(LightEstimator {
                compensation: false,
                ..l
            })
        )));
    }
    Ok(())
}

/// Validates the number of sample sets.
pub fn check_gps(gps: usize, what: &str) -> Result<(), InputError> {
    if (1..=MAX_GPS).contains(&gps) {
        Ok(())
    } else {
        Err(InputError::new(format!(
            "{what}: must be in 1..={MAX_GPS}, got {gps}"
        )))
    }
}

/// A shading point: the shadow-ray origin `x + offset·n` (the scene's [`RayRule`]), a frame
/// taking `+z` to `n`, the albedo.
///
/// [`RayRule`]: crate::render::scene::RayRule
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint {
    pub origin: Vec3,
    pub frame: Frame,
    pub albedo: Rgb,
}

impl ShadingPoint {
    /// Offset of shadow-ray origins along the normal in the workbench scene.
    pub const EPSILON: f64 = crate::render::scene::workbench::RAYS.offset;

    /// The shading point of a primary hit, shadow rays starting `offset` along the normal.
    pub fn new(hit: &Hit, offset: f64) -> Self {
        ShadingPoint {
            origin: hit.point + hit.normal * offset,
            frame: Frame::from_normal(hit.normal),
            albedo: hit.albedo,
        }
    }

    /// `L_i(ω)` for the local direction `v` (normal `+z`): `env(ω)` if the ray escapes, else 0.
    #[inline]
    pub fn incident(&self, scene: &Scene, env: &Environment, v: &Vec3) -> Rgb {
        let w = self.frame.to_world(v);
        if scene.occluded(&self.origin, &w) {
            [0.0; 3]
        } else {
            env.radiance(&w)
        }
    }

    /// The integrand `f(ω) = L_i(ω) · (albedo/π) · (ω·n)` per channel at the local direction
    /// `v` (so `ω·n = v.z`).
    #[inline]
    pub fn integrand(&self, scene: &Scene, env: &Environment, v: &Vec3) -> Rgb {
        let li = self.incident(scene, env, v);
        self.shade(li, v.z)
    }

    /// The shading formula `L_i · (albedo/π) · cos`, per channel: the one definition shared by
    /// [`ShadingPoint::integrand`] and the exact quadrature ([`crate::render::exact`]).
    #[inline]
    pub fn shade(&self, li: Rgb, cos: f64) -> Rgb {
        [0, 1, 2].map(|c| li[c] * (self.albedo[c] / PI) * cos)
    }

    /// The integrand where the world direction `w` is known to be visible:
    /// `env(w) · (albedo/π) · cos`, `cos = w·n`.
    #[inline]
    pub fn lit(&self, env: &Environment, w: &Vec3, cos: f64) -> Rgb {
        self.shade(env.radiance(w), cos)
    }
}

/// A ready-to-use integrator: the kind, the samples per pixel and, for estimators with weights,
/// the sample sets with their weights (one Cholesky per set, computed before rendering).
#[derive(Clone, Debug)]
pub struct Integrator {
    pub kind: IntegratorKind,
    pub spp: usize,
    /// The weighted sets (exactly when `kind.uses_sets()`).
    pub sets: Option<BmcSets>,
    /// `bq-pss`'s weighted point sets (exactly when `kind.uses_point_sets()`).
    pub pss: Option<PssSets>,
    /// The amplitude of the per-pixel posterior sds, when they are asked for
    /// ([`Integrator::with_uncertainty`]); None renders estimates only.
    pub uncertainty: Option<Scale>,
    /// The shadow rays and pixels estimated so far (shared by clones).
    pub counter: RayCounter,
}

/// Shadow rays traced and pixels estimated by an integrator, summed over threads (a sum, so the
/// count does not depend on the order of work): a render table's rays per pixel.
#[derive(Clone, Debug, Default)]
pub struct RayCounter {
    rays: std::sync::Arc<std::sync::atomic::AtomicU64>,
    pixels: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

impl RayCounter {
    /// One more pixel, which traced `rays` shadow rays.
    #[inline]
    pub fn add(&self, rays: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.rays.fetch_add(rays, Relaxed);
        self.pixels.fetch_add(1, Relaxed);
    }

    /// Mean shadow rays per estimated pixel (0 before any pixel).
    pub fn rays_per_pixel(&self) -> f64 {
        use std::sync::atomic::Ordering::Relaxed;
        let (r, p) = (self.rays.load(Relaxed), self.pixels.load(Relaxed));
        if p == 0 { 0.0 } else { r as f64 / p as f64 }
    }
}

impl Integrator {
    /// MC with uniform (`mc`) or cosine-weighted (`mc-cos`) sampling.
    pub fn mc(density: Density, spp: usize) -> Self {
        Integrator {
            kind: IntegratorKind {
                method: Method::Mc,
                density,
                set_design: UNIFORM_SETS,
                neighbours: NeighbourPrior::Mean,
                light: None,
            },
            spp,
            sets: None,
            pss: None,
            uncertainty: None,
            counter: RayCounter::default(),
        }
    }

    /// Builds the integrator `kind` with `spp` samples; for estimators with weights, `gps`
    /// sample sets of `kind.set_design` drawn from `seed` and weighted under `model` (needed only by those,
    /// so that MC never pays for the kernel-mean table); for `bq-pss`, `gps` point sets of
    /// `spp/2` primary samples drawn from `seed` and weighted once ([`pss`]).
    pub fn build(
        kind: IntegratorKind,
        spp: usize,
        gps: usize,
        rotate: bool,
        model: Option<&BmcModel>,
        seed: u64,
    ) -> crate::Result<Self> {
        let sets = if kind.uses_sets() {
            let model =
                model.ok_or_else(|| InputError::new(format!("integrator {kind}: needs a BMC model")))?;
            Some(BmcSets::generate(spp, gps, rotate, kind.set_design, model, seed)?)
        } else {
            None
        };
        let pss = match kind.light {
            Some(l) if kind.uses_point_sets() => Some(PssSets::generate(&l, spp, gps, seed)?),
            _ => None,
        };
        Ok(Integrator {
            kind,
            spp,
            sets,
            pss,
            uncertainty: None,
            counter: RayCounter::default(),
        })
    }

    /// The same integrator, also stating each pixel's sd per channel ([`Integrator::estimate_with_sd`])
    /// with the amplitude `scale` (math.md §7): the sample sets keep their Cholesky factors
    /// (one more factorisation per set; no estimate changes). MC ignores `scale` (its sd is the
    /// standard error of its mean).
    pub fn with_uncertainty(mut self, scale: Scale, model: Option<&BmcModel>) -> crate::Result<Self> {
        if let Some(sets) = &mut self.sets {
            let model = model
                .ok_or_else(|| InputError::new(format!("integrator {}: needs a BMC model", self.kind)))?;
            sets.keep_solvers(model, scale)?;
        }
        self.uncertainty = Some(scale);
        Ok(self)
    }

    /// The estimate of `L_o` at `p`: the pixel's sample directions (fresh from its stream
    /// `rng`, or a chosen and rotated set), the integrand on them, and the estimator per channel
    /// with the prior constant `prior[c]` (for estimators with a prior mean; zero is none).
    pub fn estimate(
        &self,
        p: &ShadingPoint,
        scene: &Scene,
        env: &Environment,
        rng: &mut WorkbenchRng,
        prior: Rgb,
    ) -> Rgb {
        self.estimate_with_sd(p, scene, env, rng, prior).0
    }

    /// [`Integrator::estimate`] and, with [`Integrator::with_uncertainty`], the uncertainty the
    /// estimator states per channel ([`Method::uncertainty`], exactly as in experiments): for
    /// estimators with weights the posterior sd `sqrt(λ̂ Var₁)` with the amplitude fitted to
    /// this pixel's values in this channel (`ml`: `λ̂ = rᵀQ⁻¹r / dof`, `r = Y − o·1` with `o`
    /// 0 for BMC, the neighbour prior `c` for BMCP, `β̂` for Bayes–Sard, math.md §7–8; `Q⁻¹Y`
    /// by one solve with the set's kept factor for the three channels); for MC the standard
    /// error of its mean (Student-t, `N − 1` degrees of freedom). The estimate is the same
    /// either way.
    pub fn estimate_with_sd(
        &self,
        p: &ShadingPoint,
        scene: &Scene,
        env: &Environment,
        rng: &mut WorkbenchRng,
        prior: Rgb,
    ) -> (Rgb, Option<[Uncertainty; 3]>) {
        if let Some(estimator) = &self.kind.light {
            let (value, sd, rays) =
                light::estimate(estimator, self.pss.as_ref(), self.spp, p, scene, env, rng);
            self.counter.add(rays);
            return (value, self.uncertainty.and(sd));
        }
        let (points, set): (Vec<Vec3>, Option<&SampleSet>) = match &self.sets {
            Some(sets) => {
                let (set, points) = sets.pick(rng);
                (points, Some(set))
            }
            None => (self.kind.density.sample_set(self.spp, rng), None),
        };
        self.counter.add(points.len() as u64);
        let weights: Option<&BmcWeights> = set.map(|s| &s.weights);
        let mut values: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(points.len()));
        for v in &points {
            let f = p.integrand(scene, env, v);
            for c in 0..3 {
                values[c].push(f[c]);
            }
        }
        let method = self.kind.method;
        if let Some(set) = set.filter(|s| !s.fitted.is_empty()) {
            return self.estimate_fitted(set, &points, &values, prior);
        }
        let rule = Rule {
            density: self.kind.density,
            points: &points,
            weights,
            inverse_diagonal: None,
        };
        let Some(scale) = self.uncertainty else {
            return ([0, 1, 2].map(|c| rule.value(method, &values[c], prior[c])), None);
        };
        let n = points.len();
        // Q⁻¹Y for the three channels in one solve (column-major n × 3); not needed for `unit`.
        let solver = set.map(|s| {
            s.solver
                .as_ref()
                .expect("Integrator::with_uncertainty keeps every set's factor")
        });
        let solved: Option<Vec<f64>> = match solver {
            Some(solver) if scale != Scale::Unit => {
                let mut rhs: Vec<f64> = values.iter().flatten().copied().collect();
                solver.factor.solve_columns_in_place(&mut rhs, 3);
                Some(rhs)
            }
            _ => None,
        };
        let rule = Rule {
            inverse_diagonal: solver.and_then(|s| s.inverse_diagonal.as_deref()),
            ..rule
        };
        let estimates = [0, 1, 2].map(|c| {
            let values = Values {
                y: &values[c],
                solved: solved.as_deref().map(|s| Solved::Full(&s[c * n..(c + 1) * n])),
            };
            rule.estimate(method, values, prior[c], scale)
        });
        let estimate = estimates.map(|e| e.value);
        let out = estimates.map(|e| e.uncertainty);
        match out {
            [Some(r), Some(g), Some(b)] => (estimate, Some([r, g, b])),
            _ => (estimate, None),
        }
    }

    /// A fitted model's estimate on a set (math.md §9): the three channels' `Q⁻¹Y` with every
    /// grid model's kept factor, and per channel the model of largest marginal likelihood gives
    /// the estimate and (with [`Integrator::with_uncertainty`]) the sd at the integrator's scale.
    fn estimate_fitted(
        &self,
        set: &SampleSet,
        points: &[Vec3],
        values: &[Vec<f64>; 3],
        prior: Rgb,
    ) -> (Rgb, Option<[Uncertainty; 3]>) {
        let n = points.len();
        let method = self.kind.method;
        let solves: Vec<Vec<f64>> = set
            .fitted
            .iter()
            .map(|c| {
                let mut rhs: Vec<f64> = values.iter().flatten().copied().collect();
                c.solver.factor.solve_columns_in_place(&mut rhs, 3);
                rhs
            })
            .collect();
        let scale = self.uncertainty.unwrap_or(Scale::Unit);
        let estimates = [0, 1, 2].map(|c| {
            let ells: Vec<f64> = set
                .fitted
                .iter()
                .zip(&solves)
                .map(|(m, solve)| {
                    crate::bq::fitted::log_marginal_likelihood(
                        method,
                        &values[c],
                        &solve[c * n..(c + 1) * n],
                        &m.weights,
                        prior[c],
                        m.log_det,
                    )
                    .unwrap_or(f64::NAN)
                })
                .collect();
            let k = crate::bq::fitted::best(&ells);
            let chosen = &set.fitted[k];
            let rule = Rule {
                density: self.kind.density,
                points,
                weights: Some(&chosen.weights),
                inverse_diagonal: chosen.solver.inverse_diagonal.as_deref(),
            };
            let values = Values {
                y: &values[c],
                solved: Some(Solved::Full(&solves[k][c * n..(c + 1) * n])),
            };
            rule.estimate(method, values, prior[c], scale)
        });
        let estimate = estimates.map(|e| e.value);
        match (self.uncertainty, estimates.map(|e| e.uncertainty)) {
            (Some(_), [Some(r), Some(g), Some(b)]) => (estimate, Some([r, g, b])),
            _ => (estimate, None),
        }
    }
}
