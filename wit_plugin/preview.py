"""Preview picture of the textured city model: a small numpy software renderer (PNG for a README).

Reads the step outputs named in ``model`` (LoD1 faces, optionally the TIN and the texture folder of
``wit:wittexture``) and draws the model seen obliquely through a perspective camera:

* **Geometry**: roof faces (holes included) are cut into triangles by a constrained Delaunay
  triangulation (``shapely.constrained_delaunay_triangles``); their z and texture coordinates are
  affine in x, y (planar faces, axis-aligned texture islands), fitted per face on the exterior ring;
  a self-intersecting roof is made valid first. Walls are fanned (quads in practice); ``ground``
  faces are never visible and are skipped; TIN triangles are drawn as they are (``footprint`` ones
  too, hidden under the buildings).
* **Camera**: placed at ``azimuth_deg`` (compass bearing from the model's centre to the camera) and
  ``elevation_deg`` above the horizon, at three times the model's radius; the focal length and
  principal point are fitted so that every vertex lies in the picture with a small margin.
* **Rasteriser**: triangles are bucketed by the power-of-two size of their pixel bounding box and
  processed in vectorised chunks (every candidate pixel of a chunk's boxes at once: barycentric
  coordinates, inside test, depth). Each chunk's fragments are resolved against a 32-bit z-buffer
  by one sort on (pixel, depth). The buffer keeps the triangle and two screen-space barycentrics
  per pixel; shading is deferred, once per visible pixel.
* **Shading**: texture coordinates are interpolated perspective-correctly and sampled bilinearly
  from the mip level matching each triangle's texel-to-pixel ratio (levels built with
  ``texture.mip_chain``, images read once and cached); untextured surfaces get a flat colour
  (walls beige, a little lighter or darker per building; terrain green-grey, roads dark grey).
  Lambert shading from a sun 65° clockwise of the camera: strong on walls, mild on roofs and
  terrain; building outlines (depth or building changes) are darkened a little, distance adds
  haze, the background is a sky gradient. The picture is rendered at twice the requested size and
  box-filtered down (anti-aliasing).

The PNG is written atomically: a cancelled or failed run leaves no file.
"""
from __future__ import annotations

import argparse
import contextlib
import itertools
import logging
import math
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from osgeo import gdal, ogr

from . import bulk_read
from . import step_layers as model
from .errors import InputError, WitError
from .feedback import SILENT, Feedback, LoggingFeedback
from .fileio import atomic_file
from .gdal_env import open_raster, read_window
from .meshes import fan_triangles, parse_texcoords, planar_triangles, triangle_vertices
from .texture import mip_chain
from .vector_io import open_step_layer

SUPERSAMPLE = 2  # rendered at this multiple of the output size, then box-filtered down
DISTANCE = 3.0  # camera distance in model radii (a field of view of about 35°)
MARGIN = 0.03  # share of the picture left free on each side
SUN_OFFSET_DEG = 65.0  # sun azimuth relative to the camera's
SUN_ELEVATION_DEG = 45.0
CELL_BUDGET = 1 << 21  # candidate pixels per rasteriser chunk (bounds memory to ~100 MB)

WALL_RGB = (222, 213, 196)
ROOF_RGB = (176, 120, 100)
TERRAIN_RGB = (128, 146, 108)
ROAD_RGB = (92, 92, 98)
FOOTPRINT_RGB = (150, 150, 140)
SKY_TOP_RGB = (104, 150, 206)
SKY_HORIZON_RGB = (222, 232, 242)
HAZE_RGB = (205, 218, 232)
HAZE_MAX = 0.3  # share of haze at the farthest point of the model

_KINDS = ("roof", "wall", "terrain", "road", "footprint")
_KIND_RGB = np.array([ROOF_RGB, WALL_RGB, TERRAIN_RGB, ROAD_RGB, FOOTPRINT_RGB], dtype=np.float32)
_ROOF, _WALL, _TERRAIN, _ROAD, _FOOTPRINT = range(len(_KINDS))
_FAR = np.uint32(0xFFFFFFFF)


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


