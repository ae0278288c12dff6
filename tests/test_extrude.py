"""LoD1 extrusion: closed outward shells, exact volumes, base on the DEM minimum, height sources."""
from __future__ import annotations

from collections import Counter
from itertools import pairwise

import numpy as np
import pytest
import shapely
from osgeo import ogr

from wit_plugin.buildings import extrude, heights
from wit_plugin.buildings.heights import HeightOptions
from wit_plugin.infra import step_layers
from wit_plugin.infra.dem import Dem
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.step_process import RECORD


def plane_dem(a=0.1, b=-0.05, c=50.0):
    gt = (-100.0, 2.0, 0.0, 200.0, 0.0, -2.0)
    centres_x = gt[0] + (np.arange(150) + 0.5) * gt[1]
    centres_y = gt[3] + (np.arange(150) + 0.5) * gt[5]
    x, y = np.meshgrid(centres_x, centres_y)
    return Dem(a * x + b * y + c, gt)


def signed_volume(faces) -> float:
    """Divergence theorem: V = 1/3 Σ (point on face · area vector); positive when normals point out."""
    volume = 0.0
    for _, rings in faces:
        area_vector = sum(0.5 * np.cross(r[:-1], r[1:]).sum(axis=0) for r in rings)
        volume += np.dot(rings[0][0], area_vector) / 3.0
    return volume


def directed_edges(faces) -> Counter:
    edges = Counter()
    for _, rings in faces:
        for r in rings:
            for p, q in pairwise(r):
                edges[(tuple(np.round(p, 9)), tuple(np.round(q, 9)))] += 1
    return edges


COURTYARD = shapely.box(0, 0, 30, 20).difference(shapely.box(10, 5, 20, 15))
L_SHAPE = shapely.Polygon([(0, 0), (12, 0), (12, 4), (4, 4), (4, 10), (0, 10)])


@pytest.mark.parametrize("footprint", [shapely.box(0, 0, 10, 8), L_SHAPE, COURTYARD,
                                       shapely.Polygon([(0, 0), (0, 10), (10, 0)])])  # clockwise input
def test_shell_is_closed_outward_and_has_the_right_volume(footprint):
    faces = extrude.solid_faces(footprint, 12.5, 9.0)
    assert signed_volume(faces) == pytest.approx(footprint.area * 9.0, rel=1e-6)
    edges = directed_edges(faces)
    # every edge used exactly once in each direction: closed, consistently oriented 2-manifold
    assert all(n == 1 for n in edges.values())
    assert all((q, p) in edges for p, q in edges)
    kinds = Counter(kind for kind, _ in faces)
    n_edges = sum(len(r.coords) - 1 for r in (footprint.exterior, *footprint.interiors))
    assert kinds == {"ground": 1, "roof": 1, "wall": n_edges}
    ground = next(r for k, r in faces if k == "ground")
    roof = next(r for k, r in faces if k == "roof")
    assert np.all(ground[0][:, 2] == 12.5) and np.all(roof[0][:, 2] == 21.5)
    assert not shapely.LinearRing(ground[0][:, :2]).is_ccw  # normal down
    assert shapely.LinearRing(roof[0][:, :2]).is_ccw  # normal up


def test_courtyard_walls_face_into_the_courtyard():
    faces = extrude.solid_faces(COURTYARD, 0.0, 6.0)
    assert len(next(r for k, r in faces if k == "roof")) == 2  # the courtyard is a hole in the roof
    centre = np.array([15.0, 10.0])
    court_walls = [r[0] for k, r in faces if k == "wall" and np.all(np.abs(r[0][:, :2] - centre) <= 5.0 + 1e-9)]
    assert len(court_walls) == 4
    for ring in court_walls:
        normal = np.cross(ring[1] - ring[0], ring[2] - ring[1])
        mid = ring[:4].mean(axis=0)
        assert np.dot(normal[:2], centre - mid[:2]) > 0  # points towards the courtyard centre


def test_base_is_the_exact_minimum_of_the_dem_on_the_footprint():
    dem = plane_dem()
    poly = shapely.Polygon([(3.3, 7.1), (41.0, 12.0), (30.0, 44.4), (5.0, 30.0)])
    # on a plane the minimum is at a vertex
    expected = min(0.1 * x - 0.05 * y + 50.0 for x, y in poly.exterior.coords)
    assert extrude.base_heights(dem, [poly])[0] == pytest.approx(expected, abs=1e-9)

    # a pit at one cell centre (45, 55): 10 m there, 30 m at every other centre
    gt = (0.0, 10.0, 0.0, 100.0, 0.0, -10.0)
    values = np.full((10, 10), 30.0)
    values[4, 4] = 10.0
    pit = Dem(values, gt)
    square = shapely.box(35, 45, 60, 70)  # holds the pit's centre: the minimum is there
    assert extrude.base_heights(pit, [square])[0] == pytest.approx(10.0, abs=1e-9)
    assert extrude.base_heights(pit, [square], "median")[0] == pytest.approx(30.0)  # 4 vertices + 9 centres
    # a strip just north of the pit: every vertex reads 30 m and no centre lies inside, but the
    # surface dips along the edge y = 56 to 30·0.1 + 10·0.9 = 12 m at x = 45
    strip = shapely.box(30, 56, 60, 58)
    assert extrude.base_heights(pit, [strip])[0] == pytest.approx(12.0, abs=1e-9)
    with pytest.raises(InputError, match="mean"):
        extrude.base_heights(pit, [square], "mean")


