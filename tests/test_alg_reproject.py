"""A DEM and orthoimage sheets in another CRS than the model's, as users run the
algorithms: wit:triangulateterrain, wit:extrudebuildings and wit:citymodel through Processing in the
QGIS process, wit:citymodeltiles headless through qgis_process on several tiles. The sample's DEM and
sheets are in EPSG:5186 (the sheets as GeoTIFFs that carry that georeference), the model in EPSG:5187."""
from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pyproj
import pytest
from conftest import ROOT
from lxml import etree
from osgeo import gdal, ogr

from wit_plugin.infra import step_layers
from wit_plugin.infra.dem import Dem
from wit_plugin.mosaic.georef import georeference_sheets
from wit_plugin.sample import SampleConfig, generate_sample

SUSEO = (127.1020, 37.4876)
SPLIT = (127.1005, 37.4876)  # beside Suseo, on the 127.100°E line between two 1:1,000 sheets
GML = "{http://www.opengis.net/gml/3.2}"


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    folder = tmp_path_factory.mktemp("belts")
    base = generate_sample(folder / "sample", SampleConfig(radius_m=320.0, seed=6, ortho_pixel_size=2.0))
    sheets = georeference_sheets([str(p) for p in base.ortho_tiles], folder / "sheets_5186", "EPSG:5186")
    dem_4326 = folder / "dem_4326.tif"  # the same relief as a geographic DEM
    gdal.Warp(str(dem_4326), str(base.dem), dstSRS="EPSG:4326", resampleAlg="bilinear", srcNodata=-9999,
              dstNodata=-9999)
    return {"base": base, "sheets": [r.output for r in sheets], "dem_4326": str(dem_4326), "folder": folder}


@pytest.fixture(scope="module")
def prepared(sample, tmp_path_factory, qgis_processing):
    """The sample's layers prepared in EPSG:5187 (through Processing)."""
    import processing
    from conftest import ensure_wit_provider

    ensure_wit_provider()
    base = sample["base"]
    return processing.run("wit:preparevectors", {
        "BUILDINGS": str(base.buildings), "ROADS": str(base.roads), "DISTRICTS": str(base.districts),
        "CENTER": f"{SUSEO[0]},{SUSEO[1]} [EPSG:4326]", "RADIUS": 180.0, "TARGET_CRS": "EPSG:5187",
        "OUTPUT": str(tmp_path_factory.mktemp("prepared") / "prepared.gpkg")})


