"""numpy helpers shared by the steps (numpy only: modules that must import without shapely use them)."""
from __future__ import annotations

import numpy as np


def ragged_indices(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For ragged groups of ``counts`` items: each item's group index and its index within it."""
    counts = np.asarray(counts, dtype=np.int64)
    owner = np.repeat(np.arange(len(counts)), counts)
    starts = np.cumsum(counts) - counts
    return owner, np.arange(len(owner)) - starts[owner]
