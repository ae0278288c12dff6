"""Constraints for the terrain mesh: footprints, roads and the area cleaned into a graph Triangle cannot choke on.

``triangle`` (Shewchuk's Triangle) crashes the whole process on duplicate vertices and crossing
segments, and QGIS with it. So the constraints are cleaned first: polygons made valid and
snapped to a 1 mm grid, all boundaries noded by snap rounding (crossings split, overlaps merged,
duplicates and zero-length pieces gone, segments routed through vertices that snapping left
beside them) and clipped to the area. Each face of the resulting arrangement gets one seed
point: a hole (outside the area, or a footprint when footprints are holes) or a region whose
attribute tells which surface and feature its triangles belong to; millimetre slivers are meshed
as part of their neighbour. In a tile, the border runs through canonical points its neighbours
share (``Seam``).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError

#: snapping grid for constraint coordinates (m): far below survey accuracy, far above float noise
GRID = 0.001


#: polygon parts narrower than this on average (m) are slivers and dropped
MIN_WIDTH = 0.01


TERRAIN, ROAD, FOOTPRINT = range(3)  # indices into step_layers.TIN_SURFACES


Feature = tuple[str | None, BaseGeometry]  # (wit_id, polygon)


@dataclass
class Constraints:
    """Cleaned input for Triangle: coordinates are relative to ``origin`` (better conditioning)."""

    origin: tuple[float, float]
    vertices: np.ndarray  # (n, 2)
    segments: np.ndarray  # (m, 2) vertex indices, noded: no crossings, no duplicates
    holes: np.ndarray  # (h, 2) one point inside each face that is not meshed
    regions: np.ndarray  # (r, 2) one point inside each meshed face; its attribute is its row + 1
    region_surface: np.ndarray  # (r,) index into TIN_SURFACES
    region_feature: np.ndarray  # (r,) wit_id or None
    faces: np.ndarray  # (f,) polygons: the faces of the noded segments, in world coordinates
    meshed: np.ndarray  # (f,) bool: the face is triangulated (else it is a hole)
    area: BaseGeometry  # the cleaned study area
    footprints: list[Feature]  # cleaned, clipped to the area
    roads: list[Feature]
    dropped: int  # input features that vanished (empty, outside the area, thinner than the grid)


def _polygonal(geoms: np.ndarray) -> np.ndarray:
    """Keep the polygonal parts of each geometry that are not slivers (None when nothing is left).

    A sliver (mean width 2·area/perimeter under ``MIN_WIDTH``) would make Triangle fill it with
    thousands of tiny triangles; it carries no information at city scale.
    """
    geoms = np.asarray(geoms, dtype=object)
    out = np.full(len(geoms), None, dtype=object)
    types = shapely.get_type_id(geoms)
    area, length = shapely.area(geoms), shapely.length(geoms)
    one_part = (types == 3) | ((types == 6) & (shapely.get_num_geometries(geoms) == 1))
    simple = one_part & (area > 0) & (2 * area >= MIN_WIDTH * length)  # the usual case, vectorised
    out[simple] = geoms[simple]
    for k in np.flatnonzero(~simple & (types >= 0)):
        parts = shapely.get_parts(shapely.get_parts(geoms[k]))  # collections hold multi-parts: flatten twice
        keep = (shapely.get_type_id(parts) == 3) & (2 * shapely.area(parts) >= MIN_WIDTH * shapely.length(parts))
        keep &= shapely.area(parts) > 0
        if keep.any():
            out[k] = shapely.multipolygons(parts[keep]) if keep.sum() > 1 else parts[keep][0]
    return out


def _each(func, geoms: np.ndarray, *args, **kwargs) -> np.ndarray:
    """``func`` over an array of geometries; where GEOS gives up on one, that one becomes None."""
    try:
        return func(geoms, *args, **kwargs)
    except shapely.errors.GEOSException:
        out = np.empty(len(geoms), dtype=object)
        for k, g in enumerate(geoms):
            try:
                out[k] = func(g, *args, **kwargs)
            except shapely.errors.GEOSException:
                out[k] = None
        return out


SEAM_SNAP = 0.003  # m: noded vertices this close to a tile border are moved onto it (a canonical point) or off it


SEAM_REACH = 0.05  # m: how far along the border such a vertex may move to its canonical point (shallow crossings)


@dataclass(frozen=True)
class Seam:
    """A tile's border and its canonical points (see ``wit_plugin.sheetrun.seams``)."""

    tile: BaseGeometry  # the tile's polygon
    points: np.ndarray  # (k, 2) canonical points on its border, on the 1 mm grid

    def insert(self, geoms):
        """``geoms`` (a geometry or a sequence, None kept) with the canonical points within half a snap distance
        of an edge inserted as vertices: an edge along the border (a road's, cut by the tile) and the border
        itself then hold the same vertices, instead of crossing each other at a grazing angle somewhere
        between them (a node the neighbour would not have)."""
        if not len(self.points):
            return geoms
        points = shapely.multipoints(self.points)
        if isinstance(geoms, BaseGeometry):
            return shapely.snap(geoms, points, SEAM_SNAP / 2)
        out = np.array(list(geoms), dtype=object)
        present = np.array([g is not None for g in out], dtype=bool)
        if present.any():
            near = present.copy()
            near[present] = shapely.dwithin(out[present].astype(object), self.tile.exterior, SEAM_SNAP)
            out[near] = shapely.snap(out[near].astype(object), points, SEAM_SNAP / 2)
        return list(out)

    def snap(self, coords: np.ndarray) -> np.ndarray:
        """``coords`` within SEAM_SNAP of the border moved onto the nearest canonical point (within SEAM_REACH:
        where a wall crosses the border at a shallow angle a sub-millimetre shift moves the crossing along it by
        millimetres), the others SEAM_SNAP × 1.5 inside the tile: a point on only one side of a border (a wall a
        millimetre from it) would split the border on that side alone."""
        border = self.tile.exterior
        near = np.flatnonzero(shapely.dwithin(border, shapely.points(coords), SEAM_SNAP))
        if not len(near):
            return coords
        out = coords.copy()
        close = np.zeros(len(near), dtype=bool)
        if len(self.points):
            tree = shapely.STRtree(shapely.points(self.points))
            index, distance = tree.query_nearest(shapely.points(coords[near]), return_distance=True, all_matches=False)
            close[index[0]] = distance <= SEAM_REACH
            out[near[index[0][distance <= SEAM_REACH]]] = self.points[index[1][distance <= SEAM_REACH]]
        for k in near[~close]:
            along = border.project(shapely.Point(coords[k]))
            foot = shapely.get_coordinates(border.interpolate(along))[0]
            edge = shapely.get_coordinates(border.interpolate(along + 1e-3))[0] - foot
            normal = np.array([-edge[1], edge[0]]) / (np.hypot(*edge) or 1.0) * SEAM_SNAP * 1.5
            inside = foot + normal if self.tile.contains(shapely.Point(foot + normal)) else foot - normal
            out[k] = np.round(inside, 3)
        return out


