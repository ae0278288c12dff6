"""What the CityGML writer reads: the step outputs it combines, read in bulk and in a stable order.

Each input is a layer opened read-only (``InputLayer``: ordered SQL reads, CRS check); besides come
the 3D envelope of the geometries, the texture images the texture table uses, the TIN triangles in
batches with their ids, and the building → district assignment (``Membership``), spooled to a
temporary SQLite table so memory stays flat.
"""
from __future__ import annotations

import contextlib
import math
import re
import sqlite3
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from itertools import groupby
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.io import bulk_read
from ..infra.io.layersource import LayerSource
from ..infra.io.sql import sql_name
from ..infra.io.vector_io import open_layer, open_step_layer
from ..infra.numtext import ring_texts

BULK = 4096  # features per bulk read (bulk_read): few Python calls, a few MB at a time
_LOOKUP_BATCH = 10_000  # buildings per district lookup (as many as the writer's progress batch)
_NCNAME = re.compile(r"[^\W\d][\w.\-]*")


@dataclass(frozen=True)
class CityGMLInputs:
    """Paths of the step outputs to combine: the LoD1 faces, or (a tile that owns no building) the TIN alone."""

    lod1: str | None
    tin: str | None = None
    roads: str | None = None
    districts: str | None = None
    textures: str | None = None  # wit:wittexture folder: images + step_layers.TEXCOORD_FILE


class InputLayer:
    """One input layer of a GeoPackage, opened read-only, with ordered SQL reads."""

    def __init__(self, ds: ogr.DataSource, layer: ogr.Layer, path: str, name: str):
        self.ds, self.layer, self.path, self.name = ds, layer, path, name
        self.table = sql_name(name)  # the layer in SQL

    @classmethod
    @contextlib.contextmanager
    def open(cls, path: str, name: str, role: str, fields: Sequence[str],
             geometry_z: bool = False) -> Iterator[InputLayer]:
        ds, layer, _ = open_step_layer(path, name, role, fields)
        path, name = LayerSource.parse(path).path, layer.GetName()
        if geometry_z and not ogr.GT_HasZ(layer.GetGeomType()):
            raise InputError(f"Layer '{name}' in {path} has no Z coordinates: give the output of the {role}.")
        yield cls(ds, layer, path, name)

    def count(self) -> int:
        return max(self.layer.GetFeatureCount(), 0)

    def check_crs(self, srs_name: str) -> None:
        """Refuse a layer whose EPSG code differs from the output's: coordinates are written as read."""
        srs = self.layer.GetSpatialRef()
        wanted = re.fullmatch(r"(?i)EPSG:(\d+)", srs_name.strip())
        code = srs.GetAuthorityCode(None) if srs is not None else None
        if wanted and code and srs.GetAuthorityName(None) == "EPSG" and code != wanted.group(1):
            raise InputError(f"Layer '{self.name}' in {self.path} is in EPSG:{code}, not {srs_name}: "
                             f"run the earlier steps with the target CRS {srs_name}.")

    def fields(self) -> list[tuple[int, str, int]]:
        return fields_of(self.layer)

    @contextlib.contextmanager
    def select(self, where: str = "", order: Iterable[str] = (), columns: str = "*") -> Iterator[ogr.Layer]:
        """Features in a stable order (SQLite sorts on disk, so memory stays flat)."""
        sql = f"SELECT {columns} FROM {self.table}"  # nosec B608  # a quoted name; the rest is this package's SQL
        if where:
            sql += f" WHERE {where}"
        if order:
            sql += " ORDER BY " + ", ".join(map(sql_name, order))
        result = self.ds.ExecuteSQL(sql)
        if result is None:
            raise InputError(f"Cannot read layer '{self.name}' of {self.path}.")
        try:
            yield result
        finally:
            self.ds.ReleaseResultSet(result)

    @contextlib.contextmanager
    def own_table(self) -> Iterator[ogr.Layer]:
        """The table through a handle of its own, read-only: GDAL streams a layer to one reader at a time, and the
        layer of this one may have a stream in progress (another reader's, or one a traceback's frame still holds)."""
        ds, layer, _ = open_layer(self.path, self.name)
        try:
            yield layer
        finally:
            del layer, ds

    def scalar(self, sql: str) -> Any:
        result = self.ds.ExecuteSQL(sql)
        if result is None:
            raise InputError(f"Cannot read layer '{self.name}' of {self.path}.")
        try:
            feature = result.GetNextFeature()
            return feature.GetField(0) if feature is not None else None
        finally:
            self.ds.ReleaseResultSet(result)


