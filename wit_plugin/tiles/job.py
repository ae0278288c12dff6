"""One tile's share of a run: what a worker needs besides the run's inputs and options."""
from __future__ import annotations

from dataclasses import dataclass

import shapely
from shapely.geometry.base import BaseGeometry

from .. import model
from ..io.vector_io import read_prepared
from ..terrain.constraints import Seam
from .plan import TileOwner, tile_of
from .seams import tile_seam


@dataclass(frozen=True)
class TileJob:
    """The tile (its owner rule holds sheet, scale, CRSs and the run's area) and the run's prepared
    roads and dongs (``context``, cut at the tile's border by the worker)."""

    owner: TileOwner
    context: str | None = None
    context_layers: tuple[str, ...] = ()

    def seam(self, target_crs: str, footprints: list[str]) -> Seam:
        """The tile's border and its canonical points, from the run's area, its roads and ``footprints``."""
        crossing = [shapely.from_wkt(self.owner.area_wkt)] if self.owner.area_wkt else []
        for name in (n for n in self.context_layers if n == model.PREPARED_ROADS):
            crossing += list(read_prepared(f"{self.context}|layername={name}", name).geoms)
        for source in footprints:
            crossing += list(read_prepared(source, source.rsplit("=", 1)[-1]).geoms)
        return tile_seam(tile_of(self.owner.sheet, target_crs, self.owner.sheet_crs).polygon, crossing)

    def area(self, target_crs: str) -> BaseGeometry:
        """The tile's polygon within the run's area."""
        polygon = tile_of(self.owner.sheet, target_crs, self.owner.sheet_crs).polygon
        if self.owner.area_wkt is None:
            return polygon
        return shapely.intersection(polygon, shapely.from_wkt(self.owner.area_wkt))
