"""Bad-input cases that run alone in a child process with an environment of their own."""
from __future__ import annotations

from .common import cases_for

# An adapter that does not exist: the GPU cannot start (a fresh process: the device is created once).
cases_for("device_info", [
    ("no such adapter", lambda c: c.ml.device_info(), ["MANYLIGHTS_ADAPTER", "no-such-gpu"]),
], raises=("GpuUnavailableError",), subprocess=True)

# Case id -> environment of its own child process.
SUBPROCESS_ENV = {"device_info:no such adapter": {"MANYLIGHTS_ADAPTER": "no-such-gpu"},
                  "LightMatrix:bad MANYLIGHTS_DEVICE": {"MANYLIGHTS_DEVICE": "quantum"},
                  "LightMatrix:gpu without any adapter": {"WGPU_BACKEND": "vulkan",
                                                          "VK_ICD_FILENAMES": "/nonexistent/icd.json",
                                                          "VK_DRIVER_FILES": "/nonexistent/icd.json"},
                  **{f"load_scene[{k}]:JPEG larger than MANYLIGHTS_MEMORY_LIMIT": {"MANYLIGHTS_MEMORY_LIMIT": "64M"}
                     for k in ("bitmap", "envmap")}}
