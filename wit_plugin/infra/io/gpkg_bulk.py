"""Write one big GeoPackage layer fast: OGR makes the file, SQLite takes the rows in bulk.

The TIN of the 1 km demo has ~600,000 triangles. Through OGR one feature at a time that took
14 s (about 23 µs a feature: a Python call per field and per geometry). Here the GeoPackage
geometry blobs (header + envelope + ISO WKB, as the GeoPackage standard §2.1.3 defines them)
are built with numpy and shapely for all rows at once and inserted with ``executemany``; OGR
creates the file, the layer (tables, SRS, metadata) and its empty R-tree spatial index first; the
index is loaded at the end in one go from the rows' envelopes (``gpkg_rtree``: SQLite's own inserts,
as GDAL 3.6 makes them, cost ~9 µs a row, 5 s for the TIN), so the result is what OGR would have
written. An intermediate file that the next step reads whole needs no index: callers may leave it out.

OGR creates a new layer's table late, when the dataset is flushed or destroyed, and the destruction
itself may come late: a profiler (Dask's, in tiled runs) keeps the frames it samples, and the
dataset in them, alive for a moment; a failure then is never reported. So the table is made
explicitly (``SyncToDisk``) while the dataset is open and its errors can be seen, and every write
is checked: a disk that is full (or any I/O error) is an ``InputError`` naming the file.
"""
from __future__ import annotations

import contextlib
import itertools
import sqlite3
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import cast

import numpy as np
import pyproj
import shapely
from osgeo import gdal, ogr, osr

from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..gdal_env import quiet_gdal
from .fileio import atomic_file
from .gpkg_rtree import bulk_load
from .sql import sql_name, sql_text
from .vector_io import FieldDef, create_fields

#: GeoPackage geometry header: "GP", version 0, flags (little-endian, XY envelope), srs_id, envelope
_HEADER = np.dtype([("magic", "S2"), ("version", "u1"), ("flags", "u1"), ("srs_id", "<i4"),
                    ("envelope", "<f8", 4)])
_FLAGS_LE_XY_ENVELOPE = 0b0000_0011
BATCH = 20_000  # rows per write_layer batch: progress and Cancel between batches
#: bound values per INSERT statement: within SQLite's oldest limit (SQLITE_MAX_VARIABLE_NUMBER, 999 before 3.32)
MAX_VALUES = 999


#: a whole blob for a triangle: the header, then ISO WKB PolygonZ (1003) with one closed ring of 4 points
_TRIANGLE = np.dtype([("header", _HEADER), ("byte_order", "u1"), ("type", "<u4"), ("rings", "<u4"),
                      ("points", "<u4"), ("xyz", "<f8", (4, 3))])


def _header(count: int, srs_id: int, bounds: np.ndarray) -> np.ndarray:
    header = np.zeros(count, dtype=_HEADER)
    header["magic"] = b"GP"
    header["flags"] = _FLAGS_LE_XY_ENVELOPE
    header["srs_id"] = srs_id
    header["envelope"] = bounds[:, [0, 2, 1, 3]]  # minx, maxx, miny, maxy
    return header


def envelopes(geoms: np.ndarray) -> np.ndarray:
    """(n, 4) xmin, ymin, xmax, ymax of shapely geometries or of (n, 3, 3) triangle corners."""
    if geoms.dtype != object:
        return np.hstack([geoms[:, :, :2].min(axis=1), geoms[:, :, :2].max(axis=1)])
    return shapely.bounds(geoms)


def geometry_blobs(geoms: np.ndarray, srs_id: int, bounds: np.ndarray) -> list[bytes]:
    """GeoPackage geometry blobs of non-empty 3D shapely geometries, or of (m, 3, 3) triangle corners, with their
    ``envelopes``.

    Triangles are laid out by numpy directly: no shapely objects for the ~600,000 of a TIN.
    """
    if geoms.dtype != object:
        blobs = np.zeros(len(geoms), dtype=_TRIANGLE)
        blobs["header"] = _header(len(geoms), srs_id, bounds)
        blobs["byte_order"], blobs["type"], blobs["rings"], blobs["points"] = 1, 1003, 1, 4
        blobs["xyz"] = geoms[:, [0, 1, 2, 0]]
        return blobs.view(np.dtype((np.void, _TRIANGLE.itemsize))).tolist()  # a bytes object per row
    raw = _header(len(geoms), srs_id, bounds).tobytes()
    size = _HEADER.itemsize
    wkbs = shapely.to_wkb(geoms, output_dimension=3, flavor="iso", byte_order=1)
    return [raw[k * size:(k + 1) * size] + wkb for k, wkb in enumerate(wkbs)]


