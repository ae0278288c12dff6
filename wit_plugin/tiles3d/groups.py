"""The levels above the tiles of a tiled run: groups by NGII sheet, as many levels as the run needs.

Each tile's own tileset starts at a coarse view of that tile; seen from afar, a run of thousands of
tiles would still ask for thousands of those. So the tiles are grouped by the sheet one scale up,
and those groups again, up to the 1° blocks of the sheet numbering: 1:1,000 tiles by their 1:5,000
sheet, 1:5,000 sheets by their 1:50,000 sheet (the number's first five digits), 1:50,000 sheets by
their block (the first three). A group is at most 25, 100 or 16 children whatever the run's size;
a group with a single child group is left out (it would only repeat it). ``plan_groups`` is the
plan alone, tested without files.

Each group gets a coarse content of its own (``write_group``): the terrain as a regular grid of
``GROUP_CELLS``² cells draped with one ``GROUP_IMAGE``² image, and its largest buildings
(``group_buildings``). The lowest groups take their terrain from the DEM and the orthoimage over
their tiles; higher ones join their children's grids and images (GDAL warps of those small rasters),
so no level reads more of the inputs than the lowest. Its geometric error is what it leaves out,
measured: the grid spacing, the grid's largest height difference with the DEM (or with its
children's grids, plus their own error), the largest building left out, the footprints'
simplification — and never less than a child's.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal
from shapely.geometry.base import BaseGeometry

from ..infra.dem import Dem
from ..infra.errors import InputError, WitError
from ..infra.io.raster_io import open_raster
from ..infra.mapsheet import parse_sheet_number, sheet_at
from .coarse import Patch, fill_colours, grid_triangles, mem_raster, neighbour_mean
from .geo import Georeference
from .glb import GlbBuilder
from .group_buildings import Candidates, add_buildings
from .textures import encode_image

GROUP_CELLS = 64
GROUP_IMAGE = 512
GROUP_DIR = "3dtiles-groups"
CHECK_DENSITY = 4
"""The DEM is compared with a group's grid at this many points per cell side (its vertical error)."""
GROUP_LEVELS = {9: "1:5,000 sheet", 8: "1:50,000 sheet", 5: "1° block"}
"""A group's kind by the digits of its children's numbers (1:1,000 tiles have 9, 1:5,000 8, 1:50,000 5)."""


def parent_sheet(number: str) -> str | None:
    """The sheet or block one level up that holds the sheet ``number`` (None for a 1° block)."""
    if len(number) == 9:  # 1:1,000 → 1:5,000: not a prefix (1:1,000 splits the 1:10,000 sheets): the centre's
        tile = parse_sheet_number(number)
        return sheet_at((tile.west + tile.east) / 2, (tile.south + tile.north) / 2, 5000).number
    if len(number) == 8:  # 1:5,000 → 1:50,000
        return number[:5]
    if len(number) == 5:  # 1:50,000 → 1° block
        return number[:3]
    return None


@dataclass
class GroupPlan:
    """One group: its children (group names or tile sheets, sorted), whether they are tiles, and its tiles."""

    name: str
    children: list[str]
    over_tiles: bool
    tiles: list[str] = field(default_factory=list)


def plan_groups(sheets: list[str]) -> tuple[dict[str, GroupPlan], list[str]]:
    """Groups over the tile ``sheets``, level by level up to the 1° blocks; (groups by name, the top
    ones). A group whose only child is a group is replaced by that child."""
    groups: dict[str, GroupPlan] = {}
    level, over_tiles = sorted(set(sheets)), True
    tiles_below = {s: [s] for s in level}
    while level and parent_sheet(level[0]) is not None:
        parents: dict[str, list[str]] = {}
        for item in level:
            parent = parent_sheet(item)
            if parent is not None:  # (always: the level's sheets share a scale, and the first has a parent)
                parents.setdefault(parent, []).append(item)
        for name, children in parents.items():
            groups[name] = GroupPlan(name, sorted(children), over_tiles,
                                     sorted(t for c in children for t in tiles_below[c]))
            tiles_below[name] = groups[name].tiles
        level, over_tiles = sorted(parents), False
    top = level if groups else []

    def resolve(name: str) -> str:
        group = groups.get(name)
        if group is not None and not group.over_tiles and len(group.children) == 1:
            return resolve(group.children[0])
        return name

    for group in groups.values():
        group.children = sorted(resolve(c) for c in group.children)
    top = sorted({resolve(name) for name in top})
    reachable: set[str] = set()
    stack = list(top)
    while stack:
        name = stack.pop()
        if name in groups and name not in reachable:
            reachable.add(name)
            stack += groups[name].children
    return {name: g for name, g in groups.items() if name in reachable}, top


@dataclass
class Terrain:
    """A group's coarse terrain: heights at the (n + 1)² vertices of a grid over the square ``rect``
    (row 0 on the north edge, NaN off the terrain), its image, and its measured vertical error."""

    rect: tuple[float, float, float, float]
    heights: np.ndarray
    image: np.ndarray
    error: float


