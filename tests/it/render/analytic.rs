//! The renderer's analytic checks (thesis §3.2.6, Tests 1–3), determinism across thread counts,
//! BMCP's prior and the RMSE ordering of MC and BMC.

// Channels are indexed in step across pixels, albedos and sky values.
#![allow(clippy::needless_range_loop)]

use workbench::bq::kernel::{Kernel, Sobolev};
use workbench::bq::kernel_mean::KernelMeanMode;
use workbench::bq::model::BmcModel;
use workbench::bq::weights::DEFAULT_NOISE;
use workbench::render::integrator::BmcSets;
use workbench::render::{Environment, Image, Integrator, IntegratorKind, Renderer, Scene};
use workbench::sampling::Density;
use workbench::util::geometry::Vec3;
use workbench::util::report::Silent;

fn model() -> BmcModel {
    BmcModel::new(
        Kernel::Sobolev(Sobolev::new(1.4).unwrap()),
        DEFAULT_NOISE,
        KernelMeanMode::Exact,
    )
}

fn hidden() -> Silent {
    Silent
}

/// The renderer with only the sphere (convex, so every hit pixel sees its whole hemisphere).
fn sphere_only(size: usize, env: Environment) -> Renderer {
    Renderer {
        scene: Scene::sphere_only(),
        ..Renderer::new(size, size, env)
    }
}

/// `(pixel index, albedo, normal)` of the pixels whose primary ray hits the scene.
fn hits(r: &Renderer) -> Vec<(usize, [f64; 3], Vec3)> {
    let mut out = Vec::new();
    for j in 0..r.height {
        for i in 0..r.width {
            if let Some(h) = r.scene.intersect(&r.camera.origin, &r.camera.ray(i, j)) {
                out.push((j * r.width + i, h.albedo, h.normal));
            }
        }
    }
    out
}

fn bmc(kind: IntegratorKind, spp: usize, gps: usize, rotate: bool, m: &BmcModel, seed: u64) -> Integrator {
    Integrator::build(kind, spp, gps, rotate, Some(m), seed).unwrap()
}

fn sets(i: &Integrator) -> &BmcSets {
    i.sets.as_ref().expect("an integrator with weights")
}

