"""Read big layers in batches through OGR's Arrow stream: numpy columns, no Python object per feature.

The TIN of the 1 km demo has ~600,000 triangles and the texture table as many rows; reading
them one OGR feature at a time (a Python call per feature, per field and per geometry) took
seconds in both wit:wittexture and wit:writecitygml. GDAL's Arrow stream (GDAL ≥ 3.6) hands
over whole batches as numpy arrays, for any vector format and for SQL results (ordered or
filtered reads); ring coordinates are then unpacked from the WKB with numpy, without shapely
objects for the common case of triangles, the sibling of ``gpkg_bulk``'s writer.
"""
from __future__ import annotations

from typing import Iterator

import numpy as np
import shapely
from osgeo import ogr

BATCH = 65_536  # features per Arrow batch: a few MB of a TIN's columns

#: ISO WKB of a PolygonZ (1003) with one ring of 4 points, little-endian: a TIN triangle
_WKB_TRIANGLE = np.dtype([("byte_order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"),
                          ("xyz", "<f8", (4, 3))])
_POLYGON_Z_TYPES = (1003, 0x80000003)  # ISO and old-style (25D) WKB type codes of PolygonZ


def batches(layer: ogr.Layer, size: int = BATCH, fid: bool = False) -> Iterator[dict[str, np.ndarray]]:
    """The features of ``layer`` (a table, or the result of ``ExecuteSQL``) as column → array batches.

    The geometry column is keyed ``"geometry"`` (WKB, None for no geometry) and, with ``fid``, the
    feature ids ``"fid"``; attribute fields by name; a field with NULLs is a
    ``numpy.ma.MaskedArray``; text comes as bytes. Ignored fields (``SetIgnoredFields``) are left out.
    """
    names = {layer.GetGeometryColumn() or "wkb_geometry": "geometry"}
    if fid:
        names[layer.GetFIDColumn() or "OGC_FID"] = "fid"
    options = [f"INCLUDE_FID={'YES' if fid else 'NO'}", f"MAX_FEATURES_IN_BATCH={size}"]
    for batch in layer.GetArrowStreamAsNumPy(options=options):
        yield {names.get(name, name): column for name, column in batch.items()}


def texts(column: np.ndarray) -> list[str]:
    """A text or integer column as Python strings, as OGR's ``GetFieldAsString`` gives them ('' for NULL)."""
    values = column.tolist()  # masked entries become None
    if column.dtype.kind == "S":
        return [v.decode("utf-8") if v is not None else "" for v in values]
    return ["" if v is None else str(v) for v in values]


def valid(column: np.ndarray) -> np.ndarray:
    """True where the column is not NULL."""
    return ~np.ma.getmaskarray(column)


def geometry_name(wkb: object) -> str:
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
    geoms = np.where(polygonal, geoms, None)
    points, index = shapely.get_coordinates(shapely.get_exterior_ring(geoms), include_z=True, return_index=True)
    rings = np.where(polygonal, shapely.get_num_interior_rings(geoms) + 1, 0).astype(np.int64)
    return points, np.bincount(index, minlength=len(geoms)).astype(np.int64), rings
