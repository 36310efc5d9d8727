//! Rules, weights, kernel means, the fitted model and estimates: `workbench rule`'s numbers and
//! [`workbench::bq::rule::Rule::estimate`], the one estimate sequence of the runner and the
//! renderer.

use crate::args::{self, Number, Text, Whole};
use crate::arrays;
use crate::model::{self, ModelArgs};
use crate::{library_error, value_error};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, OnceLock};
use workbench::bq::estimator::Method;
use workbench::bq::factor::{Factor, SpdWorkspace};
use workbench::bq::model::{BmcModel, ResolvedModel};
use workbench::bq::rule::{FactorMemory, Values};
use workbench::bq::weights::{BmcWeights, Diagnostics, Scale, Solved};
use workbench::sampling::{Density, Design};
use workbench::util::geometry::Vec3;

/// `method`, by name.
pub fn method_arg(name: &str) -> PyResult<Method> {
    Method::from_name(name).ok_or_else(|| {
        value_error(format!(
            "method: unknown method {name:?}; expected one of {}",
            Method::ALL.map(|m| format!("{:?}", m.name())).join(", ")
        ))
    })
}

/// A method with weights (`bmc`, `bmcp`, `bsq`): what a rule is for.
fn weighted_method_arg(name: &str) -> PyResult<Method> {
    let method = method_arg(name)?;
    if !method.needs_weights() {
        return Err(value_error(format!(
            "method: {name:?} uses no weights; a rule's weights are for \"bmc\" (also \"bmcp\") or \"bsq\""
        )));
    }
    Ok(method)
}

fn design_arg(name: &str) -> PyResult<Design> {
    Design::from_name(name).ok_or_else(|| {
        value_error(format!(
            "design: unknown design {name:?}; expected one of {}",
            Design::ALL.map(|d| format!("{:?}", d.name())).join(", ")
        ))
    })
}

fn scale_arg(name: &str) -> PyResult<Scale> {
    Scale::from_name(name).ok_or_else(|| {
        value_error(format!(
            "scale: unknown scale {name:?}; expected \"unit\", \"ml\" or \"loo\""
        ))
    })
}

/// Bayes–Sard fits a constant: it needs two points (as `workbench rule --method bsq`).
fn check_min_points(method: Method, n: usize, what: &str) -> PyResult<()> {
    if n < method.min_points() {
        return Err(value_error(format!(
            "{what}: method {:?} needs at least {} points, got {n}",
            method.name(),
            method.min_points()
        )));
    }
    Ok(())
}

/// The values argument against the model: a fitted model needs them, a fixed one refuses them
/// (the CLI's `--values` rules).
fn values_for_model(
    values: Option<&Bound<'_, PyAny>>,
    resolved: &ResolvedModel,
    n: usize,
) -> PyResult<Option<Vec<f64>>> {
    match (values, resolved.is_fitted()) {
        (Some(v), true) => Ok(Some(arrays::values(v, "values", n)?)),
        (None, true) => Err(value_error(
            "values: a fitted kernel needs the integrand's values at the rule's points (the model is \
             chosen by the marginal likelihood of the values)",
        )),
        (Some(_), false) => Err(value_error(
            "values: only used with a fitted kernel (a fixed kernel's weights do not depend on the values)",
        )),
        (None, false) => Ok(None),
    }
}

/// Warns (Python `RuntimeWarning`) about a weight set's numerical warnings, as the CLI prints
/// them.
fn warn_diagnostics(py: Python<'_>, d: &Diagnostics) -> PyResult<()> {
    for w in &d.warnings {
        model::warn(py, &w.message())?;
    }
    Ok(())
}

/// A rule as arrays: points `(n, 3)` and weights `(n,)`.
type PointsAndWeights<'py> = (Bound<'py, numpy::PyArray2<f64>>, Bound<'py, numpy::PyArray1<f64>>);

/// The rule ``workbench rule --n N --seed S [--design D] …`` writes: ``(points, weights)``,
/// bit for bit the CLI's CSV.
///
/// ``design="rings"`` takes N = J·M (the ring solver; up to 65536 points with exact kernel
/// means), other designs up to 16384. ``method="bsq"`` gives the Bayes–Sard weights (summing to
/// 2π; N ≥ 2); ``"bmcp"`` shares BMC's. A fitted ``kernel`` needs ``values`` (the integrand at
/// the points that ``rule`` with the same ``n``, ``seed`` and ``design`` draws): the weights are
/// those of the grid model whose marginal likelihood of the values is largest. Numerical
/// warnings (jitter, ill-conditioning, a negative posterior variance) are ``RuntimeWarning``s.
///
/// >>> points, weights = rule(64, seed=7)
/// >>> points.shape, round(float(weights.sum()), 6)
/// ((64, 3), 6.251944)
#[pyfunction]
#[pyo3(signature = (n=Whole::of(64), *, design=Text::of("uniform"), kernel=None, noise=None,
    kernel_mean=None, kernel_mean_samples=None, method=Text::of("bmc"), seed=Whole::of(0), values=None),
    text_signature = "(n=64, *, design='uniform', kernel=None, noise=None, kernel_mean=None, \
    kernel_mean_samples=None, method='bmc', seed=0, values=None)")]
