"""The TIN as it is written: on the model's millimetre grid, still watertight, one GeoPackage feature per triangle."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import ogr

from ..infra.arrays import edge_pairs, ragged_indices, triangle_edge_keys
from ..infra.dem import Dem
from ..infra.feedback import SILENT, Feedback
from ..infra.io.gpkg_bulk import write_layer
from ..infra.io.vector_io import FieldDef
from ..infra.step_layers import TIN_FEATURE_ID, TIN_LAYER, TIN_SURFACE, TIN_TRIANGLE_ID
from .constraints import Constraints
from .mesh import ROUNDING, Tin, _areas_3d, _triangle_areas, _with_heights

DEGENERATE_AREA = 2e-6  # m² at mm precision; validators reject ≤ 1e-6
#: no two vertices of the written TIN closer (m): val3dity, the reference validator of CityJSON, reads vertices
#: within its 1 mm snap tolerance as one, so an edge of 1-1.5 mm (two millimetre-grid points side by side) was a
#: "repeated point" to it
MIN_EDGE = 0.01


def snap_to_grid(tin: Tin, dem: Dem, max_passes: int = 8) -> Tin:
    """The TIN with its vertices on the model's millimetre grid, as they are written, and still watertight.

    The one place where coordinates are rounded: road and relief triangles (and neighbouring tiles)
    then write a shared vertex with the same digits. Vertices closer than ``MIN_EDGE`` become one
    (``_weld``: the triangles between them vanish; no crack, both sides lose them), so no edge is shorter;
    heights are the DEM's at the rounded points. A triangle left without area (three points in a row to the
    millimetre) or turned over by rounding is taken out by splitting the triangle across its longest edge at its third
    corner, so the ground keeps no T-junction; at the rim or a footprint it is simply dropped.
    Vertex indices are kept (a merged vertex points to the first of its group).
    """
    steps = np.rint(tin.vertices[:, :2] / ROUNDING).astype(np.int64)
    low = steps.min(axis=0) if len(steps) else np.zeros(2, dtype=np.int64)
    _, first, inverse = np.unique((steps[:, 0] - low[0]) * (1 << 32) + (steps[:, 1] - low[1]),
                                  return_index=True, return_inverse=True)
    xyz = _with_heights(dem, steps * ROUNDING)
    tris, surface, feature = first[inverse.ravel()][tin.triangles], tin.surface, tin.feature_id
    for weld in (False, True):
        if weld:
            tris = _weld(xyz, tris, steps)[tris]
        alive = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 2] != tris[:, 0])
        tris, surface, feature = tris[alive], surface[alive], feature[alive]
    return _mend_flat(xyz, tris, surface, feature, tin.constraints, max_passes)


def _weld(xyz: np.ndarray, tris: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Each vertex's representative: vertices of ``tris`` closer than ``MIN_EDGE`` become one, so no two left are.

    The mesh's rim (the area's edge, a tile's border, the footprints' holes: edges one triangle uses) keeps its
    place: a rim vertex takes the inner ones near it, and rim vertices near each other become the one first in
    (x, y) order, a rule of the rim alone, so a neighbouring tile, whose rim along the border holds the same
    vertices, welds them alike (no crack between tiles). The other vertices near each other become the first
    of each group in (x, y) order. Moves are at most about ``MIN_EDGE``.
    """
    keys = triangle_edge_keys(tris).ravel()
    edge, count = np.unique(keys, return_counts=True)
    rim = np.zeros(len(xyz), dtype=bool)
    rim[edge_pairs(edge[count == 1]).ravel()] = True
    a, b = _close_pairs(xyz, steps, np.flatnonzero(np.bincount(tris.ravel(), minlength=len(xyz))))
    representative = np.arange(len(xyz))
    if not len(a):
        return representative
    order = np.lexsort((steps[:, 1], steps[:, 0]))
    rank = np.empty(len(xyz), dtype=np.int64)
    rank[order] = np.arange(len(xyz))  # (x, y) order of the vertices
    both = rim[a] & rim[b]
    _join(representative, a[both], b[both], rank)
    inner = ~rim[a] | ~rim[b]
    a, b = a[inner], b[inner]
    to_rim = rim[a] != rim[b]  # an inner vertex goes to its nearest rim vertex's representative
    inner_of, rim_of = np.where(rim[a], b, a)[to_rim], np.where(rim[a], a, b)[to_rim]
    gap = np.hypot(*(xyz[inner_of, :2] - xyz[rim_of, :2]).T)
    nearest = np.lexsort((gap, inner_of))
    first = np.ones(len(nearest), dtype=bool)
    first[1:] = inner_of[nearest][1:] != inner_of[nearest][:-1]
    taken = inner_of[nearest][first]
    representative[taken] = representative[rim_of[nearest][first]]
    free = ~to_rim & ~np.isin(a, taken) & ~np.isin(b, taken)
    _join(representative, a[free], b[free], rank)
    return representative


