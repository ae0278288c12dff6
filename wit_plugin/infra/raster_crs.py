"""Rasters in another CRS than the model's: which CRS a raster is in, whether that differs from the
model's, and the raster reprojected on the fly to the model's CRS.

The paper unifies the CRSs by reprojecting the rasters itself (bilinear), and so do we: never a full
copy of the input, only the window a step needs, warped in memory or through a VRT in the run's
work folder — nothing is written beside an input. The cell size is the source's, in the target's
units (the smaller of the two axes, to three significant digits), measured at the raster's centre:
every tile of a run gets the same grid; bilinear resampling always weighs the four source cells
around a point, whatever the ratio of the cell sizes.
"""
from __future__ import annotations

import math

import numpy as np
import pyproj
import shapely
from osgeo import gdal
from shapely.geometry.base import BaseGeometry

from .errors import InputError
from .gdal_env import quiet_gdal

Bounds = tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
#: GDAL warp options that keep bilinear resampling to the four surrounding cells even where the
#: target cells are a hair larger than the source's (GDAL widens the kernel when it shrinks)
BILINEAR_FOUR_CELLS = ["XSCALE=1", "YSCALE=1"]


def raster_crs(ds: gdal.Dataset) -> pyproj.CRS | None:
    """The raster's horizontal CRS (a compound CRS's vertical part is left out, so a warp never shifts
    heights), or None when it has none."""
    wkt = ds.GetProjection()
    if not wkt:
        return None
    try:
        crs = pyproj.CRS.from_wkt(wkt)
    except pyproj.exceptions.CRSError:
        return None
    if crs.is_compound:
        crs = next((part for part in crs.sub_crs_list if part.is_projected or part.is_geographic), crs)
    return crs


def raster_extent(gt: tuple[float, ...], cols: int, rows: int) -> Bounds:
    """xmin, ymin, xmax, ymax of a north-up raster."""
    xs = (gt[0], gt[0] + cols * gt[1])
    ys = (gt[3], gt[3] + rows * gt[5])
    return min(xs), min(ys), max(xs), max(ys)


def crs_name(crs: pyproj.CRS) -> str:
    """e.g. "Korea 2000 / Central Belt 2010 (EPSG:5186)"."""
    code = crs.to_authority(min_confidence=90)
    return f"{crs.name} ({':'.join(code)})" if code else crs.name


def crs_code(crs: pyproj.CRS) -> str:
    """e.g. "EPSG:5186", else the CRS's name."""
    code = crs.to_authority(min_confidence=90)
    return ":".join(code) if code else crs.name


def foreign_crs(ds: gdal.Dataset, target: str | pyproj.CRS) -> pyproj.CRS | None:
    """The raster's CRS when it is another than ``target`` (None: the same, or the raster has none).

    Compared by place, not by definition: real DEMs describe EPSG:5186 as a custom "Transverse
    Mercator" on a "GRS80 ELLIPSOID" datum, which is the same CRS (its corners within 0.5 m).
    """
    source = raster_crs(ds)
    if source is None:
        return None
    target = pyproj.CRS.from_user_input(target)
    if source.equals(target, ignore_axis_order=True):
        return None
    x0, y0, x1, y1 = raster_extent(ds.GetGeoTransform(), ds.RasterXSize, ds.RasterYSize)
    xs, ys = np.array([x0, x1, x0, x1]), np.array([y0, y0, y1, y1])
    with np.errstate(invalid="ignore"):
        tx, ty = pyproj.Transformer.from_crs(source, target, always_xy=True).transform(xs, ys)
    shift = np.hypot(np.asarray(tx) - xs, np.asarray(ty) - ys)
    return None if bool(np.all(np.isfinite(shift)) and shift.max() < 0.5) else source


