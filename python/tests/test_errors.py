"""Bad input: a ValueError naming the argument and the value, never a panic across the FFI
(pyo3 would raise PanicException, which is not a ValueError, so these tests would fail), and the
CLI's one-line messages where the CLI has the same input."""

import json

import numpy as np
import pytest

import workbench as wb

POINTS, _ = wb.rule(16, seed=1)
Y = POINTS[:, 2] ** 3
RULE = wb.Rule(POINTS)


def raises(match, f, *args, **kwargs):
    with pytest.raises(ValueError, match=match) as e:
        f(*args, **kwargs)
    return str(e.value)


@pytest.mark.parametrize(
    "bad,match",
    [
        (POINTS.astype(np.float32), r"^points: must be a float64 numpy array of shape \(n, 3\).*got a float32 array of shape \(16, 3\)"),
        (POINTS[:, :2].copy(), r"^points: .*got a float64 array of shape \(16, 2\)"),
        (POINTS.ravel(), r"^points: .*got a float64 array of shape \(48,\)"),
        (POINTS.tolist(), r"^points: .*\(a Python list\)"),
        (np.zeros((0, 3)), r"^points: .*shape \(0, 3\)"),
        (np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]), r"^points\[1\]: \(1, 0, 1\) is not a unit vector \(norm 1.414"),
        (np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8]]), r"^points\[1\]: z = -0.8 is below the horizon"),
        (np.array([[0.0, 0.0, 1.0], [1.0, 0.0, -1e-300]]), r"^points\[1\]: z = -1e-300 is below the horizon \(need z >= 0\)$"),
        (np.array([[0.0, 0.0, np.nan]]), r"^points\[0\]: \(0, 0, NaN\) is not a unit vector"),
        (np.array([[0.0, 0.0, 1.0 + 2e-9]]), r"^points\[0\]: .*not a unit vector"),
    ],
)
def test_bad_points_name_the_argument_and_value(bad, match):
    raises(match, wb.estimate, "mc", bad, Y[: len(bad)] if hasattr(bad, "__len__") and len(bad) < 16 else Y)
    raises(match, wb.weights, bad)
    raises(match, wb.Rule, bad)
    raises(match, wb.Integrand("cos3"), bad)


def test_points_within_the_tolerance_are_accepted():
    p = np.array([[0.0, 0.0, 1.0 + 5e-10], [0.0, 0.0, 0.0 + 1.0]])
    wb.estimate("mc", p, np.ones(2))


@pytest.mark.parametrize(
    "bad,match",
    [
        (Y.astype(np.float32), r"^values: must be a float64 numpy array of shape \(16,\).*float32"),
        (Y[:5].copy(), r"^values: .*shape \(16,\).*got a float64 array of shape \(5,\)"),
        (Y.reshape(4, 4), r"^values: .*shape \(4, 4\)"),
        (np.where(np.arange(16) == 3, np.nan, Y), r"^values\[3\]: NaN is not a finite number"),
        (np.where(np.arange(16) == 7, np.inf, Y), r"^values\[7\]: inf is not a finite number"),
        (list(Y), r"^values: .*a Python list"),
    ],
)
def test_bad_values_name_the_argument_and_value(bad, match):
    raises(match, wb.estimate, "mc", POINTS, bad)
    raises(match, wb.estimate, "bmc", POINTS, bad, weights=RULE)
    raises(match, RULE.estimate, bad)


def test_estimate_arguments():
    raises(r'^method: unknown method "bmq"; expected one of "mc", "bmc", "bmcp", "bsq"$', wb.estimate, "bmq", POINTS, Y)
    raises(r"^prior: method \"bmcp\" needs its constant", wb.estimate, "bmcp", POINTS, Y, weights=RULE)
    raises(r"^prior: 0.5 is not used by method \"bmc\"", wb.estimate, "bmc", POINTS, Y, weights=RULE, prior=0.5)
    raises(r"^prior: .*\|c\| <= 1e100 · min\(1, √\(k\(x,x\) \+ σ_n²\)\) = 1e100 for this model .*got 1e101$", wb.estimate, "bmcp", POINTS, Y, weights=RULE, prior=1e101)
    raises(r"^prior: .*got NaN", wb.estimate, "bmcp", POINTS, Y, weights=RULE, prior=float("nan"))
    raises(r'^scale: unknown scale "big"', wb.estimate, "bmc", POINTS, Y, weights=RULE, scale="big")
    raises(r'^scale: not used by method "mc"', wb.estimate, "mc", POINTS, Y, scale="ml")
    raises(r'^weights: not used by method "mc"', wb.estimate, "mc", POINTS, Y, weights=RULE)
    raises(r'^density: unknown density "sphere"', wb.estimate, "mc", POINTS, Y, density="sphere")
    raises(r'^density: "cosine" is not used by method "bmc"', wb.estimate, "bmc", POINTS, Y, density="cosine")
    raises(r"^weights: must be a workbench.Rule .*got ndarray", wb.estimate, "bmc", POINTS, Y, weights=np.ones(16))
    other = wb.trial_points(2, "uniform", 16, 0)
    raises(r"^points: row 0 is not the rule's point 0", wb.estimate, "bmc", other, Y, weights=RULE)
    raises(r"^points: 8 points for a rule of 16", wb.estimate, "bmc", POINTS[:8].copy(), Y[:8].copy(), weights=RULE)
    one = POINTS[:1].copy()
    raises(r'^points: method "bsq" needs at least 2 points, got 1', wb.estimate, "bsq", one, Y[:1].copy())
    raises(r'^method: "mc" uses no weights', RULE.estimate, Y, "mc")


