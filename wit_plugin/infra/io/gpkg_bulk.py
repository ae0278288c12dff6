"""Write one big GeoPackage layer fast: OGR makes the file, SQLite takes the rows in bulk.

The TIN of the 1 km demo has ~600,000 triangles. Through OGR one feature at a time that took
14 s (about 23 µs a feature: a Python call per field and per geometry). Here the GeoPackage
geometry blobs (header + envelope + ISO WKB, as the GeoPackage standard §2.1.3 defines them)
are built with numpy and shapely for all rows at once and inserted with ``executemany``; OGR
creates the file and the layer first (tables, SRS, metadata) and builds the R-tree spatial index
at the end in one go, so the result is what OGR would have written.

The R-tree costs most of the time left (SQLite inserts ~10 µs a row whatever the order; GDAL
3.6 has no bulk loader): worth it for a layer a user opens in QGIS, not for an intermediate
file that the next step reads whole, so callers may leave it out.

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


def sql_name(name: str) -> str:
    """``name`` (a layer's or a field's, maybe a user's) as an SQL identifier: quoted, inner quotes doubled."""
    return '"' + name.replace('"', '""') + '"'


def sql_text(text: str) -> str:
    """``text`` as an SQL string literal: single-quoted, inner single quotes doubled."""
    return "'" + text.replace("'", "''") + "'"


def _header(count: int, srs_id: int, bounds: np.ndarray) -> np.ndarray:
    header = np.zeros(count, dtype=_HEADER)
    header["magic"] = b"GP"
    header["flags"] = _FLAGS_LE_XY_ENVELOPE
    header["srs_id"] = srs_id
    header["envelope"] = bounds[:, [0, 2, 1, 3]]  # minx, maxx, miny, maxy
    return header


def geometry_blobs(geoms: np.ndarray, srs_id: int) -> list[bytes]:
    """GeoPackage geometry blobs of non-empty 3D shapely geometries, or of (m, 3, 3) triangle corners.

    Triangles are laid out by numpy directly: no shapely objects for the ~600,000 of a TIN.
    """
    if geoms.dtype != object:
        blobs = np.zeros(len(geoms), dtype=_TRIANGLE)
        blobs["header"] = _header(len(geoms), srs_id, np.hstack([geoms[:, :, :2].min(axis=1),
                                                                 geoms[:, :, :2].max(axis=1)]))
        blobs["byte_order"], blobs["type"], blobs["rings"], blobs["points"] = 1, 1003, 1, 4
        blobs["xyz"] = geoms[:, [0, 1, 2, 0]]
        return blobs.view(np.dtype((np.void, _TRIANGLE.itemsize))).tolist()  # a bytes object per row
    raw = _header(len(geoms), srs_id, shapely.bounds(geoms)).tobytes()
    size = _HEADER.itemsize
    wkbs = shapely.to_wkb(geoms, output_dimension=3, flavor="iso", byte_order=1)
    return [raw[k * size:(k + 1) * size] + wkb for k, wkb in enumerate(wkbs)]


def _spatial_index(path: Path, layer: str, column: str) -> None:
    """OGR's R-tree of the layer, built in one go (checked like every write here)."""
    with quiet_gdal():
        try:
            ds = ogr.Open(str(path), update=1)
            if ds is not None:
                ds.ExecuteSQL(f"SELECT CreateSpatialIndex({sql_text(layer)}, {sql_text(column)})")
                ds.FlushCache()
            failed = ds is None or gdal.GetLastErrorType() >= gdal.CE_Failure
            reason = gdal.GetLastErrorMsg() or "GDAL gave no reason"
        except RuntimeError as exc:  # with ogr.UseExceptions()
            failed, reason = True, str(exc)
        ds = None
    if failed:
        raise _write_error(layer, path, f"its spatial index: {reason}")


def _total_bounds(geoms: np.ndarray) -> tuple[float, float, float, float]:
    if geoms.dtype != object:
        (x0, y0), (x1, y1) = geoms[:, :, :2].min(axis=(0, 1)), geoms[:, :, :2].max(axis=(0, 1))
        return x0, y0, x1, y1
    return tuple(shapely.total_bounds(geoms))


class BulkTable:
    """A GeoPackage table that OGR creates (file, SRS, metadata) and SQLite then fills in bulk.

    The file must be a staging file that is moved into place only when complete: it is written
    without a rollback journal and without fsync per commit (halves the insert time), and OGR's
    feature-count trigger (an UPDATE per inserted row, a third of the insert time) is dropped
    while rows go in and re-created, with the count, by ``close``. ``threaded`` lets another
    thread than the creating one insert (one thread at a time).
    """

    def __init__(self, path: str | Path, layer: str, fields: Sequence[FieldDef], crs: pyproj.CRS | None = None,
                 geometry_type: int = ogr.wkbNone, threaded: bool = False):
        self.path, self.layer, self.count, self._failed = Path(path), layer, 0, False
        self.geometry_column = _create_layer(self.path, layer, fields, crs, geometry_type)
        try:
            self.db = sqlite3.connect(path, check_same_thread=not threaded)
        except sqlite3.Error as exc:
            raise self._error(exc) from exc
        try:
            with self._checked():
                self.db.execute("PRAGMA journal_mode = OFF")
                self.db.execute("PRAGMA synchronous = OFF")
                self._triggers = self.db.execute(
                    "SELECT name, sql FROM sqlite_master WHERE type = 'trigger' AND tbl_name = ? AND name LIKE ?",
                    (layer, "trigger_insert_feature_count_%")).fetchall()
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

    def close(self, bounds: tuple[float, float, float, float] | None = None) -> None:
        """Record the feature count GDAL keeps (and trusts) and the layer extent; close."""
        try:
            if not self._failed:
                with self._checked():
                    if bounds is not None:
                        self.db.execute("UPDATE gpkg_contents SET min_x = ?, min_y = ?, max_x = ?, max_y = ? "
                                        "WHERE table_name = ?", (*bounds, self.layer))
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
                  geometry_type: int) -> str:
    """OGR makes the file and the layer's table (written now, checked); the geometry column's name."""
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
        table = BulkTable(tmp, layer, fields, crs, geometry_type)
        srs_id = cast(int, table.srs_id)  # set: the table has a CRS
        try:
            for start in range(0, len(geoms), BATCH):
                feedback.check_canceled()
                feedback.progress(90 * start / max(len(geoms), 1))
                stop = start + BATCH
                blobs = geometry_blobs(geoms[start:stop], srs_id)
                table.insert(list(zip(blobs, *(c[start:stop] for c in columns))))
        finally:
            table.close(_total_bounds(geoms) if len(geoms) else None)
        if spatial_index:
            feedback.check_canceled()
            _spatial_index(tmp, layer, table.geometry_column)
    feedback.progress(100)
    return len(geoms)