def _split_border(seam: Seam, vertices: np.ndarray, segments: np.ndarray,
                  tol: float = 1.5e-3) -> tuple[np.ndarray, np.ndarray]:
    """Split the segments that run along the tile's border at every canonical point lying on them, so both
    sides of a border hold all of its canonical points (``vertices`` in world coordinates)."""
    if not len(seam.points) or not len(segments):
        return vertices, segments
    on = shapely.dwithin(seam.tile.exterior, shapely.points(vertices), tol)
    along = np.flatnonzero(on[segments[:, 0]] & on[segments[:, 1]])
    if not len(along):
        return vertices, segments
    p, q = vertices[segments[along, 0]], vertices[segments[along, 1]]
    lines = shapely.linestrings(np.stack([p, q], axis=1))
    which, point = shapely.STRtree(shapely.points(seam.points)).query(lines, predicate="dwithin", distance=tol)
    d = q[which] - p[which]
    t = ((seam.points[point] - p[which]) * d).sum(axis=1) / (d * d).sum(axis=1)
    inner = (t > 1e-9) & (t < 1 - 1e-9) & (np.hypot(*(seam.points[point] - p[which]).T) > tol) \
        & (np.hypot(*(seam.points[point] - q[which]).T) > tol)
    if not inner.any():
        return vertices, segments
    which, point, t = which[inner], point[inner], t[inner]
    ids = np.arange(len(vertices), len(vertices) + len(point))
    vertices = np.vstack([vertices, seam.points[point]])
    chains = []
    for k in np.unique(which):
        mine = np.flatnonzero(which == k)
        chain = [segments[along[k], 0], *ids[mine[np.argsort(t[mine])]], segments[along[k], 1]]
        chains += list(zip(chain[:-1], chain[1:]))
    split = np.zeros(len(segments), dtype=bool)
    split[along[np.unique(which)]] = True
    return vertices, np.vstack([segments[~split], np.array(chains, dtype=segments.dtype)])


