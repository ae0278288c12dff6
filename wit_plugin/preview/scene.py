"""The preview's scene: LoD1 faces, TIN triangles and texture rows read into triangles with texture coordinates."""
from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.io import bulk_read
from ..infra.io.vector_io import open_step_layer
from ..infra.meshes import fan_corners, planar_triangles, triangle_vertices
from ..infra.texcoords import parse_texcoords

_KINDS = ("roof", "wall", "terrain", "road", "footprint")


_ROOF, _WALL, _TERRAIN, _ROAD, _FOOTPRINT = range(len(_KINDS))


@dataclass
class PreviewReport:
    """What ``render_preview`` drew and how long it took."""

    output: str
    width: int
    height: int
    triangles: dict[str, int] = field(default_factory=dict)
    """Triangles drawn per kind: roof, wall, terrain, road, footprint."""
    textured_triangles: int = 0
    images: int = 0
    """Texture images sampled."""
    untextured_roofs: int = 0
    """Roof faces with no usable texture row (drawn in a flat colour)."""
    seconds: dict[str, float] = field(default_factory=dict)
    """Wall-clock time per stage: read, raster, shade, write."""


@dataclass
class _Mesh:
    """Triangles in model coordinates with their drawing attributes."""

    xyz: np.ndarray  # (n, 3, 3) float64
    kind: np.ndarray  # (n,) int8, index into _KINDS
    group: np.ndarray  # (n,) int32: building number for LoD1 faces, -1 for the TIN (edge darkening)
    uv: np.ndarray  # (n, 3, 2) float32, meaningless where image < 0
    image: np.ndarray  # (n,) int32 index into the image list, -1 = untextured

    @staticmethod
    def concat(meshes: list[_Mesh]) -> _Mesh:
        names = ("xyz", "kind", "group", "uv", "image")
        return _Mesh(*(np.concatenate([getattr(m, name) for m in meshes]) for name in names))


@contextlib.contextmanager
def _open_layer(path: str, name: str, role: str, fields: tuple[str, ...]) -> Iterator[ogr.Layer]:
    ds, layer, present = open_step_layer(path, name, role, fields)
    bulk_read.ignore_fields(layer, [f for f in present if f not in fields])
    try:
        yield layer
    finally:
        del layer, ds  # the layer before its dataset


def _read_columns(layer: ogr.Layer, fields: tuple[str, ...],
                  geometry: Callable[[np.ndarray], np.ndarray] | None = None) -> dict[str | None, np.ndarray]:
    """The fields (text as str; NULL as None, or 0 for numbers) and, if ``geometry`` is given, its
    result on each batch of shapely geometries (key ``None``), so that a batch's WKB is freed at once."""
    values: dict[str | None, list] = {f: [] for f in fields}
    if geometry is not None:
        values[None] = []
    for batch, wkbs in _batches(layer, fields):
        for f in fields:
            values[f].append(batch[f])
        if geometry is not None:
            values[None].append(geometry(shapely.from_wkb(np.array(wkbs, dtype=object), on_invalid="ignore")))
    out: dict[str | None, np.ndarray] = {}
    for key, parts in values.items():
        column = np.concatenate(parts) if parts else np.zeros(0, dtype=object)
        if column.dtype.kind in "SO":
            column = np.array([v.decode() if isinstance(v, bytes) else v for v in column.tolist()], dtype=object)
        out[key] = column
    return out


def _batches(layer: ogr.Layer, fields: tuple[str, ...],
             size: int = 65536) -> Iterator[tuple[dict[str, np.ndarray], list[bytes | None]]]:
    """Field columns and WKB geometries, batch by batch: GDAL's Arrow interface when it can take the layer
    (``bulk_read.arrow_ready``), else a feature loop."""
    if bulk_read.arrow_ready(layer):
        geom_name = layer.GetGeometryColumn() or "geom"
        for batch in layer.GetArrowStreamAsNumPy(options=["USE_MASKED_ARRAYS=NO"]):
            yield batch, [bytes(w) if w is not None else None for w in batch[geom_name]] if geom_name in batch else []
        return
    rows: list[list] = []
    for feature in layer:
        geom = feature.GetGeometryRef()
        rows.append([feature.GetField(f) for f in fields] + [bytes(geom.ExportToIsoWkb()) if geom else None])
        if len(rows) == size:
            yield {f: np.array([r[k] for r in rows], dtype=object) for k, f in enumerate(fields)}, [r[-1] for r in rows]
            rows = []
    if rows:
        yield {f: np.array([r[k] for r in rows], dtype=object) for k, f in enumerate(fields)}, [r[-1] for r in rows]


class _TexTable:
    """The texture table: uv per roof or wall face (wit_id, face_no) and per TIN triangle (tri_id)."""

    def __init__(self, keys: dict, uv: np.ndarray, starts: np.ndarray, counts: np.ndarray, image: np.ndarray):
        self.keys, self.uv, self.starts, self.counts, self.image = keys, uv, starts, counts, image

    @classmethod
    def read(cls, folder: str, images: list[str]) -> _TexTable:
        path = Path(folder) / step_layers.TEXCOORD_FILE
        fields = (step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE, step_layers.TEX_IMAGE,
                  step_layers.TEX_COORDS)
        with _open_layer(str(path), step_layers.TEXCOORD_TABLE, step_layers.TEXCOORD_ROLE, fields) as layer:
            cols = _read_columns(layer, fields)
        try:
            uv, counts = parse_texcoords(cols[step_layers.TEX_COORDS].tolist())
        except ValueError:
            raise InputError(f"The texture table {path} has malformed texture coordinates: "
                             "re-run wit:wittexture.") from None
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        names, image = np.unique(cols[step_layers.TEX_IMAGE].astype(str), return_inverse=True)
        images.extend(names.tolist())
        keys = {}
        columns = (cols[step_layers.TEX_TARGET].tolist(), cols[step_layers.TEX_FEATURE].tolist(),
                   cols[step_layers.TEX_FACE].tolist())
        for i, (target, feature, face) in enumerate(zip(*columns)):
            keys[(feature, int(face or 0)) if target in ("roof", step_layers.TEX_WALL) else feature] = i
        return cls(keys, uv, starts, counts, image.astype(np.int32))

    def rows(self, keys: list) -> np.ndarray:
        """Row of each key, -1 where absent."""
        return np.array([self.keys.get(k, -1) for k in keys], dtype=np.int64)


