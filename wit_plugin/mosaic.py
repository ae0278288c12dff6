"""Mosaic georeferenced tiles into one raster, block by block (``wit:mergetiles``, SPEC §2, §5.2).

Two overlap modes:

* ``overwrite``: later tiles overwrite earlier ones where they are covered. This is the paper's
  method and, for inputs on one grid, gives the same pixels as ``gdal_merge.py``.
* ``feather`` (WIT seam interpolation): where tiles overlap, a pixel is Σ wᵢvᵢ / Σ wᵢ with wᵢ the
  distance, in output pixels from the pixel centre, to the nearest edge of tile i's rectangle;
  a NoData pixel has weight 0. Optionally after a per-tile tone correction (``gain``, below).

Guarantees:

* The output grid is the one ``gdal_merge.py`` builds: union extent, first input's pixel size,
  same rounding; each input lands on the same output window as with ``gdal_merge.py``.
* With ``gain`` off, a pixel covered by one tile only is bit-identical to that tile's pixel, in
  both modes: blending is only evaluated where two or more tiles contribute.
* With ``gain`` on (the historical name of the option: it now corrects more than a gain), every
  pixel of tile i becomes gainᵢ·v + offsetᵢ (per band), single-coverage pixels included: that is
  the point (one tone across the mosaic), so they are no longer the source values. Gains and
  offsets are solved over all overlaps at once, robustly, anchored to the mean; heights (one band
  of floats or signed integers) get an offset only, never a gain. See ``tone`` for the model. A
  tile whose correction is the identity keeps its pixels bit for bit.
* NoData (declared, an alpha band or mask, or the ``nodata`` parameter) is "not covered": it is
  never blended as a value. The output declares NoData if any input did.
* Memory does not grow with the mosaic: the output is computed in ``block_size`` windows, each
  input is read only over the window it overlaps, and the GDAL block cache is capped during the
  run. The output is a tiled, DEFLATE-compressed GeoTIFF with internal overviews (COG-style).
"""
from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from osgeo import gdal, gdal_array, osr

from .errors import InputError, WitError
from .feedback import SILENT, Feedback
from .gdal_env import capped_block_cache
from .io.fileio import atomic_file
from .io.raster_io import open_raster, read_window
from .tone import ToneSolver, is_elevation

MODES = ("feather", "overwrite")

_TILE = 512  # output GeoTIFF block size; also the size below which no more overviews are built
_TONE_SAMPLES = 512 * 512  # pixels sampled per overlap to estimate the tone correction
_PIXEL_SIZE_DRIFT = 0.01  # same pixel size if the difference drifts < 1 % of a pixel over a tile
_BLOCKS_SHARE = 85.0  # progress share of the block loop; overviews take the rest
DEFAULT_MAX_EMPTY = 0.9  # refuse a mosaic whose share of pixels no tile covers is larger
_WARN_EMPTY = 0.5  # warn above this empty share
_COVERAGE_CELLS = 1024  # the empty share is measured on a grid of at most this many cells a side


@dataclass
class MergeReport:
    """What ``merge_tiles`` wrote: the output grid, where each input landed, the tone correction used."""

    output: str
    mode: str
    gain: bool
    geotransform: tuple[float, float, float, float, float, float]
    width: int
    height: int
    bands: int
    data_type: str
    crs_wkt: str
    nodata: float | None
    inputs: list[str]
    """The inputs that landed on the grid, in input order (one covering no pixel is skipped)."""
    tile_windows: list[tuple[int, int, int, int]]
    """Each of ``inputs``' (xoff, yoff, width, height) in output pixels (may start before or end after
    the output when ``extent`` clips it)."""
    gains: list[list[float]]
    """Each of ``inputs``' multiplicative gain per band (all 1.0 with gain off, and for heights)."""
    offsets: list[list[float]]
    """Each of ``inputs``' offset per band, added after the gain (all 0.0 with gain off)."""
    resampled: list[str] = field(default_factory=list)
    """Inputs warped onto the output grid because their CRS or pixel size differed."""
    window: tuple[int, int, int, int] = (0, 0, 0, 0)
    """The written pixels (xoff, yoff, width, height) in the whole mosaic's grid (all of it without ``extent``)."""
    covered_pixels: int = 0
    """Output pixels that got a value from at least one input."""
    blended_pixels: int = 0
    """Output pixels that are a weighted mean of two or more inputs (0 in overwrite mode)."""


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


