"""The levels above the tiles of a tiled run, alone (no run): the group plan by NGII sheet, the buildings a
group shows (the largest, as prisms, with their attributes and a measured error), and the terrain of a
higher group joined from its children's."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import ogr

from wit_plugin.infra import step_layers
from wit_plugin.infra.mapsheet import sheets_covering
from wit_plugin.tiles3d.check import check_glb_metadata, read_glb
from wit_plugin.tiles3d.geo import Georeference, gltf_to_model
from wit_plugin.tiles3d.glb import GlbBuilder
from wit_plugin.tiles3d.group_buildings import Candidates, add_buildings
from wit_plugin.tiles3d.groups import Terrain, grid_at, join_terrain, parent_sheet, plan_groups

ROOT = Path(__file__).resolve().parents[1]


def _sheets(west: float, south: float, east: float, north: float, scale: int = 1000) -> list[str]:
    return [s.number for s in sheets_covering(west, south, east, north, scale)]


def test_parent_sheets_follow_the_ngii_numbering():
    assert parent_sheet("377090219") == "37709004"  # 1:1,000 → the 1:5,000 sheet holding its centre
    assert parent_sheet("37709002") == "37709"  # 1:5,000 → 1:50,000: the first five digits
    assert parent_sheet("37709") == "377"  # 1:50,000 → the 1° block
    assert parent_sheet("377") is None


def test_one_sheet_of_tiles_gives_one_group_and_no_empty_levels():
    sheets = _sheets(127.1001, 37.4901, 127.1199, 37.4999)  # inside one 1:5,000 sheet: 4 × 2 tiles
    groups, top = plan_groups(sheets)
    assert len(sheets) == 8 and list(groups) == top == ["37709005"]  # the 1:50,000 sheet and block add nothing
    assert groups["37709005"].over_tiles and groups["37709005"].children == sorted(sheets)


def test_levels_up_to_the_blocks_and_every_group_bounded():
    west = _sheets(126.9401, 37.4001, 126.9999, 37.4499)  # in block 376 (126°E)
    east = _sheets(127.0001, 37.4001, 127.0599, 37.5599)  # in block 377, across 37.5°N: two 1:50,000 sheets
    groups, top = plan_groups(west + east)
    assert top == ["37612", "377"]  # block 376 holds one 1:50,000 sheet: the block is left out
    assert groups["377"].children == ["37705", "37709"] and "376" not in groups
    assert {c for g in groups.values() for c in g.children} | set(top) == set(groups) | set(west + east)
    assert sorted(t for name in top for t in groups[name].tiles) == sorted(west + east)
    kinds = {len(name) for name in groups}
    assert kinds == {3, 5, 8}
    assert max(len(g.children) for g in groups.values() if len(g.name) == 8) <= 25
    tiles_5000 = _sheets(126.0001, 37.0001, 126.9999, 37.9999, 5000)  # a 1° block of 1:5,000 tiles
    groups, top = plan_groups(tiles_5000)
    assert len(tiles_5000) == 1600 and top == ["376"] and len(groups) == 17
    assert all(len(g.children) == 100 for g in groups.values() if len(g.name) == 5)
    assert len(groups["376"].children) == 16


def _buildings() -> Candidates:
    rng = np.random.default_rng(2)
    footprints, ids, base, top, size, attributes = [], [], [], [], [], []
    for k in range(30):
        x, y = 209000 + 40 * (k % 6), 543000 + 40 * (k // 6)
        w, h = rng.uniform(5, 25, 2)
        ring = [(x, y), (x + w, y), (x + w, y + h), (x + w / 2, y + h + 0.2), (x, y + h)]  # a 0.2 m kink
        footprints.append(shapely.Polygon(ring))
        ids.append(f"BLD_{k}")
        base.append(30.0 + k)
        height = rng.uniform(3, 60)
        top.append(30.0 + k + height)
        size.append(max(float(np.hypot(w, h + 0.2)), height))
        attributes.append([ids[-1], height, None, "한빛빌딩" if k % 2 else None])
    fields = [(step_layers.WIT_ID, ogr.OFTString), (step_layers.HEIGHT, ogr.OFTReal),
              (step_layers.STOREYS_BELOW, ogr.OFTInteger), ("BULD_NM", ogr.OFTString)]
    return Candidates(fields, ids, np.array(footprints, dtype=object), np.array(base), np.array(top),
                      np.array(size), attributes)


def test_a_group_keeps_its_largest_buildings_and_counts_the_largest_left_out():
    all_buildings = _buildings()
    kept = all_buildings.largest(10)
    order = np.argsort(-all_buildings.size)
    assert set(kept.ids) == {all_buildings.ids[i] for i in order[:10]}
    assert kept.dropped == pytest.approx(all_buildings.size[order[10]])
    halves = [Candidates(all_buildings.fields[:2], all_buildings.ids[:15], all_buildings.footprints[:15],
                         all_buildings.base[:15], all_buildings.top[:15], all_buildings.size[:15],
                         [row[:2] for row in all_buildings.attributes[:15]], dropped=1.5),
              all_buildings.largest(30)]
    joined = Candidates.join([halves[0], halves[1].largest(15)])
    assert [n for n, _ in joined.fields] == [step_layers.WIT_ID, step_layers.HEIGHT, step_layers.STOREYS_BELOW,
                                             "BULD_NM"]
    assert joined.attributes[0][2:] == [None, None]  # fields a part lacks: NULL
    assert joined.dropped == max(1.5, halves[1].largest(15).dropped)


def test_group_buildings_are_prisms_with_their_attributes_and_a_measured_simplification(tmp_path):
    buildings = _buildings()
    georef = Georeference("EPSG:5186")
    frame = georef.frame(209100.0, 543100.0, 50.0)
    glb = GlbBuilder()
    rect = (208990.0, 542990.0, 209290.0, 543290.0)
    drawn = add_buildings(glb, georef, frame, buildings, rect, cell=16.0, roof_image=None, name="g")
    assert 0.19 < drawn.simplification < 0.21 and drawn.vanished == 0.0  # the 0.2 m kink simplified away (1 m)
    data = glb.to_bytes()
    gltf, blob = read_glb(data)
    assert check_glb_metadata(gltf, blob) == ([], 1)
    table = gltf["extensions"]["EXT_structural_metadata"]["propertyTables"][0]
    assert table["count"] == 30 and "wit_storeys_below" in table["properties"]
    path = tmp_path / "g.glb"
    path.write_bytes(data)
    result = subprocess.run(["node", str(ROOT / "viewer" / "validate-gltf.mjs"), str(tmp_path)], capture_output=True,
                            text=True, timeout=300)
    summary = json.loads(result.stdout)
    assert summary["files"] == 1 and summary["errors"] == 0 and summary["warnings"] == 0, summary
    # every vertex of building k lies on its footprint's outline or inside it, at its ground or roof height
    import pygltflib

    model_gltf = pygltflib.GLTF2().load_binary(str(path))
    blob = model_gltf.binary_blob()
    for primitive in model_gltf.meshes[0].primitives:
        positions, features = (model_gltf.accessors[i] for i in (primitive.attributes.POSITION,
                                                                 primitive.attributes._FEATURE_ID_0))
        xyz = np.frombuffer(blob, np.float32, positions.count * 3,
                            model_gltf.bufferViews[positions.bufferView].byteOffset).reshape(-1, 3)
        fid = np.frombuffer(blob, np.float32, features.count,
                            model_gltf.bufferViews[features.bufferView].byteOffset).astype(int)
        points = gltf_to_model(georef, frame, xyz.astype(np.float64))
        for k in np.unique(fid):
            mine = points[fid == k]
            assert shapely.distance(buildings.footprints[k], shapely.points(mine[:, :2])).max() < 0.01
            z = mine[:, 2]
            assert np.all(np.isclose(z, buildings.base[k], atol=0.01) | np.isclose(z, buildings.top[k], atol=0.01))


def _plane(rect, n=8, image=(10, 200, 30)):
    x0, _, x1, y1 = rect
    step = (x1 - x0) / n
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    heights = 100.0 + 0.01 * (x0 + j * step - 209000) + 0.02 * (y1 - i * step - 543000)
    return Terrain(rect, heights, np.full((16, 16, 3), image, dtype=np.uint8), 0.5)


def test_a_higher_groups_terrain_is_joined_from_its_childrens(monkeypatch):
    from wit_plugin.tiles3d import groups

    monkeypatch.setattr(groups, "GROUP_CELLS", 8)
    monkeypatch.setattr(groups, "GROUP_IMAGE", 32)
    left, right = (209000.0, 543000.0, 209400.0, 543400.0), (209400.0, 543000.0, 209800.0, 543400.0)
    area = shapely.box(209000.0, 543000.0, 209800.0, 543400.0)
    joined = join_terrain([_plane(left), _plane(right, image=(200, 20, 40))], area)
    assert joined.rect == (209000.0, 542600.0, 209800.0, 543400.0)
    x, y = groups._vertices(joined.rect, 8)
    expected = 100.0 + 0.01 * (x - 209000) + 0.02 * (y - 543000)
    north = joined.heights[:5]  # the children cover the northern half
    assert np.nanmax(np.abs(north - expected[:5])) < 1e-6 and np.isfinite(north[1:4, 1:7]).all()
    assert np.isnan(joined.heights[6:]).all()
    assert joined.error == pytest.approx(0.5, abs=1e-6)  # a plane joins exactly: the children's error
    assert (joined.image[2, 4] == (10, 200, 30)).all() and (joined.image[2, 28] == (200, 20, 40)).all()
    # the grid's own heights between its vertices, as its triangles draw them
    assert grid_at(joined.heights, joined.rect, np.array([209050.0]), np.array([543350.0]))[0] == pytest.approx(
        100.0 + 0.5 + 7.0)


def _stand_in_run(folder: Path, sheets: list[str]) -> dict:
    """Tiles whose tilesets are one quad of ground and whose lod1.gpkg holds four buildings, a DEM of a
    plane and a 64² orthoimage sheet per 1:5,000 sheet: what ``write_run_tileset`` reads of a run."""
    import pyproj
    from osgeo import gdal, osr

    from wit_plugin.sheetrun.plan import tile_of
    from wit_plugin.tiles3d.geo import column_major

    georef = Georeference("EPSG:5186")
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    areas = {s: tile_of(s, "EPSG:5186").polygon for s in sheets}
    x0, y0, x1, y1 = shapely.union_all(list(areas.values())).buffer(300).bounds
    dem = gdal.GetDriverByName("GTiff").Create(str(folder / "dem.tif"), int((x1 - x0) / 20), int((y1 - y0) / 20), 1,
                                               gdal.GDT_Float32)
    dem.SetGeoTransform((x0, 20.0, 0.0, y1, 0.0, -20.0))
    dem.SetProjection(srs.ExportToWkt())
    dem.GetRasterBand(1).Fill(35.0)
    dem = None
    (folder / "ortho").mkdir()
    lon, lat = pyproj.Transformer.from_crs("EPSG:5186", "EPSG:4737", always_xy=True).transform([x0, x1], [y0, y1])
    for sheet in sheets_covering(min(lon), min(lat), max(lon), max(lat), 5000):
        image = gdal.GetDriverByName("GTiff").Create(str(folder / "ortho" / f"ortho_{sheet.number}.tif"), 64, 64, 3)
        for band, value in enumerate((90, 160, 70)):
            image.GetRasterBand(band + 1).Fill(value)
        image = None
    for number, (sheet, polygon) in enumerate(areas.items()):
        tile = folder / "tiles" / sheet
        (tile / "3dtiles").mkdir(parents=True)
        bx0, by0, bx1, by1 = polygon.bounds
        xyz = np.array([[bx0, by0, 35.0], [bx1, by0, 35.0], [bx1, by1, 35.0], [bx0, by1, 35.0]])
        frame = georef.frame((bx0 + bx1) / 2, (by0 + by1) / 2, 35.0)
        glb = GlbBuilder()
        glb.triangles(georef.local(frame, xyz[[0, 1, 2, 0, 2, 3]]).reshape(2, 3, 3),
                      glb.plain_material((150, 150, 140), lit=False))
        (tile / "3dtiles" / "ground.glb").write_bytes(glb.to_bytes())
        root = {"boundingVolume": {"region": georef.region(xyz)}, "geometricError": 8.0, "refine": "REPLACE",
                "transform": column_major(frame), "content": {"uri": "ground.glb"}}
        (tile / "3dtiles" / "tileset.json").write_text(json.dumps({"asset": {"version": "1.1"},
                                                                   "geometricError": 16.0, "root": root}))
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(tile / "lod1.gpkg"))
        layer = ds.CreateLayer(step_layers.LOD1_LAYER, srs, ogr.wkbPolygon)
        for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                           (step_layers.FACE_NUMBER, ogr.OFTInteger), (step_layers.BASE_Z, ogr.OFTReal),
                           (step_layers.HEIGHT, ogr.OFTReal), (step_layers.STOREYS_BELOW, ogr.OFTInteger)):
            layer.CreateField(ogr.FieldDefn(name, kind))
        cx, cy = polygon.centroid.x, polygon.centroid.y
        for k in range(4):
            feature = ogr.Feature(layer.GetLayerDefn())
            for name, value in ((step_layers.WIT_ID, f"BLD_{number}_{k}"), (step_layers.FACE_TYPE, "ground"),
                                (step_layers.FACE_NUMBER, 0), (step_layers.BASE_Z, 35.0),
                                (step_layers.HEIGHT, 10.0 + 10 * k)):
                feature.SetField(name, value)
            feature.SetGeometry(ogr.CreateGeometryFromWkt(shapely.box(cx + 30 * k, cy, cx + 30 * k + 12, cy + 15).wkt))
            layer.CreateFeature(feature)
        ds = None
    return areas


def test_a_run_across_two_1_50000_sheets_gets_bounded_files_that_our_checker_passes(tmp_path):
    from wit_plugin.tiles3d.check import check_tileset
    from wit_plugin.tiles3d.combine import write_run_tileset

    sheets = _sheets(127.0051, 37.4951, 127.0149, 37.5049)  # 1:1,000 sheets on both sides of 37.5°N
    areas = _stand_in_run(tmp_path, sheets)
    written = write_run_tileset(tmp_path, {s: f"tiles/{s}" for s in sheets}, areas, str(tmp_path / "dem.tif"),
                                [str(p) for p in (tmp_path / "ortho").iterdir()], "EPSG:5186")
    assert written.tiles == len(sheets) == 4 and written.without_terrain == 0
    groups, top = plan_groups(sheets)
    assert written.groups == len(groups) == 3 and top == ["377"] and written.levels == 2  # two 1:5,000, a block
    assert written.buildings == 2 * 4 * len(sheets)  # each building in its 1:5,000 group and in the block
    check = check_tileset(tmp_path)
    assert check.problems == [] and check.property_tables == 3
    assert set(check.tilesets) == {"tileset.json", "3dtiles-groups/377.json"} | {
        f"3dtiles-groups/{g}.json" for g in groups["377"].children} | {
        f"tiles/{s}/3dtiles/tileset.json" for s in sheets}
    assert written.root_bytes == (tmp_path / "tileset.json").stat().st_size < 1000
    block = json.loads((tmp_path / "3dtiles-groups" / "377.json").read_text())["root"]
    assert block["geometricError"] == pytest.approx(written.errors["377"], abs=1e-3)
    assert written.errors["377"] > max(written.errors[g] for g in groups["377"].children)
    frame = np.array(block["transform"]).reshape(4, 4).T
    for child in block["children"]:
        np.testing.assert_allclose(frame @ np.array(child["transform"]).reshape(4, 4).T, np.eye(4), atol=1e-9)
    assert list(tmp_path.glob(".wit-*")) == []  # the staging and scratch folders are gone
