"""Georeference NGII orthoimage TIFs from the sheet number in their file names (wit:georeferencemapsheets).

NGII hands out orthoimage tiles without any georeferencing; each covers its map sheet's projected
envelope plus about 50 m, pixels aligned with the target CRS axes. So the geotransform
follows from the name alone: origin at the envelope's top-left corner, pixel size = extent / pixels.

Outputs go to a staging folder inside the output folder and are moved into place only when the
whole batch has run, so a cancelled or crashed run leaves the output folder as it was. A file
that cannot be used (no sheet number, unreadable, duplicate sheet) is reported and skipped; the
batch goes on.
"""
from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET  # nosec B405  # parses only the VRT XML that GDAL made here (_write_vrt_xml)
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pyproj
import shapely
from osgeo import gdal, ogr, osr
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gdal_env import quiet_gdal, thread_config
from ..infra.io.fileio import atomic_file, atomic_files, ensure_writable_dir
from ..infra.io.raster_io import open_raster
from ..infra.mapsheet import find_sheet_in_name, projected_envelope
from ..infra.raster_crs import aligned, cell_size, crs_code, foreign_crs, raster_extent, transform_geometry, warp

OK, SKIPPED, FAILED = "ok", "skipped", "failed"
FORMATS = {"GTiff": ".tif", "VRT": ".vrt"}
TIF_SUFFIXES = (".tif", ".tiff")
INDEX_LAYER = "footprints"
WARPED_SUFFIX = ".warped.vrt"  # beside <sheet>.vrt: a TIF in another CRS, reprojected as it is read
_LISTED = 10  # inputs whose reasons are listed when none could be georeferenced
#: columns of the footprint index (SheetResult attributes), shared with the Processing glue
INDEX_FIELDS = (("sheet", str), ("scale", int), ("source", str), ("status", str), ("reason", str), ("output", str))


@dataclass
class SheetResult:
    """What happened to one input file; one row of the footprint index."""

    source: str
    sheet: str | None = None
    scale: int | None = None
    status: str = SKIPPED
    reason: str = ""
    output: str | None = None
    bounds: tuple[float, float, float, float] | None = None  # xmin, ymin, xmax, ymax incl. margin


def list_tifs(folder_or_files: str | os.PathLike | Sequence[str | os.PathLike]) -> list[str]:
    """The TIFs to process: a folder's *.tif/*.tiff (not recursive, sorted) and/or explicit files."""
    items = [folder_or_files] if isinstance(folder_or_files, (str, os.PathLike)) else list(folder_or_files)
    found: list[str] = []
    for item in items:
        path = Path(item)
        if path.is_dir():
            found += sorted(str(p) for p in path.iterdir() if p.is_file() and p.suffix.lower() in TIF_SUFFIXES)
        elif path.is_file():
            found.append(str(path))
        else:
            raise InputError(f"Input {path} does not exist.")
    if not found:
        raise InputError(f"No .tif or .tiff files in {', '.join(map(str, items)) or 'the input list'}.")
    return list(dict.fromkeys(found))


def _srs(crs: str) -> osr.SpatialReference:
    srs = osr.SpatialReference()
    try:
        with quiet_gdal():
            failed = srs.SetFromUserInput(crs) != 0
    except RuntimeError:
        failed = True
    if failed:
        raise InputError(f"Unknown coordinate reference system '{crs}'.")
    srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    return srs


def _open(path: str) -> tuple[gdal.Dataset | None, str]:
    """The source, or None and why not (missing, empty, damaged, not a raster)."""
    try:
        return open_raster(path, "orthoimage"), ""
    except InputError as exc:
        return None, str(exc)


def _plan(sources: Sequence[str], out_dir: Path, suffix: str, target_crs: str, source_crs: str,
          margin: float) -> list[SheetResult]:
    """Read every name first, so skips are known before any pixel is touched."""
    results: list[SheetResult] = []
    taken: dict[str, str] = {}  # sheet number → the file it comes from
    for source in sources:
        result = SheetResult(source=source)
        results.append(result)
        try:
            sheet = find_sheet_in_name(Path(source).name)
        except InputError as exc:
            result.reason = str(exc)
            continue
        result.sheet, result.scale = sheet.number, sheet.scale
        output = out_dir / f"{sheet.number}{suffix}"
        if sheet.number in taken:
            result.reason = f"sheet {sheet.number} already comes from {taken[sheet.number]}"
        elif os.path.realpath(output) == os.path.realpath(source):
            result.reason = f"the output {output} would replace the source; choose another output folder"
        else:
            try:
                result.bounds = projected_envelope(sheet, target_crs, source_crs, margin)
            except InputError as exc:
                result.status, result.reason = FAILED, str(exc)
                continue
            taken[sheet.number] = source
            result.output = str(output)
    return results


