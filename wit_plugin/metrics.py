"""The paper's quality measures (Tables 17 and 19) and the seam step (SPEC §5.5, §8): ``wit:qualitymetrics``.

**Geometry against the 2D sources (Table 17).** The model's buildings are read from the written
CityGML 3.0 file (``bldg:Building`` → ``core:lod1Solid`` polygons, streamed with lxml iterparse,
so the metric checks the deliverable itself) or from the LoD1 faces GeoPackage. In the CityGML
file a face's kind is not stored: horizontal faces (Z spread ≤ 1 mm) at the solid's lowest Z are
its ground, at its highest Z its roof. Everything is compared in 2D (X, Y) with the prepared
source footprints (``model.PREPARED_BUILDINGS``), matched by ``wit_id`` = ``gml:id``; the solids
``<wit_id>_part1``, ``_part2``… that wit:extrudebuildings makes from a multi-part footprint are
merged back into their building. Per building:

* *position (placement) error*: distance between the centroids of the source footprint and of the
  model's ground face(s); the mean over buildings is the paper's MPE;
* *vertex (coordinate) error*: for each vertex of the model's roof face(s), the distance to the
  nearest vertex of the source footprint; mean and maximum over all vertices are the paper's
  ME and MaxE ("coordinate consistency");
* *Hausdorff distance* of the two outlines (boundaries, GEOS discrete Hausdorff);
* *shape similarity index* SSI = IoU = area(A ∩ B) / area(A ∪ B) of the source footprint A and the
  model's ground face B: 1 for identical shapes, 0 for disjoint ones. (The paper gives no formula
  for its SSI of 0.92; IoU is the standard, scale-free choice.)

Buildings present in only one of the two are counted and listed (``model_only`` /
``source_only``) and left out of the statistics.

**Texture quality (Table 19).** Intensity I = 0.299 R + 0.587 G + 0.114 B (ITU-R BT.601, as a
float, not rounded to 8 bits; a single-band image is its own intensity).

* *sharpness* = variance of the Laplacian: L = I ∗ [[0, 1, 0], [1, −4, 1], [0, 1, 0]] evaluated
  at every pixel with reflect-101 borders (…c b | a b c … ; OpenCV's BORDER_DEFAULT), and
  var(L) = mean((L − mean L)²) over those pixels (population variance). This is
  ``cv2.Laplacian(gray, cv2.CV_64F).var()``; OpenCV's ``cvtColor`` rounds the intensity to 8
  bits first, which changes the figure by about 1.7 (the variance of the rounding noise under
  the kernel), nothing at the scale of the paper's 898–3008. ``border="valid"`` instead uses only
  pixels whose four neighbours are inside the image. With a mask, L counts at a pixel only if the
  pixel and its four neighbours are inside the mask (no step against the background).
* *contrast* = standard deviation of I (population, over the masked pixels).

Model textures: the images of a wit:wittexture folder (mip files left out). If the folder holds
``model.TEXCOORD_FILE``, only texels inside the textured rings (their UV polygons rasterised,
pixel centres inside) count, so atlas background and gutters do not; otherwise whole images
count. Values are pooled over all counted pixels of all images (not averaged per image). The
source orthoimage is measured the same way, read in row blocks, NoData excluded: over the model's
area (the bounding box of the source buildings) or a given box, and, given polygons (the
building footprints), over the pixels whose centres are inside them: the pixels the roof
atlases copy, so roof textures and their source compare pixel set for pixel set.

**Seam step.** For every tile edge (from the georef sheet index, layer ``footprints``, or the
tiles' own extents) the part that lies inside another tile, away from the mosaic's border, is
where a visible seam can be. There the step is the mean over bands of |P(left) − P(right)| for the
two mosaic pixels that the edge separates (rows above/below for horizontal edges), averaged over
all such pixel pairs of all edges. The *baseline* is the same mean for the pixel pairs one pixel
either side (the image's own gradient); *excess* = step − baseline is the seam's share. Compare
``overwrite`` with ``feather`` mosaics of the same tiles.

Outputs (each written atomically): a metrics table (metric, value, unit, paper figure) and one
row per building, as CSV, as a GeoPackage (``quality_metrics`` table, ``quality_buildings``
polygons) and as a small HTML page.
"""
from __future__ import annotations

import contextlib
import csv
import html
import math
import os
import re
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from lxml import etree
from osgeo import gdal, ogr, osr

from . import bulk_read
from . import step_layers as model
from .arrays import ragged_indices
from .citygml.validation.crs import frame_of
from .errors import InputError
from .feedback import SILENT, Feedback
from .fileio import atomic_file
from .gdal_env import open_raster, read_window
from .raster_crs import crs_name, foreign_crs, transform_geometry
from .vector_io import FieldDef, OutputLayer, gdal_quiet, open_step_layer, split_source, write_gpkg

METRICS_TABLE = "quality_metrics"
BUILDINGS_LAYER = "quality_buildings"
MATCHED, MODEL_ONLY, SOURCE_ONLY = "matched", "model_only", "source_only"
BORDERS = ("reflect101", "valid")
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".tif", ".tiff")

#: the paper's figures: Table 17 (geometry) and Table 19 (texture: Bing Maps, V-World, WIT)
PAPER_TABLE17 = {"coordinate_mean_error": 30.0, "coordinate_max_error": 80.0, "placement_mean_error": 80.0,
                 "ssi_mean": 0.92}
PAPER_TABLE19 = {"laplacian_variance": {"Bing Maps": 898.63, "V-World": 1471.99, "WIT": 3008.24},
                 "contrast": {"Bing Maps": 71.32, "V-World": 75.35, "WIT": 78.87}}

_CORE = "{http://www.opengis.net/citygml/3.0}"
_BLDG = "{http://www.opengis.net/citygml/building/3.0}"
_GML = "{http://www.opengis.net/gml/3.2}"
_PART = re.compile(r"^(.*)_part\d+$")
_MIP = re.compile(r"_mip\d+$")
_FLAT = 1e-3  # m: Z spread of a horizontal face
_BLOCK_PIXELS = 1 << 21  # pixels per block when streaming a raster (16 MB per float64 array)
_PAIRS = 2_000_000  # vertex pairs per distance chunk


# --- texture measures -----------------------------------------------------------------------------

def grayscale(image: np.ndarray) -> np.ndarray:
    """Intensity 0.299 R + 0.587 G + 0.114 B of a (bands, rows, cols) or (rows, cols) array, as float64."""
    a = np.asarray(image)
    if a.ndim == 2:
        return a.astype(np.float64)
    if a.ndim != 3 or a.shape[0] not in (1, 3, 4):
        raise InputError(f"An image of shape {a.shape} is neither single-band nor RGB(A).")
    if a.shape[0] == 1:
        return a[0].astype(np.float64)
    return 0.299 * a[0].astype(np.float64) + 0.587 * a[1] + 0.114 * a[2]


def _laplacian_valid(padded: np.ndarray) -> np.ndarray:
    """The 4-neighbour Laplacian at the interior pixels of ``padded`` (one pixel smaller on each side)."""
    c = padded[1:-1, 1:-1]
    return padded[:-2, 1:-1] + padded[2:, 1:-1] + padded[1:-1, :-2] + padded[1:-1, 2:] - 4.0 * c


def _eroded(mask_padded: np.ndarray) -> np.ndarray:
    """Interior pixels of ``mask_padded`` that are set together with their four neighbours."""
    m = mask_padded
    return m[1:-1, 1:-1] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]


