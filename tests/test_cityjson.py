"""wit_plugin.cityjson: the small city of test_citygml (two touching LoD1 boxes, one with a courtyard, a TIN with a
road, districts, textures; here also a generated facade) as CityJSON 2.0 and CityJSONSeq — checked value by value
against the inputs, the official schemas, our validator (the same verdicts as the CityGML's) and cjio."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import gdal, ogr
from test_citygml import ROAD, A, B, _add, _layer, make_inputs

from wit_plugin.citygml import writer as citygml
from wit_plugin.citygml.validate import validate_files
from wit_plugin.cityjson import schema
from wit_plugin.cityjson import writer as cityjson
from wit_plugin.cityjson.sequence import RUN_INDEX, run_translate, write_run_index
from wit_plugin.cityjson.validate import image_folder_of, validate_cityjson_files
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback

FACADE_IMAGE = "facade_house_1.png"
TILE_A, TILE_B = "37709005", "37709006"


def with_facade(inputs) -> None:
    """A generated facade on A's first wall (face 2), as wit:wittexture writes it: the image, its row in the
    texture table (u along the wall, v in storeys) and A's row in the facade table."""
    folder = Path(inputs.textures)
    gdal.GetDriverByName("PNG").CreateCopy(str(folder / FACADE_IMAGE), gdal.GetDriverByName("MEM").Create("", 8, 8, 3))
    ds = ogr.Open(str(folder / "texcoords.gpkg"), 1)
    _add(ds.GetLayerByName(step_layers.TEXCOORD_TABLE), None, **{
        step_layers.TEX_TARGET: step_layers.TEX_WALL, step_layers.TEX_FEATURE: A["wit_id"], step_layers.TEX_FACE: 2,
        step_layers.TEX_IMAGE: FACADE_IMAGE, step_layers.TEX_COORDS: "0 0 3.2656 0 3.2656 1 0 1 0 0"})
    ds = None
    ds, layer = _layer(folder / step_layers.FACADE_FILE, step_layers.FACADE_TABLE, ogr.wkbNone, {
        step_layers.WIT_ID: ogr.OFTString, step_layers.FACADE: ogr.OFTString, step_layers.FACADE_STYLE: ogr.OFTString,
        step_layers.FACADE_RULE: ogr.OFTString, step_layers.FACADE_STOREYS: ogr.OFTInteger,
        step_layers.FACADE_STOREYS_SOURCE: ogr.OFTString, step_layers.FACADE_IMAGE: ogr.OFTString})
    _add(layer, None, **{step_layers.WIT_ID: A["wit_id"], step_layers.FACADE: "generated",
                         step_layers.FACADE_STYLE: "house", step_layers.FACADE_RULE: "BDTYP_CD 01001",
                         step_layers.FACADE_STOREYS: 3, step_layers.FACADE_STOREYS_SOURCE: "GRND_FLR",
                         step_layers.FACADE_IMAGE: FACADE_IMAGE})
    del ds


