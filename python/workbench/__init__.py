"""workbench for Python: Monte Carlo and Bayesian Monte Carlo (Bayesian quadrature) over the
hemisphere, with the numbers of the ``workbench`` command line to the bit.

Quadrature rules (``rule``, ``Rule``), BMC / BMCP / Bayes–Sard weights for given points
(``weights``), kernel means (``kernel_means``, ``prior_variance``), estimates with their stated
sd (``estimate``, ``Rule.estimate``), the fitted model of a kernel grid (``fit``), the integrand
families with their certified truths (``Integrand``) and whole experiments (``run``, whose result
is the rows of ``trials.csv`` as columns: ``pandas.DataFrame(run(spec))``; ``tables=True``
adds the summary and stopping tables), and ``to_world`` (a rule's local points at a world normal).

Directions are float64 numpy arrays of shape ``(n, 3)`` in the local frame (normal ``+z``), unit
vectors (``|‖p‖ − 1| ≤ 1e-9``) with ``z ≥ 0``. Bad input raises ``ValueError`` with the
library's one-line message, naming the argument and the value. See ``docs/python.md``.
"""

from ._workbench import (
    DESIGNS,
    METHODS,
    Integrand,
    Rule,
    __version__,
    check_memory,
    estimate,
    fit,
    kernel_means,
    prior_variance,
    pss_rules,
    rule,
    run,
    to_world,
    trial_points,
    weights,
)

__all__ = [
    "DESIGNS",
    "METHODS",
    "Integrand",
    "Rule",
    "__version__",
    "check_memory",
    "estimate",
    "fit",
    "kernel_means",
    "prior_variance",
    "pss_rules",
    "rule",
    "run",
    "to_world",
    "trial_points",
    "weights",
]
