"""Mitsuba 3.9.1's ``roughdielectric`` and ``thindielectric`` in a render (the BSDF values themselves are
checked against ``bsdf.eval`` in ``test_dielectric_bsdf.py``).

Against a converged Mitsuba pixel-centre reference (``tests/references/rough-glass-direct``, ``path`` with
max_depth 2; ``tests/data/rough_glass.xml``): two rough glass panes lit from the camera's side (reflection)
and from behind (transmission: that point light reaches the camera only through the glass), one of them
seen from inside (eta < 1), and an area light seen only through a thin pane. The relative L2 error of our
direct light (exact point lights, delta chains through the thin pane) must be within 1.5x the reference's
noise, on the CPU and the GPU backends. Without the light behind the panes the error is far larger (the
transmission lobe is what the test measures), and a smooth ``dielectric`` in place of the thin pane (a
single interface bends and scales the transmitted radiance) is far off too.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import manylights as ml

HERE = Path(__file__).resolve().parents[1]
REFS = HERE / "references"
XML = HERE / "data" / "rough_glass.xml"
TOL_NOISE = 1.5


def _render(path, device="cpu"):
    scene = ml.load_scene(path)
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=0), device=device, max_depth=2)
    return np.asarray(A.column_sum(progress=False)) + A.emitted()


@pytest.fixture(scope="module")
def reference():
    meta = json.loads((REFS / "rough-glass-direct.json").read_text())
    assert meta["integrator"] == {"type": "path", "max_depth": 2} and meta["mitsuba"] == "3.9.1"
    ref, var = ml.read_exr(REFS / "rough-glass-direct.exr"), ml.read_exr(REFS / "rough-glass-direct.var.exr")
    den = float((ref.astype(np.float64) ** 2).sum())
    return ref, float(np.sqrt(var.sum() / den)), den


@pytest.mark.parametrize("device", ["cpu", "gpu"])
def test_rough_and_thin_glass_match_mitsuba(reference, device):
    ref, noise, den = reference
    img = _render(XML, device)
    err = float(np.sqrt(((img - ref) ** 2).sum() / den))
    print(f"\nrough-glass-direct ({device}): relative L2 {err:.3%} (reference noise {noise:.3%})")
    assert err <= TOL_NOISE * noise


@pytest.mark.parametrize("old, new, what", [
    ('<point name="position" x="1" y="1" z="-5"/>', '<point name="position" x="1" y="1" z="-50"/>',
     "the light behind the rough panes moved away"),
    ('<bsdf type="thindielectric">', '<bsdf type="dielectric">', "a smooth dielectric for the thin pane"),
])
def test_the_reference_tells_the_lobes_apart(reference, tmp_path, old, new, what):
    ref, noise, den = reference
    text = XML.read_text()
    assert old in text
    variant = tmp_path / "variant.xml"
    variant.write_text(text.replace(old, new))
    err = float(np.sqrt(((_render(variant) - ref) ** 2).sum() / den))
    print(f"\n{what}: relative L2 {err:.2%} (reference noise {noise:.3%})")
    assert err >= 10 * noise


def test_probe_path_tracer_matches_the_reference_on_rough_glass(reference):
    """The probe path tracer (``ml.probe_pixels``) emitter-samples at roughdielectric vertices (both sides)
    and BSDF-samples their lobes: probes on both rough panes agree with the reference within 4 sigma."""
    ref, _, _ = reference
    var = ml.read_exr(REFS / "rough-glass-direct.var.exr")
    scene = ml.load_scene(XML)
    pixels = np.array([(r, c) for r in (14, 20, 26, 29) for c in (36, 38, 42, 46)])
    mean, pvar = ml.probe_pixels(scene, pixels, spp=64, max_depth=2, progress=False)
    r = ref[pixels[:, 0], pixels[:, 1]]
    v = var[pixels[:, 0], pixels[:, 1]]
    assert np.all(r.max(axis=1) > 0.01), r
    z = np.abs(mean - r) / np.sqrt(pvar + v + 1e-12)
    print(f"\nprobes on rough glass: max |z| {z.max():.2f}, max relative difference {np.max(np.abs(mean - r) / r):.2e}")
    assert z.max() < 4.0
