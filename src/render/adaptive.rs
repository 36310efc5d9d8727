//! Adaptive sampling (docs/guide/render.md, "Adaptive sampling"; intervals of math.md §7): every pixel takes
//! samples in doubling stages `spp₀, 2spp₀, … ≤ max_spp` until the standard deviation its
//! estimator states for **each** colour channel is at most the target `T` (`--target-sd`), or
//! `max_spp` is reached. The stages are walked by [`crate::bq::stages::walk`], the walker the
//! experiments' tolerance estimators use, with [`Target::Sd`].
//!
//! - `mc`, `mc-cos`: the standard error `s/√N` of the mean of the terms `f/p`, `s` the sample sd,
//!   kept as a running variance (Welford) over the pixel's fresh samples; the samples of a stage
//!   are the first ones of the pixel's stream, so stages are nested.
//! - every estimator with weights on uniform sets (`bmc`, `bmcp`, `bmcp-edge`, `bsq`): nested
//!   sample sets — `gps` sets of `max_spp` uniform points, each stage the first `spp` points of
//!   its set — with the weights of every stage precomputed once from one Cholesky factor per set
//!   grown by blocks ([`crate::bq::factor::nested`], [`crate::bq::stages::stage_weights`]); each
//!   stage's estimate and sd come from [`crate::bq::rule::Rule::estimate`] with the `ml`
//!   amplitude `λ̂ = rᵀQ⁻¹r / dof = ‖L⁻¹r‖² / dof` (math.md §7), whose `L⁻¹Y` a pixel extends
//!   stage by stage. An estimator with a prior mean takes it from the checkerboard neighbours of
//!   a first pass, as in fixed-spp renders.
//!
//! What is compared with `T` is the stated sd, not an interval half-width: a calibrated sd `T`
//! puts 95% of errors within `1.96 T`, which is what [`AdaptiveImage::within`] measures against a
//! reference. The walker's guard holds here too (math.md §9): a stage at which some channel's
//! stated sd comes from zero evidence (MC terms all equal, or a fitted amplitude of exactly 0 —
//! typically every sample 0: a small light missed, a full shadow) never stops the pixel, which
//! doubles on; the pixel is counted ([`AdaptiveImage::share_zero_evidence`]). Like Cycles'
//! adaptive sampler the rule still needs a first stage (the pilot, `--spp`) large enough not to
//! miss features where the samples see some variation.

use super::env::Environment;
use super::image::Image;
use super::integrator::neighbours::{edge_aware_prior, first_pass, neighbour_prior};
use super::integrator::{IntegratorKind, NeighbourPrior, ShadingPoint};
use super::renderer::Renderer;
use super::scene::{Rgb, Scene};
use crate::bq::estimator::{Method, Uncertainty};
use crate::bq::factor::NotPositiveDefinite;
use crate::bq::factor::nested::NestedCholesky;
use crate::bq::model::BmcModel;
use crate::bq::rule::{Estimate, Rule, Values};
use crate::bq::stages::{Target, Verdict, doubling, stage_weights, walk};
use crate::bq::weights::Solved;
use crate::bq::weights::{BmcWeights, Scale};
use crate::sampling::Density;
use crate::util::geometry::Vec3;
use crate::util::report::Reporter;
use crate::util::rng::{WorkbenchRng, stream};
use rand::RngExt;
use rayon::prelude::*;
use std::f64::consts::TAU;

/// Stream family of the adaptive per-pixel streams (their own, so a fixed-spp render and an
/// adaptive one do not share draws by accident).
const ADAPTIVE_PIXELS: u64 = 0xada;
/// Stream of the points of nested set `s`: `stream(seed, [NESTED_SET_POINTS, s])`.
const NESTED_SET_POINTS: u64 = 0xada5e7;

/// The first stage (the pilot) when none is given: `render --target-sd` without `--spp`, a
/// table's `adaptive.first_spp`; the experiments' default `min_n` ([`crate::bq::stages::DEFAULT_MIN_N`]).
pub const DEFAULT_FIRST_SPP: usize = crate::bq::stages::DEFAULT_MIN_N;

/// The stopping rule: target sd per channel, the stages.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// The target standard deviation `T` of each channel's estimate (> 0).
    pub target_sd: f64,
    /// `spp₀, 2spp₀, … ≤ max_spp`.
    pub stages: Vec<usize>,
}

