"""Issue 30: no crash and no silent wrong number from the Python door — every reproduction of the
issue as a regression test (each failed before its fix)."""

import os

import numpy as np
import pytest

import workbench as wb

P, _ = wb.rule(64, seed=3)
Y = P[:, 2] ** 3


def raises(match, f, *args, **kwargs):
    with pytest.raises(ValueError, match=match) as e:
        f(*args, **kwargs)
    return str(e.value)


# --- item 3: numbers that never lie about certainty -------------------------------------------


@pytest.mark.parametrize("scale", ["ml", "loo"])
def test_an_overflowing_amplitude_states_an_infinite_sd_not_zero(scale):
    # rᵀQ⁻¹r overflowed to ∞ − ∞ = NaN, and max(0) made it 0: (1.6e155, 0.0), certainty. Now the
    # sd is c times that of the values / c (the sum is scaled by a power of two), or +inf where
    # the amplitude itself overflows — never 0.
    rule = wb.Rule(P)
    for values, base, factor in [(Y * 1e155, Y, 1e155), (np.full(64, 1e300), np.ones(64), 1e300)]:
        value, sd = wb.estimate("bmc", P, values, weights=rule, scale=scale)
        base_value, base_sd = rule.estimate(base, scale=scale)
        assert value == pytest.approx(factor * base_value, rel=1e-12)
        assert sd > 0
        assert sd == np.inf or sd == pytest.approx(factor * base_sd, rel=1e-9), (sd, factor * base_sd)
        assert rule.estimate(values, scale=scale) == (value, sd)


@pytest.mark.parametrize("factor", [1e150, 1e155, 1e-150, 1e-160])
def test_the_fitted_choice_does_not_depend_on_the_values_scale(factor):
    # Every ℓ was −∞ on huge values (λ̂ overflowed), and the first grid model won.
    base = wb.fit(P, Y)
    scaled = wb.fit(P, Y * factor)
    assert scaled["chosen"] == base["chosen"] != 0
    ells = np.array([g["log_marginal_likelihood"] for g in base["grid"]])
    scaled_ells = np.array([g["log_marginal_likelihood"] for g in scaled["grid"]])
    # Every ℓ shifts by the same −N log(factor).
    np.testing.assert_allclose(scaled_ells - ells, -64 * np.log(factor), rtol=1e-9)
    rule = wb.Rule(P, kernel="fitted")
    assert rule.diagnostics(values=Y * factor)["chosen"] == base["chosen"]


def test_the_bmcp_prior_is_bounded_by_the_models_scale_as_in_the_cli():
    # A kernel of scale 1e-100 takes constants up to 1e100 · 1e-100 = 1 (the CLI's bound); Python
    # accepted up to 1e100 whatever the model.
    tiny = wb.Rule(P, kernel={"type": "se", "sigma": 1e-100}, noise=0.0)
    raises(r"^prior: .* = 1(\.\d+)?e0 for this model .*got 1e1$", tiny.estimate, Y, "bmcp", prior=10.0)
    tiny.estimate(Y, "bmcp", prior=0.5)


def test_a_cosine_density_point_on_the_horizon_is_refused_by_name():
    q = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    raises(r"^points: row 1 \(1, 0, 0\) has density 0 under density \"cosine\"", wb.estimate, "mc", q, np.ones(3), density="cosine")
    # Uniform density: z = 0 is a point like any other.
    value, sd = wb.estimate("mc", q, np.ones(3))
    assert np.isfinite(value) and np.isfinite(sd)


# --- item 1: one memory estimate and one guard --------------------------------------------------


def test_q_inverse_beyond_the_budget_is_a_value_error_naming_n(monkeypatch):
    # wb.Rule(n=65536, design="rings").q_inverse() allocated 32 GiB unchecked and aborted the
    # interpreter: the ring solver's own factor is small, the n × n matrix is not.
    monkeypatch.setenv("WORKBENCH_MEMORY", "4MiB")
    rule = wb.Rule(n=1024, design="rings")
    message = raises(r"^n: q_inverse\(\) of a rule of 1024 points \(a 1024 × 1024 matrix\) needs 8.0 MiB "
                     r"\(8388608 bytes\) of memory, more than the budget of 4.0 MiB \(WORKBENCH_MEMORY=4MiB\)",
                     rule.q_inverse)
    assert "set WORKBENCH_MEMORY" in message
    monkeypatch.setenv("WORKBENCH_MEMORY", "16MiB")
    assert rule.q_inverse().shape == (1024, 1024)


