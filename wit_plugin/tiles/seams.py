"""Where a tile's terrain meets its neighbours': the canonical points of its border.

Each side of a border nodes its own constraints, and snap rounding may put a crossing a millimetre
apart on the two sides. So both sides compute the same points from the same data — each border
edge oriented the same way (from its lexicographically smaller corner), crossed by the run's area
boundary, the run's road polygons (uncut) and the footprints that cross it (a tile holds them all,
as its own or as foreign buildings) — and move their noded vertices onto them
(``terrain.Seam``). With the segments then split by a rule of the segment alone and no Steiner
point allowed on them (``terrain.triangulate(fixed_segments=True)``), neighbours share their
border vertices and heights exactly.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ..terrain.constraints import Seam

GRID_DECIMALS = 3  # the 1 mm grid of the terrain's constraints


def border_edges(tile: BaseGeometry) -> list[shapely.LineString]:
    """The tile polygon's edges, each from its lexicographically smaller end (as its neighbour sees it)."""
    ring = shapely.get_coordinates(tile.exterior)
    return [shapely.LineString(sorted([tuple(p), tuple(q)])) for p, q in zip(ring[:-1], ring[1:])]


def tile_seam(tile: BaseGeometry, crossing: Sequence[BaseGeometry]) -> Seam:
    """The seam of ``tile``: its border and where ``crossing`` geometries' boundaries cross it."""
    edges = border_edges(tile)
    boundaries = np.array([g.boundary for g in crossing if g is not None and not g.is_empty], dtype=object)
    points = [shapely.get_coordinates(np.array(edges, dtype=object))]
    for edge in edges:
        near = boundaries[shapely.intersects(edge, boundaries)] if len(boundaries) else boundaries
        if len(near):
            points.append(shapely.get_coordinates(shapely.intersection(edge, near)))
    xy = np.round(np.concatenate(points), GRID_DECIMALS)
    return Seam(tile, np.unique(xy, axis=0))