@dataclass
class ModelLayers:
    """The model's inputs opened and checked up front: layers (None where not given), images, envelope."""

    lod1: InputLayer | None
    tin: InputLayer | None
    roads: InputLayer | None
    districts: InputLayer | None
    texcoords: InputLayer | None
    images: dict[str, Path]  # image name → file, of every image the texture table uses
    envelope: tuple[float, float, float, float, float, float]  # min x y z, max x y z

    @classmethod
    def open(cls, inputs: CityGMLInputs, srs_name: str, stack: contextlib.ExitStack) -> ModelLayers:
        """Open every given input (closed with ``stack``); one ``InputError`` naming the file for a bad one."""
        def layer(path: str | None, *args: Any, **kwargs: Any) -> InputLayer | None:
            return stack.enter_context(InputLayer.open(path, *args, **kwargs)) if path else None

        lod1 = layer(inputs.lod1, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE,
                     (step_layers.WIT_ID, step_layers.FACE_NUMBER, step_layers.FACE_TYPE), geometry_z=True)
        tin = layer(inputs.tin, step_layers.TIN_LAYER, step_layers.TIN_ROLE,
                    (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE, step_layers.TIN_FEATURE_ID), geometry_z=True)
        roads = layer(inputs.roads, step_layers.PREPARED_ROADS, step_layers.PREPARED_ROADS_ROLE, (step_layers.WIT_ID,))
        districts = layer(inputs.districts, step_layers.PREPARED_DISTRICTS, step_layers.PREPARED_DISTRICTS_ROLE,
                          (step_layers.WIT_ID,))
        texcoords = layer(inputs.textures and str(Path(inputs.textures) / step_layers.TEXCOORD_FILE),
                          step_layers.TEXCOORD_TABLE, step_layers.TEXCOORD_ROLE,
                          (step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE, step_layers.TEX_IMAGE,
                           step_layers.TEX_COORDS))
        if (lod1 is None or lod1.count() == 0) and (tin is None or inputs.lod1):
            raise InputError(f"{inputs.lod1} has no building faces: run wit:extrudebuildings on a non-empty area.")
        for source in (lod1, tin):
            if source:
                source.check_crs(srs_name)
        images = texture_images(texcoords, Path(inputs.textures)) if texcoords and inputs.textures else {}
        envelope = envelope_of([source for source in (lod1, tin) if source])
        if envelope is None:
            raise InputError(f"{inputs.lod1 or inputs.tin} has no geometries: re-run the step that wrote it.")
        return cls(lod1, tin, roads, districts, texcoords, images, envelope)


def fields_of(layer: ogr.Layer) -> list[tuple[int, str, int]]:
    """(index, name, OGR type) of every attribute field (of a table or an SQL result)."""
    defn = layer.GetLayerDefn()
    return [(i, defn.GetFieldDefn(i).GetName(), defn.GetFieldDefn(i).GetType()) for i in range(defn.GetFieldCount())]


def columns_of(layer: ogr.Layer) -> dict[str, int]:
    """Field name → index: typed getters by index are several times faster than by name."""
    return {name: index for index, name, _ in fields_of(layer)}


