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
def cli_folder(tmp_path_factory):
    """The CLI's result folder of SPEC."""
    import subprocess

    from conftest import cli_binary

    d = tmp_path_factory.mktemp("run")
    (d / "spec.json").write_text(json.dumps(SPEC))
    p = subprocess.run([str(cli_binary()), "run", "spec.json", "--out", "out", "-q"], cwd=d,
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return d / "out"


@pytest.fixture(scope="module")
def cli_trials(cli_folder):
    """The CLI's trials.csv of SPEC: header and rows."""
    return read_csv(cli_folder / "trials.csv")


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


def same_table(columns, path):
    """The columns of run(…, tables=True) are the CSV's fields, value for value and bit for bit."""
    header, rows = read_csv(path)
    assert list(columns) == header, path.name
    for k, name in enumerate(header):
        got, want = columns[name], [r[k] for r in rows]
        if isinstance(got, list):
            assert got == want, name
        elif got.dtype == np.bool_:
            assert got.tolist() == [v == "true" for v in want], name
        elif got.dtype == np.int64:
            assert got.tolist() == [int(v) for v in want], name
        else:
            assert got.dtype == np.float64 and same_bits(got, [exact(v) for v in want]), name


# Issue 43, item 4: run() also returns the summary rows and the tolerance estimators' samples.
def test_run_tables_are_the_cli_csvs(cli_folder, py_trials):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tables = wb.run(SPEC, tables=True, threads=2)
    assert sorted(tables) == ["stopping_summary", "stopping_trials", "summary", "trials"]
    for name in py_trials:
        a, b = py_trials[name], tables["trials"][name]
        assert a == b if isinstance(a, list) else same_bits(a, b), name
    same_table(tables["summary"], cli_folder / "summary.csv")
    same_table(tables["stopping_trials"], cli_folder / "stopping_trials.csv")
    same_table(tables["stopping_summary"], cli_folder / "stopping_summary.csv")
    # The samples a tolerance estimator used, per trial.
    used = tables["stopping_trials"]["n_used"]
    assert used.dtype == np.int64 and np.all(used >= 4) and np.all(used <= 64)
    # Without tolerance estimators the stopping tables are empty; the old return is unchanged.
    plain = SPEC | {"estimators": ESTIMATORS[:2], "integrands": INTEGRANDS[:1]}
    t = wb.run(plain, tables=True)
    assert t["stopping_trials"] == {} and t["stopping_summary"] == {}
    assert list(wb.run(plain)) == list(t["trials"])


def test_run_tables_with_out_are_read_from_the_folder(tmp_path):
    plain = SPEC | {"estimators": ESTIMATORS[:2], "integrands": INTEGRANDS[:1]}
    r = wb.run(plain, out=tmp_path / "o", tables=True)
    assert {"out", "report", "passed", "trials", "summary"} <= set(r)
    same_table(r["summary"], tmp_path / "o" / "summary.csv")
    same_table(r["trials"], tmp_path / "o" / "trials.csv")
    assert same_bits(r["summary"]["mean_abs_error"], wb.run(plain, tables=True)["summary"]["mean_abs_error"])


# Issue 43, item 4: wb.to_world carries a rule's local points to a world normal.
def test_to_world_rotates_local_points_to_the_normal():
    points, _ = wb.rule(32, seed=3)
    n = np.array([0.3, 0.5, -0.8])
    world = wb.to_world(points, n)
    n_hat = n / np.linalg.norm(n)
    assert world.shape == (32, 3) and world.dtype == np.float64
    assert np.allclose(np.linalg.norm(world, axis=1), 1, atol=1e-12)
    assert np.allclose(world @ n_hat, points[:, 2], atol=1e-12)          # the normal's cosine is kept
    assert np.allclose(world @ world.T, points @ points.T, atol=1e-12)   # a rotation: angles kept
    # An azimuth rotates about the normal first.
    phi = 0.7
    c, s = np.cos(phi), np.sin(phi)
    rotated = points @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    assert np.allclose(wb.to_world(points, n, azimuth=phi), wb.to_world(rotated, n), atol=1e-14)
    # Rule.estimate is valid for values at rotated points: the weights of the rotated points are
    # the rule's (isotropic kernel), so the estimate of a world lobe is the local lobe's.
    rule = wb.Rule(points)
    assert np.allclose(wb.weights(rotated), rule.weights(), rtol=1e-9, atol=1e-12)
    local_axis = np.array([0.5, 0.0, np.sqrt(0.75)])
    world_axis = wb.to_world(local_axis[None, :], n)[0]
    f_world = np.maximum(wb.to_world(points, n, azimuth=phi) @ world_axis, 0) ** 8
    f_local = np.maximum(rotated @ local_axis, 0) ** 8
    assert np.allclose(f_world, f_local, rtol=1e-12, atol=1e-15)
    v_world, sd_world = rule.estimate(f_world)
    v_local, sd_local = wb.Rule(rotated).estimate(f_local)
    assert abs(v_world - v_local) <= 1e-9 * abs(v_local) and abs(sd_world - sd_local) <= 1e-6 * sd_local


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"normal": [0, 0, 0]}, r"^normal: must be a non-zero finite vector, got \[0, 0, 0\]"),
        ({"normal": [0, float("nan"), 1]}, r"^normal: must be a non-zero finite vector"),
        ({"normal": [0, 1]}, r"^normal: must be three numbers \[x, y, z\]"),
        ({"normal": "up"}, r"^normal: must be three numbers"),
        ({"normal": [0, 0, 1], "azimuth": float("inf")}, r"^azimuth: must be a finite angle"),
        ({"normal": [0, 0, 1], "azimuth": "east"}, r"^azimuth: must be a number"),
    ],
)
def test_to_world_refuses_bad_input(kwargs, match):
    points, _ = wb.rule(4, seed=1)
    with pytest.raises(ValueError, match=match):
        wb.to_world(points, **kwargs)
