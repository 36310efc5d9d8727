"""``run`` against ``workbench run``'s trials.csv, and ``estimate`` reproducing its rows, bit for
bit."""

import json
import math

import numpy as np
import pytest

import workbench as wb
from conftest import exact, read_csv, same_bits

SEED = 11
INTEGRANDS = [
    "cos3",
    {"type": "lobe", "axis": [0.5, 0, 0.866], "exponent": 8},
    {"type": "cap", "axis": [0.2, 0.1, 1], "half_angle": 30, "cosine": True},
    {"type": "gaussian", "axis": [1, 0, 1], "sharpness": 20, "name": "sg20"},
    {"type": "pixel", "pixel": [128, 200], "channel": "g"},
]
FITTED = {"type": "fitted", "grid": {"s": [1.2, 3.75], "noise": [1e-2, 1e-8]}}
ESTIMATORS = [
    {"label": "MC", "method": "mc"},
    {"label": "MC cosine", "method": "mc", "design": "cosine"},
    {"label": "BMC", "method": "bmc"},
    {"label": "BMC loo, sobol", "method": "bmc", "design": "sobol", "scale": "loo"},
    {"label": "BMC unit rings", "method": "bmc", "design": "rings", "scale": "unit"},
    {"label": "BMCP", "method": "bmcp", "design": "stratified"},
    {"label": "BMCP 0.3", "method": "bmcp", "prior": 0.3, "kernel": {"type": "sobolev", "s": 2.75}, "noise": 1e-6},
    {"label": "BSQ", "method": "bsq", "design": "fibonacci"},
    {"label": "BMC se", "method": "bmc", "kernel": {"type": "se", "length": 0.4}, "noise": 1e-4},
    {"label": "BMC fitted", "method": "bmc", "kernel": FITTED},
    {"label": "BSQ fitted", "method": "bsq", "kernel": FITTED, "design": "sobol"},
    {"label": "BMC mc-z", "method": "bmc", "kernel_mean": "mc", "kernel_mean_samples": 200},
    {"label": "BMC tol", "method": "bmc", "tolerance": {"abs": 0.05, "max_n": 64}},
]
SPEC = {
    "name": "py",
    "integrands": INTEGRANDS,
    "estimators": ESTIMATORS,
    "samples": [4, 16, 32],
    "trials": 3,
    "seed": SEED,
}


@pytest.fixture(scope="module")
def cli_trials(tmp_path_factory):
    """The CLI's trials.csv of SPEC: header and rows."""
    import subprocess

    from conftest import cli_binary

    d = tmp_path_factory.mktemp("run")
    (d / "spec.json").write_text(json.dumps(SPEC))
    p = subprocess.run([str(cli_binary()), "run", "spec.json", "--out", "out", "-q"], cwd=d,
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return read_csv(d / "out" / "trials.csv")


@pytest.fixture(scope="module")
def py_trials():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return wb.run(SPEC)


STRINGS = {"integrand", "estimator", "method", "design", "model"}
INTS = {"n", "trial", "warnings"}


def test_run_is_the_cli_trials_csv(cli_trials, py_trials):
    header, rows = cli_trials
    assert list(py_trials) == header
    assert all(len(col) == len(rows) for col in py_trials.values())
    for k, name in enumerate(header):
        got = py_trials[name]
        want = [r[k] for r in rows]
        if name in STRINGS:
            assert list(got) == want, name
        elif name in INTS:
            assert got.dtype == np.int64 and got.tolist() == [int(v) for v in want], name
        else:
            assert got.dtype == np.float64
            assert same_bits(got, [exact(v) for v in want]), name


def test_run_does_not_depend_on_threads(py_trials):
    one = wb.run(SPEC | {"estimators": ESTIMATORS[:4], "integrands": INTEGRANDS[:2]}, threads=1)
    two = wb.run(SPEC | {"estimators": ESTIMATORS[:4], "integrands": INTEGRANDS[:2]}, threads=2)
    for name in one:
        if name in STRINGS:
            assert one[name] == two[name]
        else:
            assert same_bits(one[name], two[name]), name


def test_run_of_a_file_is_the_same(tmp_path, py_trials):
    (tmp_path / "spec.json").write_text(json.dumps(SPEC | {"estimators": ESTIMATORS[:3]}))
    from_file = wb.run(str(tmp_path / "spec.json"))
    from_dict = wb.run(SPEC | {"estimators": ESTIMATORS[:3]})
    assert same_bits(from_file["estimate"], from_dict["estimate"])


def test_integrand_truths_are_the_run_truths(py_trials):
    for spec in INTEGRANDS:
        f = wb.Integrand(spec)
        rows = [i for i, name in enumerate(py_trials["integrand"]) if name == f.name]
        assert rows, f.name
        assert np.all(py_trials["truth"][rows] == f.truth)
        assert f.constant_prior == f.truth / (2 * math.pi)
    assert wb.Integrand("cos3").truth == 2 * math.pi / 4
    assert wb.Integrand(INTEGRANDS[3]).name == "sg20"


# Rows that `estimate` on the trial's points reproduces: every estimator but the ring one (its
# weights come from the ring solver, not the dense solve of given points), the MC kernel means
# (drawn from the run's own stream) and the tolerance estimator (it extends its points).
REPRODUCIBLE = [e for e in ESTIMATORS if e["label"] not in ("BMC unit rings", "BMC mc-z", "BMC tol")]


@pytest.mark.parametrize("e", REPRODUCIBLE, ids=[e["label"] for e in REPRODUCIBLE])
def test_estimate_reproduces_each_row(e, py_trials):
    design = e.get("design", "uniform")
    integrands = [wb.Integrand(s) for s in INTEGRANDS]
    checked = 0
    for n in SPEC["samples"]:
        for t in range(SPEC["trials"]):
            points = wb.trial_points(SEED, design, n, t)
            rule = None
            if e["method"] != "mc":
                model = {k: e[k] for k in ("kernel", "noise") if k in e}
                rule = wb.Rule(points, **model)
            for f in integrands:
                y = f(points)
                if e["method"] == "mc":
                    density = "cosine" if design == "cosine" else "uniform"
                    value, sd = wb.estimate("mc", points, y, density=density)
                else:
                    kwargs = {"scale": e.get("scale", "ml")}
                    if e["method"] == "bmcp":
                        kwargs["prior"] = e.get("prior", f.constant_prior)
                    value, sd = wb.estimate(e["method"], points, y, weights=rule, **kwargs)
                    assert (value, sd) == rule.estimate(y, e["method"], **kwargs)
                row = [
                    i for i in range(len(py_trials["n"]))
                    if py_trials["estimator"][i] == e["label"] and py_trials["integrand"][i] == f.name
                    and py_trials["n"][i] == n and py_trials["trial"][i] == t
                ]
                assert len(row) == 1
                assert same_bits(value, py_trials["estimate"][row[0]]), (f.name, n, t)
                assert same_bits(sd, py_trials["posterior_sd"][row[0]]), (f.name, n, t)
                if "model" in py_trials and rule is not None and rule.fitted:
                    d = rule.diagnostics(e["method"], values=y)
                    assert d["model"] == py_trials["model"][row[0]]
                checked += 1
    assert checked == len(SPEC["samples"]) * SPEC["trials"] * len(INTEGRANDS)