@pytest.fixture(scope="module")
def city(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cityjson")
    inputs = make_inputs(folder / "in")
    with_facade(inputs)
    out = folder / "out" / "city.city.json"
    report = cityjson.write_cityjson(inputs, str(out))
    return inputs, out, report, json.loads(out.read_text(encoding="utf-8"))


def _vertices(doc: dict) -> np.ndarray:
    transform = doc["transform"]
    return np.array(doc["vertices"]) * transform["scale"] + transform["translate"]


def _geometry(doc: dict, object_id: str) -> dict:
    (geometry,) = doc["CityObjects"][object_id]["geometry"]
    return geometry


def test_counts_ids_and_metadata(city):
    _, out, report, doc = city
    assert (report.buildings, report.roads, report.triangles, report.groups, report.textures) == (2, 1, 5, 2, 3)
    assert doc["type"] == "CityJSON" and doc["version"] == "2.0"
    assert doc["transform"] == {"scale": [0.001] * 3, "translate": [208990.0, 543110.0, 9.0]}
    assert list(doc["CityObjects"]) == [A["wit_id"], B["wit_id"], ROAD, citygml.TIN_RELIEF_ID, "EMD_11110101",
                                        "EMD_11110102"]
    assert [o["type"] for o in doc["CityObjects"].values()] == ["Building", "Building", "Road", "TINRelief",
                                                                 "CityObjectGroup", "CityObjectGroup"]
    metadata = doc["metadata"]
    assert metadata["referenceSystem"] == "https://www.opengis.net/def/crs/EPSG/0/5186"
    assert metadata["geographicalExtent"] == [208990.0, 543110.0, 9.5, 209050.0, 543140.0, 18.6]
    assert metadata["lineage"] == cityjson.LINEAGE
    assert report.vertices == len(doc["vertices"])


def test_buildings_attributes_and_semantics(city):
    _, _, _, doc = city
    a, b = doc["CityObjects"][A["wit_id"]], doc["CityObjects"][B["wit_id"]]
    assert a["attributes"] == {
        "wit_base_z": 10.0, "wit_height_src": "field", "BULD_NM": "서울특별시청", "GRND_FLR": 3, "AREA": 267.52,
        "NOTE": 'a<b & "c" d', "wit_facade": "generated", "wit_facade_style": "house",
        "wit_facade_rule": "BDTYP_CD 01001", "wit_facade_storeys": 3, "wit_facade_storeys_src": "GRND_FLR",
        "height": 8.6, "heightStatus": "measured", "heightLowReference": "lowestGroundPoint",
        "heightHighReference": "highestRoofEdge",
        "storeysAboveGround": 3, "storeysBelowGround": 1}
    assert b["attributes"] == {"wit_base_z": 10.5, "wit_height_src": "default", "BULD_NM": "덕수궁 별관",
                               "height": 3.0, "heightStatus": "estimated", "heightLowReference": "lowestGroundPoint",
                               "heightHighReference": "highestRoofEdge"}
    assert a["parents"] == ["EMD_11110101"] and b["parents"] == ["EMD_11110102"]
    geometry = _geometry(doc, A["wit_id"])
    assert geometry["type"] == "Solid" and geometry["lod"] == "1"
    assert geometry["semantics"] == {"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"},
                                                  {"type": "WallSurface"}], "values": [[0, 1, 2, 2, 2, 2]]}
    vertices = _vertices(doc)
    roof = vertices[geometry["boundaries"][0][1][0]]  # the roof's exterior ring, as stored (no closing point)
    assert np.allclose(roof, [[209000, 543120, 18.6], [209020.9, 543120, 18.6], [209020.9, 543132.8, 18.6],
                              [209000, 543132.8, 18.6]], rtol=0, atol=1e-6)
    courtyard = _geometry(doc, B["wit_id"])["boundaries"][0][1]  # B's roof: exterior and courtyard rings
    assert [len(ring) for ring in courtyard] == [4, 4]
    assert len(_geometry(doc, B["wit_id"])["boundaries"][0]) == 2 + 4 + 4  # ground, roof, outer and inner walls


