"""The mosaic as written: per-tile tone correction, blending where tiles overlap, blocks, overviews."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np
from osgeo import gdal, gdal_array

from ..infra.errors import InputError, WitError
from ..infra.feedback import Feedback
from .sources import _BlockIndex, _intersect, _read
from .tone import ToneSolver, is_elevation

_TILE = 512  # output GeoTIFF block size; also the size below which no more overviews are built


_TONE_SAMPLES = 512 * 512  # pixels sampled per overlap to estimate the tone correction


_BLOCKS_SHARE = 85.0  # progress share of the block loop; overviews take the rest


@dataclass
class MergeReport:
    """What ``merge_rasters`` wrote: the output grid, where each input landed, the tone correction used."""

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
        if win is None:  # (never: the pair overlaps)
            continue
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


#: ``deflate``: the mosaic as a product (read everywhere); ``fast``: one the next steps read and nobody keeps (the
#: chain's work mosaic): ZSTD at its fastest level, 2.0 instead of 3.5 CPU-s to write the 1 km sample's (45 MB, not
#: 41), DEFLATE at its fastest where GDAL was built without ZSTD
COMPRESSIONS = ("deflate", "fast")


def _compress_options(compression: str) -> list[str]:
    if compression == "deflate":
        return ["COMPRESS=DEFLATE"]
    creation = gdal.GetDriverByName("GTiff").GetMetadataItem("DMD_CREATIONOPTIONLIST") or ""
    return ["COMPRESS=ZSTD", "ZSTD_LEVEL=1"] if "ZSTD" in creation else ["COMPRESS=DEFLATE", "ZLEVEL=1"]


def _creation_options(first: gdal.Dataset, bands: int, np_dtype: np.dtype, compression: str) -> list[str]:
    options = ["TILED=YES", f"BLOCKXSIZE={_TILE}", f"BLOCKYSIZE={_TILE}", *_compress_options(compression),
               f"PREDICTOR={3 if np_dtype.kind == 'f' else 2}", "BIGTIFF=IF_SAFER", "NUM_THREADS=ALL_CPUS"]
    interp = [first.GetRasterBand(b + 1).GetColorInterpretation() for b in range(bands)]
    if np_dtype == np.uint8 and interp[:3] == [gdal.GCI_RedBand, gdal.GCI_GreenBand, gdal.GCI_BlueBand]:
        options.append("PHOTOMETRIC=RGB")
        if bands == 4 and interp[3] == gdal.GCI_AlphaBand:
            options.append("ALPHA=YES")
    return options


def _write(path: os.PathLike, first: gdal.Dataset, index: _BlockIndex, report: MergeReport, dtype: int,
           feedback: Feedback, compression: str) -> None:
    np_dtype = np.dtype(gdal_array.GDALTypeCodeToNumericTypeCode(dtype))
    try:
        ds = gdal.GetDriverByName("GTiff").Create(str(path), report.width, report.height, report.bands, dtype,
                                                  _creation_options(first, report.bands, np_dtype, compression))
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
            if block is None:  # (never: the blocks are those the window meets)
                continue
            out = np.full((report.bands, block[3], block[2]), fill, np_dtype)
            covered = np.zeros((block[3], block[2]), np.bool_)
            pieces = []
            for k in index.at(bx, by):
                tile = index.tiles[k]
                win = _intersect(block, tile.window)
                if win is None:
                    continue
                data, valid = _read(tile, win, report.bands, np_dtype)
                here = (slice(win[1] - block[1], win[1] - block[1] + win[3]),
                        slice(win[0] - block[0], win[0] - block[0] + win[2]))
                applier = appliers[k]
                if applier:
                    data = applier(data)
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