#[allow(clippy::too_many_arguments)]
pub fn rule<'py>(
    py: Python<'py>,
    n: Whole,
    design: Text,
    kernel: Option<Bound<'py, PyAny>>,
    noise: Option<Number>,
    kernel_mean: Option<Text>,
    kernel_mean_samples: Option<Whole>,
    method: Text,
    seed: Whole,
    values: Option<Bound<'py, PyAny>>,
) -> PyResult<PointsAndWeights<'py>> {
    let n = n.count("n")?;
    let seed = seed.get("seed")?;
    let design = design_arg(design.get("design")?)?;
    let method = weighted_method_arg(method.get("method")?)?;
    let args = ModelArgs::new(kernel, noise, kernel_mean, kernel_mean_samples)?;
    let resolved = args.resolve(py)?;
    let exact = resolved.kernel_mean == workbench::bq::model::KernelMeanName::Exact;
    if n > 0 {
        design
            .check_count(n)
            .map_err(|m| value_error(format!("n: {n} with design {:?}: {m}", design.name())))?;
    }
    workbench::bq::rule::check_generated_count(n, design, exact, "n", "design")
        .map_err(|e| value_error(e.0))?;
    check_min_points(method, n, "n")?;
    workbench::bq::rule::check_factor_memory(
        "n",
        &workbench::bq::rule::FactorMemory::weight_set(n, design, exact),
    )
    .map_err(|e| value_error(e.0))?;
    let values = values_for_model(values.as_ref(), &resolved, n)?;
    let model = model::build(py, &resolved)?;
    let (points, (weights, _)) = py
        .detach(|| {
            let points = workbench::bq::rule::generate_points(n, seed, design);
            workbench::bq::rule::rule_weights(&points, design, &model, method, values.as_deref(), seed)
                .map(|w| (points, w))
        })
        .map_err(library_error)?;
    warn_diagnostics(py, &weights.diagnostics)?;
    Ok((
        arrays::points_array(py, &points),
        arrays::vector(py, weights.weights),
    ))
}

/// The BMC (BMCP) or Bayes–Sard weights of given points: ``workbench rule --points FILE``,
/// bit for bit (a dense solve, at most 16384 points). ``seed`` drives MC kernel means only;
/// ``values`` as in :func:`rule` for a fitted kernel.
#[pyfunction]
#[pyo3(signature = (points, *, kernel=None, noise=None, kernel_mean=None,
    kernel_mean_samples=None, method=Text::of("bmc"), seed=Whole::of(0), values=None),
    text_signature = "(points, *, kernel=None, noise=None, kernel_mean=None, \
    kernel_mean_samples=None, method='bmc', seed=0, values=None)")]
#[allow(clippy::too_many_arguments)]
pub fn weights<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    kernel: Option<Bound<'py, PyAny>>,
    noise: Option<Number>,
    kernel_mean: Option<Text>,
    kernel_mean_samples: Option<Whole>,
    method: Text,
    seed: Whole,
    values: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    let seed = seed.get("seed")?;
    let method = weighted_method_arg(method.get("method")?)?;
    let args = ModelArgs::new(kernel, noise, kernel_mean, kernel_mean_samples)?;
    let resolved = args.resolve(py)?;
    let points = arrays::points(points, "points")?;
    workbench::bq::rule::check_point_count(points.len(), "points").map_err(|e| value_error(e.0))?;
    check_min_points(method, points.len(), "points")?;
    dense_memory("points", points.len(), &resolved)?;
    let values = values_for_model(values.as_ref(), &resolved, points.len())?;
    let model = model::build(py, &resolved)?;
    let design = Design::Iid(Density::Uniform);
    let (weights, _) = py
        .detach(|| {
            workbench::bq::rule::rule_weights(&points, design, &model, method, values.as_deref(), seed)
        })
        .map_err(library_error)?;
    warn_diagnostics(py, &weights.diagnostics)?;
    Ok(arrays::vector(py, weights.weights))
}

/// The kernel means ``z_i = ∫_H k(x_i, ω) dω`` (math.md §4): exact (tabulated in the height
/// ``x_i·n``), or the thesis's MC estimates (``"mc"``: fresh directions per point; ``"mc-shared"``:
/// one set for all), drawn from ``seed`` as :func:`rule` draws them. Not for a fitted kernel.
#[pyfunction]
#[pyo3(signature = (points, *, kernel=None, kernel_mean=None, kernel_mean_samples=None, seed=Whole::of(0)),
    text_signature = "(points, *, kernel=None, kernel_mean=None, kernel_mean_samples=None, seed=0)")]
pub fn kernel_means<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    kernel: Option<Bound<'py, PyAny>>,
    kernel_mean: Option<Text>,
    kernel_mean_samples: Option<Whole>,
    seed: Whole,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    let seed = seed.get("seed")?;
    let model = fixed_model(
        py,
        ModelArgs::new(kernel, None, kernel_mean, kernel_mean_samples)?,
    )?;
    let points = arrays::points(points, "points")?;
    let z = py.detach(|| model.kernel_means(&points, &mut workbench::bq::rule::kernel_mean_stream(seed)));
    Ok(arrays::vector(py, z))
}

/// ``V̂ = ∫_H ∫_H k(ω, ω') dω dω'``, the prior variance of the integral (exact).
#[pyfunction]
#[pyo3(signature = (kernel=None))]
pub fn prior_variance<'py>(py: Python<'py>, kernel: Option<Bound<'py, PyAny>>) -> PyResult<f64> {
    Ok(fixed_model(py, ModelArgs::new(kernel, None, None, None)?)?.prior_variance())
}

/// A fixed (not fitted) model without noise-dependent quantities.
fn fixed_model(py: Python<'_>, args: ModelArgs<'_>) -> PyResult<Arc<BmcModel>> {
    let resolved = args.resolve(py)?;
    if resolved.is_fitted() {
        return Err(value_error(
            "kernel: a fitted kernel has one kernel per grid model; give one of them, e.g. \
             {\"type\": \"sobolev\", \"s\": 2.75}",
        ));
    }
    model::build(py, &resolved)
}

/// The fitted model's choice on given points (math.md §9; ``workbench rule --points P --kernel
/// fitted --values V``): every grid model (``grid={"s": [...], "noise": [...]}``, default s ∈
/// {1.2, 1.6, 2.75, 3.75} × σ_n² ∈ {1e-2, 1e-8}) is factored and the one with the largest
/// profiled log marginal likelihood (``"bsq"``: the restricted one) wins.
///
/// Returns ``{"chosen": index, "model": "s=3.75 noise=1e-8", "s": 3.75, "noise": 1e-08,
/// "grid": [{"s", "noise", "log_marginal_likelihood"}, ...], "weights": array}``.
#[pyfunction]
#[pyo3(signature = (points, values, *, method=Text::of("bmc"), grid=None),
    text_signature = "(points, values, *, method='bmc', grid=None)")]
