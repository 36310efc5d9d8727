//! Sampling the hemisphere around `+z` (math.md §2); light and BSDF sampling and primary
//! samples for the renderer's techniques (math.md §11: [`light`], [`bsdf`], [`primary`]).

pub mod bsdf;
pub mod light;
pub mod primary;
pub mod rings;
pub mod sobol;
pub mod stratified;

use crate::util::geometry::Vec3;
use rand::{Rng, RngExt};
use std::f64::consts::{PI, TAU};

/// The density of a single sample direction (what MC divides by).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Density {
    /// `cos θ = u1`, `φ = 2π u2`; pdf `1/(2π)`.
    Uniform,
    /// `cos θ = sqrt(u1)`, `φ = 2π u2`; pdf `cos θ / π`.
    Cosine,
}

impl Density {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Density::Uniform => "uniform",
            Density::Cosine => "cosine",
        }
    }

    /// The direction for the two uniform numbers `u1, u2 ∈ [0, 1)`.
    #[inline]
    pub fn map(self, u1: f64, u2: f64) -> Vec3 {
        let cos_theta = match self {
            Density::Uniform => u1,
            Density::Cosine => u1.sqrt(),
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let (s, c) = (TAU * u2).sin_cos();
        Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
    }

    /// Probability density (per unit solid angle) of direction `w`.
    #[inline]
    pub fn pdf(self, w: &Vec3) -> f64 {
        match self {
            Density::Uniform => 1.0 / TAU,
            Density::Cosine => w.z.max(0.0) / PI,
        }
    }

    /// One direction.
    #[inline]
    pub fn sample<R: Rng + ?Sized>(self, rng: &mut R) -> Vec3 {
        let u1: f64 = rng.random();
        let u2: f64 = rng.random();
        self.map(u1, u2)
    }

    /// `n` independent directions.
    pub fn sample_set<R: Rng + ?Sized>(self, n: usize, rng: &mut R) -> Vec<Vec3> {
        (0..n).map(|_| self.sample(rng)).collect()
    }
}

impl std::fmt::Display for Density {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::stream;

    #[test]
    fn samples_are_unit_vectors_in_the_upper_hemisphere() {
        let mut rng = stream(1, &[]);
        for d in [Density::Uniform, Density::Cosine] {
            for w in d.sample_set(1000, &mut rng) {
                assert!((w.norm() - 1.0).abs() < 1e-14);
                assert!(w.z >= 0.0);
            }
        }
    }

    /// The mean of cos θ is 1/2 under uniform sampling and 2/3 under cosine sampling;
    /// tolerance 5 standard errors (σ² = 1/12 and 1/18 respectively).
    #[test]
    fn cos_theta_moments_match_the_densities() {
        let n = 200_000;
        let mut rng = stream(2, &[]);
        for (d, mean, var) in [
            (Density::Uniform, 0.5, 1.0 / 12.0),
            (Density::Cosine, 2.0 / 3.0, 1.0 / 18.0),
        ] {
            let m: f64 = d.sample_set(n, &mut rng).iter().map(|w| w.z).sum::<f64>() / n as f64;
            let se = (var / n as f64).sqrt();
            assert!((m - mean).abs() < 5.0 * se, "{d}: {m} vs {mean}");
        }
    }
}

/// How a whole point set is drawn: independent points from a density, or a randomised
/// low-discrepancy lattice (math.md §2, "extra designs").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Design {
    /// `n` independent points from a density.
    Iid(Density),
    /// Spherical Fibonacci lattice on the hemisphere with a Cranley–Patterson shift:
    /// `u1 = frac((i + ½)/n + s1)`, `u2 = frac(i/φ + s2)` (φ the golden ratio, `(s1, s2)`
    /// uniform per set), mapped like [`Density::Uniform`]. Each point is uniform on the
    /// hemisphere, so MC on it is unbiased (randomised QMC), while the set is evenly spread:
    /// one point per band `cos θ ∈ [i/n, (i+1)/n)`. Marques et al. (2013) use this lattice for
    /// spherical quadrature.
    Fibonacci,
    /// A jittered `m1 × m2` grid in `(u1, u2)`, mapped like [`Density::Uniform`] (see
    /// [`stratified`]).
    Stratified,
    /// The first `n` points of a 2-D Sobol sequence, Owen-scrambled afresh for every set, mapped
    /// like [`Density::Uniform`] (see [`sobol`]).
    Sobol,
    /// `J` rings of `M` equally spaced azimuths (`N = J·M`), ring heights jittered within
    /// equal-area strata and the whole set randomly rotated (see [`rings`]): a fully symmetric
    /// design, on which BMC solves a `J × J` system per azimuthal frequency instead of the
    /// `N × N` one ([`crate::bq::factor::rings`]).
    Rings,
}

/// The structure of a design's point sets that a factor of `Q` can exploit (math.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Structure {
    /// No structure: a dense Cholesky factor.
    Plain,
    /// `J` rings of `M` equally spaced points ([`rings`]): `Q` is block-circulant, so it
    /// factors as `⌊M/2⌋ + 1` blocks of `J × J` ([`crate::bq::factor::rings`]).
    Rings,
}

