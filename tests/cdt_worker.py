"""Robustness property of the terrain triangulation, run in a child process.

``triangle`` kills its process on bad input (segfault), which would take pytest down with it and
report nothing useful. So test_terrain runs this file as a subprocess: the hypothesis loop runs
here, and the parent asserts a clean exit. Before each example its inputs are written to the file
named by ``--last`` so that a crash can be reproduced.

Usage: python cdt_worker.py EXAMPLES SEED --last FILE [--triangulator KEY]
"""
from __future__ import annotations

import argparse
import faulthandler
import sys
import time
from itertools import pairwise
from pathlib import Path

import numpy as np
import shapely
from shapely import affinity

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from wit_plugin.infra.dem import Dem
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.step_layers import TIN_SURFACES
from wit_plugin.terrain import constraints, mesh


def hill_dem(cell: float = 2.0, origin: float = -60.0, size: int = 120) -> Dem:
    """A DEM with a sharp 30 m hill and a ridge, covering −60…180 m at 2 m cells by default."""
    centres = origin + (np.arange(size) + 0.5) * cell
    x, y = np.meshgrid(centres, centres[::-1])
    z = 30.0 * np.exp(-((x - 40.0) ** 2 + (y - 55.0) ** 2) / 150.0) + 8.0 * np.exp(-((x - y) ** 2) / 30.0) + 0.05 * x
    return Dem(z, (origin, cell, 0.0, origin + size * cell, 0.0, -cell))


def check_mesh(tin: mesh.Tin, dem: Dem, footprints_as_holes: bool) -> None:
    """Assert the mesh invariants: non-degenerate, constraints kept, exact cover, heights from the DEM."""
    cons = tin.constraints
    xy = tin.vertices[:, :2]
    tris = tin.triangles
    origin = np.array(cons.origin)
    # input vertices keep their indices, so the constraint segments can be looked up
    np.testing.assert_allclose(xy[:len(cons.vertices)], cons.vertices + origin, rtol=0, atol=1e-9)

    a, b, c = xy[tris[:, 0]] - origin, xy[tris[:, 1]] - origin, xy[tris[:, 2]] - origin
    areas = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    assert (areas > 0).all(), f"{int((areas <= 0).sum())} degenerate or clockwise triangle(s)"

    # triangles tile exactly the faces of the constraint graph that were chosen to be meshed
    faces, meshed = cons.faces, cons.meshed
    lines = shapely.linestrings(np.stack([cons.vertices[cons.segments[:, 0]], cons.vertices[cons.segments[:, 1]]],
                                         axis=1) + origin)
    expected = shapely.area(faces[meshed]).sum()
    # a face narrower than the snapping grid collapses onto a bent chain shared by both its sides
    # (segments are split at vertices snap rounding left within 0.7 mm): its area is not meshed
    widths = 2 * shapely.area(faces[meshed]) / shapely.length(faces[meshed])
    collapsed = shapely.area(faces[meshed][widths < constraints.GRID]).sum()
    assert abs(areas.sum() - expected) <= 1e-6 * expected + collapsed, (areas.sum(), expected, collapsed)
    centroids = shapely.points((a + b + c) / 3 + origin)
    hit, _ = shapely.STRtree(faces[meshed]).query(centroids, predicate="within")
    assert len(np.unique(hit)) == len(tris), "a triangle lies outside the meshed faces"
    # and those faces are the cleaned area minus the holes, up to the snapping grid
    holes = shapely.union_all([g for _, g in cons.footprints]) if footprints_as_holes and cons.footprints else None
    target = cons.area.difference(holes) if holes is not None else cons.area
    perimeter = cons.area.length + sum(g.length for _, g in cons.footprints) + sum(g.length for _, g in cons.roads)
    assert abs(expected - target.area) <= perimeter * constraints.GRID

    # every constraint segment in or around a meshed face is a chain of mesh edges
    edges = {tuple(e) for e in np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)}
    bordering = shapely.dwithin(shapely.centroid(lines), shapely.union_all(faces[meshed]), 1e-7)
    local = xy - origin
    for i, j in cons.segments[bordering]:
        p, q = cons.vertices[i], cons.vertices[j]
        d = q - p
        length = np.hypot(*d)
        t = ((local - p) @ d) / length ** 2
        off = np.abs((local[:, 0] - p[0]) * d[1] - (local[:, 1] - p[1]) * d[0]) / length
        on = np.flatnonzero((off < 1e-10) & (t > -1e-9) & (t < 1 + 1e-9))  # truly on it: ~1e-14 off
        chain = on[np.argsort(t[on])]
        assert {chain[0], chain[-1]} == {i, j}
        for u, v in pairwise(chain):
            assert (min(u, v), max(u, v)) in edges, f"constraint segment {p + origin}–{q + origin} not in the mesh"

    np.testing.assert_allclose(tin.vertices[:, 2], dem.sample(xy[:, 0], xy[:, 1]), rtol=0, atol=1e-9)
    assert set(tin.surface) <= set(TIN_SURFACES)
    if footprints_as_holes:
        assert "footprint" not in set(tin.surface)


