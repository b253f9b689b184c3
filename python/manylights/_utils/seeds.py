"""Seeds derived from a user's seed, so that every random choice is reproducible and streams are independent."""
from __future__ import annotations

import numpy as np


def derived_seed(seed: int, stream: int) -> int:
    """A seed in [0, 2^63) from (seed, stream), independent across streams (numpy SeedSequence)."""
    state = np.random.SeedSequence([int(seed), int(stream)]).generate_state(2, np.uint32)
    return int((int(state[0]) << 31) ^ int(state[1])) & ((1 << 63) - 1)

