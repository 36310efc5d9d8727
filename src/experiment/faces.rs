//! One face per estimator: the colour, marker and line an estimator is drawn with in every
//! figure of a run — error, calibration, cost — and, for the usual estimators, of every
//! committed result, so that a reader who has learnt that MC is the vermillion dashed line
//! with circles finds it so everywhere.
//!
//! - **Colour: the method**, with the default kernel (Sobolev s = 1.4): MC vermillion, BMC
//!   blue, BMCP bluish green, BSQ reddish purple ([`crate::plot::PALETTE`]'s first four). Another
//!   kernel takes one of the palette's other colours, in the order the run first uses each
//!   (method, kernel) pair.
//! - **Marker: the design**: uniform a filled circle, Sobol a filled triangle, stratified a
//!   filled square, the others the remaining shapes in [`Design::ALL`]'s order.
//! - **Line: the method's family**: dashed for Monte Carlo (no weights), solid for the methods
//!   with weights.
//!
//! Estimators the rule gives one face (a noise or amplitude sweep, a tolerance variant) take,
//! in their order, the next colour that no estimator of the run has yet, keeping their marker.

use super::plan::PlannedEstimator;
use crate::bq::estimator::Method;
use crate::plot::{PALETTE, SeriesStyle};
use crate::sampling::{Density, Design};

/// The uniform design (the default), for callers without a design.
pub const UNIFORM: Design = Design::Iid(Density::Uniform);

/// The palette index of a method with the default kernel.
fn method_colour(m: Method) -> usize {
    match m {
        Method::Mc => 0,
        Method::Bmc => 1,
        Method::Bmcp => 2,
        Method::Bsq => 3,
    }
}

/// The marker of a design: uniform 0 (filled circle), Sobol 1 (filled triangle), stratified 4
/// (filled square), the rest in [`Design::ALL`]'s order among the remaining shapes.
pub fn design_marker(d: Design) -> usize {
    const FIXED: [(&str, usize); 3] = [("uniform", 0), ("sobol", 1), ("stratified", 4)];
    const REST: [usize; 4] = [5, 2, 3, 6];
    if let Some((_, m)) = FIXED.iter().find(|(n, _)| *n == d.name()) {
        return *m;
    }
    let others: Vec<&Design> = Design::ALL
        .iter()
        .filter(|x| !FIXED.iter().any(|(n, _)| *n == x.name()))
        .collect();
    let i = others.iter().position(|x| **x == d).unwrap_or(0);
    REST[i % REST.len()]
}

/// The default kernel's settings (`{"type": "sobolev", "s": 1.4}`).
fn is_default_kernel(k: &serde_json::Value) -> bool {
    k.get("type").and_then(|t| t.as_str()) == Some("sobolev")
        && k.get("s").and_then(|s| s.as_f64()) == Some(1.4)
}

/// The faces of `estimators`, in their order (see the module docs).
///
/// A light-aware estimator (`mc-light`, `mis`, …) is a Monte Carlo method (dashed) whose
/// identity — its method and options — takes a colour of its own, as another kernel would.
pub fn faces(estimators: &[PlannedEstimator]) -> Vec<SeriesStyle> {
    let light: Vec<Option<serde_json::Value>> = estimators
        .iter()
        .map(|e| {
            e.light.map(|l| {
                serde_json::json!({
                    "method": l.method.name(),
                    "heuristic": l.heuristic.name(),
                    "compensation": l.compensation,
                })
            })
        })
        .collect();
    let identities: Vec<(Method, Option<&serde_json::Value>, Design)> = estimators
        .iter()
        .zip(&light)
        .map(|(e, l)| match (e.method.points(), l) {
            (Some(m), _) => (m, e.settings.kernel.as_ref(), e.design),
            (None, l) => (Method::Mc, l.as_ref(), e.design),
        })
        .collect();
    faces_of(&identities)
}

