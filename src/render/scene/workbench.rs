//! The workbench's own scene (render-scene.md, "World" and "Camera"): a Lambertian sphere on a
//! finite ground square, seen from above and in front.

use super::{Ground, RayRule, Scene, Sphere};
use crate::render::camera::Camera;
use crate::util::geometry::Vec3;

/// 256×256.
pub const DEFAULT_SIZE: (usize, usize) = (256, 256);

/// Shadow rays start `1e-4` along the normal and accept any hit at `t > 0`.
pub const RAYS: RayRule = RayRule {
    offset: 1e-4,
    t_min: 0.0,
    t_max: f64::INFINITY,
};

/// Ground `y = 0`, `−5 ≤ x, z ≤ 5`, albedo `0.75`; sphere centre `(0, 1, 0)`, radius 1, albedo
/// `(0.80, 0.35, 0.25)`.
pub fn scene() -> Scene {
    Scene {
        sphere: Some(Sphere {
            centre: Vec3::new(0.0, 1.0, 0.0),
            radius: 1.0,
            albedo: [0.80, 0.35, 0.25],
        }),
        ground: Some(Ground::square(5.0, [0.75; 3])),
        rays: RAYS,
    }
}

/// Eye `(0, 1.6, 6.5)`, target `(0, 0.9, 0)`, up `(0, 1, 0)`, vertical field of view 40°.
pub fn camera(width: usize, height: usize) -> Camera {
    Camera::default_for(width, height)
}
