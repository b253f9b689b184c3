"""The GPU path on limits it has never met here: requests past the adapter's limits or the GPU memory
budget raise MemoryError (never a PanicException) and the device keeps working; passes whose needs the
adapter does not meet make ``device="auto"`` take the CPU with the reason and ``device="gpu"`` refuse,
naming the pass and the limit; a lost device is replaced on the next call.

``MANYLIGHTS_GPU_LIMITS`` (lower the adapter's limits) and ``MANYLIGHTS_GPU_MEMORY_LIMIT`` (the budget) make
a small software adapter behave like a smaller GPU; ``_native._gpu_simulate_loss()`` marks the device
lost, as a driver reset would, so that the next call makes a new one with the changed environment.
"""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS
from manylights import _native


@pytest.fixture(scope="module")
def scene():
    xml, params, _ = SCENE_CONFIGS["cbox"]
    return ml.load_scene(xml, size=(32, 32), **params)


@pytest.fixture(scope="module")
def lights(scene):
    return ml.generate_lights(scene, area=64, seed=0)


@pytest.fixture()
def fresh_device(monkeypatch):
    """A new device after the test changes the environment, and another (unchanged) after it."""
    yield lambda: _native._gpu_simulate_loss()
    monkeypatch.delenv("MANYLIGHTS_GPU_LIMITS", raising=False)
    _native._gpu_simulate_loss()


def test_a_budget_smaller_than_the_matrix_raises_memory_error(scene, lights, monkeypatch):
    reference = ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64).columns([0, 5])
    monkeypatch.setenv("MANYLIGHTS_GPU_MEMORY_LIMIT", "1M")
    with pytest.raises(MemoryError) as e:
        ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64)
    msg = str(e.value)
    # 64^2 texels x 4 bytes x (256 MiB / 16 KiB capped at 6 x 256 layers) = 25.2 MB: over 1 MiB.
    assert "a light matrix of 1024 view samples, 64 lights" in msg and "shadow_atlas" in msg, msg
    assert "above the budget MANYLIGHTS_GPU_MEMORY_LIMIT of 1048576 bytes (1.0 MB)" in msg, msg
    # Any single buffer past the budget is refused the same way (the guarded allocation path): K-means'
    # 1000 points take 32000 bytes on the GPU.
    monkeypatch.setenv("MANYLIGHTS_GPU_MEMORY_LIMIT", "16K")
    pts = np.random.default_rng(0).random((1000, 3), dtype=np.float32)
    with pytest.raises(MemoryError, match=r"^KMeansPass::points needs 32000 bytes of GPU memory, above the budget MANYLIGHTS_GPU_MEMORY_LIMIT of 16384 bytes$"):
        _native.kmeans(pts, None, 8, device="gpu")
    monkeypatch.delenv("MANYLIGHTS_GPU_MEMORY_LIMIT")
    assert _native.kmeans(pts, None, 8, device="gpu")["device"] == "gpu"
    again = ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64).columns([0, 5])
    np.testing.assert_array_equal(again, reference)


def test_a_buffer_past_the_binding_limit_raises_memory_error(scene, lights, monkeypatch, fresh_device):
    monkeypatch.setenv("MANYLIGHTS_GPU_LIMITS", "max_storage_buffer_binding_size=64K")
    fresh_device()
    # 1024 view samples x 80 bytes = 81920 bytes in one binding.
    with pytest.raises(MemoryError, match=r"^a light matrix of 1024 view samples, 64 lights and \d+ triangles on the GPU: "
                                          r"view_samples needs a storage binding of 81920 bytes, above the adapter's "
                                          r"max_storage_buffer_binding_size of 65536 bytes$"):
        ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64)
    monkeypatch.delenv("MANYLIGHTS_GPU_LIMITS")
    fresh_device()
    assert ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64).columns([0]).shape == (1, 32, 32, 3)


def test_unmet_pass_needs_fall_back_or_refuse(scene, lights, monkeypatch, fresh_device):
    monkeypatch.delenv("MANYLIGHTS_DEVICE", raising=False)
    monkeypatch.delenv("MANYLIGHTS_ADAPTER", raising=False)
    monkeypatch.setenv("MANYLIGHTS_GPU_LIMITS", "max_storage_buffers_per_shader_stage=8")
    fresh_device()
    info = ml.device_info("auto")
    assert info["kind"] == "cpu"
    assert "ColumnsPass needs max_storage_buffers_per_shader_stage >= 13, the device allows 8" in info["reason"]
    assert len(info["gpu"]["unmet"]) == 4, info["gpu"]["unmet"]
    auto = ml.LightMatrix(scene, lights)
    assert auto.device["kind"] == "cpu"
    with pytest.raises(ml.GpuUnavailableError, match="cannot run every GPU pass: ClusteredVisibilityPass needs "
                                                     "max_storage_buffers_per_shader_stage >= 13, the device allows 8"):
        ml.LightMatrix(scene, lights, device="gpu")
    monkeypatch.setenv("MANYLIGHTS_GPU_LIMITS", "max_bogus=1")
    fresh_device()
    with pytest.raises(ValueError, match="MANYLIGHTS_GPU_LIMITS: unknown limit"):
        ml.device_info("gpu")


def test_a_lost_device_is_replaced(scene, lights):
    before = ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64)
    col = before.columns([3])
    assert _native._gpu_simulate_loss() is True
    assert ml.device_info("gpu")["gpu"]["lost"] is False
    after = ml.LightMatrix(scene, lights, device="gpu", shadow_map_size=64)
    np.testing.assert_array_equal(after.columns([3]), col)


def test_auto_says_why_it_took_the_cpu(monkeypatch):
    monkeypatch.delenv("MANYLIGHTS_DEVICE", raising=False)
    monkeypatch.delenv("MANYLIGHTS_ADAPTER", raising=False)
    info = ml.device_info("auto")
    gpu = info["gpu"]
    if gpu is None or not gpu["only_software"]:
        pytest.skip("a hardware adapter exists")
    assert info["kind"] == "cpu" and info["reason"].startswith("only software GPU adapters exist (")
    assert gpu["name"] in info["reason"] and gpu["adapters"] in info["reason"]
    assert ml.device_info("cpu")["reason"] is None


def test_memory_estimate_of_a_full_hd_matrix():
    est = _native._gpu_memory_estimate(1920, 1080, 100_000, 1_000_000)
    m = 1920 * 1080
    assert est["view_samples"] == m * 80 and est["view_bsdfs"] == m * 80 and est["accumulator"] == m * 16
    assert est["geometry"] == 1_000_000 * 36
    assert est["row_lights"] == 100_000 * 256
    assert est["column_batch"] == 128 << 20
    # 512^2 shadow maps: the 256 MiB budget holds 256 layers.
    assert est["shadow_atlas"] == 256 << 20
    assert est["total"] == sum(v for k, v in est.items() if k != "total")