class _Moments:
    """Count, mean and sum of squared deviations, merged block by block (Chan et al.) for exact pooling."""

    def __init__(self) -> None:
        self.n, self.mean, self.m2 = 0, 0.0, 0.0

    def add(self, values: np.ndarray) -> None:
        n = values.size
        if n == 0:
            return
        mean = float(values.mean())
        m2 = float(np.square(values - mean).sum())
        total = self.n + n
        delta = mean - self.mean
        self.mean += delta * n / total
        self.m2 += m2 + delta * delta * self.n * n / total
        self.n = total

    def merge(self, other: _Moments) -> None:
        if other.n:
            total = self.n + other.n
            delta = other.mean - self.mean
            self.mean += delta * other.n / total
            self.m2 += other.m2 + delta * delta * self.n * other.n / total
            self.n = total

    @property
    def variance(self) -> float:
        return self.m2 / self.n if self.n else math.nan


def _check_border(border: str) -> None:
    if border not in BORDERS:
        raise InputError(f"Unknown border mode {border!r}: use one of {', '.join(BORDERS)}.")


def _laplacian_moments(gray: np.ndarray, mask: np.ndarray | None, border: str) -> _Moments:
    moments = _Moments()
    g = np.asarray(gray, dtype=np.float64)
    if g.ndim != 2 or min(g.shape) < (2 if border == "reflect101" else 3):
        return moments
    m = np.ones(g.shape, bool) if mask is None else np.asarray(mask, bool)
    if border == "reflect101":
        g, m = np.pad(g, 1, mode="reflect"), np.pad(m, 1, mode="reflect")
    moments.add(_laplacian_valid(g)[_eroded(m)])
    return moments


def laplacian_variance(gray: np.ndarray, mask: np.ndarray | None = None, border: str = "reflect101") -> float:
    """Sharpness: population variance of the 4-neighbour Laplacian (see the module docstring).

    ``border="reflect101"`` equals ``cv2.Laplacian(gray, cv2.CV_64F).var()``; ``"valid"`` drops the
    outermost pixels. NaN if no pixel counts (image smaller than the kernel, empty mask).
    """
    _check_border(border)
    return _laplacian_moments(gray, mask, border).variance


