"""Do the DEM and the orthoimage sheets cover the area? Answered in seconds, before the heavy steps.

The orthoimage sheets are judged from their file names (the NGII sheet number gives the
footprint, as ``wit:georeferencemapsheets`` computes it) — or, for a TIF that carries its own
georeference in another CRS, from that georeference reprojected — so nothing is georeferenced or
merged before the answer; what is missing is named as the sheet numbers that would cover it. The DEM is
judged by its extent and by the share of NoData cells under the area.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal
from shapely.geometry.base import BaseGeometry

from ..infra.dem import NODATA_THRESHOLD, reprojection, shortfall
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.raster_io import open_raster, read_window
from ..infra.mapsheet import MapSheet, find_sheet_in_name, projected_envelope, sheets_covering
from ..infra.raster_crs import crs_code, raster_extent, transform_geometry
from ..mosaic.georef import sheet_footprint

#: NoData under more than this share of the area is an error (filling it would invent the terrain)
MAX_DEM_NODATA_SHARE = 0.05
#: uncovered slivers below this area (m²) are rounding, not a missing sheet
MIN_GAP_AREA = 0.01
#: sheets farther than this (m) from the area are judged by their number alone (a sheet georeferenced in
#: another CRS lies within tens of metres of its number's envelope)
NEAR_SHEET = 1000.0


@dataclass
class SheetFile:
    """An orthoimage file, its sheet and its footprint in the target CRS (sheet envelope + margin)."""

    path: str
    sheet: MapSheet
    footprint: BaseGeometry


@dataclass
class OrthoCoverage:
    """Which sheet files the area needs, which it does not, and what no file covers."""

    used: list[SheetFile]
    unused: list[SheetFile]
    unnamed: list[tuple[str, str]] = field(default_factory=list)  # (file, why it has no sheet number)
    uncovered: BaseGeometry | None = None
    missing_sheets: list[str] = field(default_factory=list)

    @property
    def footprint(self) -> BaseGeometry:
        """Where the used sheets have pixels."""
        return shapely.union_all([s.footprint for s in self.used])


def _km2(area: float) -> str:
    return f"{area / 1e6:.3f} km²" if area >= 1e4 else f"{area:,.1f} m²"


def require_sheet_names(files: list[str]) -> None:
    """Refuse, before any work, orthoimages none of which is named by a valid sheet number."""
    reasons = []
    for path in files:
        try:
            find_sheet_in_name(Path(path).name)
            return
        except InputError as exc:
            reasons.append(f"{Path(path).name}: {exc}")
    raise InputError("No orthoimage TIF has a valid map-sheet number in its name (e.g. "
                     "(B060)정사영상_2022_37709005.tif): " + "; ".join(reasons[:5])
                     + (" …" if len(reasons) > 5 else ""))


def ortho_coverage(files: list[str], area: BaseGeometry, target_crs: str, source_crs: str = "EPSG:4737",
                   margin: float = 50.0) -> OrthoCoverage:
    """Split ``files`` into the sheets that meet ``area`` and the rest; find what none covers.

    Only the files whose sheet lies near the area are opened (to see whether they carry their own
    georeference in another CRS): a folder of a whole city's sheets is judged in seconds.
    """
    used: list[SheetFile] = []
    unused: list[SheetFile] = []
    unnamed: list[tuple[str, str]] = []
    xmin, ymin, xmax, ymax = area.bounds
    near = shapely.box(xmin - NEAR_SHEET, ymin - NEAR_SHEET, xmax + NEAR_SHEET, ymax + NEAR_SHEET)
    for path in files:
        try:
            sheet = find_sheet_in_name(Path(path).name)
        except InputError as exc:
            unnamed.append((path, str(exc)))
            continue
        envelope = projected_envelope(sheet, target_crs, source_crs, margin)
        footprint = sheet_footprint(path, envelope, target_crs) if near.intersects(shapely.box(*envelope)) \
            else shapely.box(*envelope)
        (used if footprint.intersects(area) and footprint.intersection(area).area > 0 else unused).append(
            SheetFile(path, sheet, footprint))
    report = OrthoCoverage(used, unused, unnamed)
    gap = area.difference(report.footprint) if used else area
    if gap.area > MIN_GAP_AREA:
        report.uncovered = gap
        scales = Counter(s.sheet.scale for s in used + unused)
        scale = scales.most_common(1)[0][0] if scales else 5000
        report.missing_sheets = _sheets_over(gap, scale, target_crs, source_crs)
    return report


def _sheets_over(region: BaseGeometry, scale: int, target_crs: str, source_crs: str) -> list[str]:
    """Numbers of the sheets (of ``scale``) whose envelope meets ``region``."""
    to_degrees = pyproj.Transformer.from_crs(target_crs, source_crs, always_xy=True)
    xy = shapely.get_coordinates(shapely.segmentize(region.envelope, max(region.envelope.length / 64, 1.0)))
    lon, lat = to_degrees.transform(xy[:, 0], xy[:, 1])
    candidates = sheets_covering(min(lon), min(lat), max(lon), max(lat), scale)
    shapely.prepare(region)
    return [s.number for s in candidates
            if region.intersects(shapely.box(*projected_envelope(s, target_crs, source_crs)))]


def require_ortho(coverage: OrthoCoverage, untextured_ok: bool, feedback: Feedback = SILENT) -> None:
    """Refuse (or, when allowed, warn about) an area the sheets leave uncovered; say what is missing."""
    for path, why in coverage.unnamed:
        feedback.warning(f"{Path(path).name}: skipped, {why}.")
    if coverage.unused:
        feedback.info(f"{len(coverage.unused)} orthoimage sheet(s) lie outside the area and are not used: "
                      f"{', '.join(s.sheet.number for s in coverage.unused[:10])}"
                      f"{' …' if len(coverage.unused) > 10 else ''}.")
    if coverage.uncovered is None:
        return
    gap = coverage.uncovered
    what = (f"The orthoimage sheets leave {_km2(gap.area)} of the area uncovered "
            f"(x {gap.bounds[0]:.1f}–{gap.bounds[2]:.1f}, y {gap.bounds[1]:.1f}–{gap.bounds[3]:.1f}); "
            f"the sheets that would cover it: {', '.join(coverage.missing_sheets) or 'none on the NGII grid'}.")
    if not coverage.used:
        raise InputError(f"No orthoimage sheet covers the area. {what} Give those sheets' TIFs.")
    if not untextured_ok:
        raise InputError(f"{what} Add those TIFs, make the area smaller, or choose to leave the surfaces "
                         "outside the orthoimage untextured.")
    feedback.warning(f"{what} Surfaces there are left untextured.")


def require_dem(dem_path: str, area: BaseGeometry, target_crs: str, feedback: Feedback = SILENT,
                max_cells: int = 4_000_000) -> None:
    """Refuse a DEM that does not cover ``area`` (naming by how much, on which side) or has NoData under
    more than ``MAX_DEM_NODATA_SHARE`` of it; warn about smaller NoData patches (they are filled).

    A DEM in another CRS is judged in its own CRS, against the area reprojected there (it is
    reprojected on the fly by the steps that read it). The NoData share is read from at most
    ``max_cells`` cells (every n-th cell of a bigger window: an estimate, said so).
    """
    name = Path(dem_path).name
    ds = open_raster(dem_path, "DEM")
    source = reprojection(dem_path, ds, target_crs, feedback)
    degrees = bool(source is not None and source.is_geographic)
    region = area if source is None else transform_geometry(area, target_crs, source)
    where = "" if source is None else f" in its CRS, {crs_code(source)}"
    gt = ds.GetGeoTransform()
    extent = raster_extent(gt, ds.RasterXSize, ds.RasterYSize)
    # the area's box, as the steps read the DEM (in the DEM's CRS: that box reprojected)
    box = area.envelope if source is None else transform_geometry(area.envelope, target_crs, source)
    xmin, ymin, xmax, ymax = box.bounds
    beyond = {"west": extent[0] - xmin, "south": extent[1] - ymin, "east": xmax - extent[2], "north": ymax - extent[3]}
    short = {side: amount for side, amount in beyond.items() if amount > 0}
    if short:
        d = 6 if degrees else 1
        sides = shortfall(short, degrees)
        also = "" if source is None else f" (the area's box in {crs_code(pyproj.CRS(target_crs))}, reprojected)"
        raise InputError(f"The DEM {name} (x {extent[0]:.{d}f}–{extent[2]:.{d}f}, y {extent[1]:.{d}f}–{extent[3]:.{d}f}"
                         f"{where}) does not cover the area (x {xmin:.{d}f}–{xmax:.{d}f}, y {ymin:.{d}f}–{ymax:.{d}f}"
                         f"{also}): it stops short by {sides}. Use a DEM that covers the area, or a smaller area.")
    band = ds.GetRasterBand(1)
    c0, c1 = (int(np.floor((x - gt[0]) / gt[1])) for x in (xmin, xmax))
    r0, r1 = (int(np.floor((y - gt[3]) / gt[5])) for y in (ymax, ymin))
    c0, r0 = max(c0, 0), max(r0, 0)
    c1, r1 = min(c1, ds.RasterXSize - 1), min(r1, ds.RasterYSize - 1)
    step = max(1, int(np.ceil(np.sqrt((c1 - c0 + 1) * (r1 - r0 + 1) / max_cells))))
    cols, rows = np.arange(c0, c1 + 1, step), np.arange(r0, r1 + 1, step)
    values = read_window(band, c0, r0, c1 - c0 + 1, r1 - r0 + 1, f"the DEM {dem_path}", buf_xsize=len(cols),
                         buf_ysize=len(rows), resample_alg=gdal.GRIORA_NearestNeighbour)
    nodata = band.GetNoDataValue()
    missing = ~np.isfinite(values) | ((values == nodata) if nodata is not None else (values <= NODATA_THRESHOLD))
    if not missing.any():
        return
    u, v = np.meshgrid(cols + 0.5 * step, rows + 0.5 * step)
    under = shapely.contains_xy(region, gt[0] + u * gt[1], gt[3] + v * gt[5])
    share = (missing & under).sum() / max(under.sum(), 1)
    cells = int((missing & under).sum()) * step * step
    about = "about " if step > 1 else ""
    if share > MAX_DEM_NODATA_SHARE:
        raise InputError(f"The DEM {name} has NoData under {share:.0%} of the area ({about}{cells} cells): its terrain "
                         "would be invented. Use a DEM with data over the area.")
    if cells:
        feedback.warning(f"The DEM {name} has {about}{cells} NoData cell(s) under the area ({share:.1%}); they are "
                         "filled from their neighbours.")
