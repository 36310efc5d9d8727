//! The pinhole camera of render-scene.md, "Camera".

use crate::util::geometry::Vec3;

/// A pinhole camera with one primary ray per pixel through the pixel centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// `tan(fov/2)`.
    tan_half: f64,
    width: usize,
    height: usize,
}

impl Camera {
    /// Eye `(0, 1.6, 6.5)`, target `(0, 0.9, 0)`, up `(0, 1, 0)`, vertical field of view 40°.
    pub fn default_for(width: usize, height: usize) -> Self {
        Self::look_at(
            Vec3::new(0.0, 1.6, 6.5),
            Vec3::new(0.0, 0.9, 0.0),
            Vec3::y(),
            40.0,
            width,
            height,
        )
    }

    /// `forward = normalize(target − eye)`, `right = normalize(forward × up)`,
    /// `up' = right × forward`.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        world_up: Vec3,
        fov_deg: f64,
        width: usize,
        height: usize,
    ) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(&world_up).normalize();
        let up = right.cross(&forward);
        Camera {
            origin: eye,
            forward,
            right,
            up,
            tan_half: (fov_deg.to_radians() / 2.0).tan(),
            width,
            height,
        }
    }

    /// Direction through pixel `(i, j)` (column `i` from the left, row `j` from the top):
    /// `px = (2(i + ½)/W − 1)·t·a`, `py = (1 − 2(j + ½)/H)·t`,
    /// `dir = normalize(forward + px·right + py·up)`.
    pub fn ray(&self, i: usize, j: usize) -> Vec3 {
        let aspect = self.width as f64 / self.height as f64;
        let px = (2.0 * (i as f64 + 0.5) / self.width as f64 - 1.0) * self.tan_half * aspect;
        let py = (1.0 - 2.0 * (j as f64 + 0.5) / self.height as f64) * self.tan_half;
        (self.forward + self.right * px + self.up * py).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_right_handed_and_the_centre_ray_looks_at_the_target() {
        let c = Camera::default_for(2, 2);
        assert!((c.right - Vec3::x()).norm() < 1e-12, "right = {}", c.right);
        assert!(c.up.y > 0.0);
        // Pixel centres of a 2×2 image are symmetric about the forward axis.
        let d = (c.ray(0, 0) + c.ray(1, 1)).normalize();
        assert!((d - c.forward).norm() < 1e-12);
        // Row 0 is at the top.
        assert!(c.ray(0, 0).y > c.ray(0, 1).y);
    }
}
