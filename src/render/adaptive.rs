//! Adaptive sampling (README, "Adaptive sampling"; intervals of math.md §7): every pixel takes samples in doubling stages `spp₀, 2spp₀, …
//! ≤ max_spp` until the standard deviation its estimator states for **each** colour channel is
//! at most the target `T` (`--target-sd`), or `max_spp` is reached.
//!
//! - `mc`, `mc-cos`: the standard error `s/√N` of the mean of the terms `f/p`, `s` the sample sd,
//!   kept as a running variance (Welford) over the pixel's fresh samples; the samples of a stage
//!   are the first ones of the pixel's stream, so stages are nested.
//! - `bmc`: nested sample sets — `gps` sets of `max_spp` uniform points, each stage the first
//!   `spp` points of its set — with weights `w = Q⁻¹z` and `Var₁ = V̂ − zᵀQ⁻¹z` per stage,
//!   precomputed once from one Cholesky factor per set grown by blocks
//!   ([`crate::bq::factor::nested`]); the sd is `sqrt(λ̂ Var₁)` with the `ml` amplitude
//!   `λ̂ = YᵀQ⁻¹Y / N = ‖L⁻¹Y‖² / N` (math.md §7), whose `L⁻¹Y` a pixel extends stage by stage.
//!
//! What is compared with `T` is the stated sd, not an interval half-width: a calibrated sd `T`
//! puts 95% of errors within `1.96 T`, which is what [`AdaptiveImage::within`] measures against a
//! reference. Like Cycles' adaptive sampler this needs a first stage large enough not to miss
//! features: a pixel whose first samples all see 0 (a small light missed, a full shadow) states
//! sd 0 and stops there.

use super::env::Environment;
use super::image::Image;
use super::integrator::ShadingPoint;
use super::renderer::Renderer;
use super::scene::{Rgb, Scene};
use crate::bq::factor::NotPositiveDefinite;
use crate::bq::factor::nested::NestedCholesky;
use crate::bq::model::BmcModel;
use crate::bq::stages::Tolerance;
use crate::sampling::Design;
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
            stages: Tolerance {
                abs: target_sd,
                max_n: max_spp,
            }
            .stages(first_spp),
        }
    }

    /// The largest stage.
    pub fn max_spp(&self) -> usize {
        *self.stages.last().expect("at least one stage")
    }
}

/// One nested BMC set: its points (local frame) and, per stage, the weights and `Var₁`.
#[derive(Clone, Debug)]
pub struct NestedSet {
    pub points: Vec<Vec3>,
    /// `weights[k]`: `w = Q⁻¹z` of stage `k`'s leading points.
    pub weights: Vec<Vec<f64>>,
    /// `unit_variance[k]`: `max(V̂ − zᵀQ⁻¹z, 0)` of stage `k`.
    pub unit_variance: Vec<f64>,
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
    Mc(Design),
    /// Nested BMC sets, one picked per pixel, rotated by a random azimuth if `rotate`.
    Bmc { sets: Vec<NestedSet>, rotate: bool },
}