impl AdaptiveSettings {
    /// Stages from `first_spp` doubling up to `max_spp` (`first_spp ≤ max_spp`).
    pub fn new(target_sd: f64, first_spp: usize, max_spp: usize) -> Self {
        AdaptiveSettings {
            target_sd,
            stages: doubling(first_spp, max_spp),
        }
    }

    /// The largest stage.
    pub fn max_spp(&self) -> usize {
        *self.stages.last().expect("at least one stage")
    }
}

/// One nested weighted set: its points (local frame), the weights of every stage, and what a
/// pixel needs to extend `L⁻¹Y` stage by stage.
#[derive(Clone, Debug)]
pub struct NestedSet {
    pub points: Vec<Vec3>,
    /// `weights[k]`: the weights, `Q⁻¹1` and diagnostics of stage `k`'s leading points.
    pub weights: Vec<BmcWeights>,
    /// `L⁻¹1` of the largest stage; its leading entries are every earlier stage's own.
    ones_half: Vec<f64>,
    /// The factor of the largest stage, its rows packed (row `i` holds `L[i, ..=i]`, so the
    /// forward substitution a pixel extends runs over contiguous memory); its leading blocks are
    /// the earlier stages' factors.
    rows: Vec<f64>,
}

impl NestedSet {
    /// Row `i` of `L` (`L[i, 0..=i]`).
    #[inline]
    fn row(&self, i: usize) -> &[f64] {
        let start = i * (i + 1) / 2;
        &self.rows[start..start + i + 1]
    }

    /// Extends `y = L⁻¹b` from `y[..from]` to `b.len()` rows.
    fn forward_extend(&self, b: &[f64], y: &mut Vec<f64>, from: usize) {
        y.truncate(from);
        for (i, bi) in b.iter().enumerate().skip(from) {
            let row = self.row(i);
            let dot: f64 = row[..i].iter().zip(y.iter()).map(|(l, v)| l * v).sum();
            y.push((bi - dot) / row[i]);
        }
    }
}

/// Where a pixel's samples come from.
#[derive(Clone, Debug)]
pub enum AdaptiveSampler {
    /// Fresh MC samples from the pixel's stream (uniform or cosine-weighted).
    Mc(Density),
    /// Nested weighted sets for `method`, one picked per pixel, rotated by a random azimuth if
    /// `rotate`; an estimator with a prior mean takes it from the `neighbours` of a first pass.
    Weighted {
        method: Method,
        /// The density each set's points follow (uniform for the uniform sets).
        density: Density,
        sets: Vec<NestedSet>,
        rotate: bool,
        neighbours: NeighbourPrior,
    },
}

impl AdaptiveSampler {
    /// The sampler of integrator `kind` ([`IntegratorKind::adaptive`] must hold): fresh samples for
    /// MC; for an estimator with weights `gps` nested sets of `max_spp` uniform points under
    /// `model`, set `s` depending only on `(seed, s)`, each factored once by blocks through the
    /// stages; the weights of every stage come from the final factor's leading blocks, so with
    /// jitter (see [`crate::bq::factor::nested`]) every stage uses the same `Q + jI`. Returns the
    /// sampler and the jitter added (0 when none), for the caller's warning.
    ///
    /// # Panics
    /// If `kind` has weights and `model` is None.
    pub fn new(
        kind: IntegratorKind,
        settings: &AdaptiveSettings,
        gps: usize,
        rotate: bool,
        model: Option<&BmcModel>,
        seed: u64,
    ) -> Result<(Self, f64), NotPositiveDefinite> {
        if !kind.uses_sets() {
            return Ok((AdaptiveSampler::Mc(kind.density), 0.0));
        }
        let model = model.expect("an estimator with weights has a model");
        let max = settings.max_spp();
        let diag = model.kernel.diagonal() + model.noise;
        let mut jitter: f64 = 0.0;
        let mut sets = Vec::with_capacity(gps);
        for s in 0..gps as u64 {
            let points = kind
                .set_design
                .sample_set(max, &mut stream(seed, &[NESTED_SET_POINTS, s]));
            let soa = crate::bq::kernel::PointsSoa::new(&points);
            let mut factor = NestedCholesky::with_capacity(max);
            for &m in &settings.stages {
                factor.extend_to(m, |j, start, col| {
                    model.kernel.fill_column(&soa, j, start, col);
                    if start == j {
                        col[0] = diag;
                    }
                })?;
            }
            jitter = jitter.max(factor.jitter());
            let z: Vec<f64> = points.iter().map(|p| model.table().z(p.z)).collect();
            let weights = settings
                .stages
                .iter()
                .map(|&m| stage_weights(&factor, m, &z[..m], model.prior_variance()))
                .collect();
            let mut rows = Vec::with_capacity(max * (max + 1) / 2);
            for i in 0..max {
                rows.extend((0..=i).map(|k| factor.entry(i, k)));
            }
            let mut set = NestedSet {
                points,
                weights,
                ones_half: Vec::with_capacity(max),
                rows,
            };
            let mut ones_half = Vec::with_capacity(max);
            set.forward_extend(&vec![1.0; max], &mut ones_half, 0);
            set.ones_half = ones_half;
            sets.push(set);
        }
        let sampler = AdaptiveSampler::Weighted {
            method: kind.method,
            density: kind.set_design.density(),
            sets,
            rotate,
            neighbours: kind.neighbours,
        };
        Ok((sampler, jitter))
    }