def clean_polygons(geoms: Sequence[BaseGeometry | None] | np.ndarray, area: BaseGeometry | None = None,
                   grid: float = GRID) -> np.ndarray:
    """Valid, snapped to ``grid`` and clipped to ``area``; None for what does not survive.

    Repair uses GEOS's "structure" method, which rebuilds areas from the rings (a bow-tie gives
    both lobes) rather than keeping collapsed lines and points.
    """
    polys = np.array([g if g is not None else shapely.Polygon() for g in geoms], dtype=object)
    steps: list[tuple[Callable[..., np.ndarray], tuple, dict[str, Any]]] = [
        (shapely.make_valid, (), {"method": "structure"}), (shapely.set_precision, (grid,), {})]
    if area is not None:
        steps.append((shapely.intersection, (area,), {"grid_size": grid}))
        shapely.prepare(area)
    for func, args, kwargs in steps:
        alive = np.array([g is not None for g in polys], dtype=bool)
        if func is shapely.make_valid:  # most are valid already
            alive[alive] = ~shapely.is_valid(polys[alive])
        if func is shapely.intersection:  # most lie well inside: already clipped (and on the grid)
            alive[alive] = ~shapely.contains_properly(area, polys[alive])
        if not alive.any():
            continue
        polys[alive] = _polygonal(_each(func, polys[alive], *args, **kwargs))
    return polys