/// Test 1 adapted: under `env = 1` an unoccluded Lambertian pixel is
/// `∫ (albedo/π) cos θ dω = albedo`. MC-cos is exact per sample; MC is unbiased (mean over the
/// pixels within 5 standard errors, per-pixel variance `albedo²/(3N)`); BMC gives
/// `albedo · Σ w_i cos θ_i / π`, off by its set's quadrature error for `cos θ` (itself within
/// the RKHS bound `‖cos θ‖_H e(w)`); BMCP adds `c (2π − Σ w_i)`, the weight-sum error times the
/// prior.
#[test]
fn white_environment_gives_the_albedo_for_every_integrator() {
    let r = sphere_only(48, Environment::White);
    let hit = hits(&r);
    assert!(hit.len() > 200, "{} sphere pixels", hit.len());
    let m = model();
    let spp = 40;

    let img = r.render(&Integrator::mc(Density::Cosine, spp), 1, &hidden());
    for (k, a, _) in &hit {
        for c in 0..3 {
            assert!(
                (img.data[*k][c] - a[c]).abs() < 1e-12,
                "mc-cos {:?} vs {a:?}",
                img.data[*k]
            );
        }
    }

    let img = r.render(&Integrator::mc(Density::Uniform, spp), 2, &hidden());
    for c in 0..3 {
        let a = hit[0].1[c];
        let mean = hit.iter().map(|(k, _, _)| img.data[*k][c]).sum::<f64>() / hit.len() as f64;
        let se = a / (3.0 * spp as f64 * hit.len() as f64).sqrt();
        assert!(
            (mean - a).abs() < 5.0 * se,
            "mc channel {c}: {mean} vs {a} (se {se})"
        );
    }

    for kind in [IntegratorKind::BMC, IntegratorKind::BMCP] {
        let integ = bmc(kind, spp, 4, true, &m, 3);
        let s = sets(&integ);
        // Each set's quadrature of cos θ (exact: π).
        let cos_quadrature = |set: &workbench::render::integrator::SampleSet| -> f64 {
            set.points
                .iter()
                .zip(&set.weights.weights)
                .map(|(p, w)| w * p.z)
                .sum()
        };
        let cos_error = s
            .sets
            .iter()
            .map(|set| (cos_quadrature(set) / std::f64::consts::PI - 1.0).abs())
            .fold(0.0, f64::max);
        let sum_error = s
            .sets
            .iter()
            .map(|set| (set.weights.diagnostics.weight_sum - std::f64::consts::TAU).abs())
            .fold(0.0, f64::max);
        // The error on cos θ is within the RKHS worst-case bound ‖cos θ‖_H e(w) of each set.
        let (_, norm_cos) = crate::common::rkhs_norms_of_one_and_cos(&m.kernel);
        let table = workbench::bq::kernel_mean::KernelMeanTable::new(&m.kernel);
        for set in &s.sets {
            let z: Vec<f64> = set.points.iter().map(|p| table.z(p.z)).collect();
            let e = workbench::bq::weights::worst_case_error(
                &set.points,
                &set.weights.weights,
                &z,
                table.prior_variance(),
                &m.kernel,
            );
            let g = cos_quadrature(set);
            assert!(
                (g - std::f64::consts::PI).abs() <= norm_cos * e * (1.0 + 1e-9),
                "{kind}: cos θ error above its bound"
            );
        }
        let img = r.render(&integ, 4, &hidden());
        for (k, a, _) in &hit {
            for c in 0..3 {
                // BMCP's prior is a mean of neighbour estimates, each at most albedo·(1 + cos_error).
                let prior = if kind == IntegratorKind::BMCP {
                    (1.0 + cos_error) * a[c] / std::f64::consts::TAU
                } else {
                    0.0
                };
                let tol = a[c] * cos_error + prior * sum_error + 1e-12;
                let got = img.data[*k][c];
                assert!((got - a[c]).abs() <= tol, "{kind}: {got} vs {} (tol {tol})", a[c]);
            }
        }
    }
}

/// Test 3, the rotation test: BMC with the single sample `+z` and no azimuth rotation reads
/// the sky along the surface normal, `pixel = albedo · w · env(n) / π`, so the sphere shows the
/// sky "reflected": brightest where the normal faces the sun, bluer at the top. Without the
/// rotation to the normal every pixel would read `env(+z)` and the sphere would be flat.
#[test]
fn one_sample_along_the_normal_shows_the_sky_reflected() {
    let r = sphere_only(64, Environment::Sky);
    let m = model();
    let integ = Integrator {
        kind: IntegratorKind::BMC,
        spp: 1,
        sets: Some(BmcSets::from_points(vec![vec![Vec3::z()]], false, &m, 0).unwrap()),
        pss: None,
        uncertainty: None,
        counter: Default::default(),
    };
    let w = sets(&integ).sets[0].weights.weights[0];
    let img = r.render(&integ, 0, &hidden());
    let hit = hits(&r);
    for (k, a, n) in &hit {
        let sky = Environment::Sky.radiance(n);
        for c in 0..3 {
            let want = a[c] * w * sky[c] / std::f64::consts::PI;
            assert!(
                (img.data[*k][c] - want).abs() < 1e-12 * want.max(1.0),
                "pixel {k}"
            );
        }
    }
    let sun = Vec3::new(-1.0, 1.0, 0.5).normalize();
    let brightest = hit
        .iter()
        .max_by(|x, y| img.data[x.0][0].total_cmp(&img.data[y.0][0]))
        .unwrap();
    assert!(brightest.2.dot(&sun) > 0.95, "brightest normal {}", brightest.2);
    // Blue over red (relative to the albedo) is largest towards the zenith, smallest at the horizon.
    let tint = |k: usize, a: &[f64; 3]| (img.data[k][2] / a[2]) / (img.data[k][0] / a[0]);
    let top = hit
        .iter()
        .filter(|h| h.2.y > 0.9 && h.2.dot(&sun) < 0.8)
        .map(|h| tint(h.0, &h.1));
    let side = hit
        .iter()
        .filter(|h| h.2.y.abs() < 0.1 && h.2.dot(&sun) < 0.3)
        .map(|h| tint(h.0, &h.1));
    let (top_min, side_max) = (top.fold(f64::INFINITY, f64::min), side.fold(0.0, f64::max));
    assert!(
        top_min > side_max,
        "zenith tint {top_min} vs horizon tint {side_max}"
    );
}

