"""Texture roofs, terrain and roads from the merged orthoimage (``wit:wittexture``, SPEC §5 items 1, 3, 4).

Inputs follow ``model``: the LoD1 faces layer (``lod1_faces``), the TIN layer (``tin``) and the
merged orthoimage (north-up RGB GeoTIFF; in another CRS than the layers', the window over them
is reprojected as it is read, bilinear, ``_Ortho.reproject_to``). Outputs, in ``output_dir`` (the texture
folder): JPEG or PNG images and ``texcoords.gpkg`` holding the attribute table ``texcoords``
(one row per textured ring, ``model.TEX_*`` columns, image names relative to the folder).

What is textured, and how:

* **Roofs** (LoD1 faces ``roof``): each roof face is an *island* cut from the ortho over its 2D
  bounding box, packed into **roof atlases** (``roof_atlas_NNNN``) by shelf packing. Islands are
  padded by ``gutter`` texels of dilated edge pixels and placed on a grid of
  A = 2^⌊log2 gutter⌋ texels with slot sizes rounded up to A (the extra texels are dilated too),
  so mip levels 0…log2 A average texels of one island only: no neighbour bleeds in. An atlas is
  written when the next island does not fit; its sides are cropped to the next power of two of
  the used area (≤ ``atlas_size``).
* **Terrain and roads** (TIN triangles ``terrain`` and ``road``): a ``road`` triangle with a
  ``feature_id`` gets target ``road`` (the CityGML writer puts it in its road's traffic area),
  every other one target ``tin`` (it stays in the relief, as the writer places it). Triangles
  are grouped by **ground tile**, a square grid anchored on the ortho's origin whose side is 7/8
  of ``atlas_size`` texels. A triangle belongs to the tile holding its first vertex;
  each non-empty tile becomes one image (``ground_rRRRR_cCCCC``) covering the bounding box of its
  triangles plus ``gutter`` texels of real ortho context. Per-triangle islands would cost an
  island (and a gutter) per 5 m triangle; a ground tile needs no packing and keeps neighbouring
  triangles continuous.
* A surface (or ground tile) whose texture exceeds ``atlas_size`` (minus the gutters) is
  downscaled to fit, keeping its extent; the report counts such images (``downscaled``).
* **Not textured**: LoD1 ``wall`` faces (an orthoimage shows no facades: the CityGML writer gives
  walls no texture or a plain material), ``ground`` faces (never visible) and TIN ``footprint``
  triangles (under the buildings). The report counts them (``untextured``); the table has no rows
  for them.

UV mapping (SPEC §5.1): for an image covering the ground extent [xmin, xmax] × [ymin, ymax],
U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin), V measured from the bottom (CityGML /
OpenGL). The half-pixel correction is built in: xmin…ymax are the *outer edges* of the image's
edge texels (their centres ± half a texel), so with S = 1 a vertex at the centre of ortho pixel i
gets u·W = i' + ½, the centre of the texel holding that pixel. In an atlas the island's extent
maps onto its texel rectangle and U, V are taken over the atlas.

Scale S: a texel is about 1/S ortho pixels; windows are snapped to multiples of round(1/S)
pixels, so S = 1/n averages exact n × n pixel blocks (GDAL average resampling). Every texture
window is read with a windowed ``ReadAsArray``; the ortho is never loaded whole, and GDAL's block
cache is capped during the run as in wit:mergetiles. Features are read in bulk (``bulk_read``): a
first pass places each in its ground tile (4 bytes a feature kept), then runs of tiles whose
points fit in ``_POINTS_IN_MEMORY`` are read together (one run for the 1 km demo's 592,000
triangles). Memory is bounded by the cache cap, one atlas and one run of tiles, whatever the
size of the ortho. Images are encoded and table rows inserted in a worker thread.

Coverage: if a textured layer's extent is not inside the ortho's, the run stops before writing
anything (``InputError``): merge the tiles that cover the study area or clip the study area.
NoData pixels inside the ortho are textured as they are.

Mipmaps (paper Table 10): ``mip_chain`` gives the box-filtered chain to 1 × 1 for any image;
with ``write_mipmaps`` each image's levels 1… are written as ``<image>_mip<k>.<ext>``. KTX2 is
not written: the Khronos Python binding (pyktx) is source-only and needs libktx, which Debian
does not package; the only installable wheel (alktx2) is a young single-author project.
"""
from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pyproj
import shapely
from osgeo import gdal, ogr, osr
from shapely.geometry.base import BaseGeometry

from . import bulk_read
from . import step_layers as model
from .errors import InputError
from .feedback import SILENT, Feedback
from .fileio import atomic_files
from .gc_pause import collector_paused
from .gdal_env import capped_block_cache, open_raster, read_window
from .gpkg_bulk import BulkTable
from .numtext import ring_texts
from .raster_crs import (
    aligned,
    cell_size,
    crs_name,
    foreign_crs,
    transform_geometry,
    warp,
)
from .vector_io import FieldDef, open_layer, open_step_layer, split_source

