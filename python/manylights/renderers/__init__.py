"""Renderers of a light matrix, each returning a ``RenderResult`` (``result``): brute force, MRCS and its
clustering, error estimates, progressive rounds, budgets, baselines, clustered visibility, K-means, anti-aliasing;
and ``probes``: an unbiased path tracer at probe pixels, the reference estimator of the converged image."""
