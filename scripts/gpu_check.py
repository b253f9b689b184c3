"""`make gpu-check`: the GPU path on the first hardware adapter, in one prepared run (under 5 minutes).

Runs from an existing build (it builds nothing, so a build made beforehand can be carried to the GPU
machine): reports the adapter and its limits, runs the GPU-path tests, then `bench backends` (and
`bench scale` where it exists) at a small size, and writes everything to one JSON file
(``gpu-check.json``, or the path given). Fails loudly (exit status 2, before running anything) when the
only adapters are software ones (lavapipe, llvmpipe); ``--allow-software`` runs anyway, for trying the
script itself.

    python scripts/gpu_check.py [--out gpu-check.json] [--allow-software]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# The GPU-path tests: backends, columns/rows, clustered visibility, K-means, relighting, tensor
# reconstruction and the limits/memory/loss tests.
TESTS = [
    "tests/matrix",
    "tests/robustness/test_gpu_limits.py",
    "tests/robustness/test_memory_limits.py",
    "tests/renderers/test_clustered_visibility.py",
    "tests/renderers/test_kmeans.py",
    "tests/relight/test_relight_gpu.py",
    "tests/animation/test_tensor_animation.py",
]
# Seconds each step may take (the whole run stays under 5 minutes).
LIMITS = {"tests": 180, "bench backends": 60, "bench scale": 45}


def run(step: str, cmd: list[str], env: dict[str, str]) -> dict:
    t = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=LIMITS[step])
        rc, out = p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired as e:
        rc, out = 124, f"timed out after {LIMITS[step]} s\n{(e.stdout or b'')[-4000:]!r}"
    return {"step": step, "command": " ".join(cmd), "returncode": rc, "seconds": round(time.perf_counter() - t, 2),
            "output_tail": out[-6000:]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="gpu-check.json")
    ap.add_argument("--allow-software", action="store_true")
    args = ap.parse_args()
    import manylights as ml
    from manylights import _native

    env = dict(os.environ)
    if not args.allow_software:
        env["MANYLIGHTS_ADAPTER"] = "hardware"
    report: dict = {"started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "steps": []}
    info = ml.device_info("auto")
    report["device_info"] = info
    report["estimate_1920x1080_100k_lights_1M_triangles"] = _native._gpu_memory_estimate(1920, 1080, 100_000, 1_000_000)
    gpu = info.get("gpu")
    if gpu is None or (gpu["only_software"] and not args.allow_software):
        report["error"] = ("no hardware GPU adapter: only " + (gpu["adapters"] if gpu else "no adapter at all")
                           + "; run on a machine with a GPU driver (or pass --allow-software to try the script)")
        Path(args.out).write_text(json.dumps(report, indent=1, default=str))
        print(f"gpu-check FAILED: {report['error']}", file=sys.stderr)
        return 2
    report["steps"].append(run("tests", [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *TESTS], env))
    bench_out = REPO / "target" / "gpu-check"
    bench_out.mkdir(parents=True, exist_ok=True)
    report["steps"].append(run("bench backends", [sys.executable, "-m", "manylights.bench", "backends", "--scene", "cbox",
                                                  "--res", "64", "--lights", "256", "--row-lights", "256", "--columns",
                                                  "32", "--rows", "16", "--repeats", "1", "--out",
                                                  str(bench_out / "backends.json")], env))
    help_text = subprocess.run([sys.executable, "-m", "manylights.bench", "--help"], cwd=REPO, env=env,
                               capture_output=True, text=True).stdout
    if " scale" in help_text:
        report["steps"].append(run("bench scale", [sys.executable, "-m", "manylights.bench", "scale", "--help"], env))
    for name in ("backends.json",):
        f = bench_out / name
        if f.exists():
            report[name] = json.loads(f.read_text())
    failed = [s["step"] for s in report["steps"] if s["returncode"] != 0]
    report["failed"] = failed
    Path(args.out).write_text(json.dumps(report, indent=1, default=str))
    print(f"gpu-check: {gpu['name']} ({gpu['backend']}); "
          + (f"FAILED: {', '.join(failed)}" if failed else "every step passed") + f"; report in {args.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
