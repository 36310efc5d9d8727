//! `bmc-light`: Bayesian quadrature against the light's measure (math.md §11 (b)).
//!
//! At a shading point `x` with normal `n`, `I_c = ∫_{S²} g(d) L_c(d) dω` with
//! `g(d) = f_r(d) max(0, n·d) V(x, d)` the same for every channel. A GP on `g` with a zonal
//! Sobolev kernel `k` (§9) gives
//!
//! `Î_c = z_cᵀ Q⁻¹ g(X)`,  `Var[I_c | g(X)] = λ (V_cc − z_cᵀ Q⁻¹ z_c)`,
//!
//! `Q = K + σ_n² I` (jitter added only if Cholesky needs it), `z_c(x) = ∫ k(x·d) L_c(d) dω` and
//! `V_ab = ∫∫ k L_a L_b` from [`crate::bq::light_measure`], `λ̂ = g(X)ᵀQ⁻¹g(X) / M` (the `ml`
//! amplitude of §7), Student-t with `M` degrees of freedom. A channel mix `a` (luminance) has
//! `z_a = Σ a_c z_c` and `V_aa = aᵀVa`, so the weights and the 3×3 unit posterior variances
//! `P = V − Zᵀ Q⁻¹ Z` serve every mix.
//!
//! **Design** ([`LightDesign`]): a fixed world-space design of `K` sets of `M` points (the MIS
//! mixture of §11 (b)): the first `⌈M/2⌉` drawn from the map's luminance distribution `p_L`
//! ([`crate::sampling::light`]), the rest uniform on the sphere, each set from its own random
//! stream. Its weights `w_c = Q⁻¹ z_c` are computed once per set and channel (Cholesky, three
//! right-hand sides), never per pixel. A point below a pixel's horizon has `g = 0` without a
//! ray, so a pixel traces one ray per point above its horizon: on average
//! `⌈M/2⌉ P_L(above) + ⌊M/2⌋/2` rays.
//!
//! **Cost and cache.** The kernel means are `M K` sweeps over the map's nodes and the prior
//! variance about 3 000 more ([`crate::bq::light_measure`]); they are cached by the map's
//! content hash, lookup, kernel, `M`, `K`, seed and [`VERSION`] ([`LightDesign::load_or_build`]:
//! written atomically, read back checked). The weights and factors are recomputed from the
//! cached points and means on load (`M³/3` flops a set).
//!
//! **Status.** The core only: no `run` estimator, render integrator or table names it yet
//! (issue 40 leaves that open); the API is what they, and the Python package, will call.

use super::Uncertainty;
use crate::bq::factor::Factor;
use crate::bq::factor::dense::SpdWorkspace;
use crate::bq::kernel::{Kernel, Sobolev};
use crate::bq::light_measure::{LightMeasure, MapNodes};
use crate::render::env::EnvMap;
use crate::util::geometry::Vec3;
use rand::RngExt;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Part of the cache key: change it whenever the design or the quadrature changes.
pub const VERSION: &str = "bmc-light-1";

/// The default smoothness. math.md §11 (b): a first prototype found `s = 1.8` far better than
/// the thesis's 1.4 under a sun (1.07× MIS + Sobol against 2–2.5×) and under Pisa (0.35×); it is
/// also the smoothest Sobolev kernel below the logarithmic limit `s = 2` whose means need no
/// polynomial part. Not tuned here.
pub const DEFAULT_S: f64 = 1.8;
/// The default `σ_n²`: `g` is noise-free; a small nugget keeps the Gram matrix of points drawn
/// close together (a sun's cells) factorable without the jitter ladder.
pub const DEFAULT_NOISE: f64 = 1e-6;

/// `bmc-light`'s options, as bits so that the estimator stays `Eq + Hash`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BmcLightOptions {
    s_bits: u64,
    noise_bits: u64,
}

impl Default for BmcLightOptions {
    fn default() -> Self {
        Self::new(DEFAULT_S, DEFAULT_NOISE)
    }
}

impl BmcLightOptions {
    pub fn new(s: f64, noise: f64) -> Self {
        BmcLightOptions {
            s_bits: s.to_bits(),
            noise_bits: noise.to_bits(),
        }
    }
    pub fn s(&self) -> f64 {
        f64::from_bits(self.s_bits)
    }
    pub fn noise(&self) -> f64 {
        f64::from_bits(self.noise_bits)
    }
    /// The Sobolev kernel.
    pub fn kernel(&self) -> Kernel {
        Kernel::Sobolev(Sobolev::new(self.s()).expect("validated when the estimator was planned"))
    }
}

