"""Experiment sweeps on Dask: methods x budgets x seeds x scenes -> one pandas DataFrame row per render.

``sweep(scenes, methods, budgets, seeds)`` runs every render of the product as a task on a Dask cluster
(``dask.distributed``): a ``LocalCluster`` of worker processes by default, or any cluster through a
``Client`` or a scheduler address. Workers load scenes themselves from path + parameters and keep their
scenes and light matrices cached (``distributed.worker``); each (scene, lights) pair's brute-force reference is
one task, rendered once and cached by content hash in a directory the workers share. Rows stream back as
they complete (progress: count and the running best error per method), and with ``out=`` each is added
to a Parquet file at once (rewritten under a temporary name and renamed, so Ctrl-C or a crash leaves the
file valid); running the same sweep again skips the rows already there.

Faults: a worker process that dies mid-task has its task run again on another worker (Dask reschedules
it); a task that raises gives a row with ``status="error"`` and its error, and the sweep goes on; no row
is lost or duplicated (one row per task key).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Callable, Optional, Sequence

from .._utils import progress as _progress
from .._utils import validate as _v
from .._utils.dask import connect, gpu_resources, release
from .._utils.files import atomic_write, exclusive
from .._utils.keywords import checked_keywords
from . import worker
from .specs import (
    check_kinds,
    definition_of,
    make_tasks,
    parse_budgets,
    parse_light_models,
    parse_lights,
    parse_methods,
    parse_options,
    parse_seeds,
    parse_truth,
    scene_specs,
)

#: Parquet key-value metadata key holding the sweep definition (checked when a sweep resumes).
META_KEY = b"manylights.sweep"
#: The columns every row has, in this order (then ``seconds_<stage>`` columns, sorted).
COLUMNS = ["task", "scene", "params", "scene_hash", "lights", "light_model", "method", "rows", "columns", "clusters",
           "seed", "status", "error", "rel_l2", "relmse", "smape", "flip", "truth", "rel_l2_brute_force", "reference_rel_l2", "error_estimate", "frames", "max_rel_l2", "flicker", "shadow_maps_per_frame",
           "seconds", "setup_seconds", "reference_key",
           "reference_seconds", "reference_cached", "device", "adapter", "host"]


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
    """Write ``df`` to ``out`` atomically (``_utils.files.atomic_write``: a temporary file beside it, synced,
    then renamed over it)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           META_KEY: json.dumps(definition).encode()})
    atomic_write(out, lambda tmp: pq.write_table(table, tmp))


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
    for c in ["rel_l2", "relmse", "smape", "flip", "rel_l2_brute_force", "reference_rel_l2", "error_estimate", "max_rel_l2", "flicker", "shadow_maps_per_frame", "seconds", "setup_seconds",
              "reference_seconds", *stages]:
        df[c] = df[c].astype("float64")
    df["reference_cached"] = df["reference_cached"].astype("boolean")
    return df


# ------------------------------------------------------------------------------------------ progress
class _Progress:
    """Count of rows and the running best relative L2 per method: a tqdm bar on terminals and in notebooks,
    a few plain lines in logs (``_progress.mode()``), nothing when disabled."""

    def __init__(self, total: int, done: int, enabled: bool):
        self.total, self.done, self.best = total, done, {}
        self.mode = _progress.mode(enabled) if total > done else "off"
        self.interval = _progress.LOG_INTERVAL
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


def _error_row(task: dict, exc: BaseException) -> dict:
    return {"task": task["task"], "status": "error", "error": f"{type(exc).__name__}: {exc}"}