def _creation_options(ds: gdal.Dataset) -> list[str]:
    """Tiled, lossless, compressed; predictor 2 for integers, 3 for floats."""
    options = ["TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "COMPRESS=DEFLATE", "BIGTIFF=IF_SAFER",
               "NUM_THREADS=ALL_CPUS"]
    data_type = ds.GetRasterBand(1).DataType if ds.RasterCount else gdal.GDT_Byte
    if data_type in (gdal.GDT_Float32, gdal.GDT_Float64):
        options.append("PREDICTOR=3")
    elif data_type in (gdal.GDT_Byte, gdal.GDT_UInt16, gdal.GDT_Int16, gdal.GDT_UInt32, gdal.GDT_Int32):
        options.append("PREDICTOR=2")
    return options


def _write_geotiff(src: gdal.Dataset, target: Path, ullr: list[float] | None, crs: str | None,
                   feedback: Feedback) -> str:
    """Copy the pixels into a georeferenced GeoTIFF (``ullr`` and ``crs`` None: the source's georeference);
    returns an error message or ''."""
    def callback(complete: float, _message: str, _data: object) -> int:
        feedback.progress(100.0 * complete)
        return 0 if feedback.is_canceled() else 1

    options = gdal.TranslateOptions(format="GTiff", outputSRS=crs, outputBounds=ullr,
                                    creationOptions=_creation_options(src), callback=callback)
    try:
        with quiet_gdal():
            ds = gdal.Translate(str(target), src, options=options)
            message = gdal.GetLastErrorMsg()
    except RuntimeError as exc:
        ds, message = None, str(exc)
    feedback.check_canceled()
    if ds is None:
        return message or "GDAL could not write the GeoTIFF"
    del ds  # flush and close before the file is moved
    return ""


def _write_vrt(src: gdal.Dataset, source: str, target: Path, final_dir: Path, ullr: list[float], crs: str) -> str:
    """A VRT that points at the untouched source pixels, by a path relative to its final folder."""
    try:
        with quiet_gdal():
            vrt = gdal.Translate("", src, options=gdal.TranslateOptions(format="VRT", outputSRS=crs, outputBounds=ullr))
            message = gdal.GetLastErrorMsg()
    except RuntimeError as exc:
        vrt, message = None, str(exc)
    if vrt is None:
        return message or "GDAL could not build the VRT"
    xml = vrt.GetMetadata("xml:VRT")[0]
    vrt = None
    _write_vrt_xml(xml, source, target, final_dir)
    return ""


def _write_vrt_xml(xml: str, source: str, target: Path, final_dir: Path | None) -> None:
    """Write a VRT whose source is ``source``: by a path relative to ``final_dir`` (where the VRT will
    live), or absolute when there is none or no relative path exists (another drive on Windows)."""
    root = ET.fromstring(xml)  # nosec B314  # GDAL's own VRT of this run, not a file from outside
    href, relative = os.path.abspath(source), "0"
    if final_dir is not None:
        try:
            href, relative = Path(os.path.relpath(os.path.abspath(source), os.path.abspath(final_dir))).as_posix(), "1"
        except ValueError:
            pass
    for element in (*root.iter("SourceFilename"), *root.iter("SourceDataset")):
        element.text = href
        element.set("relativeToVRT", relative)
    target.write_text(ET.tostring(root, encoding="unicode"), encoding="utf-8")