FORMATS = {"JPEG": "jpg", "PNG": "png"}
TEXCOORDS_FILE = model.TEXCOORD_FILE
TEXTURED_TIN_SURFACES = ("terrain", "road")
ROOF_TARGET, TIN_TARGET, ROAD_TARGET = "roof", "tin", "road"  # TEX_TARGET values
OUTSIDE_ORTHO = "outside_ortho"  # TextureReport.untextured key: surfaces beyond the ortho's coverage

_POINTS_IN_MEMORY = 4_000_000  # ring points read at a time (~100 MB with their rings' data): a run of tiles
_BACKGROUND = 128  # grey for unused atlas space: neutral under JPEG ringing
_TILE_FILL = 0.875  # share of the image side given to a ground tile; the rest takes triangle overhang
_UV_PAIR = "%.12f %.12f"  # 12 decimals of u and v: 1e-12 of an image side, far below a texel of any atlas


@dataclass(frozen=True)
class TextureConfig:
    """Texture resolution, image format and atlas layout."""

    scale: float = 1.0
    """S, 0 < S ≤ 1: texture resolution relative to the ortho's."""
    image_format: str = "JPEG"
    """Either "JPEG" or "PNG"."""
    jpeg_quality: int = 90
    atlas_size: int = 2048
    """Maximum side of any image, a power of two."""
    gutter: int = 4
    """Texels of padding around each roof island (and of context around ground tiles)."""
    write_mipmaps: bool = False
    """Write each image's mip chain to 1 × 1 as files (otherwise it is derivable by the viewer)."""


@dataclass
class TextureReport:
    """What ``texture_model`` wrote."""

    output_dir: str
    texcoords: str
    """Path of ``texcoords.gpkg``."""
    images: list[str] = field(default_factory=list)
    """Images (level 0), relative to ``output_dir``."""
    surfaces: dict[str, int] = field(default_factory=lambda: {ROOF_TARGET: 0, TIN_TARGET: 0, ROAD_TARGET: 0})
    """Textured rings per TEX_TARGET."""
    untextured: dict[str, int] = field(default_factory=dict)
    """Surfaces deliberately left untextured: LoD1 'wall' / 'ground' faces, TIN 'footprint' triangles."""
    atlases: int = 0
    ground_images: int = 0
    mip_files: int = 0
    downscaled: int = 0
    """Images or islands shrunk below S to fit ``atlas_size``."""
    texel_size: float = 0.0
    """Nominal ground size of a texel (CRS units, m) = ortho pixel size / S."""
    texels_per_m2: float = 0.0
    bytes_written: int = 0


def mip_chain(image: np.ndarray) -> list[np.ndarray]:
    """The mip levels of ``image`` (rows × columns [× bands]) from itself down to 1 × 1.

    Each level halves the previous one's sides (floored, at least 1: the OpenGL rule for
    non-power-of-two sizes) by area-weighted box filtering, so an odd side still weighs every
    source texel by its covered area. Levels are computed from the unrounded previous level (in
    float32, float64 for float64 images) and returned in the input's dtype.
    """
    if image.ndim < 2 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"mip_chain needs an image of at least 1 × 1, got shape {image.shape}")
    work = np.result_type(image.dtype, np.float32)
    levels = [image]
    current = image
    while current.shape[0] > 1 or current.shape[1] > 1:
        current = _halve(_halve(current, 0, work), 1, work)
        levels.append(_as_dtype(current, image.dtype))
    return levels


