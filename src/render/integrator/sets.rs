//! BMC with re-used sample sets (math.md §4–5, thesis §3.2.4).
//!
//! Each set's points are drawn once in the local frame (normal `+z`) and weighted once
//! (`w = Q⁻¹ z`, one Cholesky per set). At a pixel one set is picked at random, optionally
//! rotated as a whole by a random azimuth about `+z` (a per-sample rotation would move the
//! points away from the locations the weights were computed for), and carried to the normal by
//! the frame. Because the kernel depends on `x·y` only, rotated points keep their weights.

use crate::bq::factor::rings::RingFactor;
use crate::bq::factor::{Factor, NotPositiveDefinite, SpdWorkspace};
use crate::bq::model::BmcModel;
use crate::bq::weights::{BmcWeights, Scale};
use crate::sampling::{Density, Design, Structure, rings};
use crate::util::geometry::Vec3;
use crate::util::rng::{WorkbenchRng, stream};
use rand::RngExt;
use std::f64::consts::TAU;

/// Stream of the points of set `s`: `stream(seed, [SET_POINTS, s])`.
const SET_POINTS: u64 = 0x5e7;
/// Stream of the MC kernel means of set `s` (only in `--kernel-mean mc`).
const SET_KERNEL_MEANS: u64 = 0x5e8;

/// One sample set in the local frame with its BMC weights.
#[derive(Clone, Debug)]
pub struct SampleSet {
    pub points: Vec<Vec3>,
    /// The weights (a fitted model: its first candidate's; the estimate uses the chosen one's).
    pub weights: BmcWeights,
    /// A fitted model's grid on this set (math.md §9), each model with its weights and kept
    /// factor: a pixel solves its values with every one and uses, per channel, the model of
    /// largest marginal likelihood. Empty for a fixed model.
    pub fitted: Vec<FittedCandidate>,
    /// What a pixel's fitted amplitude needs (math.md §7), kept only when per-pixel posterior
    /// sds are asked for ([`BmcSets::keep_solvers`]): 8 N² bytes per uniform set, about
    /// `4 N J` bytes per ring set.
    pub solver: Option<SetSolver>,
}

/// The factorisation of a set's `Q` and, for the `loo` amplitude, `diag(Q⁻¹)`. A rotation
/// about the normal leaves every `k(x_i, x_j)` and so `Q` unchanged (the kernels depend on
/// `x·y` only), so one factor serves every pixel that uses the set.
#[derive(Clone, Debug)]
pub struct SetSolver {
    pub factor: Factor,
    pub inverse_diagonal: Option<Vec<f64>>,
}

/// One model of a fitted grid on a sample set: its weights, the factor of its `Q`, `log det Q`
/// and, for the `loo` amplitude, `diag(Q⁻¹)`.
#[derive(Clone, Debug)]
pub struct FittedCandidate {
    pub weights: BmcWeights,
    pub solver: SetSolver,
    pub log_det: f64,
}

/// The sets ("GPs") of a BMC integrator.
#[derive(Clone, Debug)]
pub struct BmcSets {
    pub sets: Vec<SampleSet>,
    /// Rotate the chosen set by a random azimuth per pixel.
    pub rotate: bool,
    /// How the sets were drawn ([`Design::Iid`]`(Uniform)` or [`Design::Rings`]).
    pub design: Design,
}

impl BmcSets {
    /// `gps` sets of `spp` points each, drawn with `design` (independent uniform points or
    /// rings, [`IntegratorKind::set_design`](super::IntegratorKind::set_design)); set `s`
    /// depends only on `(seed, s)`. A rotated ring set is still a ring set, so its weights
    /// (constant on each ring) hold at every pixel.
    pub fn generate(
        spp: usize,
        gps: usize,
        rotate: bool,
        design: Design,
        model: &BmcModel,
        seed: u64,
    ) -> Result<Self, NotPositiveDefinite> {
        let points = (0..gps as u64)
            .map(|s| design.sample_set(spp, &mut stream(seed, &[SET_POINTS, s])))
            .collect();
        Self::from_design_points(points, rotate, design, model, seed)
    }

    /// Sets with the given local uniform points (normal `+z`).
    pub fn from_points(
        points: Vec<Vec<Vec3>>,
        rotate: bool,
        model: &BmcModel,
        seed: u64,
    ) -> Result<Self, NotPositiveDefinite> {
        Self::from_design_points(points, rotate, Design::Iid(Density::Uniform), model, seed)
    }

