"""Rules and weights against ``workbench rule``'s CSV and summary, bit for bit."""

import json
import math

import numpy as np
import pytest

import workbench as wb
from conftest import read_rule, same_bits, write_points, write_values

# (CLI flags, the same rule's Python arguments)
CASES = [
    (["--n", "64", "--seed", "7"], dict(n=64, seed=7)),
    (
        ["--n", "40", "--seed", "3", "--design", "sobol", "--kernel", "se", "--length", "0.3"],
        dict(n=40, seed=3, design="sobol", kernel={"type": "se", "length": 0.3}),
    ),
    (["--n", "64", "--seed", "11", "--design", "rings"], dict(n=64, seed=11, design="rings")),
    (
        ["--n", "30", "--seed", "5", "--design", "fibonacci", "--method", "bsq"],
        dict(n=30, seed=5, design="fibonacci", method="bsq"),
    ),
    (
        ["--n", "50", "--seed", "9", "--design", "stratified", "--s", "2.75", "--noise", "1e-8"],
        dict(n=50, seed=9, design="stratified", kernel={"type": "sobolev", "s": 2.75}, noise=1e-8),
    ),
    (
        ["--n", "24", "--seed", "4", "--kernel-mean", "mc", "--kernel-mean-samples", "500"],
        dict(n=24, seed=4, kernel_mean="mc", kernel_mean_samples=500),
    ),
    (
        ["--n", "24", "--seed", "4", "--design", "cosine", "--kernel-mean", "mc-shared"],
        dict(n=24, seed=4, design="cosine", kernel_mean="mc-shared"),
    ),
]


@pytest.mark.filterwarnings("ignore:the posterior variance")
@pytest.mark.parametrize("flags,kwargs", CASES, ids=[" ".join(c[0]) for c in CASES])
def test_rule_is_the_cli_rule(cli, tmp_path, flags, kwargs):
    cli("rule", *flags, "--out", "rule.csv")
    want_points, want_weights = read_rule(tmp_path / "rule.csv")
    points, weights = wb.rule(**kwargs)
    assert points.dtype == np.float64 and points.shape == want_points.shape
    assert same_bits(points, want_points)
    assert same_bits(weights, want_weights)
    # The Rule class draws and weights the same set.
    kwargs = dict(kwargs)
    method = kwargs.pop("method", "bmc")
    r = wb.Rule(**kwargs)
    assert same_bits(r.points, want_points)
    assert same_bits(r.weights(method), want_weights)


@pytest.mark.filterwarnings("ignore:the posterior variance")
@pytest.mark.parametrize("flags,kwargs", CASES[:2] + CASES[3:6], ids=[" ".join(c[0]) for c in CASES[:2] + CASES[3:6]])
def test_weights_of_given_points_are_the_cli_rule_of_a_points_file(cli, tmp_path, flags, kwargs):
    n = kwargs.get("n", 64)
    points = wb.trial_points(123, "uniform", n, 0)
    write_points(tmp_path / "p.csv", points)
    model_flags = [f for f in flags if f not in ("--n", "--design")]
    # Drop the values of the flags removed above.
    drop = {flags[i + 1] for i, f in enumerate(flags) if f in ("--n", "--design")}
    model_flags = [f for f in model_flags if f not in drop]
    cli("rule", "--points", "p.csv", *model_flags, "--out", "rule.csv")
    want_points, want_weights = read_rule(tmp_path / "rule.csv")
    assert same_bits(points, want_points)
    args = {k: v for k, v in kwargs.items() if k not in ("n", "design")}
    assert same_bits(wb.weights(points, **args), want_weights)
    method = args.pop("method", "bmc")
    assert same_bits(wb.Rule(points, **args).weights(method), want_weights)


