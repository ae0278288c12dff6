"""Mosaic georeferenced tiles into one raster, block by block (``wit:mergerasters``).

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
  run. The output is a tiled, DEFLATE-compressed GeoTIFF with internal overviews (COG-style); a mosaic the
  next steps read, not kept (the chain's), is compressed for speed instead (``compression="fast"``: ZSTD).

Modules: ``sources`` (the inputs checked, warped if needed and placed on the output grid),
``output`` (tone correction, blending and writing block by block); this one runs the step.
"""
from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from osgeo import gdal, gdal_array

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gdal_env import capped_block_cache
from ..infra.io.fileio import atomic_file
from .output import COMPRESSIONS, MergeReport, _estimate_tone, _write
from .sources import (
    _BlockIndex,
    _bounds,
    _check_coverage,
    _check_inputs,
    _clip_window,
    _direct_tile,
    _grid,
    _open,
    _output_nodata,
    _warp_reason,
    _warped_bounds,
    _warped_tile,
)

MODES = ("feather", "overwrite")


DEFAULT_MAX_EMPTY = 0.9  # refuse a mosaic whose share of pixels no tile covers is larger


def merge_rasters(
    inputs: Sequence[str],
    output: str,
    mode: str = "feather",
    gain: bool | None = None,
    nodata: float | None = None,
    feedback: Feedback = SILENT,
    block_size: int = 1024,
    max_empty: float = DEFAULT_MAX_EMPTY,
    extent: tuple[float, float, float, float] | None = None,
    compression: str = "deflate",
) -> MergeReport:
    """Mosaic ``inputs`` into the GeoTIFF ``output``; see the module docstring for the rules.

    ``gain`` (tone correction: gain and offset) defaults to on with ``feather`` and off with
    ``overwrite``. ``nodata`` overrides the
    inputs' declared NoData. A mosaic more than half empty (tiles far apart) is a warning; one whose
    empty share exceeds ``max_empty`` (0–1; 1 never refuses) is refused before anything is read or
    written. ``extent`` (xmin, ymin, xmax, ymax in the inputs' CRS) writes only the pixels of the
    mosaic's grid that meet it (a study area needs a few hundred metres of sheets that are
    kilometres wide): tone, feathering and every written pixel are those of the whole mosaic.
    ``compression``: one of ``COMPRESSIONS`` (the same pixels either way).
    Raises ``InputError`` for unusable inputs, ``CanceledError`` on cancel (no output is left behind
    in either case).
    """
    if mode not in MODES:
        raise InputError(f"Unknown overlap mode {mode!r}: use one of {', '.join(MODES)}.")
    if not inputs:
        raise InputError("No input rasters given: select at least one tile to merge.")
    if not 0.0 <= max_empty <= 1.0:
        raise InputError(f"Maximum empty share {max_empty:g} is out of range: use 0–1 (0–100 %).")
    if compression not in COMPRESSIONS:
        raise InputError(f"Unknown compression {compression!r}: use one of {', '.join(COMPRESSIONS)}.")
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
        window = (0, 0, width, height)
        if extent is not None:
            window = _clip_window(gt, width, height, extent)
            if window[2:] != (width, height):
                feedback.info(f"Writing the {window[2]} × {window[3]} px window of the {width} × {height} px "
                              f"mosaic that meets the extent {tuple(round(v, 1) for v in extent)}.")
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
            _write(tmp, first, index, report, dtype, feedback, compression)
    feedback.progress(100.0)
    return report