/// The faces of series that are each a method with a kernel (`None`: none, or the default)
/// on a design, in their order: the rule of the module docs, for experiments' estimators and
/// render tables' variants alike.
pub fn faces_of(series: &[(Method, Option<&serde_json::Value>, Design)]) -> Vec<SeriesStyle> {
    let mut kernels: Vec<(Method, String)> = Vec::new();
    let mut out: Vec<SeriesStyle> = Vec::with_capacity(series.len());
    for &(method, kernel, design) in series {
        let colour = match kernel {
            Some(k) if !is_default_kernel(k) => {
                let key = (method, k.to_string());
                let i = kernels.iter().position(|x| *x == key).unwrap_or_else(|| {
                    kernels.push(key);
                    kernels.len() - 1
                });
                4 + i % (PALETTE.len() - 4)
            }
            _ => method_colour(method),
        };
        let mut face = SeriesStyle {
            colour,
            marker: design_marker(design),
            dashed: method.is_monte_carlo(),
            grow: 0,
        };
        if out
            .iter()
            .any(|f| (f.colour, f.marker) == (face.colour, face.marker))
        {
            let used = |c: usize| out.iter().any(|f| f.colour == c) || c == face.colour;
            // The colours no method has first, so that a run's extras do not look like MC.
            if let Some(c) = (4..PALETTE.len()).chain(0..4).find(|&c| !used(c)) {
                face.colour = c;
            } else {
                // More series than colours: the palette again, with the next marker.
                face.marker = (face.marker + out.len()) % crate::plot::MARKERS;
            }
        }
        out.push(face);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::plan;

    fn plan_of(estimators: &str) -> plan::Plan {
        let text = format!(
            r#"{{"name": "x", "integrands": ["cos3"], "estimators": {estimators}, "samples": [4], "trials": 2, "seed": 1}}"#
        );
        plan::resolve(&plan::parse(&text).unwrap()).unwrap()
    }

    /// The same estimator has the same face whatever else the run compares, and the first
    /// four methods are told apart by colour, the designs by marker, MC by its dashed line.
    #[test]
    fn an_estimator_keeps_its_face_across_runs() {
        let a = plan_of(r#"[{"label": "MC", "method": "mc"}, {"label": "BMC", "method": "bmc"}]"#);
        let b = plan_of(
            r#"[{"label": "BSQ", "method": "bsq"}, {"label": "BMC", "method": "bmc"},
                {"label": "BMC sobol", "method": "bmc", "design": "sobol"}, {"label": "MC", "method": "mc"},
                {"label": "BMCP", "method": "bmcp"}]"#,
        );
        let (fa, fb) = (faces(&a.estimators), faces(&b.estimators));
        assert_eq!(fa[0], fb[3]);
        assert_eq!(fa[1], fb[1]);
        assert!(fa[0].dashed && !fa[1].dashed);
        assert_eq!((fb[2].colour, fb[1].colour), (1, 1));
        assert_ne!(fb[2].marker, fb[1].marker);
        // MC, BMC, BMCP, BSQ.
        let colours: Vec<usize> = [3, 1, 4, 0].map(|i| fb[i].colour).to_vec();
        assert_eq!(colours, [0, 1, 2, 3]);
    }

    /// Estimators the rule would draw alike (a noise sweep) still differ, each by a colour of
    /// its own; another kernel gets a colour other than the method's.
    #[test]
    fn estimators_alike_are_told_apart() {
        let p = plan_of(
            r#"[{"label": "BMC a", "method": "bmc", "noise": 0.01}, {"label": "BMC b", "method": "bmc", "noise": 0.001},
                {"label": "BMC s", "method": "bmc", "kernel": {"type": "sobolev", "s": 2.75}}]"#,
        );
        let f = faces(&p.estimators);
        for i in 0..f.len() {
            for j in 0..i {
                assert_ne!((f[i].colour, f[i].marker), (f[j].colour, f[j].marker), "{i} {j}");
            }
        }
        assert_ne!(f[2].colour, 1);
    }
}