def contrast(gray: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Contrast: population standard deviation of the intensity (over ``mask`` if given); NaN if empty."""
    g = np.asarray(gray, dtype=np.float64)
    values = g if mask is None else g[np.asarray(mask, bool)]
    return float(values.std()) if values.size else math.nan


@dataclass
class ImageQuality:
    """Sharpness and contrast of one image (or of the orthoimage window)."""

    image: str
    pixels: int  # pixels counted for the contrast (inside the mask)
    laplacian_variance: float
    contrast: float


@dataclass
class TextureMetrics:
    """Pooled texture measures of the model's images and, if given, of the source orthoimage."""

    images: list[ImageQuality] = field(default_factory=list)
    laplacian_variance: float = math.nan
    contrast: float = math.nan
    pixels: int = 0
    masked: bool = False  # True if texcoords limited the pixels to textured rings
    ortho: ImageQuality | None = None
    ortho_area: tuple[float, float, float, float] | None = None
    ortho_inside: ImageQuality | None = None  # the ortho inside ``ortho_mask`` (e.g. the building footprints)


class _Stats:
    """Moments of the Laplacian and of the intensity, pooled over images or blocks."""

    def __init__(self) -> None:
        self.lap, self.gray = _Moments(), _Moments()

    def merge(self, other: _Stats) -> None:
        self.lap.merge(other.lap)
        self.gray.merge(other.gray)

    def result(self, name: str) -> ImageQuality:
        return ImageQuality(name, self.gray.n, self.lap.variance, math.sqrt(self.gray.variance))


def _image_stats(gray: np.ndarray, mask: np.ndarray | None) -> _Stats:
    stats = _Stats()
    stats.lap = _laplacian_moments(gray, mask, "reflect101")
    stats.gray.add(gray if mask is None else gray[mask])
    return stats


def _open_vector(path: str | os.PathLike) -> ogr.DataSource | None:
    """The OGR data source, or None if GDAL cannot read it as vector data (with or without UseExceptions)."""
    with gdal_quiet():
        try:
            return ogr.Open(str(path))
        except RuntimeError:
            return None


def _read_gray(ds: gdal.Dataset, xoff: int, yoff: int, xsize: int, ysize: int) -> tuple[np.ndarray, np.ndarray]:
    """Intensity and validity (band 1's GDAL mask: NoData, alpha) of a window."""
    bands = [ds.GetRasterBand(i + 1) for i in range(3 if ds.RasterCount >= 3 else 1)]  # RGB(A) or grey(+alpha)
    what = f"the image {ds.GetDescription()}"
    data = np.stack([read_window(b, xoff, yoff, xsize, ysize, what) for b in bands])
    valid = read_window(ds.GetRasterBand(1).GetMaskBand(), xoff, yoff, xsize, ysize, f"the mask of {what[4:]}") > 0
    return grayscale(data), valid


def _list_images(images: Sequence[str] | str) -> tuple[list[Path], Path | None]:
    """Image paths (mip levels left out) and the folder's texcoords file, if any."""
    if isinstance(images, (str, os.PathLike)):
        folder = Path(images)
        if not folder.is_dir():
            return [folder], None
        paths = sorted(p for p in folder.rglob("*") if p.suffix.lower() in IMAGE_SUFFIXES
                       and not _MIP.search(p.stem) and not p.name.startswith("."))
        if not paths:
            raise InputError(f"{folder} holds no texture images (.jpg, .png, .tif): give the wit:wittexture "
                             "output folder.")
        texcoords = folder / model.TEXCOORD_FILE
        return paths, texcoords if texcoords.exists() else None
    return [Path(p) for p in images], None


def _texcoord_rings(texcoords: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """UV rings per image (relative path as stored) from the wit:wittexture table: (points, points per ring),
    read in bulk (the 1 km demo has ~600,000 rings)."""
    ds = _open_vector(texcoords)
    layer = None if ds is None else ds.GetLayerByName(model.TEXCOORD_TABLE)
    if layer is None:
        raise InputError(f"{texcoords} has no table '{model.TEXCOORD_TABLE}': re-run wit:wittexture.")
    images: list[str] = []
    uvs: list[str] = []
    for batch in bulk_read.batches(layer):
        images += bulk_read.texts(batch[model.TEX_IMAGE])
        uvs += bulk_read.texts(batch[model.TEX_COORDS])
    if not uvs:
        return {}
    counts = np.fromiter((text.count(" ") + 1 for text in uvs), dtype=np.int64, count=len(uvs)) // 2
    try:
        points = np.array(" ".join(uvs).split(), dtype=np.float64).reshape(-1, 2)
    except ValueError as exc:
        raise InputError(f"{texcoords}: texture coordinates that are not numbers ({exc}): re-run wit:wittexture.") from exc
    if len(points) != counts.sum():
        raise InputError(f"{texcoords}: texture coordinates that are not u v pairs: re-run wit:wittexture.")
    names, image_of = np.unique(np.array(images, dtype=object), return_inverse=True)
    order = np.argsort(image_of, kind="stable")  # rings grouped by image, in table order within each
    ring, within = ragged_indices(counts[order])
    points = points[(np.cumsum(counts) - counts)[order][ring] + within]
    ends = np.cumsum(np.bincount(image_of, minlength=len(names)))  # rings per image, cumulated
    point_ends = np.concatenate([[0], np.cumsum(counts[order])])[ends]
    rings, first, first_point = {}, 0, 0
    for name, last, last_point in zip(names, ends, point_ends):
        rings[name] = (points[first_point:last_point], counts[order][first:last])
        first, first_point = last, last_point
    return rings


class _Burner:
    """Polygons in an in-memory OGR layer, rasterised onto any grid: pixels whose centres are inside."""

    def __init__(self, polygons: Sequence[shapely.Geometry]):
        self._source = ogr.GetDriverByName("Memory").CreateDataSource("")
        self._layer = self._source.CreateLayer("polygons", None, ogr.wkbUnknown)
        defn = self._layer.GetLayerDefn()
        for polygon in polygons:
            feature = ogr.Feature(defn)
            feature.SetGeometryDirectly(ogr.CreateGeometryFromWkb(shapely.to_wkb(polygon)))
            self._layer.CreateFeature(feature)

    def mask(self, width: int, height: int, gt: tuple[float, ...]) -> np.ndarray:
        target = gdal.GetDriverByName("MEM").Create("", width, height, 1, gdal.GDT_Byte)
        target.SetGeoTransform(gt)
        with gdal_quiet():  # "no spatial reference on layer": both sides share one, as intended
            gdal.RasterizeLayer(target, [1], self._layer, burn_values=[1])
        return read_window(target, 0, 0, width, height, "the rasterised polygons (in memory)").astype(bool)


def _uv_mask(rings: tuple[np.ndarray, np.ndarray] | None, width: int, height: int) -> np.ndarray:
    """Texels whose centres are inside any UV ring (U right, V up from the bottom edge).

    All rings of an image go to GDAL as one multipolygon (one call, not one feature per ring): the
    rings of an image never overlap (roof islands, TIN triangles), so its even-odd fill is their union.
    """
    if rings is None or not len(rings[1]):
        return np.zeros((height, width), dtype=bool)
    points, counts = rings
    keep = counts >= 3
    ring_of = np.repeat(np.arange(len(counts)), counts)
    kept = np.repeat(keep, counts)
    polygons = shapely.polygons(shapely.linearrings(points[kept] * [width, height], indices=ring_of[kept]))
    burner = _Burner([shapely.multipolygons(polygons)])
    return burner.mask(width, height, (0.0, 1.0, 0.0, float(height), 0.0, -1.0))  # ground = (u·W, v·H)


def _ortho_stats(ortho: str, area: tuple[float, float, float, float] | shapely.Geometry | None,
                 feedback: Feedback) -> tuple[_Stats, tuple[float, float, float, float]]:
    """Streamed measures of the ortho over ``area`` (the window it covers, reflect-101 at its border).

    A polygonal ``area`` also limits the pixels to those whose centres lie inside it.
    """
    ds = open_raster(ortho, "orthoimage")
    gt = ds.GetGeoTransform()
    if gt[2] or gt[4]:
        raise InputError(f"{ortho} is rotated; give a north-up orthoimage (wit:mergetiles writes one).")
    burner = None
    if isinstance(area, shapely.Geometry):  # one pixel of margin: border pixels see their real neighbours
        burner = _Burner(shapely.get_parts(area))
        x_min, y_min, x_max, y_max = area.bounds
        area = (x_min - abs(gt[1]), y_min - abs(gt[5]), x_max + abs(gt[1]), y_max + abs(gt[5]))
    if area is None:
        x0, y0, x1, y1 = 0, 0, ds.RasterXSize, ds.RasterYSize
    else:
        cols = sorted(((area[0] - gt[0]) / gt[1], (area[2] - gt[0]) / gt[1]))
        rows = sorted(((area[1] - gt[3]) / gt[5], (area[3] - gt[3]) / gt[5]))
        x0, x1 = max(math.floor(cols[0]), 0), min(math.ceil(cols[1]), ds.RasterXSize)
        y0, y1 = max(math.floor(rows[0]), 0), min(math.ceil(rows[1]), ds.RasterYSize)
        if x1 - x0 < 2 or y1 - y0 < 2:
            raise InputError(f"The orthoimage {ortho} does not cover the model's area {tuple(round(v, 1) for v in area)}"
                             ": give the merged orthoimage of the study area.")
    width, height = x1 - x0, y1 - y0
    stats = _Stats()
    block_rows = max(8, _BLOCK_PIXELS // width)
    for r0 in range(0, height, block_rows):
        feedback.check_canceled()
        r1 = min(r0 + block_rows, height)
        a, b = max(r0 - 1, 0), min(r1 + 1, height)
        gray, valid = _read_gray(ds, x0, y0 + a, width, b - a)
        if burner is not None:
            valid &= burner.mask(width, b - a, (gt[0] + x0 * gt[1], gt[1], 0.0, gt[3] + (y0 + a) * gt[5], 0.0, gt[5]))
        stats.gray.add(gray[r0 - a:r0 - a + r1 - r0][valid[r0 - a:r0 - a + r1 - r0]])
        if height >= 2 and width >= 2:
            pad = ((1 if r0 == 0 else 0, 1 if r1 == height else 0), (1, 1))
            g, m = np.pad(gray, pad, mode="reflect"), np.pad(valid, pad, mode="reflect")
            stats.lap.add(_laplacian_valid(g)[_eroded(m)])
        feedback.progress(100.0 * r1 / height)
    bounds = (gt[0] + x0 * gt[1], gt[3] + y1 * gt[5], gt[0] + x1 * gt[1], gt[3] + y0 * gt[5])
    return stats, bounds


def texture_metrics(images: Sequence[str] | str | None, ortho: str | None = None,
                    ortho_area: tuple[float, float, float, float] | None = None,
                    ortho_mask: shapely.Geometry | None = None, feedback: Feedback = SILENT) -> TextureMetrics:
    """Sharpness and contrast of the model's texture images (a folder or a list) and of the source ortho.

    ``ortho_area`` (xmin, ymin, xmax, ymax in the ortho's CRS) limits the ortho to the model's area;
    by default the whole ortho is measured. ``ortho_mask`` (polygons in the ortho's CRS, e.g. the
    building footprints) adds ``ortho_inside``: the ortho's pixels that roof textures show, so the
    model's roof atlases and their source can be compared pixel set for pixel set.
    """
    if not images and not ortho:
        raise InputError("Give the texture folder (wit:wittexture output), the orthoimage or both.")
    result = TextureMetrics()
    paths, texcoords = _list_images(images) if images else ([], None)
    rings = _texcoord_rings(texcoords) if texcoords else None
    result.masked = rings is not None
    share = 60.0 if ortho else 100.0
    pooled = _Stats()
    folder = Path(images) if isinstance(images, (str, os.PathLike)) and Path(images).is_dir() else None
    for k, path in enumerate(paths):
        feedback.check_canceled()
        ds = open_raster(str(path), "texture image")
        gray, valid = _read_gray(ds, 0, 0, ds.RasterXSize, ds.RasterYSize)
        if rings is not None:
            valid &= _uv_mask(rings.get(path.relative_to(folder).as_posix()), ds.RasterXSize, ds.RasterYSize)
        stats = _image_stats(gray, valid)
        pooled.merge(stats)
        result.images.append(stats.result(str(path.relative_to(folder) if folder else path)))
        feedback.progress(share * (k + 1) / len(paths))
    if paths:
        pooled_result = pooled.result("model")
        result.laplacian_variance, result.contrast, result.pixels = (
            pooled_result.laplacian_variance, pooled_result.contrast, pooled_result.pixels)
        if result.pixels == 0:
            feedback.warning("No textured pixel found in the texture images (empty texcoords rings?).")
    if ortho:
        middle = (share + 100.0) / 2 if ortho_mask is not None else 100.0
        stats, result.ortho_area = _ortho_stats(ortho, ortho_area, feedback.scaled(share, middle))
        result.ortho = stats.result(str(ortho))
        if ortho_mask is not None:
            inside = _ortho_stats(ortho, ortho_mask, feedback.scaled(middle, 100.0))[0]
            result.ortho_inside = inside.result(f"{ortho} (inside the footprints)")
    feedback.progress(100.0)
    return result


# --- seam step ------------------------------------------------------------------------------------

@dataclass
class SeamEdge:
    """One tile edge inside the mosaic: where, how many pixel pairs, the mean step across it."""

    tile: int
    side: str  # "west", "east", "south", "north"
    pairs: int
    step: float
    baseline: float


@dataclass
class SeamMetrics:
    """Mean colour step across the tile borders inside a mosaic (digital numbers)."""

    step: float = math.nan
    baseline: float = math.nan
    pairs: int = 0
    edges: list[SeamEdge] = field(default_factory=list)

    @property
    def excess(self) -> float:
        """The step beyond the image's own gradient next to the border."""
        return self.step - self.baseline


def _raster_bounds(path: str) -> tuple[tuple[float, float, float, float], osr.SpatialReference | None]:
    ds = open_raster(path, "tile")
    gt = ds.GetGeoTransform()
    xs = (gt[0], gt[0] + ds.RasterXSize * gt[1])
    ys = (gt[3], gt[3] + ds.RasterYSize * gt[5])
    srs = ds.GetSpatialRef()
    return (min(xs), min(ys), max(xs), max(ys)), srs.Clone() if srs else None


def tile_footprints(footprints: str | Sequence[str]) -> tuple[list[tuple[float, float, float, float]],
                                                              osr.SpatialReference | None]:
    """Tile rectangles from the georef sheet index (layer 'footprints', status 'ok') or from rasters.

    ``footprints`` is a vector file, a folder of georeferenced tiles, or a list of tile rasters.
    """
    if isinstance(footprints, (str, os.PathLike)):
        path_text, name, _ = split_source(footprints)
        path = Path(path_text)
        if path.is_dir():
            rasters = sorted(str(p) for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff", ".vrt"))
            if not rasters:
                raise InputError(f"{path} holds no georeferenced tiles (.tif, .vrt).")
            return tile_footprints(rasters)
        vector = _open_vector(path)
        if vector is None or vector.GetLayerCount() == 0:
            return tile_footprints([str(path)])
        layer = vector.GetLayerByName(name or "footprints") or vector.GetLayer(0)
        has_status = layer.GetLayerDefn().GetFieldIndex("status") >= 0
        boxes = []
        for feature in layer:
            geometry = feature.GetGeometryRef()
            if geometry is None or geometry.IsEmpty() or (has_status and feature.GetField("status") != "ok"):
                continue
            x0, x1, y0, y1 = geometry.GetEnvelope()
            boxes.append((x0, y0, x1, y1))
        srs = layer.GetSpatialRef()
        return boxes, srs.Clone() if srs else None
    results = [_raster_bounds(p) for p in footprints]
    return [b for b, _ in results], (results[0][1] if results else None)


def _covered(n: int, intervals: list[tuple[int, int]]) -> np.ndarray:
    flags = np.zeros(n, bool)
    for a, b in intervals:
        flags[max(a, 0):min(b, n)] = True
    return flags


def seam_metrics(mosaic: str, footprints: str | Sequence[str], feedback: Feedback = SILENT) -> SeamMetrics:
    """The colour step across every tile edge that lies inside another tile (see the module docstring)."""
    ds = open_raster(mosaic, "mosaic")
    gt = ds.GetGeoTransform()
    if gt[2] or gt[4] or gt[5] >= 0:
        raise InputError(f"{mosaic} is not a north-up raster; give the output of wit:mergetiles.")
    boxes, srs = tile_footprints(footprints)
    mosaic_srs = ds.GetSpatialRef()
    if srs is not None and mosaic_srs is not None and not srs.IsSame(mosaic_srs):
        raise InputError(f"The tile footprints and the mosaic {mosaic} are in different CRSs: use the footprints "
                         "written by wit:georeferencemapsheets for these tiles.")
    if len(boxes) < 2:
        raise InputError("Fewer than two tile footprints: a seam needs at least two overlapping tiles.")
    px, py = gt[1], -gt[5]
    width, height = ds.RasterXSize, ds.RasterYSize
    bands = [b for b in (ds.GetRasterBand(i + 1) for i in range(ds.RasterCount))
             if b.GetColorInterpretation() != gdal.GCI_AlphaBand]  # alpha is coverage, not colour
    mask_band = bands[0].GetMaskBand()
    result = SeamMetrics()
    total_step = total_base = 0.0

    def col_of(x: float) -> int:  # the pixel boundary nearest to x
        return round((x - gt[0]) / px)

    def row_of(y: float) -> int:
        return round((gt[3] - y) / py)

    for i, (x0, y0, x1, y1) in enumerate(boxes):
        feedback.check_canceled()
        others = [b for j, b in enumerate(boxes) if j != i]
        for side, coord in (("west", x0), ("east", x1), ("north", y1), ("south", y0)):
            vertical = side in ("west", "east")
            if vertical:
                line, n = col_of(coord), height
                spans = [(row_of(b[3]), row_of(b[1])) for b in others
                         if b[0] < coord - 2 * px and b[2] > coord + 2 * px]
                along = (row_of(y1), row_of(y0))
                limit = width
            else:
                line, n = row_of(coord), width
                spans = [(col_of(b[0]), col_of(b[2])) for b in others
                         if b[1] < coord - 2 * py and b[3] > coord + 2 * py]
                along = (col_of(x0), col_of(x1))
                limit = height
            if not spans or line < 2 or line > limit - 2:
                continue
            use = _covered(n, spans) & _covered(n, [along])
            use[:1] = use[-1:] = False  # not at the mosaic's border
            index = np.flatnonzero(use)
            if index.size == 0:
                continue
            a, b = int(index[0]), int(index[-1]) + 1
            win = (line - 2, a, 4, b - a) if vertical else (a, line - 2, b - a, 4)
            data = np.stack([read_window(band, *win, f"the mosaic {mosaic}").astype(np.float64) for band in bands])
            valid = read_window(mask_band, *win, f"the mask of the mosaic {mosaic}") > 0
            if not vertical:
                data, valid = data.transpose(0, 2, 1), valid.T
            keep = use[a:b] & valid.all(axis=1)
            if not keep.any():
                continue
            diffs = np.abs(np.diff(data[:, keep, :], axis=2)).mean(axis=0)  # (pairs, 3): left, across, right
            step, base = diffs[:, 1], diffs[:, [0, 2]]
            result.edges.append(SeamEdge(i, side, int(step.size), float(step.mean()), float(base.mean())))
            result.pairs += int(step.size)
            total_step += float(step.sum())
            total_base += float(base.mean(axis=1).sum())
        feedback.progress(100.0 * (i + 1) / len(boxes))
    if result.pairs == 0:
        raise InputError(f"No tile edge lies inside {mosaic} where two tiles overlap: check that the footprints "
                         "belong to the tiles of this mosaic.")
    result.step, result.baseline = total_step / result.pairs, total_base / result.pairs
    return result


def seam_step(mosaic: str, footprints: str | Sequence[str], feedback: Feedback = SILENT) -> float:
    """Mean absolute colour step (DN, mean over bands) across the tile borders inside ``mosaic``."""
    return seam_metrics(mosaic, footprints, feedback).step


# --- geometry against the 2D sources --------------------------------------------------------------

@dataclass
class BuildingMetrics:
    """One building: how far the model is from its source footprint (NaN where not matched)."""

    wit_id: str
    status: str  # MATCHED, MODEL_ONLY or SOURCE_ONLY
    solids: int = 0  # model solids merged into this building (parts of a multi-part footprint)
    position_error: float = math.nan
    vertex_mean_error: float = math.nan
    vertex_max_error: float = math.nan
    hausdorff: float = math.nan
    ssi: float = math.nan
    source_area: float = math.nan
    model_area: float = math.nan
    geometry: shapely.Geometry | None = None  # source footprint (model ground if model-only), 2D


@dataclass
class GeometryMetrics:
    """Table 17: coordinate consistency, placement accuracy and shape similarity over matched buildings."""

    buildings: list[BuildingMetrics]
    source_count: int
    model_count: int
    matched: int
    model_only: list[str]
    source_only: list[str]
    vertices: int
    coordinate_mean_error: float
    coordinate_max_error: float
    placement_mean_error: float
    placement_std: float
    placement_max_error: float
    hausdorff_mean: float
    hausdorff_max: float
    ssi_mean: float
    ssi_std: float
    ssi_min: float
    crs_wkt: str | None = None


@dataclass
class _ModelBuilding:
    grounds: list[shapely.Polygon] = field(default_factory=list)
    roof_vertices: list[np.ndarray] = field(default_factory=list)
    solids: int = 0


def _polygon_3d(rings: list[np.ndarray]) -> tuple[shapely.Polygon, np.ndarray]:
    """2D polygon and the 3D points (closing points dropped) of rings given as (n, 3) arrays."""
    poly = shapely.Polygon(rings[0][:, :2], [r[:, :2] for r in rings[1:]])
    return poly, np.concatenate([r[:-1] for r in rings])


def _add_solid(target: _ModelBuilding, faces: list[tuple[shapely.Polygon, np.ndarray, str | None]]) -> None:
    """Add one solid's faces; faces without a kind are classified by height (lowest/highest horizontal)."""
    if not faces:
        return
    z = np.concatenate([pts[:, 2] for _, pts, _ in faces])
    low, high = float(z.min()), float(z.max())
    for poly, pts, kind in faces:
        if kind is None and np.ptp(pts[:, 2]) <= _FLAT:
            kind = "ground" if abs(pts[0, 2] - low) <= _FLAT else "roof" if abs(pts[0, 2] - high) <= _FLAT else None
        if kind == "ground":
            target.grounds.append(poly)
        elif kind == "roof":
            target.roof_vertices.append(pts[:, :2])
    target.solids += 1


def _poslist(ring: etree._Element, gml_id: str) -> np.ndarray:
    pos = ring.find(_GML + "posList")
    if pos is not None:
        dim = int(pos.get("srsDimension") or 3)
        values = np.array((pos.text or "").split(), dtype=np.float64)
    else:
        points = [np.array((p.text or "").split(), dtype=np.float64) for p in ring.iter(_GML + "pos")]
        dim, values = (len(points[0]) if points else 3), np.concatenate(points) if points else np.zeros(0)
    if dim != 3 or values.size % 3 or values.size < 12:
        raise InputError(f"Building {gml_id}: a lod1Solid ring is not a closed 3D ring (srsDimension 3, ≥ 4 points); "
                         "re-run wit:writecitygml.")
    return values.reshape(-1, 3)


def _gml_srs(path: str) -> str | None:
    """The srsName of the CityModel's envelope (the first element that carries one)."""
    with open(path, "rb") as fh:
        for _, element in etree.iterparse(fh, events=("start",), huge_tree=True):
            name = element.get("srsName")
            if name or element.tag == _CORE + "cityObjectMember":
                return name
    return None


def _read_gml(path: str, feedback: Feedback) -> tuple[dict[str, _ModelBuilding], str | None]:
    """Buildings of a CityGML 3.0 file: per gml:id the solids' ground polygons and roof vertices (streamed).

    Positions are turned easting (longitude) first when the srsName says they are written northing
    (latitude) first: its URN or URL form for a CRS whose EPSG order is so (``validation.crs``).
    """
    buildings: dict[str, _ModelBuilding] = {}
    size = max(os.path.getsize(path), 1)
    try:
        srs = _gml_srs(path)
        order = [1, 0, 2] if srs and frame_of(srs).lat_axis == 0 else [0, 1, 2]
        with open(path, "rb") as fh:
            members = etree.iterparse(fh, events=("end",), huge_tree=True,
                                      tag=(_CORE + "cityObjectMember", _CORE + "appearanceMember"))
            for count, (_, member) in enumerate(members):
                buildings_in = member.iter(_BLDG + "Building") if member.tag == _CORE + "cityObjectMember" else ()
                for building in buildings_in:
                    gml_id = building.get(_GML + "id") or f"Building_{len(buildings) + 1}"
                    faces = []
                    for solid in building.iter(_CORE + "lod1Solid"):
                        for polygon in solid.iter(_GML + "Polygon"):
                            rings = [_poslist(r, gml_id)[:, order] for r in polygon.iter(_GML + "LinearRing")]
                            if rings:
                                faces.append((*_polygon_3d(rings), None))
                    _add_solid(buildings.setdefault(gml_id, _ModelBuilding()), faces)
                member.clear()
                while member.getprevious() is not None:
                    del member.getparent()[0]
                if count % 1000 == 0:
                    feedback.check_canceled()
                    feedback.progress(100.0 * fh.tell() / size)
    except etree.XMLSyntaxError as exc:
        raise InputError(f"{path} is not well-formed XML ({exc}); re-run wit:writecitygml.") from exc
    if not buildings:
        raise InputError(f"{path} has no CityGML 3.0 bldg:Building: give the .gml written by wit:writecitygml "
                         "(or the LoD1 faces GeoPackage).")
    return buildings, srs


def _read_lod1(path: str, feedback: Feedback) -> tuple[dict[str, _ModelBuilding], osr.SpatialReference | None]:
    """Ground polygons and roof vertices per wit_id from the LoD1 faces layer (FACE_TYPE given)."""
    ds, layer, _ = open_step_layer(path, model.LOD1_LAYER, model.LOD1_ROLE,
                                   (model.WIT_ID, model.FACE_TYPE))
    faces: dict[str, list] = defaultdict(list)
    total = max(layer.GetFeatureCount(), 1)
    for k, feature in enumerate(layer):
        if k % 5000 == 0:
            feedback.check_canceled()
            feedback.progress(100.0 * k / total)
        kind = feature.GetFieldAsString(model.FACE_TYPE)
        geometry = feature.GetGeometryRef()
        if kind not in ("ground", "roof") or geometry is None or geometry.IsEmpty():
            continue
        poly = shapely.from_wkb(bytes(geometry.ExportToIsoWkb()))
        rings = [np.asarray(poly.exterior.coords)] + [np.asarray(r.coords) for r in poly.interiors]
        if rings[0].shape[1] != 3:
            rings = [np.column_stack([r, np.zeros(len(r))]) for r in rings]
        faces[feature.GetFieldAsString(model.WIT_ID)].append((*_polygon_3d(rings), kind))
    buildings: dict[str, _ModelBuilding] = {}
    for wit_id, solid in faces.items():
        _add_solid(buildings.setdefault(wit_id, _ModelBuilding()), solid)
    srs = layer.GetSpatialRef()
    return buildings, srs.Clone() if srs else None


def _read_sources(source: str) -> tuple[list[str], np.ndarray, osr.SpatialReference | None]:
    ds, layer, _ = open_step_layer(source, model.PREPARED_BUILDINGS, model.PREPARED_BUILDINGS_ROLE,
                                   (model.WIT_ID,))
    ids, wkbs = [], []
    for feature in layer:
        geometry = feature.GetGeometryRef()
        if geometry is None or geometry.IsEmpty():
            continue
        ids.append(feature.GetFieldAsString(model.WIT_ID))
        wkbs.append(bytes(geometry.ExportToIsoWkb()))
    geoms = shapely.force_2d(shapely.from_wkb(np.array(wkbs, dtype=object))) if wkbs else np.empty(0, dtype=object)
    srs = layer.GetSpatialRef()
    return ids, geoms, srs.Clone() if srs else None


def _epsg(srs: osr.SpatialReference | str | None) -> str | None:
    if srs is None:
        return None
    try:
        crs = pyproj.CRS.from_user_input(srs.ExportToWkt() if isinstance(srs, osr.SpatialReference) else srs)
    except pyproj.exceptions.CRSError:
        return None
    code = crs.to_epsg(min_confidence=70)
    return str(code) if code else None


def _merge_parts(models: dict[str, _ModelBuilding], source_ids: set[str]) -> dict[str, _ModelBuilding]:
    """Solids ``<id>_partN`` of a source building ``<id>`` folded into one model building."""
    merged: dict[str, _ModelBuilding] = {}
    for gml_id, b in models.items():
        match = _PART.match(gml_id)
        key = match.group(1) if match and gml_id not in source_ids and match.group(1) in source_ids else gml_id
        target = merged.setdefault(key, _ModelBuilding())
        target.grounds += b.grounds
        target.roof_vertices += b.roof_vertices
        target.solids += b.solids
    return merged


def _nearest_vertex_distances(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` (n, 2) to the nearest of ``targets`` (m, 2), chunked."""
    out = np.empty(len(points))
    step = max(1, _PAIRS // max(len(targets), 1))
    for k in range(0, len(points), step):
        d = points[k:k + step, None, :] - targets[None, :, :]
        out[k:k + step] = np.sqrt(np.min(np.einsum("ijk,ijk->ij", d, d), axis=1))
    return out


def _vertices(geometry: shapely.Geometry) -> np.ndarray:
    """2D vertices of every ring of a (multi)polygon, closing points dropped."""
    rings = shapely.get_rings(shapely.get_parts(geometry))
    return np.concatenate([shapely.get_coordinates(r)[:-1] for r in rings]) if len(rings) else np.zeros((0, 2))


def _valid(geoms: np.ndarray) -> np.ndarray:
    """Invalid polygons repaired (GEOS overlay needs valid input), keeping only their polygonal parts."""
    bad = np.flatnonzero(~shapely.is_valid(geoms))
    if bad.size:
        geoms = geoms.copy()
        for k in bad:
            parts = shapely.get_parts(shapely.make_valid(geoms[k]))
            geoms[k] = shapely.union_all(parts[np.isin(shapely.get_type_id(parts), (3, 6))])
    return geoms


def shape_similarity(a: shapely.Geometry | np.ndarray, b: shapely.Geometry | np.ndarray) -> float | np.ndarray:
    """SSI = IoU = area(A ∩ B) / area(A ∪ B) of valid polygons, element-wise for arrays (NaN if both empty)."""
    with np.errstate(invalid="ignore", divide="ignore"):  # GEOS raises FP flags on some empty overlays
        inter = shapely.area(shapely.intersection(a, b))
        return inter / (shapely.area(a) + shapely.area(b) - inter)


def geometry_metrics(model_source: str, source_buildings: str, feedback: Feedback = SILENT) -> GeometryMetrics:
    """Compare the model's buildings with the 2D source footprints (Table 17; see the module docstring).

    ``model_source``: the CityGML file (``.gml``/``.xml``) or the LoD1 faces GeoPackage;
    ``source_buildings``: footprints with the ``wit_id`` of wit:preparevectors: its GeoPackage (layer
    ``buildings``), one of its layers as ``file.gpkg|layername=…``, or a file of one such layer.
    """
    if not Path(model_source).is_file():
        raise InputError(f"The model {model_source} does not exist.")
    if not Path(split_source(source_buildings)[0]).is_file():
        raise InputError(f"The source buildings {source_buildings} do not exist.")
    ids, sources, source_srs = _read_sources(str(source_buildings))
    if not ids:
        raise InputError(f"{source_buildings} has no building footprints.")
    if len(set(ids)) != len(ids):
        raise InputError(f"{source_buildings}: '{model.WIT_ID}' is not unique; give the output of wit:preparevectors.")
    feedback.progress(5.0)
    if Path(model_source).suffix.lower() in (".gml", ".xml"):
        raw, model_srs = _read_gml(str(model_source), feedback.scaled(5.0, 60.0))
    else:
        raw, model_srs = _read_lod1(str(model_source), feedback.scaled(5.0, 60.0))
    model_code, source_code = _epsg(model_srs), _epsg(source_srs)
    if model_code and source_code and model_code != source_code:
        raise InputError(f"The model is in EPSG:{model_code} but the source buildings in EPSG:{source_code}: "
                         "compare layers in the same CRS (re-run wit:preparevectors with the model's CRS).")
    models = _merge_parts(raw, set(ids))
    index = {wit_id: k for k, wit_id in enumerate(ids)}
    matched_ids = [m for m in models if m in index and models[m].grounds]
    source_only = [i for i in ids if i not in models or not models[i].grounds]
    model_only = [m for m in models if m not in index]
    rows: list[BuildingMetrics] = []
    if matched_ids:
        a = _valid(sources[[index[m] for m in matched_ids]])
        b = _valid(np.array([shapely.union_all(models[m].grounds) if len(models[m].grounds) > 1
                             else models[m].grounds[0] for m in matched_ids], dtype=object))
        position = shapely.distance(shapely.centroid(a), shapely.centroid(b))
        area_a, area_b = shapely.area(a), shapely.area(b)
        ssi = shape_similarity(a, b)
        hausdorff = shapely.hausdorff_distance(shapely.boundary(a), shapely.boundary(b))
        feedback.progress(75.0)
        all_errors = []
        for k, wit_id in enumerate(matched_ids):
            if k % 1000 == 0:
                feedback.check_canceled()
                feedback.progress(75.0 + 20.0 * k / len(matched_ids))
            roof = models[wit_id].roof_vertices
            errors = (_nearest_vertex_distances(np.concatenate(roof), _vertices(a[k])) if roof else np.zeros(0))
            all_errors.append(errors)
            rows.append(BuildingMetrics(wit_id, MATCHED, models[wit_id].solids, float(position[k]),
                                        float(errors.mean()) if errors.size else math.nan,
                                        float(errors.max()) if errors.size else math.nan,
                                        float(hausdorff[k]), float(ssi[k]), float(area_a[k]), float(area_b[k]), a[k]))
        errors = np.concatenate(all_errors)
    else:
        position = ssi = hausdorff = errors = np.zeros(0)
    rows += [BuildingMetrics(i, SOURCE_ONLY, 0, source_area=float(sources[index[i]].area), geometry=sources[index[i]])
             for i in source_only]
    for m in model_only:
        ground = shapely.union_all(models[m].grounds) if models[m].grounds else None
        rows.append(BuildingMetrics(m, MODEL_ONLY, models[m].solids,
                                    model_area=float(ground.area) if ground is not None else math.nan,
                                    geometry=ground))
    if model_only:
        feedback.warning(f"{len(model_only)} model building(s) have no source footprint, e.g. {model_only[0]}.")
    if source_only:
        feedback.warning(f"{len(source_only)} source footprint(s) have no model building, e.g. {source_only[0]}.")

    def stat(values: np.ndarray, how) -> float:
        return float(how(values)) if values.size else math.nan

    result = GeometryMetrics(
        rows, len(ids), len(models), len(matched_ids), model_only, source_only, int(errors.size),
        stat(errors, np.mean), stat(errors, np.max), stat(position, np.mean), stat(position, np.std),
        stat(position, np.max), stat(hausdorff, np.mean), stat(hausdorff, np.max),
        stat(ssi, np.mean), stat(ssi, np.std), stat(ssi, np.min),
        source_srs.ExportToWkt() if source_srs else None)
    feedback.info(f"Geometry: {result.matched} matched building(s); placement error {result.placement_mean_error:.4f} m "
                  f"(max {result.placement_max_error:.4f}), vertex error {result.coordinate_mean_error:.4f} m "
                  f"(max {result.coordinate_max_error:.4f}), SSI {result.ssi_mean:.4f} (min {result.ssi_min:.4f}).")
    feedback.progress(100.0)
    return result


# --- report ---------------------------------------------------------------------------------------

@dataclass
class MetricRow:
    """One line of the metrics table; ``paper`` is the paper's figure for the same measure, if any."""

    group: str
    metric: str
    value: float
    unit: str
    paper: float | None = None
    note: str = ""


@dataclass
class QualityReport:
    """What ``quality_report`` measured and wrote."""

    rows: list[MetricRow]
    geometry: GeometryMetrics | None = None
    texture: TextureMetrics | None = None
    seam: SeamMetrics | None = None
    outputs: dict[str, str] = field(default_factory=dict)

    def value(self, metric: str) -> float:
        """The value of one metric by name (KeyError if it was not measured)."""
        return next(r.value for r in self.rows if r.metric == metric)


def metric_rows(geometry: GeometryMetrics | None, texture: TextureMetrics | None,
                seam: SeamMetrics | None) -> list[MetricRow]:
    """The metrics table, with the paper's Table 17 / Table 19 figures beside ours."""
    rows: list[MetricRow] = []
    if geometry:
        g, t17 = geometry, "Table 17"
        rows += [
            MetricRow("geometry", "buildings_source", g.source_count, "count"),
            MetricRow("geometry", "buildings_model", g.model_count, "count", note="model solids merged per wit_id"),
            MetricRow("geometry", "buildings_matched", g.matched, "count"),
            MetricRow("geometry", "buildings_model_only", len(g.model_only), "count"),
            MetricRow("geometry", "buildings_source_only", len(g.source_only), "count"),
            MetricRow("geometry", "coordinate_mean_error", g.coordinate_mean_error, "m",
                      PAPER_TABLE17["coordinate_mean_error"], f"{t17} ME (30–80 m); roof vertex → nearest source vertex"),
            MetricRow("geometry", "coordinate_max_error", g.coordinate_max_error, "m",
                      PAPER_TABLE17["coordinate_max_error"], f"{t17} MaxE"),
            MetricRow("geometry", "placement_mean_error", g.placement_mean_error, "m",
                      PAPER_TABLE17["placement_mean_error"], f"{t17} MPE (standard < 100 m); centroid distance"),
            MetricRow("geometry", "placement_std", g.placement_std, "m"),
            MetricRow("geometry", "placement_max_error", g.placement_max_error, "m"),
            MetricRow("geometry", "hausdorff_mean", g.hausdorff_mean, "m", note="outline Hausdorff distance"),
            MetricRow("geometry", "hausdorff_max", g.hausdorff_max, "m"),
            MetricRow("geometry", "ssi_mean", g.ssi_mean, "ratio", PAPER_TABLE17["ssi_mean"],
                      f"{t17} SSI (standard > 0.9); IoU of footprint and ground face"),
            MetricRow("geometry", "ssi_std", g.ssi_std, "ratio"),
            MetricRow("geometry", "ssi_min", g.ssi_min, "ratio"),
        ]
    if texture:
        lap, con = PAPER_TABLE19["laplacian_variance"], PAPER_TABLE19["contrast"]
        others = "Table 19: Bing Maps {Bing Maps}, V-World {V-World}, WIT {WIT}"
        if texture.images:
            scope = "textured rings only" if texture.masked else "whole images"
            rows += [
                MetricRow("texture", "texture_images", len(texture.images), "count"),
                MetricRow("texture", "texture_pixels", texture.pixels, "count", note=scope),
                MetricRow("texture", "model_laplacian_variance", texture.laplacian_variance, "DN²", lap["WIT"],
                          others.format(**lap)),
                MetricRow("texture", "model_contrast", texture.contrast, "DN", con["WIT"], others.format(**con)),
            ]
        if texture.ortho:
            rows += [
                MetricRow("texture", "ortho_laplacian_variance", texture.ortho.laplacian_variance, "DN²",
                          note="source orthoimage over the model's area"),
                MetricRow("texture", "ortho_contrast", texture.ortho.contrast, "DN"),
                MetricRow("texture", "ortho_pixels", texture.ortho.pixels, "count"),
            ]
        if texture.ortho_inside:
            rows += [
                MetricRow("texture", "ortho_footprints_laplacian_variance", texture.ortho_inside.laplacian_variance,
                          "DN²", note="source orthoimage inside the building footprints (what roofs show)"),
                MetricRow("texture", "ortho_footprints_contrast", texture.ortho_inside.contrast, "DN"),
                MetricRow("texture", "ortho_footprints_pixels", texture.ortho_inside.pixels, "count"),
            ]
    if seam:
        rows += [
            MetricRow("seam", "seam_step", seam.step, "DN", note="mean |colour step| across tile borders"),
            MetricRow("seam", "seam_baseline", seam.baseline, "DN", note="same, one pixel beside the border"),
            MetricRow("seam", "seam_excess", seam.excess, "DN", note="step − baseline"),
            MetricRow("seam", "seam_border_pixels", seam.pairs, "count"),
        ]
    return rows


_ROW_FIELDS = ["group", "metric", "value", "unit", "paper", "note"]
_BUILDING_FIELDS = [model.WIT_ID, "status", "solids", "position_error", "vertex_mean_error", "vertex_max_error",
                    "hausdorff", "ssi", "source_area", "model_area"]


def _cell(value: object) -> object:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _building_values(b: BuildingMetrics) -> list[object]:
    return [b.wit_id, b.status, b.solids, b.position_error, b.vertex_mean_error, b.vertex_max_error,
            b.hausdorff, b.ssi, b.source_area, b.model_area]


def _write_csv(path: Path, header: list[str], rows: Iterator[list[object]]) -> None:
    with open(path, "w", newline="", encoding="utf-8-sig") as fh:  # BOM: Excel reads UTF-8
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow(["" if _cell(v) is None else (f"{v:.6g}" if isinstance(v, float) else v) for v in row])


def _write_gpkg(path: Path, rows: list[MetricRow], geometry: GeometryMetrics | None) -> None:
    text, real, integer = ogr.OFTString, ogr.OFTReal, ogr.OFTInteger
    layers = [OutputLayer(METRICS_TABLE, [FieldDef(n, t) for n, t in zip(
        _ROW_FIELDS, (text, text, real, text, real, text))],
        {n: [_cell(getattr(r, n)) for r in rows] for n in _ROW_FIELDS})]
    crs = pyproj.CRS.from_wkt(geometry.crs_wkt) if geometry and geometry.crs_wkt else pyproj.CRS("EPSG:5186")
    if geometry:
        kept = [b for b in geometry.buildings if b.geometry is not None]
        columns = list(zip(*[_building_values(b) for b in kept])) or [[]] * len(_BUILDING_FIELDS)
        types = (text, text, integer) + (real,) * 7
        layers.append(OutputLayer(BUILDINGS_LAYER, [FieldDef(n, t) for n, t in zip(_BUILDING_FIELDS, types)],
                                  {n: [_cell(v) for v in col] for n, col in zip(_BUILDING_FIELDS, columns)},
                                  np.array([shapely.force_2d(b.geometry) for b in kept], dtype=object)))
    write_gpkg(path, layers, crs)


def _fmt(value: float | None) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    if isinstance(value, int) or float(value).is_integer() and abs(value) >= 1:
        return f"{value:,.0f}"
    return f"{value:.4g}" if abs(value) >= 1 else f"{value:.4f}"


def _write_html(path: Path, report: QualityReport) -> None:
    esc = html.escape
    table = "".join(f"<tr><td>{esc(r.group)}</td><td>{esc(r.metric)}</td><td class=n>{_fmt(r.value)}</td>"
                    f"<td>{esc(r.unit)}</td><td class=n>{_fmt(r.paper)}</td><td>{esc(r.note)}</td></tr>"
                    for r in report.rows)
    parts = [("<h2>Metrics</h2><table><tr><th>Group</th><th>Metric</th><th>Ours</th><th>Unit</th><th>Paper</th>"
              f"<th>Note</th></tr>{table}</table>")]
    g = report.geometry
    if g:
        worst = sorted((b for b in g.buildings if b.status == MATCHED), key=lambda b: -b.position_error)[:20]
        parts.append("<h2>Buildings with the largest placement error</h2><table><tr><th>wit_id</th><th>placement m"
                     "</th><th>vertex mean m</th><th>vertex max m</th><th>Hausdorff m</th><th>SSI</th></tr>" + "".join(
                         f"<tr><td>{esc(b.wit_id)}</td><td class=n>{b.position_error:.4f}</td>"
                         f"<td class=n>{b.vertex_mean_error:.4f}</td><td class=n>{b.vertex_max_error:.4f}</td>"
                         f"<td class=n>{b.hausdorff:.4f}</td><td class=n>{b.ssi:.5f}</td></tr>" for b in worst)
                     + "</table>")
        for title, ids in (("Model buildings without a source footprint", g.model_only),
                           ("Source footprints without a model building", g.source_only)):
            if ids:
                parts.append(f"<h2>{title} ({len(ids)})</h2><p>{esc(', '.join(ids[:200]))}"
                             f"{' …' if len(ids) > 200 else ''}</p>")
    t = report.texture
    if t and (t.images or t.ortho):
        images = t.images + [i for i in (t.ortho, t.ortho_inside) if i]
        parts.append("<h2>Texture images</h2><table><tr><th>Image</th><th>Pixels</th><th>Laplacian variance</th>"
                     "<th>Contrast</th></tr>" + "".join(
                         f"<tr><td>{esc(i.image)}</td><td class=n>{i.pixels:,}</td>"
                         f"<td class=n>{_fmt(i.laplacian_variance)}</td><td class=n>{_fmt(i.contrast)}</td></tr>"
                         for i in images) + "</table>")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>WIT City Model quality metrics</title>
<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse;margin-bottom:2em}}
td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left;vertical-align:top}}th{{background:#eee}}
td.n{{text-align:right;font-variant-numeric:tabular-nums}}</style></head>
<body><h1>Quality metrics (paper Tables 17 and 19)</h1>
<p>Placement error: centroid distance; coordinate error: each roof vertex to the nearest source vertex;
SSI: area(A∩B)/area(A∪B) of source footprint and model ground face. Sharpness: variance of the
Laplacian [[0,1,0],[1,−4,1],[0,1,0]] of I = 0.299R+0.587G+0.114B (reflect-101 borders); contrast:
standard deviation of I. Seam step: mean |colour step| across tile borders inside the mosaic.</p>
{''.join(parts)}
</body></html>
"""
    path.write_text(page, encoding="utf-8")


def _in_ortho_crs(footprints: shapely.Geometry, crs_wkt: str | None, ortho: str | None,
                  feedback: Feedback) -> shapely.Geometry:
    """The footprints in the ortho's CRS when it has another one: its own pixels are measured, never
    resampled (a warp would smooth them and lower their sharpness)."""
    if not ortho or not crs_wkt:
        return footprints
    source = foreign_crs(open_raster(ortho, "orthoimage"), crs_wkt)
    if source is None:
        return footprints
    feedback.info(f"The orthoimage {Path(ortho).name} is in {crs_name(source)}: the footprints are reprojected to it.")
    return transform_geometry(footprints, pyproj.CRS.from_wkt(crs_wkt), source, 1.0)


def quality_report(output_csv: str, model_source: str | None = None, source_buildings: str | None = None,
                   textures: Sequence[str] | str | None = None, ortho: str | None = None,
                   mosaic: str | None = None, footprints: str | Sequence[str] | None = None,
                   output_html: str | None = None, output_gpkg: str | None = None,
                   output_buildings_csv: str | None = None, feedback: Feedback = SILENT) -> QualityReport:
    """wit:qualitymetrics: measure what is given and write the tables (all files appear together or none).

    Geometry needs ``model_source`` and ``source_buildings``; texture needs ``textures`` and/or
    ``ortho``; the seam needs ``mosaic`` and ``footprints``. Per-building rows go to
    ``output_buildings_csv`` (default ``<output_csv stem>_buildings.csv``) when geometry is measured.
    """
    if bool(model_source) != bool(source_buildings):
        raise InputError("The geometry comparison needs both the model (CityGML or LoD1 faces) and the prepared "
                         "source buildings.")
    if bool(mosaic) != bool(footprints):
        raise InputError("The seam step needs both the merged mosaic and the tile footprints.")
    if not (model_source or textures or ortho or mosaic):
        raise InputError("Nothing to measure: give the model and source buildings, the textures/orthoimage, "
                         "or the mosaic and tile footprints.")
    steps = [s for s in ("geometry" if model_source else None, "texture" if textures or ortho else None,
                         "seam" if mosaic else None) if s]
    span = 95.0 / len(steps)
    done = 0.0

    def next_feedback() -> Feedback:
        nonlocal done
        done += span
        return feedback.scaled(done - span, done)

    geometry = geometry_metrics(model_source, source_buildings, next_feedback()) if model_source else None
    area = footprints_2d = None
    if geometry is not None:
        sources = [b.geometry for b in geometry.buildings if b.status != MODEL_ONLY and b.geometry is not None]
        if sources:
            footprints_2d = _in_ortho_crs(shapely.multipolygons(shapely.get_parts(np.array(sources, dtype=object))),
                                          geometry.crs_wkt, ortho, feedback)
            area = tuple(footprints_2d.bounds)
    texture = texture_metrics(textures, ortho, area, footprints_2d, next_feedback()) if textures or ortho else None
    seam = seam_metrics(mosaic, footprints, next_feedback()) if mosaic else None
    report = QualityReport(metric_rows(geometry, texture, seam), geometry, texture, seam)
    if not any(math.isfinite(r.value) for r in report.rows if r.value is not None and r.unit != "count"):
        reason = (f": no building of the model ({geometry.model_count}) matches one of the {geometry.source_count} "
                  "source footprints by wit_id; give the prepared buildings the model was made from"
                  if geometry is not None and not geometry.matched else "")
        raise InputError(f"Nothing could be measured{reason}. Nothing was written.")
    targets = {"csv": output_csv}
    if geometry is not None:
        targets["buildings_csv"] = output_buildings_csv or str(Path(output_csv).with_name(
            f"{Path(output_csv).stem}_buildings.csv"))
    if output_gpkg:
        targets["gpkg"] = output_gpkg
    if output_html:
        targets["html"] = output_html
    feedback.check_canceled()
    with contextlib.ExitStack() as stack:  # every file renamed into place only once all are written
        tmp = {key: stack.enter_context(atomic_file(path)) for key, path in targets.items()}
        _write_csv(tmp["csv"], _ROW_FIELDS, ([getattr(r, n) for n in _ROW_FIELDS] for r in report.rows))
        if geometry is not None:
            _write_csv(tmp["buildings_csv"], _BUILDING_FIELDS, (_building_values(b) for b in geometry.buildings))
        if "gpkg" in tmp:
            _write_gpkg(tmp["gpkg"], report.rows, geometry)
        if "html" in tmp:
            _write_html(tmp["html"], report)
    report.outputs = {key: str(path) for key, path in targets.items()}
    feedback.progress(100.0)
    return report