class BulkTable:
    """A GeoPackage table that OGR creates (file, SRS, metadata) and SQLite then fills in bulk.

    The file must be a staging file that is moved into place only when complete: it is written
    without a rollback journal and without fsync per commit (halves the insert time), and OGR's
    triggers on the table (the feature count's, an UPDATE per inserted row, a third of the insert
    time; the R-tree's) are dropped while rows go in and re-created by ``close``, with the count and
    the R-tree loaded in bulk. ``threaded`` lets another thread than the creating one insert (one
    thread at a time); ``spatial_index`` gives a layer with a CRS OGR's R-tree.
    """

    def __init__(self, path: str | Path, layer: str, fields: Sequence[FieldDef], crs: pyproj.CRS | None = None,
                 geometry_type: int = ogr.wkbNone, threaded: bool = False, spatial_index: bool = False):
        self.path, self.layer, self.count, self._failed = Path(path), layer, 0, False
        self.geometry_column = _create_layer(self.path, layer, fields, crs, geometry_type, spatial_index)
        self.rtree = f"rtree_{layer}_{self.geometry_column}" if spatial_index and crs is not None else None
        try:
            self.db = sqlite3.connect(path, check_same_thread=not threaded)
        except sqlite3.Error as exc:
            raise self._error(exc) from exc
        try:
            with self._checked():
                self.db.execute("PRAGMA journal_mode = OFF")
                self.db.execute("PRAGMA synchronous = OFF")
                self._triggers = self.db.execute(
                    "SELECT name, sql FROM sqlite_master WHERE type = 'trigger' AND tbl_name = ?", (layer,)).fetchall()
                for name, _ in self._triggers:
                    self.db.execute(f"DROP TRIGGER {sql_name(name)}")
                self.srs_id = None
                if crs is not None:
                    row = self.db.execute("SELECT srs_id FROM gpkg_geometry_columns WHERE table_name = ?",
                                          (layer,)).fetchone()
                    if row is None:
                        raise self._error("OGR did not create the layer's table")
                    self.srs_id = row[0]
        except InputError:
            self.db.close()
            raise
        names = [self.geometry_column] * (crs is not None) + [fd.name for fd in fields]
        self._columns = f'INSERT INTO {sql_name(layer)} ({", ".join(map(sql_name, names))}) VALUES '  # nosec B608  # names quoted, values bound
        self._row = f'({", ".join("?" * len(names))})'
        self._rows_per_statement = max(1, MAX_VALUES // len(names))
        self._insert_full = self._insert_statement(self._rows_per_statement)

    def _insert_statement(self, rows: int) -> str:
        return self._columns + ", ".join([self._row] * rows)  # nosec B608  # names quoted, values bound (?)

    def _error(self, reason: object) -> InputError:
        return _write_error(self.layer, self.path, reason)

    @contextlib.contextmanager
    def _checked(self) -> Iterator[None]:
        """SQLite's errors (a full disk, an I/O error) as ``InputError`` naming the file; after one, ``close``
        only closes the file (the caller's staging file is then removed)."""
        try:
            yield
        except sqlite3.Error as exc:
            self._failed = True
            raise self._error(exc) from exc

    def insert(self, rows: Sequence[Sequence]) -> None:
        """Append rows (values in the order of the geometry column, if any, then the fields).

        Many rows go in one statement (``INSERT … VALUES (…), (…), …``), in their order: SQLite's work per
        statement (the AUTOINCREMENT counter above all) is then done once for them all, which halves the
        time of row-per-statement ``executemany``.
        """
        step = self._rows_per_statement
        with self._checked():
            for start in range(0, len(rows), step):
                chunk = rows[start:start + step]
                statement = self._insert_full if len(chunk) == step else self._insert_statement(len(chunk))
                self.db.execute(statement, list(itertools.chain.from_iterable(chunk)))
            self.db.commit()
        self.count += len(rows)

    def _load_rtree(self, bounds: np.ndarray) -> None:
        """The R-tree of the rows inserted (fids 1 … count: a new table's, in order), loaded in bulk."""
        count = f"SELECT min(fid), max(fid), count(*) FROM {sql_name(self.layer)}"  # nosec B608  # the name quoted
        first, last, rows = self.db.execute(count).fetchone()
        if rows != len(bounds) or (rows and (first, last) != (1, rows)):
            raise ValueError(f"{len(bounds)} envelopes for the {rows} rows numbered {first} to {last}")
        bulk_load(self.db, str(self.rtree), np.arange(1, rows + 1), bounds[:, [0, 2, 1, 3]])

    def discard(self) -> None:
        """Close the unfinished file as it is (its staging copy is removed by the caller)."""
        self._failed = True
        self.close()

    def close(self, bounds: np.ndarray | None = None) -> None:
        """Record the feature count GDAL keeps (and trusts), the layer extent and its R-tree from ``bounds``
        (the rows' envelopes, in their order: xmin, ymin, xmax, ymax); close."""
        try:
            if not self._failed:
                with self._checked():
                    if bounds is not None and len(bounds):
                        extent = (*bounds[:, :2].min(axis=0).tolist(), *bounds[:, 2:].max(axis=0).tolist())
                        self.db.execute("UPDATE gpkg_contents SET min_x = ?, min_y = ?, max_x = ?, max_y = ? "
                                        "WHERE table_name = ?", (*extent, self.layer))
                    if self.rtree is not None:
                        self._load_rtree(np.zeros((0, 4)) if bounds is None else bounds)
                    self.db.execute("UPDATE gpkg_ogr_contents SET feature_count = ? WHERE table_name = ?",
                                    (self.count, self.layer))
                    for _, sql in self._triggers:
                        self.db.execute(sql)
                    self.db.commit()
        finally:
            self.db.close()


def _write_error(layer: str, path: Path, reason: object) -> InputError:
    return InputError(f"Cannot write the layer '{layer}' into {path}: {str(reason).rstrip('. ')}. Is the disk full?")


def _create_layer(path: Path, layer: str, fields: Sequence[FieldDef], crs: pyproj.CRS | None,
                  geometry_type: int, spatial_index: bool) -> str:
    """OGR makes the file, the layer's table (written now, checked) and, with ``spatial_index`` and a CRS, its
    R-tree (empty, so made at once); the geometry column's name."""
    srs = None
    if crs is not None:
        srs = osr.SpatialReference()
        srs.ImportFromWkt(crs.to_wkt())
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    failed, reason, column = True, "GDAL gave no reason", ""
    with quiet_gdal():
        try:
            ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
            lyr = None if ds is None else ds.CreateLayer(layer, srs, geometry_type,
                                                         options=["SPATIAL_INDEX=NO"] if srs else [])
            if lyr is not None:
                create_fields(lyr, fields)
                column = lyr.GetGeometryColumn() if srs else ""
                synced = lyr.SyncToDisk() == ogr.OGRERR_NONE  # the table now, not when ds is destroyed
                if synced and spatial_index and srs:
                    ds.ExecuteSQL(f"SELECT CreateSpatialIndex({sql_text(layer)}, {sql_text(column)})")
                failed = not synced or gdal.GetLastErrorType() >= gdal.CE_Failure
            reason = gdal.GetLastErrorMsg() or reason
        except RuntimeError as exc:  # with ogr.UseExceptions()
            reason = str(exc)
        lyr = ds = None
    if failed:
        raise _write_error(layer, path, reason)
    return column


def write_layer(path: str | Path, layer: str, crs: pyproj.CRS, fields: Sequence[FieldDef], geoms: np.ndarray,
                columns: Sequence[Sequence | np.ndarray], geometry_type: int = ogr.wkbPolygon25D,
                spatial_index: bool = True, feedback: Feedback = SILENT) -> int:
    """Write one GeoPackage layer atomically: ``geoms`` and one column per field.

    ``geoms``: 3D shapely geometries, or an (m, 3, 3) float array of triangle corners (PolygonZ).
    Column values must be None, int, float or str (numpy arrays are converted). Returns the count.
    """
    geoms = np.asarray(geoms, dtype=None if isinstance(geoms, np.ndarray) else object)
    columns = [c.tolist() if isinstance(c, np.ndarray) else list(c) for c in columns]
    if len(columns) != len(fields) or any(len(c) != len(geoms) for c in columns):
        raise ValueError("one column per field, one value per geometry")
    with atomic_file(path) as tmp:
        table = BulkTable(tmp, layer, fields, crs, geometry_type, spatial_index=spatial_index)
        srs_id = cast(int, table.srs_id)  # set: the table has a CRS
        bounds = envelopes(geoms) if len(geoms) else np.zeros((0, 4))
        try:
            for start in range(0, len(geoms), BATCH):
                feedback.check_canceled()
                feedback.progress(90 * start / max(len(geoms), 1))
                stop = start + BATCH
                blobs = geometry_blobs(geoms[start:stop], srs_id, bounds[start:stop])
                table.insert(list(zip(blobs, *(c[start:stop] for c in columns))))
            feedback.check_canceled()
        except BaseException:
            table.discard()
            raise
        table.close(bounds)
    feedback.progress(100)
    return len(geoms)