def envelope_of(layers: list[InputLayer]) -> tuple[float, float, float, float, float, float] | None:
    """3D bounding box of all geometries, read geometry-only through OGR's Arrow stream."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for source in layers:
        layer = source.layer
        # all but one field: GDAL 3.6's GPKG Arrow reader returns empty geometries when every field is ignored
        bulk_read.ignore_fields(layer, [name for _, name, _ in source.fields()[1:]])
        try:
            for batch in bulk_read.batches(layer, BULK):
                wkb = batch["geometry"]
                corners = bulk_read.triangles(wkb)
                xyz = (corners.reshape(-1, 3) if corners is not None
                       else shapely.get_coordinates(shapely.from_wkb(wkb), include_z=True))
                if len(xyz):
                    lo, hi = np.fmin(lo, np.nanmin(xyz, axis=0)), np.fmax(hi, np.nanmax(xyz, axis=0))
        finally:
            layer.SetIgnoredFields([])
            layer.ResetReading()
    if not np.all(np.isfinite(lo)):
        return None
    return float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]), float(hi[1]), float(hi[2])


def texture_images(texcoords: InputLayer, folder: Path) -> dict[str, Path]:
    """Image name → source path of every image the texture table uses; refuses missing images."""
    images: dict[str, Path] = {}
    with texcoords.select(columns=f'DISTINCT "{step_layers.TEX_IMAGE}"', order=(step_layers.TEX_IMAGE,)) as result:
        for feature in result:
            image = feature.GetField(0)
            rel = Path(image or "")
            if not image or rel.is_absolute() or ".." in rel.parts:
                raise InputError(f"Texture table in {texcoords.path} has an invalid image path {image!r}: "
                                 "paths must be relative to the texture folder.")
            if not (folder / rel).is_file():
                raise InputError(f"Texture image {folder / rel} listed in {texcoords.path} does not exist: "
                                 "re-run wit:wittexture.")
            images[image] = folder / rel
    return images


#: OGR field type → the kind of generic attribute it is written as (anything else: a string)
ATTRIBUTE_KINDS = {ogr.OFTInteger: "int", ogr.OFTInteger64: "int", ogr.OFTReal: "double", ogr.OFTDate: "date"}
# characters XML 1.0 cannot carry (C0 controls except tab/LF/CR, lone surrogates, U+FFFE/U+FFFF)
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def clean_text(text: str) -> str:
    """The text without the characters XML 1.0 cannot carry (so both encodings hold the same text)."""
    return _NOT_XML.sub("", text)


def typed_attributes(feature: ogr.Feature, fields: list[tuple[int, str, int]], skip: set[str]
                     ) -> Iterator[tuple[str, str, int | float | str]]:
    """(name, kind, value) of every set, finite attribute: the model's generic attributes, in field order.

    ``kind`` is int, double, date (value ``YYYY-MM-DD``) or string (value without XML-illegal characters).
    """
    for index, name, ftype in fields:
        if name in skip or not feature.IsFieldSetAndNotNull(index):
            continue
        kind = ATTRIBUTE_KINDS.get(ftype, "string")
        if kind == "int":
            value: int | float | str = feature.GetFieldAsInteger64(index)
        elif kind == "double":
            number = feature.GetFieldAsDouble(index)
            if not math.isfinite(number):
                continue
            value = number
        elif kind == "date":
            year, month, day = feature.GetFieldAsDateTime(index)[:3]
            value = f"{year:04d}-{month:02d}-{day:02d}"
        else:
            value = clean_text(feature.GetFieldAsString(index))
        yield clean_text(name), kind, value


def uv_values(texts: list[str], what: Callable[[int], str], triangles: bool) -> tuple[np.ndarray, np.ndarray]:
    """Validated texture coordinates: the (u, v) pairs of all texts one after another, and pairs per text.

    Each text must hold u v pairs: 4 for a triangle (closing point included), at least 4 for a
    ring; ``what(i)`` names the surface of text i for the error message. Texts of numbers
    separated by single spaces (as wit:wittexture writes them) are parsed in one go.
    """
    joined = " ".join(texts)
    tokens = joined.split()
    counts = np.fromiter((text.count(" ") + 1 for text in texts), dtype=np.int64, count=len(texts))
    try:  # the counts hold when the texts are the tokens joined by single spaces, none empty
        values = np.array(tokens, dtype=np.float64) if joined == " ".join(tokens) else None
    except ValueError:
        values = None
    if values is None or ((counts != 8) if triangles else (counts < 8) | (counts % 2 == 1)).any() \
            or not np.isfinite(values).all():  # irregular spacing, or a text to report: one by one
        rows = []
        for i, text in enumerate(texts):
            try:
                numbers = [float(v) for v in text.split()]
            except ValueError:
                numbers = []
            if not numbers or len(numbers) % 2 or (len(numbers) != 8 if triangles else len(numbers) < 8) \
                    or not all(map(math.isfinite, numbers)):
                raise InputError(f"Texture coordinates of {what(i)} are not a valid list of u v pairs: {text!r}. "
                                 "Re-run wit:wittexture.")
            rows.append(numbers)
        counts = np.array([len(numbers) for numbers in rows], dtype=np.int64)
        values = np.array([v for numbers in rows for v in numbers], dtype=np.float64)
    return values.reshape(-1, 2), counts // 2


def checked_wit_id(value: Any, what: str) -> str:
    if not isinstance(value, str) or not _NCNAME.fullmatch(value):
        raise InputError(f"{what} has wit_id {value!r}, which cannot be a gml:id (letters, digits, '_', '-', '.'; "
                         "not starting with a digit): re-create the layer with wit:preparevectors.")
    return value


def tri_ids(column: np.ndarray) -> list[str]:
    """``tri_<n>`` from the TIN's integer ``tri_id`` column (a batch of ``bulk_read``)."""
    if column.dtype.kind in "iu" and not np.ma.is_masked(column):
        return [f"tri_{value}" for value in column.tolist()]
    values = bulk_read.texts(column)
    for value in values:
        if not value.lstrip("-").isdigit():
            raise InputError(f"TIN triangle id {value!r} is not an integer: re-run wit:triangulateterrain.")
    return [f"tri_{value}" for value in values]


