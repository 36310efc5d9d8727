"""Your own integrand from Python (docs/guide/python-integrands.md): `run(spec, integrands=…)`
with `{"type": "python", "name": …}` integrands — the built-in's numbers to the bit for the same
function, batched calls, computed truths within their error estimate, errors naming the
integrand, the trial and N with nothing written."""

import itertools
import json
import math
import os
import threading

import numpy as np
import pytest
import workbench as wb

# Every method, designs with and without a random stream, a fitted amplitude, a tolerance
# estimator, comparison and calibration checks: the whole machinery on the integrand.
BASE = {
    "name": "cos3-py",
    "estimators": [
        {"label": "MC", "method": "mc"},
        {"label": "MC Sobol", "method": "mc", "design": "sobol"},
        {"label": "BMC", "method": "bmc"},
        {"label": "BMCP", "method": "bmcp"},
        {"label": "BSQ", "method": "bsq", "kernel": {"type": "sobolev", "s": 2.75}},
        {"label": "BMC ml", "method": "bmc", "scale": "ml", "design": "stratified"},
        {"label": "MC tol", "method": "mc", "tolerance": {"abs": 0.05, "max_n": 64, "min_n": 8}},
    ],
    "samples": [4, 16, 32],
    "trials": 12,
    "seed": 11,
    "checks": [
        {"better": "BMC", "than": "MC", "from_n": 16},
        {"calibrated": "BMC ml", "level": 0.9, "from_n": 16, "side": "lower"},
    ],
}


def cos3(points):
    z = points[:, 2]
    return z * z * z  # how Rust's powi(3) rounds


def python_cos3(**extra):
    return dict(BASE, integrands=[dict({"type": "python", "name": "cos3", "truth": math.pi / 2}, **extra)])


def csvs(folder):
    """The CSVs of a result folder but the machine-dependent timings*.csv (wall-clock seconds)."""
    return {p: (folder / p).read_bytes() for p in sorted(os.listdir(folder))
            if p.endswith(".csv") and not p.startswith("timings")}


def test_a_callable_cos3_writes_the_builtin_csvs_bit_for_bit(tmp_path):
    builtin = wb.run(dict(BASE, integrands=["cos3"]), out=tmp_path / "builtin", threads=2)
    mine = wb.run(python_cos3(), integrands={"cos3": cos3}, out=tmp_path / "mine", threads=1)
    a, b = csvs(tmp_path / "builtin"), csvs(tmp_path / "mine")
    assert "trials.csv" in a and "summary.csv" in a and "stopping_trials.csv" in a
    assert a.keys() == b.keys()
    for name in a:
        assert a[name] == b[name], name
    assert builtin["passed"] and mine["passed"]
    # The figures exist for it, named by it.
    files = set(os.listdir(tmp_path / "mine"))
    assert {"cos3.svg", "cos3-coverage.svg"} <= files, files
    manifest = json.loads((tmp_path / "mine" / "manifest.json").read_text())
    f = manifest["plan"]["integrands"][0]
    assert (f["type"], f["truth_source"], f["truth"]) == ("python", "given", math.pi / 2)


def test_in_memory_columns_match_whatever_the_threads():
    builtin = wb.run(dict(BASE, integrands=["cos3"]), threads=3)
    for threads in (1, 4):
        mine = wb.run(python_cos3(), integrands={"cos3": cos3}, threads=threads)
        for column in builtin:
            x, y = builtin[column], mine[column]
            assert x == y if isinstance(x, list) else np.array_equal(x, y, equal_nan=True), column


def test_calls_are_batched_one_per_point_set():
    calls = []
    lock = threading.Lock()

    def f(points):
        with lock:
            calls.append(points.shape)
        return cos3(points)

    spec = dict(python_cos3(), estimators=BASE["estimators"][:3], checks=[])
    wb.run(spec, integrands={"cos3": f})
    # One call per (N, trial, design): uniform and sobol.
    assert len(calls) == 2 * len(BASE["samples"]) * BASE["trials"]
    assert sorted({s[0] for s in calls}) == BASE["samples"]
    assert all(s[1] == 3 for s in calls)


