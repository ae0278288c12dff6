"""Texture quality, the paper's Table 19: sharpness and contrast of the model's textures and of their source.

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

Model textures: the images of a wit:wittexture folder cut from the orthoimage (mip files and the generated
facades left out: their sharp drawn edges are not the orthoimage's). If the folder holds
``step_layers.TEXCOORD_FILE``, only texels inside the textured rings (their UV polygons rasterised,
pixel centres inside) count, so atlas background and gutters do not; otherwise whole images
count. Values are pooled over all counted pixels of all images (not averaged per image). The
source orthoimage is measured the same way, read in row blocks, NoData excluded: over the model's
area (the bounding box of the source buildings) or a given box, and, given polygons (the
building footprints), over the pixels whose centres are inside them: the pixels the roof
atlases copy, so roof textures and their source compare pixel set for pixel set.
"""
from __future__ import annotations

import math
import os
import re
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from osgeo import gdal, ogr

from ..infra import step_layers
from ..infra.arrays import ragged_indices
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gdal_env import quiet_gdal
from ..infra.io import bulk_read
from ..infra.io.raster_io import open_raster, read_window
from ..infra.texcoords import parse_texcoord_column, unique_texts

BORDERS = ("reflect101", "valid")
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".tif", ".tiff")
_MIP = re.compile(r"_mip\d+$")
_BLOCK_PIXELS = 1 << 21  # pixels per block when streaming a raster (16 MB per float64 array)


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


def open_vector(path: str | os.PathLike) -> ogr.DataSource | None:
    """The OGR data source, or None if GDAL cannot read it as vector data (with or without UseExceptions)."""
    with quiet_gdal():
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
                       and not _MIP.search(p.stem) and not p.name.startswith(".")
                       and not p.name.startswith(step_layers.FACADE_IMAGE_PREFIX))  # drawn, not from the ortho
        if not paths:
            raise InputError(f"{folder} holds no texture images (.jpg, .png, .tif): give the wit:wittexture "
                             "output folder.")
        texcoords = folder / step_layers.TEXCOORD_FILE
        return paths, texcoords if texcoords.exists() else None
    return [Path(p) for p in images], None