    /// Whether the pixels need a prior from a first pass's neighbours.
    fn uses_prior(&self) -> bool {
        match self {
            AdaptiveSampler::Mc(_) => false,
            AdaptiveSampler::Weighted { method, .. } => method.uses_prior(),
        }
    }

    /// The row passes [`render`] makes (two for estimators with a prior), for a progress bar of
    /// `passes() × height` rows.
    pub fn passes(&self) -> usize {
        if self.uses_prior() { 2 } else { 1 }
    }
}

/// A pixel's adaptive estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelEstimate {
    pub value: Rgb,
    /// The stated sd of each channel at the stage it stopped.
    pub sd: Rgb,
    /// Samples used.
    pub spp: usize,
    /// Whether every channel met the target (rather than stopping at `max_spp`).
    pub met: bool,
    /// Whether a stage it walked had zero evidence in some channel (and so did not stop it).
    pub zero_evidence: bool,
}

/// An adaptive render: the image, each pixel's samples (0 for the background) and stated sd.
#[derive(Clone, Debug)]
pub struct AdaptiveImage {
    pub image: Image,
    /// Samples per pixel, row-major; 0 where the primary ray hits nothing.
    pub spp: Vec<usize>,
    /// Stated sd per pixel and channel (0 for the background).
    pub sd: Vec<Rgb>,
    /// Per pixel: did the rule stop it (None for the background)?
    pub met: Vec<Option<bool>>,
    /// Per pixel: did a stage have zero evidence (false for the background)?
    pub zero_evidence: Vec<bool>,
    pub target_sd: f64,
}

impl AdaptiveImage {
    /// Mean samples per hit pixel.
    pub fn mean_spp(&self) -> f64 {
        let hit: Vec<f64> = self
            .met
            .iter()
            .zip(&self.spp)
            .filter(|(m, _)| m.is_some())
            .map(|(_, &s)| s as f64)
            .collect();
        crate::util::stats::mean(&hit)
    }

    /// Share of hit pixels whose every channel met the target before `max_spp`.
    pub fn share_met(&self) -> f64 {
        let hit: Vec<bool> = self.met.iter().flatten().copied().collect();
        hit.iter().filter(|&&m| m).count() as f64 / hit.len().max(1) as f64
    }

    /// Share of hit pixels at least one of whose stages had zero evidence in some channel.
    pub fn share_zero_evidence(&self) -> f64 {
        let hit = self.met.iter().filter(|m| m.is_some()).count();
        self.zero_evidence.iter().filter(|&&z| z).count() as f64 / hit.max(1) as f64
    }

    /// Share of (hit pixel, channel) whose error against `reference` is within `1.96 T`, the 95%
    /// normal interval of an sd `T`: 0.95 if the target is met and the stated sds are
    /// calibrated.
    pub fn within(&self, reference: &Image) -> f64 {
        let bound = 1.959_963_984_540_054 * self.target_sd;
        let (mut hits, mut total) = (0usize, 0usize);
        for ((a, b), m) in self.image.data.iter().zip(&reference.data).zip(&self.met) {
            if m.is_some() {
                for c in 0..3 {
                    total += 1;
                    hits += usize::from((a[c] - b[c]).abs() <= bound);
                }
            }
        }
        hits as f64 / total.max(1) as f64
    }

