"""The two triangulation backends behind one interface, our Steiner points for the one that does not
refine (CDT), and the snapping of the TIN to the millimetre grid before it is written."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely

from wit_plugin.infra.dem import Dem
from wit_plugin.terrain import constraints, output, steiner, triangulators
from wit_plugin.terrain import mesh as terrain_mesh

sys.path.insert(0, str(Path(__file__).parent))
from cdt_worker import check_mesh, hill_dem
from test_terrain import AREA, BUILDINGS, ROADS

BACKENDS = pytest.mark.parametrize("backend", triangulators.BACKENDS, ids=["triangle", "cdt"])


def _pslg(buildings=BUILDINGS, roads=ROADS, holes=True, max_edge=None):
    cons = constraints.clean_constraints(AREA, buildings, roads, holes)
    vertices, segments = cons.vertices, cons.segments
    if max_edge:
        vertices, segments = terrain_mesh._split_long_segments(vertices, segments, max_edge)
    return cons, triangulators.Pslg(vertices, segments, cons.holes, cons.regions, terrain_mesh._face_locator(cons))


def _edges(tris: np.ndarray) -> set[int]:
    return set(triangulators.triangle_edge_keys(tris).ravel().tolist())


def _lone_inner_edges(tin: terrain_mesh.Tin) -> int:
    """Edges that one triangle alone uses, farther than 1 cm from the area's rim and the footprints."""
    tris = tin.triangles
    keys, count = np.unique(triangulators.triangle_edge_keys(tris).ravel(), return_counts=True)
    lone = triangulators.edge_pairs(keys[count == 1])
    middle = (tin.vertices[lone[:, 0], :2] + tin.vertices[lone[:, 1], :2]) / 2
    stops = shapely.union_all([tin.constraints.area.boundary] + [g.boundary for _, g in tin.constraints.footprints])
    return int((~shapely.dwithin(stops, shapely.points(middle), 0.01)).sum())


@BACKENDS
def test_a_plain_triangulation_keeps_the_graph_and_the_points(backend):
    """``triangulate``: the input vertices first and unchanged, every segment an edge, the Steiner points
    used as given, holes and the outside removed, each triangle in the region of its face."""
    cons, pslg = _pslg()
    points = np.array([[5.0, 5.0], [90.0, 20.0], [110.0, 110.0], [45.0, 78.0]])  # [45, 78]: in BLD_B, a hole
    mesh = backend.triangulate(pslg, points, pslg.locate(points))
    np.testing.assert_array_equal(mesh.vertices[:len(pslg.vertices)], pslg.vertices)
    np.testing.assert_array_equal(mesh.vertices[len(pslg.vertices):len(pslg.vertices) + 4], points)
    assert set(triangulators.edge_keys(pslg.segments).tolist()) <= _edges(mesh.triangles)
    np.testing.assert_array_equal(np.unique(mesh.constrained), np.unique(triangulators.edge_keys(pslg.segments)))
    corners = mesh.vertices[mesh.triangles]
    area = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]) / 2
    assert (area > 0).all()
    footprints = sum(g.area for _, g in BUILDINGS)
    assert area.sum() == pytest.approx(AREA.area - footprints, rel=1e-9)
    centroids = corners.mean(axis=1)
    np.testing.assert_array_equal(mesh.region, pslg.locate(centroids))  # each face's region, no hole
    used = np.unique(mesh.triangles)
    assert len(pslg.vertices) + 3 not in used  # the point in the footprint lies in a hole


def test_the_cdt_backend_labels_faces_as_triangle_does():
    """Same graph, same Steiner points: the same triangles in each region (up to Delaunay ties)."""
    cons, pslg = _pslg(max_edge=6.0)
    points, regions = steiner.lattice_points(pslg, 6.0)
    triangle_mesh = triangulators.BACKENDS[triangulators.TRIANGLE].triangulate(pslg, points, regions)
    cdt_mesh = triangulators.BACKENDS[triangulators.CDT].triangulate(pslg, points, regions)
    for mesh in (triangle_mesh, cdt_mesh):
        corners = mesh.vertices[mesh.triangles]
        area = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]) / 2
        by_region = np.bincount(mesh.region + 1, weights=area, minlength=len(pslg.regions) + 1)
        expected = shapely.area(cons.faces[cons.meshed])
        np.testing.assert_allclose(by_region[1:], expected, rtol=1e-9)
    assert len(triangle_mesh.triangles) == len(cdt_mesh.triangles)


