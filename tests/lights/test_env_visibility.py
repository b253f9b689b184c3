"""Environment strata allocated by what the camera sees of them (``generate_lights(env_visibility=True)``,
``src/lights/generate/env_visibility.rs``), against the converged Mitsuba 3.9.1 pixel-centre reference of a
room lit only through a window (``scenes/window-room``, direct light, 256 x 144).

The error is measured at 1,200 fixed pixels (the exact rows of the light set: brute force there), with the
reference's noise taken out. Measured: uniform strata 13.6% / 6.0% / 3.0% / 1.5% at 1,024 / 4,096 / 16,384 /
65,536 lights, visibility strata 3.6% / 1.4% / 0.6% / within the reference's noise; the glossy plates under
an environment map (``tests/data/veach_plates_env.xml``) 4.4% uniform, 0.7% visibility at 16,384.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import manylights as ml

ROOT = Path(__file__).resolve().parents[2]
REFS = ROOT / "tests" / "references"


@pytest.fixture(scope="module")
def room():
    scene = ml.load_scene(ROOT / "scenes" / "window-room" / "scene.xml", resx=256, resy=144)
    ref = ml.read_exr(REFS / "window-room-direct.exr").reshape(-1, 3).astype(np.float64)
    var = ml.read_exr(REFS / "window-room-direct.var.exr").reshape(-1, 3).astype(np.float64)
    pixels = np.sort(np.random.default_rng(0).choice(256 * 144, 1200, replace=False))
    return scene, pixels, ref[pixels], var[pixels]


def _error(scene, pixels, ref, var, **kwargs) -> float:
    lights = ml.generate_lights(scene, area=0, seed=1, **kwargs)
    A = ml.LightMatrix(scene, lights, device="cpu", max_depth=2)
    values = A.rows(pixels, progress=False).sum(axis=1, dtype=np.float64) + A.emitted().reshape(-1, 3)[pixels]
    sq = float(np.sum((values - ref) ** 2)) - float(var.sum())
    return float(np.sqrt(max(sq, 0.0) / np.sum(ref ** 2)))


def test_window_room_strata_converge_faster_than_uniform(room):
    scene, pixels, ref, var = room
    uniform = _error(scene, pixels, ref, var, environment=4096)
    visible = _error(scene, pixels, ref, var, environment=4096, env_visibility=True)
    finer = _error(scene, pixels, ref, var, environment=16384, env_visibility=True)
    # Measured 6.0%, 1.4%, 0.6%.
    assert 0.045 < uniform < 0.08, uniform
    assert visible < 0.02 and visible < 0.35 * uniform, (visible, uniform)
    assert finer < 0.01 and finer < 0.6 * visible, (finer, visible)


def test_visibility_strata_keep_the_power_and_the_seed(room):
    scene = room[0]
    uniform = ml.generate_lights(scene, area=0, environment=2000, seed=0)
    a = ml.generate_lights(scene, area=0, environment=2000, seed=4, env_visibility=True)
    b = ml.generate_lights(scene, area=0, environment=2000, seed=4, env_visibility=True)
    np.testing.assert_array_equal(np.asarray(a.direction), np.asarray(b.direction))
    np.testing.assert_allclose(np.asarray(a.power).sum(axis=0), np.asarray(uniform.power).sum(axis=0), rtol=2e-3)
    assert len(a) <= 2000


@pytest.mark.parametrize("kwargs, message", [
    ({"env_visibility": True, "env_importance": True}, "env_importance and env_visibility"),
    ({"env_visibility": 1}, "env_visibility must be True or False"),
])
def test_bad_env_options(room, kwargs, message):
    with pytest.raises(ValueError, match=message):
        ml.generate_lights(room[0], area=0, environment=500, **kwargs)
