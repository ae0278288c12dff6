"""wit:generatesample through Processing, drawing from given layers: the real Gangnam roads and district
layer (CP949 shapefiles, EPSG:5179) and OpenStreetMap-style footprints (GeoPackage, EPSG:4326)."""
from __future__ import annotations

import json

import pyproj
import pytest
import shapely
from conftest import juso_roads
from qgis.core import QgsProcessingException
from test_sample_given import snapshot

from wit_plugin.infra import mapsheet
from wit_plugin.infra.io.vector_io import read_layer
from wit_plugin.infra.polygons import transform

pytestmark = pytest.mark.qgis_facing


def test_draws_the_tiles_of_a_district_from_the_given_layers(run_algorithm, shared_dir, suseo_buildings, tmp_path):
    roads = juso_roads(shared_dir)
    districts = roads.with_name("TL_SCCO_EMD.shp")
    buildings = f"{suseo_buildings}|layername=buildings"
    before = snapshot(roads, suseo_buildings)
    result = run_algorithm("wit:generatesample", {
        "BUILDINGS": buildings, "ROADS": str(roads), "DISTRICTS": str(districts), "DISTRICT_CODE": "수서동",
        "ORTHO_PIXEL_SIZE": 4.0, "DEM_CELL_SIZE": 20.0, "OUTPUT": str(tmp_path / "out")})
    assert snapshot(roads, suseo_buildings) == before
    assert (result["BUILDINGS"], result["ROADS"], result["DISTRICTS"]) == (buildings, str(roads), str(districts))
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["dem_5186.tif", "ortho", "sample_manifest.json"]
    layer = read_layer(districts)
    dong = transform(layer.geoms[[n == "수서동" for n in layer.columns["EMD_KOR_NM"]]], layer.crs,
                     pyproj.CRS("EPSG:5186"))[0]
    to_sheet = pyproj.Transformer.from_crs("EPSG:5186", "EPSG:4737", always_xy=True)
    corners = shapely.get_coordinates(shapely.segmentize(dong.exterior, 20.0))
    expected = {mapsheet.sheet_at(*to_sheet.transform(x, y)).number for x, y in corners}
    manifest = json.loads((tmp_path / "out" / "sample_manifest.json").read_text(encoding="utf-8"))
    assert {t["sheet"] for t in manifest["tiles"]} >= expected and result["TILES_WRITTEN"] == len(manifest["tiles"])
    assert result["ORTHO_FOLDER"] == str(tmp_path / "out" / "ortho") and result["DEM"].endswith("dem_5186.tif")
    assert manifest["drawn_from"]["buildings"]["source"] == buildings
    assert result["BUILDINGS_DRAWN"] == manifest["counts"]["buildings"] > 400
    assert result["ROADS_DRAWN"] == manifest["counts"]["roads"] > 30 and result["BUILDINGS_WRITTEN"] == 0
    assert manifest["area"]["study_area"]["code"] == "수서동"


@pytest.mark.parametrize("extra,message", [
    ({"BUILDING_COUNT": 500}, "number of buildings applies to the synthetic city only"),
    ({"BUILDINGS": None, "DISTRICT_CODE": "수서동"}, "apply only when drawing from a given building or road layer"),
    ({"BUILDINGS": None, "WHOLE_EXTENT": True}, "apply only when drawing from a given building or road layer"),
])
def test_parameters_of_the_other_mode_are_refused(run_algorithm, suseo_buildings, tmp_path, extra, message):
    parameters = {"BUILDINGS": str(suseo_buildings), "OUTPUT": str(tmp_path / "out"), **extra}
    with pytest.raises(QgsProcessingException, match=message):
        run_algorithm("wit:generatesample", {k: v for k, v in parameters.items() if v is not None})
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