def test_components_join_what_the_pairs_connect():
    label = triangulators.components(7, np.array([0, 2, 3, 5]), np.array([1, 1, 4, 4]))
    assert label.tolist() == [0, 0, 0, 3, 3, 3, 6]
    chain = np.arange(1000)
    assert (triangulators.components(1000, chain[1:], chain[:-1]) == 0).all()


def test_lattice_points_are_in_meshed_faces_and_clear_of_every_segment():
    cons, pslg = _pslg(max_edge=5.0 * steiner.LATTICE_SPACING)
    points, regions = steiner.lattice_points(pslg, 5.0)
    spacing = steiner.LATTICE_SPACING * 5.0
    lines = shapely.linestrings(pslg.vertices[pslg.segments])
    distance = shapely.distance(shapely.points(points)[:, None], lines[None, :]).min(axis=1)
    assert distance.min() >= steiner.BAND_CLEARANCE * spacing - 1e-9
    np.testing.assert_array_equal(regions, pslg.locate(points))
    assert (regions >= 0).all() and len(points) > 0.5 * AREA.area / (spacing ** 2)
    gaps = shapely.distance(shapely.points(points)[:, None], shapely.points(points)[None, :])
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() >= steiner.BAND_SPACING * spacing - 1e-9  # no near-duplicate among them


def test_refinement_meets_the_area_limits_without_touching_a_segment():
    """Ours: points until every triangle asked is within its limit; the segments stay as they were
    (the seam rule), and no new point comes near a vertex or a segment."""
    cdt = triangulators.BACKENDS[triangulators.CDT]
    cons, pslg = _pslg(max_edge=4.0)
    mesh = cdt.triangulate(pslg)  # the graph alone: long thin triangles
    limits = np.full(len(mesh.triangles), 3.0)
    refined = cdt.refine(mesh, pslg, limits, fixed=True, whole=False)
    corners = refined.vertices[refined.triangles]
    area = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]) / 2
    assert area.max() <= 3.0 and len(refined.triangles) > 3 * len(mesh.triangles)
    np.testing.assert_array_equal(refined.constrained, mesh.constrained)  # no segment split
    new = refined.vertices[len(pslg.vertices):]
    lines = shapely.linestrings(pslg.vertices[pslg.segments])
    to_segments = shapely.distance(shapely.points(new)[:, None], lines[None, :]).min(axis=1)
    assert to_segments.min() >= steiner.MIN_CLEARANCE
    gaps = shapely.distance(shapely.points(refined.vertices)[:, None], shapely.points(new)[None, :])
    gaps[len(pslg.vertices) + np.arange(len(new)), np.arange(len(new))] = np.inf
    assert gaps.min() >= steiner.MIN_CLEARANCE
    assert (refined.origin >= -1).all() and (refined.origin >= 0).sum() < len(refined.triangles)


def test_a_point_goes_to_the_circumcentre_or_the_longest_free_edge():
    cdt = triangulators.BACKENDS[triangulators.CDT]
    cons = constraints.clean_constraints(shapely.box(0, 0, 40, 40), [], [])
    pslg = triangulators.Pslg(cons.vertices, cons.segments, cons.holes, cons.regions, terrain_mesh._face_locator(cons))
    acute = np.array([[10.0, 10.0], [20.0, 10.5], [14.0, 19.0]])
    obtuse = np.array([[14.0, 38.0], [26.0, 38.0], [20.0, 39.0]])  # its circumcircle holds no other vertex
    expected = (steiner.circumcentres(*acute[:, None, :])[0], [20.0, 38.0])  # the obtuse: its longest edge's middle
    n = len(pslg.vertices)
    for corners, point in zip((acute, obtuse), expected):
        mesh = cdt.triangulate(pslg, corners)
        row = np.flatnonzero((np.sort(mesh.triangles, axis=1) == np.arange(n, n + 3)).all(axis=1))
        made, points = steiner.split_points(mesh, pslg, row, np.array([1.0]))
        assert made.tolist() == [0]
        np.testing.assert_allclose(points[0], point)