def _close_pairs(xyz: np.ndarray, steps: np.ndarray, used: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (a, b), a < b, of the ``used`` vertices within ``MIN_EDGE`` of each other, in (a, b) order.

    The few candidates are found on the millimetre grid (``steps``, no two used vertices alike), cell by
    cell; GEOS then decides for them as an STRtree of all the points did (a pair's verdict is its own, so
    the rounding at exactly ``MIN_EDGE`` comes out the same), at a small part of the cost.
    """
    if len(used) < 2:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    reach = MIN_EDGE / ROUNDING + 0.5  # grid steps: farther apart is farther than MIN_EDGE
    cell = math.ceil(reach)  # close vertices lie in the same or in neighbouring cells
    cells = steps[used] // cell
    cells -= cells.min(axis=0)
    width = int(cells[:, 1].max()) + 2  # a row of cells more: no key of a neighbour wraps into another column
    key = cells[:, 0] * width + cells[:, 1]
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    found = []
    for dx, dy in ((0, 0), (0, 1), (1, -1), (1, 0), (1, 1)):  # each neighbouring pair of cells once
        start = np.searchsorted(ordered, ordered + dx * width + dy, "left")
        stop = np.searchsorted(ordered, ordered + dx * width + dy, "right")
        if dx == dy == 0:
            start = np.arange(1, len(ordered) + 1)  # the points after it in its own cell
        owner, k = ragged_indices(np.maximum(stop - start, 0))
        found.append(np.column_stack([order[owner], order[start[owner] + k]]))
    i, j = np.vstack(found).T
    near = ((steps[used[i]] - steps[used[j]]) ** 2).sum(axis=1) <= reach ** 2
    candidates = np.unique(np.concatenate([i[near], j[near]]))
    points = shapely.points(xyz[used[candidates], :2])
    near_a, near_b = shapely.STRtree(points).query(points, predicate="dwithin", distance=MIN_EDGE)
    a, b = used[candidates[near_a]], used[candidates[near_b]]
    close = a < b
    a, b = a[close], b[close]
    order = np.lexsort((b, a))
    return a[order], b[order]


def _join(representative: np.ndarray, a: np.ndarray, b: np.ndarray, rank: np.ndarray) -> None:
    """Union of the vertex pairs (a, b) into ``representative``: each group becomes its member of lowest rank."""
    parent: dict[int, int] = {}

    def root(v: int) -> int:
        while parent.get(v, v) != v:
            v = parent[v]
        return v

    for u, v in zip(a.tolist(), b.tolist()):
        ru, rv = root(u), root(v)
        if ru != rv:
            low, high = (ru, rv) if rank[ru] < rank[rv] else (rv, ru)
            parent[high] = low
    for v in parent:
        representative[v] = root(v)


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
    """Write the TIN as PolygonZ triangles (layer ``step_layers.TIN_LAYER``), one feature per triangle.

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