/// Same seed ⇒ the same image, bit for bit, with 1 or 2 threads, for every integrator.
#[test]
fn images_do_not_depend_on_the_thread_count() {
    let r = Renderer::new(40, 40, Environment::Sky);
    let m = model();
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    for kind in IntegratorKind::all() {
        let integ = Integrator::build(kind, 12, 3, true, Some(&m), 5).unwrap();
        let one = pool(1).install(|| r.render(&integ, 5, &hidden()));
        let two = pool(2).install(|| r.render(&integ, 5, &hidden()));
        assert_eq!(one, two, "{kind}");
        let other_seed = pool(2).install(|| r.render(&integ, 6, &hidden()));
        assert_ne!(one, other_seed, "{kind}: the seed must matter");
    }
}

/// The prior reaches the estimator: with the same sets and seed, BMCP equals BMC on the first
/// checkerboard pass and wherever `c = 0`, and differs on the second pass where the neighbours
/// give `c ≠ 0`.
#[test]
fn bmcp_differs_from_bmc_exactly_where_the_prior_is_not_zero() {
    let r = Renderer::new(32, 32, Environment::Sky);
    let m = model();
    let plain = bmc(IntegratorKind::BMC, 20, 2, true, &m, 8);
    let prior = bmc(IntegratorKind::BMCP, 20, 2, true, &m, 8);
    let a = r.render(&plain, 8, &hidden());
    let b = r.render(&prior, 8, &hidden());
    let (mut second, mut changed) = (0, 0);
    for (k, _, _) in hits(&r) {
        let (i, j) = (k % r.width, k / r.width);
        if (i + j) % 2 == 0 {
            assert_eq!(a.data[k], b.data[k], "first pass pixel ({i}, {j})");
        } else {
            second += 1;
            changed += usize::from(a.data[k] != b.data[k]);
        }
    }
    assert!(
        changed * 10 >= second * 9,
        "{changed} of {second} second-pass pixels changed"
    );
    // c = 0 is plain BMC.
    for (i, j) in [(10, 20), (16, 16), (3, 30)] {
        let none = r.pixel(i, j, &prior, 8, [0.0; 3]);
        assert!(none.is_some());
        assert_eq!(none, r.pixel(i, j, &plain, 8, [0.0; 3]));
        assert_ne!(none, r.pixel(i, j, &prior, 8, [0.05; 3]));
    }
    // A 1×1 image has no neighbours: c = 0 and BMCP = BMC.
    let tiny = Renderer::new(1, 1, Environment::Sky);
    assert_eq!(
        tiny.render(&plain, 8, &hidden()),
        tiny.render(&prior, 8, &hidden())
    );
}

/// RMSE falls as spp grows, and on the default scene BMC (4 sets, rotated) beats MC at 20–80 spp
/// in every one of several repetitions, against a cheaper MC reference at 64×64.
#[test]
fn rmse_falls_with_spp_and_bmc_beats_mc() {
    let size = 64;
    let r = Renderer::new(size, size, Environment::Sky);
    let reference = r.render(&Integrator::mc(Density::Uniform, 1000), 999, &hidden());
    let m = model();
    let reps = 4u64;
    let mut previous = [f64::INFINITY; 2];
    for spp in [20, 40, 60, 80] {
        let mut mean = [0.0; 2];
        for rep in 0..reps {
            let seed = 100 * spp as u64 + rep;
            let mc: Image = r.render(&Integrator::mc(Density::Uniform, spp), seed, &hidden());
            let b = r.render(&bmc(IntegratorKind::BMC, spp, 4, true, &m, seed), seed, &hidden());
            let (e_mc, e_bmc) = (mc.rmse(&reference), b.rmse(&reference));
            assert!(e_bmc < e_mc, "spp {spp} rep {rep}: BMC {e_bmc} vs MC {e_mc}");
            mean[0] += e_mc / reps as f64;
            mean[1] += e_bmc / reps as f64;
        }
        assert!(
            mean[0] < previous[0] && mean[1] < previous[1],
            "spp {spp}: {mean:?} vs {previous:?}"
        );
        previous = mean;
    }
}