def test_the_issues_q_inverse_at_65536_ring_points_is_refused_by_the_default_budget():
    rule = wb.Rule(n=65536, design="rings")
    # 32 GiB: refused unless the machine has 43 GiB or more.
    with pytest.raises(ValueError, match=r"^n: q_inverse\(\) of a rule of 65536 points .* needs 32.0 GiB"):
        rule.q_inverse()


def test_a_fitted_rule_states_what_its_grid_keeps(monkeypatch):
    # wb.Rule(n=4096, kernel=fitted 8×8) kept 64 factors of 128 MiB and, under a memory limit,
    # raised a Rust panic across the FFI. Now it streams its grid (3 factors whatever the grid's
    # size); what even that needs is refused by name.
    monkeypatch.setenv("WORKBENCH_MEMORY", "256MiB")
    grid = {"s": [1.2, 1.4, 1.6, 1.8, 2.25, 2.75, 3.25, 3.75], "noise": [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]}
    raises(r"^n: a rule of 4096 points keeping 2 factors \(its 64 grid models streamed: the best so far and the one "
           r"being scored\) needs 384.0 MiB \(402653184 bytes\) of memory, more than the budget of 256.0 MiB",
           wb.Rule, n=4096, kernel={"type": "fitted", "grid": grid})


def _everything(rule, values):
    """Every number a fitted rule gives on values, for bit-for-bit comparison."""
    out = []
    for y in values:
        for scale in ["unit", "ml", "loo"]:
            out.append(rule.estimate(y, "bmc", scale=scale))
            out.append(rule.estimate(y, "bsq", scale=scale))
            out.append(rule.estimate(y, "bmcp", prior=0.25, scale=scale))
        d = rule.diagnostics(values=y)
        out.append((d["chosen"], tuple(d["log_marginal_likelihoods"])))
        out.append(tuple(rule.weights(values=y)))
        out.append(tuple(rule.weights("bsq", values=y)))
    return out


@pytest.mark.parametrize("kwargs", [{"n": 512, "design": "sobol", "seed": 4}, {"n": 480, "design": "rings", "seed": 1}])
def test_a_fitted_rule_over_its_budget_streams_its_grid_with_the_same_numbers(monkeypatch, kwargs):
    # One dense factor of 512 points is 2 MiB. Caching all 8 grid models' factors (and the
    # workspace) takes 18 MiB: refused under 12 MiB before ("keeping 8 factors ... needs 18.0 MiB").
    # Now the rule streams (3 factors, 6 MiB) and every number is the cached rule's, bit for bit.
    n = kwargs["n"]
    points = wb.Rule(**kwargs).points
    values = [points[:, 2] ** 3, np.exp(points[:, 0]) + points[:, 1] ** 2, (points[:, 2] > 0.5) * 1.0]
    monkeypatch.delenv("WORKBENCH_MEMORY", raising=False)
    cached = [wb.Rule(**kwargs, kernel="fitted"), wb.Rule(points, kernel="fitted")]
    # A ring set's factor is 16·N·J bytes (150 KiB here; 9 of them 1.35 MiB, 3 of them 450 KiB);
    # the same points given are a dense solve, 2 MiB a factor.
    monkeypatch.setenv("WORKBENCH_MEMORY", "1MiB" if kwargs["design"] == "rings" else "12MiB")
    streamed = [wb.Rule(**kwargs, kernel="fitted")]
    monkeypatch.setenv("WORKBENCH_MEMORY", "12MiB")
    streamed.append(wb.Rule(points, kernel="fitted"))
    for c, s in zip(cached, streamed):
        assert _everything(s, values) == _everything(c, values)
    chosen = {c.diagnostics(values=y)["chosen"] for c in cached for y in values}
    assert len(chosen) > 1, "the values choose different models"
    # Less than the 3 factors of the stream: refused by name.
    monkeypatch.setenv("WORKBENCH_MEMORY", "5MiB")
    raises(rf"^points: a rule of {n} points keeping 2 factors \(its 8 grid models streamed", wb.Rule, points, kernel="fitted")