def merge_tiles(
    inputs: Sequence[str],
    output: str,
    mode: str = "feather",
    gain: bool | None = None,
    nodata: float | None = None,
    feedback: Feedback = SILENT,
    block_size: int = 1024,
    max_empty: float = DEFAULT_MAX_EMPTY,
    extent: tuple[float, float, float, float] | None = None,
) -> MergeReport:
    """Mosaic ``inputs`` into the GeoTIFF ``output``; see the module docstring for the rules.

    ``gain`` (tone correction: gain and offset) defaults to on with ``feather`` and off with
    ``overwrite``. ``nodata`` overrides the
    inputs' declared NoData. A mosaic more than half empty (tiles far apart) is a warning; one whose
    empty share exceeds ``max_empty`` (0–1; 1 never refuses) is refused before anything is read or
    written. ``extent`` (xmin, ymin, xmax, ymax in the inputs' CRS) writes only the pixels of the
    mosaic's grid that meet it (a study area needs a few hundred metres of sheets that are
    kilometres wide): tone, feathering and every written pixel are those of the whole mosaic.
    Raises ``InputError`` for unusable inputs, ``CanceledError`` on cancel (no output is left behind
    in either case).
    """
    if mode not in MODES:
        raise InputError(f"Unknown overlap mode {mode!r}: use one of {', '.join(MODES)}.")
    if not inputs:
        raise InputError("No input rasters given: select at least one tile to merge.")
    if not 0.0 <= max_empty <= 1.0:
        raise InputError(f"Maximum empty share {max_empty:g} is out of range: use 0–1 (0–100 %).")
    if block_size < 16:
        raise InputError(f"Block size {block_size} is too small: use at least 16 pixels.")
    use_gain = (mode == "feather") if gain is None else bool(gain)
    with capped_block_cache():
        sources = [_open(path) for path in inputs]  # kept open: warped VRTs read through them
        first = sources[0]
        bands, dtype, crs = _check_inputs(inputs, sources)
        warp_reasons = [_warp_reason(first, ds) for ds in sources]
        warp_reasons[0] = None
        bounds = [_warped_bounds(ds, first, nodata) if why else _bounds(ds)
                  for ds, why in zip(sources, warp_reasons)]
        gt, width, height = _grid(first, bounds)
        tiles = []
        for path, ds, why, bb in zip(inputs, sources, warp_reasons, bounds):
            if why:
                feedback.warning(f"{path}: {why}; resampled (bilinear) onto the first input's grid.")
                tile = _warped_tile(path, ds, first, bb, gt, width, height, nodata)
            else:
                tile = _direct_tile(path, ds, gt, width, height, bands, nodata, feedback)
            if tile is None:
                feedback.warning(f"{path}: covers less than one output pixel; skipped.")
            else:
                tiles.append(tile)
        np_dtype = np.dtype(gdal_array.GDALTypeCodeToNumericTypeCode(dtype))
        out_nodata = _output_nodata(sources, nodata, np_dtype)
        window = _clip_window(gt, width, height, extent) if extent is not None else (0, 0, width, height)
        if window[2:] != (width, height):
            feedback.info(f"Writing the {window[2]} × {window[3]} px window of the {width} × {height} px mosaic "
                          f"that meets the extent {tuple(round(v, 1) for v in extent)}.")
        feedback.info(f"Output grid {width} × {height} px, {bands} band(s) {gdal.GetDataTypeName(dtype)}, "
                      f"pixel size {gt[1]:g} × {-gt[5]:g}, mode {mode}, gain {'on' if use_gain else 'off'}.")
        _check_coverage(tiles, width, height, bands, np_dtype, max_empty, feedback)
        index = _BlockIndex(tiles, block_size)
        if use_gain:
            gains, offsets = _estimate_tone(index, bands, np_dtype, feedback)
            for tile, g, o in zip(tiles, gains, offsets):
                feedback.info(f"Tone {os.path.basename(tile.path)}: gain " + ", ".join(f"{v:.4f}" for v in g)
                              + "; offset " + ", ".join(f"{v:+.2f}" for v in o))
        else:
            gains, offsets = np.ones((len(tiles), bands)), np.zeros((len(tiles), bands))
        x0, y0, width, height = window
        report = MergeReport(
            output=str(output), mode=mode, gain=use_gain,
            geotransform=(gt[0] + x0 * gt[1], gt[1], 0.0, gt[3] + y0 * gt[5], 0.0, gt[5]), width=width,
            height=height, bands=bands, data_type=gdal.GetDataTypeName(dtype), crs_wkt=crs,
            nodata=out_nodata, inputs=[t.path for t in tiles],
            tile_windows=[(t.x0 - x0, t.y0 - y0, t.w, t.h) for t in tiles], window=window,
            gains=gains.tolist(), offsets=offsets.tolist(),
            resampled=[p for p, why in zip(inputs, warp_reasons) if why])
        with atomic_file(output) as tmp:
            _write(tmp, first, index, report, dtype, feedback)
    feedback.progress(100.0)
    return report