pub fn fit<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    values: &Bound<'py, PyAny>,
    method: Text,
    grid: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = weighted_method_arg(method.get("method")?)?;
    let kernel = PyDict::new(py);
    kernel.set_item("type", "fitted")?;
    if let Some(g) = grid {
        kernel.set_item("grid", g)?;
    }
    let args = ModelArgs::new(Some(kernel.into_any()), None, None, None)?;
    // The model's messages name the kernel's fields (`kernel: grid.noise …`, `kernel.grid: …`);
    // here the argument is the grid.
    let resolved = args.resolve(py).map_err(|e| {
        let m = e.value(py).to_string();
        let m = m
            .strip_prefix("kernel: ")
            .or(m.strip_prefix("kernel."))
            .unwrap_or(&m);
        if m.starts_with("grid") {
            value_error(m.to_string())
        } else {
            value_error(format!("grid: {m}"))
        }
    })?;
    let points = arrays::points(points, "points")?;
    workbench::bq::rule::check_point_count(points.len(), "points").map_err(|e| value_error(e.0))?;
    check_min_points(method, points.len(), "points")?;
    dense_memory("points", points.len(), &resolved)?;
    let y = arrays::values(values, "values", points.len())?;
    let model = model::build(py, &resolved)?;
    let design = Design::Iid(Density::Uniform);
    let (weights, choice) = py
        .detach(|| workbench::bq::rule::rule_weights(&points, design, &model, method, Some(&y), 0))
        .map_err(library_error)?;
    let choice = choice.expect("a fitted model chooses");
    let out = PyDict::new(py);
    out.set_item("chosen", choice.chosen)?;
    let chosen = &model.candidates()[choice.chosen];
    out.set_item("model", chosen.label())?;
    out.set_item("s", sobolev_s(chosen))?;
    out.set_item("noise", chosen.noise)?;
    let grid: Vec<Bound<'py, PyDict>> = model
        .candidates()
        .iter()
        .zip(&choice.log_likelihoods)
        .map(|(m, l)| {
            let d = PyDict::new(py);
            d.set_item("s", sobolev_s(m))?;
            d.set_item("noise", m.noise)?;
            d.set_item("log_marginal_likelihood", l)?;
            Ok(d)
        })
        .collect::<PyResult<_>>()?;
    out.set_item("grid", grid)?;
    out.set_item("weights", arrays::vector(py, weights.weights))?;
    Ok(out)
}

/// The memory guard ([`workbench::bq::rule::check_factor_memory`]) for one weight set of `n`
/// given points (a dense solve).
fn dense_memory(what: &str, n: usize, resolved: &ResolvedModel) -> PyResult<()> {
    let exact = resolved.kernel_mean == workbench::bq::model::KernelMeanName::Exact;
    let need = FactorMemory::weight_set(n, Design::Iid(Density::Uniform), exact);
    workbench::bq::rule::check_factor_memory(what, &need).map_err(|e| value_error(e.0))
}

/// The share of the memory budget a fitted rule may fill with every grid model's factor
/// (cached: an estimate then costs one solve per model). Beyond it the rule streams its grid.
const CACHE_SHARE: f64 = 0.5;

/// Whether a rule of `n` points over `models` models caches every model's factor, after the
/// memory guard of what it will keep (issue 30: "a fitted Rule keeps only what it must").
///
/// A fixed model keeps its one factor (`Q⁻¹Y`, `diag(Q⁻¹)` and `q_inverse` need it): the
/// workspace's plus the kept copy. A fitted rule caches one factor per grid model when all of
/// them (and the workspace) take at most [`CACHE_SHARE`] of the budget; otherwise it keeps only
/// every model's weights and `log det Q` (`O(N)` each) and *streams* the grid at each estimate:
/// it factors each model again in the grid's order (the same kernel-mean stream, so the same
/// factors, bit for bit), scores its marginal likelihood and keeps the best factor so far — the
/// workspace, the best so far and the one being scored, 3 factors whatever the grid's size, for
/// one factorisation per model per estimate (`M N³/3` flops instead of `M N²`).
fn keeps_all_factors(what: &str, n: usize, design: Design, exact: bool, models: usize) -> PyResult<bool> {
    let all = FactorMemory {
        subject: format!("a rule of {n} points"),
        factor_bytes: workbench::bq::rule::weight_set_bytes(n, design, exact),
        kept: models as u64,
        kept_for: "one per model".into(),
        besides: None,
    };
    let budget = workbench::util::memory::Budget::current().map_err(value_error)?;
    let fits_share = budget
        .bytes
        .is_none_or(|b| all.bytes() as f64 <= CACHE_SHARE * b as f64);
    if models == 1 || fits_share {
        workbench::bq::rule::check_factor_memory(what, &all).map_err(|e| value_error(e.0))?;
        return Ok(true);
    }
    let streamed = FactorMemory {
        kept: 2,
        kept_for: format!("its {models} grid models streamed: the best so far and the one being scored"),
        ..all
    };
    workbench::bq::rule::check_factor_memory(what, &streamed).map_err(|e| value_error(e.0))?;
    Ok(false)
}

fn sobolev_s(m: &BmcModel) -> Option<f64> {
    match &m.kernel {
        workbench::bq::kernel::Kernel::Sobolev(k) => Some(k.s()),
        _ => None,
    }
}