def run_logged(algorithm: str, parameters: dict) -> tuple[dict, list[str]]:
    """Run through Processing; the results and every message (info and warning) the algorithm gave."""
    import processing
    from qgis.core import QgsProcessingFeedback

    class Messages(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.messages = []

        def pushInfo(self, info):  # noqa: N802
            self.messages.append(info)
            super().pushInfo(info)

        def pushWarning(self, warning):  # noqa: N802
            self.messages.append(warning)
            super().pushWarning(warning)

    feedback = Messages()
    return processing.run(algorithm, parameters, feedback=feedback), feedback.messages


def _vertices(path: str, layer: str) -> np.ndarray:
    ds = ogr.Open(path)
    rings = [f.GetGeometryRef().GetGeometryRef(0).GetPoints() for f in ds.GetLayer(layer)]
    return np.unique(np.round(np.array([p for ring in rings for p in ring]), 6), axis=0)


def _on_the_dem(xyz: np.ndarray, dem: str) -> None:
    """Every vertex on the DEM reprojected to EPSG:5187, to the millimetre."""
    box = (*xyz[:, :2].min(axis=0), *xyz[:, :2].max(axis=0))
    np.testing.assert_allclose(xyz[:, 2], Dem.open(dem, box, crs="EPSG:5187").sample(xyz[:, 0], xyz[:, 1]),
                               rtol=0, atol=1e-3)


def test_triangulateterrain_with_a_dem_in_5186_and_layers_in_5187(sample, prepared, tmp_path, wit_provider):
    dem = str(sample["base"].dem)
    result, messages = run_logged("wit:triangulateterrain", {
        "DEM": dem, "AREA": f"{prepared['OUTPUT']}|layername={step_layers.STUDY_AREA}",
        "BUILDINGS": prepared["BUILDINGS_OUT"], "ROADS": prepared["ROADS_OUT"], "MAX_EDGE": 10.0,
        "OUTPUT": str(tmp_path / "tin.gpkg")})
    assert result["TRIANGLES"] > 1000
    xyz = _vertices(str(tmp_path / "tin.gpkg"), step_layers.TIN_LAYER)
    assert pyproj.CRS(ogr.Open(str(tmp_path / "tin.gpkg")).GetLayer(0).GetSpatialRef().ExportToWkt()).to_epsg() == 5187
    _on_the_dem(xyz, dem)
    assert not any("CRS mismatch" in m for m in messages)
    # alone, the step tells what the chain tells (infra.dem.reprojection), once
    assert [m for m in messages if "reprojected on the fly" in m] == [
        f"The DEM {os.path.basename(dem)} is in Korea 2000 / Central Belt 2010 (EPSG:5186): it is reprojected on "
        "the fly to Korea 2000 / East Belt 2010 (EPSG:5187) (bilinear, cells of 5 m)."], messages


def test_extrudebuildings_with_a_geographic_dem(sample, prepared, tmp_path, wit_provider):
    dem = sample["dem_4326"]
    result, messages = run_logged("wit:extrudebuildings", {
        "BUILDINGS": prepared["BUILDINGS_OUT"], "DEM": dem, "OUTPUT": str(tmp_path / "lod1.gpkg")})
    assert result["SOLIDS"] > 30
    ds = ogr.Open(str(tmp_path / "lod1.gpkg"))
    grounds = {}
    for feature in ds.GetLayer(step_layers.LOD1_LAYER):
        if feature.GetField(step_layers.FACE_TYPE) == "ground":
            grounds.setdefault(feature.GetField(step_layers.WIT_ID), []).append(
                np.array(feature.GetGeometryRef().GetGeometryRef(0).GetPoints()))
    rings = [np.concatenate(parts) for parts in grounds.values()]
    everything = np.concatenate(rings)
    reprojected = Dem.open(dem, (*everything[:, :2].min(axis=0), *everything[:, :2].max(axis=0)), crs="EPSG:5187")
    for ring in rings:  # the base: the lowest point of the reprojected DEM over the footprint, so none floats
        base = ring[0, 2]
        assert (ring[:, 2] == base).all()
        assert base <= reprojected.sample(ring[:, 0], ring[:, 1]).min() + 1e-3
        assert base >= reprojected.values.min() - 1e-3
    assert not any("mismatch" in m for m in messages), messages
    assert sum(m.startswith("The DEM dem_4326.tif is in WGS 84 (EPSG:4326): it is reprojected on the fly to Korea "
                            "2000 / East Belt 2010 (EPSG:5187)") for m in messages) == 1, messages


@pytest.mark.parametrize("algorithm", ["wit:extrudebuildings", "wit:triangulateterrain"])
def test_a_dem_in_another_crs_that_misses_the_area_is_refused_naming_it(algorithm, sample, prepared, tmp_path,
                                                                        wit_provider):
    from qgis.core import QgsProcessingException

    west = tmp_path / "inputs" / "dem_west_4326.tif"  # the geographic DEM cut 100 cells short of its east
    west.parent.mkdir()
    full = gdal.Open(sample["dem_4326"])
    gdal.Translate(str(west), full, srcWin=[0, 0, full.RasterXSize // 2, full.RasterYSize])
    before = sorted(p.name for p in west.parent.iterdir())
    parameters = {"BUILDINGS": prepared["BUILDINGS_OUT"], "DEM": str(west), "OUTPUT": str(tmp_path / "out.gpkg")}
    if algorithm == "wit:triangulateterrain":
        parameters["AREA"] = f"{prepared['OUTPUT']}|layername={step_layers.STUDY_AREA}"
    with pytest.raises(QgsProcessingException) as caught:
        run_logged(algorithm, parameters)
    message = str(caught.value)
    del caught
    assert "The DEM dem_west_4326.tif (extent x 127." in message and " in EPSG:4326) does not cover the area needed" \
        in message and " in EPSG:5187, x 127." in message and "° to the east. Use a DEM that covers" in message, message
    assert not (tmp_path / "out.gpkg").exists()
    assert sorted(p.name for p in west.parent.iterdir()) == before


def test_citymodel_in_5187_from_a_dem_and_sheets_in_5186(sample, tmp_path, wit_provider):
    base = sample["base"]
    result, messages = run_logged("wit:citymodel", {
        "ORTHO_INPUT": sample["sheets"], "DEM": str(base.dem), "BUILDINGS": str(base.buildings),
        "ROADS": str(base.roads), "DISTRICTS": str(base.districts), "CENTER": f"{SUSEO[0]},{SUSEO[1]} [EPSG:4326]",
        "RADIUS": 150.0, "TARGET_CRS": "EPSG:5187", "MAX_EDGE": 10.0, "TILES3D": False,
        "OUTPUT": str(tmp_path / "city")})
    assert result["VALID"] is True and result["ERROR_COUNT"] == 0 and result["BUILDINGS_WRITTEN"] > 20
    envelope = etree.parse(result["GML"]).find(f".//{GML}Envelope")
    assert envelope.get("srsName") == "EPSG:5187"
    # coverage, terrain and extrude each read the DEM and say so (infra.dem.reprojection); the run says it once
    assert sum("reprojected on the fly to Korea 2000 / East Belt 2010 (EPSG:5187)" in m for m in messages) == 1
    assert any("carries its own georeference in EPSG:5186: reprojected to EPSG:5187" in m for m in messages)
    _on_the_dem(_vertices(str(tmp_path / "city" / "tin.gpkg"), step_layers.TIN_LAYER), str(base.dem))


def test_citymodeltiles_headless_in_5187_from_a_dem_in_5186(sample, tmp_path):
    """Several 1:1,000 tiles through qgis_process, the DEM and the sheets in EPSG:5186: none fails."""
    base = sample["base"]
    parameters = {"ORTHO_INPUT": sample["sheets"], "DEM": str(base.dem), "BUILDINGS": str(base.buildings),
                  "ROADS": str(base.roads), "DISTRICTS": str(base.districts),
                  "CENTER": f"{SPLIT[0]},{SPLIT[1]} [EPSG:4326]", "RADIUS": 160.0, "TARGET_CRS": "EPSG:5187",
                  "MAX_EDGE": 15.0, "TILE_SCALE": 1, "WORKERS": 2, "TILES3D": False,
                  "OUTPUT": str(tmp_path / "tiles")}
    args = [str(ROOT / "scripts" / "qgis-process"), "--json", "run", "wit:citymodeltiles"]
    for name, value in parameters.items():
        args += [f"--{name}={item}" for item in (value if isinstance(value, list) else [value])]
    env = dict(os.environ, WIT_QGIS_PROFILE=str(tmp_path / "profile"))
    inputs = sample["folder"]
    before = {p: p.read_bytes() for p in inputs.rglob("*") if p.is_file()}
    run = subprocess.run(args, capture_output=True, text=True, env=env, timeout=900, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    results = json.loads(run.stdout[run.stdout.index("{"):])["results"]
    assert {p: p.read_bytes() for p in inputs.rglob("*") if p.is_file()} == before  # no .aux.xml, nothing beside
    assert results["TILES_DONE"] >= 2 and results["TILES_FAILED"] == 0, results  # buildings on both sides
    gmls = sorted((tmp_path / "tiles" / "tiles").glob("*/model.gml"))
    assert len(gmls) == results["TILES_DONE"] + results["TILES_EMPTY"]
    for gml in gmls:
        tree = etree.parse(str(gml))
        assert tree.find(f".//{GML}Envelope").get("srsName") == "EPSG:5187"
        triangles = np.array([np.array(p.text.split(), float).reshape(-1, 3)[:3]
                              for p in tree.iterfind(f".//{GML}Triangle//{GML}posList")]).reshape(-1, 3)
        _on_the_dem(np.unique(triangles, axis=0), str(base.dem))