def _texcoord_rings(texcoords: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """UV rings per image (relative path as stored) from the wit:wittexture table: (points, points per ring),
    read in bulk and parsed as the 3D Tiles export parses them (the 1 km demo has ~600,000 rings)."""
    ds = open_vector(texcoords)
    layer = None if ds is None else ds.GetLayerByName(step_layers.TEXCOORD_TABLE)
    if layer is None:
        raise InputError(f"{texcoords} has no table '{step_layers.TEXCOORD_TABLE}': re-run wit:wittexture.")
    defn = layer.GetLayerDefn()
    layer.SetIgnoredFields([name for name in (defn.GetFieldDefn(i).GetName() for i in range(defn.GetFieldCount()))
                            if name not in (step_layers.TEX_IMAGE, step_layers.TEX_COORDS)])
    names: list[str] = []
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for batch in bulk_read.batches(layer):
        try:
            points, counts = parse_texcoord_column(batch[step_layers.TEX_COORDS])
        except ValueError as exc:
            raise InputError(f"{texcoords}: texture coordinates that are not pairs of numbers u v: "
                             "re-run wit:wittexture.") from exc
        batch_names, image = unique_texts(batch[step_layers.TEX_IMAGE])
        parts.append((points, counts, image + len(names)))
        names += batch_names
    if not parts or not sum(len(counts) for _, counts, _ in parts):
        return {}
    points, counts, image = (np.concatenate(column) for column in zip(*parts))
    distinct, renumber = np.unique(np.array(names, dtype=object), return_inverse=True)
    image_of = renumber[image]
    order = np.argsort(image_of, kind="stable")  # rings grouped by image, in table order within each
    ring, within = ragged_indices(counts[order])
    points = points[(np.cumsum(counts) - counts)[order][ring] + within]
    ends = np.cumsum(np.bincount(image_of, minlength=len(distinct)))  # rings per image, cumulated
    point_ends = np.concatenate([[0], np.cumsum(counts[order])])[ends]
    rings, first, first_point = {}, 0, 0
    for name, last, last_point in zip(distinct, ends, point_ends):
        rings[name] = (points[first_point:last_point], counts[order][first:last])
        first, first_point = last, last_point
    return rings


class _Burner:
    """Polygons (WKB) in an in-memory OGR layer, rasterised onto any grid: pixels whose centres are inside."""

    def __init__(self, wkbs: Sequence[bytes]):
        self._source = ogr.GetDriverByName("Memory").CreateDataSource("")
        self._layer = self._source.CreateLayer("polygons", None, ogr.wkbUnknown)
        defn = self._layer.GetLayerDefn()
        for wkb in wkbs:
            feature = ogr.Feature(defn)
            feature.SetGeometryDirectly(ogr.CreateGeometryFromWkb(wkb))
            self._layer.CreateFeature(feature)

    def mask(self, width: int, height: int, gt: tuple[float, ...]) -> np.ndarray:
        target = gdal.GetDriverByName("MEM").Create("", width, height, 1, gdal.GDT_Byte)
        target.SetGeoTransform(gt)
        with quiet_gdal():  # "no spatial reference on layer": both sides share one, as intended
            gdal.RasterizeLayer(target, [1], self._layer, burn_values=[1])
        return read_window(target, 0, 0, width, height, "the rasterised polygons (in memory)").astype(bool)


def _multipolygon_wkb(points: np.ndarray, counts: np.ndarray) -> bytes:
    """The rings (``counts`` points each, one after another) as one MultiPolygon's WKB, a polygon per ring.

    Closed rings of one length (the TIN triangles of a ground square) are packed with numpy as fixed-size
    records; any other rings go through shapely (which also closes them).
    """
    size = int(counts[0])
    starts = np.cumsum(counts) - counts
    if (counts == size).all() and (points[starts] == points[starts + size - 1]).all():
        record = np.dtype([("order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"),
                           ("xy", "<f8", (size, 2))])
        polygons = np.zeros(len(counts), dtype=record)
        polygons["order"], polygons["type"], polygons["rings"], polygons["points"] = 1, 3, 1, size
        polygons["xy"] = points.reshape(len(counts), size, 2)
        return struct.pack("<BII", 1, 6, len(counts)) + polygons.tobytes()
    ring_of = np.repeat(np.arange(len(counts)), counts)
    return shapely.to_wkb(shapely.multipolygons(shapely.polygons(shapely.linearrings(points, indices=ring_of))))


def _uv_mask(rings: tuple[np.ndarray, np.ndarray] | None, width: int, height: int) -> np.ndarray:
    """Texels whose centres are inside any UV ring (U right, V up from the bottom edge).

    All rings of an image go to GDAL as one multipolygon (one call, not one feature per ring): the
    rings of an image never overlap (roof islands, TIN triangles), so its even-odd fill is their union.
    """
    if rings is None or not len(rings[1]):
        return np.zeros((height, width), dtype=bool)
    points, counts = rings
    keep = counts >= 3
    if not keep.any():
        return np.zeros((height, width), dtype=bool)
    burner = _Burner([_multipolygon_wkb(points[np.repeat(keep, counts)] * [width, height], counts[keep])])
    return burner.mask(width, height, (0.0, 1.0, 0.0, float(height), 0.0, -1.0))  # ground = (u·W, v·H)


@dataclass
class _Window:
    """Ortho pixels measured together: columns x0..x1 and rows y0..y1 of the raster and, with a burner, only those
    whose centres lie inside its polygons. Its Laplacian reflects at the window's own border."""

    x0: int
    y0: int
    x1: int
    y1: int
    burner: _Burner | None = None
    stats: _Stats = field(default_factory=_Stats)

    def add(self, gray: np.ndarray, valid: np.ndarray, first: int, rows: tuple[int, int], left: int,
            gt: tuple[float, ...]) -> None:
        """Measure the window's share of the block ``rows`` (raster rows r0..r1); ``gray`` and ``valid`` hold
        raster rows ``first``.. and columns ``left``.. and reach one row beyond the block where the raster has it."""
        r0, r1 = max(rows[0], self.y0), min(rows[1], self.y1)
        if r0 >= r1:
            return
        a, b = max(r0 - 1, self.y0), min(r1 + 1, self.y1)  # the rows the Laplacian of rows r0..r1 reads
        cols = slice(self.x0 - left, self.x1 - left)
        gray, valid = gray[a - first:b - first, cols], valid[a - first:b - first, cols].copy()
        width, height = self.x1 - self.x0, self.y1 - self.y0
        if self.burner is not None:
            valid &= self.burner.mask(width, b - a, (gt[0] + self.x0 * gt[1], gt[1], 0.0, gt[3] + a * gt[5], 0.0,
                                                     gt[5]))
        core = slice(r0 - a, r1 - a)
        self.stats.gray.add(gray[core][valid[core]])
        if height >= 2 and width >= 2:
            pad = ((1 if r0 == self.y0 else 0, 1 if r1 == self.y1 else 0), (1, 1))
            g, m = np.pad(gray, pad, mode="reflect"), np.pad(valid, pad, mode="reflect")
            self.stats.lap.add(_laplacian_valid(g)[_eroded(m)])


def _ortho_window(ds: gdal.Dataset, ortho: str, area: tuple[float, float, float, float] | shapely.Geometry | None
                  ) -> _Window:
    """The window of ``area`` (the whole raster if None); a polygonal area also limits the pixels to those whose
    centres lie inside it, with one pixel of margin, so that its border pixels see their real neighbours."""
    gt = ds.GetGeoTransform()
    burner = None
    if isinstance(area, shapely.Geometry):
        burner = _Burner(shapely.to_wkb(shapely.get_parts(area)).tolist())
        x_min, y_min, x_max, y_max = area.bounds
        area = (x_min - abs(gt[1]), y_min - abs(gt[5]), x_max + abs(gt[1]), y_max + abs(gt[5]))
    if area is None:
        return _Window(0, 0, ds.RasterXSize, ds.RasterYSize, burner)
    cols = sorted(((area[0] - gt[0]) / gt[1], (area[2] - gt[0]) / gt[1]))
    rows = sorted(((area[1] - gt[3]) / gt[5], (area[3] - gt[3]) / gt[5]))
    x0, x1 = max(math.floor(cols[0]), 0), min(math.ceil(cols[1]), ds.RasterXSize)
    y0, y1 = max(math.floor(rows[0]), 0), min(math.ceil(rows[1]), ds.RasterYSize)
    if x1 - x0 < 2 or y1 - y0 < 2:
        raise InputError(f"The orthoimage {ortho} does not cover the model's area "
                         f"{tuple(round(v, 1) for v in area)}: give the merged orthoimage of the study area.")
    return _Window(x0, y0, x1, y1, burner)


def _ortho_stats(ortho: str, areas: Sequence[tuple[float, float, float, float] | shapely.Geometry | None],
                 feedback: Feedback) -> list[tuple[_Stats, tuple[float, float, float, float]]]:
    """Streamed measures of the ortho over each of ``areas`` (the window each covers, reflect-101 at its border;
    a polygonal area also limits the pixels to those whose centres lie inside it): one read of the pixels they
    span, in row blocks, for all of them."""
    ds = open_raster(ortho, "orthoimage")
    gt = ds.GetGeoTransform()
    if gt[2] or gt[4]:
        raise InputError(f"{ortho} is rotated; give a north-up orthoimage (wit:mergerasters writes one).")
    windows = [_ortho_window(ds, ortho, area) for area in areas]
    x0, y0 = min(w.x0 for w in windows), min(w.y0 for w in windows)
    x1, y1 = max(w.x1 for w in windows), max(w.y1 for w in windows)
    block_rows = max(8, _BLOCK_PIXELS // (x1 - x0))
    for r0 in range(y0, y1, block_rows):
        feedback.check_canceled()
        r1 = min(r0 + block_rows, y1)
        first = max(r0 - 1, y0)
        gray, valid = _read_gray(ds, x0, first, x1 - x0, min(r1 + 1, y1) - first)
        for window in windows:
            window.add(gray, valid, first, (r0, r1), x0, gt)
        feedback.progress(100.0 * (r1 - y0) / (y1 - y0))
    return [(w.stats, (gt[0] + w.x0 * gt[1], gt[3] + w.y1 * gt[5], gt[0] + w.x1 * gt[1], gt[3] + w.y0 * gt[5]))
            for w in windows]


def texture_metrics(images: Sequence[str] | str | None, ortho: str | None = None,
                    ortho_area: tuple[float, float, float, float] | None = None,
                    ortho_mask: shapely.Geometry | None = None, feedback: Feedback = SILENT,
                    images_ready: Callable[[], None] | None = None) -> TextureMetrics:
    """Sharpness and contrast of the model's texture images (a folder or a list) and of the source ortho.

    ``ortho_area`` (xmin, ymin, xmax, ymax in the ortho's CRS) limits the ortho to the model's area;
    by default the whole ortho is measured. ``ortho_mask`` (polygons in the ortho's CRS, e.g. the
    building footprints) adds ``ortho_inside``: the ortho's pixels that roof textures show, so the
    model's roof atlases and their source can be compared pixel set for pixel set. The orthoimage is read once,
    first; ``images_ready`` is called before the images are (the chain starts the metrics while the texture step
    still writes them).
    """
    if not images and not ortho:
        raise InputError("Give the texture folder (wit:wittexture output), the orthoimage or both.")
    result = TextureMetrics()
    share = 40.0 if images else 100.0
    if ortho:
        areas = [ortho_area] if ortho_mask is None else [ortho_area, ortho_mask]
        measured = _ortho_stats(ortho, areas, feedback.scaled(0.0, share))
        result.ortho, result.ortho_area = measured[0][0].result(str(ortho)), measured[0][1]
        if ortho_mask is not None:
            result.ortho_inside = measured[1][0].result(f"{ortho} (inside the footprints)")
    if images:
        if images_ready is not None:
            images_ready()
        _measure_images(images, result, feedback.scaled(share if ortho else 0.0, 100.0))
    feedback.progress(100.0)
    return result


def _measure_images(images: Sequence[str] | str, result: TextureMetrics, feedback: Feedback) -> None:
    """The model's images into ``result``: each image's measures and the pooled ones."""
    paths, texcoords = _list_images(images)
    rings = _texcoord_rings(texcoords) if texcoords else None
    result.masked = rings is not None
    pooled = _Stats()
    folder = Path(images) if isinstance(images, (str, os.PathLike)) and Path(images).is_dir() else None
    for k, path in enumerate(paths):
        feedback.check_canceled()
        ds = open_raster(str(path), "texture image")
        gray, valid = _read_gray(ds, 0, 0, ds.RasterXSize, ds.RasterYSize)
        if rings is not None and folder is not None:  # rings come from the folder's texcoords file only
            valid &= _uv_mask(rings.get(path.relative_to(folder).as_posix()), ds.RasterXSize, ds.RasterYSize)
        stats = _image_stats(gray, valid)
        pooled.merge(stats)
        result.images.append(stats.result(str(path.relative_to(folder) if folder else path)))
        feedback.progress(100.0 * (k + 1) / len(paths))
    if paths:
        pooled_result = pooled.result("model")
        result.laplacian_variance, result.contrast, result.pixels = (
            pooled_result.laplacian_variance, pooled_result.contrast, pooled_result.pixels)
        if result.pixels == 0:
            feedback.warning("No textured pixel found in the texture images (empty texcoords rings?).")