def _halve(a: np.ndarray, axis: int, work: np.dtype) -> np.ndarray:
    """Box-filter ``a`` to half its size (floored, ≥ 1) along ``axis``, in the ``work`` dtype."""
    n = a.shape[axis]
    m = max(1, n // 2)
    if n == 2 * m:
        shape = a.shape[:axis] + (m, 2) + a.shape[axis + 1:]
        return a.reshape(shape).mean(axis=axis + 1, dtype=work)
    if n == 1:
        return a.astype(work, copy=False)
    # odd n: out[j] = mean of a over [j·n/m, (j+1)·n/m), a span of 2 + 1/m ≤ 3 texels, so it
    # overlaps at most 4 of them: a weighted sum of 4 shifted takes (no full-size temporaries)
    span = n / m
    edges = np.arange(m + 1) * span
    first = np.floor(edges[:-1]).astype(int)
    shape = (-1,) + (1,) * (a.ndim - axis - 1)
    out = np.zeros(a.shape[:axis] + (m,) + a.shape[axis + 1:], dtype=work)
    for t in range(4):
        index = first + t
        overlap = np.minimum(edges[1:], index + 1) - np.maximum(edges[:-1], index)
        weight = (np.clip(overlap, 0.0, None) / span).astype(work).reshape(shape)
        out += weight * np.take(a, np.minimum(index, n - 1), axis=axis)
    return out


def _as_dtype(a: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return np.clip(np.rint(a), info.min, info.max).astype(dtype)
    return a.astype(dtype, copy=False)


def texture_model(
    ortho: str,
    lod1_gpkg: str | None,
    tin_gpkg: str | None,
    output_dir: str,
    config: TextureConfig = TextureConfig(),
    feedback: Feedback = SILENT,
    coverage: BaseGeometry | None = None,
) -> TextureReport:
    """Cut roof, terrain and road textures from ``ortho`` into ``output_dir``; see the module docstring.

    Either layer file may be None (then its surfaces are not textured), not both. With ``coverage``
    (where the ortho has pixels, e.g. the union of its sheets), surfaces not inside it are left
    untextured and counted (``untextured["outside_ortho"]``) instead of refusing the layers. Raises
    ``InputError`` for unusable inputs or parameters and ``CanceledError`` on cancel; in both
    cases nothing is written to ``output_dir``.
    """
    _check_config(config)
    if not lod1_gpkg and not tin_gpkg:
        raise InputError("Give the LoD1 faces layer, the TIN layer or both: there is nothing to texture.")
    with contextlib.ExitStack() as stack:  # datasets closed on any exit, not when a traceback dies
        stack.enter_context(collector_paused())
        image = _Ortho(ortho, config)
        stack.callback(image.close)
        roofs = tin = None
        untextured: dict[str, int] = {}
        if lod1_gpkg:
            roofs = _Layer(lod1_gpkg, model.LOD1_LAYER, model.FACE_TYPE,
                           (model.WIT_ID, model.FACE_TYPE, model.FACE_NUMBER), (ROOF_TARGET,),
                           model.LOD1_ROLE)
            stack.callback(roofs.close)
            untextured.update({k: roofs.count((k,)) for k in ("wall", "ground")})
        if tin_gpkg:
            tin = _Layer(tin_gpkg, model.TIN_LAYER, model.TIN_SURFACE,
                         (model.TIN_TRIANGLE_ID, model.TIN_SURFACE, model.TIN_FEATURE_ID), TEXTURED_TIN_SURFACES,
                         model.TIN_ROLE)
            stack.callback(tin.close)
            untextured["footprint"] = tin.count(("footprint",))
        layers = [layer for layer in (roofs, tin) if layer is not None]
        image.reproject_to(layers, feedback)
        for layer in layers:
            image.check_covers(layer, extent=coverage is None)
        inside = _Inside(coverage, untextured)
        if not any(layer.surfaces for layer in layers):
            raise InputError("Nothing to texture: the LoD1 layer has no 'roof' faces and the TIN no 'terrain' or "
                             "'road' triangles.")
        report = TextureReport(output_dir=str(output_dir), texcoords=str(Path(output_dir) / TEXCOORDS_FILE),
                               untextured=untextured, texel_size=image.texel_size,
                               texels_per_m2=1.0 / image.texel_size ** 2)
        feedback.info(f"Texel {image.texel_size:g} m (S = {config.scale:g}); {roofs.surfaces if roofs else 0} roof "
                      f"face(s), {tin.surfaces if tin else 0} terrain/road triangle(s); walls are not textured.")
        grid = _Grid(image, config)
        share = 100.0 * (roofs.surfaces if roofs else 0) / sum(layer.surfaces for layer in layers)
        with capped_block_cache(), atomic_files([report.texcoords]) as tmp:
            out = _Output(tmp, FORMATS[config.image_format.upper()], config, report)
            try:
                if roofs is not None:
                    _texture_roofs(roofs, image, grid, out, config, inside, feedback.scaled(0.0, share))
                if tin is not None:
                    _texture_ground(tin, image, grid, out, config, inside, feedback.scaled(share, 100.0))
                out.finish()
            finally:
                out.close()
            report.bytes_written = sum(p.stat().st_size for p in tmp.iterdir())
    if untextured.get(OUTSIDE_ORTHO):
        feedback.warning(f"{untextured[OUTSIDE_ORTHO]} surface(s) lie outside the orthoimage and are left untextured.")
    feedback.info(f"Wrote {len(report.images)} image(s) ({report.atlases} roof atlas(es), {report.ground_images} "
                  f"ground tile(s)), {report.mip_files} mip file(s), {report.bytes_written / 1e6:.1f} MB.")
    feedback.progress(100.0)
    return report


def _check_config(config: TextureConfig) -> None:
    if not 0.0 < config.scale <= 1.0:
        raise InputError(f"Texture scale S = {config.scale:g} is out of range: use 0 < S ≤ 1 (1 = ortho resolution).")
    if config.image_format.upper() not in FORMATS:
        raise InputError(f"Image format {config.image_format!r} is not supported: use one of {', '.join(FORMATS)}.")
    if not 1 <= config.jpeg_quality <= 100:
        raise InputError(f"JPEG quality {config.jpeg_quality} is out of range: use 1–100.")
    size = config.atlas_size
    if size < 64 or size > 16384 or size & (size - 1):
        raise InputError(f"Atlas size {size} must be a power of two between 64 and 16384.")
    if not 0 <= config.gutter <= size // 8:
        raise InputError(f"Gutter {config.gutter} px is out of range: use 0–{size // 8} px for atlases of {size} px.")


# --- inputs -------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Rings:
    """Rings to texture, as arrays: per ring its TEX_TARGET, TEX_FEATURE (as any value ``str`` turns
    into it) and TEX_FACE; the 2D points of all rings one after another (closing points included)
    and where each ring starts (one more entry: the end)."""

    targets: np.ndarray
    features: np.ndarray
    faces: np.ndarray
    xy: np.ndarray
    starts: np.ndarray

    def __len__(self) -> int:
        return len(self.targets)

    def bbox(self, i: int) -> tuple[float, float, float, float]:
        xy = self.xy[self.starts[i]:self.starts[i + 1]]
        return (*xy.min(axis=0), *xy.max(axis=0))

    def bboxes(self) -> np.ndarray:
        """(xmin, ymin, xmax, ymax) of every ring, as rows."""
        first = self.starts[:-1]
        return np.hstack([np.minimum.reduceat(self.xy, first), np.maximum.reduceat(self.xy, first)])

    def take(self, index: np.ndarray) -> _Rings:
        """The rings at ``index``, in that order."""
        counts = self.starts[1:][index] - self.starts[:-1][index]
        starts = np.concatenate([[0], np.cumsum(counts)])
        points = np.repeat(self.starts[:-1][index] - starts[:-1], counts) + np.arange(starts[-1])
        return _Rings(self.targets[index], self.features[index], self.faces[index], self.xy[points], starts)

    @staticmethod
    def concat(parts: list[_Rings]) -> _Rings:
        if not parts:
            return _Rings(*(np.empty(0, dtype=object),) * 3, np.empty((0, 2)), np.zeros(1, dtype=np.int64))
        counts = np.concatenate([np.diff(part.starts) for part in parts])
        return _Rings(*(np.concatenate([getattr(part, name) for part in parts])
                        for name in ("targets", "features", "faces", "xy")), np.concatenate([[0], np.cumsum(counts)]))


class _Layer:
    """A textured layer: the faces of the given kinds, read in bulk tile by tile (``tiles``)."""

    def __init__(self, path: str, name: str, kind_field: str, fields: tuple[str, ...], kinds: tuple[str, ...],
                 role: str):
        self._ds, self.layer, self._fields = open_step_layer(path, name, role, fields)
        self.path, self.name, self.kind_field, self.kinds = split_source(path)[0], self.layer.GetName(), kind_field, kinds
        xmin, xmax, ymin, ymax = self.layer.GetExtent()
        self.extent = (xmin, ymin, xmax, ymax)
        srs = self.layer.GetSpatialRef()
        self.srs = srs.Clone() if srs is not None else None  # the layer owns its SRS; keep our own
        self.surfaces = self.count(kinds)

    def close(self) -> None:
        self.layer = self._ds = None

    def _where(self, kinds: tuple[str, ...]) -> str:
        return f"\"{self.kind_field}\" IN ({', '.join(repr(k) for k in kinds)})"

    def count(self, kinds: tuple[str, ...]) -> int:
        """Number of features whose kind field is one of ``kinds``."""
        self.layer.SetAttributeFilter(self._where(kinds))
        return self.layer.GetFeatureCount()

    def tiles(self, grid: _Grid, columns: tuple[str, ...],
              describe: Callable[[list[np.ndarray]], tuple[np.ndarray, ...]]) -> Iterator[tuple[tuple[int, int], _Rings]]:
        """Each ground tile over the layer's extent (row by row from the north-west) with the rings whose
        first point lies in it, in the layer's order: every ring comes exactly once.

        Read in bulk (``bulk_read``): once to place every ring in its tile (an int per feature
        kept), then once per run of tiles whose points fit in memory together (one run for the 1
        km demo); OGR spatial filters would read the whole layer per tile when it has no
        spatial index (the chain's intermediate files have none). ``describe`` turns a batch's
        ``columns`` into the rings' targets, features and faces.
        """
        keys = grid.keys(self.extent)
        (r0, c0), (_, c1) = keys[0], keys[-1]

        def tile_of(xy: np.ndarray, counts: np.ndarray) -> np.ndarray:
            row, col = grid.key_arrays(*xy[np.cumsum(counts) - counts].T)
            return (row - r0) * (c1 - c0 + 1) + (col - c0)

        placed = [(tile_of(xy, counts), counts) for xy, counts, _ in self._read(columns[:1])]
        tile = np.concatenate([t for t, _ in placed] or [np.empty(0, dtype=np.int64)]).astype(np.int32)
        points = np.bincount(tile, weights=np.concatenate([c for _, c in placed] or [np.empty(0)]), minlength=len(keys))
        del placed
        first = 0
        while first < len(keys):
            last = first + max(1, int(np.searchsorted(np.cumsum(points[first:]), _POINTS_IN_MEMORY, side="right")))
            wanted = (tile >= first) & (tile < last)
            parts = []
            for xy, counts, batch in self._read(columns, wanted):
                starts = np.concatenate([[0], np.cumsum(counts)])
                parts.append(_Rings(*describe([batch[c] for c in columns]), xy, starts))
            rings = _Rings.concat(parts)
            del parts
            mine = tile[wanted]
            order = np.argsort(mine, kind="stable")
            bounds = np.searchsorted(mine[order], np.arange(first, last + 1))
            for n in range(first, last):
                yield keys[n], rings.take(order[bounds[n - first]:bounds[n - first + 1]])
            first = last

    def _read(self, columns: tuple[str, ...], wanted: np.ndarray | None = None
              ) -> Iterator[tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]]:
        """(2D points, points per ring, the batch's columns) of the layer's surfaces, batch by batch,
        only the ``wanted`` ones (a mask over all of them, in order) if given.

        Each pass reads through a handle of its own: GDAL allows one Arrow stream per layer at a time, and
        the previous pass's may outlive it (a profiler, e.g. Dask's, keeps the frames it samples for a moment).
        """
        ds, layer, _ = open_layer(self.path, self.name)
        layer.SetAttributeFilter(self._where(self.kinds))
        bulk_read.ignore_fields(layer, [f for f in self._fields if f not in columns])
        start = 0
        try:
            for batch in bulk_read.batches(layer, fid=True):
                size = len(batch["geometry"])
                if wanted is not None:
                    keep = wanted[start:start + size]
                    batch = {name: column[keep] for name, column in batch.items()}
                start += size
                points, counts, rings = bulk_read.exterior_rings(batch["geometry"])
                if not rings.all():
                    bad = int(np.argmin(rings))
                    raise InputError(f"Feature {batch['fid'][bad]} of layer {self.name!r} in {self.path} is "
                                     f"{bulk_read.geometry_name(batch['geometry'][bad])}, not a polygon face: use "
                                     "the unmodified output of the previous step.")
                yield np.ascontiguousarray(points[:, :2]), counts, batch
        finally:
            del layer, ds


@dataclass(frozen=True)
class _Patch:
    """Texels cut from the ortho and the ground extent (outer texel edges) they cover."""

    pixels: np.ndarray  # rows × columns × 3, uint8
    extent: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
    downscaled: bool


class _Ortho:
    """The merged orthoimage, read window by window."""

    def __init__(self, path: str, config: TextureConfig):
        self.path, self.scale = path, config.scale
        self.ds = open_raster(path, "orthoimage")
        self.footprint: BaseGeometry | None = None  # where a reprojected ortho has pixels
        self.source: gdal.Dataset | None = None  # the file behind a reprojected ortho's warped VRT
        ds = self.ds
        if ds.RasterCount < 3 or any(ds.GetRasterBand(b).DataType != gdal.GDT_Byte for b in (1, 2, 3)):
            raise InputError(f"The orthoimage {path} must be RGB with 8-bit bands (it has {ds.RasterCount} band(s)): "
                             "use the output of wit:mergetiles.")
        gt = ds.GetGeoTransform(can_return_null=True)
        if gt is None or gt[2] or gt[4] or gt[5] >= 0:
            raise InputError(f"The orthoimage {path} is not georeferenced north-up: georeference it "
                             "(wit:georeferencemapsheets) and merge it (wit:mergetiles) first.")
        self._grid(ds)
        wkt = ds.GetProjection()
        self.srs = osr.SpatialReference(wkt) if wkt else None

    def _grid(self, ds: gdal.Dataset) -> None:
        gt = ds.GetGeoTransform()
        self.x0, self.px, self.y0, self.py = gt[0], gt[1], gt[3], -gt[5]
        self.width, self.height = ds.RasterXSize, ds.RasterYSize
        self.extent = (self.x0, self.y0 - self.height * self.py, self.x0 + self.width * self.px, self.y0)
        self.step = max(1, round(1.0 / self.scale))
        self.texel_size = max(self.px, self.py) / self.scale

    def reproject_to(self, layers: list[_Layer], feedback: Feedback) -> None:
        """An ortho in another CRS than the layers': read from then on through a warped VRT (in memory,
        bilinear, its pixel size in metres) over the layers' extent, so only the pixels needed are warped."""
        wkt = next((layer.srs.ExportToWkt() for layer in layers if layer.srs is not None), None)
        source = foreign_crs(self.ds, wkt) if wkt else None
        if source is None:
            return
        target = pyproj.CRS.from_wkt(wkt)
        size = cell_size(self.ds, source, target)
        self.footprint = transform_geometry(shapely.box(*self.extent), source, target)
        boxes = [layer.extent for layer in layers]
        needed = (min(b[0] for b in boxes), min(b[1] for b in boxes), max(b[2] for b in boxes), max(b[3] for b in boxes))
        self.source, self.ds = self.ds, warp(self.ds, source, target, aligned(needed, size, 8), size, fmt="VRT",
                                             exact=False)
        self._grid(self.ds)
        self.srs = osr.SpatialReference(wkt)
        feedback.info(f"The orthoimage {Path(self.path).name} is in {crs_name(source)}: its pixels over the layers are "
                      f"reprojected as they are read to {crs_name(target)} (bilinear, {size:g} m pixels).")

    def close(self) -> None:
        self.ds = self.source = None

    def check_covers(self, layer: _Layer, extent: bool = True) -> None:
        """Refuse a layer whose CRS differs or (``extent``) whose extent reaches beyond the ortho."""
        if self.srs is not None and layer.srs is not None and not self.srs.IsSame(
                layer.srs, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES"]):
            raise InputError(f"Layer {layer.name!r} ({layer.srs.GetName()}) and the orthoimage "
                             f"({self.srs.GetName()}) have different CRSs: produce both in the same CRS.")
        if not extent:
            return
        lx0, ly0, lx1, ly1 = layer.extent
        ox0, oy0, ox1, oy1 = self.footprint.bounds if self.footprint is not None else self.extent
        if lx0 < ox0 or ly0 < oy0 or lx1 > ox1 or ly1 > oy1 or (
                self.footprint is not None and not self.footprint.contains(shapely.box(*layer.extent))):
            raise InputError(
                f"Layer {layer.name!r} in {layer.path} reaches beyond the orthoimage, whose pixels are needed for "
                f"every textured surface: layer x {lx0:.2f}–{lx1:.2f}, y {ly0:.2f}–{ly1:.2f}; ortho x "
                f"{ox0:.2f}–{ox1:.2f}, y {oy0:.2f}–{oy1:.2f}. Merge the ortho tiles that cover the whole study "
                "area (wit:mergetiles) or make the study area smaller.")

    def patch(self, bbox: tuple[float, float, float, float], limit: int, margin: int = 0) -> _Patch:
        """The texels over ``bbox`` (+ ``margin`` texels, within the ortho), at most ``limit`` a side."""
        xmin, ymin, xmax, ymax = bbox
        pad = margin * self.texel_size
        step = self.step
        c0 = math.floor((xmin - pad - self.x0) / self.px) // step * step
        c1 = -(-(math.floor((xmax + pad - self.x0) / self.px) + 1) // step) * step
        r0 = math.floor((self.y0 - ymax - pad) / self.py) // step * step
        r1 = -(-(math.floor((self.y0 - ymin + pad) / self.py) + 1) // step) * step
        c0, r0 = max(c0, 0), max(r0, 0)
        c1, r1 = min(c1, self.width), min(r1, self.height)
        w, h = c1 - c0, r1 - r0
        tw, th = max(1, round(w * self.scale)), max(1, round(h * self.scale))
        shrink = min(1.0, limit / tw, limit / th)
        if shrink < 1.0:
            tw, th = max(1, math.floor(tw * shrink)), max(1, math.floor(th * shrink))
        resample = gdal.GRIORA_Average if (tw, th) != (w, h) else gdal.GRIORA_NearestNeighbour
        data = read_window(self.ds, c0, r0, w, h, f"the orthoimage {self.path}", buf_xsize=tw, buf_ysize=th,
                           band_list=[1, 2, 3], interleave="pixel", resample_alg=resample)
        extent = (self.x0 + c0 * self.px, self.y0 - r1 * self.py, self.x0 + c1 * self.px, self.y0 - r0 * self.py)
        return _Patch(data, extent, shrink < 1.0)


class _Grid:
    """Square ground tiles anchored on the ortho's top-left corner, rows going south."""

    def __init__(self, ortho: _Ortho, config: TextureConfig):
        self.x0, self.y0 = ortho.x0, ortho.y0
        self.side = math.floor(config.atlas_size * _TILE_FILL) * ortho.texel_size
        self._eps = 1e-6 * self.side

    def key(self, x: float, y: float) -> tuple[int, int]:
        return math.floor((self.y0 - y) / self.side), math.floor((x - self.x0) / self.side)

    def key_arrays(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``key`` for arrays of points: (rows, columns)."""
        return (np.floor((self.y0 - y) / self.side).astype(np.int64),
                np.floor((x - self.x0) / self.side).astype(np.int64))

    def rect(self, key: tuple[int, int]) -> tuple[float, float, float, float]:
        """The tile's xmin, ymin, xmax, ymax, widened by a hair so rounding cannot drop a boundary vertex."""
        r, c = key
        e = self._eps
        return (self.x0 + c * self.side - e, self.y0 - (r + 1) * self.side - e,
                self.x0 + (c + 1) * self.side + e, self.y0 - r * self.side + e)

    def keys(self, extent: tuple[float, float, float, float]) -> list[tuple[int, int]]:
        """The tiles over ``extent``, row by row from the north-west."""
        (r0, c0), (r1, c1) = self.key(extent[0], extent[3]), self.key(extent[2], extent[1])
        return [(r, c) for r in range(r0, r1 + 1) for c in range(c0, c1 + 1)]


# --- output -------------------------------------------------------------------------------------

def _uv(xy: np.ndarray, placements: np.ndarray, image_w: int, image_h: int) -> np.ndarray:
    """(u, v) per point: SPEC §5.1 over its placement's extent, in the image's texture space (v up).

    ``placements`` has one row per point: x, y, width, height, xmin, ymin, xmax, ymax.
    """
    x, y, width, height, xmin, ymin, xmax, ymax = placements.T
    u = (x + (xy[:, 0] - xmin) / (xmax - xmin) * width) / image_w
    v = 1.0 - (y + (ymax - xy[:, 1]) / (ymax - ymin) * height) / image_h
    return np.column_stack([u, v])


class _Output:
    """Images (and their mips) plus the texture-coordinate table, in the staging folder.

    OGR creates the GeoPackage and its attribute table; the rows (one per surface, ~600,000 for
    the 1 km demo) then go in through SQLite, a batch per image, as OGR's feature-at-a-time
    writing took most of this step's time. Images are encoded and rows inserted by one worker
    thread, an image behind the main thread (GDAL's encoders and SQLite release the GIL), while
    the main thread reads the ortho and formats the next image's rows: the two cores overlap.
    """

    _FIELDS = [FieldDef(model.TEX_TARGET, ogr.OFTString), FieldDef(model.TEX_FEATURE, ogr.OFTString),
               FieldDef(model.TEX_FACE, ogr.OFTInteger), FieldDef(model.TEX_IMAGE, ogr.OFTString),
               FieldDef(model.TEX_COORDS, ogr.OFTString)]

    def __init__(self, folder: Path, ext: str, config: TextureConfig, report: TextureReport):
        self.folder, self.ext, self.config, self.report = folder, ext, config, report
        self._driver = gdal.GetDriverByName("JPEG" if ext == "jpg" else "PNG")
        self._options = [f"QUALITY={config.jpeg_quality}"] if ext == "jpg" else ["ZLEVEL=6"]
        self._table = BulkTable(folder / TEXCOORDS_FILE, model.TEXCOORD_TABLE, self._FIELDS, threaded=True)
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="wit-texture-output")
        self._pending: Future | None = None

    def write(self, stem: str, pixels: np.ndarray, rings: _Rings, placements: np.ndarray) -> None:
        """Write one image and the rows of the rings placed in it (``placements``: one row per ring,
        or one for all, of x, y, width, height, xmin, ymin, xmax, ymax; see ``_uv``).

        ``pixels`` must not change afterwards: the worker encodes it later.
        """
        name = f"{stem}.{self.ext}"
        self.report.images.append(name)
        counts = np.diff(rings.starts)
        per_point = placements if len(placements) == 1 else np.repeat(placements, counts, axis=0)
        uv = ring_texts(_uv(rings.xy, per_point, pixels.shape[1], pixels.shape[0]), counts, _UV_PAIR)
        targets = rings.targets.tolist()
        rows = list(zip(targets, map(str, rings.features.tolist()), rings.faces.tolist(), [name] * len(uv), uv))
        for target in set(targets):
            self.report.surfaces[target] += targets.count(target)
        self._wait()  # at most one image in the worker's hands: memory stays at two images' rows
        self._pending = self._worker.submit(self._store, stem, pixels, rows)

    def _store(self, stem: str, pixels: np.ndarray, rows: list[tuple]) -> None:
        """In the worker: the image, its mips and its rows."""
        self._save(f"{stem}.{self.ext}", pixels)
        if self.config.write_mipmaps:
            for k, level in enumerate(mip_chain(pixels)[1:], start=1):
                self._save(f"{stem}_mip{k}.{self.ext}", level)
                self.report.mip_files += 1
        self._table.insert(rows)

    def _wait(self) -> None:
        """Let the worker finish its image; its error, if any, is raised here."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def _save(self, name: str, pixels: np.ndarray) -> None:
        h, w, bands = pixels.shape
        mem = gdal.GetDriverByName("MEM").Create("", w, h, bands, gdal.GDT_Byte)
        mem.WriteArray(pixels, interleave="pixel")
        if self._driver.CreateCopy(str(self.folder / name), mem, options=self._options) is None:
            raise InputError(f"Cannot write the texture image {self.folder / name}: {gdal.GetLastErrorMsg()}")

    def finish(self) -> None:
        """Index the table in the order the CityGML writer reads it (image, target, feature, face)."""
        self._wait()
        columns = ", ".join(f'"{c}"' for c in (model.TEX_IMAGE, model.TEX_TARGET, model.TEX_FEATURE, model.TEX_FACE))
        self._table.db.execute(f'CREATE INDEX "{model.TEXCOORD_TABLE}_order" ON "{model.TEXCOORD_TABLE}" ({columns})')

    def close(self) -> None:
        """Stop the worker (after its current image) and close the table; on success after ``finish``."""
        self._worker.shutdown(wait=True)
        self._table.close()


# --- roofs: islands in atlases ------------------------------------------------------------------

class _AtlasPacker:
    """Shelf packing of padded roof islands into atlases, each written when the next island does not fit."""

    def __init__(self, config: TextureConfig, out: _Output):
        self.size, self.gutter, self.out = config.atlas_size, config.gutter, out
        self.align = 1 << (config.gutter.bit_length() - 1) if config.gutter else 1  # largest 2^k ≤ gutter
        self.count = 0
        self._reset()

    def _reset(self) -> None:
        self.pixels = np.full((self.size, self.size, 3), _BACKGROUND, dtype=np.uint8)
        self.items: list[_Rings] = []  # one ring each
        self.placements: list[tuple[float, ...]] = []  # as _Output.write takes them
        self.x = self.y = self.shelf = self.used_w = 0

    def add(self, ring: _Rings, patch: _Patch) -> None:
        h, w = patch.pixels.shape[:2]
        g, a = self.gutter, self.align
        sw, sh = -(-(w + 2 * g) // a) * a, -(-(h + 2 * g) // a) * a
        if self.x + sw > self.size:  # next shelf
            self.x, self.y, self.shelf = 0, self.y + self.shelf, 0
        if self.y + sh > self.size:
            self.flush()
        self.pixels[self.y:self.y + sh, self.x:self.x + sw] = np.pad(
            patch.pixels, ((g, sh - h - g), (g, sw - w - g), (0, 0)), mode="edge")
        self.items.append(ring)
        self.placements.append((self.x + g, self.y + g, w, h, *patch.extent))
        self.x += sw
        self.shelf = max(self.shelf, sh)
        self.used_w = max(self.used_w, self.x)

    def flush(self) -> None:
        """Write the current atlas, cropped to powers of two around the used area, and start a new one."""
        if self.items:
            w, h = _pow2_ceil(self.used_w), _pow2_ceil(self.y + self.shelf)
            self.out.write(f"roof_atlas_{self.count:04d}", self.pixels[:h, :w], _Rings.concat(self.items),
                           np.array(self.placements, dtype=np.float64))
            self.out.report.atlases += 1
            self.count += 1
        self._reset()


class _Inside:
    """Keeps the surfaces inside the ortho's coverage (all when there is none) and counts the others."""

    def __init__(self, coverage: BaseGeometry | None, untextured: dict[str, int]):
        self.coverage, self.untextured = coverage, untextured
        if coverage is not None:
            shapely.prepare(coverage)

    def __call__(self, rings: _Rings) -> _Rings:
        if self.coverage is None or not len(rings):
            return rings
        keep = shapely.covers(self.coverage, shapely.box(*rings.bboxes().T))
        self.untextured[OUTSIDE_ORTHO] = self.untextured.get(OUTSIDE_ORTHO, 0) + int((~keep).sum())
        return rings.take(np.flatnonzero(keep))


def _pow2_ceil(n: int) -> int:
    return 1 << max(0, n - 1).bit_length()


def _texture_roofs(layer: _Layer, ortho: _Ortho, grid: _Grid, out: _Output, config: TextureConfig,
                   inside: _Inside, feedback: Feedback) -> None:
    """Roof islands tile by tile (spatial order), tallest first within a tile for tighter shelves."""
    def roof(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        wit_id, face_no = columns
        faces = np.ma.filled(face_no, 0).astype(object)  # as OGR's GetFieldAsInteger: NULL is 0
        return np.full(len(faces), ROOF_TARGET, dtype=object), np.array(bulk_read.texts(wit_id), dtype=object), faces

    packer = _AtlasPacker(config, out)
    limit = config.atlas_size - 2 * config.gutter
    count = len(grid.keys(layer.extent))
    for n, (_, rings) in enumerate(layer.tiles(grid, (model.WIT_ID, model.FACE_NUMBER), roof)):
        feedback.check_canceled()
        rings = inside(rings)
        patches = [ortho.patch(rings.bbox(i), limit) for i in range(len(rings))]
        for i, patch in sorted(enumerate(patches), key=lambda ip: -ip[1].pixels.shape[0]):
            packer.add(rings.take(np.array([i])), patch)
            out.report.downscaled += patch.downscaled
        feedback.progress(100.0 * (n + 1) / count)
    packer.flush()


# --- terrain and roads: one image per ground tile -----------------------------------------------

def _texture_ground(layer: _Layer, ortho: _Ortho, grid: _Grid, out: _Output, config: TextureConfig,
                    inside: _Inside, feedback: Feedback) -> None:
    """One image per non-empty ground tile, covering its triangles' bounding box plus the gutter."""
    def triangle(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tri_id, surface, feature_id = columns
        on_road = (np.ma.filled(surface, b"") == b"road") & bulk_read.valid(feature_id)
        features = tri_id if not np.ma.is_masked(tri_id) else np.array(bulk_read.texts(tri_id), dtype=object)
        return (np.array([TIN_TARGET, ROAD_TARGET], dtype=object)[on_road.astype(np.intp)], np.asarray(features),
                np.full(len(on_road), None, dtype=object))

    count = len(grid.keys(layer.extent))
    tiles = layer.tiles(grid, (model.TIN_TRIANGLE_ID, model.TIN_SURFACE, model.TIN_FEATURE_ID), triangle)
    for n, ((r, c), batch) in enumerate(tiles):
        feedback.check_canceled()
        batch = inside(batch)
        if len(batch):
            bbox = (*batch.xy.min(axis=0), *batch.xy.max(axis=0))
            patch = ortho.patch(bbox, config.atlas_size, margin=config.gutter)
            h, w = patch.pixels.shape[:2]
            placement = np.array([(0, 0, w, h, *patch.extent)], dtype=np.float64)
            out.write(f"ground_r{r:04d}_c{c:04d}", patch.pixels, batch, placement)
            out.report.ground_images += 1
            out.report.downscaled += patch.downscaled
        feedback.progress(100.0 * (n + 1) / count)
