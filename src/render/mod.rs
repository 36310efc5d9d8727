//! `workbench render`: a small renderer whose pixels are hemisphere integrals estimated with the
//! workbench's estimators, and the RMSE-against-spp tables of the thesis (Table 4.1, Fig. 4.1b).
//!
//! The scene, camera, shading and sky are defined in `docs/render-scene.md`; the estimators
//! in `docs/math.md` §3–5; the error measure in §6.

pub mod adaptive;
pub mod camera;
pub mod cuts;
pub mod env;
pub mod exact;
pub mod image;
pub mod integrator;
pub mod plan;
pub mod renderer;
pub mod scene;
pub mod texel;
pub mod uncertainty;

pub use camera::Camera;
pub use env::Environment;
pub use image::Image;
pub use integrator::{Integrator, IntegratorKind};
pub use plan::ImagePlan;
pub use renderer::{Renderer, check_size};
pub use scene::{Scene, SceneKind};
