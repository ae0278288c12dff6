"""The mosaic's inputs: checked, warped when their grid differs, placed on the output grid and read by window."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from osgeo import gdal, gdal_array, osr

from ..infra.errors import InputError
from ..infra.feedback import Feedback
from ..infra.io.raster_io import open_raster, read_window

_PIXEL_SIZE_DRIFT = 0.01  # same pixel size if the difference drifts < 1 % of a pixel over a tile


_WARN_EMPTY = 0.5  # warn above this empty share


_COVERAGE_CELLS = 1024  # the empty share is measured on a grid of at most this many cells a side


@dataclass
class _Tile:
    """One input, placed on the output grid."""

    path: str
    ds: gdal.Dataset  # what is read: the file itself, or a VRT warping it onto the output grid
    x0: int  # window in output pixels
    y0: int
    w: int
    h: int
    cols: np.ndarray  # source column of each output column of the window (gdal_merge's mapping)
    rows: np.ndarray
    nodata: list[float | None]  # per band; equal values are not covered
    mask: gdal.Band | None  # alpha / mask band: 0 is not covered

    @property
    def window(self) -> tuple[int, int, int, int]:
        return self.x0, self.y0, self.w, self.h


class _BlockIndex:
    """Which tiles touch which output block, so work stays linear in the number of tiles."""

    def __init__(self, tiles: list[_Tile], block_size: int):
        self.tiles, self.block_size = tiles, block_size
        self.cells: dict[tuple[int, int], list[int]] = {}
        for k, t in enumerate(tiles):  # in input order, which overwrite relies on
            for row in range(t.y0 // block_size, (t.y0 + t.h - 1) // block_size + 1):
                for col in range(t.x0 // block_size, (t.x0 + t.w - 1) // block_size + 1):
                    self.cells.setdefault((col, row), []).append(k)

    def at(self, bx: int, by: int) -> list[int]:
        """Indices of the tiles touching the block whose corner is output pixel (bx, by)."""
        return self.cells.get((bx // self.block_size, by // self.block_size), [])

    def overlapping_pairs(self) -> list[tuple[int, int]]:
        pairs = {(a, b) for ks in self.cells.values() for i, a in enumerate(ks) for b in ks[i + 1:]}
        return sorted(p for p in pairs if _intersect(self.tiles[p[0]].window, self.tiles[p[1]].window))


def _open(path: str) -> gdal.Dataset:
    ds = open_raster(path, "tile")
    if ds.RasterCount == 0:
        raise InputError(f"{path} has no raster bands.")
    return ds


def _check_inputs(paths: Sequence[str], sources: list[gdal.Dataset]) -> tuple[int, int, str]:
    """Refuse what cannot be merged; return band count, GDAL data type and CRS of the first input."""
    first = sources[0]
    gt = first.GetGeoTransform(can_return_null=True)
    if gt is None:
        raise InputError(f"{paths[0]} is not georeferenced: georeference it first (wit:georeferencemapsheets).")
    if gt[2] or gt[4] or gt[5] >= 0:
        raise InputError(f"{paths[0]} is rotated or south-up; the first input sets the output grid and must be "
                         "north-up: warp it first (Raster > Projections > Warp) or list another tile first.")
    for path, ds in zip(paths, sources):
        if ds.RasterCount != first.RasterCount:
            raise InputError(f"{path} has {ds.RasterCount} band(s) but {paths[0]} has {first.RasterCount}: "
                             "all tiles must have the same bands (e.g. all RGB).")
        if ds.GetGeoTransform(can_return_null=True) is None:
            raise InputError(f"{path} is not georeferenced: georeference it first (wit:georeferencemapsheets).")
        if bool(ds.GetProjection()) != bool(first.GetProjection()):
            has, lacks = (path, paths[0]) if ds.GetProjection() else (paths[0], path)
            raise InputError(f"{lacks} has no coordinate reference system but {has} has one, so it cannot be "
                             "placed: assign the CRS to every tile (Raster > Projections > Assign Projection).")
    return first.RasterCount, first.GetRasterBand(1).DataType, first.GetProjection()


def _warp_reason(first: gdal.Dataset, ds: gdal.Dataset) -> str | None:
    """Why ``ds`` cannot be copied pixel for pixel onto the first input's grid, or None."""
    if first.GetProjection():
        a, b = osr.SpatialReference(), osr.SpatialReference()
        a.ImportFromWkt(first.GetProjection())
        b.ImportFromWkt(ds.GetProjection())
        if not a.IsSame(b):
            return f"CRS {b.GetName()} differs from the first input's {a.GetName()}"
    gt, ref = ds.GetGeoTransform(), first.GetGeoTransform()
    if gt[2] or gt[4] or gt[5] >= 0:
        return "rotated or south-up geotransform"
    size = max(ds.RasterXSize, ds.RasterYSize)
    drift = max(abs(gt[1] - ref[1]) / ref[1], abs(gt[5] - ref[5]) / -ref[5]) * size
    if drift > _PIXEL_SIZE_DRIFT:
        return f"pixel size {gt[1]:g} × {-gt[5]:g} differs from the first input's {ref[1]:g} × {-ref[5]:g}"
    return None


