//! A quadrature rule: points, the density they were drawn from and, for the estimators with
//! weights, BMC weights. [`Rule::estimate`] is the one sequence every caller runs — fitted
//! amplitude (math.md §7) → stated uncertainty → estimate — for the experiment runner, the render
//! integrators and the stage walker alike. Also what `workbench rule` writes: the limits on `N`,
//! the generated points and their weights as a file a renderer can load (`workbench rule` reads
//! a points file itself).

use crate::bq::estimator::{Method, Uncertainty};
use crate::bq::factor::SpdWorkspace;
use crate::bq::model::BmcModel;
use crate::bq::weights::{BmcWeights, Scale, Solved};
use crate::error::InputError;
use crate::sampling::{Density, Design, Structure};
use crate::util::geometry::Vec3;
use crate::util::rng::stream;
use crate::util::shown::shown;

/// A rule on one point set: the points in the local frame, the density each was drawn from (what
/// MC divides by), and for the estimators with weights the weights of the set and, for the `loo`
/// amplitude, `diag(Q⁻¹)` of its factor.
#[derive(Clone, Copy, Debug)]
pub struct Rule<'a> {
    pub density: Density,
    pub points: &'a [Vec3],
    pub weights: Option<&'a BmcWeights>,
    pub inverse_diagonal: Option<&'a [f64]>,
}

/// An integrand's values `Y` on a rule's points and, when an amplitude is fitted, `Y` solved
/// with the factor: one solve per weight set and integrand (or colour channel), shared by every
/// estimator of the set, made by whoever holds the factor (a workspace, a kept factor, a nested
/// stage).
#[derive(Clone, Copy, Debug)]
pub struct Values<'a> {
    pub y: &'a [f64],
    pub solved: Option<Solved<'a>>,
}

/// What an estimator states: `Î`, its uncertainty (None where it states none, e.g. MC at
/// `N = 1`), and the amplitude `λ̂` when one was fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub uncertainty: Option<Uncertainty>,
    pub fitted_amplitude: Option<f64>,
}

impl Rule<'_> {
    /// The estimate alone, `Î` of `method` ([`Method::estimate`]) with prior constant `prior`
    /// (BMCP).
    pub fn value(&self, method: Method, y: &[f64], prior: f64) -> f64 {
        method.estimate(self.density, self.points, y, self.weights, prior)
    }

    /// The estimate with its uncertainty at `scale`: a fitted amplitude `λ̂`
    /// ([`Method::amplitude`]) when the scale is not `unit` and `Q⁻¹Y` is given, else `λ = 1`;
    /// then the stated sd `sqrt(λ Var₁)` or MC's standard error ([`Method::uncertainty`]) and
    /// `Î` ([`Method::estimate`]).
    pub fn estimate(&self, method: Method, values: Values<'_>, prior: f64, scale: Scale) -> Estimate {
        let fitted_amplitude = match values.solved {
            Some(solved) if scale != Scale::Unit => method.amplitude(
                scale,
                values.y,
                solved,
                self.weights,
                prior,
                self.inverse_diagonal,
            ),
            _ => None,
        };
        Estimate {
            value: self.value(method, values.y, prior),
            uncertainty: method.uncertainty(
                self.density,
                self.points,
                values.y,
                self.weights,
                scale,
                fitted_amplitude.unwrap_or(1.0),
            ),
            fitted_amplitude,
        }
    }
}

/// Largest number of points a weight set may have: `Q` is assembled straight into its Cholesky
/// factor's buffer, one `N × N` matrix of `f64` per worker thread ([`matrix_gib`]), and this
/// keeps it at 2 GiB.
pub const MAX_POINTS: usize = 16_384;

/// GiB of the one `N × N` matrix (`8 N²` bytes) a weight set of `n` points needs per worker
/// thread: `Q`, factored in place.
pub fn matrix_gib(n: usize) -> f64 {
    8.0 * (n as f64).powi(2) / (1u64 << 30) as f64
}

/// Bytes one weight set of `n` points drawn with `design` holds while it is computed, the one
/// memory estimate of a weight set every door uses ([`crate::util::memory`]): dense, the `N × N`
/// matrix `Q` factored in place (`8 N²`); on a ring set with exact kernel means (the ring
/// solver), the spectra and block factors, `16 N J` for `J` rings (about `6 N J` measured, so
/// a safe side). The points, weights and solves (`O(N)`) are left out.
pub fn weight_set_bytes(n: usize, design: Design, exact_kernel_means: bool) -> u64 {
    if design.structure() == Structure::Rings && exact_kernel_means {
        let rings = crate::sampling::rings::layout(n).rings as u64;
        16u64.saturating_mul(n as u64).saturating_mul(rings)
    } else {
        crate::util::memory::matrix_bytes(n)
    }
}