def test_every_door_of_the_package_uses_the_guard(monkeypatch):
    monkeypatch.setenv("WORKBENCH_MEMORY", "1MiB")
    p = wb.trial_points(1, "uniform", 512, 0)
    y = p[:, 2] ** 3
    raises(r"^n: a weight set of 512 points needs 2.0 MiB .* budget of 1.0 MiB", wb.rule, 512)
    raises(r"^points: a weight set of 512 points needs 2.0 MiB", wb.weights, p)
    raises(r"^points: a weight set of 512 points needs 2.0 MiB", wb.fit, p, y)
    raises(r"^points: a rule of 512 points keeping 1 factor", wb.Rule, p)
    raises(r"^points: a rule of 512 points keeping 1 factor", wb.estimate, "bmc", p, y)
    spec = {"name": "m", "integrands": ["cos3"], "estimators": [{"label": "BMC", "method": "bmc"}],
            "samples": [512], "trials": 2, "seed": 1}
    raises(r"^estimators\[0\] \(\"BMC\"\): a weight set of N = 512 per worker thread \(2.0 MiB\) on 1 thread needs 2.0 MiB",
           wb.run, spec, threads=1)
    monkeypatch.setenv("WORKBENCH_MEMORY", "lots")
    raises(r'^WORKBENCH_MEMORY: "lots" is not an amount of memory', wb.rule, 16)


# --- item 2: bounded, typed reads -------------------------------------------------------------


def test_a_map_that_is_a_device_or_a_fifo_is_refused_by_type_before_reading(tmp_path):
    # wb.Integrand({..., "env": "/dev/zero"}) read the map whole: 22.7 GB before the OOM killer;
    # a FIFO as a map hung.
    pixel = {"type": "pixel", "pixel": [128, 200], "channel": "g"}
    raises(r"^spec: env: /dev/zero: is a character device, not a regular file; environment maps are read "
           r"from regular files only$", wb.Integrand, {**pixel, "env": "/dev/zero"})
    fifo = tmp_path / "map.hdr"
    os.mkfifo(fifo)
    raises(rf"^spec: env: {fifo}: is a named pipe \(FIFO\), not a regular file", wb.Integrand, {**pixel, "env": str(fifo)})


def test_an_experiment_path_that_is_a_device_or_a_fifo_is_refused_by_type(tmp_path):
    # run(path) on a FIFO hung.
    fifo = tmp_path / "spec.json"
    os.mkfifo(fifo)
    raises(rf"^{fifo}: is a named pipe \(FIFO\), not a regular file; spec files are read from regular files only$",
           wb.run, str(fifo))
    raises(r"^/dev/zero: is a character device, not a regular file", wb.run, "/dev/zero")


# --- item 4: Sobolev s near 2 or 3 --------------------------------------------------------------


@pytest.mark.parametrize("s,limit", [(2.0000000000000004, 2), (2.000000000001, 2), (3.000000000001, 3)])
def test_a_sobolev_s_whose_kernel_lost_its_scale_is_refused_with_reason_and_remedy(s, limit):
    # rule --s 2.0000000000000004 --noise 1e-8 gave Σw = 0.00016 (2π expected), silently.
    message = raises(rf"^kernel: sobolev kernel: s = {s!r} is too close to {limit}: the kernel's scale k\(x,x\) = ",
                     wb.rule, 64, kernel={"type": "sobolev", "s": s}, noise=1e-8)
    assert "relative rounding error" in message and f"use s − {limit} ≥ " in message
    raises(r"^grid.s: sobolev kernel: s = .* is too close", wb.fit, P, Y, grid={"s": [s]})


def test_a_sobolev_s_near_its_limit_but_clear_of_it_keeps_its_weights():
    for s in [2.0 + 1e-6, 2.01, 3.0 + 1e-6, 1.999999, 2.999999]:
        _, w = wb.rule(64, kernel={"type": "sobolev", "s": s}, noise=1e-8)
        assert abs(w.sum() - 2 * np.pi) < 0.05, (s, w.sum())


