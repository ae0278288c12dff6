"""GDAL settings and opening shared by the raster steps."""
from __future__ import annotations

import contextlib
from typing import Iterator

from osgeo import gdal

from .errors import InputError

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


def open_raster(path: str) -> gdal.Dataset:
    """Open a raster or raise ``InputError`` with GDAL's reason (with or without GDAL exceptions)."""
    try:
        ds = gdal.Open(str(path))
    except RuntimeError as exc:
        raise InputError(f"Cannot open {path} as a raster: {exc}") from exc
    if ds is None:
        raise InputError(f"Cannot open {path} as a raster: {gdal.GetLastErrorMsg() or 'unknown format'}.")
    return ds
