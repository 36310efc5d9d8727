//! BMC with re-used sample sets (math.md §4–5, thesis §3.2.4).
//!
//! Each set's points are drawn once in the local frame (normal `+z`) and weighted once
//! (`w = Q⁻¹ z`, one Cholesky per set). At a pixel one set is picked at random, optionally
//! rotated as a whole by a random azimuth about `+z` (a per-sample rotation would move the
//! points away from the locations the weights were computed for), and carried to the normal by
//! the frame. Because the kernel depends on `x·y` only, rotated points keep their weights.

use super::ShadingPoint;
use crate::bmc::{BmcModel, BmcWeights};
use crate::geometry::Vec3;
use crate::linalg::{NotPositiveDefinite, SpdWorkspace};
use crate::render::env::Environment;
use crate::render::scene::{Rgb, Scene};
use crate::rng::{WorkbenchRng, stream};
use crate::sampling::Design;
use rand::RngExt;
use std::f64::consts::{PI, TAU};

/// Stream of the points of set `s`: `stream(seed, [SET_POINTS, s])`.
const SET_POINTS: u64 = 0x5e7;
/// Stream of the MC kernel means of set `s` (only in `--kernel-mean mc`).
const SET_KERNEL_MEANS: u64 = 0x5e8;

/// One sample set in the local frame with its BMC weights.
#[derive(Clone, Debug)]
pub struct SampleSet {
    pub points: Vec<Vec3>,
    pub weights: BmcWeights,
}

/// The sets ("GPs") of a BMC integrator.
#[derive(Clone, Debug)]
pub struct BmcSets {
    pub sets: Vec<SampleSet>,
    /// Rotate the chosen set by a random azimuth per pixel.
    pub rotate: bool,
}

impl BmcSets {
    /// `gps` sets of `spp` uniform points each; set `s` depends only on `(seed, s)`.
    pub fn generate(
        spp: usize,
        gps: usize,
        rotate: bool,
        model: &BmcModel,
        seed: u64,
    ) -> Result<Self, NotPositiveDefinite> {
        let points = (0..gps as u64)
            .map(|s| Design::Uniform.sample_set(spp, &mut stream(seed, &[SET_POINTS, s])))
            .collect();
        Self::from_points(points, rotate, model, seed)
    }

    /// Sets with the given local points (normal `+z`).
    pub fn from_points(
        points: Vec<Vec<Vec3>>,
        rotate: bool,
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
                let weights = model.weights(&points, &mut rng, &mut ws)?;
                Ok(SampleSet { points, weights })
            })
            .collect::<Result<_, _>>()?;
        Ok(BmcSets { sets, rotate })
    }

    /// Picks the set and the azimuth for a pixel from its stream: `(set, φ)`, `φ = 0` without
    /// rotation.
    #[inline]
    pub fn choose(&self, rng: &mut WorkbenchRng) -> (usize, f64) {
        let set = if self.sets.len() > 1 {
            rng.random_range(0..self.sets.len())
        } else {
            0
        };
        let phi = if self.rotate {
            TAU * rng.random::<f64>()
        } else {
            0.0
        };
        (set, phi)
    }

    /// `Î = 2πc + Σ w_i (Y_i − c)` per channel, with `Y_i = f(ω_i)` at the rotated points;
    /// `c = 0` is plain BMC, `Î = Σ w_i Y_i`. Formed as `Σ w_i Y_i + c (2π − Σ w_i)`, the same
    /// sum regrouped so that no per-pixel buffer is needed (checked against
    /// [`BmcWeights::bmcp`] in the tests).
    pub fn estimate(
        &self,
        p: &ShadingPoint,
        scene: &Scene,
        env: &Environment,
        rng: &mut WorkbenchRng,
        prior: Rgb,
    ) -> Rgb {
        let (s, phi) = self.choose(rng);
        let set = &self.sets[s];
        let (sin, cos) = phi.sin_cos();
        let mut sum = [0.0; 3];
        for (v, w) in set.points.iter().zip(&set.weights.weights) {
            let r = crate::geometry::rotate_about_z_by(v, sin, cos);
            let li = p.incident(scene, env, &r);
            let g = w * v.z / PI;
            for c in 0..3 {
                sum[c] += li[c] * g;
            }
        }
        let weight_sum = set.weights.diagnostics.weight_sum;
        [0, 1, 2].map(|c| p.albedo[c] * sum[c] + prior[c] * (TAU - weight_sum))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bmc::DEFAULT_NOISE;
    use crate::kernel::{Kernel, Sobolev};
    use crate::kernel_mean::KernelMeanMode;
    use crate::render::scene::Hit;

    fn model() -> BmcModel {
        BmcModel::new(
            Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
            DEFAULT_NOISE,
            KernelMeanMode::Exact,
        )
    }

    /// The regrouped sum equals `BmcWeights::bmcp` on the explicit values `Y_i`, for `c = 0`
    /// (then also `BmcWeights::bmc`) and `c ≠ 0`.
    #[test]
    fn regrouped_bmcp_equals_the_library_formula() {
        let sets = BmcSets::generate(30, 1, false, &model(), 9).unwrap();
        let hit = Hit {
            t: 1.0,
            point: Vec3::new(0.0, 2.0, 0.0),
            normal: Vec3::new(0.3, 0.9, 0.1).normalize(),
            albedo: [0.8, 0.35, 0.25],
        };
        let p = ShadingPoint::new(&hit);
        let scene = Scene::default_scene();
        let env = Environment::Sky;
        let set = &sets.sets[0];
        for c in [0.0, 0.05, 0.4] {
            let got = sets.estimate(&p, &scene, &env, &mut stream(1, &[]), [c; 3]);
            for (ch, got) in got.iter().enumerate() {
                let y: Vec<f64> = set
                    .points
                    .iter()
                    .map(|v| p.incident(&scene, &env, v)[ch] * p.albedo[ch] / PI * v.z)
                    .collect();
                let want = set.weights.bmcp(&y, c);
                assert!((*got - want).abs() < 1e-12, "c={c} ch={ch}: {} vs {want}", *got);
                if c == 0.0 {
                    assert!((*got - set.weights.bmc(&y)).abs() < 1e-12);
                }
            }
        }
    }
}
