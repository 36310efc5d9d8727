//! The `envmap` integrand family under a real map (issue 28 item 1): its truth (the texel sum)
//! against an independent brute-force quadrature over the map's own cells.

use crate::{Data, Test};
use workbench::experiment::plan::resolve_integrand;
use workbench::experiment::spec::IntegrandSpec;
use workbench::integrand::Integrand;
use workbench::render::Environment;
use workbench::render::env::Lookup;
use workbench::util::geometry::Vec3;
use workbench::util::quadrature::GaussLegendre;

pub const TESTS: &[Test] = &[(
    "envmap_truth_agrees_with_a_cell_by_cell_quadrature_under_pisa",
    envmap_truth_agrees_with_a_cell_by_cell_quadrature_under_pisa,
)];

fn integrand(spec: serde_json::Value) -> Integrand {
    resolve_integrand(&serde_json::from_value::<IntegrandSpec>(spec).unwrap()).unwrap()
}

/// `∫ L(d) w(d) dω` by 8×8 Gauss–Legendre on every cell of the lookup's grid (θ rows
/// `jπ/(H − 1)`; ψ knots `2π(i + ½)/W` for `mitsuba`, `−π + 2πi/(W − 1)` for `thesis`), with `L`
/// from the lookup itself (smooth inside each cell): independent of the texel sum's prefix sums
/// and cuts. Cells the horizon crosses carry a kink, an O(h²) error there.
fn brute(env: &Environment, w: usize, h: usize, lookup: Lookup, weight: impl Fn(&Vec3) -> f64) -> [f64; 3] {
    let gl = GaussLegendre::new(8);
    let rows: Vec<f64> = (0..h)
        .map(|j| j as f64 * std::f64::consts::PI / (h - 1) as f64)
        .collect();
    let tau = std::f64::consts::TAU;
    let knots: Vec<f64> = match lookup {
        Lookup::Mitsuba => (0..=w).map(|i| tau * (i as f64 + 0.5) / w as f64).collect(),
        Lookup::Thesis => (0..w)
            .map(|i| -std::f64::consts::PI + tau * i as f64 / (w - 1) as f64)
            .collect(),
    };
    let mut sum = [0.0; 3];
    for r in rows.windows(2) {
        for k in knots.windows(2) {
            let (t0, t1, p0, p1) = (r[0], r[1], k[0], k[1]);
            for (t, wt) in gl.nodes().iter().zip(gl.weights()) {
                let t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * t;
                let wt = 0.5 * (t1 - t0) * wt;
                for (p, wp) in gl.nodes().iter().zip(gl.weights()) {
                    let p = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * p;
                    let wp = 0.5 * (p1 - p0) * wp;
                    let d = Vec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos());
                    let f = weight(&d);
                    if f != 0.0 {
                        let l = env.radiance(&d);
                        for c in 0..3 {
                            sum[c] += wt * wp * l[c] * f * t.sin();
                        }
                    }
                }
            }
        }
    }
    sum
}

fn envmap_truth_agrees_with_a_cell_by_cell_quadrature_under_pisa(data: &Data) {
    workbench::data::set_folder(data.dir.clone());
    let pi = std::f64::consts::PI;
    for lookup in Lookup::ALL {
        let env = Environment::from_arg("pisa")
            .unwrap()
            .with_lookup(lookup, "lookup")
            .unwrap();
        let Environment::Map(m) = &env else { unreachable!() };
        let (w, h) = (m.width, m.height);
        for normal in [[0.0, 1.0, 0.0], [0.3, 0.2, -0.9], [-0.5, -0.6, 0.2]] {
            let n = Vec3::new(normal[0], normal[1], normal[2]).normalize();
            let want = brute(&env, w, h, lookup, |d| d.dot(&n).max(0.0) / pi);
            for (c, ch) in ["r", "g", "b"].into_iter().enumerate() {
                let f = integrand(serde_json::json!({
                    "type": "envmap", "env": "pisa", "normal": normal, "lookup": lookup.name(), "channel": ch
                }));
                let Integrand::Envmap { f, .. } = &f else {
                    unreachable!()
                };
                assert!(
                    (f.integral() - want[c]).abs() <= 2e-6 * want[c] + f.integral_error(),
                    "{lookup:?} {normal:?} {ch}: texel sum {} vs cells {}",
                    f.integral(),
                    want[c]
                );
            }
        }
    }
    // A Phong lobe (e = 20, tilted 30° in the local frame), mitsuba lookup, one normal.
    let env = Environment::from_arg("pisa").unwrap();
    let Environment::Map(m) = &env else { unreachable!() };
    let normal = [0.3, 0.2, -0.9];
    let f = integrand(serde_json::json!({
        "type": "envmap", "env": "pisa", "normal": normal, "channel": "g",
        "brdf": { "phong": 20, "axis": [0.5, 0, 0.8660254037844386] }
    }));
    let Integrand::Envmap { f, .. } = &f else {
        unreachable!()
    };
    let n = f.normal;
    let frame = workbench::util::geometry::Frame::from_normal(n);
    let a = frame.to_world(&Vec3::new(0.5, 0.0, 0.8660254037844386));
    let want = brute(&env, m.width, m.height, Lookup::Mitsuba, |d| {
        let (ca, cn) = (d.dot(&a), d.dot(&n));
        if ca <= 0.0 || cn <= 0.0 {
            0.0
        } else {
            21.0 / std::f64::consts::TAU * ca.powi(20) * cn
        }
    })[1];
    assert!(
        (f.integral() - want).abs() <= 2e-6 * want + f.integral_error(),
        "phong: texel sum {} vs cells {want}",
        f.integral()
    );
}