@pytest.mark.parametrize("method", ["bmc", "bsq"])
def test_a_fitted_rule_is_the_cli_choice(cli, tmp_path, method):
    points, _ = wb.rule(48, seed=2, design="sobol")
    f = wb.Integrand({"type": "lobe", "axis": [0.3, 0.1, 1.0], "exponent": 6})
    y = f(points)
    write_values(tmp_path / "v.csv", y)
    grid = ["--grid-s", "1.2,2.75,3.75", "--grid-noise", "1e-2,1e-8"]
    cli(
        "rule", "--n", "48", "--seed", "2", "--design", "sobol", "--kernel", "fitted", "--values", "v.csv",
        *grid, "--method", method, "--out", "rule.csv", "--summary", "rule.json",
    )
    _, want = read_rule(tmp_path / "rule.csv")
    summary = json.loads((tmp_path / "rule.json").read_text())
    kernel = {"type": "fitted", "grid": {"s": [1.2, 2.75, 3.75], "noise": [1e-2, 1e-8]}}
    _, got = wb.rule(48, seed=2, design="sobol", kernel=kernel, values=y, method=method)
    assert same_bits(got, want)
    r = wb.Rule(n=48, seed=2, design="sobol", kernel=kernel)
    assert r.fitted
    assert same_bits(r.weights(method, values=y), want)
    d = r.diagnostics(method, values=y)
    assert d["chosen"] == summary["fitted"]["chosen"]
    assert same_bits(d["log_marginal_likelihoods"], [g["log_marginal_likelihood"] for g in summary["fitted"]["grid"]])
    # fit(): the same choice on the points as given (a dense solve, as `rule --points`).
    write_points(tmp_path / "p.csv", points)
    cli("rule", "--points", "p.csv", "--kernel", "fitted", "--values", "v.csv", *grid, "--method", method,
        "--out", "given.csv", "--summary", "given.json")
    _, want_given = read_rule(tmp_path / "given.csv")
    given = json.loads((tmp_path / "given.json").read_text())
    fitted = wb.fit(points, y, method=method, grid=kernel["grid"])
    assert fitted["chosen"] == given["fitted"]["chosen"]
    assert fitted["s"] == given["kernel"]["s"] and fitted["noise"] == given["noise"]
    assert same_bits(fitted["weights"], want_given)
    assert [(g["s"], g["noise"]) for g in fitted["grid"]] == [(g["s"], g["noise"]) for g in given["fitted"]["grid"]]
    assert same_bits([g["log_marginal_likelihood"] for g in fitted["grid"]],
                     [g["log_marginal_likelihood"] for g in given["fitted"]["grid"]])


def test_diagnostics_are_the_cli_summary(cli, tmp_path):
    cli("rule", "--n", "64", "--seed", "7", "--summary", "rule.json", "--out", "rule.csv")
    summary = json.loads((tmp_path / "rule.json").read_text())
    d = wb.Rule(n=64, seed=7).diagnostics()
    for key in ["n", "weight_sum", "negative_weights", "min_weight", "max_weight", "jitter",
                "condition_estimate", "prior_variance", "posterior_variance", "warnings"]:
        assert d[key] == summary[key], key
    assert wb.prior_variance() == summary["prior_variance"]


def test_kernel_means_depend_on_the_height_only_and_match_monte_carlo():
    points = wb.trial_points(5, "uniform", 16, 0)
    z = wb.kernel_means(points)
    phi = 1.234
    c, s = np.cos(phi), np.sin(phi)
    rotated = points @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    rotated /= np.linalg.norm(rotated, axis=1)[:, None]
    rotated[:, 2] = points[:, 2]
    assert np.allclose(wb.kernel_means(rotated), z, rtol=1e-12, atol=0)
    # MC kernel means with many shared directions scatter around the exact ones (seeded, so the
    # test is deterministic; the tolerance is several standard errors of the estimate).
    mc = wb.kernel_means(points, kernel_mean="mc-shared", kernel_mean_samples=200_000, seed=1)
    assert np.all(np.abs(mc - z) < 0.02 * np.abs(z))
    assert not same_bits(mc, z)


def test_numerical_warnings_are_python_warnings(cli):
    # The CLI prints this rule's warning on stderr; Python gets it as a RuntimeWarning.
    p = cli("rule", "--n", "24", "--seed", "4", "--kernel-mean", "mc", "--kernel-mean-samples", "500")
    assert "warning: the posterior variance" in p.stderr
    with pytest.warns(RuntimeWarning, match="the posterior variance V̂ − zᵀQ⁻¹z is negative"):
        wb.rule(24, seed=4, kernel_mean="mc", kernel_mean_samples=500)


def test_q_inverse_gives_the_ml_amplitude_of_the_estimate():
    r = wb.Rule(n=40, seed=3, design="sobol")
    q = r.q_inverse()
    assert q.shape == (40, 40) and np.allclose(q, q.T, rtol=0, atol=1e-9 * np.abs(q).max())
    y = wb.Integrand({"type": "gaussian", "axis": [1, 0, 1], "sharpness": 5})(r.points)
    value, sd = r.estimate(y, "bmc", scale="ml")
    var1 = r.diagnostics()["posterior_variance"]
    assert math.isclose(sd, math.sqrt(y @ q @ y / 40 * var1), rel_tol=1e-10)
    assert math.isclose(value, float(r.weights() @ y), rel_tol=1e-12)
    with pytest.raises(ValueError, match="^kernel: a fitted rule has one Q per grid model"):
        wb.Rule(n=8, kernel="fitted").q_inverse()
