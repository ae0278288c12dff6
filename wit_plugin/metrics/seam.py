"""The seam step: how visible the tile borders inside a merged orthoimage mosaic are.

**Seam step.** For every tile edge (from the georef sheet index, layer ``footprints``, or the
tiles' own extents) the part that lies inside another tile, away from the mosaic's border, is
where a visible seam can be. There the step is the mean over bands of |P(left) − P(right)| for the
two mosaic pixels that the edge separates (rows above/below for horizontal edges), averaged over
all such pixel pairs of all edges. The *baseline* is the same mean for the pixel pairs one pixel
either side (the image's own gradient); *excess* = step − baseline is the seam's share. Compare
``overwrite`` with ``feather`` mosaics of the same tiles.
"""
from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from osgeo import gdal, osr

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.layersource import LayerSource
from ..infra.io.raster_io import open_raster, read_window
from .texture import open_vector


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
        source = LayerSource.parse(footprints)
        path = source.file
        if path.is_dir():
            rasters = sorted(str(p) for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff", ".vrt"))
            if not rasters:
                raise InputError(f"{path} holds no georeferenced tiles (.tif, .vrt).")
            return tile_footprints(rasters)
        vector = open_vector(path)
        if vector is None or vector.GetLayerCount() == 0:
            return tile_footprints([str(path)])
        layer = vector.GetLayerByName(source.layer or "footprints") or vector.GetLayer(0)
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
        raise InputError(f"{mosaic} is not a north-up raster; give the output of wit:mergerasters.")
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
