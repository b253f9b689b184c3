"""The light matrix A (``light_matrix``) and the choice of its rows (``rows``)."""