# --- item 7: argument errors are ValueErrors naming the argument --------------------------------


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: wb.rule(2.5), r"^n: must be a whole number from 0 to 18446744073709551615, got 2.5 \(a Python float\)$"),
        (lambda: wb.rule("8"), r"^n: must be a whole number .* got '8' \(a Python str\)$"),
        (lambda: wb.rule(True), r"^n: must be a whole number .* got True \(a Python bool\)$"),
        (lambda: wb.Rule(n=2**127), r"^n: must be a whole number .* got 170141183460… \(39 digits\)$"),
        (lambda: wb.rule(16, seed=-2**200), r"^seed: must be a whole number .* got -16069380442… \(61 digits\)$"),
        (lambda: wb.rule(16, design=3), r"^design: must be a string, got 3 \(a Python int\)$"),
        (lambda: wb.rule(16, method=None), r"^method: must be a string, got None \(a Python NoneType\)$"),
        (lambda: wb.rule(16, noise="small"), r"^noise: must be a number, got 'small' \(a Python str\)$"),
        (lambda: wb.rule(16, noise=10**400), r"^noise: must be a number, got 100000000000… \(401 digits\)$"),
        (lambda: wb.rule(16, kernel_mean=1), r"^kernel_mean: must be a string, got 1"),
        (lambda: wb.rule(16, kernel_mean="mc", kernel_mean_samples=1.5), r"^kernel_mean_samples: must be a whole number"),
        (lambda: wb.weights(P, method=b"bmc"), r"^method: must be a string, got b'bmc'"),
        (lambda: wb.kernel_means(P, seed="0"), r"^seed: must be a whole number"),
        (lambda: wb.fit(P, Y, method=0), r"^method: must be a string"),
        (lambda: wb.estimate(1, P, Y), r"^method: must be a string, got 1"),
        (lambda: wb.estimate("bmcp", P, Y, weights=wb.Rule(P), prior="0.1"), r"^prior: must be a number, got '0.1'"),
        (lambda: wb.estimate("bmc", P, Y, weights=wb.Rule(P), scale=1), r"^scale: must be a string"),
        (lambda: wb.estimate("mc", P, Y, density=0), r"^density: must be a string"),
        (lambda: wb.Rule(P).estimate(Y, method=1), r"^method: must be a string"),
        (lambda: wb.Rule(P).estimate(Y, "bmcp", prior=[0.1]), r"^prior: must be a number, got \[0.1\] \(a Python list\)"),
        (lambda: wb.Rule(P).weights(method=1), r"^method: must be a string"),
        (lambda: wb.Rule(P).diagnostics(method=1), r"^method: must be a string"),
        (lambda: wb.Rule(n=16, design=1), r"^design: must be a string"),
        (lambda: wb.Rule(n=16, noise=[1]), r"^noise: must be a number"),
        (lambda: wb.trial_points("1", "uniform", 4, 0), r"^seed: must be a whole number"),
        (lambda: wb.trial_points(1, 1, 4, 0), r"^design: must be a string"),
        (lambda: wb.trial_points(1, "uniform", 4, 2**130), r"^trial: must be a whole number .* \(40 digits\)$"),
        (lambda: wb.run({}, threads=2.0), r"^threads: must be a whole number"),
        (lambda: wb.fit(P, Y, grid=[]), r"^grid: invalid type: sequence, expected an object"),
        (lambda: wb.rule(16, kernel={"type": "fitted", "grid": []}, values=Y[:16].copy()),
         r'^kernel: invalid type: sequence, expected an object with a list "s" and/or a list "noise"'),
        (lambda: wb.rule(16, kernel={"type": "sobolev", "s": 1e308}), r"^kernel: sobolev kernel: s must be in .*, got 1e308$"),
        (lambda: wb.rule(16, noise=-1e300), r"^noise: noise must be finite and >= 0, got -1e300$"),
    ],
)
def test_a_wrong_type_or_size_is_a_value_error_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("scale", ["ml", "loo"])
def test_zero_evidence_and_overflow_warn_as_the_cli_counts_them(scale):
    """Issue 32: what trials.csv's warnings column counts is a RuntimeWarning — all-zero values
    give a fitted amplitude of 0 (zero evidence, sd 0); values near 1e300 overflow it to inf.
    Ordinary values and the unit amplitude (nothing fitted) warn nothing."""
    import warnings

    rule = wb.Rule(P)
    with pytest.warns(RuntimeWarning, match="zero evidence: the fitted amplitude is 0"):
        value, sd = rule.estimate(np.zeros(64), scale=scale)
    assert (value, sd) == (0.0, 0.0)
    with pytest.warns(RuntimeWarning, match="zero evidence"):
        wb.estimate("bmc", P, np.zeros(64), weights=rule, scale=scale)
    with pytest.warns(RuntimeWarning, match="overflowed to inf"):
        _, sd = rule.estimate(np.full(64, 1e300), scale=scale)
    assert sd == np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rule.estimate(Y, scale=scale)
        rule.estimate(np.zeros(64), scale="unit")


def test_a_run_warns_once_for_rows_with_warnings():
    """A callable that returns zeros: the run's
    rows count zero evidence in the warnings column, and run() says so once."""
    spec = {"name": "z", "integrands": [{"type": "python", "name": "zero", "truth": 0.0}],
            "estimators": [{"label": "BMC", "method": "bmc"}], "samples": [8], "trials": 3, "seed": 1}
    with pytest.warns(RuntimeWarning, match=r"3 of 3 rows have warnings"):
        rows = wb.run(spec, integrands={"zero": lambda p: np.zeros(len(p))})
    assert list(rows["warnings"]) == [1, 1, 1]
