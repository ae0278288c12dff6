"""Opening and reading input rasters: checked, named, and writing nothing beside them.

Whatever the host did with ``gdal.UseExceptions()`` (QGIS leaves it off, some plugins and scripts
turn it on), a failed open or read ends the same way here: ``InputError`` naming the file, the
band and window, and GDAL's reason; nothing goes to stderr. ``open_raster`` opens with PAM off
unless an ``.aux.xml`` is already there (read, never written), so none is ever written beside an input.
"""
from __future__ import annotations

import os

import numpy as np
from osgeo import gdal

from ..errors import InputError
from ..gdal_env import quiet_gdal, thread_config

DAMAGED_HINT = "the file may be truncated or damaged: copy it again from its source"


def raster_file_problem(path: str | os.PathLike) -> str | None:
    """What stops ``path`` from being a raster GDAL can open (missing, empty, unreadable), or None."""
    try:
        open_raster(path)
    except InputError as exc:
        return str(exc)
    return None


def open_raster(path: str | os.PathLike, what: str = "raster") -> gdal.Dataset:
    """Open the input raster ``path`` read-only without writing beside it, or raise ``InputError``.

    Refused: a missing or empty file, GDAL's failure to open it, an open that succeeded with
    errors (a damaged header), and a GeoTIFF whose pixel data runs past the end of the file. An
    existing ``.aux.xml`` is still read (it may hold the georeferencing or NoData); nothing is ever
    written to it.
    """
    path = str(path)
    if not path.startswith("/vsi") and not os.path.isdir(path):
        if not os.path.exists(path):
            raise InputError(f"The {what} {path} does not exist.")
        if os.path.getsize(path) == 0:
            raise InputError(f"The {what} {path} is empty (0 bytes): {DAMAGED_HINT}.")
    keep_pam = os.path.exists(f"{path}.aux.xml")
    with thread_config(GDAL_PAM_ENABLED=None if keep_pam else "NO"):
        try:
            with quiet_gdal():
                ds = gdal.OpenEx(path, gdal.OF_RASTER | gdal.OF_READONLY | gdal.OF_VERBOSE_ERROR)
                failed = ds is None or gdal.GetLastErrorType() >= gdal.CE_Failure
                if not failed:
                    ds.GetGeoTransform()  # fixes the dataset's PAM state while PAM is off
                reason = gdal.GetLastErrorMsg()
        except RuntimeError as exc:  # with gdal.UseExceptions()
            ds, failed, reason = None, True, str(exc)
    if failed:
        raise InputError(f"Cannot open the {what} {path}: {reason.rstrip('. ') or 'not a raster format GDAL reads'}.")
    end = _pixel_data_end(ds)
    if os.path.isfile(path) and end > os.path.getsize(path):
        raise InputError(f"The {what} {path} is truncated: its pixel data runs to byte {end:,} but the file has "
                         f"{os.path.getsize(path):,} bytes; {DAMAGED_HINT}.")
    return ds


def _pixel_data_end(ds: gdal.Dataset) -> int:
    """Where a GeoTIFF's last block of each band ends (0 for other formats): checked against the
    file size, it finds a truncated copy up front instead of halfway through a run."""
    if ds.GetDriver().ShortName != "GTiff" or ds.RasterCount == 0:
        return 0
    end = 0
    for number in range(1, ds.RasterCount + 1):
        band = ds.GetRasterBand(number)
        bx, by = band.GetBlockSize()
        last = f"{(ds.RasterXSize - 1) // bx}_{(ds.RasterYSize - 1) // by}"
        offset, size = (band.GetMetadataItem(f"BLOCK_{key}_{last}", "TIFF") for key in ("OFFSET", "SIZE"))
        if offset and size:
            end = max(end, int(offset) + int(size))
    return end


def read_window(source: gdal.Dataset | gdal.Band, xoff: int, yoff: int, xsize: int, ysize: int, what: str,
                **options) -> np.ndarray:
    """``source.ReadAsArray`` of one window, or ``InputError`` naming ``what`` (the file), the band(s),
    the window and GDAL's reason, with or without GDAL exceptions. ``options``: ReadAsArray's."""
    try:
        with quiet_gdal():
            data = source.ReadAsArray(xoff, yoff, xsize, ysize, **options)
            failed = data is None or gdal.GetLastErrorType() >= gdal.CE_Failure
            reason = gdal.GetLastErrorMsg()
    except RuntimeError as exc:  # with gdal.UseExceptions()
        failed, reason = True, str(exc)
    if failed:
        if isinstance(source, gdal.Band):
            bands = f", band {source.GetBand()}"
        else:
            bands = ", bands " + ", ".join(map(str, options.get("band_list") or range(1, source.RasterCount + 1)))
        raise InputError(f"Cannot read {what}{bands}, pixels x {xoff}–{xoff + xsize - 1}, y {yoff}–{yoff + ysize - 1}: "
                         f"{reason.rstrip('. ') or 'read error'}; {DAMAGED_HINT}.")
    return data


def fill_nodata(band: gdal.Band, mask: gdal.Band, max_distance: float) -> None:
    """GDAL's inverse-distance fill of ``band`` where ``mask`` is 0 (in place, no smoothing), its work rasters in
    memory: by default GDAL writes three GeoTIFFs into the current folder, which inside QGIS may be one the user
    cannot write (the fill then fails) and which a killed process leaves there."""
    gdal.FillNodata(band, mask, max_distance, 0, options=["TEMP_FILE_DRIVER=MEM"])
