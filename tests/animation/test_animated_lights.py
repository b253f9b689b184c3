"""Lights for animations: light j is the same light in every frame. On one frame the
area and environment lights are exactly ``generate_lights``'; area points and gather samples move with
their surfaces; the gather lights' reflected power equals the particle tracer's VPL power (one bounce and
all bounces) within Monte Carlo noise; and the brute-force frames match Mitsuba's path tracer."""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
import manylights.scenes
from manylights.testing import mitsuba as reference

BOUNCE = ml.scenes.scene_path("bounce")


@pytest.fixture(scope="module")
def anim():
    return ml.load_animation(BOUNCE, frames=ml.scenes.animation_frames("bounce", count=4), res=32)


@pytest.fixture(scope="module")
def lights(anim):
    return ml.generate_animation_lights(anim, area=256, environment=256, indirect=4**5, seed=3)


def test_counts_and_order(lights, anim):
    assert len(lights) == len(anim) and all(len(L) == lights.n for L in lights)
    c = lights.counts
    assert (c["delta"], c["area"], c["environment"]) == (0, 256, 256)
    # Gather samples on surfaces without diffuse reflectance (the emitter's black quad) are left out.
    assert 0.9 * 4**5 < c["indirect"] < 4**5 and lights.n == 512 + c["indirect"]
    kinds = lights[0].kind
    assert list(kinds[:256]) == [3] * 256 and list(kinds[256:512]) == [2] * 256 and np.all(kinds[512:] == 4)


def test_one_frame_equals_generate_lights(anim):
    scene = anim[0]
    one = ml.generate_animation_lights([scene], area=300, environment=200, seed=7)[0]
    ref = ml.generate_lights(scene, area=300, environment=200, seed=7)
    assert len(one) == len(ref)
    for name in ("kind", "position", "direction", "normal", "intensity"):
        assert np.array_equal(getattr(one, name), getattr(ref, name)), name


def test_lights_move_with_their_surfaces(lights, anim):
    a, b = lights[0], lights[len(anim) - 1]
    # The area light and the environment do not move: identical lights.
    for name in ("position", "normal", "intensity"):
        assert np.array_equal(getattr(a, name)[:256], getattr(b, name)[:256])
    assert np.array_equal(a.direction[256:512], b.direction[256:512])
    # Gather lights: those on the static walls and floor stay put, those on the box move with it.
    g = slice(512, None)
    moved = np.linalg.norm(a.position[g] - b.position[g], axis=1) > 1e-4
    assert 0.01 < moved.mean() < 0.3, moved.mean()
    # Every gather light stays on a surface of its own frame: the G-buffer-free check is that its distance
    # to the box's new position is consistent with a rigid motion: the moved ones all sat near the box.
    box0 = np.array([float(anim.params[0][k]) for k in ("box_x", "box_y", "box_z")])
    assert np.all(np.linalg.norm(a.position[g][moved] - box0, axis=1) < 1.2)


@pytest.mark.parametrize("photons, max_depth", [(0, 3), (20000, -1)])
def test_gather_power_matches_particle_tracing(anim, photons, max_depth):
    """One bounce: sum over gather lights of E A k_d (their reflected power) against the VPLs of
    ``generate_lights`` at bounce 1 (max_depth 3); all bounces: with the photon pre-pass against all VPLs.
    Measured: 72.5 vs 71.2-72.2 W (red) one bounce, 100.2 vs 99.3-100.5 W all bounces."""
    scene = anim[0]
    G = ml.generate_animation_lights([scene], area=4096, environment=4096, indirect=4**6, photons=photons,
                                     max_depth=max_depth, seed=1)[0]
    V = ml.generate_lights(scene, area=0, indirect=40000, max_depth=max_depth, seed=2)
    g = G.power[G.kind == 4].sum(0)
    v = V.power[V.kind == 4].sum(0)
    assert np.allclose(g, v, rtol=0.04), (g, v)


def test_brute_force_matches_mitsuba(anim, lights):
    """Frame 2 of the animation, full GI: brute force over the animation lights against Mitsuba's path
    tracer at pixel centres (measured 4.9% / 4.2% at 48x48 with 2048 spp, reference noise ~2%)."""
    k = 2
    L = ml.generate_animation_lights(anim, area=1024, environment=1024, indirect=4**5, photons=20000, seed=0)
    T = ml.LightTensor(anim, L, device="cpu")
    A = T.frame(k)
    img = A.column_sum(progress=False) + A.emitted()
    mean, var = reference.mitsuba_render(BOUNCE, (32, 32), max_depth=-1, spp=1024, seed=0, **anim.params[k])
    err = ml.relative_l2(img, mean)
    noise = float(np.sqrt(var.sum()) / np.linalg.norm(mean))
    assert err < 0.09 + 2 * noise, (err, noise)


def test_bad_input(anim):
    # Any gather count works (not only powers of 4).
    assert ml.generate_animation_lights([anim[0]], area=8, indirect=1000).counts["indirect"] > 900
    with pytest.raises(ValueError, match="no frames"):
        ml.generate_animation_lights([], area=10)
    with pytest.raises(ValueError, match="area"):
        ml.generate_animation_lights(anim, area=-1)
    cbox = ml.load_scene(ml.scenes.scene_path("cbox"), res=32)
    with pytest.raises(ValueError, match="frame 1"):
        ml.generate_animation_lights([anim[0], cbox], area=16, indirect=16)
