"""Experiment sweeps on Dask: methods x budgets x seeds x scenes -> one pandas DataFrame row per render.

``sweep(scenes, methods, budgets, seeds)`` runs every render of the product as a task on a Dask cluster
(``dask.distributed``): a ``LocalCluster`` of worker processes by default, or any cluster through a
``Client`` or a scheduler address. Workers load scenes themselves from path + parameters and keep their
scenes and light matrices cached (``sweep_worker``); each (scene, lights) pair's brute-force reference is
one task, rendered once and cached by content hash in a directory the workers share. Rows stream back as
they complete (progress: count and the running best error per method), and with ``out=`` each is added
to a Parquet file at once (rewritten under a temporary name and renamed, so Ctrl-C or a crash leaves the
file valid); running the same sweep again skips the rows already there.

Faults: a worker process that dies mid-task has its task run again on another worker (Dask reschedules
it); a task that raises gives a row with ``status="error"`` and its error, and the sweep goes on; no row
is lost or duplicated (one row per task key).
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import sys
import time
from pathlib import Path
from typing import Callable, Optional, Sequence

from . import _validate as _v
from .sweep_worker import ANIMATION_METHODS, METHODS

#: Parquet key-value metadata key holding the sweep definition (checked when a sweep resumes).
META_KEY = b"manylights.sweep"
#: The columns every row has, in this order (then ``seconds_<stage>`` columns, sorted).
COLUMNS = ["task", "scene", "params", "scene_hash", "lights", "light_model", "method", "rows", "columns", "clusters",
           "seed", "status", "error", "rel_l2", "truth", "rel_l2_brute_force", "reference_rel_l2", "error_estimate", "frames", "max_rel_l2", "flicker", "shadow_maps_per_frame",
           "seconds", "setup_seconds", "reference_key",
           "reference_seconds", "reference_cached", "device", "adapter", "host"]


# ------------------------------------------------------------------------------------------ definition
def _scene_specs(scenes, local: bool) -> list[dict]:
    from .scenes import SCENES_DIR

    if isinstance(scenes, (str, os.PathLike)) or (isinstance(scenes, tuple) and len(scenes) == 2
                                                  and isinstance(scenes[1], dict)):
        scenes = [scenes]
    try:
        scenes = list(scenes)
    except TypeError:
        raise TypeError(f"scenes must be a list of paths or (path, parameters) pairs, got {type(scenes).__name__}") \
            from None
    if not scenes:
        raise ValueError("scenes is empty: give at least one scene path or (path, parameters) pair")
    out = []
    for i, s in enumerate(scenes):
        params = {}
        if isinstance(s, (tuple, list)):
            if len(s) != 2 or not isinstance(s[1], dict):
                raise ValueError(f"scenes[{i}] must be a path or a (path, parameters dict) pair, got {s!r}")
            s, params = s
        if not isinstance(s, (str, os.PathLike)):
            raise TypeError(f"scenes[{i}]: a scene is a path (str or os.PathLike), got {type(s).__name__}")
        given = os.fspath(s)
        path = Path(given)
        if not path.is_file() and Path(given).name == given and (SCENES_DIR / given / "scene.xml").is_file():
            path = SCENES_DIR / given / "scene.xml"  # a bundled scene's name
        elif local and not path.is_file():
            raise FileNotFoundError(f"scenes[{i}]: scene file not found: {given}")
        clean = {}
        for k, v in params.items():
            if not isinstance(k, str):
                raise ValueError(f"scenes[{i}]: parameter names must be strings, got {k!r}")
            if k == "frames":
                if not isinstance(v, (list, tuple)) or not v or not all(isinstance(f, dict) for f in v):
                    raise ValueError(f"scenes[{i}]: frames must be a non-empty list of parameter dicts (one per "
                                     f"frame of the animation), got {v!r}")
                for k_, f in enumerate(v):
                    for name, x in f.items():
                        if not isinstance(name, str) or not isinstance(x, (str, int, float, bool)):
                            raise ValueError(f"scenes[{i}]: frame {k_}: parameter {name!r} must be a string "
                                             f"name with a string, number or bool value, got {x!r}")
                v = [dict(f) for f in v]
            elif k == "size":
                if not isinstance(v, (tuple, list)) or len(v) != 2:
                    raise ValueError(f"scenes[{i}]: size must be (width, height), got {v!r}")
                v = [_v.integer(f"scenes[{i}] size[{j}]", x, 1, 2**32 - 1) for j, x in enumerate(v)]
            elif not isinstance(v, (str, int, float, bool)):
                raise ValueError(f"scenes[{i}]: parameter {k!r} must be a string, number or bool, got {v!r}")
            clean[k] = v
        out.append({"path": str(path.resolve()) if path.is_file() else str(path), "display": given,
                    "params": clean})
    return out


def _methods(methods) -> list[str]:
    if isinstance(methods, str):
        methods = [methods]
    methods = list(methods)
    if not methods:
        raise ValueError(f"methods is empty: give one or more of {', '.join(METHODS)}")
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"unknown method {m!r}; methods: {', '.join(METHODS)}")
    if len(set(methods)) != len(methods):
        raise ValueError(f"methods lists a method twice: {methods}")
    return methods


def _budgets(budgets) -> list[tuple[int, int]]:
    try:
        budgets = list(budgets)
    except TypeError:
        raise ValueError(f"budgets must be a list of (rows, columns) pairs, got {budgets!r}") from None
    if not budgets:
        raise ValueError("budgets is empty: give at least one (rows, columns) pair")
    out = []
    for i, b in enumerate(budgets):
        if not isinstance(b, (tuple, list)) or len(b) != 2:
            raise ValueError(f"budgets[{i}] must be a (rows, columns) pair of integers >= 1, got {b!r}")
        out.append((_v.integer(f"budgets[{i}] rows", b[0], 1, 2**31 - 1),
                    _v.integer(f"budgets[{i}] columns", b[1], 1, 2**31 - 1)))
    if len(set(out)) != len(out):
        raise ValueError(f"budgets lists a (rows, columns) pair twice: {out}")
    return out


def _seeds(seeds) -> list[int]:
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        seeds = [seeds]
    seeds = [_v.seed(s, f"seeds[{i}]") for i, s in enumerate(seeds)]
    if not seeds:
        raise ValueError("seeds is empty: give at least one seed")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds lists a seed twice: {seeds}")
    return seeds


def _lights(lights) -> dict:
    if isinstance(lights, dict):
        allowed = {"total", "area", "environment", "indirect", "max_depth", "clamp", "seed", "env_importance",
                   "photons", "indirect_kind", "vsl_radius_scale", "vsl_neighbours", "vpl_importance",
                   "vpl_view_samples", "vpl_accept_min"}
        if bad := sorted(set(lights) - allowed):
            raise ValueError(f"lights: unknown keys {bad}; allowed: {sorted(allowed)}")
        spec = dict(lights)
    else:
        spec = {"total": lights}
    for k in ("total", "area", "environment", "indirect"):
        if k in spec:
            spec[k] = _v.integer(f"lights[{k!r}]", spec[k], 1 if k == "total" else 0, 2**40)
    spec.setdefault("seed", 0)
    spec["seed"] = _v.seed(spec["seed"], "lights['seed']")
    return spec


def _options(options, methods) -> dict:
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict of method -> keyword arguments, got {options!r}")
    out = {}
    for m, kw in options.items():
        if m not in methods:
            raise ValueError(f"options for {m!r}, which is not one of the sweep's methods {methods}")
        if not isinstance(kw, dict) or not all(isinstance(k, str) for k in kw):
            raise ValueError(f"options[{m!r}] must be a dict of keyword arguments, got {kw!r}")
        try:
            json.dumps(kw)
        except TypeError as e:
            raise ValueError(f"options[{m!r}]: values must be plain numbers, strings, lists or dicts ({e})") from None
        out[m] = dict(kw)
    return out


#: What a light model may change: ``generate_lights`` arguments, ``LightMatrix`` settings, and the bias
#: compensation image added to every render (``LightMatrix.bias_compensation`` arguments but the seed).
MODEL_LIGHTS = {"indirect_kind", "vsl_radius_scale", "vsl_neighbours", "clamp", "max_depth", "vpl_importance",
                "vpl_view_samples", "vpl_accept_min"}
MODEL_MATRIX = {"glossy_roughness", "bsdf_samples", "glossy_seed", "max_depth"}
MODEL_BIAS = {"spp", "light_samples", "max_depth"}


def _light_models(light_models) -> Optional[list[dict]]:
    """``{name: {"lights": {...}, "matrix": {...}, "bias_compensation": {...} or None}}`` -> a list of
    ``{"name", "lights", "matrix", "bias_compensation"}`` (None: no light-model axis)."""
    if light_models is None:
        return None
    if not isinstance(light_models, dict) or not light_models:
        raise ValueError(f"light_models must be a non-empty dict of name -> settings, got {light_models!r}")
    out = []
    for name, spec in light_models.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"light_models: names must be non-empty strings, got {name!r}")
        spec = {} if spec is None else spec
        if not isinstance(spec, dict) or (bad := sorted(set(spec) - {"lights", "matrix", "bias_compensation"})):
            raise ValueError(f"light_models[{name!r}] must be a dict with keys lights, matrix, bias_compensation, "
                             f"got {spec!r}")
        model = {"name": name}
        for key, allowed in (("lights", MODEL_LIGHTS), ("matrix", MODEL_MATRIX), ("bias_compensation", MODEL_BIAS)):
            kw = spec.get(key)
            if kw is None:
                model[key] = None if key == "bias_compensation" else {}
                continue
            if not isinstance(kw, dict) or (bad := sorted(set(kw) - allowed)):
                raise ValueError(f"light_models[{name!r}][{key!r}] must be a dict of {sorted(allowed)}, got {kw!r}")
            try:
                json.dumps(kw)
            except TypeError as e:
                raise ValueError(f"light_models[{name!r}][{key!r}]: values must be plain numbers or strings ({e})") \
                    from None
            model[key] = dict(kw)
        if model["lights"].get("indirect_kind", "vpl") not in ("vpl", "vsl"):
            raise ValueError(f"light_models[{name!r}]: indirect_kind must be 'vpl' or 'vsl', got "
                             f"{model['lights']['indirect_kind']!r}")
        if model["bias_compensation"] is not None and model["lights"].get("indirect_kind") == "vsl":
            raise ValueError(f"light_models[{name!r}]: bias compensation applies to clamped VPLs, not to VSLs")
        out.append(model)
    return out


def _truth(truth, specs) -> list[Optional[str]]:
    """One image file (EXR or .npy) per scene, or None (brute force)."""
    if truth is None or isinstance(truth, (str, os.PathLike)):
        truth = [truth] * len(specs)
    truth = list(truth)
    if len(truth) != len(specs):
        raise ValueError(f"truth must be one image path (or None) per scene: {len(specs)} scenes, {len(truth)} given")
    out = []
    for i, t in enumerate(truth):
        if t is not None:
            if not Path(t).is_file():
                raise FileNotFoundError(f"truth[{i}]: image file not found: {t}")
            t = str(Path(t).resolve())
        out.append(t)
    return out


def _check_kinds(specs, methods) -> None:
    """Animation methods need animated scenes (``frames`` in their parameters), the others still scenes."""
    for i, s in enumerate(specs):
        animated = "frames" in s["params"]
        wrong = [m for m in methods if (m in ANIMATION_METHODS) != animated]
        if wrong:
            what = "an animation (its parameters hold frames)" if animated else "a still scene (no frames parameter)"
            raise ValueError(f"scenes[{i}] ({s['display']}) is {what}, which method(s) {wrong} do not render; "
                             f"animation methods: {sorted(ANIMATION_METHODS)}")


def _tasks(scene_specs, methods, budgets, seeds, lights, matrix, options=None, models=None,
           truth=None) -> list[dict]:
    """Every render of the sweep, in a fixed order (scene, light model, method, budget, seed); methods without
    rows take each distinct column count once (rows = 0 in their rows). A light model's settings are merged
    into the task's lights / matrix specs; its name joins the task key only when there is a light-model axis."""
    tasks = []
    for i, s in enumerate(scene_specs):
        for model in models or [None]:
            t_lights = lights if model is None else _lights({**lights, **model["lights"]})
            t_matrix = matrix if model is None else {**matrix, **model["matrix"]}
            bias = None if model is None else model["bias_compensation"]
            if bias is not None:  # the compensation's paths use the lights' max_depth unless told
                bias = {"max_depth": t_lights.get("max_depth", 5), **bias}
            for m in methods:
                pairs = budgets if METHODS[m] else list(dict.fromkeys((0, c) for _, c in budgets))
                for rows, c in pairs:
                    for seed in seeds:
                        key = [s["display"], s["params"], m, rows, c, seed] + ([] if model is None else [model["name"]])
                        tasks.append({"task": json.dumps(key, sort_keys=True), "scene": s, "lights": t_lights,
                                      "matrix": t_matrix, "method": m, "rows": rows, "columns": c, "seed": seed,
                                      "options": (options or {}).get(m, {}),
                                      "light_model": None if model is None else model["name"],
                                      "bias_compensation": bias, "truth": None if truth is None else truth[i]})
    return tasks


