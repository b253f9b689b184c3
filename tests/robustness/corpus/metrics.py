"""Bad-input cases: the image metrics."""
from __future__ import annotations

import numpy as np

from .common import IMG, cases_for

# --------------------------------------------------------------------------------------------------
# Metrics.

cases_for("relative_l2", [
    ("shapes differ", lambda c: c.ml.relative_l2(IMG(2, 2, 3), IMG(2, 3, 3) + 1), ["shape"]),
    ("zero reference", lambda c: c.ml.relative_l2(IMG(2, 2, 3), IMG(2, 2, 3)), ["zero"]),
    ("empty", lambda c: c.ml.relative_l2(IMG(0, 3), IMG(0, 3)), ["empty"]),
    ("NaN in image", lambda c: c.ml.relative_l2(np.full((2, 2, 3), np.nan, np.float32), IMG(2, 2, 3) + 1),
     ["nan", "image"]),
    ("inf in reference", lambda c: c.ml.relative_l2(IMG(2, 2, 3), np.full((2, 2, 3), np.inf, np.float32)),
     ["inf", "reference"]),
])
cases_for("relative_l2", [("strings", lambda c: c.ml.relative_l2(np.full((2,), "a"), np.full((2,), "b")), ["'a'"])],
          raises=("TypeError",))
cases_for("fraction_within", [
    ("shapes differ", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 3, 3)), ["shape"]),
    ("empty", lambda c: c.ml.fraction_within(IMG(0, 3), IMG(0, 3)), ["empty"]),
    ("negative tolerance", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 2, 3), rel=-1), ["rel"]),
    ("NaN tolerance", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 2, 3), abs_=float("nan")), ["abs_"]),
    ("NaN reference", lambda c: c.ml.fraction_within(IMG(2, 2, 3), np.full((2, 2, 3), np.nan)), ["nan"]),
])
cases_for("metrics.error_map", [
    ("shapes differ (would broadcast)", lambda c: __import__("manylights.metrics").metrics.error_map(
        IMG(4, 4, 3), IMG(1, 1, 3)), ["shape"]),
    ("2-D image", lambda c: __import__("manylights.metrics").metrics.error_map(IMG(4, 4), IMG(4, 4)), ["(H, W"]),
])
