//! The render loop: primary rays, then one integral estimate per hit pixel, in parallel over
//! rows. Every pixel draws from its own stream `stream(seed, [PIXELS, pixel index])`, so the
//! image does not depend on the number of threads or the order of work.

use super::camera::Camera;
use super::env::Environment;
use super::exact;
use super::image::Image;
use super::integrator::neighbours::{
    NeighbourPrior, PixelGeometry, edge_aware_prior, first_pass, neighbour_prior,
};
use super::integrator::{Integrator, ShadingPoint};
use super::scene::{Rgb, Scene, SceneKind};
use super::uncertainty::PixelSds;
use crate::bq::estimator::Uncertainty;
use crate::error::InputError;
use crate::util::report::Reporter;
use crate::util::rng::stream;
use rayon::prelude::*;

/// A pixel's estimate and, when asked for, its uncertainty per channel.
type PixelOut = (Rgb, Option<[Uncertainty; 3]>);

/// Stream family of the per-pixel streams.
const PIXELS: u64 = 0x91c;

/// Largest image: the linear image and BMCP's first pass take `2 · 24` bytes per pixel, so
/// `2^24` pixels (4096 × 4096) stay under 1 GiB.
pub const MAX_PIXELS: usize = 1 << 24;

/// Rejects empty images, images with a side the tool could not read back, and images too large
/// for memory; `what` names the options or fields (`--width/--height`, `width/height`). The side
/// limit is the decoder's, [`crate::render::env::MAX_IMAGE_SIDE`]: one limit for the writer and
/// the reader, so that every image `render` writes is one `--reference` (and `--env`) reads
/// (issue 42.5: a 100000×1 render was written, then refused by its own `--reference`).
pub fn check_size(width: usize, height: usize, what: &str) -> Result<(), InputError> {
    if width == 0 || height == 0 {
        return Err(InputError::new(format!(
            "{what}: the image must be at least 1×1, got {width}×{height}"
        )));
    }
    let side = crate::render::env::MAX_IMAGE_SIDE as usize;
    match width.checked_mul(height) {
        // Under the fixed limit, the image must also fit the memory budget.
        Some(n) if n <= MAX_PIXELS && (width > side || height > side) => Err(InputError::new(format!(
            "{what}: {width}×{height} has a side over {side}, the largest the image reader \
             accepts (so that every image written can be read back as a reference image)"
        ))),
        Some(n) if n <= MAX_PIXELS => {
            crate::bq::rule::check_memory(&format!("{what}: a {width}×{height} image"), 48 * n as u64)
        }
        _ => {
            let gib = 48.0 * width as f64 * height as f64 / (1u64 << 30) as f64;
            Err(InputError::new(format!(
                "{what}: {width}×{height} would need {gib:.1} GiB; the limit is {MAX_PIXELS} \
                 pixels (4096×4096)"
            )))
        }
    }
}

/// A scene seen through a camera under an environment.
#[derive(Clone, Debug)]
pub struct Renderer {
    pub scene: Scene,
    pub camera: Camera,
    pub env: Environment,
    pub width: usize,
    pub height: usize,
}

impl Renderer {
    /// The default scene and camera (render-scene.md) at `width × height`.
    pub fn new(width: usize, height: usize, env: Environment) -> Self {
        Self::for_scene(SceneKind::Workbench, width, height, env)
    }

    /// The scene `kind` seen through its camera at `width × height`.
    pub fn for_scene(kind: SceneKind, width: usize, height: usize, env: Environment) -> Self {
        Renderer {
            scene: kind.scene(),
            camera: kind.camera(width, height),
            env,
            width,
            height,
        }
    }

    /// The number of row passes [`Renderer::render`] makes (two for estimators with a prior).
    pub fn passes(&self, integrator: &Integrator) -> usize {
        if integrator.kind.method.uses_prior() { 2 } else { 1 }
    }

