//! One face per estimator: the colour, marker and line an estimator is drawn with in every
//! figure of a run — error, calibration, cost — and, for the usual estimators, of every
//! committed result, so that a reader who has learnt that MC is the vermillion dashed line
//! with circles finds it so everywhere.
//!
//! - **Colour: one per estimator.** The method's own colour (MC vermillion, BMC blue, BMCP
//!   bluish green, BSQ reddish purple: [`super::PALETTE`]'s first four) goes to its *plain*
//!   estimator: the first of that method with the default kernel (Sobolev s = 1.4) on uniform
//!   points, else the first with the default kernel, else the first. Every other estimator —
//!   another design, kernel, noise, tolerance of the same method — takes, in the run's order,
//!   the next colour that no estimator of the run has: the palette's other five first, then
//!   the colours of methods the run does not use. So two variants of one method never share a
//!   colour (issue 43 item 5); with more estimators than colours the palette is used again,
//!   each time with the next marker, so that no two share both colour and marker.
//! - **Marker: the design**: uniform a filled circle, Sobol a filled triangle, stratified a
//!   filled square, the others the remaining shapes in [`Design::ALL`]'s order.
//! - **Line: the method's family**: dashed for Monte Carlo (no weights), solid for the methods
//!   with weights.

use super::{PALETTE, SeriesStyle};
use crate::bq::estimator::Method;
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

/// The faces of series that are each a method with a kernel (`None`: none, or the default)
/// on a design, in their order: the rule of the module docs, for experiments' estimators and
/// render tables' variants alike.
pub fn faces_of(series: &[(Method, Option<&serde_json::Value>, Design)]) -> Vec<SeriesStyle> {
    let default_kernel = |k: Option<&serde_json::Value>| k.is_none_or(is_default_kernel);
    // Each method's plain estimator: the one that keeps the method's colour.
    let plain = |m: Method| {
        let of = |keep: &dyn Fn(usize) -> bool| (0..series.len()).find(|&i| series[i].0 == m && keep(i));
        of(&|i| default_kernel(series[i].1) && series[i].2 == UNIFORM)
            .or_else(|| of(&|i| default_kernel(series[i].1)))
            .or_else(|| of(&|_| true))
    };
    let methods = [Method::Mc, Method::Bmc, Method::Bmcp, Method::Bsq];
    let plains: Vec<usize> = methods.iter().filter_map(|&m| plain(m)).collect();
    // The colours for the others: the five no method has, then those of methods not in the run.
    let spare: Vec<usize> = (4..PALETTE.len())
        .chain((0..4).filter(|&c| !plains.iter().any(|&i| method_colour(series[i].0) == c)))
        .collect();
    let mut next = 0;
    let mut out: Vec<SeriesStyle> = Vec::with_capacity(series.len());
    for (i, &(method, _, design)) in series.iter().enumerate() {
        let (colour, round) = if plains.contains(&i) {
            (method_colour(method), 0)
        } else {
            next += 1;
            (spare[(next - 1) % spare.len()], (next - 1) / spare.len())
        };
        let mut face = SeriesStyle {
            colour,
            marker: design_marker(design),
            dashed: method.is_monte_carlo(),
            grow: 0,
        };
        // A colour used again: the design's marker if its pair with this colour is free, else
        // the next marker whose pair is.
        let taken = |m: usize| out.iter().any(|f| (f.colour, f.marker) == (colour, m));
        if round > 0
            && taken(face.marker)
            && let Some(m) = (1..super::MARKERS)
                .map(|k| (face.marker + k) % super::MARKERS)
                .find(|&m| !taken(m))
        {
            face.marker = m;
        }
        out.push(face);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Design;

    fn design(name: &str) -> Design {
        Design::from_name(name).expect(name)
    }

    /// Issue 43 item 5: several MC and several BMC variants each get a colour of their own (not
    /// one per method); the plain MC and BMC (uniform, default kernel) keep their method's
    /// colour wherever they stand in the run, and no two series share colour and marker even past
    /// the palette's nine colours.
    #[test]
    fn variants_of_one_method_get_colours_of_their_own() {
        let s14 = serde_json::json!({"type": "sobolev", "s": 1.4});
        let s3 = serde_json::json!({"type": "sobolev", "s": 3.0});
        let series = [
            (Method::Mc, None, design("cosine")),
            (Method::Mc, None, UNIFORM),
            (Method::Bmc, Some(&s3), UNIFORM),
            (Method::Bmc, Some(&s14), design("sobol")),
            (Method::Bmc, Some(&s14), UNIFORM),
            (Method::Mc, None, design("sobol")),
        ];
        let f = faces_of(&series);
        assert_eq!((f[1].colour, f[4].colour), (0, 1), "{f:?}");
        for i in 0..f.len() {
            for j in 0..i {
                assert_ne!(f[i].colour, f[j].colour, "series {i} and {j}: {f:?}");
            }
        }
        assert!(f[0].dashed && f[5].dashed && !f[2].dashed);
        assert_eq!(f[3].marker, design_marker(design("sobol")));
        // 20 BMC variants: the palette runs out, the pairs stay apart.
        let many: Vec<_> = (0..20).map(|_| (Method::Bmc, None, UNIFORM)).collect();
        let f = faces_of(&many);
        for i in 0..f.len() {
            for j in 0..i {
                assert_ne!((f[i].colour, f[i].marker), (f[j].colour, f[j].marker), "{i} {j}");
            }
        }
        let distinct: std::collections::BTreeSet<usize> = f.iter().map(|x| x.colour).collect();
        assert_eq!(distinct.len(), PALETTE.len());
    }
}