    /// Sets with the given local points drawn with `design`, weighted by
    /// [`BmcModel::weights_for_design`] (the ring solver on ring sets).
    fn from_design_points(
        points: Vec<Vec<Vec3>>,
        rotate: bool,
        design: Design,
        model: &BmcModel,
        seed: u64,
    ) -> Result<Self, NotPositiveDefinite> {
        assert!(!points.is_empty(), "at least one sample set");
        let mut ws = SpdWorkspace::new();
        let sets = points
            .into_iter()
            .enumerate()
            .map(|(s, points)| {
                let mut rng = stream(seed, &[SET_KERNEL_MEANS, s as u64]);
                // A fitted model: every grid model's weights and factor, kept (one per model).
                let fitted = model
                    .candidates()
                    .iter()
                    .map(|m| {
                        let weights = m.weights_for_design(&points, design, &mut rng, &mut ws)?;
                        Ok(FittedCandidate {
                            weights,
                            solver: SetSolver {
                                factor: ws.keep_factor(),
                                inverse_diagonal: None,
                            },
                            log_det: ws.log_det(),
                        })
                    })
                    .collect::<Result<Vec<_>, NotPositiveDefinite>>()?;
                let weights = match fitted.first() {
                    Some(first) => first.weights.clone(),
                    None => model.weights_for_design(&points, design, &mut rng, &mut ws)?,
                };
                Ok(SampleSet {
                    points,
                    weights,
                    fitted,
                    solver: None,
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(BmcSets { sets, rotate, design })
    }

    /// Keeps each set's factorisation (and `diag(Q⁻¹)` for `loo`) for per-pixel amplitudes.
    /// `Q` does not depend on the kernel means, so factoring it again (the same assembly and
    /// jitter ladder, hence the same factor) costs one factorisation per set, draws nothing and
    /// changes no weight. Ring sets keep their per-frequency block factors ([`RingFactor`]).
    pub fn keep_solvers(&mut self, model: &BmcModel, scale: Scale) -> Result<(), NotPositiveDefinite> {
        let mut ws = SpdWorkspace::new();
        for set in &mut self.sets {
            if !set.fitted.is_empty() {
                // A fitted model's sets keep every model's factor already.
                for c in &mut set.fitted {
                    c.solver.inverse_diagonal =
                        (scale == Scale::Loo).then(|| c.solver.factor.inverse_diagonal());
                }
                continue;
            }
            let factor = match self.design.structure() {
                Structure::Rings => Factor::Rings(RingFactor::new(
                    &set.points,
                    rings::layout(set.points.len()),
                    &model.kernel,
                    model.noise,
                )?),
                Structure::Plain => {
                    ws.factor_gram(&set.points, &model.kernel, model.noise)?;
                    ws.keep_factor()
                }
            };
            let inverse_diagonal = (scale == Scale::Loo).then(|| factor.inverse_diagonal());
            set.solver = Some(SetSolver {
                factor,
                inverse_diagonal,
            });
        }
        Ok(())
    }

    /// Picks the set and the azimuth for a pixel from its stream: `(set, φ)`, `φ = 0` without
    /// rotation.
    #[inline]
    pub fn choose(&self, rng: &mut WorkbenchRng) -> (usize, f64) {
        let set = choose_set(self.sets.len(), rng);
        let phi = if self.rotate {
            TAU * rng.random::<f64>()
        } else {
            0.0
        };
        (set, phi)
    }

    /// The set for a pixel and its points rotated by the pixel's azimuth (see
    /// [`BmcSets::choose`]); the weights are the set's own.
    pub fn pick(&self, rng: &mut WorkbenchRng) -> (&SampleSet, Vec<Vec3>) {
        let (s, phi) = self.choose(rng);
        let set = &self.sets[s];
        let (sin, cos) = phi.sin_cos();
        let points = set
            .points
            .iter()
            .map(|v| crate::util::geometry::rotate_about_z_by(v, sin, cos))
            .collect();
        (set, points)
    }
}

/// A pixel's set among `count` reused sets, uniform, from its stream; with one set nothing is
/// drawn, so the pixel's later draws are as before. Shared by the hemisphere rules' sets and
/// bq-pss's point sets.
#[inline]
pub fn choose_set(count: usize, rng: &mut WorkbenchRng) -> usize {
    if count > 1 { rng.random_range(0..count) } else { 0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bq::kernel::{Kernel, Sobolev};
    use crate::bq::kernel_mean::KernelMeanMode;
    use crate::bq::weights::DEFAULT_NOISE;

    fn model() -> BmcModel {
        BmcModel::new(
            Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
            DEFAULT_NOISE,
            KernelMeanMode::Exact,
        )
    }

    /// Without rotation a pixel gets a set's own points; with it, the same points turned about
    /// `+z` (same heights, same lengths, not all in place), so the weights still apply.
    #[test]
    fn picked_points_are_the_set_rotated_about_the_normal() {
        let still = BmcSets::generate(30, 2, false, Design::Iid(Density::Uniform), &model(), 9).unwrap();
        let (set, points) = still.pick(&mut stream(1, &[]));
        assert_eq!(&points, &set.points);
        let turning = BmcSets::generate(30, 2, true, Design::Iid(Density::Uniform), &model(), 9).unwrap();
        let (set, points) = turning.pick(&mut stream(1, &[]));
        let mut moved = 0;
        for (p, q) in points.iter().zip(&set.points) {
            assert_eq!(p.z, q.z);
            assert!((p.norm() - 1.0).abs() < 1e-14);
            moved += usize::from((p.x - q.x).abs() > 1e-9);
        }
        assert!(moved > 20, "only {moved} of 30 points moved");
    }
}