def square(area: BaseGeometry) -> tuple[float, float, float, float]:
    """The square over ``area``'s bounds, from its north-west corner."""
    xmin, ymin, xmax, ymax = area.bounds
    side = max(xmax - xmin, ymax - ymin)
    return xmin, ymax - side, xmin + side, ymax


def _vertices(rect: tuple[float, float, float, float], n: int) -> tuple[np.ndarray, np.ndarray]:
    xmin, _, xmax, ymax = rect
    step = (xmax - xmin) / n
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    return xmin + j * step, ymax - i * step


def grid_at(heights: np.ndarray, rect: tuple[float, float, float, float], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Heights of the grid's triangles (as ``coarse.grid_triangles`` draws them) at points (x, y); NaN off it."""
    n = heights.shape[0] - 1
    xmin, _, xmax, ymax = rect
    step = (xmax - xmin) / n
    fx, fy = (np.asarray(x) - xmin) / step, (ymax - np.asarray(y)) / step
    col, row = np.clip(np.floor(fx), 0, n - 1).astype(np.int64), np.clip(np.floor(fy), 0, n - 1).astype(np.int64)
    fx, fy = fx - col, fy - row
    nw, ne = heights[row, col], heights[row, col + 1]
    sw, se = heights[row + 1, col], heights[row + 1, col + 1]
    lower = fy >= fx  # the (nw, sw, se) triangle; else (nw, se, ne)
    z = np.where(lower, nw + fy * (sw - nw) + fx * (se - sw), nw + fx * (ne - nw) + fy * (se - ne))
    outside = (fx < -1e-9) | (fx > 1 + 1e-9) | (fy < -1e-9) | (fy > 1 + 1e-9)
    return np.where(outside, np.nan, z)


def sample_terrain(area: BaseGeometry, crs: pyproj.CRS, dem: str, ortho: list[str]) -> Terrain | None:
    """A lowest group's terrain over ``area`` (target CRS) from the DEM and the orthoimage sheets
    (``ortho``: georeferenced rasters); None when they do not give it."""
    rect = square(area)
    step = (rect[2] - rect[0]) / GROUP_CELLS
    try:
        terrain = Dem.open(dem, area.bounds, crs=crs)
    except WitError:  # a group at the DEM's edge keeps the terrain of the part of its area the DEM covers
        try:
            terrain = Dem.open(dem, _covered_bounds(dem, area, crs), crs=crs)
        except WitError:
            return None
    west, south, east, north = terrain.extent
    near = area.buffer(step)  # a cell's width around the area: no gap at the tiles' edge

    def heights_at(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        inside = shapely.contains_xy(near, x, y) & (x >= west) & (x <= east) & (y >= south) & (y <= north)
        z = np.full(x.shape, np.nan)
        z[inside] = terrain.sample(x[inside], y[inside])
        return z

    heights = heights_at(*_vertices(rect, GROUP_CELLS))
    image = _warp_image(ortho, rect, crs)
    if image is None or not np.isfinite(heights).any():
        return None
    x, y = _vertices(rect, GROUP_CELLS * CHECK_DENSITY)
    dense = heights_at(x, y)
    deviation = np.abs(grid_at(heights, rect, x, y) - dense)
    error = float(np.nanmax(deviation)) if np.isfinite(deviation).any() else 0.0
    return Terrain(rect, heights, image, error)


def _covered_bounds(dem: str, area: BaseGeometry, crs: pyproj.CRS) -> tuple[float, float, float, float]:
    """The bounds of the part of ``area`` that the DEM's extent covers, in ``crs``, a cell inside its edge."""
    ds = open_raster(dem, "DEM")
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    x1, y1 = x0 + dx * ds.RasterXSize, y0 + dy * ds.RasterYSize
    extent = shapely.segmentize(shapely.box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)).buffer(
        -2 * max(abs(dx), abs(dy)), join_style="mitre"), 4 * max(abs(dx), abs(dy)))
    wkt = ds.GetProjection()
    if wkt and not pyproj.CRS.from_wkt(wkt).equals(crs):
        to_crs = pyproj.Transformer.from_crs(pyproj.CRS.from_wkt(wkt), crs, always_xy=True)
        extent = shapely.transform(extent, lambda xy: np.column_stack(to_crs.transform(xy[:, 0], xy[:, 1])))
    covered = shapely.intersection(shapely.box(*area.bounds), extent)
    if covered.is_empty:
        raise InputError(f"The DEM {dem} does not reach the group's area.")
    return tuple(covered.bounds)


def _warp_image(ortho: list[str], rect: tuple[float, float, float, float], crs: pyproj.CRS) -> np.ndarray | None:
    """The orthoimage over ``rect`` as GROUP_IMAGE² RGB pixels (averaged), or None."""
    try:
        ds = gdal.Warp("", ortho, format="MEM", outputBounds=rect, width=GROUP_IMAGE, height=GROUP_IMAGE,
                       dstSRS=crs.to_wkt(), resampleAlg="average", multithread=False)
    except RuntimeError:
        return None
    if ds is None or ds.RasterCount < 3:
        return None
    return np.ascontiguousarray(np.moveaxis(ds.ReadAsArray()[:3], 0, -1).astype(np.uint8))