def clean_constraints(area: BaseGeometry, buildings: Sequence[Feature], roads: Sequence[Feature] = (),
                      footprints_as_holes: bool = True, grid: float = GRID, seam: Seam | None = None) -> Constraints:
    """Turn possibly messy polygons into a noded straight-line graph that Triangle cannot choke on.

    ``seam`` (tiles): vertices the noding left within ``SEAM_SNAP`` of the tile's border move onto the
    border's canonical points, which the neighbouring tile computes alike.
    """
    (clean_area,) = clean_polygons([area], None, grid)
    if clean_area is None:
        raise InputError("The study area is empty or has no area; give a polygon (or a point and a radius).")
    fps = clean_polygons([g for _, g in buildings], clean_area, grid)
    rds = clean_polygons([g for _, g in roads], clean_area, grid)
    if seam is not None:  # the border runs through its canonical points on every polygon along it
        clean_area, fps, rds = seam.insert(clean_area), seam.insert(fps), seam.insert(rds)
    footprints = [(fid, g) for (fid, _), g in zip(buildings, fps) if g is not None]
    road_list = [(rid, g) for (rid, _), g in zip(roads, rds) if g is not None]
    dropped = len(buildings) + len(roads) - len(footprints) - len(road_list)

    # All boundaries noded together; faces under footprints become holes below when they are
    # holes (a union of the footprints first would cost several times the noding itself)
    lines = [clean_area.boundary] + [g.boundary for _, g in footprints] + [g.boundary for _, g in road_list]
    noded = shapely.get_parts(shapely.union_all(lines, grid_size=grid))

    # Snap rounding may bend a boundary by up to half a grid cell, which can leave sub-millimetre
    # faces whose side is a matter of rounding; each face is decided once, here, by its seed.
    faces = shapely.get_parts(shapely.polygonize(noded))
    seeds = shapely.point_on_surface(faces)
    seed_xy = shapely.get_coordinates(seeds)
    surface, feature = _classify(seeds, footprints, road_list)
    in_area = shapely.contains_xy(clean_area, seed_xy[:, 0], seed_xy[:, 1])
    meshed = in_area & ~((surface == FOOTPRINT) & footprints_as_holes)

    host = _sliver_hosts(faces, meshed)

    # The segments are the edges of the meshed faces (the noded pieces, vertex for vertex) but
    # those between a sliver and its host: walls shared by two buildings and road edges under
    # buildings bound no mesh, and left in they would only make Triangle work around them
    mesh_faces = np.flatnonzero(meshed)
    rings = shapely.get_rings(faces[mesh_faces])
    coords, part = shapely.get_coordinates(rings, return_index=True)
    ring_face = mesh_faces[np.repeat(np.arange(len(mesh_faces)), shapely.get_num_interior_rings(faces[mesh_faces]) + 1)]
    origin = (math.floor(clean_area.bounds[0]), math.floor(clean_area.bounds[1]))
    if seam is not None:
        coords = seam.snap(coords)
    keys = np.rint((coords - origin) / grid).astype(np.int64)
    unique_keys, vertex = np.unique(keys, axis=0, return_inverse=True)
    vertex = vertex.ravel()
    a, b = vertex[:-1], vertex[1:]
    keep = (part[:-1] == part[1:]) & (a != b)
    edges = np.column_stack([np.sort(np.column_stack([a[keep], b[keep]]), axis=1), host[ring_face[part[:-1][keep]]]])
    rows, count = np.unique(edges, axis=0, return_counts=True)  # an edge twice in one host is inside it
    segments = _split_at_near_vertices(unique_keys * grid, rows[count == 1, :2], 0.7 * grid)
    if seam is not None:  # every canonical point of the border on it, here as on the neighbour's side
        world, segments = _split_border(seam, unique_keys * grid + origin, segments)
        unique_keys = np.rint((world - origin) / grid).astype(np.int64)
    # a sliver keeps its seed (snap rounding can leave it cut off from its host after all) with its host's labels
    surface, feature = surface[host], feature[host]
    # a hole seed outside the segments' convex hull marks nothing (the outside is not meshed anyway) and
    # crashes Triangle: a face beyond the area's rim bounded by unmeshed faces only, found by the fuzz test
    holes = seed_xy[~meshed] - origin
    if len(holes):
        hull = shapely.convex_hull(shapely.multipoints(unique_keys * grid))
        holes = holes[shapely.contains_xy(hull, holes[:, 0], holes[:, 1])]
    return Constraints(
        origin=origin, vertices=unique_keys * grid, segments=segments,
        holes=holes, regions=seed_xy[meshed] - origin,
        region_surface=surface[meshed], region_feature=feature[meshed], faces=faces, meshed=meshed,
        area=clean_area, footprints=footprints, roads=road_list, dropped=dropped)


def _sliver_hosts(faces: np.ndarray, meshed: np.ndarray) -> np.ndarray:
    """For each face, the face it is meshed with: a meshed sliver's meshed neighbour along its
    longest shared boundary, else the face itself.

    Snap rounding leaves slivers a millimetre wide where a road edge runs along a wall; on their
    own Triangle would fill them with thousands of needle triangles (its minimum angle applies
    everywhere), merged into their neighbour they cost nothing.
    """
    host = np.arange(len(faces))
    sliver = meshed & (2 * shapely.area(faces) < MIN_WIDTH * shapely.length(faces))
    if not sliver.any():
        return host
    targets = np.flatnonzero(meshed & ~sliver)
    slivers = np.flatnonzero(sliver)
    s, t = shapely.STRtree(faces[targets]).query(faces[slivers], predicate="touches")
    if not len(s):
        return host
    shared = shapely.length(shapely.intersection(shapely.boundary(faces[slivers[s]]),
                                                 shapely.boundary(faces[targets[t]])))
    order = np.lexsort((-shared, s))  # per sliver, the longest shared boundary first
    s, t, shared = s[order], t[order], shared[order]
    first = np.r_[True, s[1:] != s[:-1]] & (shared > 0)
    host[slivers[s[first]]] = targets[t[first]]
    return host


