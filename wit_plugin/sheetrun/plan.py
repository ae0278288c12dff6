"""The tile plan: which NGII map sheets a run covers, each sheet's tile, and which tile owns a building.

Pure functions, no Dask and no files: the plan is decided before any work and tested alone.

* **Tiles** are the sheets of the NGII grid at ``scale`` (1:5,000 by default, 1:1,000 for dense
  cities) that meet the area; the sheet number is the tile id, so tiles line up with the
  orthoimage sheets users have. A tile's polygon joins the sheet's four corners projected to the
  target CRS by straight edges: neighbouring sheets share their corners exactly, so the tiles
  partition the plane without gaps or overlaps.
* **Ownership**: a building belongs to the sheet containing its point on surface (the point
  ``wit:preparevectors`` already uses to keep a building whole in a study area), found from the
  point's degrees on the sheet datum with the grid's half-open rule (an edge belongs to the cell
  east/north of it). So every building has exactly one tile, whatever the tiles' polygons, and the
  union of the tiles' buildings is the single-area selection.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError
from ..infra.mapsheet import parse_sheet_number, sheet_polygon, sheets_at, sheets_overlapping

TILE_SCALES = (5000, 1000)


@dataclass(frozen=True)
class Tile:
    """One tile of the plan: its sheet and its polygon in the target CRS."""

    sheet: str
    polygon: BaseGeometry


def _check(scale: int) -> None:
    if scale not in TILE_SCALES:
        raise InputError(f"Tile scale 1:{scale} is not offered: use {' or '.join(f'{s}' for s in TILE_SCALES)} "
                         "(the NGII 1:5,000 or 1:1,000 sheets).")


def plan_tiles(area: BaseGeometry, target_crs: str, scale: int = 5000, sheet_crs: str = "EPSG:4737") -> list[Tile]:
    """The tiles whose polygon overlaps ``area`` (with a positive area), in sheet-number order."""
    _check(scale)
    return [Tile(sheet.number, polygon) for sheet, polygon in sheets_overlapping(area, target_crs, scale, sheet_crs)]


def owners(points: np.ndarray, target_crs: str, scale: int = 5000, sheet_crs: str = "EPSG:4737") -> list[str]:
    """The sheet number owning each (x, y) point of ``points`` (target CRS)."""
    _check(scale)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if not len(points):
        return []
    lon, lat = pyproj.Transformer.from_crs(target_crs, sheet_crs, always_xy=True).transform(points[:, 0],
                                                                                           points[:, 1])
    return sheets_at(lon, lat, scale)


def tile_of(sheet: str, target_crs: str, sheet_crs: str = "EPSG:4737") -> Tile:
    """The tile of a sheet number (for a worker given only the number)."""
    return Tile(sheet, sheet_polygon(parse_sheet_number(sheet), target_crs, sheet_crs))


@dataclass(frozen=True)
class TileOwner:
    """Accepts the points (x, y, target CRS) that lie in the run's area and belong to ``sheet``:
    ``PrepareConfig.owner`` for a tile (picklable, so it travels to Dask workers)."""

    sheet: str
    scale: int
    target_crs: str
    sheet_crs: str = "EPSG:4737"
    area_wkt: str | None = None  # the run's area; None: everything

    def __call__(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        inside = np.array(owners(points, self.target_crs, self.scale, self.sheet_crs), dtype=object) == self.sheet
        if inside.any():
            inside &= self.in_run(points)
        return inside

    def in_run(self, points: np.ndarray) -> np.ndarray:
        """The points some tile of the run owns: those in the run's area."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if self.area_wkt is None:
            return np.ones(len(points), dtype=bool)
        return shapely.contains_xy(shapely.from_wkt(self.area_wkt), points[:, 0], points[:, 1])
