//! The thesis code's scene (`../shared/data/README.md`, "Their scene and renderer"; the thesis's
//! Fig. 3.11): a Lambertian sphere of albedo 0.8 touching a green parallelogram, seen from a
//! camera at the origin looking down `−z`.

use super::{Ground, RayRule, Scene, Sphere};
use crate::render::camera::Camera;
use crate::util::geometry::Vec3;

/// 500×500, the thesis's images.
pub const DEFAULT_SIZE: (usize, usize) = (500, 500);

/// Every ray, camera and shadow, starts at its origin with no offset along the normal and
/// ignores hits at `t < 1e-4` (the code's `EPSILON`) or `t > 10⁶`. (A hit at exactly `1e-4` is
/// refused here and accepted there: a set of rays of measure zero.)
pub const RAYS: RayRule = RayRule {
    offset: 0.0,
    t_min: 1e-4,
    t_max: 1e6,
};

/// Sphere centre `(0, 0, −5)`, radius 2, albedo `(0.8, 0.8, 0.8)`; the parallelogram with corner
/// `(−4, −2, −1)` and edges `(8, 0, 0)`, `(0, 0, −8)` — the rectangle `y = −2`, `−4 ≤ x ≤ 4`,
/// `−9 ≤ z ≤ −1` — albedo `(0.2, 0.8, 0.2)`, its normal `±y` facing the incoming ray.
pub fn scene() -> Scene {
    Scene {
        sphere: Some(Sphere {
            centre: Vec3::new(0.0, 0.0, -5.0),
            radius: 2.0,
            albedo: [0.8, 0.8, 0.8],
        }),
        ground: Some(Ground {
            height: -2.0,
            x: [-4.0, 4.0],
            z: [-9.0, -1.0],
            albedo: [0.2, 0.8, 0.2],
        }),
        rays: RAYS,
    }
}

/// At the origin, looking down `−z`, `y` up, vertical field of view 60°: pixel `(x, y)`'s ray is
/// `normalize(x_ss·tan 30°·W/H, y_ss·tan 30°, −1)` with `x_ss = 2(x + ½)/W − 1`,
/// `y_ss = 1 − 2(y + ½)/H` — [`Camera::look_at`] with these parameters.
pub fn camera(width: usize, height: usize) -> Camera {
    Camera::look_at(
        Vec3::zeros(),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::y(),
        60.0,
        width,
        height,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The camera's rays are the thesis code's, to rounding.
    #[test]
    fn camera_rays_follow_the_thesis_formula() {
        let (w, h) = (500usize, 400usize);
        let cam = camera(w, h);
        let t = 30f64.to_radians().tan();
        for (x, y) in [(0, 0), (499, 399), (250, 17), (3, 398)] {
            let xs = 2.0 * (x as f64 + 0.5) / w as f64 - 1.0;
            let ys = 1.0 - 2.0 * (y as f64 + 0.5) / h as f64;
            let expected = Vec3::new(xs * t * w as f64 / h as f64, ys * t, -1.0).normalize();
            assert!((cam.ray(x, y) - expected).norm() < 1e-15, "({x}, {y})");
        }
    }

    /// The sphere rests on the parallelogram; a camera ray through the image centre hits the
    /// sphere's front at `t = 3`; a ray below it hits the green floor, whose normal faces up.
    #[test]
    fn geometry_is_the_thesis_scene() {
        let s = scene();
        let centre = s.intersect(&Vec3::zeros(), &Vec3::new(0.0, 0.0, -1.0)).unwrap();
        assert!((centre.t - 3.0).abs() < 1e-12 && centre.albedo == [0.8; 3]);
        let floor = s
            .intersect(&Vec3::zeros(), &Vec3::new(0.0, -1.0, -1.0).normalize())
            .unwrap();
        assert_eq!(floor.albedo, [0.2, 0.8, 0.2]);
        assert_eq!(floor.normal, Vec3::y());
        assert!((floor.point.y + 2.0).abs() < 1e-12);
        // Seen from below, the parallelogram's normal is flipped towards the ray.
        let under = s.intersect(&Vec3::new(0.0, -3.0, -3.0), &Vec3::y()).unwrap();
        assert_eq!(under.normal, -Vec3::y());
        // A shadow ray leaving a surface point accepts no hit of that surface (t < 1e-4).
        let top = Vec3::new(0.0, 2.0, -5.0);
        assert!(!s.occluded(&top, &Vec3::y()));
        let contact_side = Vec3::new(1.0, -2.0, -5.0);
        assert!(s.occluded(&contact_side, &Vec3::new(-1.0, 1.0, 0.0).normalize()));
    }
}
