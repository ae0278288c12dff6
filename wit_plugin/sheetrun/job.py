"""One tile's share of a run: what a worker needs besides the run's inputs and options, and the
tile's own step 1 of the chain (``TileJob.tile_layers``)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import shapely
from shapely.geometry.base import BaseGeometry

from ..chain import ChainInputs, ChainOptions, PreparedLayers
from ..infra import step_layers
from ..infra.feedback import Feedback
from ..infra.io.layersource import LayerSource
from ..infra.io.vector_io import read_prepared
from ..terrain.constraints import Seam
from .layers import clip_context, prepare_tile_buildings
from .plan import TileOwner, tile_of
from .seams import tile_seam


@dataclass(frozen=True)
class TileJob:
    """The tile (its owner rule holds sheet, scale, CRSs and the run's area) and the run's prepared
    roads and dongs (``context``, cut at the tile's border by the worker)."""

    owner: TileOwner
    context: str | None = None
    context_layers: tuple[str, ...] = ()

    def seam(self, target_crs: str, footprints: list[LayerSource]) -> Seam:
        """The tile's border and its canonical points, from the run's area, its roads and ``footprints``."""
        crossing = [shapely.from_wkt(self.owner.area_wkt)] if self.owner.area_wkt else []
        if self.context is not None:  # (context layers come with their file)
            for name in (n for n in self.context_layers if n == step_layers.PREPARED_ROADS):
                crossing += list(read_prepared(LayerSource(self.context, name), name).geoms)
        for source in footprints:
            crossing += list(read_prepared(source, source.layer).geoms)
        return tile_seam(tile_of(self.owner.sheet, target_crs, self.owner.sheet_crs).polygon, crossing)

    def area(self, target_crs: str) -> BaseGeometry:
        """The tile's polygon within the run's area."""
        polygon = tile_of(self.owner.sheet, target_crs, self.owner.sheet_crs).polygon
        if self.owner.area_wkt is None:
            return polygon
        return shapely.intersection(polygon, shapely.from_wkt(self.owner.area_wkt))

    def tile_layers(self, inputs: ChainInputs, options: ChainOptions, work: Path,
                       feedback: Feedback) -> PreparedLayers:
        """Step 1 for the tile (``ChainOptions.part_layers``): its own buildings, its neighbours' crossing in,
        the run's roads and dongs cut at its border, and its seam."""
        prepared = str(work / "prepared.gpkg")
        tile_area = self.area(options.target_crs)
        names = prepare_tile_buildings(inputs.buildings, tile_area, self.owner, prepared, options.encoding, feedback)
        context = str(work / "context.gpkg")
        context_names = clip_context(self.context, self.context_layers, tile_area, context) if self.context else []
        seam = self.seam(options.target_crs, [LayerSource(prepared, n) for n in names
                                              if n in (step_layers.PREPARED_BUILDINGS, step_layers.FOREIGN_BUILDINGS)])
        return PreparedLayers.read(prepared, names, context, context_names, seam)