/// [`crate::util::memory::check`] as bad input: `what` (a flag, field or argument with its value)
/// needs `bytes`; exit 2 or a `ValueError` when it is over the budget.
pub fn check_memory(what: &str, bytes: u64) -> Result<(), InputError> {
    crate::util::memory::check(what, bytes).map_err(InputError::new)
}

/// What a guarded computation of weight sets holds at its peak, for [`check_factor_memory`]:
/// the factor being computed (`factor_bytes`, [`weight_set_bytes`]), `kept` more of that size
/// kept besides it (`kept_for` says why: "one per model"), and `besides` bytes of something else
/// (an image) with its description.
#[derive(Clone, Debug)]
pub struct FactorMemory {
    /// What is computed: `a weight set of 512 points`, `8 sample sets of 1024 points for bmc`.
    pub subject: String,
    pub factor_bytes: u64,
    pub kept: u64,
    pub kept_for: String,
    pub besides: Option<(String, u64)>,
}

impl FactorMemory {
    /// One weight set of `n` points on `design`, nothing kept.
    pub fn weight_set(n: usize, design: Design, exact_kernel_means: bool) -> FactorMemory {
        FactorMemory {
            subject: format!("a weight set of {n} points"),
            factor_bytes: weight_set_bytes(n, design, exact_kernel_means),
            kept: 0,
            kept_for: String::new(),
            besides: None,
        }
    }

    /// `{what}: {subject} keeping {kept} factors ({kept_for}) on {besides}`, the parts present.
    pub fn describe(&self, what: &str) -> String {
        let keeping = match self.kept {
            0 => String::new(),
            k => format!(
                " keeping {k} factor{} ({})",
                if k == 1 { "" } else { "s" },
                self.kept_for
            ),
        };
        let besides = self
            .besides
            .as_ref()
            .map_or(String::new(), |(b, _)| format!(" on {b}"));
        format!("{what}: {}{keeping}{besides}", self.subject)
    }

    /// The bytes: `besides + factor_bytes · (kept + 1)`, saturating.
    pub fn bytes(&self) -> u64 {
        let factors = self.factor_bytes.saturating_mul(self.kept.saturating_add(1));
        factors.saturating_add(self.besides.as_ref().map_or(0, |b| b.1))
    }
}

/// The one memory guard of every door that computes weight sets (issue 30): the CLI's `rule`,
/// `render` and render tables ([`crate::render::integrator::check_memory`]), and the Python
/// package's `rule`, `weights`, `fit`, `Rule` and `estimate` (and through them the Mitsuba
/// integrator). One line, exit 2 or a `ValueError`: `{what}: {subject} keeping {kept} factors
/// ({kept_for}) on {besides} needs … bytes of memory, more than the budget of …`. `what` names
/// the flag, field or argument (with its value where it helps: `--spp 1024`).
pub fn check_factor_memory(what: &str, need: &FactorMemory) -> Result<(), InputError> {
    check_memory(&need.describe(what), need.bytes())
}

/// Rejects `n = 0` and `n` whose matrices would not fit the memory budget.
pub fn check_point_count(n: usize, what: &str) -> Result<(), InputError> {
    if n == 0 {
        return Err(InputError::new(format!("{what}: must be at least 1, got 0")));
    }
    if n > MAX_POINTS {
        let gib = matrix_gib(n);
        return Err(InputError::new(format!(
            "{what}: {n} points would need {gib:.1} GiB for Q (factored in place); \
             the limit is {MAX_POINTS} points ({:.0} GiB)",
            matrix_gib(MAX_POINTS)
        )));
    }
    Ok(())
}

/// Largest distance of a point's norm from 1 that a given point (a points file, an array from
/// Python) may have.
pub const UNIT_TOLERANCE: f64 = 1e-9;