/// One design set: its points and what the estimator needs of them.
#[derive(Clone, Debug)]
pub struct DesignSet {
    /// World directions.
    pub points: Vec<Vec3>,
    /// `z_c` at each point, per channel.
    pub z: [Vec<f64>; 3],
    /// `w_c = Q⁻¹ z_c`.
    pub weights: [Vec<f64>; 3],
    /// `P = V − Zᵀ Q⁻¹ Z` (3×3, symmetrised).
    pub unit_variance: [[f64; 3]; 3],
    /// The jitter Cholesky needed beyond `σ_n²` (0 mostly).
    pub jitter: f64,
    factor: Factor,
}

/// `K` sets of `M` points for one map and kernel, with the prior variance.
#[derive(Clone, Debug)]
pub struct LightDesign {
    pub kernel: Kernel,
    pub noise: f64,
    /// `V_ab`.
    pub prior_variance: [[f64; 3]; 3],
    /// The outer rule's stated error of `V` ([`crate::bq::light_measure::PriorVariance`]).
    pub prior_variance_error: f64,
    pub sets: Vec<DesignSet>,
}

/// What the cache file holds: the expensive part (points, kernel means, `V`) and its key.
#[derive(Serialize, Deserialize)]
struct Cached {
    key: String,
    points: Vec<Vec<[f64; 3]>>,
    z: Vec<[Vec<f64>; 3]>,
    prior_variance: [[f64; 3]; 3],
    prior_variance_error: f64,
}

/// The design's points of set `set` (module docs): `⌈M/2⌉` from `p_L`, the rest uniform.
pub fn design_points(map: &EnvMap, m: usize, set: usize, seed: u64) -> Vec<Vec3> {
    let light = map.light();
    let mut rng = crate::util::rng::stream(seed, &[0x006c_6967_6874, set as u64]);
    let n_light = if light.is_black() { 0 } else { m.div_ceil(2) };
    (0..m)
        .map(|i| {
            let u = [rng.random::<f64>(), rng.random::<f64>()];
            if i < n_light {
                light.sample(u, false).0
            } else {
                let z = 2.0 * u[0] - 1.0;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f64::consts::TAU * u[1];
                Vec3::new(r * phi.cos(), z, r * phi.sin())
            }
        })
        .collect()
}

impl LightDesign {
    /// The cache key's description: everything the cached numbers depend on.
    pub fn key(map: &EnvMap, kernel: &Kernel, m: usize, k: usize, seed: u64) -> String {
        serde_json::json!({
            "version": VERSION,
            "map": format!("{}x{}:{:016x}", map.width, map.height, map.content_hash()),
            "lookup": map.lookup_kind().name(),
            "kernel": kernel.to_json(),
            "points": m,
            "sets": k,
            "seed": seed,
            "quadrature": {
                "order": crate::bq::light_measure::ORDER,
                "max_spacing": crate::bq::light_measure::MAX_SPACING,
                "near_bands": crate::bq::light_measure::NEAR_BANDS,
                "near_split": crate::bq::light_measure::NEAR_SPLIT,
                "outer_blocks": crate::bq::light_measure::OUTER_BLOCKS,
            },
        })
        .to_string()
    }

    /// Builds the design: `K` sets of `M` points of `map` (under its lookup) for `kernel`
    /// (Sobolev only: the light-measure means are those of a zonal kernel, checked by the
    /// caller) and nugget `noise`. What a Python caller with an RGB array (`EnvMap::from_texels`)
    /// calls.
    pub fn build(map: &EnvMap, kernel: Kernel, noise: f64, m: usize, k: usize, seed: u64) -> Self {
        let lm = LightMeasure::new(kernel, Arc::new(MapNodes::new(map)));
        let pv = lm.prior_variance();
        let points: Vec<Vec<Vec3>> = (0..k).map(|s| design_points(map, m, s, seed)).collect();
        let flat: Vec<&Vec3> = points.iter().flatten().collect();
        let zs: Vec<[f64; 3]> = flat.par_iter().map(|x| lm.kernel_mean(x)).collect();
        let z: Vec<[Vec<f64>; 3]> = zs
            .chunks(m.max(1))
            .map(|c| [0, 1, 2].map(|ch| c.iter().map(|v| v[ch]).collect()))
            .collect();
        Self::assemble(kernel, noise, points, z, pv.value, pv.error)
    }

