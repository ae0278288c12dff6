"""End to end through scripts/qgis-process, as a batch user runs the plugin headless."""
from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
from conftest import ROOT
from osgeo import gdal, ogr, osr

pytestmark = pytest.mark.qgis_facing


def qgis_process(*args: str, profile) -> dict:
    env = dict(os.environ, WIT_QGIS_PROFILE=str(profile))
    result = subprocess.run([str(ROOT / "scripts" / "qgis-process"), "--json", *args],
                            capture_output=True, text=True, env=env, timeout=600)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    return json.loads(result.stdout[result.stdout.index("{"):])


@pytest.fixture(scope="module")
def profile(tmp_path_factory):
    return tmp_path_factory.mktemp("qgis-profile")


def test_list_shows_the_wit_provider(profile):
    env = dict(os.environ, WIT_QGIS_PROFILE=str(profile))
    listing = subprocess.run([str(ROOT / "scripts" / "qgis-process"), "list"], capture_output=True,
                             text=True, env=env, timeout=300).stdout
    assert "WIT City Model" in listing
    for algorithm in ("wit:generatesample", "wit:georeferencemapsheets", "wit:mergerasters"):
        assert algorithm in listing


def test_generate_sample_then_georeference_headless(tmp_path, profile):
    sample = qgis_process("run", "wit:generatesample", "--RADIUS=300", "--SEED=3",
                          "--ORTHO_PIXEL_SIZE=4", f"--OUTPUT={tmp_path / 'sample'}", profile=profile)
    results = sample["results"]
    assert results["BUILDINGS_WRITTEN"] > 100
    buildings = gdal.OpenEx(results["BUILDINGS"], open_options=["ENCODING=CP949"])
    layer = buildings.GetLayer()
    assert layer.GetFeatureCount() == results["BUILDINGS_WRITTEN"]
    assert layer.GetSpatialRef().FindMatches()[0][0].GetAuthorityCode(None) == "5179"
    names = {f.GetField("BULD_NM") for f in layer if f.GetField("BULD_NM")}
    assert any(name.endswith("아파트") for name in names), sorted(names)[:5]
    assert results["TILES_WRITTEN"] >= 1

    geo = qgis_process("run", "wit:georeferencemapsheets", f"--INPUT={results['ORTHO_FOLDER']}",
                       f"--OUTPUT={tmp_path / 'geo'}", f"--OUTPUT_INDEX={tmp_path / 'index.gpkg'}",
                       profile=profile)["results"]
    assert geo["GEOREFERENCED"] == results["TILES_WRITTEN"] and geo["SKIPPED"] == geo["FAILED"] == 0
    manifest = json.loads((tmp_path / "sample" / "sample_manifest.json").read_text(encoding="utf-8"))
    for tile in manifest["tiles"]:
        ds = gdal.Open(str(tmp_path / "geo" / f"{tile['sheet']}.tif"))
        x0, dx, _, y0, _, dy = ds.GetGeoTransform()
        xmin, ymin, xmax, ymax = tile["envelope_5186"]
        assert (x0, y0) == pytest.approx((xmin, ymax), abs=0.001)
        assert (x0 + dx * ds.RasterXSize, y0 + dy * ds.RasterYSize) == pytest.approx((xmax, ymin), abs=0.001)
    index = ogr.Open(str(tmp_path / "index.gpkg"))  # keep the dataset alive while its layer is used
    assert index.GetLayer().GetFeatureCount() == results["TILES_WRITTEN"]


def test_raster_inputs_get_no_aux_xml_beside_them_headless(tmp_path, profile, shared_dir):
    """qgis_process loads a raster parameter (and computes its statistics) before the algorithm runs:
    the real Seoul DEM, merged headless, leaves its folder exactly as it was."""
    import shutil

    folder = tmp_path / "inputs"
    folder.mkdir()
    dem = folder / "seoul_dem.tif"
    shutil.copy(shared_dir / "data" / "dem_seoul_90m_5186" / "seoul_dem.tif", dem)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    qgis_process("run", "wit:mergerasters", f"--INPUT={dem}", f"--OUTPUT={tmp_path / 'm.tif'}", profile=profile)
    assert (tmp_path / "m.tif").is_file()
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before  # no seoul_dem.tif.aux.xml