def render_preview(lod1_gpkg: str, tin_gpkg: str | None, textures: str | None, output_png: str,
                   width: int = 1600, height: int = 1000, azimuth_deg: float = 135.0, elevation_deg: float = 40.0,
                   vertical_exaggeration: float = 1.0, feedback: Feedback = SILENT) -> PreviewReport:
    """Render the model to ``output_png``; see the module docstring.

    ``tin_gpkg`` and ``textures`` may be None (no terrain; flat colours). Raises ``InputError`` for
    unusable inputs or parameters and ``CanceledError`` on cancel; then no file is written.
    """
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        raise InputError(f"Picture size {width} × {height} is out of range: use 16–16384 pixels a side.")
    if not 5.0 <= elevation_deg <= 90.0:
        raise InputError(f"Camera elevation {elevation_deg:g}° is out of range: use 5–90°.")
    if not 0.0 < vertical_exaggeration <= 100.0:
        raise InputError(f"Vertical exaggeration {vertical_exaggeration:g} is out of range: use 0 < factor ≤ 100.")
    report = PreviewReport(output=str(output_png), width=width, height=height)
    start = time.perf_counter()
    images: list[str] = []
    table = _TexTable.read(textures, images) if textures else None
    buildings = _read_lod1(lod1_gpkg, table, report)
    feedback.check_canceled()
    meshes = [buildings] + ([_read_tin(tin_gpkg, table)] if tin_gpkg else [])
    mesh = _Mesh.concat(meshes)
    if len(mesh.xyz) == 0:
        raise InputError(f"Nothing to draw: {lod1_gpkg} has no roof or wall faces"
                         + (f" and {tin_gpkg} no triangles." if tin_gpkg else "."))
    report.triangles = {name: int(np.count_nonzero(mesh.kind == k)) for k, name in enumerate(_KINDS)}
    report.textured_triangles = int(np.count_nonzero(mesh.image >= 0))
    report.images = len(set(mesh.image[mesh.image >= 0].tolist()))
    feedback.info(f"Preview: {len(mesh.xyz)} triangles ({', '.join(f'{k} {v}' for k, v in report.triangles.items())}), "
                  f"{report.textured_triangles} textured from {report.images} image(s).")
    if report.untextured_roofs:
        feedback.warning(f"{report.untextured_roofs} roof face(s) have no texture row: drawn in a flat colour.")
    feedback.progress(10.0)
    report.seconds["read"] = time.perf_counter() - start

    mesh.xyz[:, :, 2] = (mesh.xyz[:, :, 2] - mesh.xyz[:, :, 2].min()) * vertical_exaggeration
    camera = _Camera.framing(mesh.xyz, width * SUPERSAMPLE, height * SUPERSAMPLE, azimuth_deg, elevation_deg)
    start = time.perf_counter()
    frame = _rasterise(camera, mesh.xyz, feedback.scaled(10.0, 75.0))
    report.seconds["raster"] = time.perf_counter() - start
    start = time.perf_counter()
    rgb = _shade(camera, mesh, frame, _ImageCache(Path(textures) if textures else None, images), azimuth_deg, feedback)
    picture = _downsample(rgb, SUPERSAMPLE)
    report.seconds["shade"] = time.perf_counter() - start
    feedback.check_canceled()
    start = time.perf_counter()
    _write_png(picture, output_png)
    report.seconds["write"] = time.perf_counter() - start
    feedback.info("Preview written to {} ({}).".format(
        output_png, ", ".join(f"{k} {v:.1f} s" for k, v in report.seconds.items())))
    feedback.progress(100.0)
    return report


# --- inputs -------------------------------------------------------------------------------------

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
    """The texture table: uv per roof face (wit_id, face_no) and per TIN triangle (tri_id)."""

    def __init__(self, keys: dict, uv: np.ndarray, starts: np.ndarray, counts: np.ndarray, image: np.ndarray):
        self.keys, self.uv, self.starts, self.counts, self.image = keys, uv, starts, counts, image

    @classmethod
    def read(cls, folder: str, images: list[str]) -> _TexTable:
        path = Path(folder) / model.TEXCOORD_FILE
        fields = (model.TEX_TARGET, model.TEX_FEATURE, model.TEX_FACE, model.TEX_IMAGE, model.TEX_COORDS)
        with _open_layer(str(path), model.TEXCOORD_TABLE, model.TEXCOORD_ROLE, fields) as layer:
            cols = _read_columns(layer, fields)
        try:
            uv, counts = parse_texcoords(cols[model.TEX_COORDS].tolist())
        except ValueError:
            raise InputError(f"The texture table {path} has malformed texture coordinates: re-run wit:wittexture.")
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        names, image = np.unique(cols[model.TEX_IMAGE].astype(str), return_inverse=True)
        images.extend(names.tolist())
        keys = {}
        columns = (cols[model.TEX_TARGET].tolist(), cols[model.TEX_FEATURE].tolist(), cols[model.TEX_FACE].tolist())
        for i, (target, feature, face) in enumerate(zip(*columns)):
            keys[(feature, int(face or 0)) if target == "roof" else feature] = i
        return cls(keys, uv, starts, counts, image.astype(np.int32))

    def rows(self, keys: list) -> np.ndarray:
        """Row of each key, -1 where absent."""
        return np.array([self.keys.get(k, -1) for k in keys], dtype=np.int64)


