"""Writes the comparison's scenes (python/comparison/scenes/): two equirectangular environment
maps baked from closed-form skies, and two Mitsuba 3 XML scenes that use them.

- ``sky.exr`` + ``workbench-scene.xml``: the scene of docs/render-scene.md exactly (ground
  square, sphere, pinhole camera, Lambertian albedos, +y up), lit by its procedural sky baked
  into a map. Mitsuba's ``envmap`` plugin and ``workbench render --env MAP`` look maps up the
  same way, so both renderers then integrate exactly the same radiance.
- ``studio.exr`` + ``glossy-scene.xml``: a scene that is not the workbench's: a rough gold
  sphere (roughconductor, GGX α 0.2), a red rough-plastic sphere (roughplastic, GGX α 0.1), a
  Lambertian sphere and a textured Lambertian floor (checkerboard), under a studio-like map
  (a sky gradient, a sun and two soft boxes).

Both maps are deterministic: ``python python/comparison/make_scenes.py`` rewrites the same
files. Texel (r, c) of a W × H map holds the sky at the direction where Mitsuba's bilinear
lookup puts that texel exactly: u = (c + ½)/W, v = r/(H − 1) (docs/render-scene.md), so the
map interpolates samples of the closed-form sky.
"""

from __future__ import annotations

import math
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "scenes")


def texel_directions(width: int, height: int) -> np.ndarray:
    """(H, W, 3) unit directions of the texels under Mitsuba's envmap lookup:
    u = atan2(x, −z)/2π, v = arccos(y)/π; columns at texel centres, rows from zenith to nadir."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)
    phi = 2 * math.pi * u[None, :]
    theta = math.pi * v[:, None]
    x = np.sin(theta) * np.sin(phi)
    z = -np.sin(theta) * np.cos(phi)
    y = np.cos(theta) * np.ones_like(phi)
    return np.stack([x, y, z], axis=-1)


def workbench_sky(d: np.ndarray) -> np.ndarray:
    """docs/render-scene.md's procedural sky, for unit directions d (..., 3)."""
    h = d[..., 1:2]
    up = np.array([0.90, 0.90, 0.85]) * (1 - h) + np.array([0.30, 0.50, 0.90]) * h
    down = np.broadcast_to(np.array([0.40, 0.38, 0.35]), up.shape)
    sky = np.where(h >= 0, up, down)
    s = np.array([-1.0, 1.0, 0.5])
    s /= np.linalg.norm(s)
    lobe = np.maximum(0.0, d @ s)[..., None] ** 32
    return sky + np.array([6.0, 5.6, 4.8]) * lobe


def studio(d: np.ndarray) -> np.ndarray:
    """A studio-like sky: a smooth gradient, a small warm sun, two large soft boxes (smooth
    edges, so the map has bright features of several sizes) and a dark floor."""
    y = d[..., 1:2]
    sky = np.where(
        y >= 0,
        np.array([0.55, 0.60, 0.70]) * (1 - y) + np.array([0.15, 0.25, 0.55]) * y,
        np.array([0.10, 0.09, 0.08]) * np.ones_like(y),
    )

    def blob(axis, cos_radius, softness):
        a = np.asarray(axis, dtype=float)
        a /= np.linalg.norm(a)
        c = d @ a
        return (1 / (1 + np.exp(np.clip(-(c - cos_radius) / softness, -50, 50))))[..., None]

    sun = blob([0.6, 0.55, 0.3], math.cos(math.radians(3.0)), 0.0015) * np.array([40.0, 36.0, 30.0])
    box1 = blob([-0.8, 0.6, 0.4], math.cos(math.radians(18.0)), 0.01) * np.array([2.5, 2.5, 2.5])
    box2 = blob([0.5, 0.3, -0.8], math.cos(math.radians(25.0)), 0.02) * np.array([0.8, 1.0, 1.6])
    return sky + sun + box1 + box2


