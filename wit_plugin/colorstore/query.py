"""Querying the colour store: the colour at a point, or a patch rasterised from its cells (``wit:querycolorstore``)."""
from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

import numpy as np
from osgeo import gdal

from ..infra.errors import InputError, WitError
from ..infra.io.fileio import atomic_file
from .backends import _GpkgReader, _is_dsn, _PostgisReader, _redact
from .schema import _QUERY_COLUMNS, DEFAULT_TABLE, FORMAT, FORMAT_VERSION, _check_table_name


class ColorStore:
    """An open colour store (GeoPackage or PostGIS, same API); use as a context manager."""

    def __init__(self, reader: _GpkgReader | _PostgisReader, source: str):
        self._reader = reader
        meta = reader.meta
        if meta.get("format") != FORMAT or meta.get("version") != FORMAT_VERSION:
            reader.close()
            raise InputError(f"{source} holds no colour store of format version {FORMAT_VERSION}: rebuild it.")
        self.source = source
        self.meta = meta
        self.width, self.height = int(meta["width"]), int(meta["height"])
        self.geotransform = tuple(float(v) for v in meta["geotransform"])
        self.crs_wkt: str = meta["crs_wkt"]

    @classmethod
    def open(cls, source: str | os.PathLike, table: str = DEFAULT_TABLE) -> ColorStore:
        """Open a GeoPackage path, or a PostgreSQL DSN (``postgresql://…``, ``dbname=…``, ``PG:…``)."""
        source = str(source)
        if _is_dsn(source):
            return cls(_PostgisReader(source, table), _redact(source))
        _check_table_name(table, schema_allowed=False)
        return cls(_GpkgReader(source, table), source)

    def close(self) -> None:
        self._reader.close()

    def __enter__(self) -> ColorStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """The ortho's extent (xmin, ymin, xmax, ymax): what queries accept."""
        x0, px, _, y0, _, py = self.geotransform
        return x0, y0 + self.height * py, x0 + self.width * px, y0

    def query_point(self, x: float, y: float) -> tuple[int, int, int]:
        """RGB at (x, y), bilinear in the leaf cell holding the point."""
        self._check_inside((x, y, x, y))
        c, r = self._lattice(np.array([x]), np.array([y]))
        rows = self._reader.cells(self._box(c, r), (c[0], r[0], c[0], r[0]), limit=1)
        if not rows:
            raise WitError(f"{self.source}: no cell holds ({x}, {y}); the store is incomplete: rebuild it.")
        rgb = _interpolate(np.array(rows, np.float64), np.zeros(1, np.int64), c, r)[0]
        return int(rgb[0]), int(rgb[1]), int(rgb[2])

    def query_patch(self, area: Any, resolution: float) -> np.ndarray:
        """Texture patch (H × W × 3 uint8, row 0 at the top) over ``area`` at ``resolution`` m.

        ``area`` is (xmin, ymin, xmax, ymax) or a geometry with ``.bounds`` (shapely): its bounding
        box is covered by W = round(width / resolution) × H texels (at least 1), evenly spaced,
        each coloured at its centre.
        """
        xmin, ymin, xmax, ymax = (float(v) for v in getattr(area, "bounds", area))
        if not (resolution > 0 and xmax > xmin and ymax > ymin):
            raise InputError(f"Patch needs a non-empty box and a resolution > 0 (got {area!r}, {resolution}).")
        self._check_inside((xmin, ymin, xmax, ymax))
        nx, ny = max(1, round((xmax - xmin) / resolution)), max(1, round((ymax - ymin) / resolution))
        xs = xmin + (np.arange(nx) + 0.5) * (xmax - xmin) / nx
        ys = ymax - (np.arange(ny) + 0.5) * (ymax - ymin) / ny
        c, r = self._lattice(xs, ys)
        rows = self._reader.cells(self._box(c, r), (c[0], r[0], c[-1], r[-1]), limit=None)
        cells = np.array(rows, np.float64).reshape(-1, len(_QUERY_COLUMNS))
        # Deepest last, so that it wins on shared edges as in point queries (at a T-junction it has
        # the point as a corner), and the answer does not depend on the database's row order.
        cells = cells[np.lexsort((cells[:, 2], cells[:, 1], cells[:, 0]))]
        owner = _owners(cells, c, r)
        cc, rr = np.meshgrid(c, r)
        rgb = _interpolate(cells, owner.ravel(), cc.ravel(), rr.ravel())
        return rgb.reshape(ny, nx, 3)

    def _check_inside(self, box: tuple[float, float, float, float]) -> None:
        exmin, eymin, exmax, eymax = self.extent
        slack = 1e-6 * max(abs(self.geotransform[1]), abs(self.geotransform[5]))
        if box[0] < exmin - slack or box[1] < eymin - slack or box[2] > exmax + slack or box[3] > eymax + slack:
            raise InputError(f"{box} is outside the colour store's extent {self.extent}.")

    def _lattice(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lattice coordinates of ground points, clamped to the domain (the outer half-pixel border)."""
        x0, px, _, y0, _, py = self.geotransform
        return (np.clip((x - x0) / px - 0.5, 0, self.width - 1),
                np.clip((y - y0) / py - 0.5, 0, self.height - 1))

    def _box(self, c: np.ndarray, r: np.ndarray) -> tuple[float, float, float, float]:
        """Ground box of lattice points (sorted): what the spatial index is asked for."""
        x0, px, _, y0, _, py = self.geotransform
        return x0 + (c[0] + 0.5) * px, y0 + (r[-1] + 0.5) * py, x0 + (c[-1] + 0.5) * px, y0 + (r[0] + 0.5) * py


def _owners(cells: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """For a texel grid (increasing lattice columns ``c``, rows ``r``), the index of a cell holding each.

    Each cell's texel range is found by binary search, then all (cell, texel) pairs are expanded
    at once; where cells share an edge, the later one wins.
    """
    i0, i1 = np.searchsorted(c, cells[:, 1], "left"), np.searchsorted(c, cells[:, 3], "right")
    j0, j1 = np.searchsorted(r, cells[:, 2], "left"), np.searchsorted(r, cells[:, 4], "right")
    nc, nr = np.maximum(i1 - i0, 0), np.maximum(j1 - j0, 0)
    counts = nc * nr
    k = np.repeat(np.arange(len(cells)), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    owner = np.full((len(r), len(c)), -1, np.int64)
    owner[j0[k] + local // nc[k], i0[k] + local % nc[k]] = k
    if (owner < 0).any():
        raise WitError("Some texels fall in no cell: the colour store is incomplete; rebuild it.")
    return owner


def _interpolate(cells: np.ndarray, owner: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """RGB (n, 3 uint8) at lattice points (c, r), each in cell ``owner`` (rows as ``_QUERY_COLUMNS``)."""
    cell = cells[owner]
    u = ((c - cell[:, 1]) / (cell[:, 3] - cell[:, 1]))[:, None]
    v = ((cell[:, 4] - r) / (cell[:, 4] - cell[:, 2]))[:, None]
    lb, rb, rt, lt = cell[:, 5:8], cell[:, 8:11], cell[:, 11:14], cell[:, 14:17]
    rgb = lb * (1 - u) * (1 - v) + rb * u * (1 - v) + rt * u * v + lt * (1 - u) * v
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


@contextlib.contextmanager
def _opened(store: ColorStore | str | os.PathLike, table: str) -> Iterator[ColorStore]:
    """``store`` itself, or the store at a path / DSN, opened for the call only."""
    if isinstance(store, ColorStore):
        yield store
    else:
        with ColorStore.open(store, table) as opened:
            yield opened


def query_point(store: ColorStore | str | os.PathLike, x: float, y: float,
                table: str = DEFAULT_TABLE) -> tuple[int, int, int]:
    """RGB at (x, y) from an open store or a GeoPackage path / PostGIS DSN."""
    with _opened(store, table) as s:
        return s.query_point(x, y)


def query_patch(store: ColorStore | str | os.PathLike, area: Any, resolution: float,
                table: str = DEFAULT_TABLE) -> np.ndarray:
    """Texture patch over ``area`` at ``resolution`` (see ``ColorStore.query_patch``)."""
    with _opened(store, table) as s:
        return s.query_patch(area, resolution)


def export_patch(store: ColorStore | str | os.PathLike, bbox: tuple[float, float, float, float], resolution: float,
                 output: str | os.PathLike, table: str = DEFAULT_TABLE) -> str:
    """Write ``query_patch`` over ``bbox`` as an RGB GeoTIFF in the store's CRS (atomic)."""
    with _opened(store, table) as s:
        patch = s.query_patch(bbox, resolution)
        crs_wkt = s.crs_wkt
    height, width = patch.shape[:2]
    xmin, ymin, xmax, ymax = bbox
    with atomic_file(output) as tmp:
        ds = gdal.GetDriverByName("GTiff").Create(str(tmp), width, height, 3, gdal.GDT_Byte,
                                                  ["COMPRESS=DEFLATE", "PHOTOMETRIC=RGB"])
        ds.SetGeoTransform((xmin, (xmax - xmin) / width, 0.0, ymax, 0.0, -(ymax - ymin) / height))
        ds.SetProjection(crs_wkt)
        for band in range(3):
            ds.GetRasterBand(band + 1).WriteArray(patch[:, :, band])
        ds = None
    return str(output)