def _read_lod1(path: str, table: _TexTable | None, report: PreviewReport) -> _Mesh:
    fields = (model.WIT_ID, model.FACE_TYPE, model.FACE_NUMBER)
    with _open_layer(path, model.LOD1_LAYER, model.LOD1_ROLE, fields) as layer:
        cols = _read_columns(layer, fields, lambda geoms: geoms)
    geoms, kind = cols[None], cols[model.FACE_TYPE]
    ok = ~shapely.is_missing(geoms) & (shapely.get_type_id(geoms) == 3)
    _, building = np.unique(cols[model.WIT_ID].astype(str), return_inverse=True)
    roofs = np.flatnonzero(ok & (kind == "roof"))
    walls = np.flatnonzero(ok & (kind == "wall"))
    rows = (table.rows([(cols[model.WIT_ID][i], int(cols[model.FACE_NUMBER][i] or 0)) for i in roofs])
            if table is not None else np.full(len(roofs), -1))
    roof, report.untextured_roofs = _roof_mesh(geoms[roofs], building[roofs], rows, table)
    return _Mesh.concat([roof, _wall_mesh(geoms[walls], building[walls])])


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


def _wall_mesh(polygons: np.ndarray, building: np.ndarray) -> _Mesh:
    """Walls fanned from their first vertex (convex quads in LoD1)."""
    xyz, owner = fan_triangles(polygons)
    t = len(owner)
    return _Mesh(xyz, np.full(t, _WALL, np.int8), building[owner].astype(np.int32),
                 np.zeros((t, 3, 2), np.float32), np.full(t, -1, np.int32))


def _read_tin(path: str, table: _TexTable | None) -> _Mesh:
    fields = (model.TIN_TRIANGLE_ID, model.TIN_SURFACE)
    with _open_layer(path, model.TIN_LAYER, model.TIN_ROLE, fields) as layer:
        cols = _read_columns(layer, fields, triangle_vertices)
    ok = np.flatnonzero(np.isfinite(cols[None]).all(axis=(1, 2)))
    xyz = cols[None][ok]
    surface = cols[model.TIN_SURFACE][ok]
    kind = np.select([surface == "road", surface == "footprint"], [_ROAD, _FOOTPRINT], _TERRAIN).astype(np.int8)
    uv = np.zeros((len(ok), 3, 2), np.float32)
    image = np.full(len(ok), -1, np.int32)
    if table is not None and len(ok):
        rows = table.rows([str(t) for t in cols[model.TIN_TRIANGLE_ID][ok].tolist()])
        hit = np.flatnonzero((rows >= 0) & (table.counts[np.maximum(rows, 0)] == 4))
        uv[hit] = table.uv[table.starts[rows[hit]][:, None] + np.arange(3)]
        image[hit] = table.image[rows[hit]]
    return _Mesh(xyz, kind, np.full(len(ok), -1, np.int32), uv, image)


# --- camera and rasteriser ----------------------------------------------------------------------

