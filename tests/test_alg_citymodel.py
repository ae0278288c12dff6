"""The whole chain through Processing on a small sample: every step's output feeds the next,
and the CityGML 3.0 result is valid for xmllint (an independent tool) and for our validator."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from conftest import ensure_wit_provider
from lxml import etree
from osgeo import ogr
from qgis.core import QgsVectorLayer

from wit_plugin.sample import SampleConfig, generate_sample

pytestmark = pytest.mark.qgis_facing

NS = {"bldg": "http://www.opengis.net/citygml/building/3.0", "core": "http://www.opengis.net/citygml/3.0",
      "app": "http://www.opengis.net/citygml/appearance/3.0", "dem": "http://www.opengis.net/citygml/relief/3.0",
      "tran": "http://www.opengis.net/citygml/transportation/3.0", "gml": "http://www.opengis.net/gml/3.2",
      "grp": "http://www.opengis.net/citygml/cityobjectgroup/3.0",
      "gen": "http://www.opengis.net/citygml/generics/3.0"}


@pytest.fixture(scope="module")
def chain(tmp_path_factory, qgis_processing):
    """Run every step once (module scope): the tests below inspect the results."""
    import processing

    ensure_wit_provider()
    out = tmp_path_factory.mktemp("chain")
    sample = generate_sample(out / "sample", SampleConfig(radius_m=250.0, seed=11, ortho_pixel_size=1.0))
    run = processing.run
    results = {"sample": sample}
    results["geo"] = run("wit:georeferencemapsheets", {
        "INPUT": [str(sample.ortho_tiles[0].parent)], "OUTPUT": str(out / "geo"),
        "OUTPUT_INDEX": str(out / "sheets.gpkg")})
    results["mosaic"] = run("wit:mergerasters", {
        "INPUT": results["geo"]["OUTPUT_LAYERS"], "OVERLAP": 1, "OUTPUT": str(out / "mosaic.tif")})
    results["prepared"] = run("wit:preparevectors", {
        "BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads), "DISTRICTS": str(sample.districts),
        "RADIUS": 200.0, "OUTPUT": str(out / "prepared.gpkg")})
    prepared = results["prepared"]["OUTPUT"]
    results["tin"] = run("wit:triangulateterrain", {
        "DEM": str(sample.dem), "AREA": f"{prepared}|layername=study_area",
        "BUILDINGS": results["prepared"]["BUILDINGS_OUT"], "ROADS": results["prepared"]["ROADS_OUT"],
        "OUTPUT": str(out / "tin.gpkg")})
    results["lod1"] = run("wit:extrudebuildings", {
        "BUILDINGS": results["prepared"]["BUILDINGS_OUT"], "DEM": str(sample.dem), "SPATIAL_INDEX": False,
        "OUTPUT": str(out / "lod1.gpkg")})
    results["texture"] = run("wit:wittexture", {
        "ORTHO": results["mosaic"]["OUTPUT"], "LOD1": results["lod1"]["LOD1"], "TIN": results["tin"]["TIN"],
        "OUTPUT": str(out / "textures")})
    results["gml"] = run("wit:writecitygml", {
        "LOD1": results["lod1"]["LOD1"], "TIN": results["tin"]["TIN"], "ROADS": results["prepared"]["ROADS_OUT"],
        "DISTRICTS": results["prepared"]["DISTRICTS_OUT"], "TEXTURES": results["texture"]["OUTPUT"],
        "OUTPUT": str(out / "model" / "suseo.gml")})
    results["out"] = out
    return results


def test_steps_produce_consistent_counts(chain):
    kept = chain["prepared"]["BUILDING_COUNT"]
    assert kept > 50
    assert chain["lod1"]["SOLIDS"] >= kept
    assert chain["gml"]["BUILDINGS"] == chain["lod1"]["SOLIDS"]  # a multipart footprint gives one solid per part
    assert chain["tin"]["MAX_VERTICAL_ERROR"] <= 0.5 and chain["tin"]["MAX_EDGE_MEASURED"] <= 5.0 + 1e-6
    assert chain["gml"]["TRIANGLES"] == chain["tin"]["TRIANGLES"]
    assert chain["gml"]["TEXTURED_SURFACES"] == chain["texture"]["TEXTURED_SURFACES"] > 0
    assert chain["gml"]["GROUPS"] >= 1
    tin = QgsVectorLayer(chain["tin"]["TIN"], "tin", "ogr")
    assert tin.featureCount() == chain["tin"]["TRIANGLES"]


def test_spatial_index_only_where_asked(chain):
    """The TIN (default) has a sound R-tree holding every triangle; the LoD1 faces were asked for none."""
    import sqlite3

    tin = sqlite3.connect(chain["tin"]["OUTPUT"])
    assert tin.execute("SELECT rtreecheck('rtree_tin_geom')").fetchone() == ("ok",)
    assert tin.execute("SELECT count(*) FROM rtree_tin_geom").fetchone() == (chain["tin"]["TRIANGLES"],)
    lod1 = sqlite3.connect(chain["lod1"]["OUTPUT"])
    assert lod1.execute("SELECT count(*) FROM sqlite_master WHERE name LIKE 'rtree%'").fetchone() == (0,)
    assert lod1.execute("SELECT count(*) FROM lod1_faces").fetchone()[0] > 6 * chain["lod1"]["SOLIDS"] - 1


def test_citygml_is_valid_for_xmllint(chain, shared_dir):
    result = subprocess.run(["xmllint", "--nonet", "--noout", "--schema",
                             str(shared_dir / "schemas" / "citygml3-all.xsd"), chain["gml"]["OUTPUT"]],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]


def test_citygml_is_valid_for_our_validator(chain, shared_dir):
    import processing

    ensure_wit_provider()

    result = processing.run("wit:validatecitygml", {
        "INPUT": [chain["gml"]["OUTPUT"]], "SCHEMA_DIR": str(shared_dir / "schemas"),
        "OUTPUT": str(chain["out"] / "validation.html")})
    html = (chain["out"] / "validation.html").read_text(encoding="utf-8")
    assert result["VALID"] is True, html[:3000]
    assert result["ERROR_COUNT"] == 0


def test_citygml_content(chain):
    tree = etree.parse(chain["gml"]["OUTPUT"])
    buildings = tree.findall(".//bldg:Building", NS)
    assert len(buildings) == chain["lod1"]["SOLIDS"]
    assert all(b.find("core:lod1Solid/gml:Solid", NS) is not None for b in buildings)
    assert tree.find(".//tran:Road", NS) is not None
    assert tree.find(".//dem:TINRelief", NS) is not None
    images = [e.text for e in tree.iterfind(".//app:imageURI", NS)]
    model_dir = chain["out"] / "model"
    assert images and all((model_dir / i).exists() for i in images)
    assert tree.find(".//gen:StringAttribute", NS) is not None
    assert len(tree.findall(".//grp:CityObjectGroup", NS)) == chain["gml"]["GROUPS"]
    korean = {v.text for v in tree.iterfind(".//gen:StringAttribute/gen:value", NS)}
    assert any("동" in (t or "") for t in korean)


def test_building_positions_match_the_prepared_footprints_to_the_millimetre(chain):
    ds = ogr.Open(chain["prepared"]["OUTPUT"])
    footprints = {f["wit_id"]: f.GetGeometryRef().Clone() for f in ds.GetLayerByName("buildings")}
    tree = etree.parse(chain["gml"]["OUTPUT"])
    checked = 0
    for building in tree.iterfind(".//bldg:Building", NS):
        gid = building.get("{http://www.opengis.net/gml/3.2}id")
        if gid not in footprints:
            continue  # multipart footprints become <id>_partN solids
        pos = building.find(".//gml:posList", NS).text.split()
        xy = [(float(pos[i]), float(pos[i + 1])) for i in range(0, len(pos), 3)]
        boundary = footprints[gid].GetBoundary()
        for x, y in xy:
            point = ogr.Geometry(ogr.wkbPoint)
            point.AddPoint_2D(x, y)
            assert boundary.Distance(point) <= 0.0015, (gid, x, y)
        checked += 1
    assert checked > 50


def test_citymodel_in_one_call_gives_the_same_model(chain, shared_dir, tmp_path):
    import processing

    ensure_wit_provider()
    sample = chain["sample"]
    result = processing.run("wit:citymodel", {
        "ORTHO_INPUT": [str(sample.ortho_tiles[0].parent)], "DEM": str(sample.dem),
        "BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads), "DISTRICTS": str(sample.districts),
        "RADIUS": 200.0, "SCHEMA_DIR": str(shared_dir / "schemas"), "CITYJSON": True, "OUTPUT": str(tmp_path / "city")})
    assert result["VALID"] is True and result["ERROR_COUNT"] == 0
    ids = lambda path: {b.get("{http://www.opengis.net/gml/3.2}id")  # noqa: E731
                        for b in etree.parse(path).iterfind(".//bldg:Building", NS)}
    assert ids(result["GML"]) == ids(chain["gml"]["OUTPUT"])
    # CityJSON beside it (CITYJSON): the same buildings, validated with it (validation.html lists both)
    assert result["CITYJSON_FILE"] == str(tmp_path / "city" / "model.city.json")
    cityjson = json.loads(Path(result["CITYJSON_FILE"]).read_text(encoding="utf-8"))
    assert {k for k, v in cityjson["CityObjects"].items() if v["type"] == "Building"} == ids(result["GML"])
    assert all((tmp_path / "city" / t["image"]).is_file() for t in cityjson["appearance"]["textures"])
    assert "model.city.json" in (tmp_path / "city" / "validation.html").read_text(encoding="utf-8")
    assert result["BUILDINGS_WRITTEN"] == chain["gml"]["BUILDINGS"]
    produced = {p.name for p in (tmp_path / "city").iterdir()}
    assert {"model.gml", "model_textures", "validation.html", "metrics.csv", "metrics.html", "steps.json"} <= produced
    assert not any(name.startswith((".wit-run-", "work")) for name in produced), "staging or work folder left"
    assert list(json.loads(result["STEP_TIMES"])) == ["prepare", "coverage", "georeference", "merge", "extrude",
                                                       "terrain", "metrics", "texture", "3dtiles", "citygml",
                                                       "cityjson", "validate"]
    assert result["TILESET"] == str(tmp_path / "city" / "3dtiles" / "tileset.json")
    assert Path(result["TILESET"]).is_file()
    assert {"lod1.gpkg", "tin.gpkg", "3dtiles"} <= produced
    # the sample's one building without floors here
    assert result["DEFAULT_HEIGHTS"] == chain["lod1"]["DEFAULT_HEIGHTS"] == 1
    assert result["UNTEXTURED"] == 0