def test_height_sources_and_storeys():
    rule = HeightOptions(height_field="HEIGHT_M", expression_text="EST * 2",
                         expression=lambda a: a.get("EST") and float(a["EST"]) * 2,
                         default_height=4.0).rule_for(["GRO_FLO_CO", "HEIGHT_M", "EST"])

    def height(attributes, r=rule):
        value, source = heights.building_height(attributes, r)
        return value, source.kind if source else "default"

    assert height({"GRO_FLO_CO": 5}) == (15.0, "floors")
    assert height({"GRO_FLO_CO": "0", "HEIGHT_M": "12.5"}) == (12.5, "field")
    assert height({"GRO_FLO_CO": None, "HEIGHT_M": 0, "EST": "3"}) == (6.0, "expression")
    assert height({"GRO_FLO_CO": "", "HEIGHT_M": "n/a"}) == (4.0, "default")
    assert height({}, HeightOptions().rule_for([])) == (3.0, "default")
    assert rule.describe() == "GRO_FLO_CO × 3 m → HEIGHT_M (m) → expression EST * 2 → default 4 m"


def test_extrude_records_sources_and_splits_multipart_footprints():
    dem = plane_dem()
    buildings = [
        ("BLD_1", shapely.box(0, 0, 10, 10), {"GRO_FLO_CO": 4, "UND_FLO_CO": 1}),
        ("BLD_2", COURTYARD, {"GRO_FLO_CO": 0, "UND_FLO_CO": None}),
        ("BLD_3", shapely.MultiPolygon([shapely.box(50, 50, 60, 60), shapely.box(70, 50, 75, 55)]), {}),
        ("BLD_4", shapely.Polygon([(0, 0), (5, 5), (5, 0), (0, 5)]), {"GRO_FLO_CO": 2}),  # bow-tie: two lobes
        ("BLD_5", shapely.Polygon([(1, 1), (2, 2), (3, 3)]), {}),  # collapsed
    ]
    solids, stats = extrude.extrude(buildings, dem)
    ids = [s.wit_id for s in solids]
    assert ids == ["BLD_1", "BLD_2", "BLD_3_part1", "BLD_3_part2", "BLD_4_part1", "BLD_4_part2"]
    assert stats.skipped == 1 and stats.solids == 6
    first = solids[0]
    assert (first.height, first.height_source, first.storeys_above, first.storeys_below) == (12.0, "floors", 4, 1)
    assert solids[1].height_source == "default" and solids[1].storeys_above is None
    assert stats.height_sources == {"floors": 3, "default": 3}
    for s in solids:
        assert s.base_z == pytest.approx(extrude.base_heights(dem, [_footprint(s)])[0])
        assert signed_volume(s.faces) > 0


def _footprint(solid):
    rings = next(r for k, r in solid.faces if k == "roof")
    return shapely.Polygon(rings[0][:, :2], [r[:, :2] for r in rings[1:]])


def _prepared_and_dem(tmp_path):
    """Two prepared buildings (one with GRO_FLO_CO, one courtyard without) and a DEM with undeclared NoData."""
    from osgeo import gdal, osr

    gpkg = tmp_path / "prepared.gpkg"
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(gpkg))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    lyr = ds.CreateLayer(step_layers.PREPARED_BUILDINGS, srs, ogr.wkbPolygon)
    for name, kind in [(step_layers.WIT_ID, ogr.OFTString), ("GRO_FLO_CO", ogr.OFTInteger),
                       ("UND_FLO_CO", ogr.OFTInteger), ("BUL_MAN_NO", ogr.OFTInteger64)]:
        lyr.CreateField(ogr.FieldDefn(name, kind))
    for k, (poly, floors) in enumerate([(shapely.box(200010, 550010, 200030, 550025), 3), (COURTYARD, None)]):
        if k == 1:
            poly = shapely.affinity.translate(poly, 200050, 550050)
        feat = ogr.Feature(lyr.GetLayerDefn())
        feat.SetField(step_layers.WIT_ID, f"BLD_{k}")
        if floors:
            feat.SetField("GRO_FLO_CO", floors)
        feat.SetField("BUL_MAN_NO", 1234567 + k)
        feat.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(poly)))
        lyr.CreateFeature(feat)
    ds = None
    dem_path = tmp_path / "dem.tif"
    dem_ds = gdal.GetDriverByName("GTiff").Create(str(dem_path), 100, 100, 1, gdal.GDT_Float32)
    dem_ds.SetGeoTransform((200000.0, 2.0, 0.0, 550200.0, 0.0, -2.0))
    data = np.full((100, 100), 25.0, dtype=np.float32)
    data[90:92, 20:22] = -9999.0  # undeclared NoData inside the window read
    dem_ds.GetRasterBand(1).WriteArray(data)
    dem_ds = None
    return gpkg, dem_path


