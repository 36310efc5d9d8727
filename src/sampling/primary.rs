//! Primary samples `u ∈ [0, 1)²` (math.md §11, "Samplers"): what a technique `T_t` warps into a
//! direction. Independent uniform points, or the 2-D Sobol sequence Owen-scrambled afresh for
//! every set ([`super::sobol`]): each point is still uniform on `[0, 1)²`, so an estimator that
//! is unbiased on independent points stays unbiased on them (randomised QMC), while the set is a
//! scrambled (0, m, 2)-net.

use super::sobol;
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// How a set of primary samples is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Sampler {
    /// Independent uniform points.
    Uniform,
    /// The first `n` points of the 2-D Sobol sequence, Owen-scrambled with fresh seeds per set.
    Sobol,
}

impl Sampler {
    /// Every sampler, in the order of the docs.
    pub const ALL: [Sampler; 2] = [Sampler::Uniform, Sampler::Sobol];

    /// The name in files.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Uniform => "uniform",
            Sampler::Sobol => "sobol",
        }
    }

    /// A stable number for seeding the sampler's random stream (never reuse one).
    pub fn stream_id(self) -> u64 {
        match self {
            Sampler::Uniform => 0,
            Sampler::Sobol => 1,
        }
    }

    /// `n` primary samples.
    pub fn points<R: Rng + ?Sized>(self, n: usize, rng: &mut R) -> Vec<[f64; 2]> {
        match self {
            Sampler::Uniform => (0..n).map(|_| [rng.random(), rng.random()]).collect(),
            Sampler::Sobol => sobol_points(n, rng),
        }
    }
}

/// The first `n` Sobol points, each coordinate Owen-scrambled with a seed drawn from `rng`
/// (one per coordinate and set); below the 32 scrambled bits, uniform random bits make each
/// coordinate uniform on `[0, 1)` rather than on a `2^−32` grid.
pub fn sobol_points<R: Rng + ?Sized>(n: usize, rng: &mut R) -> Vec<[f64; 2]> {
    let (s1, s2): (u32, u32) = (rng.random(), rng.random());
    let unit = |bits: u32, rng: &mut R| (bits as f64 + rng.random::<f64>()) * 2f64.powi(-32);
    (0..n as u32)
        .map(|i| {
            let u1 = unit(sobol::owen_scramble(sobol::sobol(i, 0), s1), rng);
            let u2 = unit(sobol::owen_scramble(sobol::sobol(i, 1), s2), rng);
            [u1, u2]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::stream;

    /// Every point lies in `[0, 1)²`; a scrambled set of 2^m points has one point in each of the
    /// `2^m` cells of a `2^k × 2^(m−k)` grid; two sets from different streams differ.
    #[test]
    fn sobol_sets_are_nets_in_the_unit_square() {
        let m = 6;
        let n = 1usize << m;
        let a = Sampler::Sobol.points(n, &mut stream(1, &[]));
        let b = Sampler::Sobol.points(n, &mut stream(2, &[]));
        assert_ne!(a, b);
        for k in 0..=m {
            let mut cells = vec![0; n];
            for p in &a {
                assert!((0.0..1.0).contains(&p[0]) && (0.0..1.0).contains(&p[1]));
                let x = (p[0] * (1 << k) as f64) as usize;
                let y = (p[1] * (1 << (m - k)) as f64) as usize;
                cells[x * (1 << (m - k)) + y] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "k = {k}");
        }
    }
}
