"""Terrain TIN: constraints kept, vertical error bounded (measured densely), labels, robustness."""
from __future__ import annotations

import subprocess
import sys
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import ogr, osr

from wit_plugin.infra import step_layers
from wit_plugin.infra.dem import Dem
from wit_plugin.infra.errors import InputError
from wit_plugin.terrain import build, constraints, mesh, triangulators

sys.path.insert(0, str(Path(__file__).parent))
from cdt_worker import check_mesh, hill_dem

AREA = shapely.box(0, 0, 120, 120)
BUILDINGS = [
    ("BLD_A", shapely.box(10, 10, 30, 25)),
    ("BLD_B", shapely.Polygon([(40, 60), (62, 60), (62, 70), (50, 70), (50, 85), (40, 85)])),  # L-shape
    ("BLD_C", shapely.box(70, 70, 100, 100).difference(shapely.box(80, 80, 90, 90))),  # courtyard
    ("BLD_D", shapely.Polygon([(5, 100), (20, 96.5), (24, 110), (8, 113)])),
]
ROADS = [("RD_1", shapely.box(0, 40, 120, 50)), ("RD_2", shapely.box(60, 0, 66, 120))]


def mesh_edges(tin):
    t = tin.triangles
    return {tuple(e) for e in np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1).tolist()}


def assert_edge_in_mesh(tin, p, q, edges):
    """The segment p–q is covered by a chain of collinear mesh edges."""
    xy = tin.vertices[:, :2]
    d = np.subtract(q, p)
    length = np.hypot(*d)
    t = ((xy - p) @ d) / length ** 2
    off = np.abs((xy[:, 0] - p[0]) * d[1] - (xy[:, 1] - p[1]) * d[0]) / length
    on = np.flatnonzero((off < 1e-10) & (t > -1e-9) & (t < 1 + 1e-9))  # truly on it: ~1e-14 off
    chain = on[np.argsort(t[on])]
    assert np.allclose(xy[chain[0]], p, atol=1e-6) and np.allclose(xy[chain[-1]], q, atol=1e-6)
    for u, v in pairwise(chain):
        assert (min(u, v), max(u, v)) in edges, f"edge {p}–{q} is not a union of mesh edges"


BACKENDS = pytest.mark.parametrize("triangulator", [triangulators.TRIANGLE, triangulators.CDT],
                                   ids=["triangle", "cdt"])


@BACKENDS
@pytest.mark.parametrize("holes", [True, False])
def test_every_building_and_road_edge_is_in_the_mesh(holes, triangulator):
    dem = hill_dem()
    tin, stats = mesh.triangulate(AREA, BUILDINGS, ROADS, dem, max_edge=5.0, tolerance=0.5,
                                     footprints_as_holes=holes, triangulator=triangulator)
    check_mesh(tin, dem, holes)
    edges = mesh_edges(tin)
    for _, poly in BUILDINGS:
        for ring in (poly.exterior, *poly.interiors):
            for p, q in zip(ring.coords[:-1], ring.coords[1:]):
                assert_edge_in_mesh(tin, p, q, edges)
    # road edges outside the footprints (under a building there is no mesh in holes mode)
    for _, poly in ROADS:
        for line in shapely.get_parts(poly.boundary.difference(shapely.union_all([g for _, g in BUILDINGS]))):
            for p, q in zip(line.coords[:-1], line.coords[1:]):
                assert_edge_in_mesh(tin, p, q, edges)
    assert stats.max_edge <= 5.0 * (1 + 1e-9)
    assert stats.max_vertical_error <= 0.5
    lengths = np.linalg.norm(np.diff(tin.vertices[tin.triangles[:, [0, 1, 2, 0]]][:, :, :2], axis=1), axis=2)
    assert lengths.max() == pytest.approx(stats.max_edge)