def _definition(scene_specs, methods, budgets, seeds, lights, matrix, options, models=None, truth=None) -> dict:
    d = {"version": 1, "scenes": [[s["display"], s["params"]] for s in scene_specs], "methods": methods,
         "budgets": [list(b) for b in budgets], "seeds": seeds, "lights": lights, "matrix": matrix,
         "options": options}
    if models is not None:
        d["light_models"] = models
    if truth is not None and any(t is not None for t in truth):
        d["truth"] = truth
    return d


# ------------------------------------------------------------------------------------------ Parquet
def _read_existing(out: Path, definition: dict):
    """The rows already in ``out`` (a DataFrame) when it holds this sweep; None when there is no file.

    Raises:
        ValueError: ``out`` is not a Parquet file of a sweep, or one of another sweep definition (what differs
            is named); the file is left as it is."""
    import pyarrow.parquet as pq

    if not out.exists():
        return None
    try:
        table = pq.read_table(out)
    except Exception as e:  # noqa: BLE001  (pyarrow raises several kinds for a foreign file)
        raise ValueError(f"out={out} exists and is not a readable Parquet file ({type(e).__name__}: {e}); "
                         "it was left as it is: pass another path or remove it") from e
    meta = (table.schema.metadata or {}).get(META_KEY)
    if meta is None:
        raise ValueError(f"out={out} is a Parquet file not written by manylights.sweep (no sweep definition in "
                         "its metadata); it was left as it is: pass another path or remove it")
    old = json.loads(meta)
    if old != definition:
        diff = sorted(k for k in set(old) | set(definition) if old.get(k) != definition.get(k))
        raise ValueError(f"out={out} holds a sweep of another definition (differs in: {', '.join(diff)}; "
                         f"stored {json.dumps({k: old.get(k) for k in diff})}); it was left as it is: pass the same "
                         "scenes, methods, budgets, seeds, lights and matrix settings to resume it, or another path")
    return table.to_pandas()


