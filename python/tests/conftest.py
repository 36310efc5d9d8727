"""Shared helpers: the CLI binary (``target/release/workbench``, built by ``cargo build --release``
or ``cargo test --release`` at the repository root; ``WORKBENCH_BIN`` overrides it) and exact
readers of its CSVs."""

import csv
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_binary() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("WORKBENCH_BIN", REPO / "target" / "release" / "workbench"))
    if not path.exists():
        raise RuntimeError(
            f"the workbench CLI is not at {path}: run `cargo build --release` at the repository root "
            "(or set WORKBENCH_BIN); the tests compare the bindings with it"
        )
    return path


@pytest.fixture
def cli(tmp_path):
    """Runs the CLI in ``tmp_path``; returns the completed process."""

    def run(*args, check=True):
        p = subprocess.run(
            [str(cli_binary()), *map(str, args)], cwd=tmp_path, capture_output=True, text=True
        )
        if check and p.returncode != 0:
            raise AssertionError(f"workbench {' '.join(map(str, args))} failed:\n{p.stderr}")
        return p

    return run


@pytest.fixture
def data_dir():
    """The external data folder, ``WORKBENCH_DATA`` (docs/guide/data.md), as an absolute path.
    Unset, the test is skipped with the reason; with ``WORKBENCH_REQUIRE_DATA=1`` (as CI sets)
    it fails instead, so that no data test silently does not run."""
    folder = os.environ.get("WORKBENCH_DATA", "")
    why = None
    if not folder:
        why = "WORKBENCH_DATA is not set (the external data folder, e.g. ../shared/data; docs/guide/data.md)"
    elif not os.path.isdir(folder):
        why = f"WORKBENCH_DATA={folder} is not a folder"
    if why is not None:
        if os.environ.get("WORKBENCH_REQUIRE_DATA") == "1":
            pytest.fail(f"WORKBENCH_REQUIRE_DATA=1 but {why}")
        pytest.skip(why)
    return pathlib.Path(folder).resolve()


def read_csv(path):
    """Header and rows of a CSV, as strings."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def exact(field: str) -> float:
    """A CSV number as the exact double (the CLI writes shortest round-trip form; Python's
    float() rounds correctly); an empty field is NaN, as in ``run``'s columns."""
    return float(field) if field != "" else math.nan


def read_rule(path):
    header, rows = read_csv(path)
    assert header == ["x", "y", "z", "weight"]
    a = np.array([[exact(v) for v in r] for r in rows])
    return np.ascontiguousarray(a[:, :3]), np.ascontiguousarray(a[:, 3])


def same_bits(a, b) -> bool:
    """Equal to the bit, NaNs at the same places."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    nan = np.isnan(a)
    return bool(np.array_equal(nan, np.isnan(b)) and np.all(a[~nan].view(np.uint64) == b[~nan].view(np.uint64)))


def write_points(path, points):
    with open(path, "w") as f:
        f.write("x,y,z\n")
        for p in points:
            f.write(",".join(repr(float(v)) for v in p) + "\n")


def write_values(path, values):
    with open(path, "w") as f:
        f.write("value\n")
        for v in values:
            f.write(repr(float(v)) + "\n")


#: Mitsuba's test scene inside the data folder (docs/guide/mitsuba.md, ../shared/data/README.md).
MITSUBA_SCENE = pathlib.Path("tests") / "scenes" / "bsdf_spheres" / "test_envmap_path.xml"


@pytest.fixture(scope="session")
def mitsuba_data() -> pathlib.Path:
    """``$WORKBENCH_DATA/mitsuba-data`` (Mitsuba 3's own test data, read in place, never copied).
    Without ``WORKBENCH_DATA`` (or without the files) the test is skipped with the reason; with
    ``WORKBENCH_REQUIRE_DATA=1`` (CI) that is a failure instead."""
    required = os.environ.get("WORKBENCH_REQUIRE_DATA") == "1"
    root = os.environ.get("WORKBENCH_DATA")
    if not root:
        reason = "WORKBENCH_DATA is not set (the folder holding mitsuba-data/)"
    else:
        folder = pathlib.Path(root) / "mitsuba-data"
        if (folder / MITSUBA_SCENE).is_file():
            return folder
        reason = f"{folder / MITSUBA_SCENE} is missing (WORKBENCH_DATA={root})"
    if required:
        pytest.fail(f"WORKBENCH_REQUIRE_DATA=1 but {reason}")
    pytest.skip(reason)


def assert_property_refused(mi, wbm, props, message):
    """The integrator's properties ``props`` are refused with a ValueError starting ``message``:
    by ``wbm.load_integrator``, and by Mitsuba's own loader (``mi.load_dict``, as from XML), which
    re-raises it as a RuntimeError ending with it; both within 5 s, since the checks come before
    any rule is computed or memory taken."""
    import time

    t0 = time.perf_counter()
    with pytest.raises(ValueError) as info:
        wbm.load_integrator(props)
    assert str(info.value).startswith(message), str(info.value)
    with pytest.raises(RuntimeError) as info:
        mi.load_dict({"type": "workbench", **props})
    assert str(info.value).strip().splitlines()[-1].startswith("ValueError: " + message), str(info.value)[-300:]
    assert time.perf_counter() - t0 < 5
