"""Private helpers shared by the package: argument checks, progress display, seeds, atomic files, Dask connections."""
