"""Every tile's fingerprint at once: the run's settings, and the inputs as each tile reads them, by content.

What a tile reads (``job``, ``prepare``), and so what its fingerprint holds besides the settings:

* ``buildings``: those whose box meets the tile's area grown by ``CONTEXT_MARGIN`` (what its step 1 reads),
  in the layer's order (ids are numbered in it). Those it owns with every attribute — ownership computed
  as the tile computes it (reprojected, repaired, the sheet of the point on surface), and a building whose
  point lies within ``OWNER_SLACK`` of another sheet counted in both —; the others by footprint and id
  only, all a neighbour takes of them (simplified with its own walls, cut out of its terrain): a
  building's height changed rebuilds its own tile, its footprint moved rebuilds every tile within the
  margin — a change near a border can change the neighbour's terrain.
* ``roads``, ``districts``: the run's prepared polygons that meet the tile (prepared once for the whole
  run, so a road edited in the next tile can change this tile's piece of it: what the tile gets is compared).
* ``area``: the run's area where the tile and its neighbours' buildings lie (its edge is part of the seam,
  and it decides which neighbouring buildings are in the run): its edge there, and which side is in.
* ``dem``: the DEM cells under the tile's area and under the buildings it may own (its terrain grows to hold
  them), with the margin its readers take.
* ``ortho``: the orthoimage sheets whose footprint meets that box, by their bytes (the mosaic's tone is taken
  from every sheet used).

The inputs are read once for all the tiles; each tile then costs a few box queries and one DEM window.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..chain import ChainInputs, ChainOptions
from ..chain.coverage import OrthoCoverage
from ..chain.fingerprint import (
    SLACK,
    Bounds,
    DemDigests,
    Fingerprint,
    LayerDigests,
    OrthoDigests,
    chain_settings,
    grown,
    union_bounds,
)
from ..cityjson.sequence import run_translate
from ..infra import step_layers
from ..infra.io.digests import digest
from ..infra.io.layersource import LayerSource
from ..infra.io.vector_io import VectorLayer, non_finite
from ..infra.polygons import repair_polygons, transform
from ..prepare.vectors import BUILDING_KEYS, BUILDING_PREFIX, PrepareConfig, building_reach
from ..tiles3d.groups import square
from .layers import CONTEXT_MARGIN
from .plan import Tile, owners

CONTEXT_INPUTS = {step_layers.PREPARED_ROADS: "roads", step_layers.PREPARED_DISTRICTS: "districts"}
OWNER_SLACK = 0.01
"""m: a building whose point on surface lies this close to another sheet counts as that sheet's too (the point
is computed by the same code as the tile's; this covers any rounding between two computations of it)."""


class RunInputs:
    """The run's inputs read once, and the settings its tiles are built with: what every fingerprint is taken from."""

    def __init__(self, inputs: ChainInputs, options: ChainOptions, scale: int, polygon: BaseGeometry,
                 coverage: OrthoCoverage, context: str | None, context_layers: list[str]):
        self.crs = options.target_crs
        self.polygon = shapely.from_wkt(shapely.to_wkt(polygon))  # as the workers get it
        tiles_options = dataclasses.replace(options, metrics=False, keep_work=False)  # as the workers set them
        self.settings = {**chain_settings(tiles_options), "scale": scale, "context_margin": CONTEXT_MARGIN,
                         # the CityJSONSeq's one transform: from the run's area, in every tile's vertices
                         "cityjson_translate": list(run_translate(self.polygon)) if options.cityjson else None}
        reach = building_reach(self.polygon, CONTEXT_MARGIN).bounds
        layer = LayerDigests.layer(inputs.buildings, options.encoding, reach, self.crs)
        self.buildings = LayerDigests(layer, BUILDING_PREFIX, BUILDING_KEYS)
        self.owners = _owners(layer, self.crs, scale, options.sheet_crs)
        self.context = {CONTEXT_INPUTS[name]: LayerDigests.read(str(LayerSource(context, name)), None, None, self.crs)
                        for name in context_layers} if context else {}
        self.dem = DemDigests(inputs.dem, self.crs)
        self.ortho = OrthoDigests(coverage)

    def tile(self, tile: Tile) -> Fingerprint:
        """The fingerprint of ``tile`` (see the module docstring)."""
        area = shapely.intersection(tile.polygon, self.polygon)  # as ``TileJob.area``
        reach = building_reach(area, CONTEXT_MARGIN).bounds
        read = self.buildings.select(reach, self.crs)
        own = (self.owners[read] == tile.sheet).any(axis=1) | np.isin(read, self.buildings.everywhere)
        around = union_bounds(grown(reach, SLACK), self.buildings.target_bounds(read, self.crs))
        window = union_bounds(grown(area.bounds, SLACK), self.buildings.target_bounds(read[own], self.crs))
        inputs = {"buildings": self.buildings.digest(read, own), "area": self._area(around)}
        for name, layer in self.context.items():
            inputs[name] = layer.digest(layer.select(tile.polygon.bounds, self.crs))
        inputs.update(dem=self.dem.digest(window), ortho=self.ortho.digest(window))
        return Fingerprint(self.settings, inputs)

    def _area(self, box: Bounds) -> str:
        """The run's area within ``box``: its edge there, and which of the box's centre and corners are in it (one
        of them off the edge decides, the edge being the same, every part of the box) — the same wherever the
        area changed elsewhere."""
        edge = shapely.normalize(shapely.clip_by_rect(self.polygon.boundary, *box))
        x, y = np.array([(box[0] + box[2]) / 2, box[0], box[2], box[0], box[2]]), np.array(
            [(box[1] + box[3]) / 2, box[1], box[1], box[3], box[3]])
        return digest(shapely.to_wkb(edge), shapely.contains_xy(self.polygon, x, y).tobytes())

    def group(self, area: BaseGeometry) -> str:
        """The digest of what a lowest group of the run's 3D Tiles reads itself over ``area`` (its tiles'):
        the DEM under the area, the orthoimage over the square its image covers."""
        return digest(self.dem.digest(area.bounds), self.ortho.digest(square(area)))


def _owners(layer: VectorLayer, target_crs: str, scale: int, sheet_crs: str) -> np.ndarray:
    """Per feature, the sheets that may own it: that of its point on surface as a tile finds it (the geometry
    reprojected and repaired as ``vectors`` does, ``plan.owners``), and those of the points ``OWNER_SLACK``
    around it; "" for a feature the tiles drop (no geometry, collapsed, too small)."""
    config = PrepareConfig()
    repaired = repair_polygons(transform(layer.geoms, layer.crs, pyproj.CRS.from_user_input(target_crs)),
                               layer.unclosed_rings, config.min_area, config.sliver_thinness, config.sliver_width)
    found = np.full((len(layer), 5), "", dtype=object)
    kept = np.flatnonzero(~shapely.is_missing(repaired.geoms) & ~non_finite(repaired.geoms))
    points = shapely.get_coordinates(shapely.point_on_surface(repaired.geoms[kept]))
    for k, (dx, dy) in enumerate(((0, 0), (-1, -1), (-1, 1), (1, -1), (1, 1))):
        found[kept, k] = owners(points + OWNER_SLACK * np.array([dx, dy]), target_crs, scale, sheet_crs)
    return found