# --- inputs -------------------------------------------------------------------------------------

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
    options = dict(format="VRT", resampleAlg="bilinear")
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


# --- reading ------------------------------------------------------------------------------------

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


# --- tone ---------------------------------------------------------------------------------------

def _estimate_tone(index: _BlockIndex, bands: int, np_dtype: np.dtype,
                   feedback: Feedback) -> tuple[np.ndarray, np.ndarray]:
    """Per-tile, per-band gains and offsets that make overlapping tiles agree (see ``tone``).

    Every overlap is read as a decimated sample of about ``_TONE_SAMPLES`` pixels; only pixels
    valid in both tiles count.
    """
    tiles = index.tiles
    solver = ToneSolver(len(tiles), bands, offset_only=is_elevation(bands, np_dtype),
                        ceiling=float(np.iinfo(np_dtype).max) if np_dtype.kind in "iu" else None)
    pairs = index.overlapping_pairs()
    for i, j in pairs:
        feedback.check_canceled()
        win = _intersect(tiles[i].window, tiles[j].window)
        step = max(1, math.ceil(math.sqrt(win[2] * win[3] / _TONE_SAMPLES)))
        da, va = _read(tiles[i], win, bands, np_dtype, step)
        db, vb = _read(tiles[j], win, bands, np_dtype, step)
        joint = va if vb is None else vb if va is None else va & vb
        for band in range(bands):
            solver.add(i, j, band, da[band], db[band], None if joint is None else joint[min(band, len(joint) - 1)])
    if not pairs:
        feedback.info("No tiles overlap: tone left unchanged.")
    elif solver.empty:
        feedback.warning("No overlap with enough valid pixels between the tiles: tone left unchanged.")
    return solver.solve()


def _to_dtype(values: np.ndarray, np_dtype: np.dtype) -> np.ndarray:
    """Round half to even and clip to the type's range for integers; plain cast for floats."""
    if np_dtype.kind in "iu":
        info = np.iinfo(np_dtype)
        return np.clip(np.rint(values), info.min, info.max).astype(np_dtype)
    return values.astype(np_dtype)


class _Tone:
    """Applies one tile's gains and offsets: a lookup table for 8/16-bit unsigned data, else float maths."""

    def __init__(self, gains: np.ndarray, offsets: np.ndarray, np_dtype: np.dtype):
        self.gains, self.offsets, self.dtype = gains, offsets, np_dtype
        self.luts = None
        if np_dtype.kind == "u" and np_dtype.itemsize <= 2:
            domain = np.arange(np.iinfo(np_dtype).max + 1, dtype=np.float64)
            self.luts = [_to_dtype(domain * g + o, np_dtype) for g, o in zip(gains, offsets)]

    def __call__(self, data: np.ndarray) -> np.ndarray:
        if self.luts is None:
            return _to_dtype(data * self.gains[:, None, None] + self.offsets[:, None, None], self.dtype)
        for lut, band in zip(self.luts, data):
            np.take(lut, band, out=band)
        return data