/// The per-pixel posterior sd (`render --sd-out`) is math.md §7 computed from scratch: at a
/// ground pixel and a sphere pixel, `Q` assembled entry by entry, inverted densely (an
/// independent check, not the Cholesky path), `λ̂ = rᵀQ⁻¹r / dof`, `Var₁ = V̂ − zᵀQ⁻¹z` (plus
/// §8's term for Bayes–Sard) and `sd = sqrt(λ̂ Var₁)`, for BMC, BMCP with a prior and
/// Bayes–Sard, every amplitude scale, every channel; the estimate is the one without sds.
#[test]
fn pixel_sd_matches_a_dense_computation() {
    use workbench::bq::weights::Scale;
    use workbench::render::integrator::ShadingPoint;
    use workbench::util::rng::stream;
    let r = Renderer::new(32, 32, Environment::Sky);
    let m = model();
    let spp = 12;
    for kind in [
        IntegratorKind::BMC,
        IntegratorKind::BMCP,
        IntegratorKind::from_name("bsq").unwrap(),
    ] {
        for scale in [Scale::Unit, Scale::Ml, Scale::Loo] {
            let plain = bmc(kind, spp, 2, true, &m, 5);
            let integ = plain.clone().with_uncertainty(scale, Some(&m)).unwrap();
            for (i, j) in [(16, 28), (16, 12)] {
                let p: ShadingPoint = r.shading_point(i, j).expect("a hit pixel");
                let prior = if kind.method.uses_prior() {
                    [0.1, 0.2, 0.05]
                } else {
                    [0.0; 3]
                };
                let mut rng = stream(3, &[i as u64, j as u64]);
                let (value, sd) = integ.estimate_with_sd(&p, &r.scene, &r.env, &mut rng.clone(), prior);
                assert_eq!(
                    value,
                    plain.estimate(&p, &r.scene, &r.env, &mut rng.clone(), prior)
                );
                let sd = sd.expect("an integrator with uncertainty states an sd");
                let (set, points) = sets(&integ).pick(&mut rng);
                let n = points.len();
                let q = nalgebra::DMatrix::from_fn(n, n, |a, b| {
                    m.kernel.eval(&set.points[a], &set.points[b]) + if a == b { m.noise } else { 0.0 }
                });
                let qi = q.try_inverse().expect("Q is invertible");
                let z = nalgebra::DVector::from_iterator(n, set.points.iter().map(|x| m.table().z(x.z)));
                let ones = nalgebra::DVector::from_element(n, 1.0);
                let mut var1 = m.prior_variance() - z.dot(&(&qi * &z));
                if kind.name() == "bsq" {
                    let gap = std::f64::consts::TAU - ones.dot(&(&qi * &z));
                    var1 += gap * gap / ones.dot(&(&qi * &ones));
                }
                for c in 0..3 {
                    let y = nalgebra::DVector::from_iterator(
                        n,
                        points.iter().map(|v| p.integrand(&r.scene, &r.env, v)[c]),
                    );
                    let offset = match kind.name().as_str() {
                        "bmc" => 0.0,
                        "bmcp" => prior[c],
                        _ => ones.dot(&(&qi * &y)) / ones.dot(&(&qi * &ones)),
                    };
                    let res = &y - &ones * offset;
                    let solved = &qi * &res;
                    let dof = if kind.name() == "bsq" { n - 1 } else { n };
                    let lambda = match scale {
                        Scale::Unit => 1.0,
                        Scale::Ml => res.dot(&solved) / dof as f64,
                        Scale::Loo => {
                            (0..n).map(|a| solved[a] * solved[a] / qi[(a, a)]).sum::<f64>() / n as f64
                        }
                    };
                    let want = (lambda * var1).sqrt();
                    assert!(
                        (sd[c].sd - want).abs() <= 1e-8 * want,
                        "{kind} {scale:?} pixel ({i}, {j}) channel {c}: {} vs {want}",
                        sd[c].sd
                    );
                    assert_eq!(sd[c].dof, (scale == Scale::Ml).then_some(dof));
                }
            }
        }
    }
}

