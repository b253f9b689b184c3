"""The light matrix's two backends: the CPU backend (exact rays, rayon) and the GPU backend
(wgpu) give the same matrix, every renderer runs on either, and ``device="auto"`` chooses as documented.

Values are compared with ``visibility="ray_traced"`` on the GPU (the same rays as the CPU): equal to
1e-5 relative. The GPU's default hybrid visibility decides a few grazing tests from shadow maps, so
its images are compared by relative L2 instead.
"""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS

REL = 1e-5


def _differing(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of values differing by more than REL relative (+ 1e-6 of the largest value)."""
    scale = float(np.abs(a).max())
    bad = np.abs(a - b) > REL * np.maximum(np.abs(a), np.abs(b)) + 1e-6 * scale
    return float(bad.mean())


@pytest.fixture(scope="module")
def pair():
    xml, params, _ = SCENE_CONFIGS["cbox-lights"]
    scene = ml.load_scene(xml, size=(40, 40), **params)
    lights = ml.generate_lights(scene, area=200, environment=100, indirect=400, seed=4)
    cpu = ml.LightMatrix(scene, lights, device="cpu")
    gpu = ml.LightMatrix(scene, lights, device="gpu", visibility="ray_traced")
    return scene, lights, cpu, gpu


def test_backends_report_themselves(pair):
    _, _, cpu, gpu = pair
    assert cpu.device["kind"] == "cpu" and cpu.device["backend"] == "rayon" and cpu.visibility == "ray_traced"
    assert gpu.device["kind"] == "gpu" and gpu.device["name"] == ml.device_info("gpu")["name"]
    assert "cpu" in repr(cpu) and "gpu" in repr(gpu)
    # cbox-lights has an analytic sphere: its shadow rays take the library's own traversal in any build; the
    # build's own answer ("embree" with the feature) holds for a scene of triangles only.
    assert cpu.device["shadow_rays"] == "own" and gpu.device["shadow_rays"] == "gpu"
    built = ml.device_info("cpu")["shadow_rays"]
    assert built in ("embree", "own")
    xml, params, _ = SCENE_CONFIGS["cbox"]
    cbox = ml.load_scene(xml, size=(8, 8), **params)
    assert ml.LightMatrix(cbox, ml.scene_lights(cbox), device="cpu").device["shadow_rays"] == built


def test_columns_rows_and_elements_agree(pair):
    scene, lights, cpu, gpu = pair
    m, n = cpu.shape
    js = list(range(0, n, 23))
    c, g = cpu.columns(js), gpu.columns(js)
    assert (c > 0).mean() > 0.2, "too few lit elements"
    assert _differing(c, g) <= 1e-4, f"{_differing(c, g):.2e} of the column values differ"
    rows = ml.stratified_rows(scene, 30, seed=2)
    rc, rg = cpu.rows(rows, progress=False), gpu.rows(rows, progress=False)
    assert rc.shape == (30, n, 3) and (rc > 0).mean() > 0.2
    assert _differing(rc, rg) <= 1e-4, f"{_differing(rc, rg):.2e} of the row values differ"
    # Rows and columns of the CPU backend are one matrix: R[k, j] = A[rows[k], j] exactly.
    np.testing.assert_array_equal(rc[:, js], c.reshape(len(js), m, 3)[:, rows].transpose(1, 0, 2))
    for i, j in [(int(rows[3]), js[2]), (int(rows[7]), js[5])]:
        np.testing.assert_array_equal(cpu.element(i, j), c[js.index(j)].reshape(m, 3)[i])


@pytest.mark.parametrize("method", ["mrcs", "power_sampling", "brute_force"])
def test_renderers_give_the_same_image_on_both_backends(pair, method):
    scene, lights, cpu, gpu = pair
    if method == "mrcs":
        a, b = ml.mrcs(cpu, rows=60, columns=120, seed=3), ml.mrcs(gpu, rows=60, columns=120, seed=3)
        # The same rows, clusters and representatives: the reduced matrices agreed.
        np.testing.assert_array_equal(a.representatives, b.representatives)
    elif method == "power_sampling":
        a, b = ml.power_sampling(cpu, columns=150, seed=3), ml.power_sampling(gpu, columns=150, seed=3)
    else:
        a = ml.RenderResult(image=cpu.column_sum(progress=False) + cpu.emitted(), method="bf", seed=0, device=cpu.device)
        b = ml.RenderResult(image=gpu.column_sum(progress=False) + gpu.emitted(), method="bf", seed=0, device=gpu.device)
    assert a.device["kind"] == "cpu" and b.device["kind"] == "gpu"
    err = ml.relative_l2(a.image, b.image)
    assert a.image.max() > 0 and err < 1e-5, f"{method}: CPU and GPU images differ by {err:.2e}"


def test_gpu_hybrid_visibility_is_close_to_the_cpu(pair):
    scene, lights, cpu, _ = pair
    hybrid = ml.LightMatrix(scene, lights, device="gpu", visibility="hybrid")
    assert hybrid.visibility == "hybrid"
    default = ml.LightMatrix(scene, lights, device="gpu")
    assert default.visibility == ("hybrid" if default.device["is_software"] else "ray_traced")
    err = ml.relative_l2(hybrid.column_sum(progress=False), cpu.column_sum(progress=False))
    assert err < 2e-3, f"hybrid GPU visibility is {err:.2e} from exact rays"


def test_delta_chains_on_both_backends(tmp_path):
    """Mirrors and glass: a pixel's row sums its delta-chain samples on either backend."""
    from scene.test_delta_chains import _write  # the delta-chain tests' box with a mirror and a glass ball

    scene = ml.load_scene(_write(tmp_path, "box"), size=(32, 32))
    lights = ml.generate_lights(scene, area=64, seed=1)
    cpu = ml.LightMatrix(scene, lights, device="cpu", max_depth=-1)
    gpu = ml.LightMatrix(scene, lights, device="gpu", visibility="ray_traced", max_depth=-1)
    a, b = cpu.column_sum(progress=False), gpu.column_sum(progress=False)
    assert a.max() > 0 and ml.relative_l2(a, b) < 1e-5
    r = ml.stratified_rows(scene, 20, seed=0)
    assert _differing(cpu.rows(r, progress=False), gpu.rows(r, progress=False)) <= 1e-4
    # Columns fold a pixel's samples too, block by block (about 1M elements a block): 2,000 columns with
    # repeats span two blocks, the second shorter, and each repeat is the same column bit for bit.
    m, n = cpu.shape
    assert 2000 * m > 1 << 20
    js = np.arange(2000) % n
    c = cpu.columns(js)
    assert np.array_equal(c[:n], c[n:2 * n]) and np.array_equal(c[-16:], c[(2000 - 16) % n:][:16])
    assert ml.relative_l2(c[:n].sum(0), a) < 1e-5
    assert ml.relative_l2(c[:n], gpu.columns(js[:n])) < 1e-5
    # shadow_rays names pixels and casts their delta-chain samples' rays too: exactly the backend's rays.
    before = cpu.visibility_stats()["ray_casts"]
    cpu.column_sum(progress=False)
    casts = cpu.visibility_stats()["ray_casts"] - before
    rays = cpu.shadow_rays(list(range(m)), list(range(n)))
    assert len(rays["t_max"]) == casts and rays["view"].max() >= m and rays["elements"] > m * n
    assert rays["pixel"].max() < m and np.all(rays["pixel"][rays["view"] < m] == rays["view"][rays["view"] < m])


@pytest.mark.parametrize("device", ["cpu", "gpu"])
def test_zero_lights(pair, device):
    """A matrix of 0 lights is an empty matrix on either backend: its sums are 0, renderers that sample
    lights refuse it with a clear ValueError."""
    scene, lights, _, _ = pair
    empty = lights[np.array([], dtype=np.int64)]
    A = ml.LightMatrix(scene, empty, device=device)
    assert A.shape == (scene.width * scene.height, 0)
    assert not A.column_sum(progress=False).any()
    assert A.columns([]).shape == (0, scene.height, scene.width, 3)
    assert A.rows([0, 5], progress=False).shape == (2, 0, 3)
    with pytest.raises(ValueError, match=r"no lights \(n = 0\)"):
        ml.mrcs(A)
    with pytest.raises(ValueError, match=r"needs lights \(n = 0\)"):
        ml.power_sampling(A)
    with pytest.raises(ValueError, match="out of range for 0 lights"):
        A.element(0, 0)


def test_auto_follows_manylights_device(pair, monkeypatch):
    scene, lights, _, _ = pair
    software_only = ml.device_info("gpu")["is_software"]
    monkeypatch.delenv("MANYLIGHTS_DEVICE", raising=False)
    assert ml.LightMatrix(scene, lights).device["kind"] == ("cpu" if software_only else "gpu")
    # Shadow maps are a GPU feature: asking for them under "auto" chooses the GPU.
    assert ml.LightMatrix(scene, lights, visibility="shadow_map").device["kind"] == "gpu"
    monkeypatch.setenv("MANYLIGHTS_DEVICE", "gpu")
    assert ml.LightMatrix(scene, lights).device["kind"] == "gpu"
    assert ml.device_info()["kind"] == "gpu"
    # An explicit device wins over the variable.
    assert ml.LightMatrix(scene, lights, device="cpu").device["kind"] == "cpu"
    monkeypatch.setenv("MANYLIGHTS_DEVICE", "cpu")
    assert ml.LightMatrix(scene, lights).device["kind"] == "cpu"


@pytest.mark.parametrize("name", ["glossy_blend.xml", "glossy_principled.xml"])
def test_glossy_blend_weights_on_both_backends(name):
    """Glossy MIS on blended BSDFs (``tests/data/glossy_blend.xml``: roughplastic / diffuse + near-specular
    roughconductor, one weight a checkerboard) and on principled's specular lobe (``glossy_principled.xml``):
    the GPU's w_L (``shaders/common/glossy.wgsl``; a blend's mixture pdf read through its second record)
    equals the CPU's in columns and rows, and the images agree."""
    from pathlib import Path

    xml = Path(__file__).resolve().parents[1] / "data" / name
    small = ml.load_scene(xml, size=(32, 24), width=32, height=24)
    lights = ml.generate_lights(small, area=0, environment=256)
    cpu = ml.LightMatrix(small, lights, device="cpu", max_depth=2, bsdf_samples=16)
    gpu = ml.LightMatrix(small, lights, device="gpu", visibility="ray_traced", max_depth=2, bsdf_samples=16)
    bare = ml.LightMatrix(small, lights, device="cpu", max_depth=2, glossy_roughness=0.0)
    assert cpu.glossy_work == gpu.glossy_work and cpu.glossy_work[0] > 100
    js = list(range(0, 256, 3))
    c, g = np.asarray(cpu.columns(js)), np.asarray(gpu.columns(js))
    weighted = np.abs(c - np.asarray(bare.columns(js))) > 1e-3 * np.abs(c).max()
    assert weighted.sum() > 100, "too few MIS-weighted elements to compare"
    assert _differing(c, g) <= 1e-4, f"{_differing(c, g):.2e} of the column values differ"
    rows = ml.stratified_rows(small, 20, seed=1)
    assert _differing(cpu.rows(rows, progress=False), gpu.rows(rows, progress=False)) <= 1e-4
    np.testing.assert_array_equal(gpu.emitted(), cpu.emitted())
    a = cpu.column_sum(progress=False) + cpu.emitted()
    b = gpu.column_sum(progress=False) + gpu.emitted()
    assert a.max() > 0 and ml.relative_l2(a, b) < 1e-5


def test_opengl_adapters_run_no_gpu_pass():
    """An OpenGL adapter (``WGPU_BACKEND=gl``; Mesa's llvmpipe over EGL here) gets a device but runs none of
    the passes: ``device="auto"`` takes the CPU and says why, ``"gpu"`` is refused naming OpenGL. (On it the
    columns pass does not compile and the fuzzy K-means returned wrongly ordered candidates.)"""
    import json
    import os
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import json, manylights as ml
        info = ml.device_info("auto")
        s = ml.load_scene(ml.scenes.scene_path("cbox"), size=(8, 8))
        L = ml.generate_lights(s, area=8)
        try:
            ml.LightMatrix(s, L, device="gpu")
            err = None
        except Exception as e:
            err = [type(e).__name__, str(e)]
        print(json.dumps({"info": info, "err": err, "auto": ml.LightMatrix(s, L, device="auto").device["kind"]}))
    """)
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, "WGPU_BACKEND": "gl"}, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    if (r["info"].get("gpu") or {}).get("backend") != "gl":
        pytest.skip(f"no OpenGL adapter on this machine: {r['info'].get('reason')}")
    assert r["info"]["kind"] == "cpu" and "OpenGL" in r["info"]["reason"]
    assert r["err"] is not None and r["err"][0] == "GpuUnavailableError" and "OpenGL" in r["err"][1]
    assert r["auto"] == "cpu"
