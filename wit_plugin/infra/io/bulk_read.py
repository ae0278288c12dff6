"""Read big layers in batches through OGR's Arrow stream: numpy columns, no Python object per feature.

The TIN of the 1 km demo has ~600,000 triangles and the texture table as many rows; reading
them one OGR feature at a time (a Python call per feature, per field and per geometry) took
seconds in both wit:wittexture and wit:writecitygml. GDAL's Arrow stream (GDAL ≥ 3.6) hands
over whole batches as numpy arrays, for any vector format and for SQL results (ordered or
filtered reads); ring coordinates are then unpacked from the WKB with numpy, without shapely
objects for the common case of triangles, the sibling of ``gpkg_bulk``'s writer.

Every Arrow read of the core goes through ``arrow_ready``: GDAL 3.6's Python Arrow reader crashes the
process (a segmentation fault, no exception) on a field name that is not valid UTF-8 — Korean names
of a CP949 shapefile read without recoding, as under QGIS, which sets ``SHAPE_ENCODING=""``. Such
layers (and GDAL < 3.6) take the feature API, which gives the same columns.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import shapely
from osgeo import ogr

BATCH = 65_536  # features per Arrow batch: a few MB of a TIN's columns

#: ISO WKB of a PolygonZ (1003) with one ring of 4 points, little-endian: a TIN triangle
_WKB_TRIANGLE = np.dtype([("byte_order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"),
                          ("xyz", "<f8", (4, 3))])
_POLYGON_Z_TYPES = (1003, 0x80000003)  # ISO and old-style (25D) WKB type codes of PolygonZ


def is_utf8(name: str) -> bool:
    """A name as GDAL's bindings give it is valid UTF-8 (bytes that are not come as surrogate escapes)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def arrow_ready(layer: ogr.Layer) -> bool:
    """GDAL's Arrow reader can take ``layer``: GDAL ≥ 3.6, and every column it hands over has a UTF-8 name
    (the fields not ignored, the FID and the geometry columns)."""
    if not hasattr(layer, "GetArrowStreamAsNumPy"):
        return False
    defn = layer.GetLayerDefn()
    names = [defn.GetFieldDefn(i).GetName() for i in range(defn.GetFieldCount())
             if not defn.GetFieldDefn(i).IsIgnored()]
    names += [defn.GetGeomFieldDefn(i).GetName() for i in range(defn.GetGeomFieldCount())]
    return all(is_utf8(n) for n in names + [layer.GetFIDColumn()])


def ignore_fields(layer: ogr.Layer, names: list[str]) -> None:
    """``SetIgnoredFields`` for any names: those that are not UTF-8 are passed as their own bytes, or, by
    bindings that take text only, left read (a few more columns; ``arrow_ready`` then says no)."""
    try:
        layer.SetIgnoredFields([n if is_utf8(n) else n.encode("utf-8", "surrogateescape") for n in names])
    except TypeError:
        layer.SetIgnoredFields([n for n in names if is_utf8(n)])


def batches(layer: ogr.Layer, size: int = BATCH, fid: bool = False) -> Iterator[dict[str, np.ndarray]]:
    """The features of ``layer`` (a table, or the result of ``ExecuteSQL``) as column → array batches.

    The geometry column is keyed ``"geometry"`` (WKB, None for no geometry) and, with ``fid``, the
    feature ids ``"fid"``; attribute fields by name; a field with NULLs is a
    ``numpy.ma.MaskedArray``; text comes as bytes. Ignored fields (``SetIgnoredFields``) are left out.
    Through GDAL's Arrow reader when ``arrow_ready``, else the feature API (``feature_batches``).
    """
    if not arrow_ready(layer):
        yield from feature_batches(layer, size, fid)
        return
    names = {layer.GetGeometryColumn() or "wkb_geometry": "geometry"}
    if fid:
        names[layer.GetFIDColumn() or "OGC_FID"] = "fid"
    options = [f"INCLUDE_FID={'YES' if fid else 'NO'}", f"MAX_FEATURES_IN_BATCH={size}"]
    for batch in layer.GetArrowStreamAsNumPy(options=options):
        yield {names.get(name, name): column for name, column in batch.items()}


_NUMPY_TYPES = {ogr.OFTInteger: np.int64, ogr.OFTInteger64: np.int64, ogr.OFTReal: np.float64}