/// One model's weights on a rule's points with its kept factor (what `Q⁻¹Y` and `diag(Q⁻¹)`
/// need; `None` when a fitted rule streams its grid, [`keeps_all_factors`]) and `log det Q`
/// (what a fitted model's choice needs).
struct Kept {
    weights: BmcWeights,
    factor: Option<Factor>,
    log_det: f64,
    inverse_diagonal: OnceLock<Vec<f64>>,
}

/// The model a rule's estimate uses ([`Rule::choose`]): its index, every grid model's `ℓ` (empty
/// for a fixed model), `Q⁻¹Y` under it when asked for, and its factor when the grid was streamed
/// (a cached rule's is in [`Kept`]).
struct Chosen {
    k: usize,
    ells: Vec<f64>,
    solve: Option<Vec<f64>>,
    factor: Option<Factor>,
}

/// A quadrature rule kept for estimates: points, their BMC weights under a model and the
/// factorisation of ``Q = K + σ_n² I`` (the ``ml``/``loo`` amplitudes solve with it). A fitted
/// kernel keeps every grid model's weights, and every model's factor only when they all fit half
/// the memory budget (``WORKBENCH_MEMORY``); otherwise each estimate factors the grid again, one
/// model at a time, keeping the best so far (the same numbers, bit for bit; 3 factors in memory
/// whatever the grid's size).
///
/// ``Rule(points, ...)`` weights given points (a dense solve, as :func:`weights`);
/// ``Rule(n=64, design=..., seed=...)`` draws them as :func:`rule` does (same points, same
/// weights). ``seed`` also drives MC kernel means.
#[pyclass(frozen, module = "workbench")]
pub struct Rule {
    points: Vec<Vec3>,
    /// How the points were drawn (given points: i.i.d. uniform, a dense solve).
    design: Design,
    generated: bool,
    resolved: ResolvedModel,
    model: Arc<BmcModel>,
    kept: Vec<Kept>,
    /// The seed of the kernel-mean stream, for a streamed grid's factors.
    seed: u64,
}

impl Rule {
    /// `what` names the argument the points came from (`n`, `points`), for the memory guard: the
    /// rule keeps one factor per model of a fitted grid, besides the workspace.
    fn build(
        py: Python<'_>,
        what: &str,
        points: Vec<Vec3>,
        design: Design,
        generated: bool,
        resolved: ResolvedModel,
        seed: u64,
    ) -> PyResult<Rule> {
        let models = resolved.grid.as_ref().map_or(1, |g| g.len());
        let exact = resolved.kernel_mean == workbench::bq::model::KernelMeanName::Exact;
        let cache = keeps_all_factors(what, points.len(), design, exact, models)?;
        let model = model::build(py, &resolved)?;
        let kept = py
            .detach(|| {
                // As `workbench rule` (and a fitted model's choice) draws: one kernel-mean stream
                // and one workspace, every grid model in turn.
                let mut rng = workbench::bq::rule::kernel_mean_stream(seed);
                let mut workspace = SpdWorkspace::new();
                let models: Vec<&BmcModel> = if model.is_fitted() {
                    model.candidates().iter().collect()
                } else {
                    vec![&model]
                };
                models
                    .into_iter()
                    .map(|m| {
                        let weights = m.weights_for_design(&points, design, &mut rng, &mut workspace)?;
                        Ok(Kept {
                            weights,
                            factor: cache.then(|| workspace.keep_factor()),
                            log_det: workspace.log_det(),
                            inverse_diagonal: OnceLock::new(),
                        })
                    })
                    .collect::<Result<Vec<_>, workbench::bq::factor::NotPositiveDefinite>>()
            })
            .map_err(|e| library_error(e.into()))?;
        for k in &kept {
            warn_diagnostics(py, &k.weights.diagnostics)?;
        }
        Ok(Rule {
            points,
            design,
            generated,
            resolved,
            model,
            kept,
            seed,
        })
    }

    /// `Q⁻¹Y` with model `k`'s factor.
    fn solve(&self, k: usize, y: &[f64]) -> Vec<f64> {
        let mut solve = y.to_vec();
        self.kept[k]
            .factor
            .as_ref()
            .expect("a fixed or cached rule keeps its factors")
            .solve_columns_in_place(&mut solve, 1);
        solve
    }

    /// A streamed fitted rule's choice ([`keeps_all_factors`]): every grid model factored again
    /// in the grid's order from the rule's kernel-mean stream (as [`Rule::build`] factored them),
    /// scored, and its factor kept while it is the best so far ([`fitted::best`] of the scores so
    /// far: the first largest, as on the whole grid). The chosen model, every `ℓ`, its `Q⁻¹Y` and
    /// its factor.
    ///
    /// [`fitted::best`]: workbench::bq::fitted::best
    fn stream(&self, method: Method, y: &[f64], prior: f64) -> PyResult<Chosen> {
        let mut rng = workbench::bq::rule::kernel_mean_stream(self.seed);
        let mut workspace = SpdWorkspace::new();
        let mut ells = Vec::with_capacity(self.kept.len());
        let mut best = None;
        for (k, (m, c)) in self.model.candidates().iter().zip(&self.kept).enumerate() {
            m.weights_for_design(&self.points, self.design, &mut rng, &mut workspace)
                .map_err(|e| library_error(e.into()))?;
            let factor = workspace.keep_factor();
            let mut solve = y.to_vec();
            factor.solve_columns_in_place(&mut solve, 1);
            ells.push(
                workbench::bq::fitted::log_marginal_likelihood(
                    method, y, &solve, &c.weights, prior, c.log_det,
                )
                .unwrap_or(f64::NAN),
            );
            if workbench::bq::fitted::best(&ells) == k {
                // The earlier best is dropped here: 3 factors at most (the workspace's too).
                best = Some((solve, factor));
            }
        }
        let k = workbench::bq::fitted::best(&ells);
        let (solve, factor) = best.expect("a grid has a first model");
        Ok(Chosen {
            k,
            ells,
            solve: Some(solve),
            factor: Some(factor),
        })
    }

