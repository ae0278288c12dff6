"""The vector-based colour store (``wit:buildcolorstore``, ``wit:querycolorstore``; SPEC §5.4).

The paper (§4.1, Table 14) stores, per cell, the RGB colours at the cell's four corners (LB, RB,
RT, LT) and its resolution in a spatial database, and answers "colour(s) at this place" with a
query instead of loading an image. This module defines that store precisely:

* **Lattice.** Cells live on the lattice of pixel *centres*: lattice point (c, r) is the centre of
  pixel column c, row r, at x = X0 + (c + ½)·px, y = Y0 − (r + ½)·py. A cell spans lattice
  columns c0…c1 and rows r0…r1 (c1 > c0, r1 > r0); its corner colours are the source pixels at
  its four corner points, exactly, so the reconstruction is exact at cell corners. Neighbouring
  cells share their edge lattice lines. The stored domain is the image extent shrunk by half a
  pixel; queries in that outer half-pixel border take the colour at the nearest domain point.
* **Reconstruction.** Inside a cell, colour = LB(1−u)(1−v) + RB·u(1−v) + RT·uv + LT(1−u)v with
  u = (c − c0)/(c1 − c0) from left to right and v = (r1 − r)/(r1 − r0) from bottom to top.
* **Adaptive quadtree.** The image is processed in root blocks of ``block_size`` lattice
  intervals (level 0), each read with one windowed ``ReadAsArray``. A cell is split into four
  while its reconstruction error over the source pixels it covers (all channels, 0–255 units)
  exceeds ``tolerance`` and it is above ``max_depth`` and wider than one lattice interval (such a
  cell has all its pixels as corners: exact). The error is the root mean square (``rms``, the
  default: sensor noise and fine texture average out) or the largest (``max``: a hard bound, but
  on real orthophotos it splits most cells down to a few pixels). Cells of a level are evaluated
  at once with numpy, grouped by shape (edge blocks are clipped to the image).
* **Guarantee** (``max``). Every stored cell within ``max_depth`` errs by at most ``tolerance``
  at every pixel centre. Within one pixel square both the store and the source's bilinear
  interpolation are bilinear, so the store is within ``tolerance`` of the source's bilinear
  interpolation *everywhere* in the domain; rounding the answer to integers adds at most ½.
  With ``rms`` the same holds for each cell's root mean square over its pixels.
* **Storage.** A GeoPackage by default (OGR's GPKG driver, which builds the R-tree): table
  ``table`` with the cell rectangle (Polygon, ortho CRS) as geometry and INTEGER columns
  ``level``, ``c0 r0 c1 r1`` (the lattice bounds, so that interpolation is exact whatever the
  float rounding of the geometry) and ``lb_r lb_g lb_b rb_* rt_* lt_*``; table ``<table>_meta``
  (key, JSON value) with the source, grid, CRS, tolerance and build figures. Or PostGIS when a
  connection string is given: the same tables (``geometry(Polygon, srid)`` with a GiST index,
  smallint colours), written with COPY in one transaction.
* **Queries.** A point finds one containing cell through the R-tree / GiST index (then filtered
  exactly on the lattice bounds); a patch fetches all cells meeting the requested box and
  rasterises them with the bilinear formula above, vectorised over texels.

Atomicity: a GeoPackage is written under a temporary name and renamed when complete; a PostGIS
store is created (replacing a previous one of the same name) in a single transaction, rolled back
on error or cancel. Memory is bounded by one root block, the capped GDAL cache and one batch.
PostgreSQL is reached through psycopg2 (Debian's python3-psycopg2, which QGIS's Python already
depends on), imported only when a PostGIS store is used.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import sqlite3
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from osgeo import gdal, ogr, osr

from .errors import InputError, MissingDependencyError, WitError
from .feedback import SILENT, Feedback
from .gdal_env import capped_block_cache
from .io.fileio import atomic_file
from .io.raster_io import open_raster, read_window

DEFAULT_TABLE = "color_cells"
DEFAULT_TOLERANCE = 12.0
DEFAULT_BLOCK_SIZE = 256
METRICS = ("rms", "max")
FORMAT = "wit-colorstore"
FORMAT_VERSION = 1
CORNERS = ("lb", "rb", "rt", "lt")
LATTICE_COLUMNS = ("c0", "r0", "c1", "r1")
COLOR_COLUMNS = tuple(f"{corner}_{band}" for corner in CORNERS for band in "rgb")
CELL_COLUMNS = ("level", *LATTICE_COLUMNS, *COLOR_COLUMNS)
_QUERY_COLUMNS = CELL_COLUMNS  # what queries fetch
_TABLE_NAME = re.compile(r"^(?:[A-Za-z_][A-Za-z0-9_]*\.)?[A-Za-z_][A-Za-z0-9_]*$")
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


# --- building -----------------------------------------------------------------------------------

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
            output=str(output) if output is not None else _redact(postgis_dsn), table=table,
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
                writer = _GpkgWriter(tmp, table, srs)
                try:
                    _build(ds, writer, report, feedback)
                    writer.finish(_meta_with(meta, report))
                finally:
                    writer.close()
            report.store_bytes = os.path.getsize(output)
        else:
            writer = _PostgisWriter(postgis_dsn, table, srs, feedback)
            try:
                _build(ds, writer, report, feedback)
                report.store_bytes = writer.finish(_meta_with(meta, report))
            finally:
                writer.close()
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


@dataclass
class _Cells:
    """Leaf cells of one block: level, lattice bounds (c0, r0, c1, r1) and corner colours."""

    level: np.ndarray  # (n,) int
    lattice: np.ndarray  # (n, 4) int64
    colors: np.ndarray  # (n, 12) uint8, in COLOR_COLUMNS order
    over: int = 0  # cells at max depth still over the tolerance


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


# --- writers ------------------------------------------------------------------------------------

class _GpkgWriter:
    """Cells into a new GeoPackage through OGR, which maintains the R-tree (deferred, bulk)."""

    def __init__(self, path: Path, table: str, srs: osr.SpatialReference | None):
        self.ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
        if self.ds is None:
            raise InputError(f"Cannot create GeoPackage {path}: {gdal.GetLastErrorMsg()}")
        self.table = table
        self.layer = self.ds.CreateLayer(table, srs, ogr.wkbPolygon,
                                         ["GEOMETRY_NAME=geom", "FID=fid", "SPATIAL_INDEX=YES"])
        for name in CELL_COLUMNS:
            self.layer.CreateField(ogr.FieldDefn(name, ogr.OFTInteger))
        self.defn = self.layer.GetLayerDefn()
        self.ds.StartTransaction()

    def write(self, cells: _Cells, rects: np.ndarray) -> None:
        values = np.concatenate([cells.level[:, None], cells.lattice, cells.colors], axis=1).tolist()
        for row, wkb in zip(values, shapely.to_wkb(rects)):
            feature = ogr.Feature(self.defn)
            for j, value in enumerate(row):
                feature.SetFieldInteger64(j, value)
            feature.SetGeometryDirectly(ogr.CreateGeometryFromWkb(wkb))
            self.layer.CreateFeature(feature)

    def finish(self, meta: dict[str, Any]) -> None:
        layer = self.ds.CreateLayer(f"{self.table}_meta", None, ogr.wkbNone)
        layer.CreateField(ogr.FieldDefn("key", ogr.OFTString))
        layer.CreateField(ogr.FieldDefn("value", ogr.OFTString))
        for key, value in meta.items():
            feature = ogr.Feature(layer.GetLayerDefn())
            feature.SetField("key", key)
            feature.SetField("value", json.dumps(value))
            layer.CreateFeature(feature)
        self.ds.CommitTransaction()

    def close(self) -> None:
        self.layer = self.defn = None
        self.ds = None  # closing writes the deferred R-tree


class _PostgisWriter:
    """Cells into PostGIS with COPY, in one transaction: committed by ``finish``, else rolled back."""

    def __init__(self, dsn: str, table: str, srs: osr.SpatialReference | None, feedback: Feedback):
        from psycopg2 import sql

        self.conn = _connect(dsn)
        self.cells, self.meta = _pg_names(table)
        cur = self.conn.cursor()
        self.srid = _srid(cur, srs, feedback)
        colors = sql.SQL(", ").join(sql.SQL("{} smallint NOT NULL").format(sql.Identifier(c))
                                    for c in COLOR_COLUMNS)
        lattice = sql.SQL(", ").join(sql.SQL("{} integer NOT NULL").format(sql.Identifier(c))
                                     for c in LATTICE_COLUMNS)
        cur.execute(sql.SQL("DROP TABLE IF EXISTS {t}; DROP TABLE IF EXISTS {m}; "
                            "CREATE TABLE {t} (fid bigserial PRIMARY KEY, level smallint NOT NULL, "
                            "{lattice}, {colors}, geom geometry(Polygon, {srid}) NOT NULL)").format(
            t=self.cells, m=self.meta, lattice=lattice, colors=colors, srid=sql.Literal(self.srid)))
        self.copy = sql.SQL("COPY {t} ({cols}, geom) FROM STDIN").format(
            t=self.cells, cols=sql.SQL(", ").join(map(sql.Identifier, CELL_COLUMNS))).as_string(self.conn)

    def write(self, cells: _Cells, rects: np.ndarray) -> None:
        values = np.concatenate([cells.level[:, None], cells.lattice, cells.colors], axis=1).astype(str)
        ewkb = shapely.to_wkb(shapely.set_srid(rects, self.srid), hex=True, include_srid=True)
        lines = np.column_stack([values, ewkb.astype(str)])
        text = "\n".join("\t".join(row) for row in lines.tolist()) + "\n"
        self.conn.cursor().copy_expert(self.copy, io.StringIO(text))

    def finish(self, meta: dict[str, Any]) -> int:
        from psycopg2 import sql

        cur = self.conn.cursor()
        index = sql.Identifier(f"{self.cells.strings[-1]}_geom_idx")
        cur.execute(sql.SQL("CREATE INDEX {i} ON {t} USING GIST (geom); "
                            "CREATE TABLE {m} (key text PRIMARY KEY, value text NOT NULL)").format(
            i=index, t=self.cells, m=self.meta))
        cur.executemany(sql.SQL("INSERT INTO {m} VALUES (%s, %s)").format(m=self.meta),
                        [(k, json.dumps(v)) for k, v in meta.items()])
        cur.execute(sql.SQL("ANALYZE {t}").format(t=self.cells))
        cur.execute("SELECT pg_total_relation_size(%s::regclass) + pg_total_relation_size(%s::regclass)",
                    (self.cells.as_string(self.conn), self.meta.as_string(self.conn)))
        size = int(cur.fetchone()[0])
        self.conn.commit()
        return size

    def close(self) -> None:
        self.conn.rollback()  # no-op after commit; drops everything after an error or cancel
        self.conn.close()


# --- PostgreSQL helpers -------------------------------------------------------------------------

def _connect(dsn: str) -> Any:
    """A psycopg2 connection to a database with PostGIS, or an ``InputError`` saying what is wrong."""
    try:
        import psycopg2
    except ImportError as exc:
        raise MissingDependencyError(
            "PostGIS stores need the psycopg2 package (Debian/Ubuntu: apt install python3-psycopg2; "
            "OSGeo4W and the QGIS installers ship it).") from exc
    conninfo = dsn.removeprefix("PG:")  # OGR/QGIS style "PG:dbname=..."
    try:
        conn = psycopg2.connect(conninfo, connect_timeout=10)
    except psycopg2.Error as exc:
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"Cannot connect to PostgreSQL with {_redact(dsn)}: {reason}. Check host, port, "
                         f"database, user and password.") from exc
    with conn.cursor() as cur:
        cur.execute("SELECT 1 FROM pg_extension WHERE extname = 'postgis'")
        if cur.fetchone() is None:
            conn.close()
            raise InputError(f"Database of {_redact(dsn)} has no PostGIS: run CREATE EXTENSION postgis; "
                             f"in it (as a superuser or the database owner).")
    conn.rollback()  # leave no transaction open: readers switch to autocommit
    return conn


def _pg_names(table: str) -> tuple[Any, Any]:
    """The cells and metadata table identifiers for ``table`` or ``schema.table``."""
    from psycopg2 import sql

    *schema, name = table.split(".")
    return sql.Identifier(*schema, name), sql.Identifier(*schema, f"{name}_meta")


def _srid(cur: Any, srs: osr.SpatialReference | None, feedback: Feedback) -> int:
    """The EPSG code of ``srs`` if PostGIS knows it, else 0 (unknown) with a warning."""
    code = None
    if srs is not None:
        srs = srs.Clone()
        if srs.GetAuthorityName(None) != "EPSG":
            srs.AutoIdentifyEPSG()
        if srs.GetAuthorityName(None) == "EPSG":
            code = int(srs.GetAuthorityCode(None))
    if code is not None:
        cur.execute("SELECT 1 FROM spatial_ref_sys WHERE srid = %s", (code,))
        if cur.fetchone() is not None:
            return code
    feedback.warning("The ortho's CRS has no EPSG code known to PostGIS: the store uses SRID 0; "
                     "its CRS is kept in the metadata table.")
    return 0


def _redact(dsn: str) -> str:
    """``dsn`` with its password hidden, for messages and reports."""
    dsn = re.sub(r"(://[^:/@]*:)[^@]*@", r"\1***@", dsn)
    return re.sub(r"(password\s*=\s*)('(?:[^'\\]|\\.)*'|\S+)", r"\1***", dsn)


def _is_dsn(source: str) -> bool:
    return source.startswith(("postgresql://", "postgres://", "PG:")) or "dbname=" in source


def _check_table_name(table: str, schema_allowed: bool) -> None:
    if not _TABLE_NAME.match(table) or (not schema_allowed and "." in table):
        raise InputError(f"Table name {table!r} is invalid: use letters, digits and underscores"
                         f"{' (optionally schema.table)' if schema_allowed else ''}, not starting with a digit.")


# --- reading and queries ------------------------------------------------------------------------

class _GpkgReader:
    """Cell look-ups in a GeoPackage through its R-tree, with the standard library's sqlite3."""

    def __init__(self, path: str, table: str):
        if not os.path.isfile(path):
            raise InputError(f"Colour store {path} does not exist.")
        try:
            self.db = sqlite3.connect(Path(path).resolve().as_uri() + "?mode=ro", uri=True,
                                      check_same_thread=False)
            tables = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as exc:
            raise InputError(f"{path} is not a GeoPackage: {exc}") from exc
        rtree = f"rtree_{table}_geom"
        if not {table, f"{table}_meta", rtree} <= tables:
            self.db.close()
            raise InputError(f"{path} is not a WIT colour store with table {table!r} (built by wit:buildcolorstore).")
        self.meta = {k: json.loads(v) for k, v in self.db.execute(f'SELECT key, value FROM "{table}_meta"')}
        cols = ", ".join(f'c."{c}"' for c in _QUERY_COLUMNS)
        self.sql = (f'SELECT {cols} FROM "{rtree}" r JOIN "{table}" c ON c.fid = r.id '
                    f"WHERE r.minx <= ? AND r.maxx >= ? AND r.miny <= ? AND r.maxy >= ? "
                    f"AND c.c0 <= ? AND c.c1 >= ? AND c.r0 <= ? AND c.r1 >= ?")

    def cells(self, box: tuple[float, float, float, float], lattice: tuple[float, float, float, float],
              limit: int | None) -> list[tuple]:
        xmin, ymin, xmax, ymax = box
        cmin, rmin, cmax, rmax = lattice
        query = self.sql + (f" ORDER BY c.level DESC LIMIT {int(limit)}" if limit else "")
        return self.db.execute(query, (xmax, xmin, ymax, ymin, cmax, cmin, rmax, rmin)).fetchall()

    def close(self) -> None:
        self.db.close()


