"""Building the colour store: an adaptive quadtree of cells over the orthoimage (``wit:buildcolorstore``)."""
from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from osgeo import gdal

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gdal_env import capped_block_cache
from ..infra.io.fileio import atomic_file
from ..infra.io.raster_io import open_raster, read_window
from .backends import _GpkgWriter, _PostgisWriter, _redact
from .schema import (
    DEFAULT_BLOCK_SIZE,
    DEFAULT_TABLE,
    DEFAULT_TOLERANCE,
    FORMAT,
    FORMAT_VERSION,
    METRICS,
    _Cells,
    _check_table_name,
)

_INDEX_SHARE = 95.0  # progress share of the quadtree; the spatial index and metadata take the rest


@dataclass
class BuildReport:
    """What ``build_color_store`` wrote, with the paper's Table 14 figures (sizes) and ours."""

    output: str
    """GeoPackage path, or the PostGIS DSN (password hidden)."""
    backend: str  # "gpkg" or "postgis"
    table: str
    width: int
    height: int
    pixel_size: tuple[float, float]
    tolerance: float
    metric: str
    max_depth: int
    block_size: int
    cells: int = 0
    levels: dict[int, int] = field(default_factory=dict)
    """Number of cells per quadtree level (0 = root block)."""
    cells_over_tolerance: int = 0
    """Cells stopped by ``max_depth`` while their error (``metric``) still exceeds ``tolerance``."""
    max_error: float = 0.0
    """Largest |reconstruction − source| over all pixels and channels (0–255 units)."""
    mean_error: float = 0.0
    """Mean |reconstruction − source| over all pixels and channels."""
    image_bytes: int = 0
    """Uncompressed RGB size of the ortho (width × height × 3), the paper's raster figure."""
    image_file_bytes: int = 0
    """Size of the ortho file on disk (compressed or not)."""
    store_bytes: int = 0
    """GeoPackage file size, or PostGIS total relation size (tables + indexes)."""


def build_color_store(
    ortho: str | os.PathLike,
    output: str | os.PathLike | None,
    tolerance: float = DEFAULT_TOLERANCE,
    max_depth: int | None = None,
    feedback: Feedback = SILENT,
    postgis_dsn: str | None = None,
    table: str = DEFAULT_TABLE,
    block_size: int = DEFAULT_BLOCK_SIZE,
    metric: str = "rms",
) -> BuildReport:
    """Build the colour store of the RGB orthoimage ``ortho`` (see the module docstring).

    ``output`` is the GeoPackage to write; pass ``None`` with ``postgis_dsn`` to write to PostGIS
    instead (``table`` may then be ``schema.table``). ``max_depth`` defaults to the depth of
    1-pixel cells (log2 ``block_size``). ``metric`` is how a cell's error is measured against
    ``tolerance``: ``rms`` (default; sensor noise and fine texture average out) or ``max`` (a hard
    bound at every pixel, at the cost of many more cells on real imagery). Raises ``InputError`` for unusable inputs and
    ``CanceledError`` on cancel; neither leaves a store behind.
    """
    if (output is None) == (postgis_dsn is None):
        raise InputError("Give either an output GeoPackage or a PostGIS connection, not both or neither.")
    if metric not in METRICS:
        raise InputError(f"Unknown error metric {metric!r}: use one of {', '.join(METRICS)}.")
    if not 0.0 <= tolerance <= 255.0:
        raise InputError(f"Tolerance {tolerance} is out of range: use 0–255 (colour levels).")
    if block_size < 2 or block_size > 4096 or block_size & (block_size - 1):
        raise InputError(f"Block size {block_size} must be a power of two between 2 and 4096 pixels.")
    full_depth = int(math.log2(block_size))
    if max_depth is None:
        max_depth = full_depth
    elif max_depth < 0:
        raise InputError(f"Maximum depth {max_depth} must be 0 or more.")
    max_depth = min(max_depth, full_depth)
    _check_table_name(table, schema_allowed=postgis_dsn is not None)
    if output is not None and Path(output).suffix.lower() != ".gpkg":
        raise InputError(f"Output {output} must be a GeoPackage (.gpkg).")
    with capped_block_cache():
        ds = _open_ortho(ortho)
        gt = ds.GetGeoTransform()
        width, height = ds.RasterXSize, ds.RasterYSize
        report = BuildReport(
            output=_redact(postgis_dsn) if postgis_dsn is not None else str(output), table=table,
            backend="gpkg" if output is not None else "postgis", width=width, height=height,
            pixel_size=(gt[1], -gt[5]), tolerance=float(tolerance), metric=metric, max_depth=max_depth,
            block_size=block_size, image_bytes=width * height * 3,
            image_file_bytes=sum(os.path.getsize(f) for f in ds.GetFileList() or [] if os.path.isfile(f)))
        meta = {"format": FORMAT, "version": FORMAT_VERSION, "source": str(ortho), "width": width,
                "height": height, "geotransform": list(gt), "crs_wkt": ds.GetProjection(),
                "tolerance": float(tolerance), "metric": metric, "max_depth": max_depth,
                "block_size": block_size}
        srs = ds.GetSpatialRef()
        feedback.info(f"Colour store of {ortho}: {width} × {height} px, tolerance {tolerance:g} ({metric}), "
                      f"blocks of {block_size} px, max depth {max_depth}.")
        if output is not None:
            with atomic_file(output) as tmp:
                gpkg = _GpkgWriter(tmp, table, srs)
                try:
                    _build(ds, gpkg, report, feedback)
                    gpkg.finish(_meta_with(meta, report))
                finally:
                    gpkg.close()
            report.store_bytes = os.path.getsize(output)
        elif postgis_dsn is not None:  # (exactly one of the two: checked above)
            postgis = _PostgisWriter(postgis_dsn, table, srs, feedback)
            try:
                _build(ds, postgis, report, feedback)
                report.store_bytes = postgis.finish(_meta_with(meta, report))
            finally:
                postgis.close()
    feedback.info(f"{report.cells} cells in {len(report.levels)} levels, max error {report.max_error:.1f}, "
                  f"mean error {report.mean_error:.2f}; store {report.store_bytes / 1e6:.1f} MB for "
                  f"{report.image_bytes / 1e6:.1f} MB of RGB pixels.")
    feedback.progress(100.0)
    return report


