"""Steiner points for a triangulation library that does not refine (``triangulators.CdtBackend``).

Triangle's quality and area switches have no counterpart in CDT, so the points that make triangles
small enough are placed here:

* ``lattice_points``: a first mesh whose triangles meet an area bound is a lattice of equilateral
  triangles of that area over the meshed faces, kept clear of the constraint segments (near them the
  segments' own vertices and the lattice's edge make the triangles);
* ``halve_long_edges``: the midpoint of each edge still longer than the maximum;
* ``refine``: then, round after round, one point in each triangle still over its area limit — its
  circumcentre when that lies inside the triangle (the Delaunay choice: no vertex is nearer to it
  than the triangle's corners), else the midpoint of its longest edge that is not a constraint,
  else its centroid.

No point is ever put on a constraint segment, so the segments stay exactly as the terrain split them
(the seam rule of tiled runs), and none goes nearer than a fraction of the wanted size to a segment,
a vertex or another new point: no sliver from near-duplicate vertices. A triangle that no such point
can improve stays as it is; the terrain's checks then report it.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..infra.arrays import edge_keys, edge_pairs, ragged_indices, triangle_edge_keys

if TYPE_CHECKING:
    from .triangulators import Mesh, Pslg, Triangulator

#: lattice spacing as a fraction of the maximum edge length: near the segments the triangles between
#: their vertices and the lattice have longer edges; at 0.85 about 0.1 % of the triangles of the 1 km
#: demo need a point more
LATTICE_SPACING = 0.85
#: lattice points nearer to a segment than this fraction of the lattice spacing are left out
LATTICE_CLEARANCE = 0.6
#: a band point beside a segment piece's midpoint: this fraction of the spacing away from it, kept when no
#: segment is nearer than BAND_CLEARANCE × spacing and no other point nearer than BAND_SPACING × spacing
BAND_OFFSET = 0.45
BAND_CLEARANCE = 0.3
BAND_SPACING = 0.45
#: a new point keeps this fraction of the wanted edge length (√ of its triangle's area limit) from
#: segments, vertices and the other new points
CLEARANCE = 0.2
#: and never less than this (m): well above the 1 mm grid of the constraints
MIN_CLEARANCE = 0.005
MAX_ROUNDS = 16


def lattice_points(pslg: Pslg, max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Steiner points of a first mesh and the region of each: an equilateral lattice over the meshed faces,
    clear of the segments, and in the band it leaves along them one point beside each segment piece."""
    lattice = _Lattice(pslg.vertices.min(axis=0), pslg.vertices.max(axis=0), LATTICE_SPACING * max_edge)
    p, q = pslg.vertices[pslg.segments[:, 0]], pslg.vertices[pslg.segments[:, 1]]
    kept = ~lattice.near_segments(p, q, LATTICE_CLEARANCE * lattice.spacing)
    nodes = lattice.points(kept)

    d = q - p
    normal = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
    offset = BAND_OFFSET * lattice.spacing * normal
    band = np.vstack([(p + q) / 2 + offset, (p + q) / 2 - offset])
    band = band[~lattice.near_nodes(band, kept, BAND_SPACING * lattice.spacing)]
    band = band[~_near_segments(band, pslg, np.full(len(band), BAND_CLEARANCE * lattice.spacing))]
    band = band[_spaced(band, np.full(len(band), BAND_SPACING * lattice.spacing))]
    points = np.vstack([nodes, band])
    region = pslg.locate(points, BAND_CLEARANCE * lattice.spacing)
    return points[region >= 0], region[region >= 0]


