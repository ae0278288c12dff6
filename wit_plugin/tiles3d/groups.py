"""A coarse level over several tiles of a tiled run, so that a whole district or city streams.

Each tile's own tileset starts at a coarse view of that tile; seen from afar, a run of thousands of
tiles would still ask for thousands of those. So the tiles are grouped by the NGII sheet one scale
up (1:1,000 tiles by their 1:5,000 sheet, 1:5,000 tiles by their 1:50,000 sheet), and each group
gets one coarse content of its own: the terrain as a regular grid of ``GROUP_CELLS``² cells on the
DEM, draped with one ``GROUP_IMAGE``² image of the orthoimage, over the tiles' area. It replaces
its tiles (``refine: REPLACE``) until the viewer comes closer than its geometric error allows:
the grid spacing, and never less than twice its tiles' own errors (buildings are left out at this
level: at a grid spacing of tens of metres they are a few pixels).
"""
from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal
from shapely.geometry.base import BaseGeometry

from ..dem import Dem
from ..errors import WitError
from ..feedback import SILENT, Feedback
from ..gdal_env import open_raster
from ..georef import OK, georeference_sheets
from ..mapsheet import parse_sheet_number, sheet_at
from .coarse import Patch, grid_triangles
from .geo import Georeference
from .glb import GlbBuilder
from .textures import encode_image

GROUP_SCALE = {1000: 5000, 5000: 50000}
GROUP_CELLS = 64
GROUP_IMAGE = 512
GROUP_DIR = "3dtiles-groups"


@dataclass
class Group:
    """A coarse content written for a group of tiles: its file, frame, region and error."""

    uri: str
    frame: np.ndarray
    region: list[float]
    error: float


def group_of(sheet: str, scale: int, sheet_crs: str = "EPSG:4737") -> str:
    """The sheet number one scale up that holds the tile ``sheet`` (its centre decides)."""
    tile = parse_sheet_number(sheet)
    return sheet_at((tile.west + tile.east) / 2, (tile.south + tile.north) / 2, GROUP_SCALE[scale]).number


def group_content(name: str, area: BaseGeometry, georef: Georeference, dem: str, ortho: list[str], folder: Path,
                  ) -> Group | None:
    """Write ``<folder>/<name>.glb``: the coarse terrain of ``area`` (target CRS); None when the DEM or
    the orthoimage cannot give it (the group then has no content of its own)."""
    xmin, ymin, xmax, ymax = area.bounds
    side = max(xmax - xmin, ymax - ymin)
    rect = (xmin, ymax - side, xmin + side, ymax)
    step = side / GROUP_CELLS
    i, j = np.meshgrid(np.arange(GROUP_CELLS + 1), np.arange(GROUP_CELLS + 1), indexing="ij")
    x, y = xmin + j * step, ymax - i * step
    try:
        terrain = Dem.open(dem, area.bounds, crs=georef.crs)
    except WitError:
        return None
    west, south, east, north = terrain.extent
    inside = shapely.contains_xy(area.buffer(step), x, y) & (x >= west) & (x <= east) & (y >= south) & (y <= north)
    heights = np.full(x.shape, np.nan)  # a cell's width around the area: no gap at the tiles' edge
    heights[inside] = terrain.sample(x[inside], y[inside])
    image = _image(ortho, rect, georef.crs)
    if image is None or not np.isfinite(heights).any():
        return None
    corners, uv = grid_triangles(Patch(heights, image, 0.0), rect)
    if not len(corners):
        return None
    points = corners.reshape(-1, 3)
    frame = georef.frame((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2, float(np.nanmean(points[:, 2])))
    glb = GlbBuilder()
    glb.triangles(georef.local(frame, points).reshape(-1, 3, 3), glb.photo_material(data=encode_image(image),
                                                                                       name=name), uv)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.glb").write_bytes(glb.to_bytes())
    return Group(f"{folder.name}/{name}.glb", frame, georef.region(points), step)


def _image(ortho: list[str], rect: tuple[float, float, float, float], crs: pyproj.CRS) -> np.ndarray | None:
    """The orthoimage over ``rect`` as GROUP_IMAGE² RGB pixels (averaged), or None."""
    try:
        ds = gdal.Warp("", ortho, format="MEM", outputBounds=rect, width=GROUP_IMAGE, height=GROUP_IMAGE,
                       dstSRS=crs.to_wkt(), resampleAlg="average", multithread=False)
    except RuntimeError:
        return None
    if ds is None or ds.RasterCount < 3:
        return None
    return np.ascontiguousarray(np.moveaxis(ds.ReadAsArray()[:3], 0, -1).astype(np.uint8))


def write_group_contents(output: Path, areas: dict[str, BaseGeometry], dem: str, ortho: list[str], target_crs: str,
                         sheet_crs: str = "EPSG:4737", margin: float = 50.0,
                         feedback: Feedback = SILENT) -> dict[str, Group | None]:
    """Every group's coarse content into ``<output>/3dtiles-groups/`` (replaced whole; written beside it
    first, so a failed run leaves the previous one): group name → its content, or None."""
    georef = Georeference(target_crs)
    staging = Path(tempfile.mkdtemp(prefix=".wit-groups-", dir=output))
    try:
        sheets = georeference_sheets(ortho, staging / "ortho", target_crs, sheet_crs, margin, fmt="VRT")
        vrts = [r.output for r in sheets if r.status == OK]
        extents = shapely.box(*np.array([_extent(v) for v in vrts]).T) if vrts else np.empty(0, dtype=object)
        folder = staging / GROUP_DIR
        contents = {}
        for name, area in areas.items():
            feedback.check_canceled()
            near = [vrts[k] for k in np.flatnonzero(shapely.intersects(extents, area))]  # not all sheets each time
            contents[name] = group_content(name, area, georef, dem, near, folder) if near else None
        target = output / GROUP_DIR
        if target.exists():
            shutil.rmtree(target)
        if folder.exists():
            os.replace(folder, target)
        return contents
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _extent(path: str) -> tuple[float, float, float, float]:
    """xmin, ymin, xmax, ymax of a north-up raster."""
    ds = open_raster(path, "orthoimage sheet")
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    return x0, y0 + dy * ds.RasterYSize, x0 + dx * ds.RasterXSize, y0
