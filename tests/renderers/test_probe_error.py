"""The error estimate from unbiased probe pixels (``manylights.renderers.probe_error``): it sees bias that the
variance estimates cannot, against the stored converged Mitsuba reference of cbox full GI (64x64)."""
import json

import numpy as np
import pytest

import manylights as ml
from conftest import REFERENCES, cbox_gi_64
from manylights.renderers.probe_error import probe_error


@pytest.fixture(scope="module")
def cbox():
    scene, ref = cbox_gi_64()
    meta = json.loads((REFERENCES / "cbox-gi-64.json").read_text())
    return scene, ref, meta


def test_an_image_scaled_by_0_9_is_estimated_11_percent_off(cbox):
    """0.9 I*: its relative L2 against I* is 0.1 ||I*|| / ||0.9 I*|| = 1/9, all of it bias."""
    scene, ref, _ = cbox
    est = probe_error(0.9 * ref, scene, probes=256, spp=256, seed=1)
    assert est["error_mean"] == pytest.approx(1 / 9, rel=0.15)
    assert 1 / 9 <= est["error_estimate"] <= 1.3 / 9  # the upper bound covers it, not by much
    assert est["reliable"] and est["effective_probes"] > 64
    assert est["pixels"].shape == (256, 2) and est["probe_mean"].shape == (256, 3)


def test_the_converged_image_itself_is_estimated_near_zero(cbox):
    scene, ref, meta = cbox
    est = probe_error(ref, scene, probes=256, spp=256, seed=2)
    # The reference's own noise is 0.19%; (1) removes the probes' variance, so what is left is sampling noise.
    assert est["error_mean"] < 0.02 and est["error_estimate"] < 0.03
    assert meta["relative_noise"] < 0.005


def test_clamped_vpls_error_is_seen_with_bias_and_variance_split(cbox):
    scene, ref, _ = cbox
    lights = ml.generate_lights(scene, area=1024, indirect=4000, seed=1)
    A = ml.LightMatrix(scene, lights, device="cpu")
    res = ml.mrcs(A, rows=64, columns=512, halves=True, seed=2, error_probes=256)
    true = ml.relative_l2(res.image, ref)
    assert res.variance_estimate is not None and res.variance_estimate < true  # halves: variance only
    assert 0.8 * true <= res.error_estimate <= 2.0 * true, (res.error_estimate, true)
    assert res.bias_estimate is not None and res.bias_estimate > 0
    assert res.budget["probes"]["probes"] == 256 and res.timings["probes"] > 0
    assert [s["source"] for s in res.bias_sources] == ["vpl_clamp"]
    # Without probes nothing changes: the estimate is the halves' alone.
    plain = ml.mrcs(A, rows=64, columns=512, halves=True, seed=2)
    np.testing.assert_array_equal(plain.image, res.image)
    assert plain.error_estimate == res.variance_estimate and plain.bias_estimate is None


def test_other_renderers_take_error_probes(cbox):
    scene, ref, _ = cbox
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=256, indirect=500, seed=3), device="cpu")
    for res in (ml.power_sampling(A, columns=256, error_probes=64),
                ml.clustered_visibility(A, light_clusters=64, view_clusters=64, error_probes=64),
                ml.instant_radiosity(scene, lights=300, error_probes=64, device="cpu")):
        true = ml.relative_l2(res.image, ref)
        assert res.error_estimate >= 0.5 * true, (res.method, res.error_estimate, true)
        assert res.budget["probes"]["probes"] == 64


def test_render_claims_a_target_only_under_the_probe_bound(tmp_path):
    from conftest import REPO

    path = REPO / "scenes" / "cbox" / "scene.xml"
    opts = dict(params={"res": 32}, rows_per_column=0.25, progress=False, first_lights=64, max_lights=1024)
    res = ml.render(str(path), target_error=0.05, seed=1, **opts)
    probe = res.budget["probes"]
    assert probe["probes"] == 256 and res.variance_estimate == res.budget["estimated_total_error"]
    assert res.budget["target_reached"] is (probe["reliable"] and res.error_estimate <= 0.05)
    # The clamped VPLs are listed, and the probes measure what they cost: the claim rests on the probes.
    assert [s["source"] for s in res.bias_sources] == ["vpl_clamp"] and res.bias_estimate is not None
    assert res.budget["target_reached"] is True and "probe upper bound" in res.budget["target_reason"]
    tight = ml.render(str(path), target_error=0.002, seed=1, **{**opts, "max_lights": 256})
    assert tight.budget["target_reached"] is False and "> target" in tight.budget["target_reason"]
    # At 16x16, 256 paths per probe: a few bright paths carry the estimate; it is marked and not claimed.
    small = ml.render(str(path), target_error=0.5, seed=1, **{**opts, "params": {"res": 16}, "max_lights": 256})
    assert not small.budget["probes"]["reliable"] and small.budget["target_reached"] is False
    assert "too few" in small.budget["target_reason"]


@pytest.mark.parametrize("kwargs, match", [
    (dict(probes=0), "probes"), (dict(probes=10**9), "probes"), (dict(spp=1), "spp"),
    (dict(confidence=1.0), "confidence"), (dict(seed=-1), "seed")])
def test_bad_input(cbox, kwargs, match):
    scene, ref, _ = cbox
    with pytest.raises(ValueError, match=match):
        probe_error(ref, scene, **{"probes": 8, **kwargs})
    with pytest.raises(ValueError, match="shape"):
        probe_error(ref[:10], scene, probes=8)
