"""Where the colour store lives: GeoPackage (through OGR and SQLite) or PostGIS (through psycopg2), written and read."""
from __future__ import annotations

import io
import json
import os
import re
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from osgeo import gdal, ogr, osr

from ..infra.errors import InputError, MissingDependencyError
from ..infra.feedback import Feedback
from ..infra.io import jsontext
from .schema import _QUERY_COLUMNS, CELL_COLUMNS, COLOR_COLUMNS, LATTICE_COLUMNS, _Cells, _check_table_name


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
            feature.SetField("value", jsontext.dumps(value))
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
                        [(k, jsontext.dumps(v)) for k, v in meta.items()])
        cur.execute(sql.SQL("ANALYZE {t}").format(t=self.cells))
        cur.execute("SELECT pg_total_relation_size(%s::regclass) + pg_total_relation_size(%s::regclass)",
                    (self.cells.as_string(self.conn), self.meta.as_string(self.conn)))
        size = int(cur.fetchone()[0])
        self.conn.commit()
        return size

    def close(self) -> None:
        self.conn.rollback()  # no-op after commit; drops everything after an error or cancel
        self.conn.close()


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
        # table passed _check_table_name (letters, digits, _); the values are bound (?)
        meta = self.db.execute(f'SELECT key, value FROM "{table}_meta"')  # nosec B608  # a checked name
        self.meta = {k: json.loads(v) for k, v in meta}
        cols = ", ".join(f'c."{c}"' for c in _QUERY_COLUMNS)
        self.sql = (f'SELECT {cols} FROM "{rtree}" r JOIN "{table}" c ON c.fid = r.id '  # nosec B608  # checked name
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
