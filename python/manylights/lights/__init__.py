"""Lights of a scene: generation of the many-light columns (``generate``) and gather clouds (``gather``)."""