def test_bad_input_fails_with_a_message_and_exit_code(tmp_path, profile):
    env = dict(os.environ, WIT_QGIS_PROFILE=str(profile))
    result = subprocess.run([str(ROOT / "scripts" / "qgis-process"), "run", "wit:generatesample",
                             "--CENTER=2.35,48.85 [EPSG:4326]", f"--OUTPUT={tmp_path / 'paris'}"],
                            capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode != 0
    assert "outside Korea" in result.stdout + result.stderr
    assert "Traceback" not in result.stdout + result.stderr


def test_an_output_over_its_input_fails_headless_and_leaves_the_input_intact(tmp_path, profile):
    """Nothing lost, end to end: exit code non-zero, the message printed, the shapefile untouched."""
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds = ogr.GetDriverByName("ESRI Shapefile").CreateDataSource(str(tmp_path / "buildings.shp"))
    layer = ds.CreateLayer("buildings", srs, ogr.wkbPolygon)
    feature = ogr.Feature(layer.GetLayerDefn())
    feature.SetGeometry(ogr.CreateGeometryFromWkt("POLYGON((0 0,10 0,10 10,0 10,0 0))"))
    layer.CreateFeature(feature)
    del layer, ds
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    env = dict(os.environ, WIT_QGIS_PROFILE=str(profile))
    result = subprocess.run([str(ROOT / "scripts" / "qgis-process"), "run", "wit:preparevectors",
                             f"--BUILDINGS={tmp_path / 'buildings.shp'}", f"--OUTPUT={tmp_path / 'buildings.dbf'}"],
                            capture_output=True, text=True, env=env, timeout=600)
    assert result.returncode != 0
    assert ("would overwrite the input 'Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)' "
            f"({tmp_path / 'buildings.shp'})") in result.stdout + result.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_georeference_without_the_footprint_index(tmp_path, profile):
    """OUTPUT_INDEX is optional: qgis_process 3.22 used to stop with "mandatory parameters were not
    specified"; now the sheets are written and no index is."""
    sources = tmp_path / "ngii"
    sources.mkdir()
    gdal.GetDriverByName("GTiff").Create(str(sources / "(B060)정사영상_2022_37709005.tif"), 40, 50, 3).FlushCache()
    results = qgis_process("run", "wit:georeferencemapsheets", f"--INPUT={sources}", f"--OUTPUT={tmp_path / 'geo'}",
                           profile=profile)["results"]
    assert (results["GEOREFERENCED"], results["SKIPPED"], results["FAILED"]) == (1, 0, 0)
    assert "OUTPUT_INDEX" not in results or not results["OUTPUT_INDEX"]
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == [
        "(B060)정사영상_2022_37709005.tif", "37709005.tif"]


def test_sample_drawn_from_real_roads_then_the_whole_chain_headless(tmp_path, profile, shared_dir, suseo_buildings):
    """500 m around Suseo: tiles and DEM drawn from the real Gangnam roads and footprints, then
    wit:citymodel on them with those roads: the coverage check passes and the whole model is valid."""
    from conftest import juso_roads
    from test_sample_given import snapshot

    roads = juso_roads(shared_dir)
    districts = roads.with_name("TL_SCCO_EMD.shp")
    before = snapshot(roads, suseo_buildings)
    sample = qgis_process("run", "wit:generatesample", f"--BUILDINGS={suseo_buildings}", f"--ROADS={roads}",
                          "--RADIUS=500", "--ORTHO_PIXEL_SIZE=1", f"--OUTPUT={tmp_path / 'sample'}",
                          profile=profile)["results"]
    assert sample["TILES_WRITTEN"] == 2 and sample["BUILDINGS_DRAWN"] > 400 and sample["ROADS_DRAWN"] > 50
    model = qgis_process("run", "wit:citymodel", f"--ORTHO_INPUT={sample['ORTHO_FOLDER']}", f"--DEM={sample['DEM']}",
                         f"--BUILDINGS={sample['BUILDINGS']}", f"--ROADS={sample['ROADS']}", f"--DISTRICTS={districts}",
                         "--RADIUS=500", "--MAX_EDGE=20", f"--OUTPUT={tmp_path / 'model'}", profile=profile)["results"]
    assert model["VALID"] is True and model["ERROR_COUNT"] == 0 and model["UNTEXTURED"] == 0
    assert model["BUILDINGS_WRITTEN"] > 400
    assert snapshot(roads, suseo_buildings) == before


def test_validate_without_an_html_report_writes_a_temporary_one(tmp_path, profile, shared_dir):
    """OUTPUT is optional: batch users only want VALID; the report then goes to a temporary file, never beside the
    input."""
    source = tmp_path / "in" / "LocalCRS_CityGML3.gml"
    source.parent.mkdir()
    source.write_bytes((shared_dir / "schemas" / "examples" / source.name).read_bytes())
    results = qgis_process("run", "wit:validatecitygml", f"--INPUT={source}", profile=profile)["results"]
    assert results["VALID"] is True and results["ERROR_COUNT"] == 0
    report = Path(results["OUTPUT"])  # in QGIS's temporary folder, which qgis_process empties when it ends
    assert report.name == "validation_report.html" and "processing" in report.parent.parent.name
    assert os.listdir(source.parent) == [source.name]