    /// The model an estimate of `method` on `y` uses (a fitted rule: the grid model of largest
    /// marginal likelihood, with every model's `ℓ`), and `Q⁻¹Y` under it when `needs_solve`.
    fn choose(&self, method: Method, y: &[f64], prior: f64, needs_solve: bool) -> PyResult<Chosen> {
        if !self.model.is_fitted() {
            return Ok(Chosen {
                k: 0,
                ells: Vec::new(),
                solve: needs_solve.then(|| self.solve(0, y)),
                factor: None,
            });
        }
        if self.kept[0].factor.is_none() {
            return self.stream(method, y, prior);
        }
        let mut solves = Vec::with_capacity(self.kept.len());
        let ells: Vec<f64> = self
            .kept
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let solve = self.solve(k, y);
                let l = workbench::bq::fitted::log_marginal_likelihood(
                    method, y, &solve, &c.weights, prior, c.log_det,
                )
                .unwrap_or(f64::NAN);
                solves.push(solve);
                l
            })
            .collect();
        let best = workbench::bq::fitted::best(&ells);
        Ok(Chosen {
            k: best,
            ells,
            solve: Some(solves.swap_remove(best)),
            factor: None,
        })
    }

    /// `Î` and its sd (NaN where none is stated) of `method` (one with weights) on values `y`.
    fn estimate_values(&self, method: Method, y: &[f64], prior: f64, scale: Scale) -> PyResult<(f64, f64)> {
        let (value, sd, _) = self.estimate_with_amplitude(method, y, prior, scale)?;
        Ok((value, sd))
    }

    /// [`Rule::estimate_values`] with the amplitude used (None for MC).
    fn estimate_with_amplitude(
        &self,
        method: Method,
        y: &[f64],
        prior: f64,
        scale: Scale,
    ) -> PyResult<(f64, f64, Option<f64>)> {
        let Chosen { k, solve, factor, .. } = self.choose(method, y, prior, scale != Scale::Unit)?;
        let c = &self.kept[k];
        let inverse_diagonal = (scale == Scale::Loo).then(|| {
            c.inverse_diagonal
                .get_or_init(|| {
                    c.factor
                        .as_ref()
                        .or(factor.as_ref())
                        .expect("the chosen model's factor, kept or streamed")
                        .inverse_diagonal()
                })
                .as_slice()
        });
        let rule = workbench::bq::rule::Rule {
            density: self.design.density(),
            points: &self.points,
            weights: Some(&c.weights),
            inverse_diagonal,
        };
        let values = Values {
            y,
            solved: solve.as_deref().map(Solved::Full),
        };
        let e = rule.estimate(method, values, prior, scale);
        Ok((
            e.value,
            e.uncertainty.map_or(f64::NAN, |u| u.sd),
            e.uncertainty.and_then(|u| u.amplitude),
        ))
    }

    /// The weight set `method` uses on `values` (a fitted rule needs them).
    fn weight_set(
        &self,
        method: Method,
        values: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(usize, Vec<f64>, BmcWeights)> {
        let (k, ells) = match (values, self.model.is_fitted()) {
            (None, false) => (0, Vec::new()),
            (Some(v), true) => {
                let y = arrays::values(v, "values", self.points.len())?;
                let Chosen { k, ells, .. } = self.choose(method, &y, 0.0, false)?;
                (k, ells)
            }
            (None, true) => {
                return Err(value_error(
                    "values: a fitted rule's weights depend on the integrand's values; pass them",
                ));
            }
            (Some(_), false) => {
                return Err(value_error(
                    "values: only used with a fitted kernel (a fixed kernel's weights do not depend on the values)",
                ));
            }
        };
        let w = &self.kept[k].weights;
        Ok((
            k,
            ells,
            if method == Method::Bsq {
                w.bayes_sard()
            } else {
                w.clone()
            },
        ))
    }
}

/// The prior constant of BMCP: needed by it, refused by the others; bounded as the CLI bounds an
/// experiment's `prior` ([`workbench::experiment::plan::prior_bound`]: in units of the model's
/// prior sd at a point, so a kernel of tiny scale takes only small constants).
fn prior_arg(method: Method, prior: Option<f64>, resolved: &ResolvedModel) -> PyResult<f64> {
    match (method.uses_prior(), prior) {
        (true, Some(c)) => {
            let max = workbench::experiment::plan::MAX_PRIOR;
            let bound = workbench::experiment::plan::prior_bound(resolved);
            if !(c.is_finite() && c.abs() <= bound) {
                return Err(value_error(format!(
                    "prior: the constant must be a finite number with |c| <= {max:e} · min(1, \
                     √(k(x,x) + σ_n²)) = {bound:e} for this model (larger constants overflow the \
                     fitted amplitude's rᵀQ⁻¹r), got {c:e}"
                )));
            }
            Ok(c)
        }
        (true, None) => Err(value_error(
            "prior: method \"bmcp\" needs its constant prior mean c (e.g. the integrand's mean value)",
        )),
        (false, Some(c)) => Err(value_error(format!(
            "prior: {c} is not used by method {:?} (only \"bmcp\" takes a prior)",
            method.name()
        ))),
        (false, None) => Ok(0.0),
    }
}

