//! Scene integrands (math.md §1 "Scene integrands"): the render scene's integrand at one pixel,
//! one colour channel, in the renderer's local frame (`+z` the surface normal):
//!
//! `f(ω) = L_i(ω) · (albedo_c/π) · (ω·n)`, exactly [`ShadingPoint::integrand`] at the pixel's
//! primary hit (render-scene.md), so an experiment samples what the renderer samples. Its truth
//! is the certified quadrature of [`crate::render::exact`] at [`exact::DEFAULT_TOLERANCE`]
//! (1e-9 absolute), whose error estimate is kept beside it.

use crate::render::env::Environment;
use crate::render::exact;
use crate::render::integrator::ShadingPoint;
use crate::render::{Renderer, check_size};
use crate::util::geometry::Vec3;
use std::sync::Arc;

/// The colour channel names, in order.
pub const CHANNELS: [&str; 3] = ["r", "g", "b"];

/// One pixel's integrand in one channel, with its truth.
#[derive(Clone, Debug)]
pub struct PixelIntegrand {
    /// Column and row (from the top left).
    pub pixel: [usize; 2],
    pub width: usize,
    pub height: usize,
    /// `sky`, `white` or the map file as given.
    pub env_name: String,
    /// 0, 1, 2 for r, g, b.
    pub channel: usize,
    /// Whether the primary hit is on the ground (`false`: on the sphere).
    pub on_ground: bool,
    renderer: Arc<Renderer>,
    point: ShadingPoint,
    truth: f64,
    truth_error: f64,
}

impl PartialEq for PixelIntegrand {
    /// Equal when defined alike (the scene, camera and map follow from these).
    fn eq(&self, other: &Self) -> bool {
        self.pixel == other.pixel
            && (self.width, self.height) == (other.width, other.height)
            && self.renderer.env.key() == other.renderer.env.key()
            && self.channel == other.channel
    }
}

impl PixelIntegrand {
    /// The integrand of pixel `(i, j)` of a `width × height` render of the default scene under
    /// `env` (named `env_name` in messages), channel `channel` (`r`, `g` or `b`). Errors name the
    /// JSON field: a pixel outside the image or whose primary ray hits nothing (the background).
    pub fn new(
        pixel: [usize; 2],
        width: usize,
        height: usize,
        env: Environment,
        env_name: &str,
        channel: &str,
    ) -> Result<Self, String> {
        check_size(width, height, "width/height").map_err(|e| e.0)?;
        let channel = CHANNELS
            .iter()
            .position(|c| *c == channel)
            .ok_or_else(|| format!("channel: must be \"r\", \"g\" or \"b\", got {channel:?}"))?;
        let [i, j] = pixel;
        if i >= width || j >= height {
            return Err(format!(
                "pixel: [{i}, {j}] is outside the {width}×{height} image (columns 0..{width}, rows 0..{height})"
            ));
        }
        let renderer = Renderer::new(width, height, env);
        let point = renderer.shading_point(i, j).ok_or_else(|| {
            format!(
                "pixel: [{i}, {j}] of the {width}×{height} image shows the background (its primary ray hits \
                 nothing); choose a pixel on the ground or the sphere"
            )
        })?;
        let q = exact::integrate(&point, &renderer.scene, &renderer.env, exact::DEFAULT_TOLERANCE);
        let on_ground = renderer
            .scene
            .sphere
            .is_none_or(|s| (point.origin - s.centre).norm() > s.radius * 1.001);
        Ok(PixelIntegrand {
            pixel,
            width,
            height,
            env_name: env_name.to_string(),
            channel,
            on_ground,
            renderer: Arc::new(renderer),
            point,
            truth: q.value[channel],
            truth_error: q.error,
        })
    }

    /// `f(ω)` at the local direction `w` (normal `+z`): the renderer's integrand, one channel.
    #[inline]
    pub fn value(&self, w: &Vec3) -> f64 {
        self.point.integrand(&self.renderer.scene, &self.renderer.env, w)[self.channel]
    }

    /// `∫_H f dω` by the certified quadrature.
    pub fn integral(&self) -> f64 {
        self.truth
    }

    /// The quadrature's estimated absolute error of [`PixelIntegrand::integral`] (≤ 1e-9).
    pub fn integral_error(&self) -> f64 {
        self.truth_error
    }

    /// [`PixelIntegrand::new`] under `env` as the spec names it: `sky`, `white` or a map file
    /// (read here; its errors name the field `env`).
    pub fn from_env_arg(
        pixel: [usize; 2],
        width: usize,
        height: usize,
        env: &str,
        channel: &str,
    ) -> Result<Self, String> {
        let environment = Environment::from_arg(env).map_err(|e| format!("env: {}", e.0))?;
        PixelIntegrand::new(pixel, width, height, environment, env, channel)
    }

    /// `pixel-<i>-<j>-<env>-<channel>` (`env` is `sky`, `white` or `map`).
    pub fn default_name(&self) -> String {
        let env = match self.renderer.env {
            Environment::Sky => "sky",
            Environment::White => "white",
            Environment::Map(_) => "map",
        };
        let [i, j] = self.pixel;
        format!("pixel-{i}-{j}-{env}-{}", CHANNELS[self.channel])
    }

    /// `pixel (i, j) of 256×256, ground, sky, g`.
    pub fn display_name(&self) -> String {
        let [i, j] = self.pixel;
        format!(
            "pixel ({i}, {j}) of {}×{}, {}, {}, {}",
            self.width,
            self.height,
            if self.on_ground { "ground" } else { "sphere" },
            self.env_name,
            CHANNELS[self.channel]
        )
    }
}
