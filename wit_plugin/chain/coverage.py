"""Do the DEM and the orthoimage sheets cover the area? Answered in seconds, before the heavy steps.

The orthoimage sheets are judged from their file names alone (the NGII sheet number gives the
footprint, as ``wit:georeferencemapsheets`` computes it), so nothing is georeferenced or merged
before the answer; what is missing is named as the sheet numbers that would cover it. The DEM is
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

from ..dem import NODATA_THRESHOLD, check_crs, raster_extent
from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..mapsheet import MapSheet, find_sheet_in_name, projected_envelope, sheets_covering

#: NoData under more than this share of the area is an error (filling it would invent the terrain)
MAX_DEM_NODATA_SHARE = 0.05
#: uncovered slivers below this area (m²) are rounding, not a missing sheet
MIN_GAP_AREA = 0.01


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
                     "(B060)정사영상_2022_37709005.tif): " + "; ".join(reasons[:5]) + (" …" if len(reasons) > 5 else ""))


def ortho_coverage(files: list[str], area: BaseGeometry, target_crs: str, source_crs: str = "EPSG:4737",
                   margin: float = 50.0) -> OrthoCoverage:
    """Split ``files`` into the sheets that meet ``area`` and the rest; find what none covers."""
    used, unused, unnamed = [], [], []
    for path in files:
        try:
            sheet = find_sheet_in_name(Path(path).name)
        except InputError as exc:
            unnamed.append((path, str(exc)))
            continue
        footprint = shapely.box(*projected_envelope(sheet, target_crs, source_crs, margin))
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


def require_dem(dem_path: str, area: BaseGeometry, target_crs: str, feedback: Feedback = SILENT) -> None:
    """Refuse a DEM that does not cover ``area`` (naming by how much, on which side) or has NoData under
    more than ``MAX_DEM_NODATA_SHARE`` of it; warn about smaller NoData patches (they are filled)."""
    check_crs(dem_path, target_crs, feedback)
    name = Path(dem_path).name
    try:
        ds = gdal.Open(str(dem_path))
    except RuntimeError as exc:
        raise InputError(f"Cannot open the DEM {dem_path}: {exc}") from exc
    if ds is None:
        raise InputError(f"Cannot open the DEM {dem_path}: {gdal.GetLastErrorMsg() or 'not a raster'}")
    gt = ds.GetGeoTransform()
    extent = raster_extent(gt, ds.RasterXSize, ds.RasterYSize)
    xmin, ymin, xmax, ymax = area.bounds
    beyond = {"west": extent[0] - xmin, "south": extent[1] - ymin, "east": xmax - extent[2], "north": ymax - extent[3]}
    short = {side: metres for side, metres in beyond.items() if metres > 0}
    if short:
        sides = ", ".join(f"{metres:,.1f} m to the {side}" for side, metres in short.items())
        raise InputError(f"The DEM {name} (x {extent[0]:.1f}–{extent[2]:.1f}, y {extent[1]:.1f}–{extent[3]:.1f}) "
                         f"does not cover the area (x {xmin:.1f}–{xmax:.1f}, y {ymin:.1f}–{ymax:.1f}): it stops "
                         f"short by {sides}. Use a DEM that covers the area, or a smaller area.")
    band = ds.GetRasterBand(1)
    c0, c1 = (int(np.floor((x - gt[0]) / gt[1])) for x in (xmin, xmax))
    r0, r1 = (int(np.floor((y - gt[3]) / gt[5])) for y in (ymax, ymin))
    c0, r0 = max(c0, 0), max(r0, 0)
    c1, r1 = min(c1, ds.RasterXSize - 1), min(r1, ds.RasterYSize - 1)
    values = band.ReadAsArray(c0, r0, c1 - c0 + 1, r1 - r0 + 1)
    if values is None:
        raise InputError(f"Cannot read the DEM {name}: {gdal.GetLastErrorMsg() or 'read error'}")
    nodata = band.GetNoDataValue()
    missing = ~np.isfinite(values) | ((values == nodata) if nodata is not None else (values <= NODATA_THRESHOLD))
    if not missing.any():
        return
    cols, rows = np.meshgrid(np.arange(c0, c1 + 1) + 0.5, np.arange(r0, r1 + 1) + 0.5)
    under = shapely.contains_xy(area, gt[0] + cols * gt[1], gt[3] + rows * gt[5])
    share = (missing & under).sum() / max(under.sum(), 1)
    cells = int((missing & under).sum())
    if share > MAX_DEM_NODATA_SHARE:
        raise InputError(f"The DEM {name} has NoData under {share:.0%} of the area ({cells} cells): its terrain "
                         "would be invented. Use a DEM with data over the area.")
    if cells:
        feedback.warning(f"The DEM {name} has {cells} NoData cell(s) under the area ({share:.1%}); they are filled "
                         "from their neighbours.")
