"""Douglas–Peucker simplification that keeps shared boundaries shared (``simplify_shared``).

Boundaries are noded into arcs between junctions, each arc is simplified once, polygons are rebuilt
from their arcs, and arcs whose simplification would break validity or topology are kept as they
were (``arcs_kept`` in the stats of wit:preparevectors). Simplified layers have their vertices on a
1 mm grid.
"""
from __future__ import annotations

import numpy as np
import shapely

from ..infra.feedback import SILENT, Feedback
from ..infra.polygons import orient

GRID_SIZE = 0.001  # m: coordinates are snapped to this grid where boundaries are noded
OVERLAP_TOLERANCE = 1e-4  # m²: growth of an overlap between two polygons that simplification may cause
NODING_BATCH = 2000  # polygons noded together (see _arcs)


def simplify_shared(geoms: np.ndarray, tolerance: float, grid_size: float = GRID_SIZE,
                    feedback: Feedback = SILENT) -> tuple[np.ndarray, int]:
    """Douglas–Peucker that keeps every polygon valid and every shared wall shared.

    Coordinates are snapped to ``grid_size`` (so nearly equal walls become equal) and the
    boundaries noded together (``_arcs``); ``line_merge`` joins the pieces into arcs that run
    between junctions, so an arc is either owned by one polygon or shared whole by its
    neighbours. Each arc is simplified once with its end points fixed, and each polygon is
    rebuilt from its arcs (``build_area``), so neighbours see the very same simplified wall: no
    gap, no overlap. An arc goes back to its original shape when its simplified form crosses or
    touches another arc anywhere but at their common end points, or when a polygon built from it
    is invalid or changes its number of parts or holes, or when two polygons overlap more than
    before (an arc can flip across a thin gap or overlap of the source without crossing
    anything: the arcs along the grown part go back). Returns the geometries (None stays None)
    and the number of arcs kept unsimplified. Input polygons must be valid (``repair_polygons``).

    Cost: batched noding, STRtree queries and vectorised GEOS calls; close to linear in the
    number of vertices (100,000 buildings: see benchmarks/bench_vectors.py).
    """
    out = geoms.copy()
    live = np.flatnonzero(~shapely.is_missing(geoms))
    if tolerance <= 0 or len(live) == 0:
        return out, 0
    base = shapely.set_precision(geoms[live], grid_size)
    usable = ~shapely.is_empty(base)
    live, base = live[usable], base[usable]
    feat_tree = shapely.STRtree(base)  # simplified polygons lie within their original's envelope
    arcs0, arc_of, feat_of = _arcs(base, feat_tree, grid_size, feedback.scaled(0, 60))
    arcs = shapely.simplify(arcs0, tolerance, preserve_topology=False)
    arc_tree = shapely.STRtree(arcs0)  # likewise for arcs: DP keeps a subset of the vertices
    starts, stops = shapely.get_point(arcs0, 0), shapely.get_point(arcs0, -1)
    ends = shapely.multipoints(np.column_stack([shapely.get_coordinates(starts), shapely.get_coordinates(stops)])
                               .reshape(-1, 2, 2))
    closed = shapely.is_closed(arcs0)
    n_rings = np.bincount(shapely.get_rings(base, return_index=True)[1], minlength=len(base))
    n_parts = shapely.get_num_geometries(base)
    kept = np.zeros(len(arcs0), dtype=bool)
    result = base.copy()

    def revert(which: np.ndarray) -> np.ndarray:
        which = np.unique(which[~kept[which]])
        arcs[which] = arcs0[which]
        kept[which] = True
        return which

    def arc_conflicts(check: np.ndarray) -> np.ndarray:
        """Arcs (among ``check`` and their neighbours) whose current shapes conflict."""
        bad = check[(shapely.get_num_coordinates(arcs[check]) < 4) & closed[check] | ~shapely.is_simple(arcs[check])]
        a, b = arc_tree.query(arcs[check])
        a = check[a]
        in_check = np.zeros(len(arcs), dtype=bool)
        in_check[check] = True
        pairs = (a < b) | ((a != b) & ~in_check[b])  # each pair once
        a, b = a[pairs], b[pairs]
        pairs = shapely.intersects(arcs[a], arcs[b])
        a, b = a[pairs], b[pairs]
        # open arcs may only touch at common end points: touching, and no end point on the other's inside
        wrong = ~shapely.touches(arcs[a], arcs[b])
        for p, q in ((a, b), (b, a)):
            for end in (starts, stops):
                wrong |= shapely.intersects(end[p], arcs[q]) & ~shapely.intersects(end[p], ends[q])
        # closed arcs have no boundary in the OGC sense: compare the contact with the common end points
        ring = closed[a] | closed[b]
        wrong[ring] = ~shapely.equals(shapely.intersection(arcs[a[ring]], arcs[b[ring]]),
                                      shapely.intersection(ends[a[ring]], ends[b[ring]]))
        a, b = a[wrong], b[wrong]
        # one arc of a conflicting pair goes back (the other is re-checked against it next round)
        return np.concatenate([bad, np.where(kept[b], a, b)])

    def rebuild(features: np.ndarray) -> np.ndarray:
        """Rebuild ``features`` from their current arcs; return those that fail a check."""
        sel = np.isin(feat_of, features)
        arc_sel, feat_sel = arc_of[sel], feat_of[sel]
        groups, local = np.unique(feat_sel, return_inverse=True)
        lines = shapely.multilinestrings(arcs[arc_sel], indices=local)
        built = shapely.build_area(lines)
        arc_len = np.bincount(local, weights=shapely.length(arcs[arc_sel]), minlength=len(groups))
        ok = (shapely.is_valid(built) & ~shapely.is_empty(built)
              & (shapely.get_num_geometries(built) == n_parts[groups])
              & (np.bincount(shapely.get_rings(built, return_index=True)[1], minlength=len(groups)) == n_rings[groups])
              & np.isclose(shapely.length(built), arc_len, rtol=1e-9, atol=grid_size))
        result[groups[ok]] = built[ok]
        result[groups[~ok]] = base[groups[~ok]]
        return groups[~ok]

    owner_key = feat_of.astype(np.int64) * len(arcs0) + arc_of

    def grown_overlaps(features: np.ndarray) -> np.ndarray:
        """Arcs of two polygons that now overlap more than before (an arc may flip across a thin gap)."""
        a, b = feat_tree.query(result[features])
        a = features[a]
        pairs = (a != b) & shapely.intersects(result[a], result[b])
        a, b = a[pairs], b[pairs]
        now = shapely.relate_pattern(result[a], result[b], "T********")  # interiors meet
        a, b = a[now], b[now]
        grown = shapely.difference(shapely.intersection(result[a], result[b]), shapely.intersection(base[a], base[b]))
        parts, pair = shapely.get_parts(grown, return_index=True)
        big = shapely.area(parts) > OVERLAP_TOLERANCE
        parts, pair = parts[big], pair[big]
        region, arc = arc_tree.query(parts, predicate="intersects")
        owned = (np.isin(a[pair[region]].astype(np.int64) * len(arcs0) + arc, owner_key)
                 | np.isin(b[pair[region]].astype(np.int64) * len(arcs0) + arc, owner_key))
        region, arc = region[owned], arc[owned]
        # the arcs along or through the grown part (not those that merely touch a corner of it)
        interior_contact = shapely.relate(arcs[arc], parts[region]).astype("U2")  # DE-9IM II and IB
        return arc[np.char.count(interior_contact, "1") > 0]

    check = np.flatnonzero(~shapely.equals_exact(arcs, arcs0, 0.0))
    features = np.arange(len(base))
    while True:  # every round reverts at least one more arc, so this ends
        feedback.check_canceled()
        while len(check):
            check = revert(arc_conflicts(check))
        failed = rebuild(features)
        reverted = revert(np.concatenate([arc_of[np.isin(feat_of, failed)], grown_overlaps(features)]))
        if len(reverted) == 0:
            break
        check = reverted
        features = np.unique(feat_of[np.isin(arc_of, reverted)])
        feedback.progress(90)
    out[live] = orient(result)[0]
    feedback.progress(100)
    return out, int(np.count_nonzero(kept))


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Connected-component label per node of the graph with edges (a, b) (label propagation + pointer jumping)."""
    labels = np.arange(n)
    while True:
        low = np.minimum(labels[a], labels[b])
        before = labels.copy()
        np.minimum.at(labels, a, low)
        np.minimum.at(labels, b, low)
        while not np.array_equal(labels, labels[labels]):
            labels = labels[labels]
        if np.array_equal(labels, before):
            return labels


def _arcs(polygons: np.ndarray, tree: shapely.STRtree, grid_size: float,
          feedback: Feedback) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noded boundary arcs and their (arc, polygon) ownership pairs, sorted by polygon.

    Noding everything at once grows faster than linearly in GEOS, so polygons are grouped into
    batches of whole connected groups (polygons that touch or overlap always share a batch: arcs
    never interact across batches) of about ``NODING_BATCH`` polygons, spatially sorted.
    """
    a, b = tree.query(polygons, predicate="intersects")
    labels = _components(len(polygons), a, b)
    centre = shapely.get_coordinates(shapely.centroid(polygons))
    cell = max(np.ptp(centre[:, 0]), np.ptp(centre[:, 1]), 1.0) / max(np.sqrt(len(polygons) / NODING_BATCH), 1.0)
    key = np.floor((centre - centre.min(axis=0)) / cell)
    first = np.unique(labels, return_index=True)[1]  # one representative per group
    group_rank = np.empty(labels.max() + 1, dtype=int)
    group_rank[labels[first[np.lexsort((key[first, 1], key[first, 0]))]]] = np.arange(len(first))
    order = np.lexsort((labels, group_rank[labels]))
    boundaries = shapely.boundary(polygons)
    arcs, arc_of, feat_of = [], [], []
    start, n_arcs = 0, 0
    while start < len(order):
        stop = min(start + NODING_BATCH, len(order))
        while stop < len(order) and labels[order[stop]] == labels[order[stop - 1]]:
            stop += 1
        batch = order[start:stop]
        feedback.check_canceled()
        noded = shapely.get_parts(shapely.line_merge(_node(boundaries[batch], grid_size)))
        arc_i, poly_i = _arc_owners(noded, polygons[batch], grid_size)
        arcs.append(noded)
        arc_of.append(arc_i + n_arcs)
        feat_of.append(batch[poly_i])
        n_arcs += len(noded)
        start = stop
        feedback.progress(100.0 * stop / len(order))
    arc_of, feat_of = np.concatenate(arc_of), np.concatenate(feat_of)
    order = np.lexsort((arc_of, feat_of))
    return np.concatenate(arcs), arc_of[order], feat_of[order]