def _split_at_near_vertices(vertices: np.ndarray, segments: np.ndarray, tol: float,
                            max_passes: int = 5) -> np.ndarray:
    """Unique segments, each split at every vertex that lies within ``tol`` of it (but not at its ends).

    GEOS's snap-rounded noding can leave a vertex a fraction of a grid cell beside a segment it
    should split (near-collinear edges meeting at a shallow angle). Triangle then sees an edge
    that almost touches a vertex and fills the gap with slivers and tiny triangles (tens of
    thousands on the 1 km demo); routing the segment through the vertex moves it by at most
    ``tol``. Repeated, as a bent segment can come near another vertex.
    """
    done = np.empty((0, 2), dtype=np.int64)  # checked: no vertex near them
    todo = np.unique(np.sort(segments, axis=1), axis=0)
    tree = shapely.STRtree(shapely.points(vertices))
    for _ in range(max_passes):
        p, q = vertices[todo[:, 0]], vertices[todo[:, 1]]
        seg, vert = tree.query(shapely.box(*(np.minimum(p, q) - tol).T, *(np.maximum(p, q) + tol).T))
        inner = (todo[seg, 0] != vert) & (todo[seg, 1] != vert)
        vert, seg = vert[inner], seg[inner]
        p, q = vertices[todo[seg, 0]], vertices[todo[seg, 1]]
        d = q - p
        t = ((vertices[vert] - p) * d).sum(axis=1) / (d ** 2).sum(axis=1)
        gap = vertices[vert] - (p + np.clip(t, 0.0, 1.0)[:, None] * d)
        near = (gap ** 2).sum(axis=1) <= tol ** 2
        vert, seg, t = vert[near], seg[near], t[near]
        untouched = np.ones(len(todo), dtype=bool)
        untouched[seg] = False
        done = np.vstack([done, todo[untouched]])
        if not len(vert):
            todo = todo[:0]
            break
        order = np.lexsort((t, seg))
        seg, vert = seg[order], vert[order]
        # each split segment becomes the chain start, its near vertices in order, end; the new
        # pieces are checked again (only they can have come near another vertex)
        split = np.unique(seg)
        first = np.searchsorted(seg, split)
        last = np.r_[first[1:], len(seg)] - 1
        pieces = np.vstack([np.column_stack([todo[split, 0], vert[first]]),
                            np.column_stack([vert[:-1], vert[1:]])[seg[:-1] == seg[1:]],
                            np.column_stack([vert[last], todo[split, 1]])])
        pieces = pieces[pieces[:, 0] != pieces[:, 1]]
        todo = np.unique(np.sort(pieces, axis=1), axis=0)
    return np.unique(np.vstack([done, todo]), axis=0).astype(np.int32)


def _classify(points: np.ndarray, footprints: Sequence[Feature],
              roads: Sequence[Feature]) -> tuple[np.ndarray, np.ndarray]:
    """Surface and feature id at each point: a building wins over a road, the first listed over later ones."""
    surface = np.full(len(points), TERRAIN, dtype=np.int8)
    feature = np.full(len(points), None, dtype=object)
    for code, features in ((ROAD, roads), (FOOTPRINT, footprints)):  # footprints last: they win
        if not features:
            continue
        tree = shapely.STRtree([g for _, g in features])
        pt, hit = tree.query(points, predicate="intersects")  # as "within" for interior points, 30x faster
        first = np.full(len(points), len(features), dtype=np.int64)
        np.minimum.at(first, pt, hit)
        found = first < len(features)
        surface[found] = code
        feature[found] = [features[k][0] for k in first[found]]
    return surface, feature