def tin_triangles(tin: InputLayer, where: str, order: tuple[str, ...],
                  table_rows: Callable[[dict[str, np.ndarray]], np.ndarray] | None = None
                  ) -> Iterator[tuple[list[str], list[str], dict[str, np.ndarray]]]:
    """Batches of the TIN triangles matching ``where`` in ``order``: (ids ``tri_<n>``, posList texts, the batch).

    Read in bulk (``bulk_read``); each distinct corner is formatted once (``numtext``). ``table_rows``, when the
    table holds its rows in ``order`` already (``rises_in_table_order``): the rows of a batch that ``where``
    selects; the rows are then read from the table, by the GeoPackage's own Arrow reader (GDAL reads the result of
    an SQL query through its generic one, row by row: the sample's 371k relief triangles 0.31 s sorted by SQLite,
    its 595k triangles 0.085 s from the table).
    """
    with tin.select(where, order) if table_rows is None else tin.own_table() as result:
        for batch in bulk_read.batches(result, BULK):
            if table_rows is not None:
                keep = table_rows(batch)
                if not keep.any():
                    continue
                batch = {name: column[keep] for name, column in batch.items()}
            ids = tri_ids(batch[step_layers.TIN_TRIANGLE_ID])
            points, counts, rings = bulk_read.exterior_rings(batch["geometry"])
            bad = np.flatnonzero((rings != 1) | (counts != 4))
            if len(bad):
                raise InputError(f"TIN feature tri_id={ids[bad[0]][4:]} is not a closed triangle: "
                                 "re-run wit:triangulateterrain.")
            yield ids, ring_texts(points, counts, "%.3f %.3f %.3f"), batch


def rises_in_table_order(tin: InputLayer, field: str) -> bool:
    """Whether ``field`` rises strictly from row to row in the table's own order (as the terrain step writes its
    triangle ids): reading the table then gives its rows ORDER BY ``field``. Read alone, in bulk (0.05 s for the
    sample's 595k triangles)."""
    with tin.own_table() as layer:
        defn = layer.GetLayerDefn()
        layer.SetIgnoredFields([defn.GetFieldDefn(i).GetName() for i in range(defn.GetFieldCount())
                                if defn.GetFieldDefn(i).GetName() != field] + ["OGR_GEOMETRY"])
        last = None
        for batch in bulk_read.batches(layer, 1 << 16):
            values = batch[field]
            if np.ma.is_masked(values) or values.dtype.kind not in "iu":
                return False
            values = np.asarray(values)
            if (last is not None and len(values) and values[0] <= last) or (np.diff(values) <= 0).any():
                return False
            last = values[-1] if len(values) else last
        return True