# --- writing ------------------------------------------------------------------------------------

def _creation_options(first: gdal.Dataset, bands: int, np_dtype: np.dtype) -> list[str]:
    options = ["TILED=YES", f"BLOCKXSIZE={_TILE}", f"BLOCKYSIZE={_TILE}", "COMPRESS=DEFLATE",
               f"PREDICTOR={3 if np_dtype.kind == 'f' else 2}", "BIGTIFF=IF_SAFER", "NUM_THREADS=ALL_CPUS"]
    interp = [first.GetRasterBand(b + 1).GetColorInterpretation() for b in range(bands)]
    if np_dtype == np.uint8 and interp[:3] == [gdal.GCI_RedBand, gdal.GCI_GreenBand, gdal.GCI_BlueBand]:
        options.append("PHOTOMETRIC=RGB")
        if bands == 4 and interp[3] == gdal.GCI_AlphaBand:
            options.append("ALPHA=YES")
    return options


def _write(path: os.PathLike, first: gdal.Dataset, index: _BlockIndex, report: MergeReport, dtype: int,
           feedback: Feedback) -> None:
    np_dtype = np.dtype(gdal_array.GDALTypeCodeToNumericTypeCode(dtype))
    try:
        ds = gdal.GetDriverByName("GTiff").Create(str(path), report.width, report.height, report.bands, dtype,
                                                  _creation_options(first, report.bands, np_dtype))
    except RuntimeError as exc:
        raise InputError(f"Cannot create {report.output}: {exc}") from exc
    if ds is None:
        raise InputError(f"Cannot create {report.output}: {gdal.GetLastErrorMsg()}")
    try:
        ds.SetGeoTransform(report.geotransform)
        ds.SetProjection(report.crs_wkt)
        if report.nodata is not None:
            for b in range(report.bands):
                ds.GetRasterBand(b + 1).SetNoDataValue(report.nodata)
        _write_blocks(ds, index, report, np_dtype, feedback.scaled(0, _BLOCKS_SHARE))
        ds.FlushCache()
        _build_overviews(ds, feedback.scaled(_BLOCKS_SHARE, 100))
    finally:
        ds = None  # closes the file before it is renamed or removed


def _write_blocks(ds: gdal.Dataset, index: _BlockIndex, report: MergeReport, np_dtype: np.dtype,
                  feedback: Feedback) -> None:
    """Compute and write the mosaic's ``report.window`` (whole-mosaic pixels) one block at a time."""
    fill = report.nodata if report.nodata is not None else 0
    appliers = [_Tone(np.array(g), np.array(o), np_dtype) if any(v != 1.0 for v in g) or any(o) else None
                for g, o in zip(report.gains, report.offsets)]
    block_size = index.block_size
    gdal_type = gdal_array.NumericTypeCodeToGDALTypeCode(np_dtype)
    x0, y0, width, height = report.window
    for by in range(y0 - y0 % block_size, y0 + height, block_size):
        for bx in range(x0 - x0 % block_size, x0 + width, block_size):
            feedback.check_canceled()
            block = _intersect((bx, by, block_size, block_size), report.window)
            out = np.full((report.bands, block[3], block[2]), fill, np_dtype)
            covered = np.zeros((block[3], block[2]), bool)
            pieces = []
            for k in index.at(bx, by):
                tile = index.tiles[k]
                win = _intersect(block, tile.window)
                if win is None:
                    continue
                data, valid = _read(tile, win, report.bands, np_dtype)
                here = (slice(win[1] - block[1], win[1] - block[1] + win[3]),
                        slice(win[0] - block[0], win[0] - block[0] + win[2]))
                if appliers[k]:
                    data = appliers[k](data)
                if valid is None:
                    out[(slice(None),) + here] = data
                    covered[here] = True
                else:
                    np.copyto(out[(slice(None),) + here], data, where=valid)
                    covered[here] |= valid.any(axis=0)
                pieces.append((tile, win, data, valid))
            if report.mode == "feather" and len(pieces) > 1:
                report.blended_pixels += _blend(out, block, pieces)
            report.covered_pixels += int(np.count_nonzero(covered))
            ds.WriteRaster(block[0] - x0, block[1] - y0, block[2], block[3], out, buf_type=gdal_type)
        feedback.progress(100.0 * min(by + block_size - y0, height) / height)