def test_computed_truth_is_within_its_error_estimate(tmp_path):
    spec = dict(BASE, estimators=BASE["estimators"][:1], checks=[], trials=2,
                integrands=[{"type": "python", "name": "c3", "tolerance": 1e-11}])
    wb.run(spec, integrands={"c3": cos3}, out=tmp_path / "o")
    f = json.loads((tmp_path / "o" / "manifest.json").read_text())["plan"]["integrands"][0]
    assert f["truth_source"] == "cubature" and 0 < f["truth_error_estimate"] <= 1e-11
    assert abs(f["truth"] - math.pi / 2) <= f["truth_error_estimate"]
    assert f["truth_evaluations"] >= 8 * 441


@pytest.mark.parametrize(
    "f, message",
    [
        (lambda p: 1 / 0, "the callable raised ZeroDivisionError: division by zero"),
        (lambda p: p[:, 2:], "expected shape (4,), one value per direction"),
        (lambda p: p[:-1, 2], "expected shape (4,), one value per direction"),
        (lambda p: np.where(p[:, 2] > 0.5, np.nan, 1.0), "is not finite"),
        (lambda p: "x", "not an array of 4 float64 values"),
    ],
)
def test_a_bad_callable_names_integrand_trial_and_n_and_writes_nothing(tmp_path, f, message):
    spec = dict(python_cos3(), estimators=BASE["estimators"][:1], checks=[], samples=[4])
    out = tmp_path / "never"
    with pytest.raises(ValueError) as e:
        wb.run(spec, integrands={"cos3": f}, out=out)
    assert 'integrand "cos3", trial ' in str(e.value) and ", N = 4: " in str(e.value), str(e.value)
    assert message in str(e.value)
    assert not out.exists()


def test_the_spec_and_the_callables_must_agree():
    spec = python_cos3()
    with pytest.raises(ValueError, match=r'integrands\[0\]: \{"type": "python", "name": "cos3"\} has no callable'):
        wb.run(spec)
    with pytest.raises(ValueError, match=r'integrands\["other"\]: no integrand of the spec'):
        wb.run(spec, integrands={"cos3": cos3, "other": cos3})
    with pytest.raises(ValueError, match=r'integrands\["cos3"\]: must be callable'):
        wb.run(spec, integrands={"cos3": 3})
    with pytest.raises(ValueError, match=r'integrands\[0\]\.truth: invalid type: string "1", expected f64'):
        wb.run(dict(BASE, integrands=[{"type": "python", "name": "x", "truth": "1"}]), integrands={"x": cos3})
    with pytest.raises(ValueError, match=r"integrands\[0\]\.tolerance: is the computed truth's"):
        wb.run(python_cos3(tolerance=1e-3), integrands={"cos3": cos3})
    # A bad estimator is reported before any truth is computed (the callable is never called).
    called = []
    bad = dict(BASE, estimators=[{"label": "X", "method": "bmq"}],
               integrands=[{"type": "python", "name": "x"}])
    with pytest.raises(ValueError, match="estimators"):
        wb.run(bad, integrands={"x": lambda p: called.append(1) or cos3(p)})
    assert called == []


def test_the_cli_refuses_a_python_integrand(cli, tmp_path):
    (tmp_path / "e.json").write_text(json.dumps(python_cos3()))
    p = cli("validate", "e.json", check=False)
    assert p.returncode == 2
    assert 'integrands[0].type: "python" names a Python callable' in p.stderr


# Issue 42, item 4: a callable that itself calls `run` (a nested run on a worker thread, whose
# workspace the outer unit holds, or onto which a rayon wait steals another outer unit).
# Before: pyo3's PanicException ("RefCell already borrowed"), a BaseException, not a ValueError.
NESTED = {"name": "p", "integrands": [{"type": "python", "name": "f", "truth": 1.0}],
          "estimators": [{"label": "MC", "method": "mc"}, {"label": "BMC", "method": "bmc"}],
          "samples": [8, 16], "trials": 3, "seed": 1}


