"""G-buffer (view samples at pixel centres) against Mitsuba's own ray intersection on all shared scenes."""
import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS, save_failure_images

# Acceptance: >= 99.5% of pixels agree on each of these.
MIN_AGREEMENT = 0.995
# Positions within this fraction of the scene's bounding-box diagonal.
POSITION_TOL = 1e-3
# Normals agree when their dot product exceeds this.
NORMAL_DOT = 0.999


def _match_shapes(ours: ml.Scene, ref_bbox: np.ndarray) -> np.ndarray:
    """Map Mitsuba's shape indices (+1, so that index 0 is a miss) to ours by bounding boxes."""
    ours_bbox = np.array([[s["bbox_min"], s["bbox_max"]] for s in ours.shapes], dtype=np.float32)
    mapping = np.full(len(ref_bbox) + 1, -1, np.int32)
    for k, bb in enumerate(ref_bbox):
        d = np.abs(ours_bbox - bb[None]).reshape(len(ours_bbox), -1).max(axis=1)
        mapping[k + 1] = int(np.argmin(d))
        diag = float(np.linalg.norm(bb[1] - bb[0])) + 1e-6
        assert d.min() <= 1e-3 * diag + 1e-4, f"Mitsuba shape {k} has no counterpart (bbox {bb}, off by {d.min()})"
    return mapping


_REFS = {}


@pytest.mark.parametrize("device", ["cpu", "gpu"])
@pytest.mark.parametrize("name", list(SCENE_CONFIGS))
def test_gbuffer_matches_mitsuba(name, device, mitsuba_ref):
    """Both G-buffers: the GPU's raster visibility and the CPU backend's ray casting through the BVH."""
    xml, params, (w, h) = SCENE_CONFIGS[name]
    scene = ml.load_scene(xml, size=(w, h), **params)
    assert (scene.width, scene.height) == (w, h)
    gb = scene.gbuffer(device)
    if name not in _REFS:
        _REFS[name] = mitsuba_ref.mitsuba_gbuffer(xml, (w, h), **params)
    ref = _REFS[name]
    mapping = _match_shapes(scene, ref["shape_bbox"])
    ref_sid = mapping[ref["shape_index"] + 1]
    lo, hi = scene.bounds
    diag = float(np.linalg.norm(np.array(hi) - np.array(lo)))

    same = gb["shape_index"] == ref_sid
    hit = same & (ref_sid >= 0)
    pos_ok = np.linalg.norm(gb["position"] - ref["position"], axis=-1) <= POSITION_TOL * diag
    n_ok = (gb["normal"] * ref["normal"]).sum(-1) > NORMAL_DOT
    g_ok = (gb["geo_normal"] * ref["geo_normal"]).sum(-1) > NORMAL_DOT
    frac = {
        "shape_index": same.mean(),
        "position": (pos_ok | ~hit)[same].mean(),
        "normal": (n_ok | ~hit)[same].mean(),
        "geo_normal": (g_ok | ~hit)[same].mean(),
    }
    if min(frac.values()) < MIN_AGREEMENT:
        save_failure_images(f"gbuffer-{name}-{device}", ours_position=gb["position"], ref_position=ref["position"],
                            ours_normal=gb["normal"], ref_normal=ref["normal"],
                            shape_mismatch=(~same).astype(np.float32))
    print(f"{name} ({device}):", {k: f"{v:.4%}" for k, v in frac.items()})
    for k, v in frac.items():
        assert v >= MIN_AGREEMENT, f"{name} ({device}): only {v:.4%} of pixels agree on {k} ({frac})"
