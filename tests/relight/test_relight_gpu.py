"""Direct-to-indirect relighting on the GPU: `ml.DirectToIndirect(..., device="gpu")`.
Checked against the dense transfer product (the gather cloud as cosine-emitting VPLs through the CPU light
matrix) and against the CPU relighting of the same transfer; device choice and bad input."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

# The scene's spot plus a point and a directional light, and the dense product T g + direct (the gather
# cloud as VPLs through the CPU light matrix): the same helpers as the CPU tests.
from test_relight import _dense, _lights

import manylights as ml

BOX = Path(__file__).parents[1] / "data" / "relight_box.xml"
GLOSSY_BOX = Path(__file__).parents[1] / "data" / "relight_glossy_box.xml"


@pytest.fixture(scope="module")
def box():
    return ml.load_scene(BOX)


def test_gpu_no_culling_equals_dense_transfer_product(box):
    lights = _lights(box)
    kw = dict(gather=4**5, final_gather_coefficients=4**5, threshold=0.0, near_field="point")
    dense = _dense(box, ml.DirectToIndirect(box, device="cpu", **kw), lights)
    for visibility, bound in [("ray_traced", 1e-5), (None, 1e-4)]:
        rel = ml.DirectToIndirect(box, device="gpu", visibility=visibility, **kw)
        assert rel.device["kind"] == "gpu"
        img = rel.relight(lights)
        assert img.shape == (32, 32, 3) and img.dtype == np.float32
        err = ml.relative_l2(img, dense)
        print(f"visibility {visibility}: GPU relight vs dense product {err:.2e}")
        # Measured: 1.6e-7 with exact rays, 1.6e-7 with the default hybrid shadow maps (no shadow decision
        # differs from the exact ray on this box; the bound leaves room for a few).
        assert err < bound
        assert rel.stats["wavelet_lights_culled"] == 0 and rel.stats["wavelet_lights"] > 900
        t = rel.timings
        assert {"relight_shadow_maps", "relight_gather_direct", "relight_view_direct", "relight_wavelet",
                "relight_transfer", "relight_readback"} <= set(t)
        assert t["relight_transfer"] > 0 and t["relight_readback"] > 0


def _culled(stats):
    return stats["wavelet_lights"], stats["wavelet_lights_culled"], stats["wavelet_lights_culled_glossy"]


@pytest.mark.parametrize("multibounce", ["photons", "gather"])
def test_gpu_equals_cpu_with_culling_and_bounces(box, multibounce):
    """Three bounces through the photon-mapped M (the default) or two through the gather-to-gather rows."""
    lights = _lights(box)
    bounces = 3 if multibounce == "photons" else 2
    kw = dict(gather=4**4, final_gather_coefficients=64, bounces=bounces, multibounce_coefficients=32,
              multibounce=multibounce, photons_per_sample=16, photon_neighbours=50)
    cpu = ml.DirectToIndirect(box, device="cpu", **kw)
    gpu = ml.DirectToIndirect(box, device="gpu", visibility="ray_traced", **kw)
    assert cpu.stats["multibounce"] == multibounce and (cpu.stats["photons"] > 0) == (multibounce == "photons")
    one = ml.DirectToIndirect(box, device="cpu", **{**kw, "bounces": 1}).relight(lights)
    for epsilon in [0.0, 0.02]:
        a, b = cpu.relight(lights, epsilon=epsilon), gpu.relight(lights, epsilon=epsilon)
        err = ml.relative_l2(b, a)
        sc, sg = cpu.stats, gpu.stats
        print(f"{multibounce} epsilon {epsilon}: GPU vs CPU {err:.2e}, culled {sg['wavelet_lights_culled']} of "
              f"{sg['wavelet_lights']}; bounces' share {ml.relative_l2(one, a):.3f}")
        # Measured on lavapipe: photons 4.4e-8 and 4.3e-8 (116 of 256 wavelet lights culled at 0.02, the
        # same on both); gather 4.4e-8 and 4.2e-8 (117 of 256). The multiple bounces are 8.7% (photons)
        # and 6.0% (gather) of the image (relative L2), so a GPU that skipped them would fail.
        assert err < 1e-6
        assert _culled(sg) == _culled(sc)
        assert ml.relative_l2(one, a) > 0.02
    assert 10 < sc["wavelet_lights_culled"] < sc["wavelet_lights"]


@pytest.mark.parametrize("bounces", [1, 3])
def test_gpu_equals_cpu_with_glossy_final_gather(bounces):
    """The glossy F_g (a rough conductor floor) alone and with the photon-mapped M, with and without
    culling: the same image up to float rounding, the same lights culled against F_d's and F_g's norms."""
    scene = ml.load_scene(GLOSSY_BOX, res=16)
    lights = ml.scene_lights(scene)
    kw = dict(gather=4**4, final_gather_coefficients=64, bounces=bounces, multibounce_coefficients=32,
              photons_per_sample=16, photon_neighbours=50)
    cpu = ml.DirectToIndirect(scene, device="cpu", **kw)
    gpu = ml.DirectToIndirect(scene, device="gpu", visibility="ray_traced", **kw)
    assert gpu.stats["glossy_pixels"] >= 20 and gpu.stats["multibounce"] == ("photons" if bounces > 1 else "none")
    no_glossy = ml.DirectToIndirect(scene, device="gpu", visibility="ray_traced", glossy=False, **kw).relight(lights)
    for epsilon in [0.0, 0.01]:
        a, b = cpu.relight(lights, epsilon=epsilon), gpu.relight(lights, epsilon=epsilon)
        err = ml.relative_l2(b, a)
        sc, sg = cpu.stats, gpu.stats
        print(f"bounces {bounces}, epsilon {epsilon}: GPU vs CPU {err:.2e}, culled {_culled(sg)}; "
              f"F_g's share {ml.relative_l2(no_glossy, b):.3f}")
        # Measured on lavapipe: 8.3e-8 / 8.4e-8 (one bounce; 19 and 62 of 91 lights culled at 0.01 against
        # F_d and F_g), 8.4e-8 / 7.9e-8 (three; 156 and 209 of 238). F_g is 21-25% of the image.
        assert err < 1e-6
        assert _culled(sg) == _culled(sc)
        if epsilon > 0:
            assert 10 < sc["wavelet_lights_culled_glossy"] < sc["wavelet_lights"]
        else:
            assert sc["wavelet_lights_culled_glossy"] == 0
    assert ml.relative_l2(no_glossy, b) > 0.05


def test_device_choice(box, monkeypatch):
    kw = dict(gather=16, final_gather_coefficients=4)
    monkeypatch.delenv("MANYLIGHTS_DEVICE", raising=False)
    assert ml.DirectToIndirect(box, device="cpu", **kw).device["kind"] == "cpu"
    # "auto" picks as the light matrix does: a hardware GPU, else the CPU (faster than a software adapter).
    auto = ml.DirectToIndirect(box, **kw).device
    assert auto["kind"] == ml.device_info("auto")["kind"]
    if ml.device_info("gpu")["is_software"]:
        assert auto["kind"] == "cpu"
    monkeypatch.setenv("MANYLIGHTS_DEVICE", "gpu")
    assert ml.DirectToIndirect(box, **kw).device["kind"] == "gpu"
    assert ml.DirectToIndirect(box, device="cpu", **kw).device["kind"] == "cpu"
    # Shadow-map visibility asks for the GPU.
    monkeypatch.delenv("MANYLIGHTS_DEVICE")
    assert ml.DirectToIndirect(box, visibility="hybrid", **kw).device["kind"] == "gpu"


def test_gpu_bad_input(box, monkeypatch):
    kw = dict(gather=16, final_gather_coefficients=4)
    with pytest.raises(ValueError, match="'auto', 'gpu' or 'cpu'.*cuda"):
        ml.DirectToIndirect(box, device="cuda", **kw)
    with pytest.raises(TypeError, match="device"):
        ml.DirectToIndirect(box, device=1, **kw)
    with pytest.raises(ValueError, match="visibility.*bogus"):
        ml.DirectToIndirect(box, device="gpu", visibility="bogus", **kw)
    with pytest.raises(TypeError, match="visibility"):
        ml.DirectToIndirect(box, visibility=2, **kw)
    with pytest.raises(ValueError, match="shadow maps.*CPU"):
        ml.DirectToIndirect(box, device="cpu", visibility="shadow_map", **kw)
    with pytest.raises(ValueError, match="shadow_map_size"):
        ml.DirectToIndirect(box, device="gpu", shadow_map_size=8, **kw)
    monkeypatch.setenv("MANYLIGHTS_DEVICE", "tpu")
    with pytest.raises(ValueError, match="MANYLIGHTS_DEVICE.*tpu"):
        ml.DirectToIndirect(box, **kw)
    monkeypatch.delenv("MANYLIGHTS_DEVICE")
    rel = ml.DirectToIndirect(box, device="gpu", **kw)
    with pytest.raises(ValueError, match="empty"):
        rel.relight(ml.scene_lights(box)[0:0])
    for eps in [-1.0, float("nan"), float("inf")]:
        with pytest.raises(ValueError, match="epsilon"):
            rel.relight(ml.scene_lights(box), epsilon=eps)
    with pytest.raises(TypeError):
        rel.relight("lights")