/// Checks a given point: finite, a unit vector (`|‖p‖ − 1| ≤ 1e-9`) and not below the horizon
/// (`z ≥ 0`, the local frame with normal `+z`). The message says what is wrong; the caller says
/// where (a file's line, an array's row).
pub fn check_point(p: Vec3) -> Result<(), String> {
    let norm = p.norm();
    // NaN coordinates make the norm NaN: not a unit vector either.
    if (norm - 1.0).abs() > UNIT_TOLERANCE || norm.is_nan() {
        return Err(format!(
            "({}, {}, {}) is not a unit vector (norm {})",
            shown(p.x),
            shown(p.y),
            shown(p.z),
            shown(norm)
        ));
    }
    if p.z < 0.0 {
        return Err(format!("z = {} is below the horizon (need z >= 0)", shown(p.z)));
    }
    Ok(())
}

/// Stream identifiers under the rule's seed.
const POINTS_STREAM: u64 = 0;
const KERNEL_MEAN_STREAM: u64 = 1;

/// The random stream of a rule's MC kernel means under `seed` (`workbench rule --kernel-mean
/// mc`): what [`compute_rule`] and [`rule_weights`] draw from.
pub fn kernel_mean_stream(seed: u64) -> crate::util::rng::WorkbenchRng {
    stream(seed, &[KERNEL_MEAN_STREAM])
}

/// `n` points drawn with `design` from `seed`: the set `workbench rule --n N --seed S` uses.
pub fn generate_points(n: usize, seed: u64, design: Design) -> Vec<Vec3> {
    design.sample_set(n, &mut stream(seed, &[POINTS_STREAM]))
}

/// The weights of `points` under `model`; `seed` drives the MC kernel-mean mode only.
pub fn compute_rule(points: &[Vec3], model: &BmcModel, seed: u64) -> crate::Result<BmcWeights> {
    let mut rng = kernel_mean_stream(seed);
    Ok(model.weights(points, &mut rng, &mut SpdWorkspace::new())?)
}

/// The weights of a set generated with `design` ([`generate_points`]): by the ring solver on
/// a ring set ([`BmcModel::weights_for_design`]), otherwise as [`compute_rule`].
pub fn compute_rule_for_design(
    points: &[Vec3],
    design: Design,
    model: &BmcModel,
    seed: u64,
) -> crate::Result<BmcWeights> {
    let mut rng = kernel_mean_stream(seed);
    Ok(model.weights_for_design(points, design, &mut rng, &mut SpdWorkspace::new())?)
}

/// The weights `workbench rule` writes (and the Python bindings' `rule` and `weights`) for
/// `points` drawn with `design` (points read from a file count as i.i.d. uniform: a dense solve):
/// a fixed model's ([`compute_rule_for_design`]) or, for a fitted model, those of the grid model
/// the values `y` choose ([`crate::bq::fitted::choose_on_points`], with the choice), as `bmc`
/// weights or turned into Bayes–Sard's ([`BmcWeights::bayes_sard`]) for `Method::Bsq`. `seed`
/// drives the MC kernel means, as in [`compute_rule`].
///
/// # Panics
/// With a fitted model and no values (or a fixed one with values), or values of another length.
pub fn rule_weights(
    points: &[Vec3],
    design: Design,
    model: &BmcModel,
    method: Method,
    values: Option<&[f64]>,
    seed: u64,
) -> crate::Result<(BmcWeights, Option<crate::bq::fitted::Choice>)> {
    assert_eq!(
        model.is_fitted(),
        values.is_some(),
        "values exactly for a fitted model"
    );
    let (weights, choice) = match values {
        Some(y) => {
            let mut rng = kernel_mean_stream(seed);
            let choice =
                crate::bq::fitted::choose_on_points(model, points, design, method, y, 0.0, &mut rng)?;
            (choice.weights.clone(), Some(choice))
        }
        None => (compute_rule_for_design(points, design, model, seed)?, None),
    };
    let weights = if method == Method::Bsq {
        weights.bayes_sard()
    } else {
        weights
    };
    Ok((weights, choice))
}

/// [`check_point_count`] for a set generated with `design`: a ring set needs a count that
/// splits into rings ([`crate::sampling::rings::check`]) and, with exact kernel means, may be
/// as large as [`crate::bq::factor::rings::MAX_RING_POINTS`] (no `N × N` matrix is formed).
pub fn check_generated_count(
    n: usize,
    design: Design,
    exact_kernel_means: bool,
    what: &str,
    design_setting: &str,
) -> Result<(), InputError> {
    if n == 0 {
        return check_point_count(n, what);
    }
    design
        .check_count(n)
        .map_err(|m| InputError::new(format!("{what}: {n} with {design_setting} {design}: {m}")))?;
    if design.structure() == Structure::Rings && exact_kernel_means {
        let max = crate::bq::factor::rings::MAX_RING_POINTS;
        if n > max {
            return Err(InputError::new(format!(
                "{what}: {n} points; the rings design allows at most {max}"
            )));
        }
        return Ok(());
    }
    check_point_count(n, what)
}

