"""Pause Python's cyclic garbage collector while a step churns through millions of small objects.

Texturing and CityGML writing allocate strings, tuples and lists by the million (texture
coordinates, posLists, rows) and free them again by reference counting: they make no reference
cycles. Yet every 700 allocations CPython runs a collection, and the full ones walk every live
object of the process, which in QGIS (qgis_process, the Processing dialog) holds ~90,000 more
than a plain Python process: that is part of why the same step ran slower through QGIS. While
paused, nothing is scanned; the collector resumes as it was when the step ends, whatever the
outcome.
"""
from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator


@contextlib.contextmanager
def collector_paused() -> Iterator[None]:
    """Disable the cyclic garbage collector for the ``with`` block (re-enabled after, if it was on)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
