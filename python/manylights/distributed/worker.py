"""The tasks of ``manylights.distributed.sweep`` as they run on a Dask worker (or in the calling process).

Everything a task receives is plain data (paths, parameter dicts, numbers): a worker loads the scene
itself from path + parameters, generates the lights and builds the ``LightMatrix``, and keeps them in a
per-process cache (``_MATRICES``) so the next task of the same scene reuses them. No GPU state is ever
pickled. Two kinds of task:

- ``reference(...)``: the brute-force image of a (scene, lights, matrix settings) triple, read from or
  written to the shared reference directory, keyed by the scene's content hash (``reference_key``);
- ``render(task, reference)``: one render of one method at one budget and seed, returned as one row
  (a dict of plain values) with its relative L2 against the reference.
"""
from __future__ import annotations

import hashlib
import json
import socket
import threading
import time
from collections import OrderedDict
from pathlib import Path
from typing import Optional

import numpy as np

from .._utils.files import atomic_write, folder_hash, npz_bytes
from ..animation.frames import load_animation
from ..animation.lights import generate_animation_lights
from ..animation.tensor import LightTensor, mrcs_per_frame
from ..animation.tensor_clustering import tensor_clustering
from ..io.images import read_exr
from ..lights.generate import generate_lights
from ..matrix.light_matrix import LightMatrix
from ..metrics import flicker, flip, relative_l2, relative_l2_per_frame, relmse, smape
from ..renderers.baselines import instant_radiosity, power_sampling
from ..renderers.clustered_visibility import clustered_visibility
from ..renderers.light_tree import light_bvh_sampling, ris_sampling, stochastic_lightcuts
from ..renderers.lightcuts import lightcuts, reconstruction_cuts
from ..renderers.lightslice import lightslice
from ..renderers.mrcs import mrcs
from ..scene import load_scene

#: Methods and whether they take rows (methods without rows use the columns of each budget).
METHODS = {"mrcs": True, "power_sampling": False, "instant_radiosity": False, "clustered_visibility": True,
           "light_bvh_sampling": False, "ris_sampling": False, "tensor_clustering": True, "mrcs_per_frame": True,
           "lightcuts": False, "reconstruction_cuts": False, "stochastic_lightcuts": False, "lightslice": True}
#: clustered_visibility reads a budget (rows, columns) as (view clusters, light clusters).
#: Methods that render animations (a scene whose parameters hold ``frames``); the others render one image.
ANIMATION_METHODS = {"tensor_clustering", "mrcs_per_frame"}

#: Loaded (scene, lights, LightMatrix, content hash) per scene/lights/matrix settings, most recent last.
_MATRICES: OrderedDict = OrderedDict()
#: How many matrices a worker process keeps (a scene + its LightMatrix each).
CACHE_SIZE = 4
_LOCK = threading.Lock()
#: Content hashes of scene folders already hashed by this process: path -> (mtime_ns of the XML, hash).
_HASHES: dict = {}


def scene_hash(xml: Path) -> str:
    """sha256 (hex) over the XML's folder: every file's relative path and bytes in sorted order (meshes and
    textures change the image as much as the XML does); the same rule as the benchmarks' caches.

    Raises:
        FileNotFoundError: the XML is missing (named)."""
    xml = Path(xml)
    if not xml.is_file():
        raise FileNotFoundError(f"scene file not found on host {socket.gethostname()}: {xml}")
    mtime = xml.stat().st_mtime_ns
    got = _HASHES.get(str(xml))
    if got is None or got[0] != mtime:
        got = (mtime, folder_hash(xml))
        _HASHES[str(xml)] = got
    return got[1]


