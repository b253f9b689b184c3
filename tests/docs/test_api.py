"""Python API surface: image I/O, device info, LightMatrix arguments, CLI, stub agreement."""
import ast
import os
import subprocess
import sys

import numpy as np
import pytest

import manylights as ml
from conftest import REPO


def test_exr_round_trip_and_png(tmp_path):
    rng = np.random.default_rng(1)
    img = rng.random((7, 5, 3), dtype=np.float32) * 10
    ml.write_exr(tmp_path / "a.exr", img)
    back = ml.read_exr(tmp_path / "a.exr")
    assert back.shape == (7, 5, 3) and back.dtype == np.float32
    np.testing.assert_array_equal(back, img)
    ml.write_png(tmp_path / "a.png", img)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError):
        ml.write_exr(tmp_path / "b.exr", np.zeros((4, 4)))


def test_device_info():
    info = ml.device_info()
    assert info["kind"] in {"cpu", "gpu"} and info["name"]
    assert isinstance(info["is_software"], bool)
    gpu = info["gpu"]
    assert gpu["name"] and gpu["backend"] in {"vulkan", "gl", "metal", "dx12"}
    # "auto" takes a hardware GPU, else the CPU (this machine's only adapter may be software).
    if "MANYLIGHTS_DEVICE" not in os.environ:
        assert info["kind"] == ("cpu" if gpu["is_software"] else "gpu"), info
    cpu = ml.device_info("cpu")
    assert cpu["kind"] == "cpu" and cpu["backend"] == "rayon" and cpu["threads"] >= 1 and not cpu["is_software"]
    g = ml.device_info("gpu")
    assert g["kind"] == "gpu" and g["name"] == gpu["name"] and g["threads"] == 0


@pytest.fixture(scope="module")
def demo_matrix():
    scene = ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=48)
    lights = ml.scene_lights(scene)
    return scene, lights, ml.LightMatrix(scene, lights, shadow_map_size=512)


def test_lightmatrix_columns_and_weighted_sum(demo_matrix):
    scene, lights, A = demo_matrix
    assert A.shape == (48 * 48, 3) and len(lights) == 3
    cols = A.columns([0, 1, 2])
    assert cols.shape == (3, 48, 48, 3) and cols.dtype == np.float32
    assert all(float(c.max()) > 0 for c in cols)
    w = np.array([0.5, 2.0, 1.5], np.float32)
    np.testing.assert_allclose(A.column_sum(w, progress=False), np.tensordot(w, cols, 1), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(A.column_sum(progress=False), cols.sum(0), rtol=1e-5, atol=1e-6)


def test_lightmatrix_bad_arguments(demo_matrix):
    _, _, A = demo_matrix
    with pytest.raises(ValueError, match="3"):
        A.columns([3])
    with pytest.raises(ValueError):
        A.column_sum([1.0, 2.0])
    with pytest.raises(ValueError, match="(?i)nan"):
        A.column_sum([1.0, float("nan"), 1.0])


def test_gbuffer_arrays(demo_matrix):
    scene, _, _ = demo_matrix
    gb = scene.gbuffer()
    assert gb["position"].shape == (48, 48, 3) and gb["shape_index"].dtype == np.int32
    assert set(np.unique(gb["shape_index"])) <= set(range(-1, len(scene.shapes)))
    n = np.linalg.norm(gb["normal"][gb["shape_index"] >= 0], axis=-1)
    np.testing.assert_allclose(n, 1.0, atol=1e-4)


def test_cli_render(tmp_path):
    out = tmp_path / "cli.exr"
    r = subprocess.run([sys.executable, "-m", "manylights", "render", str(REPO / "scenes" / "demo" / "scene.xml"),
                        "-o", str(out), "-D", "res=32"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert ml.read_exr(out).shape == (32, 32, 3) and out.with_suffix(".png").exists()
    bad = subprocess.run([sys.executable, "-m", "manylights", "render", str(tmp_path / "nope.xml")],
                         capture_output=True, text=True, timeout=600)
    assert bad.returncode == 1 and "nope.xml" in bad.stderr


def test_stub_matches_native_module():
    stub = ast.parse((REPO / "python" / "manylights" / "_native.pyi").read_text())
    names = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    native = {n for n in dir(ml._native) if not n.startswith("_")}
    assert names == native, f"stub only: {names - native}; native only: {native - names}"