#[pymethods]
impl Rule {
    #[new]
    #[pyo3(signature = (points=None, *, n=None, design=None, kernel=None, noise=None,
        kernel_mean=None, kernel_mean_samples=None, seed=Whole::of(0)),
        text_signature = "(points=None, *, n=None, design=None, kernel=None, noise=None, \
        kernel_mean=None, kernel_mean_samples=None, seed=0)")]
    #[allow(clippy::too_many_arguments)]
    fn new<'py>(
        py: Python<'py>,
        points: Option<&Bound<'py, PyAny>>,
        n: Option<Whole>,
        design: Option<Text>,
        kernel: Option<Bound<'py, PyAny>>,
        noise: Option<Number>,
        kernel_mean: Option<Text>,
        kernel_mean_samples: Option<Whole>,
        seed: Whole,
    ) -> PyResult<Rule> {
        let n = n.map(|n| n.count("n")).transpose()?;
        let seed = seed.get("seed")?;
        let design = args::text_opt(design.as_ref(), "design")?;
        let args = ModelArgs::new(kernel, noise, kernel_mean, kernel_mean_samples)?;
        let resolved = args.resolve(py)?;
        let exact = resolved.kernel_mean == workbench::bq::model::KernelMeanName::Exact;
        match (points, n) {
            (Some(_), Some(_)) => Err(value_error(
                "n: give either points or n (points to generate), not both",
            )),
            (Some(_), None) if design.is_some() => Err(value_error(
                "design: only with n (how to generate the points); given points are weighted as they are",
            )),
            (Some(p), None) => {
                let points = arrays::points(p, "points")?;
                workbench::bq::rule::check_point_count(points.len(), "points")
                    .map_err(|e| value_error(e.0))?;
                Rule::build(
                    py,
                    "points",
                    points,
                    Design::Iid(Density::Uniform),
                    false,
                    resolved,
                    seed,
                )
            }
            (None, n) => {
                let n = n.unwrap_or(64);
                let design = design_arg(design.unwrap_or("uniform"))?;
                if n > 0 {
                    design
                        .check_count(n)
                        .map_err(|m| value_error(format!("n: {n} with design {:?}: {m}", design.name())))?;
                }
                workbench::bq::rule::check_generated_count(n, design, exact, "n", "design")
                    .map_err(|e| value_error(e.0))?;
                let points = workbench::bq::rule::generate_points(n, seed, design);
                Rule::build(py, "n", points, design, true, resolved, seed)
            }
        }
    }

    /// The points, shape ``(n, 3)`` (a copy).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        arrays::points_array(py, &self.points)
    }

    /// The number of points.
    #[getter]
    fn n(&self) -> usize {
        self.points.len()
    }

    fn __len__(&self) -> usize {
        self.points.len()
    }

    /// The design the points were drawn with, None for given points.
    #[getter]
    fn design(&self) -> Option<&'static str> {
        self.generated.then(|| self.design.name())
    }

    /// Whether the kernel is fitted: the weights then depend on the values.
    #[getter]
    fn fitted(&self) -> bool {
        self.model.is_fitted()
    }

    /// The resolved model (kernel with parameters, noise, kernel mean), as a manifest states it.
    #[getter]
    fn model<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_python(py, &self.resolved.to_json())
    }

    /// The weights for ``method`` (``"bsq"``: Bayes–Sard's); a fitted rule needs the values
    /// that choose its model.
    #[pyo3(signature = (method=Text::of("bmc"), values=None),
        text_signature = "($self, method='bmc', values=None)")]
    fn weights<'py>(
        &self,
        py: Python<'py>,
        method: Text,
        values: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let method = weighted_method_arg(method.get("method")?)?;
        check_min_points(method, self.points.len(), "points")?;
        let (_, _, w) = self.weight_set(method, values)?;
        Ok(arrays::vector(py, w.weights))
    }

    /// The weight set's diagnostics as ``workbench rule --summary`` states them (``n``,
    /// ``weight_sum``, ``negative_weights``, ``min_weight``, ``max_weight``, ``jitter``,
    /// ``condition_estimate``, ``prior_variance``, ``posterior_variance`` (raw, unit amplitude),
    /// ``posterior_sd``, ``warnings``); a fitted rule adds ``chosen``, ``model`` and
    /// ``log_marginal_likelihoods``.
    #[pyo3(signature = (method=Text::of("bmc"), values=None),
        text_signature = "($self, method='bmc', values=None)")]
    fn diagnostics<'py>(
        &self,
        py: Python<'py>,
        method: Text,
        values: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let method = weighted_method_arg(method.get("method")?)?;
        check_min_points(method, self.points.len(), "points")?;
        let (k, ells, w) = self.weight_set(method, values)?;
        let d = &w.diagnostics;
        let out = PyDict::new(py);
        out.set_item("n", d.n)?;
        out.set_item("weight_sum", d.weight_sum)?;
        out.set_item("negative_weights", d.negative_weights)?;
        out.set_item("min_weight", d.min_weight)?;
        out.set_item("max_weight", d.max_weight)?;
        out.set_item("jitter", d.jitter)?;
        out.set_item("condition_estimate", d.condition_estimate)?;
        out.set_item("prior_variance", d.prior_variance)?;
        out.set_item("posterior_variance", d.posterior_variance)?;
        out.set_item("posterior_sd", w.posterior_sd())?;
        out.set_item(
            "warnings",
            d.warnings.iter().map(|w| w.message()).collect::<Vec<_>>(),
        )?;
        if self.model.is_fitted() {
            out.set_item("chosen", k)?;
            out.set_item("model", self.model.candidates()[k].label())?;
            out.set_item("log_marginal_likelihoods", ells)?;
        }
        Ok(out)
    }

    /// ``Q⁻¹ = (K + σ_n² I)⁻¹``, shape ``(n, n)``, of a fixed model's rule: what a vectorised
    /// renderer needs for the ``ml`` amplitude ``λ̂ = YᵀQ⁻¹Y / N`` of many pixels at once.
    fn q_inverse<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        if self.model.is_fitted() {
            return Err(value_error(
                "kernel: a fitted rule has one Q per grid model; use a fixed kernel",
            ));
        }
        let n = self.points.len();
        // 8 n² bytes more: 32 GiB at n = 65536 on rings (whose own factor is small), which
        // aborted the interpreter; the guard first, then a fallible allocation.
        let what = format!("n: q_inverse() of a rule of {n} points (a {n} × {n} matrix)");
        workbench::bq::rule::check_memory(&what, workbench::util::memory::matrix_bytes(n))
            .map_err(|e| value_error(e.0))?;
        let mut q = workbench::util::memory::try_zeros(n * n, &what).map_err(value_error)?;
        for i in 0..n {
            q[i * n + i] = 1.0;
        }
        self.kept[0]
            .factor
            .as_ref()
            .expect("a fixed rule keeps its factor")
            .solve_columns_in_place(&mut q, n);
        // Column-major n × n; Q⁻¹ is symmetric, so the rows read the same.
        Ok(numpy::ndarray::Array2::from_shape_vec((n, n), q)
            .expect("n × n")
            .into_pyarray(py))
    }

    /// ``(Î, sd)`` as :func:`estimate` with ``weights=self`` (without the points argument),
    /// with its ``RuntimeWarning``s.
    #[pyo3(signature = (values, method=Text::of("bmc"), prior=None, scale=None),
        text_signature = "($self, values, method='bmc', prior=None, scale=None)")]
    fn estimate(
        &self,
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        method: Text,
        prior: Option<Number>,
        scale: Option<Text>,
    ) -> PyResult<(f64, f64)> {
        let method = weighted_method_arg(method.get("method")?)?;
        let prior = args::number_opt(prior.as_ref(), "prior")?;
        let scale = args::text_opt(scale.as_ref(), "scale")?;
        let y = arrays::values(values, "values", self.points.len())?;
        self.estimate_checked(py, method, &y, prior, scale)
    }

    fn __repr__(&self) -> String {
        let model = if self.model.is_fitted() {
            format!("fitted over {} models", self.model.candidates().len())
        } else {
            self.model.label()
        };
        match self.generated {
            true => format!(
                "workbench.Rule(n={}, design={:?}, {model})",
                self.points.len(),
                self.design.name()
            ),
            false => format!("workbench.Rule({} given points, {model})", self.points.len()),
        }
    }
}

