//! The certified pixel quadrature (`render::exact`) against closed forms and an independent
//! method. Closed forms are computed to ~1e-14, so a difference above the quadrature's tolerance
//! plus its own error estimate is a failure of the quadrature.

use rand::RngExt;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use workbench::integrand::family::{AxisIntegrand, Profile};
use workbench::render::exact::{self, DEFAULT_TOLERANCE};
use workbench::render::integrator::ShadingPoint;
use workbench::render::scene::{Ground, Scene};
use workbench::render::{Environment, Renderer};
use workbench::util::geometry::Vec3;
use workbench::util::quadrature::GaussLegendre;
use workbench::util::rng::stream;

const SIZE: usize = 64;

fn renderer(scene: Scene, env: Environment) -> Renderer {
    let mut r = Renderer::new(SIZE, SIZE, env);
    r.scene = scene;
    r
}

/// Every hit pixel's shading point, with whether it is on the ground.
fn hits(r: &Renderer) -> Vec<((usize, usize), ShadingPoint)> {
    let mut out = Vec::new();
    for j in 0..SIZE {
        for i in 0..SIZE {
            if let Some(p) = r.shading_point(i, j) {
                out.push(((i, j), p));
            }
        }
    }
    out
}

fn on_ground(p: &ShadingPoint) -> bool {
    p.frame.n.y == 1.0 && (p.origin.y - ShadingPoint::EPSILON).abs() < 1e-12
}

/// `∫ (ω·y) dω` over the cone from `x'` to the default sphere, clipped to `ω.y ≥ 0`, in
/// coordinates about the cone's axis `c` (a different split from the quadrature's): at polar
/// angle ψ about `c` the circle's part above the horizon is the arc `|φ| ≤ Φ(ψ)/2` with
/// `cos(Φ/2) = clamp(−cos ψ c_y / (sin ψ e_y), −1, 1)` (`e` the unit vector ⊥ `c` towards `+y`),
/// and `∫_arc ω·y dφ = cos ψ c_y Φ + 2 sin ψ e_y sin(Φ/2)` (math.md §1's `A_1`). The ψ-integral
/// is split where the clamp starts to act and integrated by composite Gauss–Legendre in the
/// angle, after `ψ = a + h sin(πv/2)` for the square-root ends.
fn clipped_cone_cosine(origin: Vec3, centre: Vec3, radius: f64) -> f64 {
    let d = centre - origin;
    let dist = d.norm();
    let c = d / dist;
    let beta = (radius / dist).asin();
    let e_y = (1.0 - c.y * c.y).sqrt();
    let arc = |psi: f64| -> f64 {
        let (s, co) = psi.sin_cos();
        let ratio = if s * e_y > 0.0 {
            (-co * c.y / (s * e_y)).clamp(-1.0, 1.0)
        } else {
            -1.0
        };
        let phi = 2.0 * ratio.acos();
        s * (co * c.y * phi + 2.0 * s * e_y * (phi / 2.0).sin())
    };
    // The clamp stops acting where the circle touches the horizon: ψ = π/2 − θ_c (θ_c the
    // angle of c from +y).
    let kink = FRAC_PI_2 - c.y.acos();
    let mut pieces = vec![0.0];
    if kink > 0.0 && kink < beta {
        pieces.push(kink);
    }
    pieces.push(beta);
    let gl = GaussLegendre::new(40);
    let mut total = 0.0;
    for w in pieces.windows(2) {
        let (a, b) = (w[0], w[1]);
        let m = 64;
        for k in 0..m {
            let (v0, v1) = (
                -1.0 + 2.0 * k as f64 / m as f64,
                -1.0 + 2.0 * (k + 1) as f64 / m as f64,
            );
            let (c0, h0) = (0.5 * (a + b), 0.5 * (b - a));
            total += gl.integrate(v0, v1, |v| {
                let psi = c0 + h0 * (FRAC_PI_2 * v).sin();
                arc(psi) * h0 * FRAC_PI_2 * (FRAC_PI_2 * v).cos()
            });
        }
    }
    total
}