/// `render_with_sd` gives the image `render` gives, bit for bit, with sds on exactly the hit
/// pixels (positive there, 0 on the background), for the plain and the edge-aware BMCP.
#[test]
fn render_with_sd_keeps_the_image() {
    use workbench::bq::weights::Scale;
    let r = Renderer::new(24, 24, Environment::Sky);
    let m = model();
    for kind in [
        IntegratorKind::BMC,
        IntegratorKind::BMCP,
        IntegratorKind::BMCP_EDGE,
    ] {
        let plain = bmc(kind, 10, 3, true, &m, 8);
        let image = r.render(&plain, 4, &hidden());
        let integ = plain.with_uncertainty(Scale::Ml, Some(&m)).unwrap();
        let (again, sds) = r.render_with_sd(&integ, 4, &hidden());
        assert_eq!(image, again, "{kind}");
        assert_eq!(sds.dof, Some(10));
        let hit: Vec<bool> = r.geometry().iter().map(Option::is_some).collect();
        assert_eq!(sds.hit, hit);
        // A zero sd is a zero fitted amplitude (every sample of the channel occluded), counted.
        let mut zero = 0;
        for (k, s) in sds.sd.data.iter().enumerate() {
            if hit[k] {
                assert!(
                    s.iter().all(|&v| v >= 0.0 && v.is_finite()),
                    "{kind} pixel {k}: {s:?}"
                );
                zero += s.iter().filter(|&&v| v == 0.0).count();
            } else {
                assert_eq!(*s, [0.0; 3]);
            }
        }
        assert_eq!(zero, sds.zero_amplitude, "{kind}");
        assert!(
            zero * 20 < 3 * hit.iter().filter(|&&h| h).count(),
            "{kind}: {zero} zero sds"
        );
    }
}

/// The edge-aware prior's depth tolerance separates the default scene's surfaces at 256×256:
/// every pair of 4-neighbours on the same surface (same albedo) is within it, and every pair
/// across the sphere's silhouette gets weight 0 (a normal facing away or a depth jump).
/// Prints the margins (`--nocapture`) behind docs/guide/render.md's justification of the defaults.
#[test]
fn edge_weights_separate_the_scene_surfaces() {
    use workbench::render::integrator::neighbours::{EDGE_DEPTH_TOLERANCE, edge_weight};
    let r = Renderer::new(256, 256, Environment::Sky);
    let g = r.geometry();
    let albedo: Vec<Option<[f64; 3]>> = (0..256 * 256)
        .map(|k| {
            r.scene
                .intersect(&r.camera.origin, &r.camera.ray(k % 256, k / 256))
                .map(|h| h.albedo)
        })
        .collect();
    let (mut same_jump, mut same_cos, mut cross_pairs, mut cross_min_jump) =
        (0.0f64, 1.0f64, 0, f64::INFINITY);
    let mut cross_by_normal = 0;
    for j in 0..256 {
        for i in 0..256 {
            let k = j * 256 + i;
            let Some(a) = g[k] else { continue };
            for (ii, jj) in [(i + 1, j), (i, j + 1)] {
                if ii >= 256 || jj >= 256 {
                    continue;
                }
                let Some(b) = g[jj * 256 + ii] else { continue };
                let jump = (b.depth - a.depth).abs() / a.depth;
                if albedo[k] == albedo[jj * 256 + ii] {
                    same_jump = same_jump.max(jump);
                    same_cos = same_cos.min(a.normal.dot(&b.normal));
                    assert!(edge_weight(&a, &b) > 0.0, "same surface at ({i}, {j})");
                } else {
                    cross_pairs += 1;
                    cross_min_jump = cross_min_jump.min(jump);
                    cross_by_normal += usize::from(a.normal.dot(&b.normal) <= 0.0);
                    assert_eq!(edge_weight(&a, &b), 0.0, "across the silhouette at ({i}, {j})");
                    assert_eq!(edge_weight(&b, &a), 0.0, "across the silhouette at ({i}, {j})");
                }
            }
        }
    }
    println!(
        "same surface: largest relative depth jump {same_jump:.4}, largest normal angle {:.2}°; \
         {cross_pairs} pairs across the silhouette: smallest depth jump {cross_min_jump:.4}, \
         {cross_by_normal} with normals facing apart",
        same_cos.acos().to_degrees()
    );
    assert!(same_jump < EDGE_DEPTH_TOLERANCE && cross_pairs > 100);
}

