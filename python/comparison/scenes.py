"""Scenes nobody here wrote, read in place from ``$WORKBENCH_DATA`` (never copied into the
repository): Mitsuba's ``bsdf_spheres`` test scene and its ``matpreview`` scene from
``mitsuba-data``, optionally at another resolution, under another map (``envmaps/polyhaven/``)
and, for matpreview, with another shell material; and ``mi.cornell_box()``.

Variations are made by rewriting the XML's text into a temporary file whose relative paths are
made absolute (the data folder is only read).
"""

from __future__ import annotations

import os
import re
import tempfile

import mitsuba as mi

SPHERES = os.path.join("mitsuba-data", "tests", "scenes", "bsdf_spheres")
MATPREVIEW = os.path.join("mitsuba-data", "scenes", "matpreview")
#: Shell materials for matpreview: the scene's own plastic, and rough ones (GGX).
SHELLS = {
    "plastic": None,
    "roughplastic-0.1": '<bsdf type="roughplastic" id="bsdf-matpreview"><float name="alpha" value="0.1"/>'
                        '<rgb name="diffuse_reflectance" value="0.940, 0.271, 0.361"/></bsdf>',
    "roughplastic-0.3": '<bsdf type="roughplastic" id="bsdf-matpreview"><float name="alpha" value="0.3"/>'
                        '<rgb name="diffuse_reflectance" value="0.940, 0.271, 0.361"/></bsdf>',
    "roughconductor-0.1": '<bsdf type="roughconductor" id="bsdf-matpreview"><float name="alpha" value="0.1"/>'
                          '<string name="material" value="Au"/></bsdf>',
    "roughconductor-0.3": '<bsdf type="roughconductor" id="bsdf-matpreview"><float name="alpha" value="0.3"/>'
                          '<string name="material" value="Au"/></bsdf>',
}


def data_root() -> str:
    root = os.environ.get("WORKBENCH_DATA")
    if not root:
        raise SystemExit("error: WORKBENCH_DATA is not set (the folder holding mitsuba-data/ and envmaps/)")
    return root


#: Debevec's light probes (``envmaps/debevec/``) by name: the 1024×512 lat-long of each.
DEBEVEC = {"pisa": "pisa_1024x512.hdr", "grace": "grace_256x128.hdr"}


def env_path(env: str) -> str:
    """``museum`` (the scenes' own map), a Debevec probe (``pisa``, ``grace``) or a Poly Haven
    map's name (``park``, ``sky``, …: these two with the real, unclipped sun)."""
    if env == "museum":
        return os.path.join(data_root(), "mitsuba-data", "common", "textures", "museum.exr")
    if env in DEBEVEC:
        path = os.path.join(data_root(), "envmaps", "debevec", DEBEVEC[env])
        if not os.path.isfile(path):
            raise SystemExit(f"error: map {env!r}: {path} is missing")
        return path
    path = os.path.join(data_root(), "envmaps", "polyhaven", f"{env}.hdr")
    if not os.path.isfile(path):
        raise SystemExit(f"error: map {env!r}: {path} is missing")
    return path


def _write(text: str) -> str:
    fd, path = tempfile.mkstemp(suffix=".xml", prefix="workbench-scene-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    return path


def _matpreview_text(root: str, env: str, shell: str) -> str:
    """matpreview.xml with absolute paths, the map ``env`` (its own ``envmap.exr`` for the museum)
    and the shell ``shell`` of ``SHELLS`` in place of its plastic."""
    folder = os.path.join(root, MATPREVIEW)
    with open(os.path.join(folder, "matpreview.xml")) as f:
        text = f.read()
    text = text.replace('value="envmap.exr"', f'value="{env_path(env) if env != "museum" else os.path.join(folder, "envmap.exr")}"')
    text = text.replace('value="matpreview.serialized"', f'value="{os.path.join(folder, "matpreview.serialized")}"')
    if SHELLS.get(shell):
        text = re.sub(r'<bsdf type="plastic" id="bsdf-matpreview">.*?</bsdf>', SHELLS[shell], text, flags=re.S)
    elif shell not in SHELLS:
        raise SystemExit(f"error: shell {shell!r}; expected one of {list(SHELLS)}")
    return text


def source(name: str, env: str = "museum", shell: str = "plastic"):
    """``(xml_path, params)``: the scene ``name`` (``bsdf_spheres`` or ``matpreview``) as a
    temporary XML file with absolute paths (at its own resolution) and the parameters
    ``mi.load_file`` needs, for scripts that edit the XML further (vs_direct.py)."""
    root = data_root()
    if name == "bsdf_spheres":
        folder = os.path.join(root, SPHERES)
        with open(os.path.join(folder, "test_envmap_path.xml")) as f:
            main = f.read()
        main = main.replace('<path value="../../../common"/>',
                            f'<path value="{os.path.join(root, "mitsuba-data", "common")}"/>')
        main = main.replace('value="textures/museum.exr"', f'value="{env_path(env)}"')
        main = main.replace('<include filename="fragments/sphere_grid.xml"/>',
                            f'<include filename="{os.path.join(folder, "fragments", "sphere_grid.xml")}"/>')
        return _write(main), {}
    if name == "matpreview":
        text = _matpreview_text(root, env, shell)
        return _write(text), {"max_depth": 2}
    raise SystemExit(f"error: scene {name!r}; expected bsdf_spheres or matpreview")


def load(name: str, res=None, env: str = "museum", shell: str = "plastic", spp: int = 1):
    """``(scene, sensor)`` — sensor None: the scene's own. ``name``: ``bsdf_spheres``,
    ``matpreview`` or ``cornell_box``; ``res`` = (width, height)."""
    if name == "cornell_box":
        d = mi.cornell_box()
        if res:
            d["sensor"]["film"]["width"], d["sensor"]["film"]["height"] = res
        return mi.load_dict(d), None
    root = data_root()
    if name == "bsdf_spheres":
        folder = os.path.join(root, SPHERES)
        with open(os.path.join(folder, "fragments", "sphere_grid.xml")) as f:
            fragment = f.read()
        if res:
            fragment = fragment.replace('<integer name="width" value="48"/>', f'<integer name="width" value="{res[0]}"/>')
            fragment = fragment.replace('<integer name="height" value="48"/>', f'<integer name="height" value="{res[1]}"/>')
        with open(os.path.join(folder, "test_envmap_path.xml")) as f:
            main = f.read()
        main = main.replace('<path value="../../../common"/>',
                            f'<path value="{os.path.join(root, "mitsuba-data", "common")}"/>')
        main = main.replace('value="textures/museum.exr"', f'value="{env_path(env)}"')
        main = main.replace('<include filename="fragments/sphere_grid.xml"/>', f'<include filename="{_write(fragment)}"/>')
        path = _write(main)
        return mi.load_file(path, spp=spp), None
    if name == "matpreview":
        text = _matpreview_text(root, env, shell)
        kwargs = {"spp": spp}
        if res:
            kwargs.update(width=res[0], height=res[1])
        return mi.load_file(_write(text), max_depth=2, **kwargs), None
    raise SystemExit(f"error: scene {name!r}; expected bsdf_spheres, matpreview or cornell_box")