def test_textures_same_images_and_coordinates_as_the_citygml(city):
    _, out, _, doc = city
    textures = doc["appearance"]["textures"]
    assert textures == [
        {"type": "JPG", "image": "city_textures/atlas/roofs.jpg", "textureType": "specific"},
        {"type": "PNG", "image": f"city_textures/{FACADE_IMAGE}", "wrapMode": "wrap", "textureType": "typical"},
        {"type": "PNG", "image": "city_textures/ground.png", "textureType": "specific"}]
    assert all((out.parent / t["image"]).is_file() for t in textures)
    assert doc["appearance"]["default-theme-texture"] == "rgbTexture"
    uv = np.array(doc["appearance"]["vertices-texture"])
    a = _geometry(doc, A["wit_id"])["texture"]
    assert sorted(a) == ["generatedFacade", "rgbTexture"]
    roof = a["rgbTexture"]["values"][0][1][0]
    assert roof[0] == 0 and uv[roof[1:]].tolist() == [[0, 0], [0.5, 0], [0.5, 0.5], [0, 0.5]]
    assert [v for k, v in enumerate(a["rgbTexture"]["values"][0]) if k != 1] == [[[None]]] * 5
    wall = a["generatedFacade"]["values"][0][2][0]
    assert wall[0] == 1 and uv[wall[1:]].tolist() == [[0, 0], [3.2656, 0], [3.2656, 1], [0, 1]]
    b_roof = _geometry(doc, B["wit_id"])["texture"]["rgbTexture"]["values"][0][1]
    assert b_roof[0][0] == 0 and b_roof[1] == [None]  # the courtyard ring: no coordinates, as in the CityGML
    road = _geometry(doc, ROAD)
    assert road["type"] == "MultiSurface" and road["lod"] == "2"
    assert road["semantics"] == {"surfaces": [{"type": "TrafficArea"}], "values": [0, 0]}
    values = road["texture"]["rgbTexture"]["values"]
    assert values[1] == [[None]] and values[0][0][0] == 2 and uv[values[0][0][1:]].tolist() == [[0, 0], [1, 0],
                                                                                                  [1, 0.25]]
    # the relief: one composite surface per part joined by edges (terrain triangles 3 and 4; the footprint's 5)
    ground, footprint = doc["CityObjects"][citygml.TIN_RELIEF_ID]["geometry"]
    assert [g["type"] for g in (ground, footprint)] == ["CompositeSurface"] * 2
    assert [len(g["boundaries"]) for g in (ground, footprint)] == [2, 1]
    assert [v[0][0] for v in ground["texture"]["rgbTexture"]["values"]] == [2, 2]
    assert "texture" not in footprint  # triangle 5 has no texture coordinates


def test_groups_list_their_buildings(city):
    _, _, _, doc = city
    first, second = doc["CityObjects"]["EMD_11110101"], doc["CityObjects"]["EMD_11110102"]
    assert first["children"] == [A["wit_id"]] and second["children"] == [B["wit_id"]]
    assert first["attributes"] == {"name": "청운동", "EMD_CD": "11110101", "EMD_KOR_NM": "청운동"}


def test_schema_valid_and_the_same_verdict_as_the_citygml(city, tmp_path, shared_dir):
    inputs, out, _, _ = city
    assert schema.available()
    (report,) = validate_cityjson_files([str(out)])
    assert report.valid and report.issues == [], report.issues
    gml = tmp_path / "city.gml"
    citygml.write_citygml(inputs, str(gml))
    (gml_report,) = validate_files([str(gml)], shared_dir / "schemas")
    assert gml_report.valid == report.valid


def test_cjio_reads_it(city):
    _, out, _, _ = city
    from cjio import cityjson as cj

    with open(out, encoding="utf-8") as stream:
        model = cj.reader(stream)
    model.check_version()
    assert model.get_epsg() == 5186
    assert model.number_city_objects_level1() == 4  # groups, road, relief (buildings are the groups' children)
    info = "\n".join(model.get_info(long=True))
    assert "|-- CityObjectGroup (2)" in info and "Building (2)" in info and "|-- Road (1)" in info
    assert "semantics surfaces = ['GroundSurface', 'RoofSurface', 'TrafficArea', 'WallSurface']" in info
    assert model.get_textures_location() == str(out.parent / "city_textures" / "atlas")  # its first image's


def test_stable_bytes_and_linked_textures(city, tmp_path):
    inputs, out, _, _ = city
    again = tmp_path / "city.city.json"
    cityjson.write_cityjson(inputs, str(again))
    assert again.read_bytes() == out.read_bytes()
    linked = tmp_path / "linked" / "city.city.json"
    cityjson.write_cityjson(inputs, str(linked), copy_textures=False)
    images = [t["image"] for t in json.loads(linked.read_text())["appearance"]["textures"]]
    assert not (linked.parent / "city_textures").exists()
    assert all(not Path(i).is_absolute() and (linked.parent / i).is_file() for i in images)