impl Rule {
    fn estimate_checked(
        &self,
        py: Python<'_>,
        method: Method,
        y: &[f64],
        prior: Option<f64>,
        scale: Option<&str>,
    ) -> PyResult<(f64, f64)> {
        check_min_points(method, self.points.len(), "points")?;
        let prior = prior_arg(method, prior, &self.resolved)?;
        let scale = scale.map_or(Ok(Scale::DEFAULT), scale_arg)?;
        let (value, sd, amplitude) = self.estimate_with_amplitude(method, y, prior, scale)?;
        for w in estimate_warnings(value, amplitude, scale) {
            crate::model::warn(py, &w)?;
        }
        Ok((value, sd))
    }
}

/// The warnings the CLI counts in `trials.csv`'s `warnings` column for one estimate
/// ([`workbench::experiment::runner::UnitResult::warnings_for`]), as sentences: a fitted
/// amplitude of exactly 0 (`zero_amplitude`: zero evidence, e.g. all values equal to the prior
/// mean, all zero for BMC), one that overflowed to ∞, and an estimate that is not finite.
pub fn estimate_warnings(value: f64, amplitude: Option<f64>, scale: Scale) -> Vec<String> {
    let mut out = Vec::new();
    let fitted = scale != Scale::Unit;
    match amplitude {
        Some(a) if fitted && a == 0.0 => out.push(
            "zero evidence: the fitted amplitude is 0 (the values are what the prior mean says, e.g. all \
             zero for bmc), so the sd is 0 and an interval has width 0; the CLI counts it as zero_amplitude \
             in trials.csv's warnings"
                .to_string(),
        ),
        Some(a) if fitted && a.is_infinite() => out.push(
            "the fitted amplitude overflowed to inf (values of magnitude near 1e146 or more), so the sd is inf; \
             rescale the values"
                .to_string(),
        ),
        _ => {}
    }
    if !value.is_finite() {
        out.push(format!(
            "the estimate is not finite ({value}); the CLI counts it in trials.csv's warnings"
        ));
    }
    out
}

/// A `serde_json` value as the Python object `json.loads` gives.
pub fn json_to_python<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.getattr("loads")?.call1((value.to_string(),))
}