@BACKENDS
def test_both_backends_give_the_same_guarantees(backend):
    """Same input: a valid TIN with every constraint, edges ≤ MAX_EDGE, DEM error ≤ TOLERANCE, and —
    on the millimetre grid — no edge that only one triangle uses away from the rim and the footprints."""
    dem = hill_dem()
    tin, stats = terrain_mesh.triangulate(AREA, BUILDINGS, ROADS, dem, max_edge=4.0, tolerance=0.3,
                                     triangulator=backend.key)
    check_mesh(tin, dem, True)
    assert stats.max_edge <= 4.0 * (1 + 1e-9) and stats.max_vertical_error <= 0.3
    exact = terrain_mesh.exact_vertical_error(dem, tin.vertices, tin.triangles)
    assert exact.max() == pytest.approx(stats.max_vertical_error, abs=1e-9)
    snapped = output.snap_to_grid(tin, dem)
    assert _lone_inner_edges(snapped) == 0
    np.testing.assert_allclose(snapped.vertices[:, :2], np.round(snapped.vertices[:, :2], 3), rtol=0, atol=1e-9)


def test_the_backends_differ_little_in_triangle_count():
    dem = hill_dem()
    counts = [terrain_mesh.triangulate(AREA, BUILDINGS, ROADS, dem, max_edge=4.0, triangulator=b.key)[1].triangles
              for b in triangulators.BACKENDS]
    assert 0.7 * counts[0] <= counts[1] <= 1.1 * counts[0], counts


def test_snapping_welds_millimetre_neighbours_and_mends_flat_triangles():
    """Two vertices 0.4 mm apart become one (the two triangles at their edge vanish), a vertex 0.3 mm beside
    a road's edge falls onto it and the road triangle across it is split there: on the grid, no triangle
    without area and no edge that one triangle alone uses, and the road keeps its triangles."""
    flat = Dem(np.full((4, 4), 7.0), (-10.0, 10.0, 0.0, 30.0, 0.0, -10.0))
    cons = constraints.clean_constraints(shapely.box(0, 0, 10, 10), [], [("R", shapely.box(2, 8, 6, 9))])
    pslg = triangulators.Pslg(cons.vertices, cons.segments, cons.holes, cons.regions, terrain_mesh._face_locator(cons))
    points = np.array([[5.0004, 5.0], [5.0, 5.0], [4.0, 7.9997], [2.0, 2.0], [8.0, 2.0], [8.0, 6.0], [2.0, 5.0],
                       [4.0, 8.6]])
    mesh = triangulators.BACKENDS[triangulators.CDT].triangulate(pslg, points, pslg.locate(points))
    road = int(np.flatnonzero(cons.region_surface == constraints.ROAD)[0])
    surface = np.where(mesh.region == road, "road", "terrain").astype(object)
    xyz = np.column_stack([mesh.vertices, np.full(len(mesh.vertices), 7.0)])
    tin = terrain_mesh.Tin(xyz, mesh.triangles, surface, np.full(len(surface), None), cons)
    assert _lone_inner_edges(tin) == 0
    snapped = output.snap_to_grid(tin, flat)
    assert len(snapped.triangles) == len(tin.triangles) - 2 - 1 + 1  # weld: −2; flat one: −1, road split: +1
    assert _lone_inner_edges(snapped) == 0
    assert (terrain_mesh._areas_3d(snapped.vertices, snapped.triangles) > output.DEGENERATE_AREA).all()
    assert (terrain_mesh._triangle_areas(snapped.vertices, snapped.triangles) > 0).all()
    np.testing.assert_allclose(snapped.vertices[:, :2], np.round(snapped.vertices[:, :2], 3), rtol=0, atol=1e-9)
    assert (snapped.surface == "road").sum() == (surface == "road").sum() + 1
    assert terrain_mesh._triangle_areas(snapped.vertices, snapped.triangles).sum() == pytest.approx(100.0)


