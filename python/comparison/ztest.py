"""Mitsuba's own z-test on Mitsuba's own test scene, for the workbench integrator beside Mitsuba's
``path`` (``max_depth`` 2) and ``direct``.

The scene is ``tests/scenes/bsdf_spheres/test_envmap_path.xml`` of ``mitsuba-data`` (read from
``$WORKBENCH_DATA/mitsuba-data``, never copied): 10 spheres and 2 masked leaves under the museum
map, 48×48, judged as Mitsuba's test suite judges a render: per pixel and channel
``z = |mean − ref| · √(spp / max(var, 1e-4))`` against ``refs/test_envmap_ref_rgb.exr`` and its
per-sample variance ``refs/test_envmap_ref_rgb_var.exr`` (math.md §10). The XML is loaded as
Mitsuba's tests load it, with ``integrator="workbench"`` in place of ``path`` (inside ``moment``,
its ``max_depth`` 2); each method then renders the scene with ``moment`` around the workbench
integrator with that method's properties. Per object (the object a ray through the pixel centre
hits) and overall: the median z and the share of z > 3.

    python python/comparison/ztest.py [--spp 64] [--n 16] [--out results/mitsuba/ztest]

With ``--out`` it writes ``ztest.csv``, ``ztest.md`` and ``ztest.json`` there.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

import mitsuba as mi

SCENE = os.path.join("mitsuba-data", "tests", "scenes", "bsdf_spheres")
#: The objects of fragments/sphere_grid.xml by their centre (y, z) in world space.
OBJECTS = {
    (-6, 0): "diffuse",
    (-3, 0): "diffuse textured",
    (0, 0): "dielectric (diamond)",
    (3, 0): "plastic (smooth)",
    (6, 0): "roughdielectric beckmann 0.02",
    (6, 3): "roughdielectric ggx 0.1",
    (3, 3): "roughplastic beckmann 0.1",
    (0, 3): "roughplastic beckmann 0.05",
    (-3, 3): "conductor (smooth)",
    (-6, 3): "roughconductor beckmann 0.05",
    (-6, -3): "mask twosided diffuse",
    (-3, -3): "mask diffuse",
}
#: Methods: label → the workbench integrator's properties, or a Mitsuba integrator's.
METHODS = {
    "bmc": {"type": "workbench", "method": "bmc"},
    "bmc fitted": {"type": "workbench", "method": "bmc", "kernel": "fitted"},
    "bmc sobol": {"type": "workbench", "method": "bmc", "design": "sobol"},
    "bmc 1 rule": {"type": "workbench", "method": "bmc", "rules": 1},
    "bmc fitted 1 rule": {"type": "workbench", "method": "bmc", "kernel": "fitted", "rules": 1},
    "mc_cosine": {"type": "workbench", "method": "mc_cosine"},
    "mc_bsdf": {"type": "workbench", "method": "mc_bsdf"},
    "bq-pss": {"type": "workbench", "method": "bq-pss"},
    "bq-pss order 1": {"type": "workbench", "method": "bq-pss", "order": 1},
    "path": {"type": "path", "max_depth": 2},
    "direct": {"type": "direct"},
}


def data_dir(root=None) -> str:
    root = root or os.environ.get("WORKBENCH_DATA")
    if not root:
        raise SystemExit("error: WORKBENCH_DATA is not set (the folder holding mitsuba-data/)")
    d = os.path.join(root, SCENE)
    if not os.path.isfile(os.path.join(d, "test_envmap_path.xml")):
        raise SystemExit(f"error: {d}/test_envmap_path.xml is missing (WORKBENCH_DATA={root})")
    return d


def load(d: str, spp: int):
    """The scene as Mitsuba's tests load it, with the workbench integrator named in place of
    ``path`` (default properties, the fragment's ``max_depth`` 2), and the reference and its
    per-sample variance."""
    scene = mi.load_file(os.path.join(d, "test_envmap_path.xml"), spp=spp, integrator="workbench")
    ref = np.array(mi.Bitmap(os.path.join(d, "refs", "test_envmap_ref_rgb.exr")), dtype=np.float64)
    var = np.array(mi.Bitmap(os.path.join(d, "refs", "test_envmap_ref_rgb_var.exr")), dtype=np.float64)
    return scene, ref[..., :3], var[..., :3]


def object_labels(scene) -> np.ndarray:
    """Per pixel, the name of the object the ray through the pixel centre hits ("background"
    where it hits none), found by the hit point's nearest object centre (a JIT variant)."""
    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    jj, ii = np.mgrid[0:h, 0:w]
    pos = mi.Point2f(((ii + 0.5) / w).ravel().tolist(), ((jj + 0.5) / h).ravel().tolist())
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    valid = np.array(si.is_valid(), dtype=bool)
    y, z = np.array(si.p.y, dtype=np.float64), np.array(si.p.z, dtype=np.float64)
    keys = list(OBJECTS)
    d2 = np.stack([(y - k[0]) ** 2 + (z - k[1]) ** 2 for k in keys])
    names = np.array([OBJECTS[k] for k in keys], dtype=object)[np.argmin(d2, axis=0)]
    names[~valid] = "background"
    return names.reshape(h, w)


def integrator(label: str, n: int):
    props = dict(METHODS[label])
    if props["type"] == "workbench":
        props.update(n=n, max_depth=2)
    return mi.load_dict({"type": "moment", "nested": props})


def z_scores(img, ref, var, spp):
    return np.abs(img - ref) * np.sqrt(spp / np.maximum(var, 1e-4))


def summarise(z, img, ref, labels):
    rows = {}
    groups = ["all"] + [v for v in OBJECTS.values()] + ["background"]
    for g in groups:
        m = np.ones(labels.shape, bool) if g == "all" else labels == g
        if not m.any():
            continue
        zz = z[m]
        rows[g] = {
            "pixels": int(m.sum()),
            "median_z": float(np.median(zz)),
            "share_z_above_3": float(np.mean(zz > 3)),
            "rmse": float(np.sqrt(np.mean((img[m] - ref[m]) ** 2))),
            "mean_difference": float(np.mean(img[m] - ref[m])),
        }
    return rows


def run(spp: int, n: int, methods, seed: int = 0, root=None, labels=None):
    """``{method: {"seconds", "groups": {object: summary}}}``; renders each method once (after a
    warm-up render at 1 spp, so that times are of compiled kernels)."""
    d = data_dir(root)
    scene, ref, var = load(d, spp)
    if labels is None:
        labels = object_labels(scene)
    out = {}
    for label in methods:
        integ = integrator(label, n)
        mi.render(scene, integrator=integ, spp=1, seed=seed + 1000)
        t0 = time.perf_counter()
        img = np.array(mi.render(scene, integrator=integ, spp=spp, seed=seed), dtype=np.float64)[..., :3]
        seconds = time.perf_counter() - t0
        z = z_scores(img, ref, var, spp)
        out[label] = {"seconds": seconds, "groups": summarise(z, img, ref, labels), "image": img}
    return out, labels


def table(results, spp, n) -> str:
    labels = list(results)
    groups = list(next(iter(results.values()))["groups"])
    lines = [
        f"Mitsuba's z-test on bsdf_spheres/test_envmap_path.xml at {spp} spp (camera samples per pixel; "
        f"the workbench integrator with n = {n} directions per camera sample): median z / share of "
        "pixel-channels with z > 3, per object (the object at the pixel centre).",
        "",
        "| object | pixels | " + " | ".join(labels) + " |",
        "|---|---:|" + "---:|" * len(labels),
    ]
    for g in groups:
        cells = []
        for lab in labels:
            r = results[lab]["groups"][g]
            cells.append(f"{r['median_z']:.2f} / {100 * r['share_z_above_3']:.1f}%")
        lines.append(f"| {g} | {results[labels[0]]['groups'][g]['pixels']} | " + " | ".join(cells) + " |")
    lines.append("| RMSE (all) | | " + " | ".join(f"{results[lab]['groups']['all']['rmse']:.4f}" for lab in labels) + " |")
    lines.append("| time (s) | | " + " | ".join(f"{results[lab]['seconds']:.2f}" for lab in labels) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--n", type=int, default=16)
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    import workbench.mitsuba as wbm

    variant = wbm.set_variant()
    wbm.register()
    methods = args.methods.split(",")
    for m in methods:
        if m not in METHODS:
            raise SystemExit(f"error: --methods: unknown method {m!r}; expected some of {list(METHODS)}")
    results, _ = run(args.spp, args.n, methods, args.seed)
    text = table(results, args.spp, args.n)
    print(text)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "ztest.md"), "w") as f:
            f.write(text)
        with open(os.path.join(args.out, "ztest.csv"), "w") as f:
            f.write("method,object,pixels,median_z,share_z_above_3,rmse,mean_difference,seconds\n")
            for lab, r in results.items():
                for g, s in r["groups"].items():
                    f.write(f"{lab},{g},{s['pixels']},{s['median_z']!r},{s['share_z_above_3']!r},"
                            f"{s['rmse']!r},{s['mean_difference']!r},{r['seconds']!r}\n")
        meta = {
            "spp": args.spp, "n": args.n, "seed": args.seed, "variant": variant,
            "mitsuba": mi.__version__, "python": platform.python_version(), "command": " ".join(sys.argv),
        }
        with open(os.path.join(args.out, "ztest.json"), "w") as f:
            json.dump(meta, f, indent=1)
        for lab, r in results.items():
            mi.Bitmap(r["image"].astype(np.float32)).write(os.path.join(args.out, f"{lab.replace(' ', '-')}.exr"))


if __name__ == "__main__":
    main()
