//! The texel sum (`render::texel`, math.md §10) on synthetic maps, under both lookups: closed
//! forms (a constant map, one bright cell, a half-black map) and brute-force MC over the
//! renderer's own integrand on the thesis scene, where occluders cut the cells.

use std::f64::consts::{PI, TAU};
use workbench::render::env::{EnvMap, Lookup};
use workbench::render::exact;
use workbench::render::integrator::ShadingPoint;
use workbench::render::{Environment, Renderer, Scene, SceneKind};
use workbench::util::geometry::Vec3;
use workbench::util::rng::stream;

use crate::brute_force::assert_agrees_with_cosine_mc;

fn map(w: usize, h: usize, lookup: Lookup, texel: impl Fn(usize, usize) -> [f32; 3]) -> Environment {
    let texels = (0..h)
        .flat_map(|r| (0..w).map(move |c| (r, c)))
        .map(|(r, c)| texel(r, c))
        .collect();
    Environment::Map(EnvMap::from_texels(w, h, texels).with_lookup(lookup))
}

/// Every `step`-th hit pixel of `r`.
fn points(r: &Renderer, step: usize) -> Vec<((usize, usize), ShadingPoint)> {
    let mut out = Vec::new();
    for j in 0..r.height {
        for i in 0..r.width {
            if let Some(p) = r.shading_point(i, j) {
                out.push(((i, j), p));
            }
        }
    }
    out.into_iter().step_by(step).collect()
}

/// A constant map is `--env white` scaled: with nothing in the way every pixel is
/// `L·albedo`, under either lookup.
#[test]
fn a_constant_map_gives_the_albedo_times_its_radiance() {
    for lookup in Lookup::ALL {
        let env = map(16, 9, lookup, |_, _| [2.0, 0.5, 1.0]);
        let mut r = Renderer::new(24, 24, env);
        r.scene = Scene::sphere_only();
        for (px, p) in points(&r, 7) {
            let q = exact::integrate(&p, &r.scene, &r.env, 1e-9);
            for (c, l) in [2.0, 0.5, 1.0].iter().enumerate() {
                let expected = l * p.albedo[c];
                assert!(
                    (q.value[c] - expected).abs() <= 1e-9 + q.error,
                    "{lookup:?} {px:?} channel {c}: {} vs {expected}",
                    q.value[c]
                );
            }
            assert!(q.error <= 1e-9, "{px:?}: {:e}", q.error);
        }
    }
}

/// Half-black (thesis lookup, `H − 1` even so the cells split at the horizon): the upper
/// hemisphere of the map at radiance 1 seen by an unoccluded surface of normal `n` gives
/// `(albedo/π) ∫_{H(n) ∩ H(y)} n·ω dω = albedo (1 + n_y)/2`.
#[test]
fn a_half_black_map_gives_the_clipped_hemisphere() {
    let env = map(
        12,
        9,
        Lookup::Thesis,
        |r, _| if r < 4 { [1.0; 3] } else { [0.0; 3] },
    );
    let mut r = Renderer::new(32, 32, env);
    r.scene = Scene::sphere_only();
    let pts = points(&r, 5);
    assert!(pts.len() > 20);
    for (px, p) in pts {
        let q = exact::integrate(&p, &r.scene, &r.env, 1e-9);
        let expected = p.albedo[0] * (1.0 + p.frame.n.y) / 2.0;
        assert!(
            (q.value[0] - expected).abs() <= 1e-9 + q.error,
            "{px:?} n = {:?}: {} vs {expected}",
            p.frame.n,
            q.value[0]
        );
    }
}

/// One bright cell (thesis lookup), wholly above an unoccluded surface's horizon:
/// `(albedo/π) L ∫_cell n·d sin θ dθ dψ` with `d = (sin θ sin ψ, cos θ, −sin θ cos ψ)`:
/// `n_x S (cos ψ₀ − cos ψ₁) + n_y C (ψ₁ − ψ₀) − n_z S (sin ψ₁ − sin ψ₀)`,
/// `S = ∫ sin²θ dθ`, `C = ∫ sin θ cos θ dθ` over the cell's rows.
#[test]
fn a_single_bright_cell_matches_its_closed_form() {
    let (w, h) = (9usize, 7usize);
    let (row, col) = (1usize, 7usize);
    let env = map(w, h, Lookup::Thesis, |r, c| {
        if (r, c) == (row, col) { [7.0; 3] } else { [0.0; 3] }
    });
    let (t0, t1) = (
        row as f64 * PI / (h - 1) as f64,
        (row + 1) as f64 * PI / (h - 1) as f64,
    );
    let (p0, p1) = (
        -PI + TAU * col as f64 / (w - 1) as f64,
        -PI + TAU * (col + 1) as f64 / (w - 1) as f64,
    );
    let s = |t: f64| t / 2.0 - (2.0 * t).sin() / 4.0;
    let cc = |t: f64| t.sin().powi(2) / 2.0;
    let (big_s, big_c) = (s(t1) - s(t0), cc(t1) - cc(t0));
    let mut r = Renderer::new(32, 32, env);
    r.scene = Scene::sphere_only();
    let mut checked = 0;
    for (px, p) in points(&r, 2) {
        let n = p.frame.n;
        // The cell's corners and edge midpoints all above the horizon (n·d > 0 on the cell,
        // as n·d is a great-circle test and the cell is small).
        let inside = [t0, 0.5 * (t0 + t1), t1].iter().all(|&t| {
            [p0, 0.5 * (p0 + p1), p1]
                .iter()
                .all(|&ps| n.dot(&Vec3::new(t.sin() * ps.sin(), t.cos(), -t.sin() * ps.cos())) > 0.05)
        });
        if !inside {
            continue;
        }
        checked += 1;
        let cell = n.x * big_s * (p0.cos() - p1.cos()) + n.y * big_c * (p1 - p0)
            - n.z * big_s * (p1.sin() - p0.sin());
        let expected = p.albedo[0] / PI * 7.0 * cell;
        let q = exact::integrate(&p, &r.scene, &r.env, 1e-10);
        assert!(
            (q.value[0] - expected).abs() <= 1e-10 + q.error,
            "{px:?}: {} vs {expected}",
            q.value[0]
        );
    }
    assert!(checked >= 10, "only {checked} pixels see the whole cell");
}