def feature_batches(layer: ogr.Layer, size: int = BATCH, fid: bool = False) -> Iterator[dict[str, np.ndarray]]:
    """``batches`` through the feature API: the same keys and kinds of columns (masked where NULL,
    numbers as numbers, everything else as the bytes of its text); geometries as an object array of
    ISO WKB (None where missing)."""
    defn = layer.GetLayerDefn()
    fields = [(i, defn.GetFieldDefn(i)) for i in range(defn.GetFieldCount()) if not defn.GetFieldDefn(i).IsIgnored()]
    layer.ResetReading()
    while True:
        rows: list[tuple[int, bytes | None, list]] = []
        while len(rows) < size and (feature := layer.GetNextFeature()) is not None:
            geom = feature.GetGeometryRef()
            rows.append((feature.GetFID(), None if geom is None else bytes(geom.ExportToIsoWkb()),
                         [None if not feature.IsFieldSetAndNotNull(i) else
                          feature.GetField(i) if fd.GetType() in _NUMPY_TYPES else
                          feature.GetFieldAsString(i).encode("utf-8", "surrogateescape") for i, fd in fields]))
        if not rows:
            return
        batch: dict[str, np.ndarray] = {"geometry": np.array([r[1] for r in rows] + [None], dtype=object)[:-1]}
        if fid:
            batch["fid"] = np.array([r[0] for r in rows], dtype=np.int64)
        for k, (_, fd) in enumerate(fields):
            values = [r[2][k] for r in rows]
            missing = np.array([v is None for v in values])
            kind = _NUMPY_TYPES.get(fd.GetType())
            filled = [(0 if kind else b"") if v is None else v for v in values]
            batch[fd.GetName()] = np.ma.MaskedArray(np.array(filled, dtype=kind or bytes), mask=missing)
        yield batch
        if len(rows) < size:
            return


def texts(column: np.ndarray) -> list[str]:
    """A text or integer column as Python strings, as OGR's ``GetFieldAsString`` gives them ('' for NULL; Arrow's
    UTF-8 bytes decoded, in a fixed-width or an object column)."""
    values = column.tolist()  # masked entries become None
    if column.dtype.kind == "S":
        return [v.decode("utf-8", "replace") if v is not None else "" for v in values]
    return [v.decode("utf-8", "replace") if isinstance(v, bytes) else ("" if v is None else str(v)) for v in values]


def valid(column: np.ndarray) -> np.ndarray:
    """True where the column is not NULL."""
    return ~np.ma.getmaskarray(column)


def geometry_name(wkb: Any) -> str:
    """What an entry of a geometry column holds, for messages: 'a POINT', 'an empty POLYGON', 'no geometry'."""
    geom = None if wkb is None or wkb is np.ma.masked else shapely.from_wkb(bytes(wkb))
    if geom is None:
        return "no geometry"
    name = geom.geom_type.upper()
    return f"an empty {name}" if geom.is_empty else f"{'an' if name[0] in 'AEIOU' else 'a'} {name}"


def triangles(wkb: np.ndarray) -> np.ndarray | None:
    """(n, 4, 3) corners (closing point repeated) if every geometry is a single-ring 4-point PolygonZ
    in little-endian WKB, as the TIN writer stores them; else None (use ``exterior_rings``)."""
    if wkb.dtype.kind != "V" or wkb.dtype.itemsize != _WKB_TRIANGLE.itemsize or np.ma.is_masked(wkb):
        return None
    parsed = np.frombuffer(np.ascontiguousarray(np.ma.getdata(wkb)).tobytes(), dtype=_WKB_TRIANGLE)
    if not ((parsed["byte_order"] == 1).all() and np.isin(parsed["type"], _POLYGON_Z_TYPES).all()
            and (parsed["rings"] == 1).all() and (parsed["points"] == 4).all()):
        return None
    return parsed["xyz"]


def exterior_rings(wkb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, counts, rings): the exterior ring of each geometry as stored, closing point included.

    ``points`` (m, 3) holds the rings one after another (Z is NaN for 2D geometries), ``counts``
    their lengths; ``rings`` is the number of rings of each polygon (a multipolygon of one polygon
    counts as that polygon), 0 where the geometry is missing, empty or not a polygon (count 0).
    """
    corners = triangles(wkb)
    if corners is not None:
        ones = np.ones(len(corners), dtype=np.int64)
        return corners.reshape(-1, 3), 4 * ones, ones
    geoms = shapely.from_wkb(np.array(wkb.tolist(), dtype=object))  # NULL → None
    single = ((shapely.get_type_id(geoms) == shapely.GeometryType.MULTIPOLYGON)
              & (shapely.get_num_geometries(geoms) == 1))
    geoms = np.where(single, shapely.get_geometry(geoms, 0), geoms)
    polygonal = (shapely.get_type_id(geoms) == shapely.GeometryType.POLYGON) & ~shapely.is_empty(geoms)
    geoms = np.where(polygonal, geoms, None)  # type: ignore[call-overload]  # numpy's stubs refuse None, numpy takes it
    points, index = shapely.get_coordinates(shapely.get_exterior_ring(geoms), include_z=True, return_index=True)
    rings = np.where(polygonal, shapely.get_num_interior_rings(geoms) + 1, 0).astype(np.int64)
    return points, np.bincount(index, minlength=len(geoms)).astype(np.int64), rings