# -- messy input -------------------------------------------------------------------------------


def strategies():
    from hypothesis import strategies as st

    coord = st.floats(-30, 130, allow_nan=False)
    point = st.tuples(coord, coord)
    size = st.floats(0, 40, allow_nan=False)
    rect = st.builds(lambda x, y, w, h: [(x, y), (x + w, y), (x + w, y + h), (x, y + h)], coord, coord, size, size)
    ring = st.one_of(rect, st.lists(point, min_size=1, max_size=9))
    tiny = st.sampled_from([0.0, 1e-9, 1e-6, 4e-4, 1.2e-3, 0.05])

    @st.composite
    def messy_ring(draw):
        pts = list(draw(ring))
        for _ in range(draw(st.integers(0, 2))):  # duplicated and near-coincident vertices
            k = draw(st.integers(0, len(pts) - 1))
            eps = draw(tiny)
            pts.insert(k, (pts[k][0] + eps, pts[k][1] - eps))
        if draw(st.booleans()):
            pts.reverse()
        while len(pts) < 3:  # a ring needs three points: pad with repeats (degenerate on purpose)
            pts.append(pts[-1])
        return pts

    @st.composite
    def messy_polygon(draw):
        shell = draw(messy_ring())
        holes = [draw(messy_ring()) for _ in range(draw(st.integers(0, 1)))]
        return shapely.Polygon(shell, holes)  # may be invalid: self-intersecting, bow-tie, hole outside…

    @st.composite
    def polygon_set(draw, max_size):
        polys = draw(st.lists(messy_polygon(), max_size=max_size))
        for _ in range(draw(st.integers(0, 3)) if polys else 0):
            base = polys[draw(st.integers(0, len(polys) - 1))]
            kind = draw(st.sampled_from(["copy", "nudge", "slide"]))
            if kind == "copy":  # exact duplicate
                polys.append(base)
            elif kind == "nudge":  # near-coincident everywhere
                e = draw(tiny)
                polys.append(affinity.translate(base, e, e))
            else:  # collinear overlapping edges
                polys.append(affinity.translate(base, draw(st.floats(-10, 10, allow_nan=False)), 0.0))
        return polys

    area = st.one_of(st.just(shapely.box(0, 0, 100, 100)),
                     st.just(shapely.Polygon([(0, 0), (100, 0), (100, 100), (50, 40), (0, 100)])),
                     st.just(shapely.box(0, 0, 100, 100).difference(shapely.box(40, 40, 55, 60))),
                     messy_polygon())
    return area, polygon_set


def main() -> int:
    from hypothesis import HealthCheck, given, seed, settings
    from hypothesis import strategies as st

    parser = argparse.ArgumentParser()
    parser.add_argument("examples", type=int)
    parser.add_argument("seed", type=int)
    parser.add_argument("--last", required=True)
    parser.add_argument("--triangulator", type=int, default=None)
    args = parser.parse_args()
    faulthandler.enable()
    dem = hill_dem()
    area, polygon_set = strategies()
    outcome = {"meshed": 0, "rejected": 0}

    @seed(args.seed)
    @settings(max_examples=args.examples, deadline=None, database=None, print_blob=True,
              suppress_health_check=list(HealthCheck))
    @given(area=area, buildings=polygon_set(10), roads=polygon_set(5), holes=st.booleans(),
           max_edge=st.sampled_from([6.0, 10.0, 25.0]))
    def robust(area, buildings, roads, holes, max_edge):
        started = time.perf_counter()
        Path(args.last).write_text(repr({"area": area.wkt, "buildings": [g.wkt for g in buildings],
                                         "roads": [g.wkt for g in roads], "holes": holes, "max_edge": max_edge}))
        b = [(f"B{k}", g) for k, g in enumerate(buildings)]
        r = [(f"R{k}", g) for k, g in enumerate(roads)]
        try:
            tin, _ = mesh.triangulate(area, b, r, dem, max_edge=max_edge, tolerance=0.5,
                                         footprints_as_holes=holes, triangulator=args.triangulator)
        except InputError as exc:
            assert str(exc), "an InputError must say what is wrong"
            outcome["rejected"] += 1
            return
        check_mesh(tin, dem, holes)
        outcome["meshed"] += 1
        outcome["slowest"] = max(outcome.get("slowest", 0.0), time.perf_counter() - started)

    robust()
    print(f"meshed {outcome['meshed']} rejected {outcome['rejected']} slowest {outcome.get('slowest', 0):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
