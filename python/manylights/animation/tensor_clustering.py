"""``tensor_clustering``: an animation rendered by tensor clustering, in this process or with its chunks of
frames on a Dask cluster (``animation.tensor_dask``)."""
from __future__ import annotations

from typing import Optional

from .._utils import validate as _v
from .._utils.keywords import checked_keywords
from .tensor import LightTensor
from .tensor_clusters import render_clustered
from .tensor_dask import distributed_tensor_clustering


@checked_keywords()
def tensor_clustering(T, rows: int = 100, columns: int = 300, seed: int = 0, *, chunk: int = 40,
                      representative: str = "centroid", init_clusters: int = 100, time_weight: float = 1.0,
                      row_indices=None, progress: Optional[bool] = None, client=None, connect_timeout: float = 10.0,
                      first_chunk: int = 0):
    """Render an animation by tensor clustering (Hašan, Velázquez, Pellacini, Bala, EGSR 2008, Sec. 4).

    The same ``rows`` stratified view samples are computed in every frame (the r slices, ``T.slices``), the
    n x f light-frame pairs of the reduced tensor are clustered (``cluster_tensor``: ``columns`` per frame on
    average, ``columns * f`` in all, chunks of ``chunk`` frames), each cluster's representative column is
    rendered once in its own frame and carried into every frame of its cluster by the pixel mappings,
    scaled by Rec (Sec. 4.5), and each frame adds what its camera sees of emitters. On the GPU backend the
    representative columns never leave the GPU: they are scaled, mapped and accumulated there and each
    chunk's frames are read back once (Sec. 5; ``_native.tensor_reconstruct_gpu``); on the CPU backend
    ``_native.tensor_accumulate`` does the same with rayon. The two agree to float round-off.

    Args:
        T: a ``LightTensor``.
        rows: r, view samples sampled in every frame (ignored with ``row_indices``).
        columns: representative columns per frame on average (the paper's budget: 300-500 shadow maps per
            frame are rows + columns); the total c = columns * f is clipped to [f, n f].
        seed: seeds the rows and the clustering.
        chunk, init_clusters, time_weight: as ``cluster_tensor``.
        representative: "centroid" (default; not in the paper: the pair whose scaled reduced column best
            matches its cluster's sum), "max" (the paper's Sec. 4.5: the pair of largest weight) or
            "sampled" (MRCS's weight-proportional choice). Measured on the bundled animation (8 frames,
            48x48, 3,000 lights, 300 shadow maps per frame): mean per-frame error 1.6% with "centroid"
            against 3.0-3.2% with "max" (per-frame MRCS at 600: 1.9-2.2%); README has the full figures.
            "centroid" considers only pairs of at least half the cluster's mean weight, so no pair the rows
            barely see is scaled up by hundreds (which made one seed in 8 an outlier at 6.4%).
        row_indices: your own view-sample rows instead of ``stratified_rows``.
        progress: progress over the slices (None: a bar in a terminal or notebook, nothing in logs; True:
            also a few lines in logs; False: nothing).
        client: a ``dask.distributed.Client`` or scheduler address: each chunk of ``chunk`` frames is one Dask
            task (a worker loads its frames from ``T.animation``'s paths and parameters; ``animation.tensor_dask``).
            Each chunk is clustered with its index (``first_chunk``), so the result equals the serial call's
            to float round-off. Timings are summed over chunks; ``budget`` adds chunks and wall_seconds.
        connect_timeout: seconds to wait for a scheduler given by address.
        first_chunk: as ``cluster_tensor``: T is chunk ``first_chunk`` onwards of a longer animation (its
            chunks are then clustered exactly as in the whole animation).

    Returns:
        AnimationResult: frames (f, H, W, 3) float32; shadow_maps_per_frame = rows + representatives
        rendered in that frame (counted); the clustering; timings per stage in seconds: row_selection,
        slices, clustering, mappings, columns (rendering the representatives), reconstruction (scaling and
        mapping them into their frames), emitted.

    Raises:
        TypeError: T is not a LightTensor. ValueError: rows or columns out of range, a bad chunk or
            representative, a negative seed; ``client`` with a T not made from an ``Animation``.
        OSError: a scheduler address not reachable within ``connect_timeout``.
    """
    if not isinstance(T, LightTensor):
        raise TypeError(f"T must be a LightTensor, got {type(T).__name__}")
    m, n, f = T.shape
    seed = _v.seed(seed)
    columns = _v.integer("columns", columns, 1, n)
    if client is not None:
        return distributed_tensor_clustering(T, rows, columns, seed, chunk, client, row_indices,
                                             _v.real("connect_timeout", connect_timeout, 0.0),
                                             dict(representative=representative, init_clusters=init_clusters,
                                                  time_weight=time_weight))
    return render_clustered(T, rows, columns, seed, chunk=chunk, representative=representative,
                            init_clusters=init_clusters, time_weight=time_weight, row_indices=row_indices,
                            progress=progress, first_chunk=first_chunk)
