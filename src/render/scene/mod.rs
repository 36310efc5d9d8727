//! Scenes: a Lambertian sphere over a Lambertian rectangle, seen through a pinhole camera.
//! [`SceneKind`] names the two scenes the renderer knows, one file each: the workbench's own
//! ([`workbench`], render-scene.md "World") and the thesis code's ([`thesis`],
//! `../shared/data/README.md`). A third scene is one file and one arm of [`SceneKind`].

pub mod thesis;
pub mod workbench;

use super::camera::Camera;
use crate::error::InputError;
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

/// The horizontal rectangle `y = height`, `x₀ ≤ x ≤ x₁`, `z₀ ≤ z ≤ z₁`, with a Lambertian albedo;
/// its normal `±y` faces the ray that hits it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    pub height: f64,
    /// `[x₀, x₁]`.
    pub x: [f64; 2],
    /// `[z₀, z₁]`.
    pub z: [f64; 2],
    pub albedo: Rgb,
}

impl Ground {
    /// The square `y = 0`, `|x| ≤ half`, `|z| ≤ half`.
    pub fn square(half: f64, albedo: Rgb) -> Self {
        Ground {
            height: 0.0,
            x: [-half, half],
            z: [-half, half],
            albedo,
        }
    }
}

/// Which hits a ray accepts and where shadow rays start: a hit at `t` counts when
/// `t_min < t ≤ t_max`; a shading point's shadow rays start `offset` along the normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayRule {
    pub offset: f64,
    pub t_min: f64,
    pub t_max: f64,
}

impl RayRule {
    #[inline]
    fn accepts(&self, t: f64) -> bool {
        t > self.t_min && t <= self.t_max
    }
}

/// The first hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter `t > 0` of the hit.
    pub t: f64,
    pub point: Vec3,
    /// Unit surface normal (facing the ray for the ground).
    pub normal: Vec3,
    pub albedo: Rgb,
}

/// The objects of a scene and its ray rule; two primitives, so no acceleration structure.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub sphere: Option<Sphere>,
    pub ground: Option<Ground>,
    pub rays: RayRule,
}

impl Scene {
    /// The workbench scene ([`workbench::scene`]).
    pub fn default_scene() -> Self {
        workbench::scene()
    }

    /// The default sphere alone: a convex object never shadows itself, so every hit pixel is
    /// unoccluded (used by the analytic tests).
    pub fn sphere_only() -> Self {
        Scene {
            ground: None,
            ..Scene::default_scene()
        }
    }

    /// The nearest accepted hit of the ray `origin + t·dir` (`dir` unit).
    pub fn intersect(&self, origin: &Vec3, dir: &Vec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        if let Some(s) = &self.sphere
            && let Some(t) = sphere_t(s, &self.rays, origin, dir)
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
            && let Some(t) = ground_t(g, &self.rays, origin, dir)
            && best.is_none_or(|b| t < b.t)
        {
            let normal = if dir.y > 0.0 { -Vec3::y() } else { Vec3::y() };
            best = Some(Hit {
                t,
                point: origin + dir * t,
                normal,
                albedo: g.albedo,
            });
        }
        best
    }

    /// Whether the ray `origin + t·dir` hits anything the ray rule accepts (visibility of the
    /// environment).
    #[inline]
    pub fn occluded(&self, origin: &Vec3, dir: &Vec3) -> bool {
        self.sphere
            .as_ref()
            .is_some_and(|s| sphere_t(s, &self.rays, origin, dir).is_some())
            || self
                .ground
                .as_ref()
                .is_some_and(|g| ground_t(g, &self.rays, origin, dir).is_some())
    }
}

/// The scenes the renderer knows, by name (`--scene`, a render table's `"scene"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum SceneKind {
    /// The workbench's sphere on a square (render-scene.md), 256×256 by default.
    #[default]
    Workbench,
    /// The thesis code's sphere on a parallelogram under a camera at the origin, 500×500.
    Thesis,
}

impl SceneKind {
    pub const ALL: [SceneKind; 2] = [SceneKind::Workbench, SceneKind::Thesis];

    /// `workbench` or `thesis`.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Workbench => "workbench",
            SceneKind::Thesis => "thesis",
        }
    }

    /// Parses [`SceneKind::name`]; `what` names the option or field in the error.
    pub fn from_name(name: &str, what: &str) -> Result<Self, InputError> {
        Self::ALL.into_iter().find(|k| k.name() == name).ok_or_else(|| {
            InputError::new(format!(
                "{what}: unknown scene {name:?}; the scenes are {}",
                Self::ALL.map(|k| k.name()).join(", ")
            ))
        })
    }

    /// The scene's objects and ray rule.
    pub fn scene(self) -> Scene {
        match self {
            SceneKind::Workbench => workbench::scene(),
            SceneKind::Thesis => thesis::scene(),
        }
    }

    /// The scene's camera for a `width × height` image.
    pub fn camera(self, width: usize, height: usize) -> Camera {
        match self {
            SceneKind::Workbench => workbench::camera(width, height),
            SceneKind::Thesis => thesis::camera(width, height),
        }
    }

    /// The image size when none is given.
    pub fn default_size(self) -> (usize, usize) {
        match self {
            SceneKind::Workbench => workbench::DEFAULT_SIZE,
            SceneKind::Thesis => thesis::DEFAULT_SIZE,
        }
    }
}

/// The nearer root of `‖o + t d − c‖² = r²` if the ray rule accepts it, else the farther:
/// `t = −b ∓ sqrt(b² − (‖o − c‖² − r²))`, `b = (o − c)·d`.
#[inline]
fn sphere_t(s: &Sphere, rays: &RayRule, origin: &Vec3, dir: &Vec3) -> Option<f64> {
    let oc = origin - s.centre;
    let b = oc.dot(dir);
    let c = oc.norm_squared() - s.radius * s.radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    let near = -b - root;
    if rays.accepts(near) {
        return Some(near);
    }
    let far = -b + root;
    rays.accepts(far).then_some(far)
}

/// `t = (height − o.y) / d.y` if the ray rule accepts it and the point is inside the rectangle.
#[inline]
fn ground_t(g: &Ground, rays: &RayRule, origin: &Vec3, dir: &Vec3) -> Option<f64> {
    if dir.y == 0.0 {
        return None;
    }
    let t = (g.height - origin.y) / dir.y;
    if !rays.accepts(t) {
        return None;
    }
    let x = origin.x + t * dir.x;
    let z = origin.z + t * dir.z;
    (g.x[0] <= x && x <= g.x[1] && g.z[0] <= z && z <= g.z[1]).then_some(t)
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

    #[test]
    fn scene_names_round_trip_and_unknown_names_are_refused() {
        for k in SceneKind::ALL {
            assert_eq!(SceneKind::from_name(k.name(), "--scene").unwrap(), k);
        }
        let e = SceneKind::from_name("cornell", "--scene").unwrap_err().0;
        assert_eq!(
            e,
            "--scene: unknown scene \"cornell\"; the scenes are workbench, thesis"
        );
    }
}