def georeference_sheets(inputs: Sequence[str], output_dir: str | os.PathLike, target_crs: str = "EPSG:5186",
                        source_crs: str = "EPSG:4737", margin: float = 50.0, fmt: str = "GTiff",
                        feedback: Feedback = SILENT) -> list[SheetResult]:
    """Write ``<sheet>.tif`` (or ``.vrt``) for every input whose name carries a valid sheet number.

    Returns one result per input, in input order; some may be skipped or failed (warnings). Raises
    InputError for bad parameters, an unwritable output folder, or when no input could be
    georeferenced at all (the message lists why for each), CanceledError if cancelled (then nothing
    is written).
    """
    if fmt not in FORMATS:
        raise InputError(f"Unknown output format '{fmt}'; use one of {', '.join(FORMATS)}.")
    if not (math.isfinite(margin) and margin >= 0):
        raise InputError(f"The margin must be a non-negative number of metres, not {margin}.")
    _srs(target_crs)
    _srs(source_crs)
    out_dir = ensure_writable_dir(output_dir)
    results = _plan(inputs, out_dir, FORMATS[fmt], target_crs, source_crs, margin)
    planned = [r for r in results if r.output]
    for result in results:
        if not result.output:
            feedback.warning(f"{result.status.capitalize()} {result.source}: {result.reason}")
    if planned:
        with atomic_files([r.output for r in planned if r.output]) as staging:  # (all: planned have one)
            for i, result in enumerate(planned):
                feedback.check_canceled()
                step = feedback.scaled(100.0 * i / len(planned), 100.0 * (i + 1) / len(planned))
                _process(result, staging, out_dir, target_crs, fmt, step)
                step.progress(100.0)
    feedback.progress(100.0)
    counts = {s: sum(r.status == s for r in results) for s in (OK, SKIPPED, FAILED)}
    if not counts[OK]:
        reasons = "".join(f"\n  {Path(r.source).name}: {r.status}, {r.reason}" for r in results[:_LISTED])
        more = f"\n  … and {len(results) - _LISTED} more" if len(results) > _LISTED else ""
        raise InputError(f"No orthoimage TIF could be georeferenced ({counts[SKIPPED]} skipped, {counts[FAILED]} "
                         f"failed):{reasons}{more}")
    feedback.info(f"Georeferenced {counts[OK]} sheet(s); skipped {counts[SKIPPED]}, failed {counts[FAILED]}.")
    return results


def _process(result: SheetResult, staging: Path, out_dir: Path, target_crs: str, fmt: str,
             feedback: Feedback) -> None:
    """Georeference one planned input into the staging folder; record failure instead of raising."""
    if result.output is None or result.bounds is None:  # (``_plan`` sets both of a planned input)
        raise ValueError(f"{result.source} is not planned: it has no output or no bounds.")
    target = staging / Path(result.output).name
    src, message = _open(result.source)
    if src is None:
        _fail(result, message, feedback)
        return
    own = _own_crs(src, target_crs)
    if own is not None:
        _reprojected(result, src, own, staging, target, out_dir, target_crs, fmt, feedback)
        return
    xmin, ymin, xmax, ymax = result.bounds
    ullr = [xmin, ymax, xmax, ymin]
    try:
        if fmt == "GTiff":
            error = _write_geotiff(src, target, ullr, target_crs, feedback)
        else:
            error = _write_vrt(src, result.source, target, out_dir, ullr, target_crs)
    except OSError as exc:
        error = str(exc)
    if error:
        target.unlink(missing_ok=True)
        _fail(result, error, feedback)
        return
    result.status = OK
    feedback.info(f"{Path(result.source).name}: sheet {result.sheet} (1:{result.scale:,}) → {target.name}, "
                  f"{src.RasterXSize}×{src.RasterYSize} px of "
                  f"{(xmax - xmin) / src.RasterXSize:.4f} × {(ymax - ymin) / src.RasterYSize:.4f} m")


def _own_crs(src: gdal.Dataset, target_crs: str) -> pyproj.CRS | None:
    """The CRS of a TIF that carries its own georeference in another CRS than the target, else None (its
    sheet number then places it, pixels aligned with the target CRS's axes)."""
    return foreign_crs(src, target_crs) if src.GetGeoTransform(can_return_null=True) is not None else None


def sheet_footprint(path: str, sheet_bounds: tuple[float, float, float, float], target_crs: str) -> BaseGeometry:
    """Where ``path`` has pixels in the target CRS: its own georeference reprojected when it carries one in
    another CRS, else ``sheet_bounds`` (its sheet's envelope + margin)."""
    src, _ = _open(path)
    own = _own_crs(src, target_crs) if src is not None else None
    if own is None or src is None:  # (no dataset: no CRS of its own either)
        return shapely.box(*sheet_bounds)
    return transform_geometry(shapely.box(*raster_extent(src.GetGeoTransform(), src.RasterXSize, src.RasterYSize)),
                              own, target_crs)


