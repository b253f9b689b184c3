"""Connecting to a Dask cluster (``dask.distributed``, an optional dependency imported when a cluster is asked
for): a given client, a scheduler address, or a new ``LocalCluster`` sized for this machine."""
from __future__ import annotations

import logging
import os
from typing import Optional

from .. import _native


def connect(client, workers: Optional[int], connect_timeout: float, device: str):
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


def release(client, owned: bool) -> None:
    """Close ``client`` and its local cluster when ``connect`` made them (``owned``); a client the caller gave
    stays open."""
    if owned:
        cluster = client.cluster
        client.close()
        if cluster is not None:
            cluster.close()


def default_workers(device: str = "auto") -> int:
    """Worker processes of the default ``LocalCluster``: one per hardware GPU adapter when the sweep runs on
    a GPU, else (CPU backend or a software adapter) 2 when the machine has 2+ cores, else 1."""
    info = _native.device_info(device)
    if info.get("kind") == "gpu" and not info.get("is_software"):
        return 1  # wgpu exposes one adapter to a process; more GPUs need one worker per GPU (docs/guide/sweep-cluster.md)
    return 2 if (os.cpu_count() or 1) >= 2 else 1


def gpu_resources(client) -> Optional[dict]:
    """{"GPU": 1} when the cluster's workers advertise a GPU resource (``dask worker --resources GPU=1``)."""
    try:
        workers = client.scheduler_info().get("workers", {})
    except Exception:  # noqa: BLE001
        return None
    if any("GPU" in (w.get("resources") or {}) for w in workers.values()):
        return {"GPU": 1}
    return None
