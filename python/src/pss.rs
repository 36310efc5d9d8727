//! `pss_rules(n, sets, order, seed)`: `bq-pss`'s point sets in primary sample space with their
//! weights, from the library (`workbench::bq::estimator::bq_pss::point_sets`, math.md §11 (a)),
//! for a renderer that picks one set per camera sample (the Mitsuba integrator, issue 41).

use numpy::IntoPyArray;
use numpy::ndarray::{Array2, Array3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use workbench::bq::estimator::bq_pss::{PssWeights, point_sets};
use workbench::bq::factor::SpdWorkspace;
use workbench::bq::kernel::primary::SobolevOrder;
use workbench::sampling::primary::Sampler;

use crate::args::Whole;
use crate::value_error;

/// ``bq-pss``'s ``sets`` point sets of ``n`` Owen-scrambled Sobol points in ``[0, 1)²`` (a fresh
/// scramble per set from ``seed``) with the product Sobolev kernel of ``order`` (1 or 2; math.md
/// §11 (a)), whose kernel mean is 1, so the weights depend on the points only. Returns
/// ``{"points": (sets, n, 2), "bmc_weights": (sets, n) = Q⁻¹1, "bsq_weights": (sets, n) (summing
/// to 1), "bmc_var1": (sets,) = 1 − 1ᵀQ⁻¹1, "bsq_var1": (sets,) = (1 − 1ᵀQ⁻¹1)/1ᵀQ⁻¹1,
/// "q_inverse": (sets, n, n), "jitter": (sets,)}``, every number the library's (``Q⁻¹`` by its
/// Cholesky solves, with the jitter its ladder added).
#[pyfunction]
#[pyo3(signature = (n, sets, order, seed=Whole::of(0)), text_signature = "(n, sets, order, seed=0)")]
pub fn pss_rules<'py>(
    py: Python<'py>,
    n: Whole,
    sets: Whole,
    order: Whole,
    seed: Whole,
) -> PyResult<Bound<'py, PyDict>> {
    let n = n.get("n")? as usize;
    let sets = sets.get("sets")? as usize;
    let seed = seed.get("seed")?;
    let order_number = order.get("order")?;
    let order = SobolevOrder::from_number(order_number).ok_or_else(|| {
        value_error(format!(
            "order: unknown kernel order {order_number}; expected 1 or 2"
        ))
    })?;
    if n < 2 {
        return Err(value_error(format!("n: must be at least 2, got {n}")));
    }
    if sets < 1 {
        return Err(value_error(format!("sets: must be at least 1, got {sets}")));
    }
    let bytes = (sets as u64)
        .saturating_mul(n as u64)
        .saturating_mul(n as u64)
        .saturating_mul(16);
    workbench::util::memory::check(&format!("{sets} bq-pss sets of n = {n} points"), bytes)
        .map_err(value_error)?;
    let rules = py
        .detach(|| point_sets(seed, Sampler::Sobol, sets, n, order))
        .map_err(|e| value_error(format!("n: {e}")))?;
    let mut points = Array3::<f64>::zeros((sets, n, 2));
    let mut bmc = Array2::<f64>::zeros((sets, n));
    let mut bsq = Array2::<f64>::zeros((sets, n));
    let mut q_inverse = Array3::<f64>::zeros((sets, n, n));
    let mut bmc_var1 = Vec::with_capacity(sets);
    let mut bsq_var1 = Vec::with_capacity(sets);
    let mut jitter = Vec::with_capacity(sets);
    for (k, rule) in rules.iter().enumerate() {
        for (i, p) in rule.points.iter().enumerate() {
            points[[k, i, 0]] = p[0];
            points[[k, i, 1]] = p[1];
        }
        for (i, w) in rule.weights(PssWeights::Bmc).into_iter().enumerate() {
            bmc[[k, i]] = w;
        }
        for (i, w) in rule.weights(PssWeights::Bsq).into_iter().enumerate() {
            bsq[[k, i]] = w;
        }
        bmc_var1.push(rule.unit_variance(PssWeights::Bmc).unwrap_or(f64::NAN));
        bsq_var1.push(rule.unit_variance(PssWeights::Bsq).unwrap_or(f64::NAN));
        jitter.push(rule.jitter);
        // Q⁻¹ by the library's Cholesky solves of the same Q (the same jitter ladder, so the
        // same jitter as the set's weights).
        let mut ws = SpdWorkspace::new();
        ws.factor_entries(n, |i, j| order.eval(&rule.points[i], &rule.points[j]))
            .map_err(|e| value_error(format!("n: {e}")))?;
        let mut eye = vec![0.0; n * n];
        for i in 0..n {
            eye[i * n + i] = 1.0;
        }
        ws.keep_factor().solve_columns_in_place(&mut eye, n);
        for i in 0..n {
            for j in 0..n {
                q_inverse[[k, i, j]] = eye[j * n + i];
            }
        }
    }
    let out = PyDict::new(py);
    out.set_item("points", points.into_pyarray(py))?;
    out.set_item("bmc_weights", bmc.into_pyarray(py))?;
    out.set_item("bsq_weights", bsq.into_pyarray(py))?;
    out.set_item("bmc_var1", crate::arrays::vector(py, bmc_var1))?;
    out.set_item("bsq_var1", crate::arrays::vector(py, bsq_var1))?;
    out.set_item("q_inverse", q_inverse.into_pyarray(py))?;
    out.set_item("jitter", crate::arrays::vector(py, jitter))?;
    Ok(out)
}