    /// Weights and factors from points and means (cheap; also what a cache load does).
    fn assemble(
        kernel: Kernel,
        noise: f64,
        points: Vec<Vec<Vec3>>,
        z: Vec<[Vec<f64>; 3]>,
        prior_variance: [[f64; 3]; 3],
        prior_variance_error: f64,
    ) -> Self {
        let sets = points
            .into_iter()
            .zip(z)
            .map(|(pts, z)| {
                let n = pts.len();
                let mut ws = SpdWorkspace::new();
                let info = ws
                    .factor_entries(n, |i, j| {
                        kernel.eval(&pts[i], &pts[j]) + if i == j { noise } else { 0.0 }
                    })
                    .expect("a Sobolev Gram matrix with a nugget factors with the jitter ladder");
                let mut rhs: Vec<f64> = z.iter().flatten().copied().collect();
                let factor = ws.keep_factor();
                factor.solve_columns_in_place(&mut rhs, 3);
                let weights: [Vec<f64>; 3] = [0, 1, 2].map(|c| rhs[c * n..(c + 1) * n].to_vec());
                let mut p = [[0.0; 3]; 3];
                for a in 0..3 {
                    for b in 0..3 {
                        let zw = |x: usize, y: usize| -> f64 {
                            z[x].iter().zip(&weights[y]).map(|(u, v)| u * v).sum()
                        };
                        p[a][b] = prior_variance[a][b] - 0.5 * (zw(a, b) + zw(b, a));
                    }
                }
                DesignSet {
                    points: pts,
                    z,
                    weights,
                    unit_variance: p,
                    jitter: info.jitter,
                    factor,
                }
            })
            .collect();
        LightDesign {
            kernel,
            noise,
            prior_variance,
            prior_variance_error,
            sets,
        }
    }

    /// The cache file of a design under `dir`.
    pub fn cache_path(dir: &Path, key: &str) -> PathBuf {
        dir.join(format!(
            "light-design-{}.json",
            crate::util::hash::fnv1a_hex(key.bytes())
        ))
    }

    /// [`LightDesign::build`], read from `dir` when a sound entry with the same key is there,
    /// written there atomically otherwise (no cache without a `dir`). A damaged or foreign entry
    /// is built again (and `note` says so).
    #[allow(clippy::too_many_arguments)]
    pub fn load_or_build(
        map: &EnvMap,
        kernel: Kernel,
        noise: f64,
        m: usize,
        k: usize,
        seed: u64,
        dir: Option<&Path>,
        note: &dyn Fn(&str),
    ) -> crate::Result<Self> {
        let key = Self::key(map, &kernel, m, k, seed);
        let Some(dir) = dir else {
            return Ok(Self::build(map, kernel, noise, m, k, seed));
        };
        let path = Self::cache_path(dir, &key);
        if let Ok(bytes) = std::fs::read(&path) {
            match serde_json::from_slice::<Cached>(&bytes) {
                Ok(c) if c.key == key && Self::sound(&c, m, k) => {
                    let points = c
                        .points
                        .iter()
                        .map(|s| s.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect())
                        .collect();
                    return Ok(Self::assemble(
                        kernel,
                        noise,
                        points,
                        c.z,
                        c.prior_variance,
                        c.prior_variance_error,
                    ));
                }
                _ => note(&format!(
                    "warning: {} is not a sound bmc-light design for this map and kernel; building it again",
                    path.display()
                )),
            }
        }
        let start = std::time::Instant::now();
        let design = Self::build(map, kernel, noise, m, k, seed);
        let cached = Cached {
            key,
            points: design
                .sets
                .iter()
                .map(|s| s.points.iter().map(|p| [p.x, p.y, p.z]).collect())
                .collect(),
            z: design.sets.iter().map(|s| s.z.clone()).collect(),
            prior_variance: design.prior_variance,
            prior_variance_error: design.prior_variance_error,
        };
        crate::files::atomic::write_atomic(
            &path,
            serde_json::to_string(&cached).expect("serialisable").as_bytes(),
        )?;
        note(&format!(
            "bmc-light: kernel means of {k} sets of {m} points in {:.1} s → {}",
            start.elapsed().as_secs_f64(),
            path.display()
        ));
        Ok(design)
    }

