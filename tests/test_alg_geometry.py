"""The geometry algorithms through Processing, on the generated sample and the real Gangnam data."""
from __future__ import annotations

import pytest
from qgis.core import QgsProcessingException, QgsVectorLayer

from wit_plugin.sample import SampleConfig, generate_sample

pytestmark = pytest.mark.qgis_facing


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return generate_sample(tmp_path_factory.mktemp("sample"),
                           SampleConfig(radius_m=300.0, seed=5, ortho_pixel_size=4.0))


def test_prepare_vectors_on_the_sample(tmp_path, sample, run_algorithm):
    result = run_algorithm("wit:preparevectors", {
        "BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads), "DISTRICTS": str(sample.districts),
        "RADIUS": 250.0, "OUTPUT": str(tmp_path / "prepared.gpkg")})
    buildings = QgsVectorLayer(result["BUILDINGS_OUT"], "b", "ogr")
    roads = QgsVectorLayer(result["ROADS_OUT"], "r", "ogr")
    assert buildings.isValid() and roads.isValid()
    assert buildings.crs().authid() == "EPSG:5186"
    assert 50 < buildings.featureCount() == result["BUILDING_COUNT"] < sample.counts["buildings"]
    assert all(f.geometry().isGeosValid() for f in buildings.getFeatures())
    names = {f["BULD_NM"] for f in buildings.getFeatures() if f["BULD_NM"]}
    assert any("아파트" in n or "빌딩" in n for n in names), names
    assert all(f["wit_id"].startswith("BLD_") for f in buildings.getFeatures())
    assert roads.featureCount() > 0
    assert (tmp_path / "prepared_stats.csv").exists() or result["STATS"]


def test_prepare_real_gangnam_roads_by_district_code(tmp_path, shared_dir, run_algorithm):
    data = shared_dir / "data" / "juso_gangnam_11680_2019"
    result = run_algorithm("wit:preparevectors", {
        "ROADS": str(data / "TL_SPRD_MANAGE.shp"), "DISTRICTS": str(data / "TL_SCCO_EMD.shp"),
        "DISTRICT_CODE": "11680115", "OUTPUT": str(tmp_path / "suseo.gpkg")})
    districts = QgsVectorLayer(result["DISTRICTS_OUT"], "d", "ogr")
    assert [f["EMD_KOR_NM"] for f in districts.getFeatures()] == ["수서동"]
    roads = QgsVectorLayer(result["ROADS_OUT"], "r", "ogr")
    assert roads.featureCount() > 5
    assert "광평로" in {f["RN"] for f in roads.getFeatures()}


def test_unknown_district_code_is_a_clear_error(tmp_path, shared_dir, run_algorithm):
    data = shared_dir / "data" / "juso_gangnam_11680_2019"
    with pytest.raises(QgsProcessingException,
                       match="neither a code nor a name in TL_SCCO_EMD.shp; it has 11680101 역삼동"):
        run_algorithm("wit:preparevectors", {
            "DISTRICTS": str(data / "TL_SCCO_EMD.shp"), "DISTRICT_CODE": "99999999",
            "OUTPUT": str(tmp_path / "x.gpkg")})
    assert not (tmp_path / "x.gpkg").exists()