def _reprojected(result: SheetResult, src: gdal.Dataset, own: pyproj.CRS, staging: Path, target: Path, out_dir: Path,
                 target_crs: str, fmt: str, feedback: Feedback) -> None:
    """A TIF georeferenced in another CRS, reprojected from its own georeference (bilinear, its pixel size in
    metres, on a grid aligned to multiples of it): a warped VRT of the untouched pixels whose coverage is
    the mask of a 3-band VRT beside it (``<sheet>.vrt``), or a GeoTIFF with that mask. ``target``: the
    output's path in ``staging``."""
    warped_file = staging / f"{target.stem}{WARPED_SUFFIX}"
    size = cell_size(src, own, target_crs)
    footprint = transform_geometry(shapely.box(*raster_extent(src.GetGeoTransform(), src.RasterXSize,
                                                              src.RasterYSize)), own, target_crs)
    bounds = aligned(footprint.bounds, size)
    try:
        warped = warp(src, own, pyproj.CRS.from_user_input(target_crs), bounds, size, fmt="VRT", exact=False,
                      alpha=True)
        _write_vrt_xml(warped.GetMetadata("xml:VRT")[0], result.source, warped_file, None)
        bands = list(range(1, warped.RasterCount))
        warped = None
        with quiet_gdal():
            masked = gdal.Translate(str(target) if fmt == "VRT" else "", str(warped_file), format="VRT",
                                    bandList=bands, maskBand=len(bands) + 1)
            reason = gdal.GetLastErrorMsg()
        if masked is None:
            raise InputError(reason or "GDAL could not build the VRT")
        if fmt == "GTiff":
            with thread_config(GDAL_TIFF_INTERNAL_MASK="YES"):  # the mask inside the file, no .msk beside it
                error = _write_geotiff(masked, target, None, None, feedback)
            masked = None
            warped_file.unlink()
            if error:
                raise InputError(error)
        else:
            masked = None
            _write_vrt_xml(warped_file.read_text(encoding="utf-8"), result.source, warped_file, out_dir)
    except (InputError, OSError, RuntimeError) as exc:
        target.unlink(missing_ok=True)
        warped_file.unlink(missing_ok=True)
        _fail(result, str(exc), feedback)
        return
    result.status, result.bounds = OK, bounds
    feedback.info(f"{Path(result.source).name}: sheet {result.sheet} carries its own georeference in "
                  f"{crs_code(own)}: reprojected to {target_crs} (bilinear, {size:g} m pixels) → {target.name}")


def _fail(result: SheetResult, reason: str, feedback: Feedback) -> None:
    result.status, result.reason, result.output = FAILED, reason, None
    feedback.warning(f"Failed {result.source}: {reason}")


def write_footprint_index(results: Sequence[SheetResult], path: str | os.PathLike, crs: str = "EPSG:5186") -> None:
    """A GeoPackage layer with one row per input: footprint polygon (none if skipped) and outcome."""
    srs = _srs(crs)
    fields = [(name, ogr.OFTInteger if kind is int else ogr.OFTString) for name, kind in INDEX_FIELDS]
    with atomic_file(path) as tmp:
        try:
            with quiet_gdal():
                ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(tmp))
                layer = None if ds is None else ds.CreateLayer(INDEX_LAYER, srs, ogr.wkbPolygon)
        except RuntimeError as exc:
            raise InputError(f"Cannot create the footprint index {path}: {exc}") from exc
        if layer is None:
            raise InputError(f"Cannot create the footprint index {path}: {gdal.GetLastErrorMsg()}")
        for name, kind in fields:
            layer.CreateField(ogr.FieldDefn(name, kind))
        defn = layer.GetLayerDefn()
        layer.StartTransaction()
        for r in results:
            feature = ogr.Feature(defn)
            for name, _ in fields:
                value = getattr(r, name)
                if value is not None:
                    feature.SetField(name, value)
            if r.bounds:
                xmin, ymin, xmax, ymax = r.bounds
                ring = ogr.Geometry(ogr.wkbLinearRing)
                for x, y in ((xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax), (xmin, ymin)):
                    ring.AddPoint_2D(x, y)
                polygon = ogr.Geometry(ogr.wkbPolygon)
                polygon.AddGeometry(ring)
                feature.SetGeometry(polygon)
            layer.CreateFeature(feature)
        layer.CommitTransaction()
        ds = layer = None