def _blend(out: np.ndarray, block: tuple[int, int, int, int], pieces: list) -> int:
    """Feather the pixels of ``out`` where two or more tiles are valid; return how many.

    ``pieces`` hold (tile, window, pixels, valid) for each tile over its part of the block, the
    pixels already tone-corrected.
    """
    region = None
    for i, (_, wa, _, _) in enumerate(pieces):
        for _, wb, _, _ in pieces[i + 1:]:
            both = _intersect(wa, wb)
            if both is not None:
                region = both if region is None else _union(region, both)
    if region is None:
        return 0
    rx, ry, rw, rh = region
    bands = out.shape[0]
    count = np.zeros((bands, rh, rw), np.uint8)
    parts = []
    for tile, win, data, valid in pieces:
        sub = _intersect(win, region)
        if sub is None:
            continue
        sx, sy, sw, sh = sub
        src = (slice(sy - win[1], sy - win[1] + sh), slice(sx - win[0], sx - win[0] + sw))
        dst = (slice(sy - ry, sy - ry + sh), slice(sx - rx, sx - rx + sw))
        dx = np.arange(sx, sx + sw) + 0.5 - tile.x0
        dy = np.arange(sy, sy + sh) + 0.5 - tile.y0
        weight = np.minimum.outer(np.minimum(dy, tile.h - dy), np.minimum(dx, tile.w - dx)).astype(np.float32)
        ok = None if valid is None else valid[(slice(None),) + src]
        count[(slice(None),) + dst] += 1 if ok is None else ok
        parts.append((data[(slice(None),) + src], ok, weight, dst))
    blend = count >= 2
    acc = np.empty((rh, rw))
    wsum = np.empty((rh, rw))
    target = out[:, ry - block[1]:ry - block[1] + rh, rx - block[0]:rx - block[0] + rw]
    for band in range(bands):
        if not blend[band].any():
            continue
        acc.fill(0.0)
        wsum.fill(0.0)
        for values, ok, weight, dst in parts:
            w = weight if ok is None else weight * ok[min(band, len(ok) - 1)]
            v = values[band].astype(np.float64)
            if ok is not None and values.dtype.kind == "f":
                v[w == 0] = 0.0  # NaN NoData must not poison the sum
            acc[dst] += w * v
            wsum[dst] += w
        np.divide(acc, wsum, out=acc, where=blend[band])
        np.copyto(target[band], _to_dtype(acc, out.dtype), where=blend[band])
    return int(np.count_nonzero(blend.any(axis=0)))


def _union(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    x0, y0 = min(a[0], b[0]), min(a[1], b[1])
    return x0, y0, max(a[0] + a[2], b[0] + b[2]) - x0, max(a[1] + a[3], b[1] + b[3]) - y0


def _build_overviews(ds: gdal.Dataset, feedback: Feedback) -> None:
    """Internal AVERAGE overviews by factors of 2 until the smallest is under 512 px."""
    size, factor, levels = max(ds.RasterXSize, ds.RasterYSize), 2, []
    while size * 2 / factor > _TILE:
        levels.append(factor)
        factor *= 2
    if not levels:
        return

    def callback(complete: float, _message: str, _data: object) -> int:
        feedback.progress(100.0 * complete)
        return 0 if feedback.is_canceled() else 1

    try:
        failed = ds.BuildOverviews("AVERAGE", levels, callback=callback) != 0
    except RuntimeError:
        failed = True
    feedback.check_canceled()
    if failed:
        raise WitError(f"Building overviews failed: {gdal.GetLastErrorMsg()}")