    /// Renders one image; `progress` advances by one per row and pass (see [`Renderer::passes`]).
    ///
    /// Pixels whose primary ray hits nothing show `env(dir)`. For an estimator with a prior mean
    /// (`bmcp`) the first pass renders the `(i + j)`-even pixels with prior 0 (plain BMC), the
    /// second the others with the neighbour prior (plain or edge-aware, [`NeighbourPrior`]).
    pub fn render(&self, integrator: &Integrator, seed: u64, progress: &dyn Reporter) -> Image {
        self.render_pixels(integrator, seed, progress).0
    }

    /// [`Renderer::render`] and the sd each pixel's estimator states per channel (the integrator
    /// must come from [`Integrator::with_uncertainty`]); the image is the one `render` gives.
    pub fn render_with_sd(
        &self,
        integrator: &Integrator,
        seed: u64,
        progress: &dyn Reporter,
    ) -> (Image, PixelSds) {
        assert!(
            integrator.uncertainty.is_some(),
            "render_with_sd needs Integrator::with_uncertainty"
        );
        let (image, sds) = self.render_pixels(integrator, seed, progress);
        (image, PixelSds::new(self.width, self.height, &sds))
    }

    /// Each pixel's value and, when the integrator states one, its uncertainty per channel
    /// (None for background pixels).
    fn render_pixels(
        &self,
        integrator: &Integrator,
        seed: u64,
        progress: &dyn Reporter,
    ) -> (Image, Vec<Option<[Uncertainty; 3]>>) {
        let with_prior = integrator.kind.method.uses_prior();
        let first: Vec<Option<PixelOut>> = self.rows(progress, |i, j| {
            if with_prior && !first_pass(i, j) {
                return None;
            }
            self.pixel_with_sd(i, j, integrator, seed, [0.0; 3])
        });
        let pixels: Vec<Option<PixelOut>> = if with_prior {
            let values: Vec<Option<Rgb>> = first.iter().map(|p| p.map(|p| p.0)).collect();
            let geometry = match integrator.kind.neighbours {
                NeighbourPrior::Mean => None,
                NeighbourPrior::EdgeAware => Some(self.geometry()),
            };
            self.rows(progress, |i, j| {
                if first_pass(i, j) {
                    return first[j * self.width + i];
                }
                let c = match &geometry {
                    None => neighbour_prior(&values, self.width, self.height, i, j),
                    Some(g) => edge_aware_prior(&values, g, self.width, self.height, i, j),
                };
                self.pixel_with_sd(i, j, integrator, seed, c)
            })
        } else {
            first
        };
        let mut data = Vec::with_capacity(pixels.len());
        let mut sds = Vec::with_capacity(pixels.len());
        for (k, p) in pixels.into_iter().enumerate() {
            match p {
                Some((value, sd)) => {
                    data.push(value);
                    sds.push(sd);
                }
                None => {
                    let (i, j) = (k % self.width, k / self.width);
                    data.push(self.env.radiance(&self.camera.ray(i, j)));
                    sds.push(None);
                }
            }
        }
        let image = Image {
            width: self.width,
            height: self.height,
            data,
        };
        (image, sds)
    }

