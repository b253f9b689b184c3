"""`make gpu-check`: the GPU path on the first hardware adapter, in one prepared run (under 5 minutes).

Runs from an existing build (it builds nothing, so a build made beforehand can be carried to the GPU
machine): reports the adapter and its limits, runs the GPU-path tests, then `bench backends` and
`bench scale --small` on the GPU, and writes everything to one JSON file (``gpu-check.json``, or the path
given), rewritten after every step so that a run cut short keeps what it measured. Fails loudly (exit status
2, before running anything) when the only adapters are software ones (lavapipe, llvmpipe);
``--allow-software`` runs anyway, for trying the script itself. ``--extended`` adds, for the docs' figures
(a few more minutes): every other test with a GPU case (``-k gpu``), `bench backends` at 256 pixels wide on
cbox and veach-ajar, and the MRCS paper-size point (``bench scale --axes paper``) on the GPU and on the CPU
of the same machine.

    python scripts/gpu_check.py [--out gpu-check.json] [--allow-software] [--extended]
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
# The whole output of each step.
LOGS = REPO / "target" / "gpu-check" / "logs"
# Seconds each step may take (the default steps stay under 5 minutes together).
LIMITS = {"tests": 150, "bench backends": 50, "bench scale": 75,
          "other GPU tests": 110, "bench backends 256": 60, "paper point gpu": 100, "paper point cpu": 100}


def run(step: str, cmd: list[str], env: dict[str, str]) -> dict:
    t = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=LIMITS[step])
        rc, out = p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired as e:
        rc, out = 124, f"timed out after {LIMITS[step]} s\n{(e.stdout or b'')[-4000:]!r}"
    LOGS.mkdir(parents=True, exist_ok=True)
    (LOGS / (step.replace(" ", "-") + ".log")).write_text(out)
    return {"step": step, "command": " ".join(cmd), "returncode": rc, "seconds": round(time.perf_counter() - t, 2),
            "output_tail": out[-6000:]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="gpu-check.json")
    ap.add_argument("--allow-software", action="store_true")
    ap.add_argument("--extended", action="store_true", help="more tests and the paper-size point (a few minutes)")
    args = ap.parse_args()
    import manylights as ml
    from manylights import _native

    env = dict(os.environ)
    try:
        import mitsuba  # noqa: F401
    except ImportError:  # a GPU machine with only the built extension: the tests against Mitsuba skip
        env["MANYLIGHTS_SKIP_MITSUBA"] = "1"
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
    bench_out = REPO / "target" / "gpu-check"
    bench_out.mkdir(parents=True, exist_ok=True)
    py = [sys.executable, "-m"]

    def save():
        report["failed"] = [s["step"] for s in report["steps"] if s["returncode"] != 0]
        Path(args.out).write_text(json.dumps(report, indent=1, default=str))

    def step(name, cmd, json_out=None):
        report["steps"].append(run(name, cmd, env))
        if json_out is not None and json_out.exists():
            report[name + " result"] = json.loads(json_out.read_text())
        save()
        print(f"{name}: returncode {report['steps'][-1]['returncode']}, {report['steps'][-1]['seconds']} s",
              flush=True)

    step("tests", py + ["pytest", "-q", "-p", "no:cacheprovider", "--durations=15", *TESTS])
    step("bench backends", py + ["manylights.bench", "backends", "--scene", "cbox", "--res", "64", "--lights", "256",
                                 "--row-lights", "256", "--columns", "32", "--rows", "16", "--repeats", "1",
                                 "--out", str(bench_out)], bench_out / "backends.json")
    step("bench scale", py + ["manylights.bench", "scale", "--small", "--device", "gpu", "--axes", "pixels", "lights",
                              "triangles", "--out", str(bench_out / "scale")], bench_out / "scale" / "scale.json")
    if args.extended:
        step("paper point gpu", py + ["manylights.bench", "scale", "--device", "gpu", "--axes", "paper",
                                      "--out", str(bench_out / "paper-gpu")], bench_out / "paper-gpu" / "scale.json")
        step("bench backends 256", py + ["manylights.bench", "backends", "--scene", "cbox", "veach-ajar", "--res",
                                         "256", "--lights", "1024", "--row-lights", "4096", "--columns", "128",
                                         "--rows", "64", "--repeats", "2", "--gpu-visibility", "hybrid",
                                         "ray_traced", "shadow_map", "--out", str(bench_out / "backends-256")],
             bench_out / "backends-256" / "backends.json")
        step("other GPU tests", py + ["pytest", "-q", "-p", "no:cacheprovider", "-k", "gpu", "--durations=15",
                                      "--continue-on-collection-errors",
                                      *[f"--ignore={t}" for t in TESTS], "tests"])
        step("paper point cpu", py + ["manylights.bench", "scale", "--device", "cpu", "--axes", "paper",
                                      "--out", str(bench_out / "paper-cpu")], bench_out / "paper-cpu" / "scale.json")
    save()
    failed = report["failed"]
    print(f"gpu-check: {gpu['name']} ({gpu['backend']}); "
          + (f"FAILED: {', '.join(failed)}" if failed else "every step passed") + f"; report in {args.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
