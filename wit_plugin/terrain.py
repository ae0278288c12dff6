"""Terrain TIN: constrained Delaunay triangulation of the study area (wit:triangulateterrain).

Building footprints and road polygons are constraints, so every triangle lies wholly on terrain,
on a road or under a building, and the later steps can drape roads and cut holes exactly.
Heights come from the DEM by bilinear interpolation (``dem.Dem``), and the mesh is refined until
no edge is longer than ``max_edge`` and the planar triangles stay within ``tolerance`` of the
interpolated DEM surface everywhere (``vertical_error``: a rigorous cheap bound settles most
triangles, the rest and the reported maximum are measured exactly). Refinement for edge length
re-meshes only patches around the few triangles that need it.

``triangle`` (Shewchuk's Triangle) crashes the whole process on duplicate vertices and crossing
segments, and QGIS with it. So the constraints are cleaned first: polygons made valid and
snapped to a 1 mm grid, all boundaries noded by snap rounding (crossings split, overlaps merged,
duplicates and zero-length pieces gone, segments routed through vertices that snapping left
beside them) and clipped to the area. Each face of the resulting arrangement gets one seed
point: a hole (outside the area, or a footprint when footprints are holes) or a region whose
attribute tells which surface and feature its triangles belong to; millimetre slivers are meshed
as part of their neighbour.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal, ogr, osr
from shapely.geometry.base import BaseGeometry

from . import triangulators
from .arrays import ragged_indices
from .dem import Dem
from .deps import require
from .errors import InputError
from .feedback import SILENT, Feedback
from .fileio import refuse_overlap
from .gpkg_bulk import write_layer
from .model import (
    FOREIGN_BUILDINGS,
    PREPARED_BUILDINGS,
    PREPARED_ROADS,
    TIN_FEATURE_ID,
    TIN_LAYER,
    TIN_SURFACE,
    TIN_SURFACES,
    TIN_TRIANGLE_ID,
    WIT_ID,
)
from .polygons import transform
from .triangulators import edge_pairs, triangle_edge_keys
from .vector_io import FieldDef, VectorLayer, read_layer, read_prepared

#: snapping grid for constraint coordinates (m): far below survey accuracy, far above float noise
GRID = 0.001
#: polygon parts narrower than this on average (m) are slivers and dropped
MIN_WIDTH = 0.01
DEGENERATE_AREA = 2e-6  # m² at mm precision; validators reject ≤ 1e-6
ROUNDING = 1e-3  # m: the precision coordinates are written with
#: the first pass's triangles are about this × max_edge² (Triangle's area bound), for the size estimate
AREA_FACTOR = triangulators.AREA_FACTOR
#: refuse meshes that would not fit in memory on an ordinary machine
MAX_TRIANGLES = 30_000_000
TERRAIN, ROAD, FOOTPRINT = range(3)  # indices into model.TIN_SURFACES

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


@dataclass
class Tin:
    """The triangulated terrain: world coordinates, one label per triangle."""

    vertices: np.ndarray  # (n, 3)
    triangles: np.ndarray  # (m, 3), counter-clockwise seen from above
    surface: np.ndarray  # (m,) one of TIN_SURFACES
    feature_id: np.ndarray  # (m,) wit_id of the road / building, or None
    constraints: Constraints


@dataclass
class TinStats:
    """What the triangulation produced, for the log and the benchmark."""

    vertices: int
    triangles: int
    max_edge: float
    max_vertical_error: float
    refinement_iterations: int
    nodata_filled: int
    constraint_segments: int
    dropped_features: int
    triangles_by_surface: dict[str, int]

    def as_dict(self) -> dict:
        return asdict(self)


# -- cleaning --------------------------------------------------------------------------------


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
    """A tile's border and its canonical points (see ``wit_plugin.tiles.seams``)."""

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
            foot = shapely.get_coordinates(border.interpolate(border.project(shapely.Point(coords[k]))))[0]
            edge = shapely.get_coordinates(border.interpolate(border.project(shapely.Point(coords[k])) + 1e-3))[0] - foot
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


