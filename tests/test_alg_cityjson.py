"""wit:exportcityjson and wit:validatecitygml on CityJSON through Processing and headless through qgis_process; and,
given QGIS's CityJSON Loader plugin (WIT_CITYJSON_LOADER: its folder, fetched by hand, not part of the project),
the file loaded by it."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT
from qgis.core import QgsVectorLayer
from test_citygml import A, B, make_inputs

pytestmark = pytest.mark.qgis_facing

#: the CityJSON Loader plugin's folder (a checkout of cityjson/cityjson-qgis-plugin); its test runs when given
LOADER = os.environ.get("WIT_CITYJSON_LOADER")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("cityjson-alg") / "in")


def _export(inputs, output: Path) -> dict:
    return {"LOD1": inputs.lod1, "TIN": inputs.tin, "ROADS": inputs.roads, "DISTRICTS": inputs.districts,
            "TEXTURES": inputs.textures, "OUTPUT": str(output)}


def test_export_through_processing(inputs, tmp_path, run_algorithm):
    out = tmp_path / "out" / "city.city.json"
    result = run_algorithm("wit:exportcityjson", _export(inputs, out))
    assert result["OUTPUT"] == str(out)
    assert (result["BUILDINGS"], result["ROADS_WRITTEN"], result["TRIANGLES"], result["GROUPS"]) == (2, 1, 5, 2)
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert len(doc["vertices"]) == result["VERTICES"]
    assert doc["CityObjects"][A["wit_id"]]["attributes"]["BULD_NM"] == "서울특별시청"
    assert sorted(p.name for p in (out.parent / "city_textures").rglob("*.*")) == ["ground.png", "roofs.jpg"]


def test_export_without_an_output_writes_a_temporary_file(inputs, run_algorithm):
    parameters = _export(inputs, "")
    del parameters["OUTPUT"]
    result = run_algorithm("wit:exportcityjson", parameters)
    assert Path(result["OUTPUT"]).is_file() and result["BUILDINGS"] == 2


def test_validate_reads_cityjson_and_citygml_alike(inputs, tmp_path, run_algorithm):
    model = tmp_path / "city.city.json"
    sequence = tmp_path / "city.city.jsonl"
    for out in (model, sequence):
        run_algorithm("wit:exportcityjson", _export(inputs, out))
    broken = tmp_path / "broken.city.json"
    doc = json.loads(model.read_text(encoding="utf-8"))
    shell = doc["CityObjects"][B["wit_id"]]["geometry"][0]["boundaries"][0]
    shell[:] = [[ring[::-1] for ring in surface] for surface in shell]  # every face reversed: inside out
    broken.write_text(json.dumps(doc), encoding="utf-8")
    result = run_algorithm("wit:validatecitygml", {"INPUT": [str(model), str(sequence), str(broken)],
                                                   "OUTPUT": str(tmp_path / "report.html"),
                                                   "OUTPUT_TABLE": str(tmp_path / "table.gpkg")})
    assert result["VALID"] is False and result["ERROR_COUNT"] == 1
    table = QgsVectorLayer(result["OUTPUT_TABLE"], "t", "ogr")
    rows = {Path(f["file"]).name: (f["status"], f["errors"], f["details"]) for f in table.getFeatures()}
    assert rows == {"city.city.json": ("Success", 0, "valid (schema, ids, references, geometry, textures)"),
                    "city.city.jsonl": ("Success", 0, "valid (schema, ids, references, geometry, textures)"),
                    "broken.city.json": ("Fail", 1, "solid-orientation: 1 error")}
    assert B["wit_id"] in (tmp_path / "report.html").read_text(encoding="utf-8")


def test_export_and_validate_headless(inputs, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cityjson-headless")
    env = dict(os.environ, WIT_QGIS_PROFILE=str(tmp_path_factory.mktemp("qgis-profile")))

    def run(*args: str) -> dict:
        done = subprocess.run([str(ROOT / "scripts" / "qgis-process"), "--json", "run", *args], capture_output=True,
                              text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        return json.loads(done.stdout[done.stdout.index("{"):])["results"]

    out = tmp / "city.city.jsonl"
    exported = run("wit:exportcityjson", *(f"--{k}={v}" for k, v in _export(inputs, out).items()))
    assert exported["BUILDINGS"] == 2 and len(out.read_text(encoding="utf-8").splitlines()) == 1 + 6
    validated = run("wit:validatecitygml", f"--INPUT={out}", f"--OUTPUT={tmp / 'report.html'}")
    assert validated["VALID"] is True and validated["ERROR_COUNT"] == 0


@pytest.mark.skipif(not LOADER, reason="WIT_CITYJSON_LOADER (the CityJSON Loader plugin's folder) is not given")
def test_the_cityjson_loader_plugin_loads_the_buildings_with_their_attributes(inputs, tmp_path, run_algorithm):
    """QGIS's CityJSON Loader (copied into a fresh profile, run through its own Processing algorithm in a QGIS of
    its own) loads every building with its attributes, Korean names intact."""
    out = tmp_path / "city.city.json"
    run_algorithm("wit:exportcityjson", _export(inputs, out))
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "cityjson_loader.py"), LOADER, str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    layers = json.loads(done.stdout)["layers"]
    buildings = layers["city.city - Building"]
    assert buildings["features"] == 2 and buildings["crs"] == "EPSG:5186"
    assert buildings["first"]["uid"] == A["wit_id"] and buildings["first"]["attribute.BULD_NM"] == "서울특별시청"
    assert buildings["first"]["attribute.height"] == "8.6" and buildings["first"]["parents"] == "EMD_11110101"
    assert buildings["geometry"] == 1006  # MultiPolygonZ
