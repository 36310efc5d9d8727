//! The default scene (render-scene.md, "World"): a Lambertian sphere on a finite ground square.

use crate::util::geometry::Vec3;

/// Linear RGB triple.
pub type Rgb = [f64; 3];

/// A sphere with a Lambertian albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: Vec3,
    pub radius: f64,
    pub albedo: Rgb,
}

/// The square `y = 0`, `|x| ≤ half`, `|z| ≤ half`, normal `+y`, with a Lambertian albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    pub half: f64,
    pub albedo: Rgb,
}

/// The first hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter `t > 0` of the hit.
    pub t: f64,
    pub point: Vec3,
    /// Unit surface normal.
    pub normal: Vec3,
    pub albedo: Rgb,
}

/// The objects of a scene; two primitives, so no acceleration structure.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub sphere: Option<Sphere>,
    pub ground: Option<Ground>,
}

impl Scene {
    /// The scene of render-scene.md: ground `y = 0`, `−5 ≤ x, z ≤ 5`, albedo `0.75`; sphere
    /// centre `(0, 1, 0)`, radius 1, albedo `(0.80, 0.35, 0.25)`.
    pub fn default_scene() -> Self {
        Scene {
            sphere: Some(Sphere {
                centre: Vec3::new(0.0, 1.0, 0.0),
                radius: 1.0,
                albedo: [0.80, 0.35, 0.25],
            }),
            ground: Some(Ground {
                half: 5.0,
                albedo: [0.75, 0.75, 0.75],
            }),
        }
    }

    /// The default sphere alone: a convex object never shadows itself, so every hit pixel is
    /// unoccluded (used by the analytic tests).
    pub fn sphere_only() -> Self {
        Scene {
            ground: None,
            ..Scene::default_scene()
        }
    }

    /// The nearest hit with `t > 0` of the ray `origin + t·dir` (`dir` unit).
    pub fn intersect(&self, origin: &Vec3, dir: &Vec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        if let Some(s) = &self.sphere
            && let Some(t) = sphere_t(s, origin, dir)
        {
            let point = origin + dir * t;
            best = Some(Hit {
                t,
                point,
                normal: (point - s.centre) / s.radius,
                albedo: s.albedo,
            });
        }
        if let Some(g) = &self.ground
            && let Some(t) = ground_t(g, origin, dir)
            && best.is_none_or(|b| t < b.t)
        {
            best = Some(Hit {
                t,
                point: origin + dir * t,
                normal: Vec3::y(),
                albedo: g.albedo,
            });
        }
        best
    }

    /// Whether the ray `origin + t·dir` hits anything at `t > 0` (visibility of the sky).
    #[inline]
    pub fn occluded(&self, origin: &Vec3, dir: &Vec3) -> bool {
        self.sphere
            .as_ref()
            .is_some_and(|s| sphere_t(s, origin, dir).is_some())
            || self
                .ground
                .as_ref()
                .is_some_and(|g| ground_t(g, origin, dir).is_some())
    }
}

/// Smallest root `t > 0` of `‖o + t d − c‖² = r²`: `t = −b ∓ sqrt(b² − (‖o − c‖² − r²))`,
/// `b = (o − c)·d`.
#[inline]
fn sphere_t(s: &Sphere, origin: &Vec3, dir: &Vec3) -> Option<f64> {
    let oc = origin - s.centre;
    let b = oc.dot(dir);
    let c = oc.norm_squared() - s.radius * s.radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    let near = -b - root;
    if near > 0.0 {
        return Some(near);
    }
    let far = -b + root;
    (far > 0.0).then_some(far)
}

/// `t = −o.y / d.y` if positive and inside the square.
#[inline]
fn ground_t(g: &Ground, origin: &Vec3, dir: &Vec3) -> Option<f64> {
    if dir.y == 0.0 {
        return None;
    }
    let t = -origin.y / dir.y;
    if t <= 0.0 {
        return None;
    }
    let x = origin.x + t * dir.x;
    let z = origin.z + t * dir.z;
    (x.abs() <= g.half && z.abs() <= g.half).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_hit_the_sphere_and_the_ground() {
        let scene = Scene::default_scene();
        let down = Vec3::new(0.0, -1.0, 0.0);
        let top = scene.intersect(&Vec3::new(0.0, 5.0, 0.0), &down).unwrap();
        assert!((top.t - 3.0).abs() < 1e-12 && (top.normal - Vec3::y()).norm() < 1e-12);
        let ground = scene.intersect(&Vec3::new(3.0, 5.0, 0.0), &down).unwrap();
        assert!((ground.t - 5.0).abs() < 1e-12 && ground.albedo == [0.75; 3]);
        // Outside the square: nothing.
        assert!(scene.intersect(&Vec3::new(6.0, 5.0, 0.0), &down).is_none());
        // From inside the sphere the far root counts.
        assert!(scene.occluded(&Vec3::new(0.0, 1.0, 0.0), &Vec3::x()));
        assert!(!scene.occluded(&Vec3::new(0.0, 2.0001, 0.0), &Vec3::y()));
    }
}