def clean_polygons(geoms: Sequence[BaseGeometry | None], area: BaseGeometry | None = None,
                   grid: float = GRID) -> np.ndarray:
    """Valid, snapped to ``grid`` and clipped to ``area``; None for what does not survive.

    Repair uses GEOS's "structure" method, which rebuilds areas from the rings (a bow-tie gives
    both lobes) rather than keeping collapsed lines and points.
    """
    geoms = np.array([g if g is not None else shapely.Polygon() for g in geoms], dtype=object)
    steps = [(shapely.make_valid, (), {"method": "structure"}), (shapely.set_precision, (grid,), {})]
    if area is not None:
        steps.append((shapely.intersection, (area,), {"grid_size": grid}))
        shapely.prepare(area)
    for func, args, kwargs in steps:
        alive = np.array([g is not None for g in geoms], dtype=bool)
        if func is shapely.make_valid:  # most are valid already
            alive[alive] = ~shapely.is_valid(geoms[alive])
        if func is shapely.intersection:  # most lie well inside: already clipped (and on the grid)
            alive[alive] = ~shapely.contains_properly(area, geoms[alive])
        if not alive.any():
            continue
        geoms[alive] = _polygonal(_each(func, geoms[alive], *args, **kwargs))
    return geoms


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


# -- triangulation and refinement -------------------------------------------------------------


def _split_long_segments(vertices: np.ndarray, segments: np.ndarray,
                         max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Subdivide segments longer than ``max_edge`` into equal pieces (new vertices appended)."""
    p, q = vertices[segments[:, 0]], vertices[segments[:, 1]]
    pieces = np.maximum(np.ceil(np.hypot(*(q - p).T) / max_edge - 1e-9), 1).astype(np.int64)
    owner, k = ragged_indices(pieces - 1)  # interior points of each segment
    t = ((k + 1) / pieces[owner])[:, None]
    new = p[owner] + t * (q[owner] - p[owner])
    ids = np.arange(len(vertices), len(vertices) + len(new))
    # chain of every segment: start, its interior points, end
    starts = np.cumsum(pieces) - pieces  # position of each segment's first piece
    chain_a = np.empty(pieces.sum(), dtype=np.int64)
    chain_b = np.empty(pieces.sum(), dtype=np.int64)
    chain_a[starts] = segments[:, 0]
    chain_b[starts + pieces - 1] = segments[:, 1]
    inner = starts[owner] + k
    chain_b[inner] = ids
    chain_a[inner + 1] = ids
    return np.vstack([vertices, new]), np.column_stack([chain_a, chain_b]).astype(np.int32)


def _split_for_dem(vertices: np.ndarray, segments: np.ndarray, dem: Dem, origin: np.ndarray, tolerance: float,
                   max_rounds: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Halve every segment along which the DEM leaves the straight line between its ends by more than
    ``tolerance`` (exactly, ``Dem.deviation_range``), until none does.

    A rule of the segment alone: two tiles that share a border segment split it alike, so with no
    Steiner point allowed on segments afterwards their meshes meet vertex for vertex.
    """
    world = vertices + origin
    z = dem.sample(world[:, 0], world[:, 1])
    for _ in range(max_rounds):
        p, q = segments[:, 0], segments[:, 1]
        low, high = dem.deviation_range(world[p, 0], world[p, 1], z[p], world[q, 0], world[q, 1], z[q],
                                        ends_on_surface=True)
        bad = np.maximum(-low, high) > tolerance
        if not bad.any():
            break
        mid = 0.5 * (vertices[p[bad]] + vertices[q[bad]])
        ids = np.arange(len(vertices), len(vertices) + len(mid))
        vertices = np.vstack([vertices, mid])
        world = np.vstack([world, mid + origin])
        z = np.concatenate([z, dem.sample(mid[:, 0] + origin[0], mid[:, 1] + origin[1])])
        segments = np.vstack([segments[~bad], np.column_stack([p[bad], ids]), np.column_stack([ids, q[bad]])])
    return vertices, segments.astype(np.int32)


def _triangle_areas(xy: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _longest_edges(xy: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    squared = [((q - p) ** 2).sum(axis=1) for p, q in ((a, b), (b, c), (c, a))]
    return np.sqrt(np.maximum(np.maximum(squared[0], squared[1]), squared[2]))


def _with_heights(dem: Dem, world: np.ndarray) -> np.ndarray:
    return np.column_stack([world, dem.sample(world[:, 0], world[:, 1])])


def vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
    """Max |DEM − planar triangle| per triangle (vertex z must be DEM heights): exact wherever it
    exceeds ``tolerance`` (0: everywhere), elsewhere possibly an upper bound that is itself within
    ``tolerance``, so ``error > tolerance`` picks exactly the triangles that are too far off.

    Most triangles are settled by ``Dem.plane_deviation_bound``; only the rest are measured
    exactly (``exact_vertical_error``).
    """
    if not len(tris):
        return np.zeros(0)
    error = dem.plane_deviation_bound(xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]])
    over = np.flatnonzero(error > tolerance)
    error[over] = exact_vertical_error(dem, xyz, tris[over])
    return error


def max_vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray, error: np.ndarray, tolerance: float) -> float:
    """The exact maximum of ``error`` as ``vertical_error(…, tolerance)`` gave it (updated in place).

    The values above ``tolerance`` are exact; the largest bounds below are measured exactly in
    falling order until none can beat the largest exact value (by a nanometre).
    """
    slack = 1e-9  # m: rounding noise in the bounds costs nothing
    over = error > tolerance
    exact_max = float(error[over].max()) if over.any() else 0.0
    if not over.any() and len(error):  # a first guess from the largest bounds keeps the sort below short
        top = np.argpartition(-error, min(1024, len(error) - 1))[:1024]
        error[top] = exact_vertical_error(dem, xyz, tris[top])
        over[top] = True
        exact_max = float(error[top].max())
    rest = np.flatnonzero(~over & (error > exact_max + slack))
    rest = rest[np.argsort(-error[rest], kind="stable")]
    start, size = 0, 1024  # growing batches: few calls, little wasted work
    while start < len(rest) and error[rest[start]] > exact_max + slack:
        batch = rest[start:start + size]
        error[batch] = exact_vertical_error(dem, xyz, tris[batch])
        exact_max = max(exact_max, float(error[batch].max()))
        start, size = start + size, 2 * size
    return exact_max