class _PostgisReader:
    """Cell look-ups in PostGIS through the GiST index (``&&``)."""

    def __init__(self, dsn: str, table: str):
        from psycopg2 import sql

        _check_table_name(table, schema_allowed=True)
        self.conn = _connect(dsn)
        self.conn.autocommit = True
        cells, meta = _pg_names(table)
        with self.conn.cursor() as cur:
            cur.execute("SELECT to_regclass(%s), to_regclass(%s)",
                        (cells.as_string(self.conn), meta.as_string(self.conn)))
            if None in cur.fetchone():
                self.conn.close()
                raise InputError(f"{_redact(dsn)} has no WIT colour store {table!r} (built by wit:buildcolorstore).")
            cur.execute(sql.SQL("SELECT key, value FROM {m}").format(m=meta))
            self.meta = {k: json.loads(v) for k, v in cur.fetchall()}
            cur.execute(sql.SQL("SELECT ST_SRID(geom) FROM {t} LIMIT 1").format(t=cells))
            srid = cur.fetchone()[0]
        self.sql = sql.SQL("SELECT {cols} FROM {t} WHERE geom && ST_MakeEnvelope(%s, %s, %s, %s, {srid}) "
                           "AND c0 <= %s AND c1 >= %s AND r0 <= %s AND r1 >= %s").format(
            cols=sql.SQL(", ").join(map(sql.Identifier, _QUERY_COLUMNS)), t=cells,
            srid=sql.Literal(srid)).as_string(self.conn)
        self.cur = self.conn.cursor()

    def cells(self, box: tuple[float, float, float, float], lattice: tuple[float, float, float, float],
              limit: int | None) -> list[tuple]:
        cmin, rmin, cmax, rmax = lattice
        query = self.sql + (f" ORDER BY level DESC LIMIT {int(limit)}" if limit else "")
        self.cur.execute(query, (*box, cmax, cmin, rmax, rmin))
        return self.cur.fetchall()

    def close(self) -> None:
        self.conn.close()


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