    /// The spp map as a scalar image for [`crate::render::image::scalar_png`] (its
    /// [`Image::error_norms`] against the black image): each pixel `[v, v, v] / √3` so
    /// that its norm is `v = spp`, drawn against black up to `max_spp` with a colour bar.
    pub fn spp_as_norms(&self) -> (Image, Image) {
        let k = 1.0 / 3f64.sqrt();
        let map = Image {
            width: self.image.width,
            height: self.image.height,
            data: self.spp.iter().map(|&s| [s as f64 * k; 3]).collect(),
        };
        let black = Image {
            width: map.width,
            height: map.height,
            data: vec![[0.0; 3]; map.data.len()],
        };
        (map, black)
    }
}

/// Renders with adaptive sampling; rows in parallel, every pixel from its own stream, so the
/// image does not depend on the thread count. `progress` advances by one per row and pass
/// ([`AdaptiveSampler::passes`]): for an estimator with a prior mean the first pass renders the
/// `(i + j)`-even pixels with prior 0, the second the others with the neighbour prior.
pub fn render(
    renderer: &Renderer,
    sampler: &AdaptiveSampler,
    settings: &AdaptiveSettings,
    seed: u64,
    progress: &dyn Reporter,
) -> AdaptiveImage {
    let w = renderer.width;
    let with_prior = sampler.uses_prior();
    let pass = |prior_of: &(dyn Fn(usize, usize) -> Option<Rgb> + Sync)| -> Vec<Option<PixelEstimate>> {
        let rows: Vec<Vec<Option<PixelEstimate>>> = (0..renderer.height)
            .into_par_iter()
            .map(|j| {
                let row = (0..w)
                    .map(|i| {
                        let prior = prior_of(i, j)?;
                        let p = renderer.shading_point(i, j)?;
                        let mut rng = stream(seed, &[ADAPTIVE_PIXELS, (j * w + i) as u64]);
                        Some(pixel(
                            &p,
                            &renderer.scene,
                            &renderer.env,
                            sampler,
                            settings,
                            prior,
                            &mut rng,
                        ))
                    })
                    .collect();
                progress.advance(1);
                row
            })
            .collect();
        rows.into_iter().flatten().collect()
    };
    let first = pass(&|i, j| (!with_prior || first_pass(i, j)).then_some([0.0; 3]));
    let estimates = match sampler {
        AdaptiveSampler::Weighted { neighbours, .. } if with_prior => {
            let values: Vec<Option<Rgb>> = first.iter().map(|p| p.map(|p| p.value)).collect();
            let geometry = match neighbours {
                NeighbourPrior::Mean => None,
                NeighbourPrior::EdgeAware => Some(renderer.geometry()),
            };
            let (width, height) = (renderer.width, renderer.height);
            let second = pass(&|i, j| {
                (!first_pass(i, j)).then(|| match &geometry {
                    None => neighbour_prior(&values, width, height, i, j),
                    Some(g) => edge_aware_prior(&values, g, width, height, i, j),
                })
            });
            first.iter().zip(second).map(|(a, b)| a.or(b)).collect()
        }
        _ => first,
    };
    let data = estimates
        .iter()
        .enumerate()
        .map(|(k, e)| match e {
            Some(e) => e.value,
            None => renderer.env.radiance(&renderer.camera.ray(k % w, k / w)),
        })
        .collect();
    AdaptiveImage {
        image: Image {
            width: w,
            height: renderer.height,
            data,
        },
        spp: estimates.iter().map(|e| e.map_or(0, |e| e.spp)).collect(),
        sd: estimates.iter().map(|e| e.map_or([0.0; 3], |e| e.sd)).collect(),
        met: estimates.iter().map(|e| e.map(|e| e.met)).collect(),
        zero_evidence: estimates
            .iter()
            .map(|e| e.is_some_and(|e| e.zero_evidence))
            .collect(),
        target_sd: settings.target_sd,
    }
}

/// One pixel's adaptive estimate at shading point `p`, with prior constant `prior` per channel
/// (used by estimators with a prior mean).
pub fn pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    sampler: &AdaptiveSampler,
    settings: &AdaptiveSettings,
    prior: Rgb,
    rng: &mut WorkbenchRng,
) -> PixelEstimate {
    match sampler {
        AdaptiveSampler::Mc(design) => mc_pixel(p, scene, env, *design, settings, rng),
        AdaptiveSampler::Weighted {
            method,
            density,
            sets,
            rotate,
            ..
        } => weighted_pixel(
            p,
            scene,
            env,
            (*method, *density),
            sets,
            *rotate,
            settings,
            prior,
            rng,
        ),
    }
}