def _meta_with(meta: dict[str, Any], report: BuildReport) -> dict[str, Any]:
    return {**meta, "cells": report.cells, "levels": {str(k): v for k, v in report.levels.items()},
            "max_error": report.max_error, "mean_error": report.mean_error,
            "cells_over_tolerance": report.cells_over_tolerance, "image_bytes": report.image_bytes}


def _open_ortho(path: str | os.PathLike) -> gdal.Dataset:
    """Open the ortho and refuse what the store cannot represent, saying what to do instead."""
    ds = open_raster(path, "orthoimage")
    types = {gdal.GetDataTypeName(ds.GetRasterBand(b).DataType) for b in range(1, min(ds.RasterCount, 3) + 1)}
    if ds.RasterCount < 3 or types != {"Byte"}:
        raise InputError(f"{path} is not an RGB orthoimage: the colour store needs 3 bands of Byte, it has "
                         f"{ds.RasterCount} band(s) of {', '.join(sorted(types)) or 'no type'}.")
    gt = ds.GetGeoTransform(can_return_null=True)
    if gt is None:
        raise InputError(f"{path} is not georeferenced: run wit:georeference first.")
    if gt[2] != 0 or gt[4] != 0 or gt[1] <= 0 or gt[5] >= 0:
        raise InputError(f"{path} is rotated or not north-up: warp it north-up (gdalwarp) first.")
    if not ds.GetProjection():
        raise InputError(f"{path} has no CRS: assign one (e.g. EPSG:5186) first.")
    if ds.RasterXSize < 2 or ds.RasterYSize < 2:
        raise InputError(f"{path} is {ds.RasterXSize} × {ds.RasterYSize} px: the store needs at least 2 × 2.")
    return ds


def _build(ds: gdal.Dataset, writer: _GpkgWriter | _PostgisWriter, report: BuildReport,
           feedback: Feedback) -> None:
    """Run the quadtree over every root block, streaming cells to ``writer``; fill ``report``."""
    width, height, size = ds.RasterXSize, ds.RasterYSize, report.block_size
    gt = ds.GetGeoTransform()
    origins = [(bx, by) for by in range(0, height - 1, size) for bx in range(0, width - 1, size)]
    error_sum = 0.0
    for k, (bx, by) in enumerate(origins):
        feedback.check_canceled()
        w, h = min(size + 1, width - bx), min(size + 1, height - by)
        block = read_window(ds, bx, by, w, h, f"the orthoimage {ds.GetDescription()}",
                            band_list=[1, 2, 3]).astype(np.float32)
        cells, errors = _quadtree(block, size, report.tolerance, report.max_depth, report.metric)
        own = errors[:, :min(size, height - by), :min(size, width - bx)]  # shared edges counted once
        report.max_error = max(report.max_error, float(own.max()))
        error_sum += float(own.sum(dtype=np.float64))
        cells.lattice += (bx, by, bx, by)
        report.cells += len(cells.level)
        report.cells_over_tolerance += cells.over
        for level, count in zip(*np.unique(cells.level, return_counts=True)):
            report.levels[int(level)] = report.levels.get(int(level), 0) + int(count)
        writer.write(cells, _rectangles(gt, cells.lattice))
        feedback.progress(_INDEX_SHARE * (k + 1) / len(origins))
    report.levels = dict(sorted(report.levels.items()))
    report.mean_error = error_sum / (width * height * 3)


