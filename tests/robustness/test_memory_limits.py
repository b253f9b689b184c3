"""Requests that cannot fit in memory are refused before allocating: MemoryError naming
the request and the limit, never an abort or an OOM kill; the same objects keep working afterwards.

``MANYLIGHTS_MEMORY_LIMIT`` lowers the host memory the checks allow, which makes the requests below
"too large" on any machine; the sizes in the messages are exact (r x n x 12 bytes for rows ...).
"""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS


@pytest.fixture(scope="module")
def scene():
    xml, params, _ = SCENE_CONFIGS["cbox"]
    return ml.load_scene(xml, size=(32, 32), **params)


@pytest.fixture(scope="module")
def matrix(scene):
    return ml.LightMatrix(scene, ml.generate_lights(scene, area=300, seed=0))


def test_rows_too_large_for_host_memory(matrix, monkeypatch):
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "2M")
    r, n = 1000, matrix.shape[1]
    with pytest.raises(MemoryError) as e:
        matrix.rows(np.arange(r), progress=False)
    msg = str(e.value)
    # 1000 x 300 x 12 bytes = 3.6 MB against the 2 MiB limit.
    assert f"rows: {r} rows x {n} lights x RGB float32" in msg and "3.6 MB" in msg and "2.1 MB" in msg, msg
    # Within the limit the same matrix still gives rows, equal to its columns.
    small = matrix.rows([100, 600], progress=False)
    assert small.shape == (2, n, 3)
    monkeypatch.delenv("MANYLIGHTS_MEMORY_LIMIT")
    R = matrix.rows(np.arange(r), progress=False)
    np.testing.assert_array_equal(R[[100, 600]], small)


def test_columns_too_large_for_host_memory(matrix, monkeypatch):
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "100K")
    with pytest.raises(MemoryError, match=r"columns: 10 columns x 1024 view samples x RGB float32 needs 122880 bytes "
                                          r".* only 102400 bytes"):
        matrix.columns(range(10))
    assert matrix.columns([0, 1]).shape == (2, 32, 32, 3)


def test_generate_lights_too_many_for_host_memory(scene, monkeypatch):
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "64M")
    with pytest.raises(MemoryError, match="generate_lights: 1000000 area .* needs 236.0 MB .* only 67.1 MB"):
        ml.generate_lights(scene, area=1_000_000)
    # Indexing with a huge repeated index array: 1e6 x 236 bytes (the 4-corner patch added 48, the VSL radius 4, the glossy-MIS measure and mesh 8).
    lights = ml.generate_lights(scene, area=8, seed=0)
    with pytest.raises(MemoryError, match="a LightSet of 1000000 selected lights needs 236.0 MB"):
        lights[np.zeros(1_000_000, dtype=np.int64)]
    assert len(lights[np.zeros(1000, dtype=np.int64)]) == 1000


def test_film_too_large_for_host_memory(monkeypatch):
    xml, params, _ = SCENE_CONFIGS["cbox"]
    big = ml.load_scene(xml, size=(4096, 4096), **params)
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "256M")
    with pytest.raises(MemoryError, match="view samples of a 4096x4096 film"):
        ml.LightMatrix(big, ml.generate_lights(big, area=4))


def test_shadow_maps_too_large(scene, monkeypatch):
    # Shadow maps exist only on the GPU backend: pin it (under "auto" this machine would use the CPU).
    if not ml.device_info("gpu")["is_software"]:
        pytest.skip("shadow maps live in GPU memory here; the adapter reports no memory size to check against")
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "256M")
    lights = ml.generate_lights(scene, area=4, seed=0)
    # At least one cube (6 layers) of 8192^2 float32 texels = 1.61 GB.
    with pytest.raises(MemoryError, match=r"shadow maps: \d+ layers of 8192\^2 texels \(shadow_map_size = 8192\)"):
        ml.LightMatrix(scene, lights, shadow_map_size=8192, device="gpu")
    A = ml.LightMatrix(scene, lights, shadow_map_size=64, device="gpu")
    with pytest.raises(MemoryError, match=r"rows: a 8192\^2 cube depth map"):
        A.rows([0], shadow_map_size=8192, progress=False)
    assert A.rows([0, 500], shadow_map_size=64, progress=False).shape == (2, 4, 3)


def test_bad_memory_limit_setting(matrix, monkeypatch):
    monkeypatch.setenv("MANYLIGHTS_MEMORY_LIMIT", "lots")
    with pytest.raises(ValueError, match="MANYLIGHTS_MEMORY_LIMIT must be a byte count .* got \"lots\""):
        matrix.rows([0], progress=False)


# --- Address-space and data-segment limits (ulimit -v / ulimit -d) -------------------------------------------
# Each request runs in a child process whose limit is set before it starts; without the limit in the policy
# the allocation fails inside Rust and the process aborts (SIGABRT, "memory allocation failed").
ULIMIT_CHILD = r"""
import sys, manylights as ml
which = sys.argv[1]
s = ml.load_scene(sys.argv[2], res=32)
try:
    if which == "columns":
        ml.LightMatrix(s, ml.generate_lights(s, area=64, seed=0), device="cpu").columns([0] * 150000)
    elif which == "generate_lights":
        ml.generate_lights(s, area=8_000_000, seed=0)
    elif which == "gpu columns":
        L = ml.generate_lights(s, area=64, seed=0)
        try:
            A = ml.LightMatrix(s, L, device="gpu", shadow_map_size=64)
        except MemoryError:
            raise
        except Exception as e:  # no adapter on this machine
            print("NO GPU:", e)
            sys.exit(0)
        A.columns([0] * 300000)
    print("RETURNED")
except MemoryError as e:
    print("MemoryError:", e)
"""


@pytest.mark.parametrize("limit", ["RLIMIT_AS", "RLIMIT_DATA"])
@pytest.mark.parametrize("which", ["columns", "generate_lights", "gpu columns"])
def test_requests_past_an_address_space_limit_raise_memoryerror_in_a_child(which, limit):
    import resource
    import subprocess
    import sys
    from pathlib import Path

    if limit == "RLIMIT_DATA" and which == "gpu columns":
        pytest.skip("one GPU case (ulimit -v) suffices")
    repo = Path(__file__).resolve().parents[2]
    lim = getattr(resource, limit)

    # ulimit -v 1500000 (KiB) / ulimit -d 1500000; 2000000 with a GPU device: Mesa's software driver reserves
    # about 1.5 GB of address space compiling the passes' shaders, and crashes (SIGSEGV) when it cannot.
    kib = 2_000_000 if which == "gpu columns" else 1_500_000

    def set_limit():
        resource.setrlimit(lim, (kib * 1024, resource.RLIM_INFINITY))

    p = subprocess.run([sys.executable, "-c", ULIMIT_CHILD, which, str(repo / "scenes" / "demo" / "scene.xml")],
                       preexec_fn=set_limit, capture_output=True, text=True, timeout=300,
                       env={**__import__("os").environ, "PYTHONPATH": str(repo / "python")})
    assert p.returncode == 0, f"exit status {p.returncode} (an abort is -6): {p.stderr[-1500:]}"
    if p.stdout.startswith("NO GPU:"):
        pytest.skip(p.stdout.strip())
    assert p.stdout.startswith("MemoryError:"), p.stdout + p.stderr[-1500:]
    needs = {"columns": "1.84 GB", "gpu columns": "3.69 GB", "generate_lights": "1.89 GB"}[which]
    assert needs in p.stdout and "ulimit -v / -d" in p.stdout, p.stdout