    /// Every pixel's primary-hit normal and depth (None for background), row-major: what the
    /// edge-aware neighbour prior and the edge mask compare.
    pub fn geometry(&self) -> Vec<Option<PixelGeometry>> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for j in 0..self.height {
            for i in 0..self.width {
                let hit = self.scene.intersect(&self.camera.origin, &self.camera.ray(i, j));
                out.push(hit.map(|h| PixelGeometry {
                    normal: h.normal,
                    depth: h.t,
                }));
            }
        }
        out
    }

    /// [`Renderer::pixel`] with the stated uncertainty ([`Integrator::estimate_with_sd`]).
    fn pixel_with_sd(
        &self,
        i: usize,
        j: usize,
        integrator: &Integrator,
        seed: u64,
        prior: Rgb,
    ) -> Option<PixelOut> {
        let p = self.shading_point(i, j)?;
        let mut rng = stream(seed, &[PIXELS, (j * self.width + i) as u64]);
        Some(integrator.estimate_with_sd(&p, &self.scene, &self.env, &mut rng, prior))
    }

    /// The integral estimate at pixel `(i, j)`, or `None` if the primary ray hits nothing.
    pub fn pixel(&self, i: usize, j: usize, integrator: &Integrator, seed: u64, prior: Rgb) -> Option<Rgb> {
        let p = self.shading_point(i, j)?;
        let mut rng = stream(seed, &[PIXELS, (j * self.width + i) as u64]);
        Some(integrator.estimate(&p, &self.scene, &self.env, &mut rng, prior))
    }

    /// The shading point of pixel `(i, j)`'s primary hit, or `None` if its ray hits nothing.
    pub fn shading_point(&self, i: usize, j: usize) -> Option<ShadingPoint> {
        let dir = self.camera.ray(i, j);
        let hit = self.scene.intersect(&self.camera.origin, &dir)?;
        Some(ShadingPoint::new(&hit, self.scene.rays.offset))
    }

    /// Pixel `(i, j)`'s integral by the certified quadrature ([`exact::integrate`]) to the
    /// absolute tolerance `tol`, or `None` if its ray hits nothing.
    pub fn exact_pixel(&self, i: usize, j: usize, tol: f64) -> Option<exact::PixelIntegral> {
        let p = self.shading_point(i, j)?;
        Some(exact::integrate(&p, &self.scene, &self.env, tol))
    }

    /// The exact image: every hit pixel by the certified quadrature ([`exact::integrate`], all
    /// three channels) to the absolute tolerance `tol`, the others `env(dir)`; rows in parallel,
    /// deterministic (no randomness, and each pixel's work is independent of the others').
    /// `progress` advances by one per row.
    pub fn render_exact(&self, tol: f64, progress: &dyn Reporter) -> (Image, ExactStats) {
        let pixels = self.rows(progress, |i, j| match self.exact_pixel(i, j, tol) {
            Some(q) => (q.value, Some(q)),
            None => (self.env.radiance(&self.camera.ray(i, j)), None),
        });
        let mut stats = ExactStats::default();
        for (k, (_, q)) in pixels.iter().enumerate() {
            if let Some(q) = q {
                if q.error > stats.max_error {
                    stats.max_error = q.error;
                    stats.worst_pixel = (k % self.width, k / self.width);
                }
                stats.depth_limited += q.depth_limited as usize;
                stats.work_limited += q.work_limited as usize;
                stats.evaluations += q.evaluations;
            }
        }
        let image = Image {
            width: self.width,
            height: self.height,
            data: pixels.into_iter().map(|(v, _)| v).collect(),
        };
        (image, stats)
    }

    /// `f(i, j)` for every pixel, rows in parallel, collected in row-major order.
    fn rows<T: Send>(&self, progress: &dyn Reporter, f: impl Fn(usize, usize) -> T + Sync) -> Vec<T> {
        let rows: Vec<Vec<T>> = (0..self.height)
            .into_par_iter()
            .map(|j| {
                let row = (0..self.width).map(|i| f(i, j)).collect();
                progress.advance(1);
                row
            })
            .collect();
        rows.into_iter().flatten().collect()
    }
}

/// What an exact render reports about its quadrature.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExactStats {
    /// The largest estimated absolute error of any pixel and channel.
    pub max_error: f64,
    /// The pixel `(i, j)` with that error.
    pub worst_pixel: (usize, usize),
    /// Pixels where some interval reached the bisection depth limit.
    pub depth_limited: usize,
    /// Pixels whose outer rule stopped at its work limit ([`crate::render::cuts::MAX_PAIRS`]).
    pub work_limited: usize,
    /// Integrand evaluations in all.
    pub evaluations: u64,
}
