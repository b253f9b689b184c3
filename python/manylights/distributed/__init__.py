"""Experiment sweeps on Dask (``sweep``; the tasks as workers run them: ``worker``; their definition: ``specs``)."""