def _bounds(ds: gdal.Dataset) -> tuple[float, float, float, float]:
    """(ulx, uly, lrx, lry) as gdal_merge computes them."""
    gt = ds.GetGeoTransform()
    return gt[0], gt[3], gt[0] + gt[1] * ds.RasterXSize, gt[3] + gt[5] * ds.RasterYSize


def _warp_options(first: gdal.Dataset, ds: gdal.Dataset, nodata: float | None) -> dict:
    options: dict[str, object] = dict(format="VRT", resampleAlg="bilinear")
    if first.GetProjection():
        options["dstSRS"] = first.GetProjection()
    if nodata is not None:
        options["srcNodata"] = nodata
    if ds.GetRasterBand(ds.RasterCount).GetColorInterpretation() != gdal.GCI_AlphaBand:
        options["dstAlpha"] = True  # marks the pixels the warp leaves empty
    return options


def _warp(ds: gdal.Dataset, **options) -> gdal.Dataset:
    """An in-memory warped VRT of ``ds``; InputError whatever GDAL's exception mode."""
    try:
        vrt = gdal.Warp("", ds, **options)
    except RuntimeError as exc:
        vrt, message = None, str(exc)
    else:
        message = gdal.GetLastErrorMsg()
    if vrt is None:
        raise InputError(f"Cannot resample {ds.GetDescription()} onto the first input's grid: {message}")
    return vrt


def _warped_bounds(ds: gdal.Dataset, first: gdal.Dataset, nodata: float | None) -> tuple[float, float, float, float]:
    """Bounds of ``ds`` in the first input's CRS, as gdalwarp suggests them."""
    ref = first.GetGeoTransform()
    return _bounds(_warp(ds, xRes=ref[1], yRes=-ref[5], **_warp_options(first, ds, nodata)))


def _grid(first: gdal.Dataset, bounds: list[tuple[float, float, float, float]]) -> tuple[list[float], int, int]:
    """Union extent, first pixel size and gdal_merge's size rounding."""
    ulx, uly, lrx, lry = bounds[0]
    for b in bounds:
        ulx, uly, lrx, lry = min(ulx, b[0]), max(uly, b[1]), max(lrx, b[2]), min(lry, b[3])
    ref = first.GetGeoTransform()
    gt = [ulx, ref[1], 0.0, uly, 0.0, ref[5]]
    return gt, int((lrx - ulx) / gt[1] + 0.5), int((lry - uly) / gt[5] + 0.5)


def _clip_window(gt: list[float], width: int, height: int,
                 extent: tuple[float, float, float, float]) -> tuple[int, int, int, int]:
    """The pixels (x0, y0, w, h) of the grid that meet ``extent`` (xmin, ymin, xmax, ymax)."""
    xmin, ymin, xmax, ymax = extent
    x0 = max(0, math.floor((xmin - gt[0]) / gt[1]))
    x1 = min(width, math.ceil((xmax - gt[0]) / gt[1]))
    y0 = max(0, math.floor((ymax - gt[3]) / gt[5]))
    y1 = min(height, math.ceil((ymin - gt[3]) / gt[5]))
    if x1 <= x0 or y1 <= y0:
        raise InputError(f"The tiles (x {gt[0]:.1f}–{gt[0] + width * gt[1]:.1f}, y {gt[3] + height * gt[5]:.1f}–"
                         f"{gt[3]:.1f}) do not meet the extent x {xmin:.1f}–{xmax:.1f}, y {ymin:.1f}–{ymax:.1f}.")
    return x0, y0, x1 - x0, y1 - y0