def test_rule_arguments():
    raises(r'^design: unknown design "halton"; expected one of "uniform", "cosine", "fibonacci", "stratified", "sobol", "rings"$',
           wb.rule, 16, design="halton")
    raises(r"^n: must be at least 1, got 0$", wb.rule, 0)
    raises(r'^n: 31 with design "rings": ', wb.rule, 31, design="rings")
    raises(r"^n: 20000 points would need .* GiB", wb.rule, 20000)
    raises(r'^method: "mc" uses no weights', wb.rule, 16, method="mc")
    raises(r'^n: method "bsq" needs at least 2 points, got 1', wb.rule, 1, method="bsq")
    raises(r"^kernel: sobolev kernel: s must be in \(1, 2\), \(2, 3\) or \(3, 4\), got 2$", wb.rule, 16, kernel={"type": "sobolev", "s": 2})
    raises(r"^kernel.type: unknown variant `matern`", wb.rule, 16, kernel="matern")
    raises(r"^kernel: unknown field `scale`", wb.rule, 16, kernel={"type": "se", "scale": 1})
    raises(r"^kernel\.s: must be a finite number, got nan", wb.rule, 16, kernel={"type": "sobolev", "s": float("nan")})
    raises(r"^noise: noise must be finite and >= 0, got -1$", wb.rule, 16, noise=-1.0)
    raises(r'^kernel_mean: unknown kernel mean "quad"', wb.rule, 16, kernel_mean="quad")
    raises(r"^kernel_mean_samples: is only used with", wb.rule, 16, kernel_mean_samples=10)
    raises(r"^values: a fitted kernel needs the integrand's values", wb.rule, 16, kernel="fitted")
    raises(r"^values: only used with a fitted kernel", wb.rule, 16, values=Y)
    raises(r"^values: .*shape \(16,\)", wb.rule, 16, kernel="fitted", values=Y[:3].copy())
    raises(r"^noise: 0.01 is not used with a fitted kernel", wb.rule, 16, kernel="fitted", noise=0.01, values=Y)
    raises(r"^kernel: grid.s: sobolev kernel: s must be", wb.rule, 16, kernel={"type": "fitted", "grid": {"s": [2.0]}}, values=Y)
    raises(r"^n: give either points or n", wb.Rule, POINTS, n=16)
    raises(r"^design: only with n", wb.Rule, POINTS, design="sobol")
    raises(r"^values: a fitted rule's weights depend on the integrand's values", wb.Rule(POINTS, kernel="fitted").weights)
    raises(r"^kernel: a fitted kernel has one kernel per grid model", wb.kernel_means, POINTS, kernel="fitted")
    raises(r"^grid.noise must be finite and >= 0, got -1", wb.fit, POINTS, Y, grid={"noise": [-1.0]})
    raises(r"^grid: unknown field `sigma`", wb.fit, POINTS, Y, grid={"sigma": [1.0]})
    raises(r'^design: unknown design "grid"', wb.trial_points, 1, "grid", 16, 0)
    raises(r"^n: must be at least 1, got 0", wb.trial_points, 1, "uniform", 0, 0)


def test_whole_number_arguments_out_of_range():
    big = 2**64
    raises(r"^n: must be a whole number from 0 to 18446744073709551615, got -1$", wb.rule, -1)
    raises(r"^seed: must be a whole number .* got -3$", wb.rule, 16, seed=-3)
    raises(rf"^seed: must be a whole number .* got {big}$", wb.Rule, n=16, seed=big)
    raises(r"^kernel_mean_samples: must be a whole number .* got -5$", wb.weights, POINTS, kernel_mean="mc", kernel_mean_samples=-5)
    raises(r"^seed: must be a whole number .* got -1$", wb.kernel_means, POINTS, seed=-1)
    raises(r"^trial: must be a whole number .* got -1$", wb.trial_points, 1, "uniform", 4, -1)
    raises(r"^threads: must be in 1..=256, got -2$", wb.run, GOOD, threads=-2)
    # The largest seed is a seed.
    wb.trial_points(2**64 - 1, "uniform", 4, 0)


def test_integrand_arguments():
    raises(r'^spec: unknown integrand "sin"', wb.Integrand, "sin")
    raises(r"^spec: axis: must be a non-zero finite vector", wb.Integrand, {"type": "lobe", "axis": [0, 0, 0], "exponent": 2})
    raises(r"^spec: half_angle: must be in \(0, 180\] degrees, got 200", wb.Integrand, {"type": "cap", "axis": [0, 0, 1], "half_angle": 200})
    raises(r"^spec: missing field `exponent`", wb.Integrand, {"type": "lobe", "axis": [0, 0, 1]})
    raises(r"^spec: pixel: \[300, 5\] is outside the 256×256 image", wb.Integrand, {"type": "pixel", "pixel": [300, 5], "channel": "g"})