impl Design {
    /// Every design, in the order of the docs: the list that the conformance tests walk and
    /// that names are parsed from. A new design is added here and in the matches below (all
    /// exhaustive, so a design not wired everywhere does not compile).
    pub const ALL: [Design; 6] = [
        Design::Iid(Density::Uniform),
        Design::Iid(Density::Cosine),
        Design::Fibonacci,
        Design::Stratified,
        Design::Sobol,
        Design::Rings,
    ];

    /// Parses [`Design::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }

    /// The names of [`Design::ALL`], for messages.
    pub fn names() -> String {
        Self::ALL.map(|d| d.name()).join(", ")
    }

    /// A stable number for seeding the design's random stream (never reuse one).
    pub fn stream_id(self) -> u64 {
        match self {
            Design::Iid(Density::Uniform) => 0,
            Design::Iid(Density::Cosine) => 1,
            Design::Fibonacci => 2,
            Design::Stratified => 3,
            Design::Sobol => 4,
            Design::Rings => 5,
        }
    }

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Design::Iid(d) => d.name(),
            Design::Fibonacci => "fibonacci",
            Design::Stratified => "stratified",
            Design::Sobol => "sobol",
            Design::Rings => "rings",
        }
    }

    /// The density each point follows (what MC divides by).
    pub fn density(self) -> Density {
        match self {
            Design::Iid(d) => d,
            Design::Fibonacci | Design::Stratified | Design::Sobol | Design::Rings => Density::Uniform,
        }
    }

    /// A set of `n` points.
    pub fn sample_set<R: Rng + ?Sized>(self, n: usize, rng: &mut R) -> Vec<Vec3> {
        match self {
            Design::Iid(d) => d.sample_set(n, rng),
            Design::Fibonacci => {
                const INV_GOLDEN: f64 = 0.618_033_988_749_894_9;
                let (s1, s2): (f64, f64) = (rng.random(), rng.random());
                (0..n)
                    .map(|i| {
                        let u1 = ((i as f64 + 0.5) / n as f64 + s1).fract();
                        let u2 = (i as f64 * INV_GOLDEN + s2).fract();
                        Density::Uniform.map(u1, u2)
                    })
                    .collect()
            }
            Design::Stratified => {
                let (m1, m2) = stratified::grid(n);
                (0..n)
                    .map(|k| {
                        let (a, b) = ((k % m1) as f64, (k / m1) as f64);
                        let (j1, j2): (f64, f64) = (rng.random(), rng.random());
                        Density::Uniform.map((a + j1) / m1 as f64, (b + j2) / m2 as f64)
                    })
                    .collect()
            }
            Design::Sobol => primary::sobol_points(n, rng)
                .into_iter()
                .map(|[u1, u2]| Density::Uniform.map(u1, u2))
                .collect(),
            Design::Rings => rings::sample_set(n, rng),
        }
    }

    /// What a factor of `Q` on a set of this design can exploit ([`crate::bq::factor`] asks
    /// this instead of matching on designs): nothing, or the ring layout.
    pub fn structure(self) -> Structure {
        match self {
            Design::Iid(_) | Design::Fibonacci | Design::Stratified | Design::Sobol => Structure::Plain,
            Design::Rings => Structure::Rings,
        }
    }

    /// Whether the first N points are the same whatever the final N, so that a stage can extend
    /// the one before it: i.i.d. points and the Sobol sequence are; the Fibonacci lattice, the
    /// jittered grid and the rings depend on N.
    pub fn is_nested(self) -> bool {
        match self {
            Design::Iid(_) | Design::Sobol => true,
            Design::Fibonacci | Design::Stratified | Design::Rings => false,
        }
    }

    /// Whether `n` points can be drawn with this design: every count can, except for the rings
    /// design (see [`rings::check`]); the message says why not.
    pub fn check_count(self, n: usize) -> Result<(), String> {
        match self {
            Design::Iid(_) | Design::Fibonacci | Design::Stratified | Design::Sobol => Ok(()),
            Design::Rings => rings::check(n).map(|_| ()),
        }
    }
}

impl serde::Serialize for Design {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Design {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Design::from_name(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown design {name:?}; expected one of {}",
                Design::names()
            ))
        })
    }
}

impl std::fmt::Display for Design {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod set_design_tests {
    use super::*;
    use crate::util::rng::stream;

    /// A shifted Fibonacci set has exactly one point in each band `cos θ ∈ [i/n, (i+1)/n)`
    /// and all points are unit vectors on the upper hemisphere.
    #[test]
    fn fibonacci_sets_are_stratified_in_cos_theta() {
        let mut rng = stream(9, &[]);
        for n in [1, 7, 64, 255] {
            let pts = Design::Fibonacci.sample_set(n, &mut rng);
            let mut bands = vec![0; n];
            for p in &pts {
                assert!((p.norm() - 1.0).abs() < 1e-14 && p.z >= 0.0);
                bands[((p.z * n as f64) as usize).min(n - 1)] += 1;
            }
            assert!(bands.iter().all(|&c| c == 1), "n={n}: {bands:?}");
        }
    }
}