def write_exr(path: str, rgb: np.ndarray) -> None:
    import mitsuba as mi

    if not mi.variant():
        mi.set_variant("scalar_rgb")
    mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


WORKBENCH_XML = """<!-- The workbench render scene (docs/render-scene.md) in Mitsuba 3's format: +y up, the
     ground square y = 0, |x|, |z| <= 5 (a rectangle: [-1, 1]^2 in z = 0 with normal +z, turned
     by -90 deg about x to normal +y and scaled by 5), the unit sphere at (0, 1, 0), Lambertian
     albedos, the pinhole camera, the procedural sky baked into sky.exr (make_scenes.py).
     Written by python/comparison/make_scenes.py. -->
<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="res" value="128"/>
    <default name="integrator" value="direct"/>

    <integrator type="$integrator"/>

    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world">
            <lookat origin="0, 1.6, 6.5" target="0, 0.9, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <rfilter type="box"/>
        </film>
    </sensor>

    <emitter type="envmap">
        <string name="filename" value="sky.exr"/>
    </emitter>

    <shape type="rectangle" id="ground">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="5"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.75, 0.75, 0.75"/>
        </bsdf>
    </shape>

    <shape type="sphere" id="sphere">
        <point name="center" x="0" y="1" z="0"/>
        <float name="radius" value="1"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.80, 0.35, 0.25"/>
        </bsdf>
    </shape>
</scene>
"""

GLOSSY_XML = """<!-- Glossy and diffuse materials under an environment map (studio.exr, make_scenes.py):
     a rough gold sphere, a red rough-plastic sphere, a Lambertian sphere, a checkerboard
     Lambertian floor. +y up. Written by python/comparison/make_scenes.py. -->
<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="res" value="128"/>
    <default name="integrator" value="direct"/>

    <integrator type="$integrator"/>

    <sensor type="perspective">
        <float name="fov" value="35"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world">
            <lookat origin="0, 3.2, 7.0" target="0, 0.5, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <rfilter type="box"/>
        </film>
    </sensor>

    <emitter type="envmap">
        <string name="filename" value="studio.exr"/>
    </emitter>

    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="6"/>
        </transform>
        <bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.70, 0.70, 0.68"/>
                <rgb name="color1" value="0.25, 0.27, 0.30"/>
                <transform name="to_uv">
                    <scale x="6" y="6"/>
                </transform>
            </texture>
        </bsdf>
    </shape>

    <shape type="sphere" id="gold">
        <point name="center" x="-1.6" y="0.8" z="0"/>
        <float name="radius" value="0.8"/>
        <bsdf type="roughconductor">
            <string name="material" value="Au"/>
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.2"/>
        </bsdf>
    </shape>

    <shape type="sphere" id="plastic">
        <point name="center" x="0.2" y="0.8" z="-0.6"/>
        <float name="radius" value="0.8"/>
        <bsdf type="roughplastic">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.1"/>
            <rgb name="diffuse_reflectance" value="0.70, 0.12, 0.08"/>
        </bsdf>
    </shape>

    <shape type="sphere" id="matte">
        <point name="center" x="1.7" y="0.6" z="0.6"/>
        <float name="radius" value="0.6"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.30, 0.55, 0.75"/>
        </bsdf>
    </shape>
</scene>
"""


def main() -> None:
    os.makedirs(SCENES, exist_ok=True)
    write_exr(os.path.join(SCENES, "sky.exr"), workbench_sky(texel_directions(128, 65)))
    write_exr(os.path.join(SCENES, "studio.exr"), studio(texel_directions(256, 129)))
    with open(os.path.join(SCENES, "workbench-scene.xml"), "w") as f:
        f.write(WORKBENCH_XML)
    with open(os.path.join(SCENES, "glossy-scene.xml"), "w") as f:
        f.write(GLOSSY_XML)
    print(f"wrote {SCENES}/{{sky.exr, studio.exr, workbench-scene.xml, glossy-scene.xml}}")


if __name__ == "__main__":
    main()