/// MC with a running mean and variance per channel (Welford).
fn mc_pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    design: Density,
    settings: &AdaptiveSettings,
    rng: &mut WorkbenchRng,
) -> PixelEstimate {
    let target = Target::Sd(settings.target_sd);
    let (mut mean, mut m2) = ([0.0; 3], [0.0; 3]);
    let mut n = 0usize;
    let stop = walk(&settings.stages, |stage| {
        while n < stage {
            let v = design.sample(rng);
            let f = p.integrand(scene, env, &v);
            let pdf = design.pdf(&v);
            n += 1;
            for c in 0..3 {
                let x = f[c] / pdf;
                let d = x - mean[c];
                mean[c] += d / n as f64;
                m2[c] += d * (x - mean[c]);
            }
        }
        let sd = m2.map(|s| {
            if n > 1 {
                (s / (n - 1) as f64 / n as f64).sqrt()
            } else {
                f64::INFINITY
            }
        });
        // With one sample the sd is infinite (no interval), not zero evidence.
        let verdict = Verdict::all(sd.map(|sd| {
            target.judge(Some(&Uncertainty {
                sd,
                dof: Some(n - 1),
                amplitude: None,
            }))
        }));
        Ok::<_, std::convert::Infallible>(((mean, sd), verdict))
    });
    let Ok(stop) = stop;
    PixelEstimate {
        value: stop.at.0,
        sd: stop.at.1,
        spp: stop.n_used,
        met: stop.met,
        zero_evidence: stop.zero_evidence > 0,
    }
}

/// An estimator with weights on a nested set: the set and azimuth are chosen as the fixed-spp
/// renderer does, the integrand evaluated only on each stage's new points, `L⁻¹Y` extended per
/// stage, and each stage estimated by [`Rule::estimate`] with the `ml` amplitude.
#[allow(clippy::too_many_arguments)]
fn weighted_pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    (method, density): (Method, Density),
    sets: &[NestedSet],
    rotate: bool,
    settings: &AdaptiveSettings,
    prior: Rgb,
    rng: &mut WorkbenchRng,
) -> PixelEstimate {
    let s = if sets.len() > 1 {
        rng.random_range(0..sets.len())
    } else {
        0
    };
    let phi = if rotate { TAU * rng.random::<f64>() } else { 0.0 };
    let (sin, cos) = phi.sin_cos();
    let set = &sets[s];
    let target = Target::Sd(settings.target_sd);
    let max = settings.max_spp();
    let mut values: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(max));
    let mut solved: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(max));
    let (mut n, mut k) = (0usize, 0usize);
    let stop = walk(&settings.stages, |stage| {
        for v in &set.points[n..stage] {
            let f = p.integrand(scene, env, &crate::util::geometry::rotate_about_z_by(v, sin, cos));
            for c in 0..3 {
                values[c].push(f[c]);
            }
        }
        for c in 0..3 {
            set.forward_extend(&values[c], &mut solved[c], n);
        }
        n = stage;
        let rule = Rule {
            density,
            points: &set.points[..n],
            weights: Some(&set.weights[k]),
            inverse_diagonal: None,
        };
        k += 1;
        let estimates: [Estimate; 3] = [0, 1, 2].map(|c| {
            let values = Values {
                y: &values[c],
                solved: Some(Solved::Half {
                    y: &solved[c],
                    ones: &set.ones_half[..n],
                }),
            };
            rule.estimate(method, values, prior[c], Scale::Ml)
        });
        let verdict = Verdict::all(
            (0..3).map(|c| target.judge_stage(estimates[c].uncertainty.as_ref(), &values[c], Scale::Ml)),
        );
        Ok::<_, std::convert::Infallible>((estimates, verdict))
    });
    let Ok(stop) = stop;
    PixelEstimate {
        value: stop.at.map(|e| e.value),
        sd: stop.at.map(|e| e.uncertainty.map_or(f64::INFINITY, |u| u.sd)),
        spp: stop.n_used,
        met: stop.met,
        zero_evidence: stop.zero_evidence > 0,
    }
}
