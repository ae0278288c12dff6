"""The gml:ids of one file as 64-bit hashes, each with the point count of the ring it names.

Why hashes: a 1.6 GB model has tens of millions of ids; as Python strings in a set they took
~100 bytes each. Here an id costs 12 bytes (int64 hash + uint32 points) in sorted runs, merged
like a log-structured merge, so n ids cost O(n log n) and a lookup searches a few runs.

The hash is Python's own string hash (64-bit SipHash, ~50 ns per id where a cryptographic hash
took ~600 ns): two distinct ids share one with probability about n²/2⁶⁵ for n ids, i.e. 1 in 2
million files of 4 million ids. A collision would show as a false duplicate id, or hide a
reference to a missing id that happens to hash like an existing one; Python salts the hash per
process, so it would not repeat in another run.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

_TIER = 8
"""A run is merged into the one before once it reaches 1/_TIER of its size: few runs to search, each id copied
a few times."""


class IdStore:
    """Sorted runs of (hash, points); ``add`` returns which of the new ids were already known."""

    def __init__(self) -> None:
        self._runs: list[tuple[np.ndarray, np.ndarray]] = []

    def __len__(self) -> int:
        return sum(len(keys) for keys, _ in self._runs)

    def add(self, keys: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Add ids (their ``hashes``, in file order) with their ring point counts (0: not a ring).

        Returns a boolean mask of the duplicates: every occurrence after the first, in this call
        or any earlier one.
        """
        if not len(keys):
            return np.zeros(0, dtype=bool)
        order = np.argsort(keys, kind="stable")  # equal hashes stay in file order
        sorted_keys = keys[order]
        dup_sorted = np.r_[False, sorted_keys[1:] == sorted_keys[:-1]] | self.find(sorted_keys)[0]
        duplicate = np.empty(len(keys), dtype=bool)
        duplicate[order] = dup_sorted
        if not dup_sorted.all():
            fresh = ~dup_sorted
            self._runs.append((sorted_keys[fresh], points.astype(np.uint32)[order][fresh]))
        while len(self._runs) > 1 and len(self._runs[-2][0]) <= _TIER * len(self._runs[-1][0]):
            self._runs.append(_merge_runs(self._runs.pop(), self._runs.pop()))
        return duplicate

    def find(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(found, points) for each hash (searched in sorted order: several times faster in big runs)."""
        if not len(keys) or not self._runs:
            return np.zeros(len(keys), dtype=bool), np.zeros(len(keys), dtype=np.uint32)
        order = np.argsort(keys)
        needles = keys[order]
        found = np.zeros(len(keys), dtype=bool)
        points = np.zeros(len(keys), dtype=np.uint32)
        for run_keys, run_points in self._runs:
            at = np.minimum(np.searchsorted(run_keys, needles), len(run_keys) - 1)
            hit = run_keys[at] == needles
            found[order[hit]] = True
            points[order[hit]] = run_points[at[hit]]
        return found, points


def _merge_runs(new: tuple[np.ndarray, np.ndarray],
                old: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One sorted run (hashes, points) from two whose hashes differ: linear, no temporary copy of either."""
    at = np.searchsorted(old[0], new[0])
    at += np.arange(len(at))  # where the new run's hashes land in the merged run
    from_new = np.zeros(len(old[0]) + len(at), dtype=bool)
    from_new[at] = True
    merged = []
    for n, o in zip(new, old):
        out = np.empty(len(from_new), dtype=o.dtype)
        out[at] = n
        out[~from_new] = o
        merged.append(out)
    return merged[0], merged[1]


def hashes(strings: Sequence[str]) -> np.ndarray:
    """64-bit hashes (int64) of ``strings``."""
    return np.fromiter(map(hash, strings), dtype=np.int64, count=len(strings))