class _Lattice:
    """Equilateral lattice nodes (row j, column i) at x = (i + (j mod 2) / 2)·spacing, y = j·spacing·√3/2,
    over a box; whole-grid questions answered by index arithmetic instead of a spatial index."""

    def __init__(self, lower: np.ndarray, upper: np.ndarray, spacing: float):
        self.spacing, self.row = spacing, spacing * math.sqrt(3.0) / 2.0
        self.j0, self.i0 = math.floor(lower[1] / self.row), math.floor(lower[0] / spacing) - 1
        self.shape = (math.ceil(upper[1] / self.row) - self.j0 + 1, math.ceil(upper[0] / spacing) - self.i0 + 2)

    def xy(self, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        """Coordinates of nodes given by absolute row and column."""
        return np.column_stack([(i + 0.5 * (j % 2)) * self.spacing, j * self.row])

    def points(self, mask: np.ndarray) -> np.ndarray:
        j, i = np.nonzero(mask)
        return self.xy(j + self.j0, i + self.i0)

    def _around(self, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(owner, j, i): every node of the grid in each box lower–upper (absolute indices)."""
        j_lo = np.maximum(np.ceil(lower[:, 1] / self.row).astype(np.int64), self.j0)
        j_hi = np.minimum(np.floor(upper[:, 1] / self.row).astype(np.int64), self.j0 + self.shape[0] - 1)
        i_lo = np.maximum(np.floor(lower[:, 0] / self.spacing - 0.5).astype(np.int64), self.i0)
        i_hi = np.minimum(np.ceil(upper[:, 0] / self.spacing).astype(np.int64), self.i0 + self.shape[1] - 1)
        nj, ni = np.maximum(j_hi - j_lo + 1, 0), np.maximum(i_hi - i_lo + 1, 0)
        owner, k = ragged_indices(nj * ni)
        return owner, j_lo[owner] + k // np.maximum(ni[owner], 1), i_lo[owner] + k % np.maximum(ni[owner], 1)

    def near_segments(self, p: np.ndarray, q: np.ndarray, distance: float, chunk: int = 65536) -> np.ndarray:
        """Mask of the nodes within ``distance`` of a segment p–q."""
        near = np.zeros(self.shape, dtype=bool)
        for start in range(0, len(p), chunk):
            a, b = p[start:start + chunk], q[start:start + chunk]
            owner, j, i = self._around(np.minimum(a, b) - distance, np.maximum(a, b) + distance)
            node = self.xy(j, i)
            d = b[owner] - a[owner]
            t = np.clip(((node - a[owner]) * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-300), 0.0, 1.0)
            gap = node - (a[owner] + t[:, None] * d)
            hit = (gap * gap).sum(axis=1) <= distance * distance
            near[j[hit] - self.j0, i[hit] - self.i0] = True
        return near

    def near_nodes(self, points: np.ndarray, mask: np.ndarray, distance: float) -> np.ndarray:
        """Each point within ``distance`` of a node of ``mask``."""
        owner, j, i = self._around(points - distance, points + distance)
        gap = self.xy(j, i) - points[owner]
        hit = ((gap * gap).sum(axis=1) <= distance * distance) & mask[j - self.j0, i - self.i0]
        near = np.zeros(len(points), dtype=bool)
        near[owner[hit]] = True
        return near


def halve_long_edges(backend: Triangulator, mesh: Mesh, pslg: Pslg, max_edge: float, rounds: int = 1) -> Mesh:
    """``mesh`` with the midpoint of every edge longer than ``max_edge`` added (not of a segment: segments are
    split beforehand), where it keeps ``CLEARANCE`` × ``max_edge`` from the segments; a round or two."""
    for _ in range(rounds):
        xy, tris = mesh.vertices, mesh.triangles
        keys = triangle_edge_keys(tris).ravel()
        ends = edge_pairs(keys)
        long = np.flatnonzero(((xy[ends[:, 1]] - xy[ends[:, 0]]) ** 2).sum(axis=1) > max_edge * max_edge)
        long = long[~np.isin(keys[long], mesh.constrained)]
        long = long[np.unique(keys[long], return_index=True)[1]]  # each edge once
        if not len(long):
            break
        points = 0.5 * (xy[ends[long, 0]] + xy[ends[long, 1]])
        clear = ~_near_segments(points, pslg, np.full(len(points), CLEARANCE * max_edge))
        if not clear.any():
            break
        region = mesh.region[long[clear] // 3]
        mesh = backend.insert(mesh, pslg, points[clear], np.where(region >= 0, region, -3))
    return mesh


def refine(backend: Triangulator, mesh: Mesh, pslg: Pslg, limits: np.ndarray) -> Mesh:
    """``mesh`` with points added until every triangle with a positive limit has at most that area.

    The limits live on the vertices (a vertex: the largest limit of its triangles; a new point: its
    triangle's), and a later triangle gets one when all its corners have one: the refined zone stays
    where it was asked for instead of spreading to neighbours that are bigger than the limit.
    """
    vertex_limit = np.full(len(mesh.vertices), -np.inf)
    np.maximum.at(vertex_limit, mesh.triangles[limits > 0].ravel(), np.repeat(limits[limits > 0], 3))
    vertex_limit[vertex_limit == -np.inf] = np.inf  # no limit
    triangle_limit = limits
    origin = np.arange(len(mesh.triangles))  # each triangle's row in the mesh given, −1 when new
    for _ in range(MAX_ROUNDS):
        xy, tris = mesh.vertices, mesh.triangles
        limited = np.flatnonzero(triangle_limit > 0)
        corners = xy[tris[limited]]
        area = 0.5 * ((corners[:, 1, 0] - corners[:, 0, 0]) * (corners[:, 2, 1] - corners[:, 0, 1])
                      - (corners[:, 1, 1] - corners[:, 0, 1]) * (corners[:, 2, 0] - corners[:, 0, 0]))
        bad = limited[area > triangle_limit[limited]]
        if not len(bad):
            break
        made, points = split_points(mesh, pslg, bad, triangle_limit[bad])
        if not len(points):
            break
        region = mesh.region[bad[made]]
        mesh = backend.insert(mesh, pslg, points, np.where(region >= 0, region, -3))  # −3: not known
        origin = np.where(mesh.origin >= 0, origin[mesh.origin], -1) if mesh.origin is not None \
            else np.full(len(mesh.triangles), -1)
        vertex_limit = np.concatenate([vertex_limit, np.full(len(mesh.vertices) - len(vertex_limit), np.inf)])
        vertex_limit[len(xy):len(xy) + len(points)] = triangle_limit[bad[made]]
        near = np.isfinite(vertex_limit)
        triangle_limit = np.full(len(mesh.triangles), -1.0)
        zone = np.flatnonzero(near[mesh.triangles].all(axis=1))
        triangle_limit[zone] = vertex_limit[mesh.triangles[zone]].max(axis=1)
    mesh.origin = origin
    return mesh


def split_points(mesh: Mesh, pslg: Pslg, bad: np.ndarray, limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One new point for each of the ``bad`` triangles where one can go (see the module): (which of
    ``bad`` got one, the points). A circumcentre inside its triangle is as far from every vertex as the
    corners are (Delaunay); a midpoint or a centroid is checked against the triangle's corners."""
    xy, tris = mesh.vertices, mesh.triangles[bad]
    a, b, c = xy[tris[:, 0]], xy[tris[:, 1]], xy[tris[:, 2]]
    clearance = np.maximum(CLEARANCE * np.sqrt(limits), MIN_CLEARANCE)

    centre = circumcentres(a, b, c)
    own = inside(centre, a, b, c)

    edges = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1)  # (k, 3, 2)
    lengths = np.linalg.norm(xy[edges[:, :, 1]] - xy[edges[:, :, 0]], axis=2)
    lengths[np.isin(edge_keys(edges), mesh.constrained)] = -1.0  # constraint pieces are never split
    longest = lengths.argmax(axis=1)
    ends = edges[np.arange(len(tris)), longest]
    midpoint = np.where((lengths.max(axis=1) > 0)[:, None], 0.5 * (xy[ends[:, 0]] + xy[ends[:, 1]]), np.nan)

    # the circumcentre inside the triangle (an acute one); else the midpoint of its longest edge, as
    # Ruppert's algorithm does for an obtuse one (its circumcentre lies beyond that edge); else the
    # centroid. Each lies in the triangle or on its edge: never on a vertex of the mesh
    candidates = np.stack([np.where(own[:, None], centre, np.nan), midpoint, (a + b + c) / 3.0])  # (3, k, 2)
    corners = np.stack([a, b, c], axis=1)
    chosen = np.full((len(tris), 2), np.nan)
    for rank, candidate in enumerate(candidates):  # the first acceptable one of each triangle
        todo = np.flatnonzero(np.isnan(chosen[:, 0]) & np.isfinite(candidate).all(axis=1))
        if not len(todo):
            continue
        clear = ~_near_segments(candidate[todo], pslg, clearance[todo])
        if rank:
            gaps = np.linalg.norm(corners[todo] - candidate[todo][:, None, :], axis=2)
            clear &= (gaps >= clearance[todo, None]).all(axis=1)
        chosen[todo[clear]] = candidate[todo[clear]]
    made = np.flatnonzero(np.isfinite(chosen[:, 0]))
    made = made[_spaced(chosen[made], clearance[made])]
    return made, chosen[made]


def circumcentres(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Circumcentre of each triangle (nan for a degenerate one), computed relative to ``a``."""
    ab, ac = b - a, c - a
    d = 2.0 * (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])
    ab2, ac2 = (ab ** 2).sum(axis=1), (ac ** 2).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (ac[:, 1] * ab2 - ab[:, 1] * ac2) / d
        uy = (ab[:, 0] * ac2 - ac[:, 0] * ab2) / d
    out = a + np.column_stack([ux, uy])
    out[d == 0] = np.nan
    return out


def inside(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Each point strictly inside its counter-clockwise triangle."""
    def side(u, v):
        return (v[:, 0] - u[:, 0]) * (p[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (p[:, 0] - u[:, 0])

    with np.errstate(invalid="ignore"):
        return (side(a, b) > 0) & (side(b, c) > 0) & (side(c, a) > 0)


def _near_segments(points: np.ndarray, pslg: Pslg, distance: np.ndarray) -> np.ndarray:
    """Each point within its ``distance`` of a constraint segment of ``pslg``."""
    near = np.zeros(len(points), dtype=bool)
    if not len(points) or not len(pslg.segments):
        return near
    p, q = pslg.vertices[pslg.segments[:, 0]], pslg.vertices[pslg.segments[:, 1]]
    point, segment = pslg.segment_grid(float(distance.max())).near(points, distance)
    d = q[segment] - p[segment]
    t = np.clip(((points[point] - p[segment]) * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-300), 0.0, 1.0)
    gap = points[point] - (p[segment] + t[:, None] * d)
    near[point[(gap * gap).sum(axis=1) <= distance[point] ** 2]] = True
    return near


class SegmentGrid:
    """The segments listed in the cells of a uniform grid that their boxes meet, to find the segments near
    many points at once without building a tree each time. Cells about as big as a segment, and at least
    ``reach``: a point's search box then meets a few cells only."""

    def __init__(self, p: np.ndarray, q: np.ndarray, reach: float):
        lower, upper = np.minimum(p, q), np.maximum(p, q)
        self.cell = max(float(np.median(upper - lower)) * 2.0, reach, 1e-3)
        self.origin = lower.min(axis=0)
        segment, key = self._cells(lower, upper)
        order = np.argsort(key, kind="stable")
        self.segment, self.key = segment[order], key[order]

    def _cells(self, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo = np.floor((lower - self.origin) / self.cell).astype(np.int64)
        n = np.floor((upper - self.origin) / self.cell).astype(np.int64) - lo + 1
        owner, k = ragged_indices(n[:, 0] * n[:, 1])
        return owner, (lo[owner, 0] + k // n[owner, 1]) * (1 << 31) + lo[owner, 1] + k % n[owner, 1]

    def near(self, points: np.ndarray, distance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point, segment) whose boxes come within each point's ``distance``."""
        point, key = self._cells(points - distance[:, None], points + distance[:, None])
        start, stop = np.searchsorted(self.key, key, "left"), np.searchsorted(self.key, key, "right")
        owner, k = ragged_indices(stop - start)
        return point[owner], self.segment[start[owner] + k]


def _candidates(points: np.ndarray, reach: float, lower: np.ndarray,
                upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (point, box) where the point may lie within ``reach`` of the box: every box grown by ``reach``
    is listed in each cell of a uniform grid it meets, and a point looks in its own cell."""
    cell = max(2.0 * reach, float(np.median(upper - lower)) if len(lower) else 0.0, 1e-9)
    origin = np.minimum(points.min(axis=0), lower.min(axis=0)) - reach
    lo = np.floor((lower - reach - origin) / cell).astype(np.int64)
    n = np.floor((upper + reach - origin) / cell).astype(np.int64) - lo + 1
    box, k = ragged_indices(n[:, 0] * n[:, 1])
    key = (lo[box, 0] + k // n[box, 1]) * (1 << 31) + lo[box, 1] + k % n[box, 1]
    order = np.argsort(key, kind="stable")
    box, key = box[order], key[order]
    own = np.floor((points - origin) / cell).astype(np.int64)
    point_key = own[:, 0] * (1 << 31) + own[:, 1]
    start, stop = np.searchsorted(key, point_key, "left"), np.searchsorted(key, point_key, "right")
    point, k = ragged_indices(stop - start)
    return point, box[start[point] + k]


def _spaced(points: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """Which points to keep so that no two kept ones are nearer than the first one's ``distance``
    (of two near ones, the later goes)."""
    keep = np.ones(len(points), dtype=bool)
    if len(points) < 2:
        return keep
    j, i = _candidates(points, float(distance.max()), points, points)
    close = (i < j) & (((points[i] - points[j]) ** 2).sum(axis=1) <= distance[i] ** 2)
    keep[j[close]] = False
    return keep