def _read_lod1(path: str, table: _TexTable | None, report: PreviewReport) -> _Mesh:
    fields = (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER)
    with _open_layer(path, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE, fields) as layer:
        cols = _read_columns(layer, fields, lambda geoms: geoms)
    geoms, kind = cols[None], cols[step_layers.FACE_TYPE]
    ok = ~shapely.is_missing(geoms) & (shapely.get_type_id(geoms) == 3)
    _, building = np.unique(cols[step_layers.WIT_ID].astype(str), return_inverse=True)
    roofs = np.flatnonzero(ok & (kind == "roof"))
    walls = np.flatnonzero(ok & (kind == "wall"))
    def rows(faces: np.ndarray) -> np.ndarray:
        keys = [(cols[step_layers.WIT_ID][i], int(cols[step_layers.FACE_NUMBER][i] or 0)) for i in faces]
        return table.rows(keys) if table is not None else np.full(len(faces), -1)

    roof, report.untextured_roofs = _roof_mesh(geoms[roofs], building[roofs], rows(roofs), table)
    return _Mesh.concat([roof, _wall_mesh(geoms[walls], building[walls], rows(walls), table)])


def _roof_mesh(polygons: np.ndarray, building: np.ndarray, rows: np.ndarray,
               table: _TexTable | None) -> tuple[_Mesh, int]:
    """Constrained Delaunay triangles of the roofs (z and uv affine in x, y per face); untextured faces."""
    ring_xyz, ring_face = shapely.get_coordinates(shapely.get_exterior_ring(polygons), include_z=True,
                                                  return_index=True)
    n = len(polygons)
    values = np.column_stack([ring_xyz[:, 2], np.zeros((len(ring_xyz), 2))])
    textured = np.zeros(n, dtype=bool)
    if table is not None and n:
        ring_counts = np.bincount(ring_face, minlength=n)
        row_counts = np.where(rows >= 0, table.counts[np.maximum(rows, 0)], -1)
        textured = row_counts == ring_counts
        point = np.flatnonzero(textured[ring_face])
        first = np.concatenate([[0], np.cumsum(ring_counts)[:-1]])
        within = point - first[ring_face[point]]
        values[point, 1:] = table.uv[table.starts[rows[ring_face[point]]] + within]
    xy, fitted, face = planar_triangles(polygons, values)
    xyz = np.concatenate([xy, fitted[:, :, :1]], axis=2)
    image = np.where(textured[face], table.image[np.maximum(rows[face], 0)] if table is not None else -1, -1)
    mesh = _Mesh(xyz, np.full(len(face), _ROOF, np.int8), building[face].astype(np.int32),
                 fitted[:, :, 1:].astype(np.float32), image.astype(np.int32))
    return mesh, int(np.count_nonzero(~textured)) if table is not None else 0


def _wall_mesh(polygons: np.ndarray, building: np.ndarray, rows: np.ndarray, table: _TexTable | None) -> _Mesh:
    """Walls fanned from their first vertex (convex quads in LoD1), with their generated facade where the
    texture row fits the ring."""
    xyz = shapely.get_coordinates(shapely.get_exterior_ring(polygons), include_z=True)
    index, owner = fan_corners(polygons)
    t = len(owner)
    uv, image = np.zeros((t, 3, 2), np.float32), np.full(t, -1, np.int32)
    if table is not None and t:
        counts = shapely.get_num_coordinates(shapely.get_exterior_ring(polygons))
        textured = (rows >= 0) & (table.counts[np.maximum(rows, 0)] == counts)
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        hit = np.flatnonzero(textured[owner])
        uv[hit] = table.uv[table.starts[rows[owner[hit]]][:, None] + (index[hit] - first[owner[hit]][:, None])]
        image[hit] = table.image[rows[owner[hit]]]
    return _Mesh(xyz[index], np.full(t, _WALL, np.int8), building[owner].astype(np.int32), uv, image)


def _read_tin(path: str, table: _TexTable | None) -> _Mesh:
    fields = (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE)
    with _open_layer(path, step_layers.TIN_LAYER, step_layers.TIN_ROLE, fields) as layer:
        cols = _read_columns(layer, fields, triangle_vertices)
    ok = np.flatnonzero(np.isfinite(cols[None]).all(axis=(1, 2)))
    xyz = cols[None][ok]
    surface = cols[step_layers.TIN_SURFACE][ok]
    kind = np.select([surface == "road", surface == "footprint"], [_ROAD, _FOOTPRINT], _TERRAIN).astype(np.int8)
    uv = np.zeros((len(ok), 3, 2), np.float32)
    image = np.full(len(ok), -1, np.int32)
    if table is not None and len(ok):
        rows = table.rows([str(t) for t in cols[step_layers.TIN_TRIANGLE_ID][ok].tolist()])
        hit = np.flatnonzero((rows >= 0) & (table.counts[np.maximum(rows, 0)] == 4))
        uv[hit] = table.uv[table.starts[rows[hit]][:, None] + np.arange(3)]
        image[hit] = table.image[rows[hit]]
    return _Mesh(xyz, kind, np.full(len(ok), -1, np.int32), uv, image)
