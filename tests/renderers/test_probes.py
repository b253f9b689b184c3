"""The probe path tracer (``manylights.probe_pixels``, ``src/pathtrace``) against converged Mitsuba 3.9.1
pixel-centre references (``tests/references``: ``path`` integrator, camera ray through the pixel centre,
mean and variance of the mean per pixel), probe by probe.

Per scene, 64 probe pixels drawn at random (fixed seed) from the film; per probe and channel the z-score
z = (ours - mitsuba) / sqrt(var_ours + var_mitsuba). If both are unbiased, z is close to N(0, 1) (the
variances are estimated from >= 64 samples each). Checks, over the 192 (probe, channel) values:
- at most ``MAX_OUTLIERS`` with |z| > 3 (0.5 expected under the null; the rest of the allowance is for
  probes on a silhouette, where Mitsuba's and our camera hit may differ: ~0.15% of pixels);
- mean z^2 in ``Z2_BAND``: its expectation is 1; channels are correlated, so the effective number of
  independent values lies between 64 and 192 and the standard deviation of the mean z^2 between 0.10
  and 0.18 (sqrt(2 / n)); the band is +-3 sd at 64 (1 +- 0.53). A bias of one standard error per probe
  would give 2, a variance underestimated by half 2 as well;
- the summed radiance of all probes within 4 standard errors of Mitsuba's (relative figures printed).
Probes are drawn among the pixels where the reference is lit and random (the others are zero on both
sides, or the environment seen directly, deterministic: uninformative);
probes with no variance on either side (the environment seen directly) must agree to float rounding
and are left out of the z statistics.
Not here: veach-ajar (full GI through a door ajar): its paths are heavy-tailed, so at 1,024 spp the
sample variance underestimates (mean z^2 3.1, z mostly negative, sum -1.6%); at 8,192 spp mean z^2
1.31, 4 of 192 above 3, sum -0.23% (3 s): consistent with noise, too slow and too tail-sensitive for a
unit test.
"""
from __future__ import annotations

import json
import time

import numpy as np
import pytest

import manylights as ml
from conftest import REFERENCES, REPO, SCENES

PROBES = 64
MAX_OUTLIERS = 4
Z2_BAND = (0.47, 1.53)

# name: (scene xml, loader params, reference, max_depth, spp)
CASES = {
    "cbox-direct": (SCENES / "cbox" / "scene.xml", {}, "cbox-direct", 2, 4096),
    "cbox-gi": (SCENES / "cbox" / "scene.xml", {}, "cbox-gi-64", -1, 4096),
    "cbox-lights-direct": (SCENES / "cbox-lights" / "scene.xml", {}, "cbox-lights-direct", 2, 4096),
    "veach-plates-direct": (REPO / "tests" / "data" / "veach_plates.xml", {}, "veach-plates-direct", 2, 4096),
    "veach-plates-env-direct": (REPO / "tests" / "data" / "veach_plates_env.xml", {}, "veach-plates-env-direct", 2, 4096),
}


def _reference(name):
    meta = json.loads((REFERENCES / f"{name}.json").read_text())
    return ml.read_exr(REFERENCES / f"{name}.exr")[..., :3], ml.read_exr(REFERENCES / f"{name}.var.exr")[..., :3], meta


def _probes(h, w, seed=1, lit=None):
    """PROBES distinct pixels at random; with ``lit`` ((H, W) bool), only from those pixels."""
    pool = np.arange(h * w) if lit is None else np.flatnonzero(lit)
    flat = np.random.default_rng(seed).choice(pool, size=min(PROBES, pool.size), replace=False)
    return np.stack([flat // w, flat % w], axis=1)


@pytest.mark.parametrize("case", list(CASES))
def test_probes_match_mitsuba(case):
    xml, params, ref_name, max_depth, spp = CASES[case]
    ref, ref_var, meta = _reference(ref_name)
    assert meta["integrator"] == {"type": "path", "max_depth": max_depth}
    w, h = meta["size"]
    scene = ml.load_scene(xml, size=(w, h), **params)
    px = _probes(h, w, lit=(ref.sum(-1) > 0) & (ref_var.sum(-1) > 0))
    t0 = time.perf_counter()
    mean, var = ml.probe_pixels(scene, px, spp=spp, max_depth=max_depth, seed=3, progress=False)
    took = time.perf_counter() - t0
    assert mean.shape == var.shape == (PROBES, 3) and mean.dtype == var.dtype == np.float32
    r, rv = ref[px[:, 0], px[:, 1]], ref_var[px[:, 0], px[:, 1]]
    # Deterministic probes (the environment seen directly: no variance on either side) agree to float
    # rounding; the others give z-scores.
    floor = (1e-5 * r) ** 2
    det = var + rv <= floor
    assert np.allclose(mean[det], r[det], rtol=3e-5, atol=1e-7)
    z = (mean - r)[~det] / np.sqrt((var + rv + floor)[~det])
    outliers = int((np.abs(z) > 3).sum())
    z2 = float(np.mean(z * z))
    total, total_ref = float(mean.sum()), float(r.sum())
    se = float(np.sqrt((var + rv).sum()))
    print(f"\n{case}: {PROBES} probes x {spp} spp in {took:.2f} s ({PROBES * spp / took:,.0f} paths/s); "
          f"mean z^2 {z2:.2f} over {z.size}, |z| > 3: {outliers}, max |z| {np.abs(z).max():.2f}; "
          f"sum {total:.4g} vs Mitsuba {total_ref:.4g} ({(total - total_ref) / total_ref:+.2%}, "
          f"{(total - total_ref) / se:+.2f} se)")
    assert outliers <= MAX_OUTLIERS, z
    assert Z2_BAND[0] <= z2 <= Z2_BAND[1]
    assert abs(total - total_ref) <= 4 * se


def test_probes_are_seeded_and_start_at_the_image_hits():
    xml, params, _, _, _ = CASES["cbox-direct"]
    scene = ml.load_scene(xml, size=(32, 32), **params)
    px = _probes(32, 32)[:8]
    a = ml.probe_pixels(scene, px, spp=16, max_depth=2, seed=5, progress=False)
    b = ml.probe_pixels(scene, px, spp=16, max_depth=2, seed=5, progress=False)
    c = ml.probe_pixels(scene, px, spp=16, max_depth=2, seed=6, progress=False)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])
    # max_depth=1: what the camera sees directly, exactly the light matrix's emitted image.
    emitted = ml.LightMatrix(scene, ml.generate_lights(scene, area=16), device="cpu", max_depth=2).emitted()
    m1, v1 = ml.probe_pixels(scene, np.array([[r, c] for r in range(32) for c in range(32)]), spp=2, max_depth=1,
                             progress=False)
    assert np.array_equal(m1.reshape(32, 32, 3), emitted) and not v1.any()


def test_principled_is_refused(tmp_path):
    xml = tmp_path / "principled.xml"
    xml.write_text("""<scene version="3.0.0">
    <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/>
    </transform><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <shape type="sphere"><bsdf type="principled"><rgb name="base_color" value="0.5"/></bsdf></shape>
    <emitter type="constant"/>
</scene>""")
    scene = ml.load_scene(xml)
    with pytest.raises(ValueError, match="principled"):
        ml.probe_pixels(scene, [[0, 0]], spp=4, progress=False)
