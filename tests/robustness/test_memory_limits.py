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
# the allocation fails inside Rust and the process aborts (SIGABRT, "memory allocation failed"). The limit is
# the address space the child itself uses before the request (measured in an unlimited child: it differs
# between machines, with the number of cores and the libraries numpy brings) plus a margin smaller than the
# request, so the test asks the same question everywhere.
ULIMIT_CHILD = r"""
import sys, manylights as ml
which, measure = sys.argv[1], len(sys.argv) > 3

def vm_kib():
    f = {l.split(":")[0]: l.split()[1] for l in open("/proc/self/status") if l.startswith(("VmSize:", "VmData:"))}
    return f["VmSize"] + " " + f["VmData"]

s = ml.load_scene(sys.argv[2], res=32)
try:
    if which == "columns":
        A = ml.LightMatrix(s, ml.generate_lights(s, area=64, seed=0), device="cpu")
        A.columns([0] * 16)
        if measure:
            print("VM", vm_kib()); sys.exit(0)
        A.columns([0] * 150000)
    elif which == "generate_lights":
        ml.generate_lights(s, area=1000, seed=0)
        if measure:
            print("VM", vm_kib()); sys.exit(0)
        ml.generate_lights(s, area=8_000_000, seed=0)
    elif which in ("gpu columns", "gpu device"):
        L = ml.generate_lights(s, area=64, seed=0)
        if measure and which == "gpu device":
            print("VM", vm_kib()); sys.exit(0)
        try:
            A = ml.LightMatrix(s, L, device="gpu", shadow_map_size=64)
        except ml.GpuUnavailableError as e:
            print("GpuUnavailableError:", e)
            print("auto:", ml.LightMatrix(s, L, device="auto", shadow_map_size=64).device["kind"], ml.device_info("auto"))
            sys.exit(0)
        A.columns([0] * 16)
        if measure:
            print("VM", vm_kib()); sys.exit(0)
        A.columns([0] * 300000)
    print("RETURNED")
except MemoryError as e:
    print("MemoryError:", e)
"""


def _ulimit_child(which: str, limit: str | None, kib: int = 0):
    import resource
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]

    def set_limit():
        if limit:
            lim = getattr(resource, limit)
            resource.setrlimit(lim, (kib * 1024, resource.RLIM_INFINITY))

    args = [sys.executable, "-c", ULIMIT_CHILD, which, str(repo / "scenes" / "demo" / "scene.xml")]
    if limit is None:
        args.append("measure")
    # The first adapter (hardware before software): MANYLIGHTS_ADAPTER would turn device="auto"'s fallback
    # into an error.
    env = {k: v for k, v in __import__("os").environ.items() if k != "MANYLIGHTS_ADAPTER"}
    p = subprocess.run(args, preexec_fn=set_limit, capture_output=True, text=True, timeout=300,
                       env={**env, "PYTHONPATH": str(repo / "python")})
    assert p.returncode == 0, f"exit status {p.returncode} (an abort is -6): {p.stderr[-1500:]}"
    return p


def _vm_kib(which: str, limit: str = "RLIMIT_AS") -> int:
    """KiB of address space (RLIMIT_AS: VmSize) or data segment (RLIMIT_DATA: VmData) the child uses before its
    request."""
    p = _ulimit_child(which, None)
    if p.stdout.startswith("GpuUnavailableError:"):
        pytest.skip("no GPU adapter: " + p.stdout.splitlines()[0])
    size, data = p.stdout.split("VM")[1].split()[:2]
    return int(size if limit == "RLIMIT_AS" else data)


@pytest.mark.parametrize("limit", ["RLIMIT_AS", "RLIMIT_DATA"])
@pytest.mark.parametrize("which", ["columns", "generate_lights", "gpu columns"])
def test_requests_past_an_address_space_limit_raise_memoryerror_in_a_child(which, limit):
    if limit == "RLIMIT_DATA" and which == "gpu columns":
        pytest.skip("one GPU case (ulimit -v) suffices")
    # Room of 1 GB (1.5 GB with a GPU device, which must keep its driver's reserve at device creation) for
    # requests of 1.84, 1.89 and 3.69 GB.
    margin = 1_500_000 if which == "gpu columns" else 1_000_000
    kib = _vm_kib(which, limit) + margin
    if which == "gpu columns":
        kib = max(kib, _vm_kib("gpu device", limit) + 2_400_000)
    p = _ulimit_child(which, limit, kib)
    assert p.stdout.startswith("MemoryError:"), p.stdout + p.stderr[-1500:]
    needs = {"columns": "1.84 GB", "gpu columns": "3.69 GB", "generate_lights": "1.89 GB"}[which]
    assert needs in p.stdout and "ulimit -v / -d" in p.stdout, p.stdout


def test_no_gpu_device_is_created_under_a_limit_its_driver_cannot_work_in():
    """GPU drivers reserve about 2 GB of address space creating a device and compiling shaders and abort the
    process when they cannot (NVIDIA's: "LLVM ERROR: out of memory"); under a limit leaving 1 GB of room,
    device="gpu" raises GpuUnavailableError naming the limit and device="auto" runs on the CPU, saying why."""
    kib = _vm_kib("gpu device") + 1_000_000
    p = _ulimit_child("gpu device", "RLIMIT_AS", kib)
    assert p.stdout.startswith("GpuUnavailableError:"), p.stdout + p.stderr[-1500:]
    assert "ulimit -v" in p.stdout and "2.15 GB" in p.stdout, p.stdout
    auto = p.stdout.split("auto:")[1]
    assert auto.split()[0] == "cpu" and "ulimit -v" in auto, auto