@dataclass
class _Camera:
    """Perspective camera: view axes, position, focal length (pixels) and principal point."""

    position: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    focal: float
    cx: float
    cy: float
    width: int
    height: int

    @classmethod
    def framing(cls, xyz: np.ndarray, width: int, height: int, azimuth_deg: float, elevation_deg: float) -> _Camera:
        """Look at the centre of the model's box from the given direction; fit every vertex in the frame."""
        points = xyz.reshape(-1, 3)
        lo, hi = points.min(axis=0), points.max(axis=0)
        centre = (lo + hi) / 2
        radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
        az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
        to_camera = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
        forward = -to_camera
        right = np.cross(forward, [0.0, 0.0, 1.0]) if elevation_deg < 90 else np.array([1.0, 0.0, 0.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        camera = cls(centre + DISTANCE * radius * to_camera, right, up, forward, 1.0, 0.0, 0.0, width, height)
        view = camera.view(points)
        sx, sy = view[:, 0] / view[:, 2], view[:, 1] / view[:, 2]
        span_x, span_y = max(np.ptp(sx), 1e-9), max(np.ptp(sy), 1e-9)
        camera.focal = min(width / span_x, height / span_y) * (1 - 2 * MARGIN)
        camera.cx = width / 2 - camera.focal * (sx.min() + sx.max()) / 2
        camera.cy = height / 2 + camera.focal * (sy.min() + sy.max()) / 2
        return camera

    def view(self, points: np.ndarray) -> np.ndarray:
        """Camera coordinates: right, up, depth along the view direction."""
        d = points - self.position
        return np.stack([d @ self.right, d @ self.up, d @ self.forward], axis=-1)

    def project(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (x right, y down) and 1/depth of points (..., 3)."""
        view = self.view(xyz)
        inv = 1.0 / view[..., 2]
        return np.stack([self.cx + self.focal * view[..., 0] * inv, self.cy - self.focal * view[..., 1] * inv],
                        axis=-1), inv


@dataclass
class _Frame:
    """The z-buffer's result: per pixel the visible triangle (-1 = none) and barycentrics l1, l2."""

    triangle: np.ndarray
    l1: np.ndarray
    l2: np.ndarray
    screen: np.ndarray  # (n, 3, 2) pixel coordinates of the triangles
    inv_depth: np.ndarray  # (n, 3)


def _rasterise(camera: _Camera, xyz: np.ndarray, feedback: Feedback) -> _Frame:
    """Z-buffer every triangle; chunks of equally sized pixel boxes are processed at once."""
    w, h = camera.width, camera.height
    screen, inv = camera.project(xyz)
    x, y = screen[..., 0], screen[..., 1]
    x0 = np.clip(np.ceil(x.min(axis=1) - 0.5), 0, w).astype(np.int64)
    x1 = np.clip(np.floor(x.max(axis=1) - 0.5), -1, w - 1).astype(np.int64)
    y0 = np.clip(np.ceil(y.min(axis=1) - 0.5), 0, h).astype(np.int64)
    y1 = np.clip(np.floor(y.max(axis=1) - 0.5), -1, h - 1).astype(np.int64)
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    live = np.flatnonzero((x1 >= x0) & (y1 >= y0) & (np.abs(area2) > 1e-12) & (inv.min(axis=1) > 0))
    bw = 1 << np.ceil(np.log2(x1[live] - x0[live] + 1)).astype(np.int64)
    bh = 1 << np.ceil(np.log2(y1[live] - y0[live] + 1)).astype(np.int64)
    order = np.lexsort((bh, bw))
    live, bw, bh = live[order], bw[order], bh[order]
    # l1 = a1·gx + b1·gy + c1 over the box's pixel offsets gx, gy (centres at +0.5); likewise l2
    ox, oy = x[:, 0] - x0 - 0.5, y[:, 0] - y0 - 0.5
    ex1, ey1, ex2, ey2 = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], x[:, 2] - x[:, 0], y[:, 2] - y[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.stack([ey2, -ex2, -(ox * ey2 - oy * ex2), -ey1, ex1, -(ex1 * oy - ey1 * ox)], axis=1) / area2[:, None]
    coef = coef.astype(np.float32)
    inv_lo, inv_hi = float(inv.min()), float(inv.max())
    iz = ((inv - inv_lo) / max(inv_hi - inv_lo, 1e-30)).astype(np.float32)  # 0 far … 1 near

    zbuf = np.full(w * h, _FAR, dtype=np.uint32)
    tbuf = np.full(w * h, -1, dtype=np.int32)
    l1buf = np.zeros(w * h, np.float32)
    l2buf = np.zeros(w * h, np.float32)
    groups = np.flatnonzero(np.diff(np.concatenate([[-1], bw * 65536 + bh, [-1]])))
    done, total = 0, max(len(live), 1)
    for g0, g1 in itertools.pairwise(groups):
        gw, gh = int(bw[g0]), int(bh[g0])
        step = max(1, CELL_BUDGET // (gw * gh))
        gx = np.arange(gw, dtype=np.float32)[None, None, :]
        gy = np.arange(gh, dtype=np.float32)[None, :, None]
        for c0 in range(g0, g1, step):
            feedback.check_canceled()
            t = live[c0:min(c0 + step, g1)]
            k = coef[t][:, :, None, None]
            l1 = k[:, 0] * gx + k[:, 1] * gy + k[:, 2]
            l2 = k[:, 3] * gx + k[:, 4] * gy + k[:, 5]
            eps = np.float32(-1e-5)
            inside = (l1 >= eps) & (l2 >= eps) & (l1 + l2 <= 1 - eps)
            inside &= (gx < (x1[t] - x0[t] + 1)[:, None, None]) & (gy < (y1[t] - y0[t] + 1)[:, None, None])
            ti, yy, xx = np.nonzero(inside)
            l1, l2 = l1[ti, yy, xx], l2[ti, yy, xx]
            tri = t[ti]
            z = iz[tri, 0] + l1 * (iz[tri, 1] - iz[tri, 0]) + l2 * (iz[tri, 2] - iz[tri, 0])
            depth = ((1.0 - np.clip(z, 0.0, 1.0)) * np.float32(4.29e9)).astype(np.uint32)  # 0 = nearest
            pixel = (y0[tri] + yy) * w + x0[tri] + xx
            _resolve(pixel, depth, tri, l1, l2, zbuf, tbuf, l1buf, l2buf)
            done += len(t)
            feedback.progress(100.0 * done / total)
    return _Frame(tbuf.reshape(h, w), l1buf.reshape(h, w), l2buf.reshape(h, w), screen, inv)


def _resolve(pixel: np.ndarray, depth: np.ndarray, tri: np.ndarray, l1: np.ndarray, l2: np.ndarray,
             zbuf: np.ndarray, tbuf: np.ndarray, l1buf: np.ndarray, l2buf: np.ndarray) -> None:
    """Keep, per pixel, the nearest fragment if it is nearer than the buffer's."""
    order = np.argsort((pixel.astype(np.int64) << 32) | depth.astype(np.int64))
    p = pixel[order]
    first = np.ones(len(p), dtype=bool)
    first[1:] = p[1:] != p[:-1]
    sel = order[first]
    p = pixel[sel]
    nearer = depth[sel] < zbuf[p]
    sel, p = sel[nearer], p[nearer]
    zbuf[p], tbuf[p], l1buf[p], l2buf[p] = depth[sel], tri[sel], l1[sel], l2[sel]


# --- shading ------------------------------------------------------------------------------------

class _ImageCache:
    """Texture images read once (GDAL), with their mip levels built on demand."""

    def __init__(self, folder: Path | None, names: list[str]):
        self.folder, self.names = folder, names
        self._levels: dict[int, list[np.ndarray]] = {}

    def size(self, index: int) -> tuple[int, int]:
        """Width and height of level 0."""
        base = self.level(index, 0)
        return base.shape[1], base.shape[0]

    def level(self, index: int, level: int) -> np.ndarray:
        """Mip ``level`` (clamped to the chain) of image ``index`` as rows × columns × 3 uint8."""
        levels = self._levels.get(index)
        if levels is None:
            levels = self._levels[index] = [self._read(index)]
        if level > 0 and len(levels) == 1:
            levels.extend(mip_chain(levels[0])[1:])
        return levels[min(level, len(levels) - 1)]

    def _read(self, index: int) -> np.ndarray:
        path = self.folder / self.names[index]
        ds = open_raster(path, "texture image")
        bands = [1, 2, 3] if ds.RasterCount >= 3 else [1, 1, 1]
        data = np.stack([read_window(ds.GetRasterBand(b), 0, 0, ds.RasterXSize, ds.RasterYSize,
                                     f"the texture image {path}") for b in bands], axis=-1)
        return np.clip(data, 0, 255).astype(np.uint8) if data.dtype != np.uint8 else data


def _bilinear(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples (n × 3 float32) of ``image`` at texture coordinates (v from the bottom), edges clamped."""
    h, w = image.shape[:2]
    fx = np.clip(u * w - 0.5, 0, w - 1).astype(np.float32)
    fy = np.clip((1.0 - v) * h - 0.5, 0, h - 1).astype(np.float32)
    ix, iy = np.minimum(fx.astype(np.int64), max(w - 2, 0)), np.minimum(fy.astype(np.int64), max(h - 2, 0))
    ax, ay = (fx - ix)[:, None], (fy - iy)[:, None]
    jx, jy = np.minimum(ix + 1, w - 1), np.minimum(iy + 1, h - 1)
    top = image[iy, ix] * (1 - ax) + image[iy, jx] * ax
    bottom = image[jy, ix] * (1 - ax) + image[jy, jx] * ax
    return top * (1 - ay) + bottom * ay


def _shade(camera: _Camera, mesh: _Mesh, frame: _Frame, cache: _ImageCache, azimuth_deg: float,
           feedback: Feedback) -> np.ndarray:
    """Colour every pixel (float32 rows × columns × 3, 0–255): textures, light, edges, haze and sky."""
    h, w = frame.triangle.shape
    rows = np.linspace(0.0, 1.0, h, dtype=np.float32)[:, None, None]
    sky = np.array(SKY_TOP_RGB, np.float32) * (1 - rows) + np.array(SKY_HORIZON_RGB, np.float32) * rows
    rgb = np.broadcast_to(sky, (h, w, 3)).copy()
    covered = np.flatnonzero(frame.triangle.ravel() >= 0)
    t = frame.triangle.ravel()[covered]
    l1, l2 = frame.l1.ravel()[covered], frame.l2.ravel()[covered]
    lam = np.stack([1 - l1 - l2, l1, l2], axis=1) * frame.inv_depth[t].astype(np.float32)
    inv_z = lam.sum(axis=1)
    bary = lam / inv_z[:, None]  # perspective-correct barycentrics
    depth = 1.0 / inv_z

    colour = _KIND_RGB[mesh.kind[t]].copy()
    textured = np.flatnonzero(mesh.image[t] >= 0)
    if len(textured):
        tt = t[textured]
        uv = np.einsum("pk,pkc->pc", bary[textured], mesh.uv[tt])
        level = _mip_levels(mesh, frame, cache)[tt]
        key = mesh.image[tt].astype(np.int64) * 64 + level
        order = np.argsort(key, kind="stable")
        bounds = np.flatnonzero(np.diff(np.concatenate([[-1], key[order], [-1]])))
        for b0, b1 in itertools.pairwise(bounds):
            feedback.check_canceled()
            sel = order[b0:b1]
            image = cache.level(int(key[sel[0]] // 64), int(key[sel[0]] % 64))
            colour[textured[sel]] = _bilinear(image, uv[sel, 0], uv[sel, 1])
    colour *= _light(camera, mesh, azimuth_deg)[t][:, None]

    edge = _edges(frame.triangle, mesh.group, depth, covered, w, h)
    colour *= np.where(edge, np.float32(0.72), np.float32(1.0))[:, None]
    near, far = float(depth.min()), float(depth.max())
    haze = (np.clip((depth - near) / max(far - near, 1e-9), 0, 1) ** 1.5 * HAZE_MAX)[:, None]
    colour = colour * (1 - haze) + np.array(HAZE_RGB, np.float32) * haze
    rgb.reshape(-1, 3)[covered] = colour
    feedback.progress(95.0)
    return rgb


def _mip_levels(mesh: _Mesh, frame: _Frame, cache: _ImageCache) -> np.ndarray:
    """Per triangle, the mip level whose texels are about one pixel (0 for untextured triangles)."""
    levels = np.zeros(len(mesh.image), dtype=np.int64)
    textured = np.flatnonzero(mesh.image >= 0)
    if not len(textured):
        return levels
    used = set(mesh.image[textured].tolist())
    sizes = np.array([cache.size(i) if i in used else (1, 1) for i in range(int(mesh.image.max()) + 1)],
                     dtype=np.float64)
    uv = mesh.uv[textured].astype(np.float64) * sizes[mesh.image[textured]][:, None, :]
    s = frame.screen[textured]

    def area(p: np.ndarray) -> np.ndarray:
        return np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                      - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))

    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(area(uv) / area(s))
    levels[textured] = np.clip(np.floor(np.log2(np.nan_to_num(ratio, nan=1.0, posinf=1.0))), 0, 30)
    return levels


def _light(camera: _Camera, mesh: _Mesh, azimuth_deg: float) -> np.ndarray:
    """Lambert factor per triangle: strong on walls (tinted per building), mild on roofs and terrain (1 on flat)."""
    az, el = math.radians(azimuth_deg + SUN_OFFSET_DEG), math.radians(SUN_ELEVATION_DEG)
    sun = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
    p = mesh.xyz
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-12)[:, None]
    facing = np.einsum("nk,nk->n", camera.position - p[:, 0], normal)
    normal[facing < 0] *= -1  # the side the camera sees
    lit = normal @ sun
    wall = mesh.kind == _WALL
    tint = 0.9 + 0.15 * ((mesh.group * 0.618034) % 1.0)  # a little variety between buildings
    return np.where(wall, tint * (0.55 + 0.5 * np.clip(lit, 0, 1)),
                    np.clip(1.0 + 0.8 * (lit - math.sin(el)), 0.6, 1.25)).astype(np.float32)


def _edges(triangle: np.ndarray, group: np.ndarray, depth: np.ndarray, covered: np.ndarray,
           w: int, h: int) -> np.ndarray:
    """Covered pixels on a building outline: next to another building or the ground, or to a farther surface."""
    g = np.full(h * w, -2, np.int64)
    g[covered] = group[triangle.ravel()[covered]]
    z = np.full(h * w, np.finfo(np.float32).max, np.float32)
    z[covered] = depth
    g, z = g.reshape(h, w), z.reshape(h, w)
    edge = np.zeros((h, w), dtype=bool)
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        ga, gb, za, zb = g[tuple(a)], g[tuple(b)], z[tuple(a)], z[tuple(b)]
        differs = (ga != gb) & ((ga >= 0) | (gb >= 0))
        jump = np.abs(za - zb) > 0.01 * np.minimum(za, zb)
        mark = differs | jump
        edge[tuple(a)] |= mark & (za <= zb) & (ga >= 0)  # the nearer side of a building outline
        edge[tuple(b)] |= mark & (zb < za) & (gb >= 0)
    return edge.ravel()[covered]


def _downsample(rgb: np.ndarray, factor: int) -> np.ndarray:
    h, w = rgb.shape[0] // factor, rgb.shape[1] // factor
    small = rgb[:h * factor, :w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    return np.clip(np.rint(small), 0, 255).astype(np.uint8)


def _write_png(picture: np.ndarray, output_png: str) -> None:
    h, w = picture.shape[:2]
    with atomic_file(output_png) as tmp:
        mem = gdal.GetDriverByName("MEM").Create("", w, h, 3, gdal.GDT_Byte)
        for b in range(3):
            mem.GetRasterBand(b + 1).WriteArray(picture[:, :, b])
        try:
            written = gdal.GetDriverByName("PNG").CreateCopy(str(tmp), mem)
        except RuntimeError as exc:  # with gdal.UseExceptions()
            raise InputError(f"Cannot write the preview {output_png}: {exc}") from exc
        if written is None:
            raise InputError(f"Cannot write the preview {output_png}: {gdal.GetLastErrorMsg()}")
        written = mem = None


# --- command line -------------------------------------------------------------------------------

def main(argv: list[str] | None = None) -> int:
    """``python -m wit_plugin.preview LOD1.gpkg TIN.gpkg TEXTURES_DIR OUT.png`` ("-" for no TIN / textures)."""
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.preview", description=__doc__.split("\n")[0])
    parser.add_argument("lod1", help="LoD1 faces GeoPackage (wit:extrudebuildings)")
    parser.add_argument("tin", help="TIN GeoPackage (wit:triangulateterrain), or - for none")
    parser.add_argument("textures", help="texture folder (wit:wittexture), or - for none")
    parser.add_argument("output", help="PNG to write")
    parser.add_argument("--width", type=int, default=1600)
    parser.add_argument("--height", type=int, default=1000)
    parser.add_argument("--azimuth", type=float, default=135.0, help="compass bearing from the model to the camera")
    parser.add_argument("--elevation", type=float, default=40.0, help="camera elevation above the horizon, degrees")
    parser.add_argument("--exaggeration", type=float, default=1.0, help="vertical exaggeration")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        render_preview(args.lod1, None if args.tin == "-" else args.tin,
                       None if args.textures == "-" else args.textures, args.output, args.width, args.height,
                       args.azimuth, args.elevation, args.exaggeration, LoggingFeedback())
    except WitError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