/// CSV `x,y,z,weight`, every number in Rust's shortest round-trip form (exact `f64`).
pub fn rule_csv(points: &[Vec3], weights: &[f64]) -> Vec<u8> {
    let mut out = String::from("x,y,z,weight\n");
    for (p, w) in points.iter().zip(weights) {
        out.push_str(&format!("{:?},{:?},{:?},{:?}\n", p.x, p.y, p.z, w));
    }
    out.into_bytes()
}

/// The summary JSON of a rule (`points` are the rule's points, for the worst-case error).
pub fn rule_summary(
    model: &BmcModel,
    mode_name: &str,
    points: &[Vec3],
    rule: &BmcWeights,
) -> serde_json::Value {
    let d = &rule.diagnostics;
    // Against the exact kernel means whatever the mode, so it measures the rule itself.
    let table = model.table();
    let z: Vec<f64> = points.iter().map(|p| table.z(p.z)).collect();
    let wce = crate::bq::weights::worst_case_error(
        points,
        &rule.weights,
        &z,
        table.prior_variance(),
        &model.kernel,
    );
    serde_json::json!({
        "n": d.n,
        "kernel": model.kernel.to_json(),
        "noise": model.noise,
        "kernel_mean": mode_name,
        "weight_sum": d.weight_sum,
        "weight_sum_target": std::f64::consts::TAU,
        "prior_variance": d.prior_variance,
        "posterior_variance": d.posterior_variance,
        "negative_weights": d.negative_weights,
        "min_weight": d.min_weight,
        "max_weight": d.max_weight,
        "jitter": d.jitter,
        "condition_estimate": d.condition_estimate,
        "worst_case_error": wce,
        "warnings": d.warnings.iter().map(|w| w.message()).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point's message shows tiny and huge coordinates in exponent form (a z of -1e-300 was
    /// three hundred digits long), ordinary ones as written.
    #[test]
    fn bad_points_are_named_in_a_short_line() {
        let below = check_point(Vec3::new(1.0, 0.0, -1e-300)).unwrap_err();
        assert_eq!(below, "z = -1e-300 is below the horizon (need z >= 0)");
        let far = check_point(Vec3::new(1e100, 0.0, 0.0)).unwrap_err();
        assert_eq!(far, "(1e100, 0, 0) is not a unit vector (norm 1e100)");
        let plain = check_point(Vec3::new(0.6, 0.0, -0.8)).unwrap_err();
        assert_eq!(plain, "z = -0.8 is below the horizon (need z >= 0)");
    }

    /// The one guard's accounting: the factor computed, the ones kept beside it, the rest; its
    /// line names each part present.
    #[test]
    fn factor_memory_counts_what_is_kept_and_says_so() {
        let one = FactorMemory::weight_set(512, Design::Iid(crate::sampling::Density::Uniform), true);
        assert_eq!(one.bytes(), 8 * 512 * 512);
        assert_eq!(one.describe("--n"), "--n: a weight set of 512 points");
        let kept = FactorMemory {
            subject: "2 sample sets of 64 points for bmc".into(),
            factor_bytes: 100,
            kept: 3,
            kept_for: "one per set for the sds".into(),
            besides: Some(("a 10-pixel image".into(), 480)),
        };
        assert_eq!(kept.bytes(), 480 + 4 * 100);
        assert_eq!(
            kept.describe("--spp 64"),
            "--spp 64: 2 sample sets of 64 points for bmc keeping 3 factors (one per set for the sds) \
             on a 10-pixel image"
        );
        let huge = FactorMemory {
            kept: u64::MAX,
            ..kept
        };
        assert_eq!(huge.bytes(), u64::MAX);
    }

    #[test]
    fn point_count_limits() {
        assert!(
            check_point_count(0, "--n")
                .unwrap_err()
                .to_string()
                .contains("got 0")
        );
        assert!(
            check_point_count(MAX_POINTS + 1, "--n")
                .unwrap_err()
                .to_string()
                .contains("GiB")
        );
        assert!(check_point_count(64, "--n").is_ok());
    }
}