/// ``(Î, sd)``: the estimate of ``∫_H f dω`` from the values at the points and the sd the
/// estimator states (NaN where it states none: MC with one point) — the numbers of a
/// ``trials.csv`` row, bit for bit.
///
/// - ``"mc"``: ``(1/N) Σ f/p`` with ``p`` the ``density`` the points were drawn from
///   (``"uniform"``, default, or ``"cosine"``); sd ``s/√N`` (Student-t, N − 1 dof).
/// - ``"bmc"``, ``"bmcp"`` (``prior`` = its constant c, required), ``"bsq"`` (N ≥ 2): with the
///   weights and factor of ``weights``, a :class:`Rule` on these very points (its ``points``);
///   ``None`` builds the default model's rule (a factorisation per call: keep a Rule instead).
///   ``scale`` is the amplitude of the sd: ``"ml"`` (default; Student-t with N, for bsq N − 1,
///   dof), ``"unit"`` or ``"loo"`` (math.md §7). A fitted rule chooses its model for these
///   values, as the runner does.
///
/// What ``trials.csv``'s ``warnings`` column counts is a ``RuntimeWarning`` here: zero evidence
/// (a fitted amplitude of exactly 0, e.g. all values 0 for ``"bmc"``: sd 0), an amplitude
/// that overflowed to ∞ (values near 1e146 or larger: sd ∞), an estimate that is not finite.
///
/// The call costs about 0.5 µs besides the estimate itself at N = 64 (docs/python.md).
#[pyfunction]
#[pyo3(signature = (method, points, values, *, weights=None, prior=None, scale=None, density=None))]
#[allow(clippy::too_many_arguments)]
pub fn estimate<'py>(
    py: Python<'py>,
    method: Text,
    points: &Bound<'py, PyAny>,
    values: &Bound<'py, PyAny>,
    weights: Option<&Bound<'py, PyAny>>,
    prior: Option<Number>,
    scale: Option<Text>,
    density: Option<Text>,
) -> PyResult<(f64, f64)> {
    let method = method_arg(method.get("method")?)?;
    let prior = args::number_opt(prior.as_ref(), "prior")?;
    let scale = args::text_opt(scale.as_ref(), "scale")?;
    let density = args::text_opt(density.as_ref(), "density")?;
    if !method.needs_weights() {
        for (name, given) in [
            ("weights", weights.is_some()),
            ("scale", scale.is_some()),
            ("prior", prior.is_some()),
        ] {
            if given {
                return Err(value_error(format!(
                    "{name}: not used by method \"mc\" (plain Monte Carlo: the mean of f/p)"
                )));
            }
        }
        let density = match density.unwrap_or("uniform") {
            "uniform" => Density::Uniform,
            "cosine" => Density::Cosine,
            other => {
                return Err(value_error(format!(
                    "density: unknown density {other:?}; expected \"uniform\" or \"cosine\""
                )));
            }
        };
        let points = arrays::points(points, "points")?;
        let y = arrays::values(values, "values", points.len())?;
        // f/p at a point where the density is 0 is no term of the mean (it gave (nan, nan)).
        if let Some(i) = points.iter().position(|w| density.pdf(w) <= 0.0) {
            return Err(value_error(format!(
                "points: row {i} ({}, {}, {}) has density 0 under density {:?} (the cosine density \
                 is 0 on the horizon z = 0), so f/p is undefined there; MC needs points where the \
                 density is positive",
                points[i].x,
                points[i].y,
                points[i].z,
                density.name()
            )));
        }
        let rule = workbench::bq::rule::Rule {
            density,
            points: &points,
            weights: None,
            inverse_diagonal: None,
        };
        let e = rule.estimate(method, Values { y: &y, solved: None }, 0.0, Scale::Unit);
        return Ok((e.value, e.uncertainty.map_or(f64::NAN, |u| u.sd)));
    }
    if let Some(d) = density {
        return Err(value_error(format!(
            "density: {d:?} is not used by method {:?} (BMC weights hold for points from any density)",
            method.name()
        )));
    }
    match weights {
        Some(w) => {
            let rule = w.cast::<Rule>().map_err(|_| {
                value_error(format!(
                    "weights: must be a workbench.Rule (its weights with the factor the posterior sd \
                     needs) or None, got {}",
                    w.get_type().name().map_or("?".into(), |n| n.to_string())
                ))
            })?;
            let rule = rule.get();
            same_points(points, &rule.points)?;
            let y = arrays::values(values, "values", rule.points.len())?;
            rule.estimate_checked(py, method, &y, prior, scale)
        }
        None => {
            let p = arrays::points(points, "points")?;
            workbench::bq::rule::check_point_count(p.len(), "points").map_err(|e| value_error(e.0))?;
            let y = arrays::values(values, "values", p.len())?;
            check_min_points(method, p.len(), "points")?;
            let resolved = ModelArgs::new(None, None, None, None)?.resolve(py)?;
            let rule = Rule::build(py, "points", p, Design::Iid(Density::Uniform), false, resolved, 0)?;
            rule.estimate_checked(py, method, &y, prior, scale)
        }
    }
}

/// `points` must be the rule's own points, bit for bit (the weights hold for them only).
fn same_points(points: &Bound<'_, PyAny>, own: &[Vec3]) -> PyResult<()> {
    use numpy::{PyArray2, PyArrayMethods};
    let differ = |what: String| {
        value_error(format!(
            "points: {what}; with weights=rule, pass the rule's own points (rule.points)"
        ))
    };
    let Ok(array) = points.cast::<PyArray2<f64>>() else {
        // Checked as any points argument, for the message.
        arrays::points(points, "points")?;
        return Err(differ("are not the rule's points".into()));
    };
    let view = array.readonly();
    let view = view.as_array();
    if view.nrows() != own.len() || view.ncols() != 3 {
        arrays::points(points, "points")?;
        return Err(differ(format!(
            "{} points for a rule of {}",
            view.nrows(),
            own.len()
        )));
    }
    for (i, (row, p)) in view.rows().into_iter().zip(own).enumerate() {
        if row[0].to_bits() != p.x.to_bits()
            || row[1].to_bits() != p.y.to_bits()
            || row[2].to_bits() != p.z.to_bits()
        {
            return Err(differ(format!("row {i} is not the rule's point {i}")));
        }
    }
    Ok(())
}

/// `_estimate_core_seconds(rule, values, method="bmc", scale=None, iterations=10000) -> float`:
/// the mean seconds of the estimate's own work (the model's `Q⁻¹Y`, the amplitude, `Î` and its
/// sd) without the Python call around it, for the overhead benchmark (`python/bench/`).
#[pyfunction]
#[pyo3(name = "_estimate_core_seconds", signature = (rule, values, method=Text::of("bmc"), scale=None, iterations=10000),
    text_signature = "(rule, values, method='bmc', scale=None, iterations=10000)")]
pub fn estimate_core_seconds(
    rule: &Bound<'_, Rule>,
    values: &Bound<'_, PyAny>,
    method: Text,
    scale: Option<Text>,
    iterations: usize,
) -> PyResult<f64> {
    let rule = rule.get();
    let method = weighted_method_arg(method.get("method")?)?;
    let scale = args::text_opt(scale.as_ref(), "scale")?;
    let y = arrays::values(values, "values", rule.points.len())?;
    let scale = scale.map_or(Ok(Scale::DEFAULT), scale_arg)?;
    let start = std::time::Instant::now();
    let mut sink = 0.0;
    for _ in 0..iterations.max(1) {
        let (v, sd) = rule.estimate_values(method, std::hint::black_box(&y), 0.0, scale)?;
        sink += v + sd;
    }
    std::hint::black_box(sink);
    Ok(start.elapsed().as_secs_f64() / iterations.max(1) as f64)
}