def test_sequence_one_feature_a_line(city, tmp_path):
    inputs, _, _, doc = city
    out = tmp_path / "city.city.jsonl"
    report = cityjson.write_cityjson(inputs, str(out))
    lines = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert report.features == len(lines) - 1 == 6
    head = lines[0]
    assert head["CityObjects"] == {} and head["vertices"] == [] and head["transform"] == doc["transform"]
    assert [f["id"] for f in lines[1:]] == list(doc["CityObjects"])
    for feature, (object_id, city_object) in zip(lines[1:], doc["CityObjects"].items()):
        assert feature["type"] == "CityJSONFeature" and list(feature["CityObjects"]) == [object_id]
        mine = feature["CityObjects"][object_id]
        assert mine.get("attributes") == city_object.get("attributes")
        if "geometry" in mine:  # the same coordinates and texture coordinates, by local indices
            here, there = mine["geometry"][0], city_object["geometry"][0]
            local = np.array(feature["vertices"])[np.array(_flat(here["boundaries"]))]
            whole = np.array(doc["vertices"])[np.array(_flat(there["boundaries"]))]
            assert local.tolist() == whole.tolist()
    a = lines[1]
    assert [t["image"] for t in a["appearance"]["textures"]] == ["city_textures/atlas/roofs.jpg",
                                                                 f"city_textures/{FACADE_IMAGE}"]
    (report,) = validate_cityjson_files([str(out)])
    assert report.valid, report.issues


def _flat(values):
    return [x for v in values for x in (_flat(v) if isinstance(v, list) else [v])]