/// Against brute force: on the thesis scene (the sphere shadows the floor, the floor the
/// sphere, the horizon cuts cells) under a map of random texels with a bright "sun", the texel
/// sum and a 400 000-sample MC estimate of the renderer's own integrand (cosine-weighted; the
/// map read by its lookup, visibility by its ray rule) agree within 5 standard errors, for
/// both lookups.
#[test]
fn the_texel_sum_agrees_with_brute_force_on_the_thesis_scene() {
    let samples = 400_000;
    for lookup in Lookup::ALL {
        let mut rng = stream(11, &[]);
        use rand::RngExt;
        let texels: Vec<[f32; 3]> = (0..24 * 12)
            .map(|k| {
                let sun = if k == 3 * 24 + 17 { 50.0 } else { 0.0 };
                [
                    rng.random::<f32>() + sun,
                    rng.random::<f32>(),
                    0.2 * rng.random::<f32>(),
                ]
            })
            .collect();
        let env = Environment::Map(EnvMap::from_texels(24, 12, texels).with_lookup(lookup));
        let r = Renderer::for_scene(SceneKind::Thesis, 40, 40, env);
        let mut checked = 0;
        for (px, p) in points(&r, 97) {
            let q = exact::integrate(&p, &r.scene, &r.env, 1e-7);
            let mut rng = stream(12, &[(px.1 * 40 + px.0) as u64]);
            let what = format!("{lookup:?} {px:?}");
            assert_agrees_with_cosine_mc(&q, &p, &r.scene, &r.env, samples, &mut rng, &what);
            checked += 1;
        }
        assert!(checked >= 5, "{checked}");
    }
}

/// One texel of 3·10¹¹ in an 8×4 map of ones (issue 42.1: `render --integrator exact` never
/// ended, bisecting rounding noise far above its 1e-6 absolute tolerance): the irradiance ends,
/// below the work limit, at the value linearity gives (`E = 1 + (3·10¹¹ − 1) E₁`, `E₁` the same
/// texel alone at 1), within its stated error. That error carries the sums' rounding floor,
/// which scales with the map, not the value (a prefix sum past the bright texel is 10¹¹: a
/// difference of two of them is off by 10⁻⁵ even where `E = 1`); it stays within 10⁻¹⁴ of the
/// bright texel. Both lookups, three normals.
#[test]
fn a_very_bright_texel_ends_with_its_rounding_floor_stated() {
    use workbench::render::texel;
    let sun = 3e11f32;
    for lookup in Lookup::ALL {
        let bright = map(
            8,
            4,
            lookup,
            |r, c| if (r, c) == (1, 2) { [sun; 3] } else { [1.0; 3] },
        );
        let alone = map(
            8,
            4,
            lookup,
            |r, c| if (r, c) == (1, 2) { [1.0; 3] } else { [0.0; 3] },
        );
        let (Environment::Map(mb), Environment::Map(ma)) = (&bright, &alone) else {
            unreachable!()
        };
        for n in [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.3, 0.5, -0.8).normalize(),
        ] {
            let q = texel::irradiance(n, &bright, mb, 1e-6);
            let one = texel::irradiance(n, &alone, ma, 1e-13);
            assert!(!q.work_limited, "{lookup:?} {n:?}: work limit");
            assert!(
                q.evaluations < 1 << 20,
                "{lookup:?} {n:?}: {} nodes",
                q.evaluations
            );
            let want = 1.0 + (sun as f64 - 1.0) * one.value[0];
            let slack = q.error + (sun as f64) * one.error;
            assert!(
                (q.value[0] - want).abs() <= slack,
                "{lookup:?} {n:?}: {} vs {want} (stated {:.1e} + {:.1e})",
                q.value[0],
                q.error,
                (sun as f64) * one.error
            );
            assert!(
                q.error <= 1e-14 * sun as f64,
                "{lookup:?} {n:?}: stated {:.2e} of {want:.3e}",
                q.error
            );
        }
    }
}