def light_counts(scene, spec: dict) -> dict:
    """``generate_lights`` (``generate_animation_lights`` for an animation: ``scene`` is then its frame 0)
    arguments of a lights spec: ``{"total": N, "seed": s, ...}`` splits N as the MRCS benchmark does (a
    quarter area lights when the scene has area emitters, a quarter environment lights when it has an
    environment, the rest indirect); explicit ``area`` / ``environment`` / ``indirect`` counts are taken as
    they are."""
    spec = dict(spec)
    total = spec.pop("total", None)
    if total is not None:
        has_area = any(e["type"] == "area" for e in scene.emitters)
        has_env = any(e["type"] in ("envmap", "constant") for e in scene.emitters)
        spec.setdefault("area", total // 4 if has_area else 0)
        spec.setdefault("environment", total // 4 if has_env else 0)
        spec.setdefault("indirect", total - spec["area"] - spec["environment"])
    return spec


def _matrix(scene_spec: dict, lights_spec: dict, matrix_spec: dict):
    """(scene, lights, LightMatrix, content hash, seconds to make them), from this process's cache."""
    key = json.dumps([scene_spec["path"], scene_spec["params"], lights_spec, matrix_spec], sort_keys=True)
    with _LOCK:
        if key in _MATRICES:
            _MATRICES.move_to_end(key)
            return _MATRICES[key] + (0.0,)
    t = time.perf_counter()
    path = Path(scene_spec["path"])
    digest = scene_hash(path)
    params = dict(scene_spec["params"])
    size = params.pop("size", None)
    size = None if size is None else tuple(size)
    frames = params.pop("frames", None)
    if frames is not None:  # an animation: its LightTensor plays the part of the matrix
        scene = load_animation(path, frames=frames, size=size, device=matrix_spec.get("device", "auto"), **params)
        lights = generate_animation_lights(scene, **light_counts(scene[0], lights_spec))
        A = LightTensor(scene, lights, **matrix_spec)
    else:
        scene = load_scene(path, size=size, **params)
        lights = generate_lights(scene, **light_counts(scene, lights_spec))
        A = LightMatrix(scene, lights, **matrix_spec)
    entry = (scene, lights, A, digest)
    with _LOCK:
        _MATRICES[key] = entry
        while len(_MATRICES) > CACHE_SIZE:
            _MATRICES.popitem(last=False)
    return entry + (time.perf_counter() - t,)


def reference_key(digest: str, scene_spec: dict, lights_spec: dict, matrix_spec: dict, device: dict,
                  visibility: str, bias_compensation: Optional[dict] = None) -> str:
    """The cache key of a brute-force reference: everything the image depends on (the scene folder's
    content hash, the loader parameters, the light spec, the backend kind and visibility, the bias
    compensation's settings when a light model adds it), 24 hex digits."""
    what = {"scene": digest, "params": scene_spec["params"], "lights": lights_spec,
            "matrix": {**matrix_spec, "device": device.get("kind"), "visibility": visibility}}
    if bias_compensation is not None:
        what["bias_compensation"] = {**bias_compensation, "seed": REFERENCE_BIAS_SEED}
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:24]


#: The seed of the bias compensation image in a light model's brute-force reference: one no render uses
#: (render seeds are the sweep's seeds, small integers), so a render's compensation is independent of it.
REFERENCE_BIAS_SEED = 2**64 - 1


def bias_image(A, settings: Optional[dict], seed: int):
    """``A.bias_compensation(**settings, seed=seed)`` (H, W, 3) float32, or None without settings."""
    if settings is None:
        return None
    return A.bias_compensation(seed=seed, **settings)


#: Truth images read by this process: path -> (mtime_ns, image (H, W, 3) float32).
_TRUTHS: dict = {}


def truth_image(path: str) -> np.ndarray:
    """The image at ``path`` (OpenEXR through ``read_exr``, or a ``.npy``), its first three channels,
    float32, read once per process (again when the file changes).

    Raises:
        FileNotFoundError: the file is missing on this host; ValueError: not an (H, W, >= 3) image."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"truth image not found on host {socket.gethostname()}: {path}")
    mtime = p.stat().st_mtime_ns
    got = _TRUTHS.get(path)
    if got is None or got[0] != mtime:
        img = np.load(p) if p.suffix == ".npy" else read_exr(p)
        img = np.asarray(img, dtype=np.float32)
        if img.ndim != 3 or img.shape[2] < 3:
            raise ValueError(f"truth image {path} must be (H, W, 3+), got shape {img.shape}")
        got = (mtime, img[..., :3])
        _TRUTHS[path] = got
    return got[1]


def reference(scene_spec: dict, lights_spec: dict, matrix_spec: dict, reference_dir: str,
              bias_compensation: Optional[dict] = None) -> dict:
    """The brute-force image (column sum + emitted, + the bias compensation image of seed
    ``REFERENCE_BIAS_SEED`` when
    ``bias_compensation`` holds its settings) of a scene's light matrix, rendered at most once per
    content: read from ``<reference_dir>/<key>.npz`` when an earlier task or sweep stored it, else rendered
    and stored there (written under a temporary name and renamed, so a reader never sees half a file).

    Returns:
        dict: image (H, W, 3) float32 ((f, H, W, 3) for an animation), seconds (of the render that made it),
        cached (bool), key, scene_hash,
        lights (n), device (the matrix's device dict), host.

    Raises:
        FileNotFoundError: the scene file is missing on this worker (path and host named); whatever
            ``load_scene`` / ``generate_lights`` / ``LightMatrix`` raise for the scene.
    """
    scene, lights, A, digest, _ = _matrix(scene_spec, lights_spec, matrix_spec)
    animation = "frames" in scene_spec["params"]
    n = len(lights[0]) if animation else len(lights)
    visibility = A.frame(0).visibility if animation else A.visibility
    key = reference_key(digest, scene_spec, lights_spec, matrix_spec, A.device, visibility, bias_compensation)
    d = Path(reference_dir)
    path = d / f"{key}.npz"
    out = {"key": key, "scene_hash": digest, "lights": int(n), "device": dict(A.device),
           "host": socket.gethostname()}
    if path.is_file():
        try:
            with np.load(path) as z:
                return {**out, "image": z["image"].astype(np.float32), "seconds": float(z["seconds"]),
                        "cached": True}
        except (OSError, ValueError, KeyError):
            pass  # unreadable (another program's file): render it again and replace it
    t = time.perf_counter()
    if animation:
        image = A.brute_force(progress=False).astype(np.float32)  # (f, H, W, 3)
    else:
        image = A.column_sum(progress=False) + A.emitted()
        if bias_compensation is not None:
            image = image + bias_image(A, bias_compensation, REFERENCE_BIAS_SEED)
        image = image.astype(np.float32)
    seconds = time.perf_counter() - t
    d.mkdir(parents=True, exist_ok=True)
    atomic_write(path, data=npz_bytes(image=image, seconds=seconds))
    return {**out, "image": image, "seconds": seconds, "cached": False}


def _flip_or_nan(image, truth) -> float:
    """HDR-FLIP of ``image`` against ``truth`` (``metrics.flip``), NaN where ``flip-evaluator`` is not installed
    (an optional dependency: the other metrics do not need it)."""
    try:
        return float(flip(image, truth))
    except ImportError:
        return float("nan")


def render(task: dict, ref: dict) -> dict:
    """One render of ``task`` (method, rows, columns, seed on its scene / lights / matrix) and its row.

    A method that raises gives a row with ``status="error"`` and the error (type and message) instead of
    failing the sweep.

    Returns:
        dict of plain values: task (the row's key), method, rows, columns, seed, status, error, rel_l2
        (relative L2 against ``ref["image"]``; the mean over frames for an animation, with max_rel_l2,
        flicker, frames and shadow_maps_per_frame), truth ("brute_force", or "image:<file name>" when the task
        names a truth image: rel_l2 is then against it, rel_l2_brute_force against ``ref`` and
        reference_rel_l2 is ``ref``'s own error against it), relmse and smape (against the same image as
        rel_l2; still images only), error_estimate (the method's own estimate of its relative L2: MRCS with options {"halves": True}; NaN otherwise), seconds
        (all stages) and ``seconds_<stage>`` per stage, clusters (columns rendered), lights, scene_hash,
        reference_key, reference_seconds, reference_cached (read from the cache directory), device, adapter, host,
        setup_seconds (scene + matrix loading of this task; 0 when cached)."""
    row = {"task": task["task"], "status": "ok", "error": None, "host": socket.gethostname(),
           "scene_hash": ref["scene_hash"], "reference_key": ref["key"], "reference_seconds": ref["seconds"],
           "reference_cached": ref["cached"], "lights": ref["lights"]}
    try:
        scene, lights, A, _, setup = _matrix(task["scene"], task["lights"], task["matrix"])
        row["setup_seconds"] = setup
        row["device"] = A.device.get("kind")
        row["adapter"] = A.device.get("name")
        method, c, seed = task["method"], task["columns"], task["seed"]
        opts = dict(task.get("options") or {})
        if method in ANIMATION_METHODS:
            render_fn = tensor_clustering if method == "tensor_clustering" else mrcs_per_frame
            res = render_fn(A, rows=task["rows"], columns=c, seed=seed, **opts)
            e = relative_l2_per_frame(res.frames, ref["image"])
            row.update(rel_l2=float(np.mean(e)), max_rel_l2=float(np.max(e)),
                       flicker=float(flicker(res.frames, ref["image"])), frames=int(len(res.frames)),
                       shadow_maps_per_frame=float(np.mean(res.shadow_maps_per_frame)),
                       clusters=int(res.budget["columns"]), seconds=res.seconds)
            row.update({f"seconds_{k}": float(v) for k, v in res.timings.items()})
            return row
        if method == "mrcs":
            res = mrcs(A, rows=task["rows"], columns=c, seed=seed, **opts)
            row["clusters"] = int(len(res.representatives))
        elif method == "power_sampling":
            res = power_sampling(A, columns=c, seed=seed, **opts)
            row["clusters"] = int(len(res.representatives))
        elif method == "instant_radiosity":
            res = instant_radiosity(scene, lights=c, seed=seed, **opts, **task["matrix"])
            row["clusters"] = int(res.budget["lights"])
        elif method in ("light_bvh_sampling", "ris_sampling"):
            # A budget's columns are the light samples (shadow rays) per view sample.
            render_fn = light_bvh_sampling if method == "light_bvh_sampling" else ris_sampling
            res = render_fn(A, samples=c, seed=seed, **opts)
            row["clusters"] = c
            row["rays"] = int(res.budget["shadow_rays"])
        elif method in ("lightcuts", "reconstruction_cuts"):
            # A budget's columns are the largest cut per view sample (error: options, default 2%).
            render_fn = lightcuts if method == "lightcuts" else reconstruction_cuts
            res = render_fn(A, max_cut=c, seed=seed, **opts)
            row["clusters"] = c
            row["rays"] = int(res.budget["shadow_rays"])
        elif method == "stochastic_lightcuts":
            # A budget's columns are the cut size (shadow rays per view sample).
            res = stochastic_lightcuts(A, cut_size=c, seed=seed, **opts)
            row["clusters"] = c
            row["rays"] = int(res.budget["shadow_rays"])
        elif method == "lightslice":
            # rows = slices, columns = clusters per slice.
            res = lightslice(A, slices=task["rows"], columns=c, seed=seed, **opts)
            row["clusters"] = int(res.budget["columns"])
            row["rays"] = int(res.budget["shadow_rays"])
        elif method == "clustered_visibility":
            res = clustered_visibility(A, light_clusters=c, view_clusters=task["rows"], seed=seed, **opts)
            row["clusters"] = int(res.budget["light_clusters"])
            row["rays"] = int(res.budget["rays"])
        else:  # sweep() checks the names: only a hand-made task gets here
            raise ValueError(f"unknown method {method!r}; methods: {', '.join(METHODS)}")
        image, seconds = res.image, res.seconds
        for k, v in res.timings.items():
            row[f"seconds_{k}"] = float(v)
        if task.get("bias_compensation") is not None:  # the light model's compensation image: its cost counts
            t = time.perf_counter()
            image = image + bias_image(A, task["bias_compensation"], seed)
            row["seconds_bias_compensation"] = time.perf_counter() - t
            seconds += row["seconds_bias_compensation"]
        row["rel_l2_brute_force"] = float(relative_l2(image, ref["image"]))
        row["rel_l2"] = row["rel_l2_brute_force"]
        row["truth"] = "brute_force"
        truth_img = ref["image"]
        if task.get("truth") is not None:
            truth = truth_image(task["truth"])
            if truth.shape != image.shape:
                raise ValueError(f"truth image {task['truth']} is {truth.shape[1]}x{truth.shape[0]}, the render "
                                 f"{image.shape[1]}x{image.shape[0]}")
            row["rel_l2"] = float(relative_l2(image, truth))
            truth_img = truth
            row["reference_rel_l2"] = float(relative_l2(ref["image"], truth))
            row["truth"] = f"image:{Path(task['truth']).name}"
        row["relmse"] = float(relmse(image, truth_img))
        row["smape"] = float(smape(image, truth_img))
        row["flip"] = _flip_or_nan(image, truth_img)
        if getattr(res, "error_estimate", None) is not None:
            row["error_estimate"] = float(res.error_estimate)
        row["seconds"] = seconds
    except Exception as e:  # noqa: BLE001  (recorded in the row; the sweep goes on)
        row["status"] = "error"
        row["error"] = f"{type(e).__name__}: {e}"
    return row