def test_run_writes_polygonz_faces_with_fields(tmp_path):
    gpkg, dem_path = _prepared_and_dem(tmp_path)
    out = tmp_path / "lod1.gpkg"
    stats = extrude.extrude_buildings(gpkg, dem_path, out, HeightOptions(storey_height=3.5))
    assert stats.solids == 2 and stats.nodata_filled == 4
    ds = ogr.Open(str(out))
    lyr = ds.GetLayerByName(step_layers.LOD1_LAYER)
    assert lyr.GetGeomType() == ogr.wkbPolygon25D
    feats = list(lyr)
    assert len(feats) == 2 + 4 + 2 + 8  # ground + roof + walls, per building
    names = [lyr.GetLayerDefn().GetFieldDefn(k).GetName() for k in range(lyr.GetLayerDefn().GetFieldCount())]
    for name in (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER, step_layers.BASE_Z,
                 step_layers.HEIGHT, step_layers.HEIGHT_SOURCE, step_layers.STOREYS_ABOVE, step_layers.STOREYS_BELOW,
                 "GRO_FLO_CO", "BUL_MAN_NO"):
        assert name in names
    first = [f for f in feats if f[step_layers.WIT_ID] == "BLD_0"]
    assert [f[step_layers.FACE_NUMBER] for f in first] == list(range(6))
    assert first[0][step_layers.FACE_TYPE] == "ground" and first[0][step_layers.HEIGHT] == pytest.approx(10.5)
    assert first[0][step_layers.HEIGHT_SOURCE] == "floors" and first[0]["BUL_MAN_NO"] == 1234567
    assert first[0][step_layers.HEIGHT_RULE] == "GRO_FLO_CO × 3.5 m"
    assert first[0][step_layers.BASE_Z] == pytest.approx(25.0)
    court = [f for f in feats if f[step_layers.WIT_ID] == "BLD_1"]
    assert court[0][step_layers.HEIGHT_SOURCE] == "default" and court[0][step_layers.HEIGHT_RULE] == "default 3 m"
    roof = shapely.from_wkb(bytes(court[1].GetGeometryRef().ExportToIsoWkb()))
    assert roof.has_z and len(roof.interiors) == 1
    assert not list(tmp_path.glob(".lod1*"))  # no temporary file left behind


def test_the_solids_in_their_own_process_are_the_solids_made_here(tmp_path):
    """The chain runs ``python -m wit_plugin.buildings`` beside the terrain: the same faces, fields and report as
    in this process, for the chain's height options; a refusal is a record (``infra.step_process``) and status 2."""
    import json
    import subprocess
    import sys

    from wit_plugin.infra.interpreter import core_env

    gpkg, dem_path = _prepared_and_dem(tmp_path)
    here = extrude.extrude_buildings(gpkg, dem_path, tmp_path / "here.gpkg", HeightOptions(storey_height=3.5),
                                     spatial_index=False)
    done = subprocess.run([sys.executable, "-m", "wit_plugin.buildings", str(gpkg), str(dem_path),
                           str(tmp_path / "there.gpkg"), "--storey-height", "3.5"],
                          capture_output=True, text=True, env=core_env(), check=True)
    assert json.loads(done.stdout) == here.as_dict()

    def faces(path):
        ds = ogr.Open(str(path))  # (held: its layer dies with it)
        layer = ds.GetLayerByName(step_layers.LOD1_LAYER)
        return [(bytes(f.GetGeometryRef().ExportToIsoWkb()), f.items()) for f in layer]

    assert faces(tmp_path / "there.gpkg") == faces(tmp_path / "here.gpkg")
    refused = subprocess.run([sys.executable, "-m", "wit_plugin.buildings", str(gpkg), str(dem_path),
                              str(tmp_path / "none.gpkg"), "--height-field", "HGT"], capture_output=True, text=True,
                             env=core_env())
    last = json.loads(refused.stderr.splitlines()[-1].removeprefix(RECORD))  # (the records before: its progress)
    assert refused.returncode == 2 and last["error"] == "InputError"
    assert "height field 'HGT' is not in" in last["refused"]
    assert not (tmp_path / "none.gpkg").exists()