def exact_vertical_error(dem: Dem, xyz: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Exact max |DEM − planar triangle| over each triangle (vertex z must be DEM heights).

    The difference of the piecewise bilinear DEM and a plane is bilinear inside each DEM cell,
    hence linear along the grid lines through the cell centres: its extremes over a triangle lie
    on the triangle's edges (``Dem.deviation_range``) or at the cell centres inside it.
    """
    if not len(tris):
        return np.zeros(0)
    unique, inverse = np.unique(triangle_edge_keys(tris), return_inverse=True)
    i, j = edge_pairs(unique).T
    lo, hi = dem.deviation_range(xyz[i, 0], xyz[i, 1], xyz[i, 2], xyz[j, 0], xyz[j, 1], xyz[j, 2],
                                 ends_on_surface=True)
    error = np.maximum(-lo, hi)[inverse.ravel()].reshape(-1, 3).max(axis=1)

    a, b, c = xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]]
    corners = np.stack([a, b, c])
    lower, upper = corners.min(axis=0), corners.max(axis=0)
    owner, x, y, z = dem.nodes_in_boxes(lower[:, 0], lower[:, 1], upper[:, 0], upper[:, 1])
    if len(owner):
        a, b, c = a[owner], b[owner], c[owner]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        with np.errstate(divide="ignore", invalid="ignore"):  # a sliver too thin for world coordinates
            wa = ((b[:, 0] - x) * (c[:, 1] - y) - (b[:, 1] - y) * (c[:, 0] - x)) / det
            wb = ((c[:, 0] - x) * (a[:, 1] - y) - (c[:, 1] - y) * (a[:, 0] - x)) / det
        wc = 1.0 - wa - wb
        inside = (wa >= -1e-12) & (wb >= -1e-12) & (wc >= -1e-12)
        dev = np.abs(z - (wa * a[:, 2] + wb * b[:, 2] + wc * c[:, 2]))
        np.maximum.at(error, owner[inside], dev[inside])
    return error


def triangulate(area: BaseGeometry, buildings: Sequence[Feature], roads: Sequence[Feature], dem: Dem,
                max_edge: float = 5.0, tolerance: float = 0.5, footprints_as_holes: bool = True,
                max_iterations: int = 10, fixed_segments: bool = False, seam: Seam | None = None,
                feedback: Feedback = SILENT, triangulator: int | None = None) -> tuple[Tin, TinStats]:
    """Mesh the area with footprints and roads as constraints, refined to ``max_edge`` and ``tolerance``.

    ``triangulator``: a ``triangulators.BACKENDS`` key (None: Triangle where installed, else CDT); the
    checks and the refinement they drive are the same whichever backend meshes.
    ``fixed_segments`` (tiles): every segment — the tile's border above all — is split beforehand by a
    rule of the segment alone (equal pieces ≤ ``max_edge``, then halved until the DEM is within
    ``tolerance`` along it) and no Steiner point may go on any segment, so neighbouring tiles share
    their border vertices exactly. A backend that never splits segments gets them split so always.
    """
    backend = triangulators.backend(triangulator)
    if not max_edge > 0 or not tolerance > 0:
        raise InputError("Max edge length and vertical tolerance must be positive.")
    require([backend.module])
    feedback.info(f"Triangulator: {backend.label}; licence: {backend.licence}.")
    feedback.progress(0)
    cons = clean_constraints(area, buildings, roads, footprints_as_holes, seam=seam)
    estimate = cons.area.area / (AREA_FACTOR * max_edge ** 2)
    if estimate > MAX_TRIANGLES:
        raise InputError(f"A max edge length of {max_edge} m would make about {estimate:,.0f} triangles over this "
                         "area; use a longer max edge or split the area into tiles.")
    if cons.dropped:
        feedback.warning(f"{cons.dropped} building/road polygon(s) dropped: empty, outside the area or slivers "
                         f"narrower than {MIN_WIDTH * 100:.0f} cm.")
    feedback.check_canceled()
    feedback.progress(10)

    if not len(cons.regions):
        raise InputError("Nothing is left to triangulate: building footprints cover the whole study area.")
    origin = np.array(cons.origin, dtype=np.float64)
    # tiles: the same pieces whichever backend meshes, so a resumed run's tiles meet those of an earlier one
    piece = min(b.piece_length for b in triangulators.BACKENDS) if fixed_segments else backend.piece_length
    # rounding to the millimetre before writing (snap_to_grid) lengthens an edge by up to 1.4 mm: the mesh keeps
    # 2 mm below the limit, so the written TIN is within it
    target = max_edge - 2 * ROUNDING if max_edge > 20 * ROUNDING else max_edge
    vertices, segments = _split_long_segments(cons.vertices, cons.segments, piece * target)
    fixed = fixed_segments or not backend.splits_segments
    if fixed:
        vertices, segments = _split_for_dem(vertices, segments, dem, origin, tolerance)
    pslg = triangulators.Pslg(vertices, segments, cons.holes, cons.regions, _face_locator(cons))
    mesh = backend.mesh(pslg, target, fixed)
    xy = np.empty((0, 2))
    xyz = np.empty((0, 3))
    longest = error = np.empty(0)
    iterations = 0
    while True:  # take the mesh in: heights of the new vertices, length and DEM error of the new triangles
        known = len(xy) if np.array_equal(mesh.vertices[:len(xy)], xy) else 0  # refining keeps vertices
        xy, tris = mesh.vertices, mesh.triangles
        xyz = np.vstack([xyz[:known], _with_heights(dem, xy[known:] + origin)])
        fresh = np.flatnonzero(mesh.origin < 0) if mesh.origin is not None and known else None
        if fresh is None:
            longest, error = _longest_edges(xy, tris), vertical_error(dem, xyz, tris, tolerance)
        else:  # only the new triangles are measured
            longest, error = longest[mesh.origin], error[mesh.origin]
            longest[fresh] = _longest_edges(xy, tris[fresh])
            error[fresh] = vertical_error(dem, xyz, tris[fresh], tolerance)
        too_long = longest > target * (1 + 1e-9)
        too_far = error > tolerance
        feedback.info(f"Mesh pass {iterations}: {len(tris)} triangles, {int(too_long.sum())} with an edge over "
                      f"{max_edge:g} m, {int(too_far.sum())} more than {tolerance:g} m off the DEM.")
        if not (too_long.any() or too_far.any()) or iterations == max_iterations:
            break
        feedback.check_canceled()
        feedback.progress(10 + 80 * (iterations + 1) / (max_iterations + 1))
        iterations += 1
        # error shrinks with the square of the size (area); at least halve what is too far off
        shrink = np.ones(len(tris))
        shrink[too_long] = 0.9 * (target / longest[too_long]) ** 2
        shrink[too_far] = np.minimum(shrink[too_far], np.clip(0.8 * tolerance / error[too_far], 0.05, 0.5))
        bad = too_long | too_far
        limits = np.full(len(tris), -1.0)
        limits[bad] = shrink[bad] * _triangle_areas(xy, tris[bad])
        previous = len(tris)
        mesh = backend.refine(mesh, pslg, limits, fixed, whole=bool(too_far.any()))
        if len(mesh.triangles) == previous and np.array_equal(mesh.triangles, tris):
            break  # no Steiner point could go where one is needed
    tris = mesh.triangles
    max_error = max_vertical_error(dem, xyz, tris, error, tolerance)
    if too_long.any() or too_far.any():
        feedback.warning(f"After {iterations} refinement passes the mesh still has edges up to {longest.max():.2f} m "
                         f"and a vertical error up to {max_error:.3f} m.")
    feedback.info(f"Mesh: longest edge {longest.max():.2f} m, max vertical error {max_error:.3f} m.")

    surface, feature = _labels(mesh.region, xyz, tris, cons)
    tin = Tin(xyz, tris, surface, feature, cons)
    counts = {name: int((surface == name).sum()) for name in TIN_SURFACES}
    used = int(np.count_nonzero(np.bincount(tris.ravel(), minlength=len(xyz))))  # some lie in holes
    stats = TinStats(vertices=used, triangles=len(tris), max_edge=float(longest.max()),
                     max_vertical_error=max_error, refinement_iterations=iterations,
                     nodata_filled=dem.nodata_cells, constraint_segments=len(cons.segments),
                     dropped_features=cons.dropped, triangles_by_surface=counts)
    feedback.progress(100)
    return tin, stats


def _face_locator(cons: Constraints):
    """``Pslg.locate`` for the faces of ``cons``: the region row of each (origin-relative) point, −1 in a
    hole or outside the area, −2 in no face.

    Points at least ``clear`` from every segment (the CDT backend's lattice) are looked up in a raster of
    the faces with cells of ``clear`` / 0.75: the centre of a point's cell is then in the point's face,
    and GDAL burns a cell with the face its centre lies in. Other points: point in polygon.
    """
    region_row = np.where(cons.meshed, np.cumsum(cons.meshed) - 1, -1)
    faces = cons.faces.copy()
    shapely.prepare(faces)  # point in polygon on an edge index: the terrain face has thousands of holes
    tree = shapely.STRtree(faces)
    origin = np.array(cons.origin, dtype=np.float64)
    rasters: dict[float, tuple] = {}

    def exact(world: np.ndarray) -> np.ndarray:
        out = np.full(len(world), -2, dtype=np.int64)
        point, face = tree.query(shapely.points(world))  # boxes only, then the prepared polygons
        inside = shapely.contains_xy(faces[face], world[point, 0], world[point, 1])
        out[point[inside]] = region_row[face[inside]]
        return out

    def locate(points: np.ndarray, clear: float = 0.0) -> np.ndarray:
        if not len(points):
            return np.full(0, -2, dtype=np.int64)
        world = points + origin
        if clear <= 0:
            return exact(world)
        if clear not in rasters:
            rasters[clear] = _face_raster(faces, clear / 0.75)
        grid, x0, y0, cell = rasters[clear]
        if grid is None:
            return exact(world)
        col = np.floor((world[:, 0] - x0) / cell).astype(np.int64)
        row = np.floor((y0 - world[:, 1]) / cell).astype(np.int64)
        inside = (col >= 0) & (col < grid.shape[1]) & (row >= 0) & (row < grid.shape[0])
        out = np.full(len(world), -2, dtype=np.int64)
        face = grid[row[inside], col[inside]] - 1
        out[np.flatnonzero(inside)[face >= 0]] = region_row[face[face >= 0]]
        return out

    return locate


#: the face raster of ``_face_locator`` stays below this many cells (else point in polygon)
MAX_FACE_CELLS = 40_000_000


def _face_raster(faces: np.ndarray, cell: float) -> tuple:
    """(grid of face index + 1, 0 outside every face; x0; y0; cell) or (None, …) when too big."""
    xmin, ymin, xmax, ymax = shapely.total_bounds(faces)
    cols, rows = math.ceil((xmax - xmin) / cell) + 1, math.ceil((ymax - ymin) / cell) + 1
    if cols * rows > MAX_FACE_CELLS:
        return None, 0.0, 0.0, cell
    raster = gdal.GetDriverByName("MEM").Create("", cols, rows, 1, gdal.GDT_Int32)
    raster.SetGeoTransform((xmin, cell, 0.0, ymax, 0.0, -cell))
    frame = osr.SpatialReference()
    frame.SetLocalCS("faces")  # the same on both sides: no transformation
    raster.SetSpatialRef(frame)
    source = ogr.GetDriverByName("Memory").CreateDataSource("")
    layer = source.CreateLayer("faces", frame, geom_type=ogr.wkbPolygon)
    layer.CreateField(ogr.FieldDefn("id", ogr.OFTInteger))
    definition = layer.GetLayerDefn()
    for k, wkb in enumerate(shapely.to_wkb(faces)):
        feature = ogr.Feature(definition)
        feature.SetField(0, k + 1)
        feature.SetGeometry(ogr.CreateGeometryFromWkb(wkb))
        layer.CreateFeature(feature)
    gdal.RasterizeLayer(raster, [1], layer, options=["ATTRIBUTE=id"])
    return raster.GetRasterBand(1).ReadAsArray(), xmin, ymax, cell


def _areas_3d(xyz: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Area of each triangle in 3D."""
    a, b, c = xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def _labels(region: np.ndarray, xyz: np.ndarray, tris: np.ndarray,
            cons: Constraints) -> tuple[np.ndarray, np.ndarray]:
    """Surface name and feature id per triangle from its region (a row of ``cons.regions``, −1: none)."""
    unseeded = region < 0
    surface = np.empty(len(tris), dtype=object)
    feature = np.empty(len(tris), dtype=object)
    names = np.array(TIN_SURFACES, dtype=object)
    surface[~unseeded] = names[cons.region_surface[region[~unseeded]]]
    feature[~unseeded] = cons.region_feature[region[~unseeded]]
    if unseeded.any():  # a seed too close to a segment to be located; classify by centroid instead
        centroids = shapely.points(xyz[tris[unseeded]][:, :, :2].mean(axis=1))
        codes, ids = _classify(centroids, cons.footprints, cons.roads)
        surface[unseeded], feature[unseeded] = names[codes], ids
    return surface, feature


# -- files -------------------------------------------------------------------------------------


def snap_to_grid(tin: Tin, dem: Dem, max_passes: int = 8) -> Tin:
    """The TIN with its vertices on the model's millimetre grid, as they are written, and still watertight.

    The one place where coordinates are rounded: road and relief triangles (and neighbouring tiles)
    then write a shared vertex with the same digits. Vertices that round to the same point become one
    (the triangles between them vanish; no crack, both sides lose them); heights are the DEM's at the
    rounded points. A triangle left without area (three points in a row to the millimetre) or turned
    over by rounding is taken out by splitting the triangle across its longest edge at its third
    corner, so the ground keeps no T-junction; at the rim or a footprint it is simply dropped.
    Vertex indices are kept (a merged vertex points to the first of its group).
    """
    steps = np.rint(tin.vertices[:, :2] / ROUNDING).astype(np.int64)
    low = steps.min(axis=0) if len(steps) else np.zeros(2, dtype=np.int64)
    _, first, inverse = np.unique((steps[:, 0] - low[0]) * (1 << 32) + (steps[:, 1] - low[1]),
                                  return_index=True, return_inverse=True)
    xyz = _with_heights(dem, steps * ROUNDING)
    tris = first[inverse.ravel()][tin.triangles]
    surface, feature = tin.surface, tin.feature_id
    alive = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 2] != tris[:, 0])
    tris, surface, feature = tris[alive], surface[alive], feature[alive]
    return _mend_flat(xyz, tris, surface, feature, tin.constraints, max_passes)


