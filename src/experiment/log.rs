//! How an experiment reads its unit logs ([`crate::job::unit_log`]): a unit's rows are every
//! (integrand, estimator) of the plan in the plan's order.

use super::plan::Plan;
use crate::job::LogSet;

/// Rows per unit: one per (integrand, estimator).
pub fn rows_per_unit(plan: &Plan) -> usize {
    plan.integrands.len() * plan.estimators.len()
}

/// Calls `f(unit, integrand, estimator, line)` for every row of every unit of `logs` in unit
/// order, the line without its digest. Fails if a log ends early or runs on.
pub fn for_each_row(
    plan: &Plan,
    logs: &LogSet,
    f: &mut dyn FnMut(usize, usize, usize, &str) -> crate::Result<()>,
) -> crate::Result<()> {
    let ne = plan.estimators.len();
    logs.for_each_line(
        plan.samples.len() * plan.trials,
        rows_per_unit(plan),
        &mut |u, k, line| f(u, k / ne, k % ne, line.text),
    )
}