def join_terrain(children: list[Terrain], area: BaseGeometry) -> Terrain | None:
    """A higher group's terrain over ``area`` from its children's: heights and image warped from theirs
    (bilinear, average); error: the largest height difference at a child's vertex, plus its error."""
    if not children:
        return None
    rect = square(area)
    side = rect[2] - rect[0]
    # heights: rasters whose pixel centres are the grids' vertices
    sources = [mem_raster(c.heights[None], _vertex_geotransform(c.rect, c.heights.shape[0] - 1)) for c in children]
    target = mem_raster(np.full((1, GROUP_CELLS + 1, GROUP_CELLS + 1), np.nan), _vertex_geotransform(rect, GROUP_CELLS))
    gdal.Warp(target, sources, resampleAlg="bilinear", srcNodata=float("nan"), dstNodata=float("nan"),
              multithread=False)
    heights = target.GetRasterBand(1).ReadAsArray().astype(np.float64)
    if not np.isfinite(heights).any():
        return None
    x, y = _vertices(rect, GROUP_CELLS)  # vertices a cell around the area but off the children's grids: their
    near = shapely.contains_xy(area.buffer(side / GROUP_CELLS), x, y)  # neighbours' mean (no gap between groups)
    for _ in range(2):
        missing = np.isnan(heights) & near
        if not missing.any():
            break
        heights[missing] = neighbour_mean(heights)[missing]
    sources = [mem_raster(np.moveaxis(c.image, -1, 0), (c.rect[0], (c.rect[2] - c.rect[0]) / c.image.shape[1], 0.0,
                                                  c.rect[3], 0.0, -(c.rect[3] - c.rect[1]) / c.image.shape[0]))
               for c in children]
    target = mem_raster(np.zeros((3, GROUP_IMAGE, GROUP_IMAGE), dtype=np.uint8),
                  (rect[0], side / GROUP_IMAGE, 0.0, rect[3], 0.0, -side / GROUP_IMAGE))
    gdal.Warp(target, sources, resampleAlg="average", multithread=False)
    image = np.ascontiguousarray(np.moveaxis(target.ReadAsArray(), 0, -1))
    # texels off the children's images (the edge cells): their neighbours' colours
    image = fill_colours(image, (image != 0).any(axis=-1))
    error = 0.0
    for child in children:
        x, y = _vertices(child.rect, child.heights.shape[0] - 1)
        deviation = np.abs(grid_at(heights, rect, x, y) - child.heights)
        error = max(error, child.error + (float(np.nanmax(deviation)) if np.isfinite(deviation).any() else 0.0))
    return Terrain(rect, heights, image, error)


def _vertex_geotransform(rect: tuple[float, float, float, float], n: int) -> tuple[float, ...]:
    step = (rect[2] - rect[0]) / n
    return rect[0] - step / 2, step, 0.0, rect[3] + step / 2, 0.0, -step


@dataclass
class Group:
    """A group's written content: its file (relative to the group folder's parent), frame, region, error."""

    uri: str
    frame: np.ndarray
    region: list[float]
    error: float
    buildings: int = 0
    bytes: int = 0


def write_group(name: str, area: BaseGeometry, terrain: Terrain | None, buildings: Candidates,
                georef: Georeference, folder: Path) -> Group | None:
    """Write ``<folder>/<name>.glb``, the group's terrain and buildings; None if it has neither. The
    error returned is the content's own (the caller adds its children's)."""
    rect = terrain.rect if terrain is not None else square(area)
    cell = (rect[2] - rect[0]) / GROUP_CELLS
    glb, corners, error = GlbBuilder(), [], buildings.dropped
    image = None
    heights = [buildings.base, buildings.top]
    if terrain is not None:
        xyz, uv = grid_triangles(Patch(terrain.heights, terrain.image, terrain.error), rect)
        corners.append(xyz.reshape(-1, 3))
        heights.append(xyz[..., 2].ravel())
        error = max(error, cell, terrain.error)
    z = np.concatenate(heights)
    z = z[np.isfinite(z)]
    if not len(z):
        return None
    frame = georef.frame((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2, float((z.min() + z.max()) / 2))
    if terrain is not None and len(xyz):
        image = encode_image(terrain.image)
        glb.triangles(georef.local(frame, xyz.reshape(-1, 3)).reshape(-1, 3, 3),
                      glb.photo_material(data=image, name=name), uv)
    drawn = add_buildings(glb, georef, frame, buildings, rect, cell, image, name)
    error = max(error, drawn.simplification, drawn.vanished)
    if not glb.primitives:
        return None
    points = np.concatenate(corners + [drawn.corners])
    folder.mkdir(parents=True, exist_ok=True)
    data = glb.to_bytes()
    (folder / f"{name}.glb").write_bytes(data)
    return Group(f"{name}.glb", frame, georef.region(points), error, len(buildings.ids), len(data))


def raster_extent(path: str, what: str = "orthoimage sheet") -> tuple[float, float, float, float]:
    """xmin, ymin, xmax, ymax of a north-up raster."""
    ds = open_raster(path, what)
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    return x0, y0 + dy * ds.RasterYSize, x0 + dx * ds.RasterXSize, y0