def _direct_tile(path: str, ds: gdal.Dataset, gt: list[float], width: int, height: int, bands: int,
                 nodata: float | None, feedback: Feedback) -> _Tile | None:
    """Place ``ds`` with gdal_merge's window arithmetic (file_info.copy_into), bit for bit."""
    ulx, uly, lrx, lry = _bounds(ds)
    sgt = ds.GetGeoTransform()
    t_lrx, t_lry = gt[0] + width * gt[1], gt[3] + height * gt[5]
    gx0, gx1 = max(gt[0], ulx), min(t_lrx, lrx)
    gy0, gy1 = min(gt[3], uly), max(t_lry, lry)
    if gx0 >= gx1 or gy0 <= gy1:
        return None
    tx, ty = int((gx0 - gt[0]) / gt[1] + 0.1), int((gy0 - gt[3]) / gt[5] + 0.1)
    tw, th = int((gx1 - gt[0]) / gt[1] + 0.5) - tx, int((gy1 - gt[3]) / gt[5] + 0.5) - ty
    sx, sy = int((gx0 - sgt[0]) / sgt[1] + 0.1), int((gy0 - sgt[3]) / sgt[5] + 0.1)
    sw, sh = int((gx1 - sgt[0]) / sgt[1] + 0.5) - sx, int((gy1 - sgt[3]) / sgt[5] + 0.5) - sy
    if min(tw, th, sw, sh) < 1:
        return None
    shift = max(abs(d - round(d)) for d in ((ulx - gt[0]) / gt[1], (uly - gt[3]) / gt[5]))
    if shift > 0.01:
        feedback.warning(f"{path}: origin is {shift:.2f} px off the output grid; snapped to it as gdal_merge "
                         "does (nearest-neighbour, shift under one pixel).")
    band1 = ds.GetRasterBand(1)
    declared = [ds.GetRasterBand(b + 1).GetNoDataValue() for b in range(bands)]
    mask = None
    if nodata is None and not any(v is not None for v in declared):
        flags = band1.GetMaskFlags()
        if not flags & gdal.GMF_ALL_VALID and flags & gdal.GMF_PER_DATASET:
            mask = band1.GetMaskBand()  # alpha band or internal mask
    return _Tile(path, ds, tx, ty, tw, th, _index_map(sx, sw, tw, ds.RasterXSize),
                 _index_map(sy, sh, th, ds.RasterYSize),
                 [nodata] * bands if nodata is not None else declared, mask)


def _index_map(offset: int, src_size: int, dst_size: int, limit: int) -> np.ndarray:
    """Source index of each destination index: GDAL's nearest-neighbour RasterIO rule."""
    i = np.arange(dst_size, dtype=np.float64)
    return np.clip(np.floor((i + 0.5) * (src_size / dst_size) + offset + 1e-10), 0, limit - 1).astype(np.int64)


def _warped_tile(path: str, ds: gdal.Dataset, first: gdal.Dataset, bounds: tuple[float, float, float, float],
                 gt: list[float], width: int, height: int, nodata: float | None) -> _Tile | None:
    """Warp ``ds`` into a VRT whose pixels are exactly a window of the output grid."""
    x0 = max(0, math.floor((bounds[0] - gt[0]) / gt[1] + 1e-6))
    x1 = min(width, math.ceil((bounds[2] - gt[0]) / gt[1] - 1e-6))
    y0 = max(0, math.floor((bounds[1] - gt[3]) / gt[5] + 1e-6))
    y1 = min(height, math.ceil((bounds[3] - gt[3]) / gt[5] - 1e-6))
    if x1 <= x0 or y1 <= y0:
        return None
    extent = (gt[0] + x0 * gt[1], gt[3] + y1 * gt[5], gt[0] + x1 * gt[1], gt[3] + y0 * gt[5])
    vrt = _warp(ds, outputBounds=extent, width=x1 - x0, height=y1 - y0, **_warp_options(first, ds, nodata))
    return _Tile(path, vrt, x0, y0, x1 - x0, y1 - y0, np.arange(x1 - x0), np.arange(y1 - y0),
                 [None] * ds.RasterCount, vrt.GetRasterBand(vrt.RasterCount))


