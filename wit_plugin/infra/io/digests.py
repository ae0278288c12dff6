"""Content digests: how a rerun tells whether an input changed — by its bytes, never by its file time or path.

SHA-256 throughout (hardware-accelerated on current CPUs: a whole city's orthoimage sheets hash in seconds),
hex, cut to 32 characters: 128 bits, ample for telling versions of one input apart.
"""
from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Iterable

from .fileio import file_family
from .raster_io import open_raster, read_window

DIGEST_CHARS = 32
CHUNK = 1 << 20


def raw_digest(*parts: bytes | str) -> bytes:
    """The SHA-256 of ``parts`` in order, each length-prefixed (so ``("ab", "c")`` and ``("a", "bc")`` differ)."""
    hasher = hashlib.sha256()
    for part in parts:
        data = part.encode("utf-8") if isinstance(part, str) else part
        hasher.update(len(data).to_bytes(8, "little"))
        hasher.update(data)
    return hasher.digest()


def digest(*parts: bytes | str) -> str:
    """``raw_digest`` in hex, cut to ``DIGEST_CHARS``."""
    return raw_digest(*parts).hex()[:DIGEST_CHARS]


def file_digest(path: str | os.PathLike) -> str:
    """The digest of a file's bytes and of its sidecars that exist (a GeoTIFF's .aux.xml, world file…),
    each with its name: what GDAL reads when it opens the file."""
    hasher = hashlib.sha256()
    for member in (p for p in file_family(path) if p.is_file()):
        hasher.update(member.name.encode("utf-8"))
        with open(member, "rb") as handle:
            while chunk := handle.read(CHUNK):
                hasher.update(chunk)
    return hasher.hexdigest()[:DIGEST_CHARS]


def raster_window_digest(path: str | os.PathLike, bounds: tuple[float, float, float, float],
                         margin_cells: int, extra: Iterable[str] = ()) -> str:
    """The digest of band 1's cells covering ``bounds`` (the raster's own CRS) plus ``margin_cells``, clipped to
    the raster, with where they lie (the window's corner, cell size, which sides are the raster's edges), the
    CRS, NoData and data type: what a reader of that window sees. ``extra``: further facts to mix in."""
    ds = open_raster(path, "DEM")
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    cols, rows = ds.RasterXSize, ds.RasterYSize
    us = sorted((x - x0) / dx for x in (bounds[0], bounds[2]))
    vs = sorted((y - y0) / dy for y in (bounds[1], bounds[3]))
    c0, c1 = max(0, math.floor(us[0]) - margin_cells), min(cols, math.ceil(us[1]) + margin_cells)
    r0, r1 = max(0, math.floor(vs[0]) - margin_cells), min(rows, math.ceil(vs[1]) + margin_cells)
    band = ds.GetRasterBand(1)
    if c1 <= c0 or r1 <= r0:  # off the raster: what is read there is an error, and that stays so
        return digest("outside", ds.GetProjection(), *extra)
    values = read_window(band, c0, r0, c1 - c0, r1 - r0, f"the DEM {path}")
    place = (x0 + c0 * dx, dx, y0 + r0 * dy, dy, c1 - c0, r1 - r0, c0 == 0, r0 == 0, c1 == cols, r1 == rows)
    return digest(repr(place), ds.GetProjection(), repr(band.GetNoDataValue()), str(values.dtype),
                  values.tobytes(), *extra)