def test_the_default_is_cdt_where_triangle_cannot_be_imported(tmp_path):
    (tmp_path / "sitecustomize.py").write_text(
        "import sys\n\n\nclass NoTriangle:\n    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'triangle':\n            raise ImportError('blocked')\n\n\n"
        "sys.meta_path.insert(0, NoTriangle())\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")])))
    code = ("from wit_plugin.terrain import triangulators as t; print(t.default_key(), t.available(t.BACKENDS[0]), "
            "t.backend(None).label)")
    out = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).parents[1], env=env, capture_output=True,
                         text=True, timeout=120, check=True).stdout.strip().split(maxsplit=2)
    assert out == ["1", "False", "CDT (MPL-2.0)"]
    assert triangulators.default_key() == triangulators.TRIANGLE  # here, where it is installed


def test_the_triangulator_options_are_the_backends_in_order(qgis_processing):
    from conftest import ensure_wit_provider

    ensure_wit_provider()
    from wit_citymodel.processing_provider.shared_parameters import TRIANGULATOR_OPTIONS

    assert TRIANGULATOR_OPTIONS == triangulators.LABELS == ("Triangle (non-commercial licence)", "CDT (MPL-2.0)")
    with pytest.raises(ValueError, match="0 .Triangle"):
        triangulators.backend(2)


def test_snapping_leaves_no_edge_shorter_than_a_centimetre():
    """Vertices under 1 cm apart (val3dity reads them as one at its 1 mm snap) become one: two inner ones 6 mm
    apart, and an inner one 5 mm from a corner of the area's rim, which keeps its place; the ground stays whole."""
    flat = Dem(np.full((4, 4), 7.0), (-10.0, 10.0, 0.0, 30.0, 0.0, -10.0))
    cons = constraints.clean_constraints(shapely.box(0, 0, 10, 10), [], [("R", shapely.box(2, 8, 6, 9))])
    pslg = triangulators.Pslg(cons.vertices, cons.segments, cons.holes, cons.regions, terrain_mesh._face_locator(cons))
    points = np.array([[5.0, 5.0], [5.006, 5.0], [0.004, 0.003], [2.0, 2.0], [8.0, 2.0], [8.0, 6.0], [2.0, 5.0]])
    mesh = triangulators.BACKENDS[triangulators.CDT].triangulate(pslg, points, pslg.locate(points))
    surface = np.full(len(mesh.triangles), "terrain", dtype=object)
    xyz = np.column_stack([mesh.vertices, np.full(len(mesh.vertices), 7.0)])
    tin = terrain_mesh.Tin(xyz, mesh.triangles, surface, np.full(len(surface), None), cons)
    edges = lambda t: np.hypot(*np.diff(t.vertices[t.triangles[:, [0, 1, 2, 0]], :2], axis=1).T)  # noqa: E731
    assert edges(tin).min() < 0.006
    snapped = output.snap_to_grid(tin, flat)
    assert edges(snapped).min() >= output.MIN_EDGE
    assert _lone_inner_edges(snapped) == 0
    assert terrain_mesh._triangle_areas(snapped.vertices, snapped.triangles).sum() == pytest.approx(100.0)
    used = snapped.vertices[np.unique(snapped.triangles), :2].round(3).tolist()
    assert [0.0, 0.0] in used and [0.004, 0.003] not in used  # the rim's corner stays, the inner point goes
    assert [5.0, 5.0] in used and [5.006, 5.0] not in used  # the first in (x, y) order stays


def test_components_join_linked_items_under_their_smallest():
    from wit_plugin.infra.arrays import components

    labels = components(np.array([[5, 1], [1, 3], [7, 8], [3, 0]]), 10)
    assert labels.tolist() == [0, 0, 2, 0, 4, 0, 6, 7, 7, 9]
    assert components(np.zeros((0, 2), dtype=np.int64), 3).tolist() == [0, 1, 2]