/// Ring sample sets (`bmc-rings`, `bmcp-rings`, `bsq-rings`): their weights (by the `J × J`
/// ring solver) equal the dense Cholesky weights of the same points to 1e-10 relative, and so
/// do a few pixels' estimates and their sds (`ml` and `loo`, through the kept ring factor) when
/// the same points are weighted densely and picked, rotated, with the same pixel stream.
#[test]
fn ring_sets_match_the_dense_solve_on_the_same_points() {
    use workbench::bq::weights::Scale;
    use workbench::render::integrator::ShadingPoint;
    use workbench::util::rng::stream;
    let r = Renderer::new(32, 32, Environment::Sky);
    let m = model();
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
    for name in ["bmc", "bmcp", "bsq"] {
        let dense_kind = IntegratorKind::from_name(name).unwrap();
        let ring_kind = IntegratorKind::from_name(&format!("{name}-rings")).unwrap();
        for spp in [36, 64] {
            let rings = bmc(ring_kind, spp, 2, true, &m, 11);
            let points: Vec<Vec<Vec3>> = sets(&rings).sets.iter().map(|s| s.points.clone()).collect();
            let dense = Integrator {
                kind: dense_kind,
                spp,
                sets: Some(BmcSets::from_points(points, true, &m, 11).unwrap()),
                pss: None,
                uncertainty: None,
                counter: Default::default(),
            };
            for (a, b) in sets(&rings).sets.iter().zip(&sets(&dense).sets) {
                let scale = b.weights.weights.iter().fold(0.0f64, |s, w| s.max(w.abs()));
                for (x, y) in a.weights.weights.iter().zip(&b.weights.weights) {
                    assert!((x - y).abs() <= 1e-10 * scale, "{ring_kind} N={spp}: {x} vs {y}");
                }
            }
            for scale in [Scale::Ml, Scale::Loo] {
                let rings = rings.clone().with_uncertainty(scale, Some(&m)).unwrap();
                let dense = dense.clone().with_uncertainty(scale, Some(&m)).unwrap();
                for (i, j) in [(16, 28), (16, 12), (5, 20)] {
                    let p: ShadingPoint = r.shading_point(i, j).expect("a hit pixel");
                    let prior = [0.1, 0.2, 0.05];
                    let rng = stream(3, &[i as u64, j as u64]);
                    let (va, sa) = rings.estimate_with_sd(&p, &r.scene, &r.env, &mut rng.clone(), prior);
                    let (vb, sb) = dense.estimate_with_sd(&p, &r.scene, &r.env, &mut rng.clone(), prior);
                    let (sa, sb) = (sa.unwrap(), sb.unwrap());
                    for c in 0..3 {
                        assert!(
                            rel(va[c], vb[c]) < 1e-10,
                            "{ring_kind} N={spp} ({i}, {j}) channel {c}: {} vs {}",
                            va[c],
                            vb[c]
                        );
                        assert!(
                            rel(sa[c].sd, sb[c].sd) < 1e-10,
                            "{ring_kind} {scale:?} N={spp} ({i}, {j}) channel {c}: sd {} vs {}",
                            sa[c].sd,
                            sb[c].sd
                        );
                    }
                }
            }
        }
    }
}