impl AdaptiveSampler {
    /// `gps` nested sets of `max_spp` uniform points, set `s` depending only on `(seed, s)`,
    /// each factored once by blocks through the stages; the weights and `Var₁` of every stage
    /// come from the final factor's leading blocks, so with jitter (see
    /// [`crate::bq::factor::nested`]) every stage uses the same `Q + jI`. Returns the sets and the
    /// jitter added (0 when none), for the caller's warning.
    pub fn bmc(
        settings: &AdaptiveSettings,
        gps: usize,
        rotate: bool,
        model: &BmcModel,
        seed: u64,
    ) -> Result<(Self, f64), NotPositiveDefinite> {
        let max = settings.max_spp();
        let diag = model.kernel.diagonal() + model.noise;
        let mut jitter: f64 = 0.0;
        let mut sets = Vec::with_capacity(gps);
        for s in 0..gps as u64 {
            let points = Design::Uniform.sample_set(max, &mut stream(seed, &[NESTED_SET_POINTS, s]));
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
            let mut weights = Vec::new();
            let mut unit_variance = Vec::new();
            for &m in &settings.stages {
                let mut w = z[..m].to_vec();
                factor.solve_leading_in_place(m, &mut w);
                let zw: f64 = z[..m].iter().zip(&w).map(|(a, b)| a * b).sum();
                unit_variance.push((model.prior_variance() - zw).max(0.0));
                weights.push(w);
            }
            let mut rows = Vec::with_capacity(max * (max + 1) / 2);
            for i in 0..max {
                rows.extend((0..=i).map(|k| factor.entry(i, k)));
            }
            sets.push(NestedSet {
                points,
                weights,
                unit_variance,
                rows,
            });
        }
        Ok((AdaptiveSampler::Bmc { sets, rotate }, jitter))
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

    /// The spp map as a scalar image for [`Image::error_png`]: each pixel `[v, v, v] / √3` so
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
/// image does not depend on the thread count. `progress` advances by one per row.
pub fn render(
    renderer: &Renderer,
    sampler: &AdaptiveSampler,
    settings: &AdaptiveSettings,
    seed: u64,
    progress: &dyn Reporter,
) -> AdaptiveImage {
    let w = renderer.width;
    let rows: Vec<Vec<(Rgb, Option<PixelEstimate>)>> = (0..renderer.height)
        .into_par_iter()
        .map(|j| {
            let row = (0..w)
                .map(|i| match renderer.shading_point(i, j) {
                    Some(p) => {
                        let mut rng = stream(seed, &[ADAPTIVE_PIXELS, (j * w + i) as u64]);
                        let e = pixel(&p, &renderer.scene, &renderer.env, sampler, settings, &mut rng);
                        (e.value, Some(e))
                    }
                    None => (renderer.env.radiance(&renderer.camera.ray(i, j)), None),
                })
                .collect();
            progress.advance(1);
            row
        })
        .collect();
    let pixels: Vec<(Rgb, Option<PixelEstimate>)> = rows.into_iter().flatten().collect();
    AdaptiveImage {
        image: Image {
            width: w,
            height: renderer.height,
            data: pixels.iter().map(|p| p.0).collect(),
        },
        spp: pixels.iter().map(|p| p.1.map_or(0, |e| e.spp)).collect(),
        sd: pixels.iter().map(|p| p.1.map_or([0.0; 3], |e| e.sd)).collect(),
        met: pixels.iter().map(|p| p.1.map(|e| e.met)).collect(),
        target_sd: settings.target_sd,
    }
}

/// One pixel's adaptive estimate at shading point `p`.
pub fn pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    sampler: &AdaptiveSampler,
    settings: &AdaptiveSettings,
    rng: &mut WorkbenchRng,
) -> PixelEstimate {
    match sampler {
        AdaptiveSampler::Mc(design) => mc_pixel(p, scene, env, *design, settings, rng),
        AdaptiveSampler::Bmc { sets, rotate } => bmc_pixel(p, scene, env, sets, *rotate, settings, rng),
    }
}

/// MC with a running mean and variance per channel (Welford).
fn mc_pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    design: Design,
    settings: &AdaptiveSettings,
    rng: &mut WorkbenchRng,
) -> PixelEstimate {
    let (mut mean, mut m2) = ([0.0; 3], [0.0; 3]);
    let mut n = 0usize;
    let last = settings.max_spp();
    for &stage in &settings.stages {
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
        let met = sd.iter().all(|&s| s <= settings.target_sd);
        if met || stage == last {
            return PixelEstimate {
                value: mean,
                sd,
                spp: n,
                met,
            };
        }
    }
    unreachable!("the last stage returns")
}

/// BMC on a nested set: the set and azimuth are chosen as the fixed-spp renderer does, the
/// integrand evaluated only on each stage's new points, `L⁻¹Y` extended per stage.
fn bmc_pixel(
    p: &ShadingPoint,
    scene: &Scene,
    env: &Environment,
    sets: &[NestedSet],
    rotate: bool,
    settings: &AdaptiveSettings,
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
    let max = settings.max_spp();
    let mut values: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(max));
    let mut solved: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(max));
    let mut n = 0usize;
    for (k, &stage) in settings.stages.iter().enumerate() {
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
        let w = &set.weights[k];
        let value = [0, 1, 2].map(|c| w.iter().zip(&values[c]).map(|(a, b)| a * b).sum::<f64>());
        // ml amplitude λ̂ = YᵀQ⁻¹Y / N (math.md §7; BMC: residuals r = Y).
        let sd = [0, 1, 2].map(|c| {
            // As crate::bq::weights::fit_amplitude with `ml`, with YᵀQ⁻¹Y = ‖L⁻¹Y‖².
            let lambda = if values[c].iter().all(|&y| y == 0.0) {
                0.0
            } else {
                solved[c].iter().map(|y| y * y).sum::<f64>() / n as f64
            };
            (lambda * set.unit_variance[k]).sqrt()
        });
        let met = sd.iter().all(|&s| s <= settings.target_sd);
        if met || stage == max {
            return PixelEstimate {
                value,
                sd,
                spp: n,
                met,
            };
        }
    }
    unreachable!("the last stage returns")
}