def _node(lines: np.ndarray, grid_size: float) -> shapely.Geometry:
    """Node and dissolve linework: GEOS's noder (fast), else snap-rounding union (robust, slower)."""
    try:
        return shapely.node(shapely.multilinestrings(shapely.get_parts(lines)))
    except shapely.errors.GEOSException:
        return shapely.union_all(lines, grid_size=grid_size)


def _arc_owners(arcs: np.ndarray, polygons: np.ndarray, grid_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (arc, polygon) such that the arc is part of the polygon's boundary.

    Works on the faces of the noded arcs (``polygonize``), whose edges are exactly the arcs, so no
    tolerance wider than rounding is needed even where source polygons overlap by a sliver: a face
    belongs to the polygons that contain its interior point, and an arc bounds a polygon when
    exactly one of the (one or two) faces beside it belongs to that polygon.
    """
    faces = shapely.get_parts(shapely.polygonize(arcs))
    face_of, poly_of = shapely.STRtree(polygons).query(shapely.point_on_surface(faces), predicate="intersects")
    first_mid = (shapely.get_coordinates(shapely.get_point(arcs, 0))
                 + shapely.get_coordinates(shapely.get_point(arcs, 1))) / 2
    arc_at, face_at = shapely.STRtree(shapely.boundary(faces)).query(shapely.points(first_mid), predicate="dwithin",
                                                                     distance=grid_size * 1e-3)
    # expand (arc, face) by the polygons of each face: CSR over faces
    order = np.argsort(face_of, kind="stable")
    face_of, poly_of = face_of[order], poly_of[order]
    starts = np.searchsorted(face_of, np.arange(len(faces) + 1))
    per_face = np.diff(starts)[face_at]
    arc_rep = np.repeat(arc_at, per_face)
    within_face = np.arange(per_face.sum()) - np.repeat(np.cumsum(per_face) - per_face, per_face)
    offsets = np.repeat(starts[face_at], per_face) + within_face
    key, counts = np.unique(poly_of[offsets].astype(np.int64) * len(arcs) + arc_rep, return_counts=True)
    key = key[counts % 2 == 1]
    return key % len(arcs), key // len(arcs)