    /// Whether a cache entry has the shape and values a design of `K` sets of `M` has.
    fn sound(c: &Cached, m: usize, k: usize) -> bool {
        let finite = |v: f64| v.is_finite();
        c.points.len() == k
            && c.z.len() == k
            && c.points.iter().all(|s| {
                s.len() == m
                    && s.iter().all(|p| {
                        p.iter().all(|&v| finite(v))
                            && ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1.0).abs() < 1e-9
                    })
            })
            && c.z
                .iter()
                .all(|s| s.iter().all(|ch| ch.len() == m && ch.iter().all(|&v| finite(v))))
            && c.prior_variance.iter().flatten().all(|&v| finite(v))
            && finite(c.prior_variance_error)
    }

    /// `M`, the points per set.
    pub fn points_per_set(&self) -> usize {
        self.sets.first().map_or(0, |s| s.points.len())
    }
}

impl DesignSet {
    /// `Î` and its posterior sd for the channel mix `a` (per-channel `[1,0,0]` etc., or
    /// luminance) from `g` at the set's points (0 below the horizon).
    pub fn estimate(&self, g: &[f64], a: [f64; 3]) -> (f64, Uncertainty) {
        let (values, amplitude) = self.estimate_channels(g);
        let value = (0..3).map(|c| a[c] * values[c]).sum();
        let mut var1 = 0.0;
        for x in 0..3 {
            for y in 0..3 {
                var1 += a[x] * a[y] * self.unit_variance[x][y];
            }
        }
        (value, self.uncertainty(amplitude, var1))
    }

    /// `Î_c` for the three channels and the amplitude `λ̂ = gᵀQ⁻¹g / M` they share.
    pub fn estimate_channels(&self, g: &[f64]) -> ([f64; 3], f64) {
        let m = self.points.len();
        assert_eq!(g.len(), m, "one value per point");
        let values = [0, 1, 2].map(|c| self.weights[c].iter().zip(g).map(|(w, v)| w * v).sum::<f64>());
        let amplitude = if g.iter().all(|&v| v == 0.0) {
            0.0
        } else {
            let mut solved = g.to_vec();
            self.factor.solve_columns_in_place(&mut solved, 1);
            (g.iter().zip(&solved).map(|(a, b)| a * b).sum::<f64>() / m as f64).max(0.0)
        };
        (values, amplitude)
    }

    /// The interval of a channel (mix) with unit posterior variance `var1` (clamped at 0: a
    /// negative one is the prior variance's quadrature error) under amplitude `λ̂`.
    pub fn uncertainty(&self, amplitude: f64, var1: f64) -> Uncertainty {
        Uncertainty {
            sd: (amplitude * var1.max(0.0)).sqrt(),
            dof: Some(self.points.len()),
            amplitude: Some(amplitude),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a constant map `L`, `I = L ∫ g` for any `g`: with `g = 1` the estimate is
    /// `L zᵀQ⁻¹1`, which tends to `4π L` as the points fill the sphere; the design's weights
    /// solve `Q w = z` (residual at rounding).
    #[test]
    fn weights_solve_the_system_and_integrate_a_constant() {
        let map = EnvMap::from_texels(32, 16, vec![[1.0, 1.0, 1.0]; 512]);
        let kernel = Kernel::Sobolev(Sobolev::new(1.8).unwrap());
        let d = LightDesign::build(&map, kernel, 1e-6, 64, 2, 7);
        for set in &d.sets {
            let n = set.points.len();
            for i in 0..n {
                let r: f64 = (0..n)
                    .map(|j| {
                        (kernel.eval(&set.points[i], &set.points[j]) + if i == j { 1e-6 } else { 0.0 })
                            * set.weights[0][j]
                    })
                    .sum::<f64>()
                    - set.z[0][i];
                assert!(r.abs() < 1e-9 * set.z[0][i].abs(), "residual {r:e}");
            }
            let (v, _) = set.estimate(&vec![1.0; n], [1.0, 0.0, 0.0]);
            assert!((v / (4.0 * std::f64::consts::PI) - 1.0).abs() < 0.05, "{v}");
        }
    }
}
