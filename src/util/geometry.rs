//! Directions on the unit sphere and frames that carry the local `+z` to a normal.

/// A 3-vector; directions are unit vectors.
pub type Vec3 = nalgebra::Vector3<f64>;

/// An orthonormal frame `(t, b, n)` with `n` the given unit normal.
///
/// `to_world(v) = v.x·t + v.y·b + v.z·n` maps the local frame (normal `+z`) to the world, the
/// rotation of math.md §5. Any such frame is valid because the kernels are isotropic; this one is
/// the branch-free construction of Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// The frame around the unit normal `n`.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bt, n }
    }

    /// Local coordinates (normal `+z`) to world coordinates.
    #[inline]
    pub fn to_world(&self, v: &Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// Rotation of `v` by the angle `phi` about `+z`.
#[inline]
pub fn rotate_about_z(v: &Vec3, phi: f64) -> Vec3 {
    let (sin, cos) = phi.sin_cos();
    rotate_about_z_by(v, sin, cos)
}

/// Rotation of `v` about `+z` by the angle whose sine and cosine are given (computed once
/// when a whole sample set is rotated).
#[inline]
pub fn rotate_about_z_by(v: &Vec3, sin: f64, cos: f64) -> Vec3 {
    Vec3::new(cos * v.x - sin * v.y, sin * v.x + cos * v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_maps_z_to_normal() {
        for n in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.3, -0.5, 0.2).normalize(),
            Vec3::new(0.0, 1.0, 0.0),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.to_world(&Vec3::z()) - n).norm() < 1e-15);
            assert!(f.t.dot(&f.b).abs() < 1e-15);
            assert!(f.t.dot(&f.n).abs() < 1e-15);
            assert!((f.t.norm() - 1.0).abs() < 1e-15 && (f.b.norm() - 1.0).abs() < 1e-15);
            // Right-handed, so a rotation and not a reflection.
            assert!((f.t.cross(&f.b) - n).norm() < 1e-14);
        }
    }
}