def _dense_error(dem, tin, n=12):
    """Max |DEM − triangle plane| sampled on a barycentric lattice of n+1 points per side."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    keep = i + j <= n
    w = np.column_stack([i[keep], j[keep], n - i[keep] - j[keep]]) / n  # (k, 3)
    corners = tin.vertices[tin.triangles]  # (m, 3, 3)
    points = np.einsum("kc,mcd->mkd", w, corners)  # (m, k, 3)
    z = dem.sample(points[..., 0].ravel(), points[..., 1].ravel()).reshape(points.shape[:2])
    return np.abs(z - points[..., 2]).max()


@BACKENDS
def test_vertical_error_is_within_tolerance_on_a_sharp_hill(triangulator):
    # 1 m cells, a 40 m hill with σ ≈ 4 m: far too sharp for 30 m triangles without refinement
    centres = np.arange(200) + 0.5
    x, y = np.meshgrid(centres, centres[::-1])
    dem = Dem(40.0 * np.exp(-((x - 100) ** 2 + (y - 90) ** 2) / 32.0) + 0.02 * x, (0.0, 1.0, 0.0, 200.0, 0.0, -1.0))
    area = shapely.box(20, 20, 180, 180)
    building = [("BLD_H", shapely.box(95, 60, 110, 75))]

    coarse, coarse_stats = mesh.triangulate(area, building, [], dem, max_edge=30.0, tolerance=0.25,
                                               max_iterations=0, triangulator=triangulator)
    assert _dense_error(dem, coarse) > 1.0  # the hill is badly missed without refinement
    assert coarse_stats.max_vertical_error >= _dense_error(dem, coarse) - 1e-9  # measured, not guessed

    tin, stats = mesh.triangulate(area, building, [], dem, max_edge=30.0, tolerance=0.25,
                                     triangulator=triangulator)
    dense = _dense_error(dem, tin, n=16)
    assert stats.refinement_iterations > 0
    assert stats.max_vertical_error <= 0.25
    assert dense <= stats.max_vertical_error + 1e-9  # the exact measure bounds any sampling
    assert dense >= 0.5 * stats.max_vertical_error  # and is not wildly pessimistic
    np.testing.assert_allclose(tin.vertices[:, 2], dem.sample(tin.vertices[:, 0], tin.vertices[:, 1]),
                               rtol=0, atol=1e-9)


@BACKENDS
def test_holes_and_constrained_footprints_are_labelled(triangulator):
    dem = hill_dem()
    footprint_area = sum(g.area for _, g in BUILDINGS)
    for holes in (True, False):
        tin, stats = mesh.triangulate(AREA, BUILDINGS, ROADS, dem, max_edge=8.0, footprints_as_holes=holes,
                                         triangulator=triangulator)
        xy = tin.vertices[:, :2][tin.triangles]
        areas = 0.5 * np.abs(np.cross(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]))
        centroids = xy.mean(axis=1)
        by = {s: areas[tin.surface == s].sum() for s in step_layers.TIN_SURFACES}
        if holes:
            assert by["footprint"] == 0 and stats.triangles_by_surface["footprint"] == 0
            assert areas.sum() == pytest.approx(AREA.area - footprint_area, rel=1e-9)
        else:
            assert by["footprint"] == pytest.approx(footprint_area, rel=1e-9)
            assert areas.sum() == pytest.approx(AREA.area, rel=1e-9)
        # each triangle belongs to the first building, else the first road, containing it
        expected = np.full(len(centroids), None, dtype=object)
        for wit_id, poly in reversed(BUILDINGS + ROADS):
            expected[shapely.contains_xy(poly, centroids[:, 0], centroids[:, 1])] = wit_id
        np.testing.assert_array_equal(tin.feature_id, expected)
        is_road = np.array([f is not None and f.startswith("RD") for f in expected])
        assert set(tin.surface[is_road]) == {"road"}
        terrain_tris = tin.surface == "terrain"
        assert all(f is None for f in tin.feature_id[terrain_tris])


def test_bad_input_is_an_input_error():
    dem = hill_dem()
    with pytest.raises(InputError, match="study area is empty"):
        mesh.triangulate(shapely.Polygon([(0, 0), (1, 1), (2, 2)]), [], [], dem)
    with pytest.raises(InputError, match="positive"):
        mesh.triangulate(AREA, [], [], dem, max_edge=0)
    with pytest.raises(InputError, match="outside the DEM"):
        mesh.triangulate(shapely.box(0, 0, 500, 500), [], [], dem, max_edge=50)
    with pytest.raises(InputError, match="split the area"):
        mesh.triangulate(shapely.box(0, 0, 100000, 100000), [], [], dem, max_edge=5)
    with pytest.raises(InputError, match="cover the whole"):
        mesh.triangulate(AREA, [("BLD_X", shapely.box(-10, -10, 130, 130))], [], dem)


@pytest.mark.slow  # 200 examples per backend: 2.5 and 5 min on a loaded 2-core machine
@BACKENDS
def test_messy_input_never_crashes_the_triangulator(tmp_path, triangulator):
    """Random invalid, overlapping, duplicated, near-coincident polygons: a valid mesh or InputError.

    Runs in a subprocess: a segfault in the library fails this test instead of killing pytest.
    """
    last = tmp_path / "last_example.txt"
    proc = subprocess.run([sys.executable, str(Path(__file__).with_name("cdt_worker.py")), "200", "20250407",
                           "--last", str(last), "--triangulator", str(triangulator)],
                          capture_output=True, text=True, timeout=900, check=False)
    detail = f"stdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-6000:]}"
    if proc.returncode < 0:
        pytest.fail(f"triangulation crashed with signal {-proc.returncode} on:\n{last.read_text()}\n{detail}")
    assert proc.returncode == 0, detail
    assert "meshed" in proc.stdout


def _write_prepared(path, buildings, roads):
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    for name, features in ((step_layers.PREPARED_BUILDINGS, buildings), (step_layers.PREPARED_ROADS, roads)):
        lyr = ds.CreateLayer(name, srs, ogr.wkbPolygon)
        lyr.CreateField(ogr.FieldDefn(step_layers.WIT_ID, ogr.OFTString))
        for wit_id, geom in features:
            feat = ogr.Feature(lyr.GetLayerDefn())
            feat.SetField(step_layers.WIT_ID, wit_id)
            feat.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(geom)))
            lyr.CreateFeature(feat)
    ds = None


def test_run_on_the_seoul_dem_writes_a_tin(tmp_path, shared_dir):
    suseo = np.array([209020.9, 543132.8])
    shift = shapely.affinity.translate
    buildings = [(w, shift(g, *(suseo - 60))) for w, g in BUILDINGS]
    roads = [(w, shift(g, *(suseo - 60))) for w, g in ROADS]
    prepared = tmp_path / "prepared.gpkg"
    _write_prepared(prepared, buildings, roads)
    area = shapely.Point(*suseo).buffer(150, quad_segs=16)
    out = tmp_path / "tin.gpkg"
    stats = build.triangulate_terrain(shared_dir / "data/dem_seoul_90m_5186/seoul_dem.tif", prepared, prepared, out,
                                                        area)
    assert stats.max_edge <= 5.0 * (1 + 1e-9) and stats.max_vertical_error <= 0.5
    ds = ogr.Open(str(out))
    lyr = ds.GetLayerByName(step_layers.TIN_LAYER)
    assert lyr.GetGeomType() == ogr.wkbPolygon25D
    assert lyr.GetFeatureCount() == stats.triangles
    assert lyr.GetSpatialRef().GetAuthorityCode(None) == "5186"
    defn = lyr.GetLayerDefn()
    assert [defn.GetFieldDefn(k).GetName() for k in range(defn.GetFieldCount())] == \
        [step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE, step_layers.TIN_FEATURE_ID]
    surfaces, zs = set(), []
    for feat in lyr:
        surfaces.add(feat[step_layers.TIN_SURFACE])
        ring = feat.GetGeometryRef().GetGeometryRef(0)
        assert ring.GetPointCount() == 4
        zs += [ring.GetZ(k) for k in range(4)]
    assert surfaces == {"terrain", "road"}
    assert 10 < min(zs) and max(zs) < 60  # Suseo lies at about 19 m
    assert not list(tmp_path.glob(".tin*"))


def test_cancel_leaves_no_output(tmp_path, shared_dir):
    from wit_plugin.infra.errors import CanceledError
    from wit_plugin.infra.feedback import Feedback

    class CancelAtOnce(Feedback):
        def is_canceled(self) -> bool:
            return True

    suseo = np.array([209020.9, 543132.8])
    prepared = tmp_path / "prepared.gpkg"
    _write_prepared(prepared, [("BLD_A", shapely.box(*(suseo - 5), *(suseo + 5)))], [])
    out = tmp_path / "tin.gpkg"
    with pytest.raises(CanceledError):
        build.triangulate_terrain(shared_dir / "data/dem_seoul_90m_5186/seoul_dem.tif", prepared, prepared, out,
                                    shapely.Point(*suseo).buffer(50), feedback=CancelAtOnce())
    assert not list(tmp_path.glob("*tin*")) and not list(tmp_path.glob(".tin*"))


@pytest.mark.parametrize("tolerance", [0.0, 0.05, 0.3, 10.0])
def test_vertical_error_is_exact_where_it_matters(tolerance):
    """Exact above the tolerance (so refinement picks exactly the right triangles), a bound within
    it elsewhere, and the exact maximum over all triangles whatever the tolerance."""
    dem = hill_dem()
    tin, _ = mesh.triangulate(AREA, BUILDINGS, ROADS, dem, max_edge=12.0, tolerance=100.0, max_iterations=0)
    exact = mesh.exact_vertical_error(dem, tin.vertices, tin.triangles)
    error = mesh.vertical_error(dem, tin.vertices, tin.triangles, tolerance)
    max_error = mesh.max_vertical_error(dem, tin.vertices, tin.triangles, error.copy(), tolerance)
    assert max_error == pytest.approx(exact.max(), abs=1e-9) and exact.max() > 0.05
    np.testing.assert_array_equal(error > tolerance, exact > tolerance)
    over = exact > tolerance
    np.testing.assert_allclose(error[over], exact[over], rtol=0, atol=1e-12)
    assert (error >= exact - 1e-12).all()


def test_segments_are_split_at_vertices_snap_rounding_left_beside_them():
    # a cluster of vertices a millimetre apart, as snap rounding leaves where lines meet at a
    # shallow angle: 0–2 passes through vertex 1, and 3–1 / 1–4 pass within 0.7 mm of 0 and 2
    v = np.array([[16.766, 1177.943], [16.766, 1177.944], [16.766, 1177.945], [15.61, 1171.734],
                  [29.447, 1142.441], [20.103, 1195.863], [0.0, 0.0], [10.0, 0.0005], [20.0, 0.0]])
    s = np.array([[3, 1], [0, 2], [1, 4], [1, 5], [6, 8], [7, 6]])
    out = constraints._split_at_near_vertices(v, s, 0.7 * constraints.GRID)
    assert {tuple(e) for e in out.tolist()} == {(0, 1), (0, 3), (0, 4), (1, 2), (2, 5), (6, 7), (7, 8)}
    lines = shapely.linestrings(v[out])
    i, j = shapely.STRtree(lines).query(lines, predicate="intersects")
    i, j = i[i < j], j[i < j]
    touching = shapely.intersection(lines[i], lines[j])
    assert (shapely.get_type_id(touching) == 0).all()  # pieces meet at single points only: no overlaps


def test_millimetre_slivers_between_roads_and_walls_cost_no_triangles(monkeypatch):
    """A road edge 1 mm off a wall leaves a sliver face; merged into its neighbour it is not
    filled with needles, and the mesh still tiles the area exactly."""
    dem = hill_dem()
    road = [("RD_S", shapely.box(0, 40.001, 120, 50))]  # 1 mm from the buildings' north walls
    building = [("BLD_S", shapely.box(0, 20, 60, 40)), ("BLD_T", shapely.box(60, 20, 120, 40))]
    tin, stats = mesh.triangulate(AREA, building, road, dem, max_edge=8.0)
    check_mesh(tin, dem, True)
    cons = tin.constraints
    widths = 2 * shapely.area(cons.faces) / shapely.length(cons.faces)
    assert (cons.meshed & (widths < constraints.MIN_WIDTH)).sum() == 1  # the sliver is there
    reference, ref_stats = mesh.triangulate(AREA, building, [("RD_S", shapely.box(0, 40, 120, 50))], dem,
                                               max_edge=8.0)
    assert stats.triangles <= 1.05 * ref_stats.triangles
    xy = tin.vertices[:, :2][tin.triangles]
    areas = 0.5 * np.abs(np.cross(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]))
    assert (areas < 0.01).sum() <= 4  # only where the sliver meets the area's edge
    monkeypatch.setattr(constraints, "_sliver_hosts", lambda faces, meshed: np.arange(len(faces)))
    _, unmerged = mesh.triangulate(AREA, building, road, dem, max_edge=8.0)
    assert unmerged.triangles > 2 * stats.triangles  # the needles the merge saves


def test_long_edges_are_fixed_by_refining_patches_only(monkeypatch):
    """On a plane (no vertical error) only edge length drives refinement: the few triangles with a
    long edge are re-meshed in patches that fit the untouched mesh exactly."""
    centres = np.arange(-60, 180, 2.0) + 1.0
    x, y = np.meshgrid(centres, centres[::-1])
    plane = Dem(20.0 + 0.03 * x - 0.02 * y, (-60.0, 2.0, 0.0, 180.0, 0.0, -2.0))
    patches = []
    refine = triangulators.TriangleBackend._refine_patch
    monkeypatch.setattr(triangulators.TriangleBackend, "_refine_patch",
                        staticmethod(lambda *a: patches.append(len(a[2])) or refine(*a)))
    tin, stats = mesh.triangulate(AREA, BUILDINGS, ROADS, plane, max_edge=5.0,
                                     triangulator=triangulators.TRIANGLE)
    assert patches and max(patches) < 0.2 * stats.triangles  # patches, not the whole mesh
    assert stats.refinement_iterations == len(patches)
    check_mesh(tin, plane, True)  # conforming, constraints kept, exact cover
    lengths = np.linalg.norm(np.diff(tin.vertices[tin.triangles[:, [0, 1, 2, 0]]][:, :, :2], axis=1), axis=2)
    assert lengths.max() <= 5.0 * (1 + 1e-9) and stats.max_vertical_error < 1e-9
    t = tin.triangles
    _, count = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1), axis=0,
                         return_counts=True)
    assert count.max() == 2  # every edge between at most two triangles: no overlap at the patch seams


def test_terrain_covers_buildings_that_cross_the_rim(tmp_path, shared_dir):
    """A building kept whole at the edge of a circular area lies on terrain, not over the rim."""
    suseo = np.array([209020.9, 543132.8])
    area = shapely.Point(*suseo).buffer(100, quad_segs=16)
    crossing = shapely.box(suseo[0] + 80, suseo[1] - 15, suseo[0] + 130, suseo[1] + 15)  # 30 m of 50 outside
    inside = shapely.box(*(suseo - 10), *(suseo + 10))
    outside = shapely.box(suseo[0] + 300, suseo[1], suseo[0] + 320, suseo[1] + 20)  # not in the model
    prepared = tmp_path / "prepared.gpkg"
    _write_prepared(prepared, [("BLD_X", crossing), ("BLD_I", inside), ("BLD_O", outside)], [])
    out = tmp_path / "tin.gpkg"
    build.triangulate_terrain(shared_dir / "data/dem_seoul_90m_5186/seoul_dem.tif", prepared, None, out, area,
                                build.TerrainConfig(max_edge=10.0, footprints_as_holes=False))
    ds = ogr.Open(str(out))
    triangles = [shapely.from_wkb(bytes(f.GetGeometryRef().ExportToIsoWkb()))
                 for f in ds.GetLayer(step_layers.TIN_LAYER)]
    covered = shapely.union_all(shapely.force_2d(np.array(triangles, dtype=object)), grid_size=1e-3)
    assert covered.buffer(1e-3).contains(crossing)  # the whole footprint, also its 30 m outside the circle
    assert covered.area == pytest.approx(shapely.union(area, crossing).area, rel=1e-3)
    assert not covered.intersects(outside)
    grown = build.covering_area(area, [crossing, inside, outside])
    assert grown.area == pytest.approx(shapely.union(area, crossing).area, rel=1e-6)  # on the 1 mm grid
    assert build.covering_area(area, [inside, outside]) is area


def test_close_pairs_are_those_an_strtree_of_all_points_finds():
    """``output._close_pairs`` (grid candidates, GEOS verdicts) finds exactly the pairs within MIN_EDGE that an
    STRtree of every vertex finds, exactly 1 cm apart (10 steps: (10, 0), (6, 8), …) included."""
    from wit_plugin.terrain import output

    rng = np.random.default_rng(5)
    base = rng.integers(0, 2_000_000, (3000, 2)) + [208_020_888, 542_132_772]  # mm steps of the Korean belt
    offsets = rng.choice([0, 3, 6, 8, 10, 11, -6, -8, -10, 14], size=(3000, 2))
    steps = np.unique(np.vstack([base, base + offsets, base[:500] + [[6, 8]], base[:500] + [[0, -10]]]), axis=0)
    xyz = np.column_stack([steps * mesh.ROUNDING, np.zeros(len(steps))])
    used = np.flatnonzero(rng.random(len(steps)) < 0.9)
    points = shapely.points(xyz[used, :2])
    near_a, near_b = shapely.STRtree(points).query(points, predicate="dwithin", distance=output.MIN_EDGE)
    a, b = used[near_a], used[near_b]
    expected = sorted(zip(a[a < b].tolist(), b[a < b].tolist()))
    found = output._close_pairs(xyz, steps, used)
    assert list(zip(*(f.tolist() for f in found))) == expected
    assert len(expected) > 500  # the exact-1-cm pairs among them