def test_tiles_join_into_one_valid_sequence(city, tmp_path):
    """Two tiles of a run (the same model twice, as two sheets): one transform, ids shared by tiles suffixed,
    images named from the run's folder; header + features joined by cat is one valid sequence."""
    inputs, _, _, _ = city
    run = tmp_path / "run"
    translate = run_translate(shapely.box(208900.5, 543000.2, 209300, 543300))
    assert translate == (208900.0, 543000.0, 0.0)
    for sheet in (TILE_A, TILE_B):
        tile_inputs = inputs if sheet == TILE_A else citygml.CityGMLInputs(
            lod1=None, tin=inputs.tin, roads=inputs.roads, districts=inputs.districts, textures=inputs.textures)
        part = cityjson.SequencePart(translate, f"_{sheet}", f"tiles/{sheet}")
        out = run / "tiles" / sheet / "model.city.jsonl"
        cityjson.write_cityjson(tile_inputs, str(out), part=part)
    tile_a_file = run / "tiles" / TILE_A / "model.city.jsonl"
    write_run_index(run, [(s, f"tiles/{s}/model.city.jsonl") for s in (TILE_A, TILE_B, "37709007")], "EPSG:5186",
                    translate)
    head = json.loads((run / RUN_INDEX).read_text())
    assert [p["sheet"] for p in head["metadata"]["parts"]] == [TILE_A, TILE_B]  # 37709007 has no sequence
    assert [p["features"] for p in head["metadata"]["parts"]] == [6, 2]  # tile B: its road and relief
    assert head["transform"]["translate"] == list(translate)
    joined = run / "run.city.jsonl"
    subprocess.run(f"(cat {RUN_INDEX}; tail -q -n +2 tiles/*/model.city.jsonl) > {joined.name}", shell=True,
                   cwd=run, check=True)
    lines = joined.read_text(encoding="utf-8").splitlines()
    ids = [json.loads(line)["id"] for line in lines[1:]]
    assert ids == [A["wit_id"], B["wit_id"], f"{ROAD}_{TILE_A}", f"DEM_tin_{TILE_A}", f"EMD_11110101_{TILE_A}",
                   f"EMD_11110102_{TILE_A}", f"{ROAD}_{TILE_B}", f"DEM_tin_{TILE_B}"]
    assert json.loads(lines[1])["CityObjects"][A["wit_id"]]["parents"] == [f"EMD_11110101_{TILE_A}"]
    images = {t["image"] for line in lines[1:] for t in json.loads(line).get("appearance", {}).get("textures", [])}
    assert images == {f"tiles/{s}/model_textures/{i}" for s in (TILE_A, TILE_B) for i in ("ground.png",)} | {
        f"tiles/{TILE_A}/model_textures/atlas/roofs.jpg", f"tiles/{TILE_A}/model_textures/{FACADE_IMAGE}"}
    reports = validate_cityjson_files([str(joined), str(tile_a_file)])
    assert [r.valid for r in reports] == [True, True], [r.issues for r in reports]
    assert image_folder_of(tile_a_file) == run  # a tile's images are found from its run's folder
    cli = subprocess.run([str(Path(sys.executable).parent / "cjio"), "stdin", "info"], stdin=open(joined, "rb"),
                         capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    assert "Building (2)" in cli.stdout and "|-- Road (2)" in cli.stdout and "|-- TINRelief (2)" in cli.stdout


def test_buildings_only_and_relief_only(city, tmp_path):
    inputs, _, _, _ = city
    out = tmp_path / "only.city.json"
    report = cityjson.write_cityjson(citygml.CityGMLInputs(lod1=inputs.lod1), str(out))
    doc = json.loads(out.read_text())
    assert report.buildings == 2 and report.roads == report.triangles == report.groups == 0
    assert "appearance" not in doc and all("parents" not in o for o in doc["CityObjects"].values())
    (valid,) = validate_cityjson_files([str(out)])
    assert valid.valid


def test_writer_refuses_bad_input_up_front(city, tmp_path):
    inputs, _, _, _ = city
    with pytest.raises(InputError, match="does not exist"):
        cityjson.write_cityjson(citygml.CityGMLInputs(lod1=str(tmp_path / "missing.gpkg")),
                                str(tmp_path / "x.city.json"))
    with pytest.raises(InputError, match="ends with .city.json"):
        cityjson.write_cityjson(inputs, str(tmp_path / "x.gml"))
    with pytest.raises(InputError, match="written as a CityJSONSeq"):
        cityjson.write_cityjson(inputs, str(tmp_path / "x.city.json"),
                                part=cityjson.SequencePart((0, 0, 0), "_1", "t"))
    with pytest.raises(InputError, match="EPSG:5186, not EPSG:5179"):
        cityjson.write_cityjson(inputs, str(tmp_path / "x.city.json"), srs_name="EPSG:5179")
    tiff = tmp_path / "tex"
    shutil.copytree(inputs.textures, tiff)
    ds = ogr.Open(str(tiff / "texcoords.gpkg"), 1)
    ds.ExecuteSQL("UPDATE texcoords SET image = 'ground.tif' WHERE image = 'ground.png'")
    ds = None
    gdal.GetDriverByName("GTiff").CreateCopy(str(tiff / "ground.tif"), gdal.Open(str(tiff / "ground.png")))
    with pytest.raises(InputError, match="neither PNG nor JPEG"):
        cityjson.write_cityjson(citygml.CityGMLInputs(lod1=inputs.lod1, textures=str(tiff)),
                                str(tmp_path / "x.city.json"))
    assert not list(tmp_path.glob("x*"))


def test_cancel_leaves_no_output(city, tmp_path):
    inputs, _, _, _ = city

    class Cancel(Feedback):
        def is_canceled(self) -> bool:
            return True

    with pytest.raises(CanceledError):
        cityjson.write_cityjson(inputs, str(tmp_path / "c.city.json"), feedback=Cancel())
    assert list(tmp_path.iterdir()) == []


def _cells(cells: list[tuple[int, int]]) -> np.ndarray:
    """Two triangles per unit cell (x, y), counter-clockwise: (n, 3, 3) corners."""
    triangles = []
    for x, y in cells:
        a, b, c, d = (x, y, 0.0), (x + 1, y, 0.0), (x + 1, y + 1, 0.0), (x, y + 1, 0.0)
        triangles += [(a, b, c), (a, c, d)]
    return np.array(triangles, dtype=float)


def test_relief_parts_are_connected_and_manifold():
    """Two cells touching at the vertex (2, 2) only, joined around it by a path of cells: one edge-connected
    set, pinched at that vertex (a composite surface must not be): the second fan becomes a part of its own."""
    from wit_plugin.cityjson.objects import surface_parts

    assert len(set(surface_parts(_cells([(0, 0), (1, 0), (0, 1), (1, 1)])).tolist())) == 1
    path = [(0, 1), (0, 2), (0, 3), (1, 3), (2, 3)]
    part = surface_parts(_cells([(1, 1), (2, 2)] + path))
    assert len(set(part.tolist())) == 2
    assert part[0] == part[1] == part[4] and part[2] == part[3] != part[0]  # (1, 1) with the path; (2, 2) alone
    assert len(set(surface_parts(_cells([(0, 0), (1, 1)])).tolist())) == 2  # touching at a vertex: two parts