@pytest.mark.parametrize("threads", [1, 2])
def test_a_callable_that_calls_run_gets_a_nested_run_not_a_panic(threads):
    inner = dict(NESTED, integrands=["cos3"], trials=1, samples=[4])
    expected_inner = wb.run(inner)
    seen = []

    def f(p):
        rows = wb.run(inner, threads=2)
        seen.append(rows["estimate"].tolist())
        return p[:, 2]

    plain = wb.run(NESTED, integrands={"f": lambda p: p[:, 2]}, threads=threads)
    nested = wb.run(NESTED, integrands={"f": f}, threads=threads)
    # The nested runs gave their own rows, and the outer rows are those of a run without them.
    assert seen and all(s == expected_inner["estimate"].tolist() for s in seen)
    for column in plain:
        a, b = plain[column], nested[column]
        assert a == b if isinstance(a, list) else np.array_equal(a, b, equal_nan=True), column


def test_a_callable_that_writes_a_nested_run_folder(tmp_path):
    inner = dict(NESTED, integrands=["cos3"], trials=1, samples=[4])

    calls = itertools.count()

    def f(p):
        # One folder per call: two nested runs may be under way at once (each releases the GIL).
        wb.run(inner, out=tmp_path / f"inner-{len(p)}-{next(calls)}", threads=2)
        return p[:, 2]

    result = wb.run(NESTED, integrands={"f": f}, out=tmp_path / "outer", threads=2)
    assert (tmp_path / "outer" / "trials.csv").exists() and (tmp_path / "inner-8-0" / "trials.csv").exists()
    assert result["out"].endswith("outer")


# Issue 42, Low: a complex return value was cut to its real part (numpy's ComplexWarning only);
# strings were parsed as numbers.
@pytest.mark.parametrize(
    "f, message",
    [
        (lambda p: p[:, 2] + 1j * p[:, 0], "returned complex values"),
        (lambda p: (p[:, 2] + 0j).tolist(), "returned complex values"),
        (lambda p: [str(v) for v in p[:, 2]], "returned strings"),
    ],
)
def test_a_callable_returning_complex_or_text_is_refused(f, message):
    spec = dict(python_cos3(), estimators=BASE["estimators"][:1], checks=[], samples=[4])
    with pytest.raises(ValueError) as e:
        wb.run(spec, integrands={"cos3": f})
    assert 'integrand "cos3", trial ' in str(e.value) and message in str(e.value), str(e.value)


# Issue 43, item 4: the computed truth of a tilted smooth lobe meets its default tolerance (in
# μ = cos θ the cubature ran out of values although right to 1e-13), and a tolerance out of the
# cubature's reach is refused as the tolerance's, with the remedy.
def tilted_lobe(points):
    a = np.array([np.sin(np.radians(40)), 0.0, np.cos(np.radians(40))])
    return np.exp(8.0 * (points @ a - 1.0)) * points[:, 2]


def test_the_computed_truth_of_a_tilted_smooth_lobe_meets_the_default_tolerance(tmp_path):
    spec = dict(BASE, estimators=BASE["estimators"][:1], checks=[], trials=2, samples=[4],
                integrands=[{"type": "python", "name": "lobe"}])
    wb.run(spec, integrands={"lobe": tilted_lobe}, out=tmp_path / "o")
    f = json.loads((tmp_path / "o" / "manifest.json").read_text())["plan"]["integrands"][0]
    # The same integrand as the library's family (Gaussian × cos θ), whose truth is certified.
    a = [np.sin(np.radians(40)), 0.0, np.cos(np.radians(40))]
    family = wb.Integrand({"type": "gaussian", "axis": a, "sharpness": 8.0, "cosine": True})
    assert f["truth_source"] == "cubature"
    assert 0 < f["truth_error_estimate"] <= 1e-10 * abs(family.truth)
    assert abs(f["truth"] - family.truth) <= max(f["truth_error_estimate"], 1e-15)


def test_an_unreachable_tolerance_is_refused_as_the_tolerance_with_the_remedy():
    spec = dict(BASE, estimators=BASE["estimators"][:1], checks=[], trials=1, samples=[4],
                integrands=[{"type": "python", "name": "step"}])
    with pytest.raises(ValueError) as e:
        wb.run(spec, integrands={"step": lambda p: (p[:, 0] > 0.3).astype(np.float64)})
    m = str(e.value)
    assert m.startswith("integrands[0].tolerance: the cubature did not reach the default tolerance"), m
    assert "the integrand's values were fine" in m and 'give "truth"' in m and "trial" not in m, m