# ------------------------------------------------------------------------------------------ sweep
@checked_keywords()
def sweep(scenes, methods: Sequence[str] = ("mrcs", "power_sampling"), budgets=((100, 300),),
          seeds: Sequence[int] = (0,), *, lights=10_000, client=None, workers: Optional[int] = None,
          out=None, reference_dir=None, device: str = "auto", visibility: Optional[str] = None,
          shadow_map_size: Optional[int] = None, options: Optional[dict] = None, rerun_errors: bool = False,
          light_models: Optional[dict] = None, truth=None, progress: Optional[bool] = None,
          connect_timeout: float = 10.0, on_row: Optional[Callable[[dict], None]] = None):
    """Run every render of methods x budgets x seeds x scenes as Dask tasks; one DataFrame row per render.

    Args:
        scenes: a list of scene XML paths, bundled scene names (``"cbox"``) or ``(path, parameters)`` pairs;
            parameters are ``load_scene``'s (``{"res": 64}``, ``{"size": (64, 48)}``); with ``"frames"``: [one
            dict per frame] the scene is an animation (``load_animation``; the other parameters are common to
            every frame). Paths must be valid on the workers (a shared file system on a real cluster).
        methods: for still scenes any of ``"mrcs"`` (takes rows and columns), ``"power_sampling"``,
            ``"instant_radiosity"``, ``"light_bvh_sampling"``, ``"ris_sampling"`` and ``"stochastic_lightcuts"``
            (columns only: they take each distinct column count of ``budgets`` once, their rows are 0; the
            light-tree samplers read it as light samples per view sample, Stochastic Lightcuts as its cut
            size), ``"lightcuts"`` and ``"reconstruction_cuts"`` (columns only: the largest cut per view
            sample, ``options`` may set ``error``), ``"lightslice"`` (rows = slices, columns = clusters per slice), ``"clustered_visibility"``; for animations ``"tensor_clustering"`` and ``"mrcs_per_frame"`` (rows and
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
            model's brute-force reference adds it with seed ``worker.REFERENCE_BIAS_SEED``, 2^64 - 1). Every render runs once per model; rows name
            their model in ``light_model`` (None without the axis). Each worker caches each model's matrix.
        truth: the image the error is measured against instead of each model's brute force: an image file
            (EXR or ``.npy``, (H, W, 3+)) for every scene, or a list of one path or None per scene (a
            converged Mitsuba reference: ``rel_l2`` is then against it, ``rel_l2_brute_force`` against the
            brute force and ``reference_rel_l2`` the brute force's own error against it).
        rerun_errors: with ``out``, also run again the rows stored with ``status="error"``.
        progress: the count and the running best error per method (None: a bar in a terminal or notebook,
            nothing in logs; True: also a few lines in logs; False: nothing).
        connect_timeout: seconds to wait for a scheduler given by address.
        on_row: called with each new row (a dict) after it is written.

    Returns:
        pandas DataFrame, one row per render in task order (scene, method, budget, seed), columns: task (the
        row's key), scene (as given), params (JSON), scene_hash (sha256 of the scene folder), lights (n),
        method, rows, columns, clusters (columns rendered), seed (Int64), status ("ok" / "error"), error
        (type: message, or None), light_model (its name, or None), rel_l2 (relative L2 against the truth, float64),
        relmse, smape and flip (``metrics.relmse`` / ``metrics.smape`` / ``metrics.flip``, HDR-FLIP, against the
        same truth; NaN for animations, flip NaN without the optional ``flip-evaluator`` package),
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
        RuntimeError (``_utils.files.LockedError``): another sweep (thread, process or host) is writing ``out``:
            each sweep holds ``<out>.lock`` (its pid, host and start time) while it runs; a lock of a dead
            process of this host is taken over.
    """
    local = client is None
    specs = scene_specs(scenes, local=local)
    methods = parse_methods(methods)
    budgets = parse_budgets(budgets)
    seeds = parse_seeds(seeds)
    lights = parse_lights(lights)
    options = parse_options(options, methods)
    models = parse_light_models(light_models)
    truths = parse_truth(truth, specs)
    check_kinds(specs, methods)
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

    tasks = make_tasks(specs, methods, budgets, seeds, lights, matrix, options, models, truths)
    order = {t["task"]: i for i, t in enumerate(tasks)}
    definition = definition_of(specs, methods, budgets, seeds, lights, matrix, options, models, truths)
    if out is not None:
        out = Path(out)
        if not out.parent.is_dir():
            raise FileNotFoundError(f"out={out}: the directory {out.parent} does not exist")
    # One sweep at a time per out file (threads, processes, hosts): a second one is refused, not mixed in.
    with exclusive(out, "sweep") if out is not None else contextlib.nullcontext():
        done: dict[str, dict] = {}
        if out is not None:
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
                cl, owned = connect(client, workers, connect_timeout, device)
                try:
                    _run_dask(cl, todo, reference_dir, accept)
                finally:
                    release(cl, owned)
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
    refs: dict = {}
    for t in todo:
        rid = _ref_id(t)
        if rid not in refs:
            try:
                refs[rid] = worker.reference(t["scene"], t["lights"], t["matrix"], reference_dir,
                                                   t.get("bias_compensation"))
            except Exception as e:  # noqa: BLE001  (every task of this scene gets the error row)
                refs[rid] = e
        ref = refs[rid]
        accept(_error_row(t, ref) if isinstance(ref, BaseException) else worker.render(t, ref))


def _run_dask(client, todo: list[dict], reference_dir: str, accept) -> None:
    """Submit one reference task per (scene, lights, matrix) and one render task per row; accept rows as
    they complete. Dask reruns the tasks of a worker that dies; a task that still fails (the reference
    raised, or ``KilledWorker`` after repeated deaths) becomes an error row."""
    from dask.distributed import as_completed

    resources = gpu_resources(client)
    stamp = hashlib.sha256(f"{os.getpid()} {time.time_ns()}".encode()).hexdigest()[:10]
    refs: dict = {}
    futures = {}
    for i, t in enumerate(todo):
        rid = _ref_id(t)
        if rid not in refs:
            refs[rid] = client.submit(worker.reference, t["scene"], t["lights"], t["matrix"], reference_dir,
                                      t.get("bias_compensation"), key=f"manylights-reference-{stamp}-{len(refs)}", pure=False,
                                      resources=resources)
        f = client.submit(worker.render, t, refs[rid], key=f"manylights-render-{stamp}-{i}", pure=False,
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
