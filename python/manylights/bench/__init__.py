"""Full-size benchmark figures: ``python -m manylights.bench <subcommand>``, one module per subcommand.

The library never imports this package; it runs from a clone (the benchmarks read ``scenes/`` and the stored
Mitsuba references in ``tests/references``; ``common``).

Subcommands:
    lights   the many-light figures: full global illumination of ``cbox`` (128x128) and
             ``veach-ajar`` (64x36) with area + indirect lights against the stored Mitsuba references
             (tests/references/*-gi.exr), the VPL clamp on and off, and a sweep over the number of VPLs N_i.
             Prints a table, writes ``<out>/lights.json`` and ``<out>/lights.png`` (error vs N_i).

    python -m manylights.bench lights --scene cbox --lights 100000
    python -m manylights.bench lights --scene all --lights 100000 --engine oracle

    mrcs     error against time for MRCS and its baselines (``bench.mrcs``).
    compare  power sampling, instant radiosity, MRCS and clustered visibility on one error-against-time
             chart per scene, and clustered visibility over light x view cluster counts (``bench.compare``).
    cuts     MRCS against reconstruction cuts at equal error on the same lights and rays, the MRCS paper's
             comparison, on cbox, veach-ajar and the many-emitter hall (``bench.cuts``).
    backends the CPU backend against the GPU backend: ms per column, weighted column and row (``bench.backends``).
    tensor   tensor clustering against per-frame MRCS on an animation: error and flicker against shadow maps
             per frame, speed-up over brute force (``bench.tensor``).
    relight  direct-to-indirect relighting: error against Mitsuba vs kept wavelet coefficients (the paper's
             Figure 3), on-the-fly culling, precompute time and memory, relights per second (``bench.relight``).
    calibrate the MRCS error estimate (``error_estimate``) against the true relative L2 over scenes x
             budgets x seeds: table, JSON and scatter plot (``bench.calibrate``).
    budgets  ml.render(A, target_error=e) against the cheapest fixed MRCS budget reaching e: share of seeds
             at or below e, time ratio; JSON + chart (``bench.budgets``).
    targets  ml.render(scene, target_error=e) against converged Mitsuba references: what it claims, its
             estimate and the true error per (scene, target) cell, Mitsuba's time to the same error
             (``bench.targets``).
    bias     res.bias_estimate against the true bias of the mean over 16 seeds at fixed light counts, on
             clamped-VPL interiors against converged Mitsuba references (``bench.bias``).
    scale    MRCS 300/900 time and peak memory against pixels (to 1024x768), lights (to 1M) and triangles (a
             generated room, to 2M), log-log slopes, and the paper-size point (``bench.scale``).
    vs-mitsuba time to 5/2/1% relative L2 of a converged Mitsuba reference: MRCS on the CPU and GPU backends
             against Mitsuba's path tracer (``bench.vs_mitsuba``).

Engines: ``cpu`` (default) renders ``column_sum() + emitted()`` on the CPU backend (exact rays); ``gpu``
renders the same on the GPU backend (``ray_traced`` visibility by default: on a software
GPU it is faster than shadow maps for these small images); ``oracle`` sums rows of the exact CPU oracle
(``row_exact``) plus ``emitted()`` -- the same matrix (tests/lights/test_lights.py checks GPU = oracle to 1e-7),
~50x faster on a machine without a hardware GPU.
"""