def transform_geometry(geometry: BaseGeometry, source: pyproj.CRS | str, target: pyproj.CRS | str,
                       step: float | None = None) -> BaseGeometry:
    """``geometry`` in ``target``, its edges first cut into pieces of at most ``step`` (default: 1/64 of its
    box's perimeter) so that straight edges may bend as the projection bends them."""
    transformer = pyproj.Transformer.from_crs(source, target, always_xy=True)
    box = geometry.envelope
    dense = shapely.segmentize(geometry, step or max(box.length / 64, 1e-9))
    moved = shapely.transform(dense, lambda xy: np.column_stack(transformer.transform(xy[:, 0], xy[:, 1])))
    if not np.isfinite(shapely.get_coordinates(moved)).all():
        raise InputError(f"Part of the area cannot be expressed in {crs_name(pyproj.CRS(target))}: it lies outside "
                         "that CRS's domain.")
    return moved


def cell_size(ds: gdal.Dataset, source: pyproj.CRS, target: pyproj.CRS | str) -> float:
    """The raster's cell size in ``target`` units, at its centre: the smaller of its two axes, to three
    significant digits (a 5 m DEM in the next belt measures 5.0017 m there: its grid is of 5 m)."""
    gt = ds.GetGeoTransform()
    cx, cy = gt[0] + gt[1] * ds.RasterXSize / 2, gt[3] + gt[5] * ds.RasterYSize / 2
    xs, ys = np.array([cx, cx + gt[1], cx]), np.array([cy, cy, cy + gt[5]])
    tx, ty = pyproj.Transformer.from_crs(source, target, always_xy=True).transform(xs, ys)
    sides = [math.hypot(tx[k] - tx[0], ty[k] - ty[0]) for k in (1, 2)]
    if not all(math.isfinite(s) and s > 0 for s in sides):
        raise InputError(f"The raster's cells cannot be expressed in {crs_name(pyproj.CRS(target))}: its centre lies "
                         "outside that CRS's domain.")
    return float(f"{min(sides):.3g}")


def aligned(bounds: Bounds, size: float, margin_cells: int = 0) -> Bounds:
    """``bounds`` grown outwards to multiples of ``size`` (plus a margin): grids of several windows meet."""
    return ((math.floor(bounds[0] / size) - margin_cells) * size, (math.floor(bounds[1] / size) - margin_cells) * size,
            (math.ceil(bounds[2] / size) + margin_cells) * size, (math.ceil(bounds[3] / size) + margin_cells) * size)


def warp(ds: gdal.Dataset, source: pyproj.CRS, target: pyproj.CRS | str, bounds: Bounds, size: float,
         fmt: str = "MEM", resampling: str = "bilinear", exact: bool = True,
         output_type: int | None = None, nodata: float | None = None, alpha: bool = False) -> gdal.Dataset:
    """The part of ``ds`` over ``bounds`` (target CRS) on a north-up grid of ``size`` cells in ``target``.

    ``fmt`` "MEM" warps now; "VRT" returns a warped VRT (in memory) that warps what is read, when it
    is read. ``exact``: every cell's centre transformed by PROJ (else GDAL interpolates the transform
    to 1/100 of a cell, much faster for imagery). ``alpha``: a last band marks the cells the source
    covers (255) or not (0).
    """
    xmin, ymin, xmax, ymax = bounds
    width, height = max(1, round((xmax - xmin) / size)), max(1, round((ymax - ymin) / size))
    options = gdal.WarpOptions(format=fmt, srcSRS=source.to_wkt(), dstSRS=pyproj.CRS(target).to_wkt(),
                               outputBounds=(xmin, ymax - height * size, xmin + width * size, ymax),
                               width=width, height=height, resampleAlg=resampling,
                               errorThreshold=0.0 if exact else 0.01, warpOptions=BILINEAR_FOUR_CELLS,
                               outputType=output_type or gdal.GDT_Unknown, dstNodata=nodata, dstAlpha=alpha,
                               multithread=False)
    try:
        with quiet_gdal():
            out = gdal.Warp("", ds, options=options)
            reason = gdal.GetLastErrorMsg()
    except RuntimeError as exc:
        out, reason = None, str(exc)
    if out is None:
        raise InputError(f"Cannot reproject {ds.GetDescription() or 'the raster'} to {crs_name(pyproj.CRS(target))}: "
                         f"{reason or 'GDAL could not warp it'}.")
    return out
