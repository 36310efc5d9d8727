//! Estimators of a pixel's illumination integral (render-scene.md, "Shading"):
//!
//! `L_o = ∫_{H(n)} f(ω) dω`, `f(ω) = L_i(ω) · (albedo/π) · (ω·n)` per colour channel,
//! with `L_i(ω) = env(ω)` when the ray from `x + 1e-4 n` towards `ω` escapes and 0 otherwise.
//!
//! Adding an integrator: one file here, one arm in [`IntegratorKind`] and [`Estimator`].

pub mod bmc;
pub mod bmcp;
pub mod mc;

use super::env::Environment;
use super::scene::{Hit, Rgb, Scene};
use crate::bmc::BmcModel;
use crate::geometry::{Frame, Vec3};
use crate::rng::WorkbenchRng;
use crate::sampling::Design;
pub use bmc::{BmcSets, SampleSet};

/// The integrators of `workbench render --integrator`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// MC with uniform hemisphere samples, fresh per pixel (math.md §3).
    Mc,
    /// MC with cosine-weighted samples, the standard importance-sampled baseline.
    McCos,
    /// BMC with precomputed sample sets rotated to the normal (math.md §4–5).
    Bmc,
    /// BMC with a constant prior from the checkerboard neighbours (thesis §3.2.5).
    Bmcp,
}

impl IntegratorKind {
    /// All kinds, in the order of the docs.
    pub const ALL: [IntegratorKind; 4] = [
        IntegratorKind::Mc,
        IntegratorKind::McCos,
        IntegratorKind::Bmc,
        IntegratorKind::Bmcp,
    ];

    /// The name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Mc => "mc",
            IntegratorKind::McCos => "mc-cos",
            IntegratorKind::Bmc => "bmc",
            IntegratorKind::Bmcp => "bmcp",
        }
    }

    /// Parses [`IntegratorKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the kind uses BMC sample sets (and so the `gps`/`rotate`/model options).
    pub fn uses_sets(self) -> bool {
        matches!(self, IntegratorKind::Bmc | IntegratorKind::Bmcp)
    }
}

impl std::fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A shading point: the offset ray origin `x + 1e-4 n`, a frame taking `+z` to `n`, the albedo.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint {
    pub origin: Vec3,
    pub frame: Frame,
    pub albedo: Rgb,
}

impl ShadingPoint {
    /// Offset of shadow-ray origins along the normal.
    pub const EPSILON: f64 = 1e-4;

    /// The shading point of a primary hit.
    pub fn new(hit: &Hit) -> Self {
        ShadingPoint {
            origin: hit.point + hit.normal * Self::EPSILON,
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
}

/// A ready-to-use integrator: the kind, the samples per pixel and, for BMC, the sample sets
/// with their weights (one Cholesky per set, computed before rendering).
#[derive(Clone, Debug)]
pub struct Integrator {
    pub kind: IntegratorKind,
    pub spp: usize,
    pub estimator: Estimator,
}

/// How one pixel's integral is formed.
#[derive(Clone, Debug)]
pub enum Estimator {
    /// Fresh samples per pixel from `Design`.
    Mc(Design),
    /// Rotated, pre-weighted sample sets.
    Bmc(BmcSets),
}

impl Integrator {
    /// MC with uniform (`mc`) or cosine-weighted (`mc-cos`) sampling.
    pub fn mc(design: Design, spp: usize) -> Self {
        let kind = match design {
            Design::Uniform => IntegratorKind::Mc,
            Design::Cosine => IntegratorKind::McCos,
        };
        Integrator {
            kind,
            spp,
            estimator: Estimator::Mc(design),
        }
    }

    /// Builds the integrator `kind` with `spp` samples; for `bmc`/`bmcp`, `gps` uniform sample
    /// sets drawn from `seed` and weighted under `model` (needed only by those kinds, so that
    /// MC never pays for the kernel-mean table).
    pub fn build(
        kind: IntegratorKind,
        spp: usize,
        gps: usize,
        rotate: bool,
        model: Option<&BmcModel>,
        seed: u64,
    ) -> anyhow::Result<Self> {
        Ok(match kind {
            IntegratorKind::Mc => Self::mc(Design::Uniform, spp),
            IntegratorKind::McCos => Self::mc(Design::Cosine, spp),
            IntegratorKind::Bmc | IntegratorKind::Bmcp => {
                let model = model.ok_or_else(|| anyhow::anyhow!("{kind} needs a BMC model"))?;
                Integrator {
                    kind,
                    spp,
                    estimator: Estimator::Bmc(BmcSets::generate(spp, gps, rotate, model, seed)?),
                }
            }
        })
    }

    /// The estimate of `L_o` at `p`; `prior` is the BMCP constant `c` per channel (`None` or
    /// zero for plain BMC; ignored by MC). `rng` is the pixel's own stream.
    #[inline]
    pub fn estimate(
        &self,
        p: &ShadingPoint,
        scene: &Scene,
        env: &Environment,
        rng: &mut WorkbenchRng,
        prior: Option<Rgb>,
    ) -> Rgb {
        match &self.estimator {
            Estimator::Mc(design) => mc::estimate(*design, self.spp, p, scene, env, rng),
            Estimator::Bmc(sets) => sets.estimate(p, scene, env, rng, prior.unwrap_or([0.0; 3])),
        }
    }
}
