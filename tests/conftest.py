"""Shared fixtures: where the test scenes are, Mitsuba references, and failure images."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]

#: The scenes bundled with the package (cbox, cbox-lights, veach-ajar, demo, bounce).
SCENES = REPO / "scenes"
#: Scenes only the tests read (matpreview, bunny: tests/data/README.md), not part of the package.
TEST_SCENES = REPO / "tests" / "data" / "scenes"

# Test configurations per test scene: (xml, loader params, film size (W, H)). Sizes keep each film's
# aspect ratio; Mitsuba rays use normalised film positions, so its own film size does not matter.
SCENE_CONFIGS = {
    "cbox": (SCENES / "cbox" / "scene.xml", {"res": 128}, (128, 128)),
    "cbox-lights": (SCENES / "cbox-lights" / "scene.xml", {"res": 128}, (128, 128)),
    "matpreview": (TEST_SCENES / "matpreview" / "scene.xml", {"width": 128, "height": 96}, (128, 96)),
    "bunny": (TEST_SCENES / "bunny" / "scene.xml", {}, (128, 96)),
    "veach-ajar": (SCENES / "veach-ajar" / "scene.xml", {"resx": 128, "resy": 72}, (128, 72)),
}

FAILURES = REPO / "tests" / "_failures"
REFERENCES = REPO / "tests" / "references"


def cbox_gi_64():
    """cbox full GI at the size of its Mitsuba reference ``cbox-gi-64`` (64x64, noise 0.19%): (scene, reference
    (H, W, 3) float32)."""
    import json

    import manylights as ml

    meta = json.loads((REFERENCES / "cbox-gi-64.json").read_text())
    xml, params, _ = SCENE_CONFIGS["cbox"]
    scene = ml.load_scene(xml, size=tuple(meta["size"]), **{k: v for k, v in params.items() if k != "res"})
    return scene, ml.read_exr(REFERENCES / "cbox-gi-64.exr")[..., :3]


def save_failure_images(name: str, **images) -> Path:
    """Write the images of a failing comparison (EXR) to tests/_failures/<name>/ (git-ignored)."""
    import manylights as ml

    d = FAILURES / name
    d.mkdir(parents=True, exist_ok=True)
    for k, v in images.items():
        v = np.asarray(v, dtype=np.float32)
        if v.ndim == 2:
            v = np.repeat(v[..., None], 3, axis=-1)
        ml.write_exr(d / f"{k}.exr", v)
    return d


@pytest.fixture(scope="session")
def mitsuba_ref():
    """The reference module with Mitsuba imported. Mitsuba is a test dependency, so nothing is skipped, except
    where ``MANYLIGHTS_SKIP_MITSUBA=1`` says this machine has none (``make gpu-check`` on a GPU machine that
    has only the built extension)."""
    import os

    from manylights.testing import mitsuba as reference

    if os.environ.get("MANYLIGHTS_SKIP_MITSUBA") == "1":
        pytest.skip("MANYLIGHTS_SKIP_MITSUBA=1: no Mitsuba on this machine")

    reference.mitsuba()
    return reference


def seed_total_z(runs, truth, bias: float = 1.0) -> float:
    """z of the image total of the mean over ``runs`` (RenderResults of independent seeds, each with its
    per-pixel ``error_image``, the RMS over channels of the sample variance's square root) against
    ``bias x truth``: the variance of the mean is sum(error_image^2) / seeds^2 per pixel, x 3 channels."""
    import numpy as np

    seeds = len(runs)
    mean = np.mean([r.image for r in runs], axis=0).astype(np.float64)
    var = np.sum([np.square(r.error_image.astype(np.float64)) for r in runs], axis=0) / seeds**2
    return float((mean - bias * truth).sum() / np.sqrt(3 * var.sum()))
