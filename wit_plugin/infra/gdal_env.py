"""GDAL settings shared by the steps: a capped block cache, thread-local options, no sidecars, quiet errors.

Inputs are never written to: GDAL's PAM would save an ``.aux.xml`` beside an input once anything
(statistics computed by QGIS when it loads a layer, a NoData set) changes its auxiliary metadata.
``no_sidecars`` turns PAM off for the current thread only, so QGIS's own settings and its other
threads are untouched. Opening and reading rasters with these settings: ``io.raster_io``.
"""
from __future__ import annotations

import contextlib
from collections.abc import Iterator

from osgeo import gdal

CACHE_BYTES = 64 * 1024 * 1024  # GDAL block cache cap during a raster step (bounds peak memory)


@contextlib.contextmanager
def capped_block_cache() -> Iterator[None]:
    """Cap GDAL's block cache during the run: it bounds peak memory (default: 5 % of RAM).

    GDAL_NUM_THREADS is deliberately not set: with GDAL 3.6, multithreaded overview computation
    on top of multithreaded compression (NUM_THREADS) can deadlock its shared thread pool.
    """
    old_cache = gdal.GetCacheMax()
    if old_cache > CACHE_BYTES:
        gdal.SetCacheMax(CACHE_BYTES)
    try:
        yield
    finally:
        gdal.SetCacheMax(old_cache)


@contextlib.contextmanager
def thread_config(**options: str | None) -> Iterator[None]:
    """GDAL configuration options for this thread only, restored afterwards (None: unset)."""
    old = {key: gdal.GetThreadLocalConfigOption(key, None) for key in options}
    for key, value in options.items():
        gdal.SetThreadLocalConfigOption(key, value)
    try:
        yield
    finally:
        for key, value in old.items():
            gdal.SetThreadLocalConfigOption(key, value)


def no_sidecars() -> contextlib.AbstractContextManager[None]:
    """Datasets opened (and first queried) inside never write an ``.aux.xml``: PAM off, this thread.

    GDAL fixes a dataset's PAM state when its georeferencing or metadata is first read, so that
    must happen inside too (``open_raster`` does it).
    """
    return thread_config(GDAL_PAM_ENABLED="NO")


@contextlib.contextmanager
def quiet_gdal() -> Iterator[None]:
    """GDAL errors recorded (for the message) but kept off stderr; the last error is reset first."""
    gdal.ErrorReset()
    gdal.PushErrorHandler("CPLQuietErrorHandler")
    try:
        yield
    finally:
        gdal.PopErrorHandler()