def _check_coverage(tiles: list[_Tile], width: int, height: int, bands: int, np_dtype: np.dtype,
                    max_empty: float, feedback: Feedback) -> None:
    """Warn when the mosaic is mostly empty, refuse beyond ``max_empty``: tiles kilometres apart
    would otherwise silently become a huge file of NoData.

    The empty share is measured on a coarse grid where a cell touched by a tile counts as covered,
    so it never overstates the emptiness.
    """
    cell = max(1, math.ceil(max(width, height) / _COVERAGE_CELLS))
    covered = np.zeros((-(-height // cell), -(-width // cell)), bool)
    for t in tiles:
        covered[t.y0 // cell:-(-(t.y0 + t.h) // cell), t.x0 // cell:-(-(t.x0 + t.w) // cell)] = True
    empty = 1.0 - covered.mean() if tiles else 1.0
    if empty <= _WARN_EMPTY:
        return
    size = f"{width:,} × {height:,} px, {width * height * bands * np_dtype.itemsize / 1e9:.1f} GB uncompressed"
    if empty > max_empty:
        raise InputError(f"The mosaic would be {size}, and about {empty:.0%} of it would be empty (no tile "
                         f"covers it): the {len(tiles)} tiles lie far apart. Merge the tiles of each area "
                         f"separately, or raise the maximum empty share (now {max_empty:.0%}) to write it anyway.")
    feedback.warning(f"The mosaic is {size}, and about {empty:.0%} of it is empty (no tile covers it): the tiles "
                     "lie far apart.")


def _output_nodata(sources: list[gdal.Dataset], nodata: float | None, np_dtype: np.dtype) -> float | None:
    """The parameter, else the first NoData any input declares; it must fit the output type."""
    value = nodata
    for ds in sources:
        for b in range(ds.RasterCount):
            if value is None:
                value = ds.GetRasterBand(b + 1).GetNoDataValue()
    if value is not None and np_dtype.kind in "iu":
        info = np.iinfo(np_dtype)
        if not (float(value).is_integer() and info.min <= value <= info.max):
            raise InputError(f"NoData {value:g} does not fit the {np_dtype.name} output "
                             f"(range {info.min}..{info.max}): give a NoData value inside that range.")
    return value


def _intersect(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> tuple[int, int, int, int] | None:
    x0, y0 = max(a[0], b[0]), max(a[1], b[1])
    x1, y1 = min(a[0] + a[2], b[0] + b[2]), min(a[1] + a[3], b[1] + b[3])
    return (x0, y0, x1 - x0, y1 - y0) if x1 > x0 and y1 > y0 else None


def _read(tile: _Tile, win: tuple[int, int, int, int], bands: int, np_dtype: np.dtype,
          step: int = 1) -> tuple[np.ndarray, np.ndarray | None]:
    """Pixels of ``tile`` over the output window ``win``, and where they are valid (None: all).

    ``step`` > 1 reads a decimated sample (for tone estimation) instead of every pixel.
    """
    x, y, w, h = win
    cols = tile.cols[x - tile.x0:x - tile.x0 + w]
    rows = tile.rows[y - tile.y0:y - tile.y0 + h]
    c0, r0 = int(cols[0]), int(rows[0])
    cw, rh = int(cols[-1]) - c0 + 1, int(rows[-1]) - r0 + 1
    buf = (-(-w // step), -(-h // step)) if step > 1 else (cw, rh)
    pick = None if step > 1 or (cw == w and rh == h) else np.ix_(rows - r0, cols - c0)
    data = read_window(tile.ds, c0, r0, cw, rh, f"the tile {tile.path}", buf_xsize=buf[0], buf_ysize=buf[1],
                       band_list=list(range(1, bands + 1)), buf_type=gdal_array.NumericTypeCodeToGDALTypeCode(np_dtype))
    data = data.reshape(bands, buf[1], buf[0])
    if pick is not None:
        data = data[(slice(None),) + pick]
    invalid = None
    if any(v is not None for v in tile.nodata):
        invalid = np.zeros(data.shape, bool)
        for b, v in enumerate(tile.nodata):
            if v is not None:
                value = np_dtype.type(v) if np_dtype.kind == "f" else v  # float32 NoData compares as float32
                invalid[b] = np.isnan(data[b]) if math.isnan(v) else data[b] == value
    if np_dtype.kind == "f":
        nan = np.isnan(data)
        if nan.any():
            invalid = nan if invalid is None else invalid | nan
    if tile.mask is not None:
        mask = read_window(tile.mask, c0, r0, cw, rh, f"the mask of the tile {tile.path}", buf_xsize=buf[0],
                           buf_ysize=buf[1])
        mask = (mask[pick] if pick is not None else mask)[None] == 0
        invalid = mask if invalid is None else invalid | mask
    if invalid is None or not invalid.any():
        return data, None
    return data, ~invalid