def _quadtree(block: np.ndarray, size: int, tolerance: float, max_depth: int,
              metric: str) -> tuple[_Cells, np.ndarray]:
    """Leaf cells of one root block ((3, h, w) float32 pixels) and the per-pixel abs error.

    Level by level, all candidate cells are fitted at once, in groups of equal shape (cells are
    clipped to the block at the image's right and bottom edges; empty ones are dropped).
    """
    h, w = block.shape[1:]
    errors = np.zeros_like(block)
    x, y = np.zeros(1, np.int64), np.zeros(1, np.int64)  # candidate cells' nominal corners (LT)
    levels, lattices, colors, over = [], [], [], 0
    for level in range(max_depth + 1):
        s = size >> level
        cw, ch = np.minimum(s, w - 1 - x), np.minimum(s, h - 1 - y)
        split = np.zeros(len(x), bool)
        for gw, gh in set(zip(cw.tolist(), ch.tolist())):
            sel = np.flatnonzero((cw == gw) & (ch == gh))
            corners, err = _fit(block, x[sel], y[sel], gw, gh)
            bad = _cell_error(err, metric) > tolerance
            leaf = ~bad if level < max_depth and s > 1 else np.ones(len(sel), bool)
            over += int(np.count_nonzero(bad & leaf))
            split[sel[~leaf]] = True
            lx, ly = x[sel[leaf]], y[sel[leaf]]
            rows = ly[:, None, None] + np.arange(gh + 1)[None, :, None]
            cols = lx[:, None, None] + np.arange(gw + 1)[None, None, :]
            errors[:, rows, cols] = err[:, leaf]
            levels.append(np.full(len(lx), level))
            lattices.append(np.stack([lx, ly, lx + gw, ly + gh], axis=1))
            colors.append(corners[leaf])
        if not split.any():
            break
        half = s // 2
        x = np.concatenate([x[split] + dx for dy in (0, half) for dx in (0, half)])
        y = np.concatenate([y[split] + dy for dy in (0, half) for dx in (0, half)])
        keep = (x < w - 1) & (y < h - 1)
        x, y = x[keep], y[keep]
    return _Cells(np.concatenate(levels), np.concatenate(lattices), np.concatenate(colors), over), errors


def _cell_error(err: np.ndarray, metric: str) -> np.ndarray:
    """Per-cell error from abs errors (3, n, h, w): the largest, or the root mean square."""
    if metric == "max":
        return err.max(axis=(0, 2, 3))
    return np.sqrt(np.mean(np.square(err), axis=(0, 2, 3)))


def _fit(block: np.ndarray, x: np.ndarray, y: np.ndarray, cw: int, ch: int) -> tuple[np.ndarray, np.ndarray]:
    """Corner colours ((n, 12) uint8) and abs reconstruction errors ((3, n, ch+1, cw+1)) of n cells."""
    rows = y[:, None, None] + np.arange(ch + 1)[None, :, None]
    cols = x[:, None, None] + np.arange(cw + 1)[None, None, :]
    samples = block[:, rows, cols]  # (3, n, ch+1, cw+1), row 0 at the top
    lb, rb, rt, lt = (samples[:, :, -1, 0], samples[:, :, -1, -1], samples[:, :, 0, -1], samples[:, :, 0, 0])
    u = (np.arange(cw + 1, dtype=np.float32) / cw)[None, None, None, :]
    v = (np.arange(ch, -1, -1, dtype=np.float32) / ch)[None, None, :, None]  # 1 at the top row
    bottom = lb[..., None, None] + (rb - lb)[..., None, None] * u
    top = lt[..., None, None] + (rt - lt)[..., None, None] * u
    err = np.abs(samples - (bottom + (top - bottom) * v))
    corners = np.stack([lb, rb, rt, lt], axis=0)  # (4, 3, n)
    return corners.transpose(2, 0, 1).reshape(len(x), 12).astype(np.uint8), err


def _rectangles(gt: Sequence[float], lattice: np.ndarray) -> np.ndarray:
    """Cell rectangles (shapely Polygons) in the ortho CRS from lattice bounds."""
    x = gt[0] + (lattice[:, [0, 2]] + 0.5) * gt[1]
    y = gt[3] + (lattice[:, [3, 1]] + 0.5) * gt[5]  # r1 is the bottom (smaller y)
    return shapely.box(x[:, 0], y[:, 0], x[:, 1], y[:, 1])