class FacadeRows:
    """The texture step's facade table (one row per building with a generated facade), read in wit_id order
    beside the buildings, which come in the same order: ``of`` gives a building's row, if it has one."""

    def __init__(self, result: ogr.Layer):
        self.fields = fields_of(result)
        self._rows = iter(result)
        self._column = columns_of(result)[step_layers.WIT_ID]
        self._row = next(self._rows, None)

    @classmethod
    @contextlib.contextmanager
    def open(cls, folder: Path) -> Iterator[FacadeRows | None]:
        """The rows of ``folder``'s facade table; None when the texture step generated no facade."""
        path = folder / step_layers.FACADE_FILE
        if not path.is_file():
            yield None
            return
        with InputLayer.open(str(path), step_layers.FACADE_TABLE, step_layers.TEXCOORD_ROLE,
                             step_layers.FACADE_FIELDS) as table, table.select(order=(step_layers.WIT_ID,)) as result:
            yield cls(result)

    def of(self, wit_id: str) -> ogr.Feature | None:
        while self._row is not None and self._row.GetFieldAsString(self._column) < wit_id:
            self._row = next(self._rows, None)
        if self._row is not None and self._row.GetFieldAsString(self._column) == wit_id:
            return self._row
        return None


class Membership:
    """Building → district assignment, spooled to a temporary SQLite table (constant memory)."""

    def __init__(self, districts: InputLayer):
        self.rows: list[tuple[str, ogr.Feature]] = []  # (wit_id, feature) sorted by wit_id
        geoms = []
        districts.layer.ResetReading()
        features = sorted(((checked_wit_id(f.GetField(step_layers.WIT_ID), f"A district in {districts.path}"), f)
                           for f in districts.layer), key=lambda pair: pair[0])
        for wit_id, group in groupby(features, key=lambda pair: pair[0]):
            feature = next(group)[1]
            geometry = feature.GetGeometryRef()
            if geometry is not None and not geometry.IsEmpty():
                self.rows.append((wit_id, feature))
                geoms.append(shapely.from_wkb(bytes(geometry.ExportToIsoWkb())))
        self.fields = districts.fields()
        self.tree = shapely.STRtree(geoms)
        self.pending: list[tuple[str, bytes]] = []
        self.tmp = tempfile.TemporaryDirectory(prefix="wit-citygml-")
        self.db = sqlite3.connect(Path(self.tmp.name) / "members.sqlite")
        self.db.execute("CREATE TABLE m (district INTEGER, building TEXT)")

    def __enter__(self) -> Membership:
        return self

    def __exit__(self, *exc: object) -> None:
        self.db.close()
        self.tmp.cleanup()

    def add(self, building: str, footprint_wkb: bytes) -> None:
        self.pending.append((building, footprint_wkb))
        if len(self.pending) >= _LOOKUP_BATCH:
            self.flush()

    def flush(self) -> None:
        """Assign the pending buildings: the district containing the footprint's representative point.

        A point on a shared border goes to the district with the smallest wit_id (deterministic).
        """
        if not self.pending:
            return
        points = shapely.point_on_surface(shapely.from_wkb([wkb for _, wkb in self.pending]))
        pairs = self.tree.query(points, predicate="intersects")
        first: dict[int, int] = {}
        for building, district in zip(*pairs.tolist()):
            first[building] = min(district, first.get(building, district))
        self.db.executemany("INSERT INTO m VALUES (?, ?)",
                            ((district, self.pending[b][0]) for b, district in first.items()))
        self.pending.clear()

    def parents(self) -> Iterator[tuple[str, str]]:
        """(building wit_id, its district's wit_id) for every assigned building, in building order."""
        self.flush()
        for building, district in self.db.execute("SELECT building, district FROM m ORDER BY building"):
            yield building, self.rows[district][0]

    def groups(self) -> Iterator[tuple[str, Any, Iterator[str]]]:
        """(district wit_id, district feature, member wit_ids sorted) for districts with members."""
        self.flush()
        cursor = self.db.execute("SELECT district, building FROM m ORDER BY district, building")
        for district, rows in groupby(cursor, key=lambda row: row[0]):
            wit_id, feature = self.rows[district]
            yield wit_id, feature, (building for _, building in rows)