def _write(out: Path, df, definition: dict) -> None:
    """Write ``df`` to ``out`` atomically: a temporary file beside it, then a rename over it."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           META_KEY: json.dumps(definition).encode()})
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)


def _frame(rows: list[dict], order: dict):
    import pandas as pd

    df = pd.DataFrame(rows)
    for c in COLUMNS:
        if c not in df.columns:
            df[c] = None
    stages = sorted(c for c in df.columns if c.startswith("seconds_"))
    df = df[COLUMNS + stages]
    df = df.assign(_order=df["task"].map(order)).sort_values("_order", kind="stable").drop(columns="_order")
    df = df.reset_index(drop=True)
    for c in ("lights", "rows", "columns", "clusters", "seed", "frames"):
        df[c] = df[c].astype("Int64")
    for c in ["rel_l2", "rel_l2_brute_force", "reference_rel_l2", "error_estimate", "max_rel_l2", "flicker", "shadow_maps_per_frame", "seconds", "setup_seconds",
              "reference_seconds", *stages]:
        df[c] = df[c].astype("float64")
    df["reference_cached"] = df["reference_cached"].astype("boolean")
    return df


# ------------------------------------------------------------------------------------------ progress
class _Progress:
    """Count of rows and the running best relative L2 per method: a tqdm bar on terminals and in notebooks,
    a few plain lines in logs (``progress.mode()``), nothing when disabled."""

    def __init__(self, total: int, done: int, enabled: bool):
        from . import progress

        self.total, self.done, self.best = total, done, {}
        self.mode = progress.mode() if enabled and total > done else "off"
        self.interval = progress.LOG_INTERVAL
        self.bar = None
        self.start = self.last = time.perf_counter()
        if self.mode == "bar":
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, initial=done, desc="sweep", unit="render", leave=False)
        elif self.mode == "log":
            self._log(f"{total - done} renders to do ({done} of {total} already in the output)")

    def _log(self, msg: str) -> None:
        try:
            print(f"manylights: sweep: {msg}", file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass

    def best_text(self) -> str:
        return ", ".join(f"{m} {e:.4g}" for m, e in sorted(self.best.items()))

    def update(self, row: dict) -> None:
        self.done += 1
        e = row.get("rel_l2")
        if row.get("status") == "ok" and e is not None and math.isfinite(e):
            m = row["method"]
            self.best[m] = min(self.best.get(m, math.inf), e)
        if self.bar is not None:
            self.bar.set_postfix_str("best rel L2: " + self.best_text(), refresh=False)
            self.bar.update(1)
        elif self.mode == "log":
            now = time.perf_counter()
            if now - self.last >= self.interval and self.done < self.total:
                self.last = now
                self._log(f"{self.done}/{self.total}, {now - self.start:.0f} s; best rel L2: {self.best_text()}")

    def close(self, exc: Optional[BaseException]) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.mode == "log":
            took = time.perf_counter() - self.start
            how = "done" if exc is None else f"stopped ({type(exc).__name__})"
            self._log(f"{how}: {self.done}/{self.total} in {took:.1f} s; best rel L2: {self.best_text()}")


# ------------------------------------------------------------------------------------------ Dask
def _connect(client, workers: Optional[int], connect_timeout: float, device: str):
    """(client, owned): the given client, a new one to a scheduler address, or a new LocalCluster's."""
    from dask.distributed import Client, LocalCluster

    if isinstance(client, Client):
        return client, False
    if isinstance(client, str):
        try:
            return Client(client, timeout=connect_timeout), True
        except (OSError, TimeoutError) as e:
            raise OSError(f"cannot reach the Dask scheduler at {client!r} within {connect_timeout:g} s "
                          f"({type(e).__name__}: {e})") from None
    n = workers if workers is not None else default_workers(device)
    cores = os.cpu_count() or 1
    # One thread per worker process; the CPU backend's rayon pool gets an equal share of the cores.
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR, env={"RAYON_NUM_THREADS": str(max(1, cores // n))})
    except RuntimeError as e:
        raise RuntimeError(f"could not start a LocalCluster of {n} worker processes ({e}); a script that runs a "
                           "sweep must do so under `if __name__ == \"__main__\":` (worker processes are spawned "
                           "and import the main module), or pass workers=0 to run in this process") from e
    return Client(cluster), True


def default_workers(device: str = "auto") -> int:
    """Worker processes of the default ``LocalCluster``: one per hardware GPU adapter when the sweep runs on
    a GPU, else (CPU backend or a software adapter) 2 when the machine has 2+ cores, else 1."""
    import manylights as ml

    info = ml.device_info(device)
    if info.get("kind") == "gpu" and not info.get("is_software"):
        return 1  # wgpu exposes one adapter to a process; more GPUs need one worker per GPU (README)
    return 2 if (os.cpu_count() or 1) >= 2 else 1


def _gpu_resources(client) -> Optional[dict]:
    """{"GPU": 1} when the cluster's workers advertise a GPU resource (``dask worker --resources GPU=1``)."""
    try:
        workers = client.scheduler_info().get("workers", {})
    except Exception:  # noqa: BLE001
        return None
    if any("GPU" in (w.get("resources") or {}) for w in workers.values()):
        return {"GPU": 1}
    return None


def _error_row(task: dict, exc: BaseException) -> dict:
    return {"task": task["task"], "status": "error", "error": f"{type(exc).__name__}: {exc}"}


# ------------------------------------------------------------------------------------------ sweep
def sweep(scenes, methods: Sequence[str] = ("mrcs", "power_sampling"), budgets=((100, 300),),
          seeds: Sequence[int] = (0,), *, lights=10_000, client=None, workers: Optional[int] = None,
          out=None, reference_dir=None, device: str = "auto", visibility: Optional[str] = None,
          shadow_map_size: Optional[int] = None, options: Optional[dict] = None, rerun_errors: bool = False,
          light_models: Optional[dict] = None, truth=None, progress: bool = True,
          connect_timeout: float = 10.0, on_row: Optional[Callable[[dict], None]] = None):
    """Run every render of methods x budgets x seeds x scenes as Dask tasks; one DataFrame row per render.

    Args:
        scenes: a list of scene XML paths, bundled scene names (``"cbox"``) or ``(path, parameters)`` pairs;
            parameters are ``load_scene``'s (``{"res": 64}``, ``{"size": (64, 48)}``); with ``"frames"``: [one
            dict per frame] the scene is an animation (``load_animation``; the other parameters are common to
            every frame). Paths must be valid on the workers (a shared file system on a real cluster).
        methods: for still scenes any of ``"mrcs"`` (takes rows and columns), ``"power_sampling"`` and
            ``"instant_radiosity"`` (columns only: they take each distinct column count of ``budgets`` once,
            their rows are 0); for animations ``"tensor_clustering"`` and ``"mrcs_per_frame"`` (rows and
            columns per frame).
        budgets: (rows, columns) pairs of integers >= 1 (MRCS: r sampled rows, c clusters; power sampling: c
            sampled lights; instant radiosity: c generated lights).
        seeds: render seeds (integers >= 0); the same seed gives the same row on the same backend.
        lights: the scene's light set: an integer N (a quarter area lights when the scene has area emitters, a
            quarter environment lights when it has an environment, the rest indirect) or a dict of
            ``generate_lights`` arguments (``area``, ``environment``, ``indirect``, ``max_depth``, ``clamp``,
            ``seed``, ``photons`` for animations (``generate_animation_lights``), or ``total`` split as N is).
            The light seed is 0 unless given: every render of a scene
            sees the same matrix.
        client: None: a new ``LocalCluster`` of ``workers`` processes (default ``default_workers(device)``),
            closed at the end; a ``dask.distributed.Client``; or a scheduler address (``"tcp://host:8786"``).
        workers: worker processes of the LocalCluster; 0 runs every task in this process, one after another,
            without Dask (the serial reference of a sweep).
        out: a Parquet file: rows already there are skipped (the sweep resumes), each new row is written as it
            arrives (the file is replaced atomically: it is valid whenever the sweep stops).
        reference_dir: where brute-force references are cached by content hash (shared by the workers);
            default ``$MANYLIGHTS_CACHE/references`` or ``~/.cache/manylights/references``.
        device, visibility, shadow_map_size: the ``LightMatrix`` settings of every render.
        options: per method, more keyword arguments of its function (``{"tensor_clustering": {"chunk": 8}}``).
        light_models: an axis of light models / estimator options, ``{name: {"lights": {...}, "matrix":
            {...}, "bias_compensation": {...}}}`` (every key optional): ``lights`` overrides ``generate_lights``
            arguments (``indirect_kind`` "vpl" / "vsl", ``vsl_radius_scale``, ``vsl_neighbours``, ``clamp``,
            ``max_depth``, ``vpl_importance``, ``vpl_view_samples``, ``vpl_accept_min``), ``matrix`` the ``LightMatrix`` settings (``glossy_roughness`` (0 = glossy MIS
            off), ``bsdf_samples``, ``glossy_seed``, ``max_depth``), and ``bias_compensation`` (``spp``,
            ``light_samples``, ``max_depth``) adds ``LightMatrix.bias_compensation(seed=<render seed>)`` to
            every image of the model, its seconds in ``seconds`` and ``seconds_bias_compensation`` (the
            model's brute-force reference adds it with seed ``sweep_worker.REFERENCE_BIAS_SEED``, 2^64 - 1). Every render runs once per model; rows name
            their model in ``light_model`` (None without the axis). Each worker caches each model's matrix.
        truth: the image the error is measured against instead of each model's brute force: an image file
            (EXR or ``.npy``, (H, W, 3+)) for every scene, or a list of one path or None per scene (a
            converged Mitsuba reference: ``rel_l2`` is then against it, ``rel_l2_brute_force`` against the
            brute force and ``reference_rel_l2`` the brute force's own error against it).
        rerun_errors: with ``out``, also run again the rows stored with ``status="error"``.
        progress: show the count and the running best error per method (a bar, or lines in a log).
        connect_timeout: seconds to wait for a scheduler given by address.
        on_row: called with each new row (a dict) after it is written.

    Returns:
        pandas DataFrame, one row per render in task order (scene, method, budget, seed), columns: task (the
        row's key), scene (as given), params (JSON), scene_hash (sha256 of the scene folder), lights (n),
        method, rows, columns, clusters (columns rendered), seed (Int64), status ("ok" / "error"), error
        (type: message, or None), light_model (its name, or None), rel_l2 (relative L2 against the truth, float64),
        truth ("brute_force" or "image:<file name>"), rel_l2_brute_force (against the brute-force reference),
        reference_rel_l2 (the brute force against the truth image; NaN without one),
        error_estimate (the method's own estimate of its error where it makes one, e.g. ``options={"mrcs": {"halves": True}}``; NaN otherwise); for animations frames, max_rel_l2
        (the worst frame), flicker (``metrics.flicker``) and shadow_maps_per_frame (mean), rel_l2 being the
        mean per-frame relative L2 (NaN for still scenes); seconds (all stages),
        setup_seconds (scene loading + matrix of that task; 0 when the worker had it cached), reference_key,
        reference_seconds (brute force), reference_cached (True: read from ``reference_dir``, not rendered),
        device ("cpu" / "gpu"), adapter (the device's name), host, and
        ``seconds_<stage>`` per stage of each method (NaN where a method has no such stage). Seconds are
        wall-clock seconds on the worker.

    Raises:
        ValueError: an unknown or repeated method, a method for the other kind of scene (still / animation),
            bad ``options`` or ``light_models``, a ``truth`` list of the wrong length, empty or repeated
            scenes / budgets / seeds, a budget not a
            pair of integers >= 1, a bad lights spec, an ``out`` file of another sweep definition or not a
            sweep's Parquet file (the file is left untouched).
        FileNotFoundError: a scene file missing (named) when the sweep runs locally; the directory of ``out``
            missing; a ``truth`` image missing. A scene missing on a remote worker gives error rows naming the path and host.
        OSError: a scheduler address not reachable within ``connect_timeout``.
        TypeError: scenes not a list of paths / pairs.
        KeyboardInterrupt: Ctrl-C; the rows written so far stay in ``out``, the LocalCluster is closed.
    """
    local = client is None
    specs = _scene_specs(scenes, local=local)
    methods = _methods(methods)
    budgets = _budgets(budgets)
    seeds = _seeds(seeds)
    lights = _lights(lights)
    options = _options(options, methods)
    models = _light_models(light_models)
    truths = _truth(truth, specs)
    _check_kinds(specs, methods)
    if not isinstance(device, str) or device not in ("auto", "cpu", "gpu"):
        raise ValueError(f"device must be 'auto', 'cpu' or 'gpu', got {device!r}")
    matrix = {"device": device}
    if visibility is not None:
        matrix["visibility"] = visibility
    if shadow_map_size is not None:
        matrix["shadow_map_size"] = _v.integer("shadow_map_size", shadow_map_size, 1, 16384)
    if workers is not None:
        workers = _v.integer("workers", workers, 0, 4096)
    connect_timeout = _v.real("connect_timeout", connect_timeout, 0.0)
    if reference_dir is None:
        base = os.environ.get("MANYLIGHTS_CACHE") or str(Path.home() / ".cache" / "manylights")
        reference_dir = str(Path(base) / "references")
    reference_dir = os.fspath(reference_dir)

    tasks = _tasks(specs, methods, budgets, seeds, lights, matrix, options, models, truths)
    order = {t["task"]: i for i, t in enumerate(tasks)}
    definition = _definition(specs, methods, budgets, seeds, lights, matrix, options, models, truths)
    done: dict[str, dict] = {}
    if out is not None:
        out = Path(out)
        if not out.parent.is_dir():
            raise FileNotFoundError(f"out={out}: the directory {out.parent} does not exist")
        old = _read_existing(out, definition)
        if old is not None:
            for r in old.to_dict("records"):
                if r["task"] in order and not (rerun_errors and r["status"] == "error"):
                    done[r["task"]] = r
    todo = [t for t in tasks if t["task"] not in done]

    bar = _Progress(len(tasks), len(done), progress)
    exc = None
    rows = dict(done)

    def accept(row: dict) -> None:
        task = tasks[order[row["task"]]]
        s = task["scene"]
        row = {**row, "scene": s["display"], "params": json.dumps(s["params"], sort_keys=True),
               "method": task["method"], "rows": task["rows"], "columns": task["columns"], "seed": task["seed"],
               "light_model": task["light_model"]}
        row.setdefault("error_estimate", math.nan)
        rows[row["task"]] = row
        if out is not None:
            _write(out, _frame(list(rows.values()), order), definition)
        bar.update(row)
        if on_row is not None:
            on_row(row)

    try:
        if todo and workers == 0 and local:
            _run_serial(todo, reference_dir, accept)
        elif todo:
            cl, owned = _connect(client, workers, connect_timeout, device)
            try:
                _run_dask(cl, todo, reference_dir, accept)
            finally:
                if owned:
                    cluster = cl.cluster
                    cl.close()
                    if cluster is not None:
                        cluster.close()
    except BaseException as e:
        exc = e
        raise
    finally:
        bar.close(exc)
    return _frame(list(rows.values()), order)


def _ref_id(task: dict) -> str:
    return json.dumps([task["scene"]["path"], task["scene"]["params"], task["lights"], task["matrix"],
                       task.get("bias_compensation")], sort_keys=True)


def _run_serial(todo: list[dict], reference_dir: str, accept) -> None:
    """Every task in this process, one after another (``workers=0``)."""
    from . import sweep_worker

    refs: dict = {}
    for t in todo:
        rid = _ref_id(t)
        if rid not in refs:
            try:
                refs[rid] = sweep_worker.reference(t["scene"], t["lights"], t["matrix"], reference_dir,
                                                   t.get("bias_compensation"))
            except Exception as e:  # noqa: BLE001  (every task of this scene gets the error row)
                refs[rid] = e
        ref = refs[rid]
        accept(_error_row(t, ref) if isinstance(ref, BaseException) else sweep_worker.render(t, ref))


def _run_dask(client, todo: list[dict], reference_dir: str, accept) -> None:
    """Submit one reference task per (scene, lights, matrix) and one render task per row; accept rows as
    they complete. Dask reruns the tasks of a worker that dies; a task that still fails (the reference
    raised, or ``KilledWorker`` after repeated deaths) becomes an error row."""
    from dask.distributed import as_completed

    from . import sweep_worker

    resources = _gpu_resources(client)
    stamp = hashlib.sha256(f"{os.getpid()} {time.time_ns()}".encode()).hexdigest()[:10]
    refs: dict = {}
    futures = {}
    for i, t in enumerate(todo):
        rid = _ref_id(t)
        if rid not in refs:
            refs[rid] = client.submit(sweep_worker.reference, t["scene"], t["lights"], t["matrix"], reference_dir,
                                      t.get("bias_compensation"), key=f"manylights-reference-{stamp}-{len(refs)}", pure=False,
                                      resources=resources)
        f = client.submit(sweep_worker.render, t, refs[rid], key=f"manylights-render-{stamp}-{i}", pure=False,
                          resources=resources)
        futures[f.key] = (f, t)
    pending = as_completed([f for f, _ in futures.values()])
    try:
        for f in pending:
            _, t = futures[f.key]
            # result(), not a look at f.status: a worker that dies right after finishing a task loses its
            # result, the future goes back to pending and dask recomputes it; result() waits for that,
            # where the status read just after completion said "finished" or "pending" by timing (and a
            # pending future became an error row: CI, test_killed_worker_loses_no_row).
            try:
                row = f.result()
            except Exception as err:  # noqa: BLE001  (the task raised, KilledWorker, a cancelled future)
                row = _error_row(t, err)
            f.release()
            accept(row)
    finally:
        remaining = [f for f, _ in futures.values() if f.status == "pending"]
        if remaining:
            client.cancel(remaining)
        for r in refs.values():
            r.release()
