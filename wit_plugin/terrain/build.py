"""The terrain step (wit:triangulateterrain): a constrained Delaunay TIN of the study area.

Building footprints and road polygons are constraints, so every triangle lies wholly on terrain,
on a road or under a building, and the later steps can drape roads and cut holes exactly. The
step reads the layers and the DEM, cleans the constraints (``constraints``), meshes and refines
to the DEM (``mesh``) and writes the TIN on the millimetre grid (``output``).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra.dem import Dem
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import refuse_overlap
from ..infra.io.vector_io import VectorLayer, read_layer, read_prepared
from ..infra.polygons import transform
from ..infra.step_layers import FOREIGN_BUILDINGS, PREPARED_BUILDINGS, PREPARED_ROADS, WIT_ID
from .constraints import GRID, Feature, Seam, _polygonal, clean_polygons
from .mesh import TinStats, _longest_edges, max_vertical_error, triangulate, vertical_error
from .output import snap_to_grid, write_tin
from .triangulators import MAX_EDGE, VERTICAL_TOLERANCE


@dataclass(frozen=True)
class TerrainConfig:
    """The step's settings (wit:triangulateterrain's parameters)."""

    max_edge: float = MAX_EDGE  # m: no triangle edge longer
    tolerance: float = VERTICAL_TOLERANCE  # m: no triangle farther from the DEM surface
    footprints_as_holes: bool = True  # else footprints are constrained edges, meshed over
    spatial_index: bool = True  # of the written TIN; an intermediate file read whole needs none
    triangulator: int | None = None  # a ``triangulators.BACKENDS`` key (None: the default)


@dataclass(frozen=True)
class TileContext:
    """What a tile of a tiled run adds: its neighbours' buildings and its border, which must match theirs.

    ``foreign``: the neighbouring tiles' buildings that cross into this one (footprints here, but
    they do not grow the area); ``seam``: the border's canonical points. The border then matches
    the neighbours' (fixed segments, see ``mesh.triangulate``).
    """

    foreign: str | Path | None = None
    seam: Seam | None = None


def features(layer: VectorLayer) -> list[Feature]:
    """(wit_id, geometry) pairs of a prepared layer."""
    ids = layer.columns.get(WIT_ID) or [None] * len(layer)
    return list(zip(ids, layer.geoms))


def covering_area(area: BaseGeometry, footprints: Sequence[BaseGeometry | None] | np.ndarray,
                  feedback: Feedback = SILENT) -> BaseGeometry:
    """The area grown to hold every footprint that reaches into it, so no building overhangs the rim.

    Buildings are kept whole at the edge of a study area (their point on surface decides), so a
    footprint can cross the rim; the terrain then follows its walls outside instead of stopping
    under it. Footprints wholly outside the area are not added (they are not in the model).
    """
    geoms = np.array([g for g in clean_polygons(footprints) if g is not None], dtype=object)
    if not len(geoms):
        return area
    shapely.prepare(area)
    crossing = geoms[~shapely.covered_by(geoms, area) & shapely.intersects(area, geoms)]
    crossing = crossing[shapely.area(shapely.intersection(crossing, area)) > 0] if len(crossing) else crossing
    if not len(crossing):
        return area
    grown = _polygonal(np.array([shapely.union_all([area, *crossing], grid_size=GRID)], dtype=object))[0]
    feedback.info(f"Terrain extended by {grown.area - area.area:,.1f} m² beyond the study area to hold the whole "
                  f"footprints of {len(crossing)} building(s) that cross its edge.")
    return grown


def triangulate_terrain(dem_path: str | Path, buildings: str | Path | None, roads: str | Path | None,
                        output: str | Path, area: BaseGeometry | str | Path, config: TerrainConfig | None = None,
                        feedback: Feedback = SILENT, tile: TileContext | None = None) -> TinStats:
    """wit:triangulateterrain: read the constraint layers and the DEM, mesh, write the TIN GeoPackage.

    ``buildings`` / ``roads`` are prepared layers (``file.gpkg|layername=…``, or the prepared
    GeoPackage itself); ``area`` is a polygon, or a vector source whose polygons together form it,
    grown to hold the footprints that cross its edge (``covering_area``). ``tile``: given in a
    tiled run only.
    """
    config = config or TerrainConfig()
    foreign = tile.foreign if tile is not None else None
    max_edge, tolerance = config.max_edge, config.tolerance
    refuse_overlap([(output, False)], [dem_path, buildings, roads, foreign,
                                       None if isinstance(area, BaseGeometry) else area])
    layers = {kind: read_prepared(source, name, feedback) for kind, source, name in
              (("buildings", buildings, PREPARED_BUILDINGS), ("roads", roads, PREPARED_ROADS),
               ("foreign", foreign, FOREIGN_BUILDINGS)) if source}
    crs: pyproj.CRS | None
    if not isinstance(area, BaseGeometry):
        area_layer = read_layer(area)
        polygons = [g for g in area_layer.geoms if g is not None]
        if not polygons:
            raise InputError(f"The study area {area} has no polygons.")
        area = shapely.union_all(polygons)
        crs = area_layer.crs
    else:
        crs = next(iter(layers.values())).crs if layers else None
    if crs is None:
        raise InputError("Give the study area as a layer (or a constraint layer) so the TIN's CRS is known.")
    for layer in layers.values():  # any layer: its geometries in the TIN's CRS
        if not layer.crs.equals(crs):
            layer.geoms = transform(layer.geoms, layer.crs, crs)
    if "buildings" in layers:
        area = covering_area(area, layers["buildings"].geoms, feedback)
    dem = Dem.open(dem_path, area.bounds, feedback=feedback, crs=crs)
    footprints = [f for kind in ("buildings", "foreign") if kind in layers for f in features(layers[kind])]
    tin, stats = triangulate(area, footprints, features(layers["roads"]) if "roads" in layers else [], dem,
                             max_edge, tolerance, config.footprints_as_holes, fixed_segments=tile is not None,
                             seam=tile.seam if tile is not None else None, feedback=feedback.scaled(0, 80),
                             triangulator=config.triangulator)
    tin = snap_to_grid(tin, dem)  # what is written is measured: edges can grow by up to 1.4 mm
    stats.max_edge = float(_longest_edges(tin.vertices[:, :2], tin.triangles).max())
    error = vertical_error(dem, tin.vertices, tin.triangles, tolerance)
    stats.max_vertical_error = max_vertical_error(dem, tin.vertices, tin.triangles, error, tolerance)
    if stats.max_vertical_error > tolerance:  # rounding to the millimetre moved a vertex by up to 0.7 mm
        feedback.warning(f"On the millimetre grid the TIN departs from the DEM by up to "
                         f"{stats.max_vertical_error:.3f} m, over the vertical tolerance of {tolerance:g} m.")
    stats.triangles = write_tin(output, tin, crs, config.spatial_index, feedback.scaled(80, 100))
    feedback.info("TIN: " + ", ".join(f"{k} {v}" for k, v in stats.as_dict().items()))
    feedback.progress(100)
    return stats
