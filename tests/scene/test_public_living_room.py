"""A public interior, bundled: Bitterli's "The Grey & White Room" by Wig42 (CC-BY 3.0; the Mitsuba conversion
of mitsuba2-transient-scenes, made smaller by ``tests/public_scenes.py bundle``: meshes as binary PLY, textures
block-averaged; ``tests/data/scenes/living-room/LICENSE.txt``). A version 0.5 file, lit only through its
windows by an environment map, with masked leaves (``mask`` with a bitmap opacity), glass, rough plastics and
rough conductors, on twosided BSDFs.

- The loader's facts: 65 PLY shapes, the BSDF types, the environment map, the upgraded ``maxDepth``.
- Direct light (max_depth 2) at 96 x 54 against a converged pixel-centre Mitsuba 3.9.1 reference
  (``tests/references/living-room-direct``): the brute force of 16,384 environment strata allocated by
  visibility (``generate_lights(env_visibility=True)``, what ``ml.render`` uses), glossy MIS with 4,096 BSDF
  samples per view sample, within 1.5x the reference's noise; 1,024 uniform strata are far outside it (the
  test can fail).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import manylights as ml

HERE = Path(__file__).resolve().parents[1]
XML = HERE / "data" / "scenes" / "living-room" / "scene.xml"
REFS = HERE / "references"
SIZE = (96, 54)
# Relative L2 against the reference may exceed the reference's own noise by this factor.
TOL_NOISE = 1.5
# 1,024 uniform strata must miss the reference by at least this many noise levels.
OFF_NOISE = 3.0


def _brute(scene, **lights):
    A = ml.LightMatrix(scene, ml.generate_lights(scene, seed=0, **lights), device="cpu", max_depth=2,
                       bsdf_samples=4096)
    return np.asarray(A.column_sum(progress=False)) + A.emitted()


def test_loads_as_published():
    scene = ml.load_scene(XML, size=SIZE)
    assert (scene.width, scene.height) == SIZE
    assert len(scene.shapes) == 65 and {s["type"] for s in scene.shapes} == {"ply"}
    types = sorted({b["type"] for b in scene.bsdfs})
    assert types == ["conductor", "dielectric", "diffuse", "mask", "roughconductor", "roughplastic", "twosided"]
    assert [e["type"] for e in scene.emitters] == ["envmap"]
    assert scene.integrator["max_depth"] == 65
    assert "CC-BY" in (XML.parent / "LICENSE.txt").read_text()


def test_direct_light_matches_mitsuba():
    meta = json.loads((REFS / "living-room-direct.json").read_text())
    assert meta["integrator"] == {"type": "path", "max_depth": 2} and meta["mitsuba"] == "3.9.1"
    ref, var = ml.read_exr(REFS / "living-room-direct.exr"), ml.read_exr(REFS / "living-room-direct.var.exr")
    den = (ref ** 2).sum()
    noise = float(np.sqrt(var.sum() / den))
    scene = ml.load_scene(XML, size=SIZE)
    err = float(np.sqrt(((_brute(scene, environment=16384, env_visibility=True) - ref) ** 2).sum() / den))
    off = float(np.sqrt(((_brute(scene, environment=1024) - ref) ** 2).sum() / den))
    print(f"\nliving room: relative L2 {err:.3%} (reference noise {noise:.3%}; 1,024 uniform strata {off:.3%})")
    assert err <= TOL_NOISE * noise
    assert off >= OFF_NOISE * noise