GOOD = {"name": "bad", "integrands": ["cos3"], "estimators": [{"label": "MC", "method": "mc"}],
        "samples": [4], "trials": 2, "seed": 1}
BAD_SPECS = [
    GOOD | {"samples": [4, 0]},
    GOOD | {"estimators": [{"label": "B", "method": "bmc", "kernel": {"type": "sobolev", "s": 2}}]},
    GOOD | {"estimators": [{"label": "MC", "method": "mc", "noise": 0.1}]},
    GOOD | {"integrands": ["cos3", {"type": "lobe", "axis": [0, 0, 1], "exponent": -1}]},
    GOOD | {"extra": 1},
    GOOD | {"checks": [{"better": "MC", "than": "BMC"}]},
]


@pytest.mark.parametrize("spec", BAD_SPECS, ids=range(len(BAD_SPECS)))
def test_run_errors_are_the_cli_messages(cli, tmp_path, spec):
    (tmp_path / "bad.json").write_text(json.dumps(spec))
    p = cli("run", "bad.json", "--out", "out", check=False)
    assert p.returncode == 2
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("Error: bad.json: ")
    cli_message = line.removeprefix("Error: ")
    # A file: the very message; a dict: the same without the file's name.
    with pytest.raises(ValueError) as e:
        wb.run(str(tmp_path / "bad.json"))
    assert str(e.value) == cli_message.replace("bad.json", str(tmp_path / "bad.json"), 1)
    with pytest.raises(ValueError) as e:
        wb.run(spec)
    assert str(e.value) == cli_message.removeprefix("bad.json: ")


def test_run_arguments(tmp_path):
    raises(r"^threads: must be in 1..=256, got 0", wb.run, GOOD, threads=0)
    raises(r"^spec: must be an experiment as a dict .* got a Python int", wb.run, 3)
    raises(r"^seed: must be a finite number, got inf", wb.run, GOOD | {"seed": float("inf")})
    missing = str(tmp_path / "missing.json")
    raises(r"missing.json", wb.run, missing)


# Issue 42, Low: values JSON cannot hold are refused naming their field (json.dumps said "Out of
# range float values are not JSON compliant" without the field, and a set's TypeError had no
# place); every dict argument goes through the one check (run's spec, Integrand's, the kernel).
RUN_SPEC = {"name": "x", "integrands": ["cos3"], "estimators": [{"label": "MC", "method": "mc"}],
            "samples": [4], "trials": 1, "seed": 1}


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda s: s["estimators"].append({"label": "P", "method": "bmcp", "prior": float("nan")}),
         r"^estimators\[1\]\.prior: must be a finite number, got nan \(JSON has no NaN or infinity\)$"),
        (lambda s: s.update(integrands=[{"type": "python", "name": "f", "truth": float("inf")}]),
         r"^integrands\[0\]\.truth: must be a finite number, got inf"),
        (lambda s: s["estimators"][0].update(noise=np.float32("nan")),
         r"^estimators\[0\]\.noise: must be a finite number, got nan"),
        (lambda s: s.update(samples={4, 8}), r"^samples: must be a list, got \{.*\} \(a Python set\)"),
        (lambda s: s.update(samples=[4, 1 + 2j]), r"^samples\[1\]: must be a JSON value .*got \(1\+2j\) \(a Python complex\)"),
        (lambda s: s.update(seed=object()), r"^seed: must be a JSON value .*\(a Python object\)"),
        (lambda s: s["estimators"][0].update({3: "x"}), r"^estimators\[0\]: keys must be str .*got the key 3 \(a Python int\)"),
    ],
)
def test_a_spec_dict_names_the_field_that_json_cannot_hold(edit, match):
    spec = json.loads(json.dumps(RUN_SPEC))
    edit(spec)
    raises(match, wb.run, spec, integrands={"f": lambda p: p[:, 2]})


def test_every_dict_argument_names_the_field():
    raises(r"^spec: axis\[1\]: must be a finite number, got nan",
           wb.Integrand, {"type": "lobe", "axis": [0, float("nan"), 1], "exponent": 8})
    raises(r"^spec: normal: must be a list, got", wb.Integrand,
           {"type": "envmap", "env": "x.hdr", "normal": {0.0, 1.0}})
    raises(r"^kernel\.s: must be a finite number, got inf", wb.weights, POINTS,
           kernel={"type": "sobolev", "s": float("inf")})
    # numpy numbers and arrays are JSON numbers and lists.
    lobe = wb.Integrand({"type": "lobe", "axis": np.array([0.5, 0.0, 0.866]), "exponent": np.int64(8)})
    assert lobe.name == wb.Integrand({"type": "lobe", "axis": [0.5, 0, 0.866], "exponent": 8}).name