/// White environment, ground without a sphere: every ground pixel equals its albedo exactly
/// (`∫_H (albedo/π) cos θ dω = albedo`).
#[test]
fn unoccluded_ground_under_white_is_its_albedo() {
    let scene = Scene {
        sphere: None,
        ..Scene::default_scene()
    };
    let r = renderer(scene, Environment::White);
    let points = hits(&r);
    assert!(points.len() > 100);
    for (px, p) in points.iter().step_by(97) {
        let q = exact::integrate(p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        for c in 0..3 {
            assert!((q.value[c] - 0.75).abs() <= 1e-12, "{px:?}: {:?}", q.value);
        }
        assert!(q.error <= DEFAULT_TOLERANCE, "{px:?}: {}", q.error);
    }
}

/// White environment, default scene: a ground pixel is `albedo (1 − (1/π) ∫_{cone ∩ H} ω·y dω)`,
/// the cone clipped to the horizon computed in the cone's own coordinates. Covers the contact
/// shadow (the pixels nearest the sphere's foot) and open ground.
#[test]
fn occluded_ground_under_white_is_albedo_minus_the_clipped_cone() {
    let r = renderer(Scene::default_scene(), Environment::White);
    let sphere = r.scene.sphere.unwrap();
    let mut ground: Vec<_> = hits(&r).into_iter().filter(|(_, p)| on_ground(p)).collect();
    // Nearest to the contact point first.
    ground.sort_by(|a, b| a.1.origin.xz().norm().total_cmp(&b.1.origin.xz().norm()));
    let picks = [0, 1, 2, 5, 20, ground.len() / 2, ground.len() - 1];
    for &k in &picks {
        let (px, p) = &ground[k];
        let q = exact::integrate(p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        let hidden = clipped_cone_cosine(p.origin, sphere.centre, sphere.radius);
        let expected = 0.75 * (1.0 - hidden / PI);
        let diff = (q.value[0] - expected).abs();
        assert!(
            diff <= DEFAULT_TOLERANCE + q.error,
            "{px:?} at {:?}: {} vs {expected} (diff {diff:e}, est {:e})",
            p.origin,
            q.value[0],
            q.error
        );
        assert!(
            q.error <= DEFAULT_TOLERANCE,
            "{px:?}: error estimate {:e}",
            q.error
        );
    }
}

/// `∫_{P} (ω·n) dω` over the spherical polygon seen from `o` through the vertices `v` (in
/// order), by Lambert's formula `½ |Σ_i Θ_i (n·Γ_i)|`, `Θ_i` the angle between consecutive
/// vertex directions and `Γ_i` the unit normal of their plane. Valid for a polygon in `ω·n ≥ 0`.
fn lambert(o: Vec3, n: Vec3, v: &[Vec3]) -> f64 {
    let u: Vec<Vec3> = v.iter().map(|p| (p - o).normalize()).collect();
    let mut s = 0.0;
    for i in 0..u.len() {
        let (a, b) = (u[i], u[(i + 1) % u.len()]);
        let cross = a.cross(&b);
        let theta = cross.norm().atan2(a.dot(&b));
        if cross.norm() > 0.0 {
            s += theta * n.dot(&cross.normalize());
        }
    }
    0.5 * s.abs()
}

/// The ground square clipped to the half-space `(p − o)·n ≥ 0` (Sutherland–Hodgman).
fn clipped_square(half: f64, o: Vec3, n: Vec3) -> Vec<Vec3> {
    let square = [
        Vec3::new(-half, 0.0, -half),
        Vec3::new(half, 0.0, -half),
        Vec3::new(half, 0.0, half),
        Vec3::new(-half, 0.0, half),
    ];
    let side = |p: &Vec3| (p - o).dot(&n);
    let mut out = Vec::new();
    for i in 0..4 {
        let (a, b) = (square[i], square[(i + 1) % 4]);
        let (sa, sb) = (side(&a), side(&b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
    out
}

/// White environment: a sphere pixel is `albedo (1 − (1/π) ∫_{Q ∩ H(n)} ω·n dω)` with `Q` the
/// ground square seen from `x'` (Lambert's polygon formula on the clipped square); without the
/// ground it is the albedo exactly (a convex object never shadows itself).
#[test]
fn sphere_under_white_is_albedo_minus_what_the_square_hides() {
    let r = renderer(Scene::default_scene(), Environment::White);
    let half = r.scene.ground.unwrap().x[1];
    let lone = renderer(Scene::sphere_only(), Environment::White);
    let sphere: Vec<_> = hits(&r).into_iter().filter(|(_, p)| !on_ground(p)).collect();
    assert!(sphere.len() > 100);
    let mut checked_partial = 0;
    for (px, p) in sphere.iter().step_by(37) {
        let n = p.frame.n;
        let q = exact::integrate(p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        let poly = clipped_square(half, p.origin, n);
        let hidden = if poly.len() >= 3 {
            lambert(p.origin, n, &poly)
        } else {
            0.0
        };
        if hidden > 0.0 && hidden < 0.5 {
            checked_partial += 1;
        }
        for (c, albedo) in p.albedo.iter().enumerate() {
            let expected = albedo * (1.0 - hidden / PI);
            let diff = (q.value[c] - expected).abs();
            assert!(
                diff <= DEFAULT_TOLERANCE + q.error,
                "{px:?} n = {n:?}: {} vs {expected} ({diff:e})",
                q.value[c]
            );
        }
        assert!(q.error <= DEFAULT_TOLERANCE, "{px:?}: {:e}", q.error);
        let alone = exact::integrate(p, &lone.scene, &lone.env, DEFAULT_TOLERANCE);
        for c in 0..3 {
            assert!((alone.value[c] - p.albedo[c]).abs() <= 1e-12, "{px:?}");
        }
    }
    assert!(
        checked_partial >= 3,
        "too few pixels see part of the square: {checked_partial}"
    );
}

/// Sky, ground without a sphere: `(albedo/π) [2π (A/6 + Z/3) + S ∫_H max(0, ω·s)^32 ω·y dω]`
/// (sky `A (1 − h) + Z h`, `h = ω·y = cos θ`), the sun lobe's integral from the lobe family's
/// one-dimensional truth (tilt of `s` from the normal: `s.y = 2/3`).
#[test]
fn open_ground_under_the_sky_matches_the_closed_form() {
    let scene = Scene {
        sphere: None,
        ground: Some(Ground::square(5.0, [0.75; 3])),
        ..Scene::default_scene()
    };
    let r = renderer(scene, Environment::Sky);
    let sy: f64 = 2.0 / 3.0;
    let lobe = AxisIntegrand::new(
        Profile::Lobe { exponent: 32.0 },
        [(1.0 - sy * sy).sqrt(), 0.0, sy],
        true,
    )
    .unwrap()
    .integral();
    let (a, z, sun) = ([0.90, 0.90, 0.85], [0.30, 0.50, 0.90], [6.0, 5.6, 4.8]);
    let (_, p) = hits(&r)[100];
    let q = exact::integrate(&p, &r.scene, &r.env, DEFAULT_TOLERANCE);
    for c in 0..3 {
        let expected = 0.75 / PI * (TAU * (a[c] / 6.0 + z[c] / 3.0) + sun[c] * lobe);
        let diff = (q.value[c] - expected).abs();
        assert!(
            diff <= DEFAULT_TOLERANCE + q.error,
            "channel {c}: {} vs {expected} ({diff:e})",
            q.value[c]
        );
    }
    assert!(q.error <= DEFAULT_TOLERANCE);
}

/// Sky, default scene: the quadrature against a stratified estimate of the renderer's own
/// integrand (`ShadingPoint::integrand`, ray-traced visibility) on a 700 × 700 grid in
/// `(cos θ, φ)` about the normal, one jittered sample per stratum. The strata are independent,
/// so the estimate's standard error is estimated from pairs of neighbouring strata; the two
/// must agree within 5 standard errors (plus the quadrature's tolerance). Pixels: open ground,
/// the contact shadow, the sphere near its silhouette and under the horizon.
#[test]
fn sky_pixels_agree_with_a_stratified_estimate_of_the_renderers_integrand() {
    let r = renderer(Scene::default_scene(), Environment::Sky);
    let all = hits(&r);
    let ground: Vec<_> = all.iter().filter(|(_, p)| on_ground(p)).collect();
    let sphere: Vec<_> = all.iter().filter(|(_, p)| !on_ground(p)).collect();
    let contact = ground
        .iter()
        .min_by(|a, b| a.1.origin.xz().norm().total_cmp(&b.1.origin.xz().norm()))
        .unwrap();
    let silhouette = sphere
        .iter()
        .min_by(|a, b| a.1.frame.n.z.total_cmp(&b.1.frame.n.z))
        .unwrap();
    let below = sphere
        .iter()
        .min_by(|a, b| a.1.frame.n.y.total_cmp(&b.1.frame.n.y))
        .unwrap();
    let picks = [
        ground[ground.len() / 3],
        *contact,
        *silhouette,
        *below,
        sphere[sphere.len() / 2],
    ];
    let m = 700usize;
    for (k, (px, p)) in picks.iter().enumerate() {
        let q = exact::integrate(p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        let mut rng = stream(17, &[k as u64]);
        let mut sum = [0.0; 3];
        let mut pair_var = [0.0; 3];
        let cell = TAU / (m * m) as f64;
        for a in 0..m {
            let mut prev = [0.0; 3];
            for b in 0..m {
                let (u1, u2): (f64, f64) = (rng.random(), rng.random());
                let mu = (a as f64 + u1) / m as f64;
                let phi = TAU * (b as f64 + u2) / m as f64;
                let s = (1.0 - mu * mu).max(0.0).sqrt();
                let v = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
                let f = p.integrand(&r.scene, &r.env, &v).map(|x| x * cell);
                for c in 0..3 {
                    sum[c] += f[c];
                    if b % 2 == 1 {
                        // Var(X − Y)/2 estimates each stratum's variance (a slight
                        // overestimate: neighbours' means differ too).
                        pair_var[c] += (f[c] - prev[c]).powi(2);
                    }
                }
                prev = f;
            }
        }
        for c in 0..3 {
            // Σ over pairs of (X − Y)² has mean Σ over strata of Var (plus the pairs' squared mean
            // differences), so this overestimates the standard error slightly.
            let se = pair_var[c].sqrt();
            let diff = (q.value[c] - sum[c]).abs();
            assert!(
                diff <= 5.0 * se + DEFAULT_TOLERANCE,
                "pixel {px:?} channel {c}: exact {} ± {:e}, stratified {} ± {se:e}",
                q.value[c],
                q.error,
                sum[c]
            );
        }
        assert!(q.error <= DEFAULT_TOLERANCE, "{px:?}: {:e}", q.error);
    }
}

/// Environment maps are integrated cell by cell: a constant map is the white environment, and a
/// small random map agrees with the stratified estimate of the renderer's integrand.
#[test]
fn maps_are_integrated_cell_by_cell() {
    use workbench::render::env::EnvMap;
    let constant = Environment::Map(EnvMap::from_texels(6, 4, vec![[1.0; 3]; 24]));
    let r = renderer(Scene::default_scene(), constant);
    let white = renderer(Scene::default_scene(), Environment::White);
    for (px, p) in hits(&r).iter().step_by(301) {
        let a = exact::integrate(p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        let b = exact::integrate(p, &white.scene, &white.env, DEFAULT_TOLERANCE);
        for c in 0..3 {
            assert!(
                (a.value[c] - b.value[c]).abs() <= 2.0 * DEFAULT_TOLERANCE,
                "{px:?}"
            );
        }
    }
    let mut rng = stream(5, &[1]);
    let texels: Vec<[f32; 3]> = (0..8 * 5)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    let r = renderer(
        Scene::default_scene(),
        Environment::Map(EnvMap::from_texels(8, 5, texels)),
    );
    let all = hits(&r);
    let m = 600usize;
    for (px, p) in [all[all.len() / 4], all[all.len() / 2]] {
        let q = exact::integrate(&p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        assert!(q.error <= DEFAULT_TOLERANCE, "{px:?}: {:e}", q.error);
        let cell = TAU / (m * m) as f64;
        let (mut sum, mut var) = (0.0, 0.0);
        for a in 0..m {
            let mut prev = 0.0;
            for b in 0..m {
                let (u1, u2): (f64, f64) = (rng.random(), rng.random());
                let mu = (a as f64 + u1) / m as f64;
                let phi = TAU * (b as f64 + u2) / m as f64;
                let s = (1.0 - mu * mu).max(0.0).sqrt();
                let f = p.integrand(&r.scene, &r.env, &Vec3::new(s * phi.cos(), s * phi.sin(), mu))[1] * cell;
                sum += f;
                if b % 2 == 1 {
                    var += (f - prev).powi(2);
                }
                prev = f;
            }
        }
        let se = var.sqrt();
        assert!(
            (q.value[1] - sum).abs() <= 5.0 * se + DEFAULT_TOLERANCE,
            "{px:?}: {} vs {sum} ± {se:e}",
            q.value[1]
        );
    }
}

/// A `pixel` integrand in an experiment is the renderer's integrand at that pixel in its local
/// frame, and its truth is the quadrature's; bad pixels, channels and maps are one-line errors
/// naming the field.
#[test]
fn pixel_integrands_resolve_to_the_renderers_integrand() {
    use workbench::experiment::plan::{parse, resolve};
    use workbench::integrand::Integrand;
    let spec = |integrand: &str| {
        format!(
            r#"{{"name": "px", "integrands": [{integrand}], "estimators": [{{"label": "MC", "method": "mc"}}],
                "samples": [4], "trials": 2, "seed": 1}}"#
        )
    };
    let plan = resolve(&parse(&spec(r#"{"type": "pixel", "pixel": [20, 50], "width": 64, "height": 64, "env": "sky", "channel": "b"}"#)).unwrap()).unwrap();
    let f = &plan.integrands[0];
    assert_eq!(f.name(), "pixel-20-50-sky-b");
    assert!(matches!(f, Integrand::Pixel { .. }));
    let r = Renderer::new(64, 64, Environment::Sky);
    let p = r.shading_point(20, 50).unwrap();
    let q = exact::integrate(&p, &r.scene, &r.env, DEFAULT_TOLERANCE);
    assert_eq!(f.integral(), q.value[2]);
    let mut rng = stream(3, &[0]);
    for _ in 0..1000 {
        let (u1, u2): (f64, f64) = (rng.random(), rng.random());
        let s = (1.0 - u1 * u1).sqrt();
        let v = Vec3::new(s * (TAU * u2).cos(), s * (TAU * u2).sin(), u1);
        assert_eq!(f.value(&v), p.integrand(&r.scene, &r.env, &v)[2]);
    }
    let bad = |integrand: &str| resolve(&parse(&spec(integrand)).unwrap()).unwrap_err();
    assert_eq!(
        bad(r#"{"type": "pixel", "pixel": [64, 0], "width": 64, "height": 64, "channel": "g"}"#),
        "integrands[0].pixel: [64, 0] is outside the 64×64 image (columns 0..64, rows 0..64)"
    );
    assert!(
        bad(r#"{"type": "pixel", "pixel": [0, 0], "width": 64, "height": 64, "channel": "g"}"#)
            .starts_with("integrands[0].pixel: [0, 0] of the 64×64 image shows the background")
    );
    assert!(
        bad(r#"{"type": "pixel", "pixel": [20, 50], "channel": "a"}"#).starts_with("integrands[0].channel: ")
    );
    assert!(
        bad(r#"{"type": "pixel", "pixel": [20, 50], "channel": "r", "env": "/nonexistent.hdr"}"#)
            .starts_with("integrands[0].env: /nonexistent.hdr: cannot read")
    );
}

/// Tolerance met against a far tighter run: on every 5th hit pixel of a 32×32 sky render, the
/// default-tolerance value lies within 1e-9 of the value at 1e-12 in every channel.
#[test]
fn default_tolerance_holds_against_a_tighter_run() {
    let r = Renderer::new(32, 32, Environment::Sky);
    let mut checked = 0;
    for k in (0..32 * 32).step_by(5) {
        let Some(p) = r.shading_point(k % 32, k / 32) else {
            continue;
        };
        let a = exact::integrate(&p, &r.scene, &r.env, DEFAULT_TOLERANCE);
        let b = exact::integrate(&p, &r.scene, &r.env, 1e-12);
        for c in 0..3 {
            let d = (a.value[c] - b.value[c]).abs();
            assert!(d <= DEFAULT_TOLERANCE, "pixel {k}: {d:e}");
        }
        checked += 1;
    }
    assert!(checked > 100);
}