def _key(a: int, b: int) -> int:
    """``triangulators.edge_keys`` of one edge, in plain integers."""
    return (min(a, b) << 31) | max(a, b)


def _flat(xyz: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Triangles without area at the model's precision, or turned over."""
    return (_areas_3d(xyz, tris) <= DEGENERATE_AREA) | (_triangle_areas(xyz, tris) <= 0)


def _mend_flat(xyz: np.ndarray, tris: np.ndarray, surface: np.ndarray, feature: np.ndarray, cons: Constraints,
               max_passes: int) -> Tin:
    """Remove the flat (or turned) triangles; each one's neighbour across its longest edge a–c is split in two
    at the flat one's third corner b, which lies on (or a rounding beyond) a–c. New triangles that are flat
    in turn are mended in the next pass. The few edges looked for are found among all in one vectorised
    search; the new triangles are searched one by one."""
    keys = triangle_edge_keys(tris).ravel()
    todo = list(np.flatnonzero(_flat(xyz, tris)))
    wanted = np.unique(keys.reshape(-1, 3)[todo]) if todo else np.empty(0, dtype=np.int64)
    at = np.minimum(np.searchsorted(wanted, keys), max(len(wanted) - 1, 0))
    owners: dict[int, list[int]] = {}
    for r in np.flatnonzero(wanted[at] == keys) if len(wanted) else []:
        owners.setdefault(int(keys[r]), []).append(int(r) // 3)
    rows = [tris]
    labels = [(surface, feature)]
    removed = np.zeros(len(tris), dtype=bool)
    extra: list[list[int]] = []  # new triangles (3 corners, the row their labels come from)
    extra_at: dict[int, list[int]] = {}  # edge key → rows of the new triangles with that edge

    def triangle(k: int) -> np.ndarray:
        return tris[k] if k < len(tris) else np.array(extra[k - len(tris)][:3])

    def across(k: int, key: int) -> int | None:
        found = owners[key] if key in owners else [int(r) // 3 for r in np.flatnonzero(keys == key)]
        found = found + extra_at.get(key, [])
        live = [r for r in found if r != k and not (removed[r] if r < len(tris) else extra[r - len(tris)][4])]
        return live[0] if live else None

    for _ in range(max_passes):
        if not todo:
            break
        made = len(extra)
        for k in todo:
            if k < len(tris) and removed[k] or k >= len(tris) and extra[k - len(tris)][4]:
                continue
            corners = triangle(k)
            lengths = [np.hypot(*(xyz[corners[(i + 1) % 3], :2] - xyz[corners[i], :2])) for i in range(3)]
            i = int(np.argmax(lengths))
            a, c, b = int(corners[i]), int(corners[(i + 1) % 3]), int(corners[(i + 2) % 3])
            n = across(k, _key(a, c))
            for r in (k, n):
                if r is None:
                    continue
                if r < len(tris):
                    removed[r] = True
                else:
                    extra[r - len(tris)][4] = True
            if n is not None:  # the neighbour runs c → a; at b it becomes c → b → d and b → a → d
                d = next(int(v) for v in triangle(n) if v != a and v != c)
                source = n if n < len(tris) else extra[n - len(tris)][3]
                for corners_new in ((c, b, d), (b, a, d)):
                    extra.append([*corners_new, source, False])
                    u, v, w = corners_new
                    for edge in (_key(u, v), _key(v, w), _key(w, u)):
                        extra_at.setdefault(edge, []).append(len(tris) + len(extra) - 1)
        new = np.array([e[:3] for e in extra[made:]], dtype=tris.dtype).reshape(-1, 3)
        todo = [len(tris) + made + int(k) for k in np.flatnonzero(_flat(xyz, new))] if len(new) else []
    keep = ~removed
    if extra:
        alive = np.array([not e[4] for e in extra])
        new = np.array([e[:3] for e in extra], dtype=tris.dtype)[alive]
        source = np.array([e[3] for e in extra])[alive]
        rows.append(new)
        labels.append((surface[source], feature[source]))
    return Tin(xyz, np.vstack([rows[0][keep], *rows[1:]]),
               np.concatenate([labels[0][0][keep], *[lab[0] for lab in labels[1:]]]),
               np.concatenate([labels[0][1][keep], *[lab[1] for lab in labels[1:]]]), cons)


def write_tin(path: str | Path, tin: Tin, crs: pyproj.CRS, spatial_index: bool = True,
              feedback: Feedback = SILENT) -> int:
    """Write the TIN as PolygonZ triangles (layer ``model.TIN_LAYER``), one feature per triangle.

    Give it a TIN on the millimetre grid (``snap_to_grid``): it is written as it is, and only a triangle
    that would be degenerate at that precision (none after ``snap_to_grid``) is left out, with a count.
    ``tri_id`` keeps the mesh's numbering. Returns the number written.
    """
    grid = np.round(tin.vertices / ROUNDING) * ROUNDING
    kept = np.flatnonzero((_areas_3d(grid, tin.triangles) > DEGENERATE_AREA)
                          & (_triangle_areas(grid, tin.triangles) > 0))
    if len(kept) < len(tin.triangles):
        feedback.warning(f"{len(tin.triangles) - len(kept)} triangle(s) without area at millimetre precision "
                         "not written.")
    triangles = tin.vertices[tin.triangles[kept]]
    fields = [FieldDef(TIN_TRIANGLE_ID, ogr.OFTInteger), FieldDef(TIN_SURFACE, ogr.OFTString),
              FieldDef(TIN_FEATURE_ID, ogr.OFTString)]
    return write_layer(path, TIN_LAYER, crs, fields, triangles, [kept, tin.surface[kept], tin.feature_id[kept]],
                       spatial_index=spatial_index, feedback=feedback)


def features(layer: VectorLayer) -> list[Feature]:
    """(wit_id, geometry) pairs of a prepared layer."""
    ids = layer.columns.get(WIT_ID) or [None] * len(layer)
    return list(zip(ids, layer.geoms))


def covering_area(area: BaseGeometry, footprints: Sequence[BaseGeometry | None],
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


def run(dem_path: str | Path, buildings: str | Path | None, roads: str | Path | None, output: str | Path,
        area: BaseGeometry | str | Path, max_edge: float = 5.0, tolerance: float = 0.5,
        footprints_as_holes: bool = True, spatial_index: bool = True, feedback: Feedback = SILENT,
        foreign: str | Path | None = None, fixed_segments: bool = False, seam: Seam | None = None,
        triangulator: int | None = None) -> TinStats:
    """wit:triangulateterrain: read the constraint layers and the DEM, mesh, write the TIN GeoPackage.

    ``buildings`` / ``roads`` are prepared layers (``file.gpkg|layername=…``, or the prepared
    GeoPackage itself); ``area`` is a polygon, or a vector source whose polygons together form it,
    grown to hold the footprints that cross its edge (``covering_area``). Tiles: ``foreign`` are the
    neighbouring tiles' buildings that cross into this one (footprints here, but they do not grow the
    area), and ``fixed_segments`` makes the border match the neighbours' (see ``triangulate``).
    ``triangulator``: a ``triangulators.BACKENDS`` key (None: the default).
    """
    refuse_overlap([(output, False)], [dem_path, buildings, roads, foreign,
                                       None if isinstance(area, BaseGeometry) else area])
    layers = {kind: read_prepared(source, name, feedback) for kind, source, name in
              (("buildings", buildings, PREPARED_BUILDINGS), ("roads", roads, PREPARED_ROADS),
               ("foreign", foreign, FOREIGN_BUILDINGS)) if source}
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
                             max_edge, tolerance, footprints_as_holes, fixed_segments=fixed_segments, seam=seam,
                             feedback=feedback.scaled(0, 80), triangulator=triangulator)
    tin = snap_to_grid(tin, dem)  # what is written is measured: edges can grow by up to 1.4 mm
    stats.max_edge = float(_longest_edges(tin.vertices[:, :2], tin.triangles).max())
    error = vertical_error(dem, tin.vertices, tin.triangles, tolerance)
    stats.max_vertical_error = max_vertical_error(dem, tin.vertices, tin.triangles, error, tolerance)
    if stats.max_vertical_error > tolerance:  # rounding to the millimetre moved a vertex by up to 0.7 mm
        feedback.warning(f"On the millimetre grid the TIN departs from the DEM by up to "
                         f"{stats.max_vertical_error:.3f} m, over the vertical tolerance of {tolerance:g} m.")
    stats.triangles = write_tin(output, tin, crs, spatial_index, feedback.scaled(80, 100))
    feedback.info("TIN: " + ", ".join(f"{k} {v}" for k, v in stats.as_dict().items()))
    feedback.progress(100)
    return stats
