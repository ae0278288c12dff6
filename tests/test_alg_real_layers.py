"""Real national layers through Processing and through scripts/qgis-process.

Every algorithm that reads vectors takes the NGII digital map as NGII ships it (Korean field names in
CP949, an EUC-KR ``.cpg`` or none, EPSG:5187) with QGIS's own GDAL settings, without a crash; every
step takes any layer of its geometry type: a shapefile of another name, a GeoPackage of two layers
with ``|layername=``, a layer of the project; a layer without the fields a step needs is refused with
the step that makes them. Through qgis_process a crash is an exit code, not a dead test run.
"""
from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import ngii
import numpy as np
import pytest
from conftest import ROOT, ensure_wit_provider, qgis_gui_profile
from lxml import etree
from osgeo import gdal, ogr

from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
from wit_plugin.colorstore import build_color_store
from wit_plugin.infra import step_layers
from wit_plugin.prepare.area import StudyArea
from wit_plugin.sample import GivenLayers, SampleConfig, draw_from_layers

pytestmark = pytest.mark.slow

TARGET = "EPSG:5187"
AREA_WKT = "POLYGON((217870 361780,218260 361780,218260 361940,217870 361940,217870 361780))"
NS = {"bldg": "http://www.opengis.net/citygml/building/3.0", "tran": "http://www.opengis.net/citygml/transportation/3.0",
      "con": "http://www.opengis.net/citygml/construction/3.0", "gml": "http://www.opengis.net/gml/3.2",
      "gen": "http://www.opengis.net/citygml/generics/3.0"}


def _copy_layers(target: Path, layers: list[tuple[str, str, str]]) -> None:
    """Copy (source file, source layer, new name) into the GeoPackage ``target``."""
    out = ogr.GetDriverByName("GPKG").CreateDataSource(str(target))
    for path, name, new_name in layers:
        source = ogr.Open(path)
        out.CopyLayer(source.GetLayerByName(name), new_name)
        source = None
    out = None


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> dict:
    """The NGII inputs, the orthoimage sheets drawn from them, and every step's output (one core chain
    run), repacked under other names: what a user brings to each algorithm."""
    folder = tmp_path_factory.mktemp("ngii-scene")
    raw = folder / "수치지도"
    inputs = {"buildings": ngii.buildings(raw), "roads": ngii.road_polygons(raw), "lines": ngii.centre_lines(raw),
              "area": ngii.area(raw), "dem": ngii.dem(folder / "dem_5187.tif"),
              "dem_5186": ngii.dem(folder / "dem_5186.tif", epsg=5186)}
    given = GivenLayers(buildings=str(inputs["buildings"]), roads=str(inputs["roads"]))
    sample = draw_from_layers(folder / "sample", given, SampleConfig(ortho_pixel_size=2.0, with_dem=False))
    assert sample.sheets == ["35901058", "35901059"]
    inputs["ortho"] = str(sample.ortho_tiles[0].parent)
    chain = folder / "chain"
    run_city_model(ChainInputs([inputs["ortho"]], str(inputs["dem"]), str(inputs["buildings"]), str(inputs["roads"])),
                   ChainOptions(area=StudyArea.polygon(AREA_WKT, TARGET), target_crs=TARGET, max_edge=20.0,
                                keep_work=True, tiles3d=False, metrics=False), chain)
    work = chain / "work"
    steps = folder / "steps"
    steps.mkdir()
    _copy_layers(steps / "faces.gpkg", [(str(chain / "lod1.gpkg"), step_layers.LOD1_LAYER, "notes"),
                                        (str(chain / "lod1.gpkg"), step_layers.LOD1_LAYER, "faces")])
    _copy_layers(steps / "mesh.gpkg", [(str(chain / "tin.gpkg"), step_layers.TIN_LAYER, "mesh")])
    _copy_layers(steps / "도로.gpkg", [(str(work / "prepared.gpkg"), step_layers.STUDY_AREA, "구역"),
                                     (str(work / "prepared.gpkg"), step_layers.PREPARED_ROADS, "도로")])
    _copy_layers(steps / "index.gpkg", [(str(work / "prepared.gpkg"), step_layers.STUDY_AREA, "area"),
                                        (str(work / "sheets.gpkg"), "footprints", "sheets")])
    with ngii.shapefile_text("CP949"):
        gdal.VectorTranslate(str(steps / "footprints.shp"), f"{work / 'prepared.gpkg'}",
                             layers=[step_layers.PREPARED_BUILDINGS], layerCreationOptions=["ENCODING=CP949"])
    assert "층수".encode("cp949") in (steps / "footprints.dbf").read_bytes()
    points = ngii.write_shapefile(steps / "지점.shp", ogr.wkbPoint, [("이름", ogr.OFTString, 20)],
                                  [{"이름": "첨성대"}, {"이름": "똠방각하"}],
                                  ["POINT(217910 361810)", "POINT(218120 361870)"], cpg="CP949")
    store = steps / "store.gpkg"
    build_color_store(str(work / "ortho.tif"), str(store))
    return {**{k: str(v) for k, v in inputs.items()}, "folder": folder, "work": work, "chain": chain,
            "lod1": f"{steps / 'faces.gpkg'}|layername=faces", "tin": str(steps / "mesh.gpkg"),
            "roads_prepared": f"{steps / '도로.gpkg'}|layername=도로", "footprints": str(steps / "footprints.shp"),
            "sheets": f"{steps / 'index.gpkg'}|layername=sheets", "textures": str(work / "textures"),
            "mosaic": str(work / "ortho.tif"), "points": str(points), "store": str(store)}


def _buildings_of(gml: Path) -> dict[str, float]:
    """gml:id → con:height of every bldg:Building."""
    tree = etree.parse(str(gml))
    return {b.get("{http://www.opengis.net/gml/3.2}id"): float(b.find(".//con:Height/con:value", NS).text)
            for b in tree.iterfind(".//bldg:Building", NS)}


def _roads_of(gml: Path) -> int:
    return len(etree.parse(str(gml)).findall(".//tran:Road", NS))


def _ids_and_floors(source: str) -> dict[str, float]:
    """wit_id → 층수 × 3 m of the prepared buildings (wit_ids are the NGII UFIDs)."""
    return {f"BLD_{ufid}": 3.0 * floors for ufid, floors in
            zip([r["UFID"] for r in _rows(source)], [r["층수"] for r in _rows(source)])}


def _rows(source: str) -> list[dict]:
    path, _, name = source.partition("|layername=")
    ds = gdal.OpenEx(path, gdal.OF_VECTOR, open_options=["ENCODING=CP949"] if path.endswith(".shp") else [])
    layer = ds.GetLayerByName(name) if name else ds.GetLayer(0)
    return [feature.items() for feature in layer]


# -- the cases: per algorithm, its parameters (inputs as a user gives them) and the check of its results --

def _prepare(s, out):
    return {"BUILDINGS": s["buildings"], "ROADS": s["roads"], "AREA_LAYER": s["area"], "TARGET_CRS": TARGET,
            "OUTPUT": str(out / "prepared.gpkg")}


def _check_prepare(r, s, out):
    assert r["BUILDING_COUNT"] == 12
    roads = _rows(r["ROADS_OUT"])
    assert [row[step_layers.ROAD_WIDTH_SOURCE] for row in roads] == ["surface", "surface"]
    assert [row["층수"] for row in _rows(r["BUILDINGS_OUT"])] == ngii.FLOORS
    assert [row["명칭"] for row in _rows(r["BUILDINGS_OUT"])][:2] == ["똠방각하", "햇살아파트"]


def _extrude(s, out):
    return {"BUILDINGS": s["buildings"], "DEM": s["dem"], "OUTPUT": str(out / "lod1.gpkg")}


def _check_extrude(r, s, out):
    assert (r["SOLIDS"], r["DEFAULT_HEIGHTS"]) == (12, 0)
    heights = {row["UFID"]: (row[step_layers.HEIGHT], row[step_layers.HEIGHT_RULE]) for row in _rows(r["LOD1"])}
    assert heights == {row["UFID"]: (3.0 * row["층수"], "층수 × 3 m") for row in _rows(s["buildings"])}


def _terrain(s, out):
    return {"DEM": s["dem"], "AREA": s["area"], "BUILDINGS": s["buildings"], "ROADS": s["roads"], "MAX_EDGE": 20.0,
            "OUTPUT": str(out / "tin.gpkg")}


def _check_terrain(r, s, out):
    surfaces = [row[step_layers.TIN_SURFACE] for row in _rows(r["TIN"])]
    assert r["TRIANGLES"] == len(surfaces) > 100
    assert set(surfaces) == {"terrain", "road"}  # footprints are holes: the buildings stand on them


def _texture(s, out):
    return {"ORTHO": s["mosaic"], "LOD1": s["lod1"], "TIN": s["tin"], "OUTPUT": str(out / "textures")}


def _check_texture(r, s, out):
    roofs = [row for row in _rows(str(out / "textures" / step_layers.TEXCOORD_FILE))
             if row[step_layers.TEX_TARGET] == "roof"]
    assert len(roofs) == 12 and r["TEXTURED_SURFACES"] > 100


def _citygml(s, out):
    return {"LOD1": s["lod1"], "TIN": s["tin"], "ROADS": s["roads_prepared"], "TEXTURES": s["textures"],
            "OUTPUT": str(out / "model.gml")}


def _check_citygml(r, s, out):
    assert (r["BUILDINGS"], r["ROADS_WRITTEN"]) == (12, 2)
    assert _buildings_of(out / "model.gml") == _ids_and_floors(s["footprints"])


def _cityjson(s, out):
    return {"LOD1": s["lod1"], "TIN": s["tin"], "ROADS": s["roads_prepared"], "TEXTURES": s["textures"],
            "OUTPUT": str(out / "model.city.json")}


def _check_cityjson(r, s, out):
    """The same buildings as the CityGML writer's, with their heights, from the national layer's 층수 in CP949."""
    assert (r["BUILDINGS"], r["ROADS_WRITTEN"]) == (12, 2)
    model = json.loads((out / "model.city.json").read_text(encoding="utf-8"))
    heights = {i: o["attributes"]["height"] for i, o in model["CityObjects"].items() if o["type"] == "Building"}
    assert heights == pytest.approx(_ids_and_floors(s["footprints"]))


def _tiles3d(s, out):
    return {"LOD1": s["lod1"], "TIN": s["tin"], "TEXTURES": s["textures"], "OUTPUT": str(out / "3dtiles")}


def _check_tiles3d(r, s, out):
    assert r["BUILDINGS"] == 12 and Path(r["TILESET"]).is_file()


def _metrics(s, out):
    return {"MODEL": str(s["chain"] / "model.gml"), "SOURCE_BUILDINGS": s["footprints"], "ORTHO": s["mosaic"],
            "MOSAIC": s["mosaic"], "FOOTPRINTS": s["sheets"], "OUTPUT": str(out / "metrics.csv")}


def _check_metrics(r, s, out):
    assert r["SSI_MEAN"] == pytest.approx(1.0, abs=0.01) and r["PLACEMENT_MEAN_ERROR"] < 0.05
    assert r["SEAM_STEP"] is not None and np.isfinite(r["SEAM_STEP"])


def _sample(s, out):
    return {"BUILDINGS": s["buildings"], "ROADS": s["roads"], "WHOLE_EXTENT": True, "ORTHO_PIXEL_SIZE": 4.0,
            "WITH_DEM": False, "OUTPUT": str(out / "sample")}


def _check_sample(r, s, out):
    assert (r["TILES_WRITTEN"], r["BUILDINGS_DRAWN"], r["ROADS_DRAWN"]) == (2, 12, 2)


def _colours(s, out):
    return {"STORE": s["store"], "POINTS": s["points"], "OUTPUT": str(out / "coloured.gpkg")}


def _check_colours(r, s, out):
    rows = _rows(str(out / "coloured.gpkg"))
    assert r["POINTS_COLOURED"] == 2 and [row["이름"] for row in rows] == ["첨성대", "똠방각하"]
    assert all(0 <= row[band] <= 255 for row in rows for band in "RGB")


def _citymodel(s, out):
    return {"ORTHO_INPUT": [s["ortho"]], "DEM": s["dem"], "BUILDINGS": s["buildings"], "ROADS": s["roads"],
            "AREA_LAYER": s["area"], "TARGET_CRS": TARGET, "MAX_EDGE": 20.0, "TILES3D": False,
            "OUTPUT": str(out / "model")}


def _check_citymodel(r, s, out):
    assert (r["VALID"], r["ERROR_COUNT"], r["BUILDINGS_WRITTEN"], r["DEFAULT_HEIGHTS"]) == (True, 0, 12, 0)
    gml = Path(r["GML"])
    assert _roads_of(gml) == 2
    assert _buildings_of(gml) == _ids_and_floors(s["footprints"])


CASES = {
    "wit:preparevectors": (_prepare, _check_prepare),
    "wit:extrudebuildings": (_extrude, _check_extrude),
    "wit:triangulateterrain": (_terrain, _check_terrain),
    "wit:wittexture": (_texture, _check_texture),
    "wit:writecitygml": (_citygml, _check_citygml),
    "wit:exportcityjson": (_cityjson, _check_cityjson),
    "wit:export3dtiles": (_tiles3d, _check_tiles3d),
    "wit:qualitymetrics": (_metrics, _check_metrics),
    "wit:generatesample": (_sample, _check_sample),
    "wit:querycolorstore": (_colours, _check_colours),
    "wit:citymodel": (_citymodel, _check_citymodel),
}


def test_the_cases_cover_every_algorithm_that_reads_vectors(wit_provider):
    """Every algorithm with a vector-layer input is here (wit:citymodeltiles: the end-to-end test below; the
    shipped model wit:citymodelmodel passes its layers to these algorithms)."""
    reading = {f"wit:{a.name()}" for a in wit_provider.algorithms()
               if any(d.type() in ("vector", "source") for d in a.parameterDefinitions())}
    assert reading == set(CASES) | {"wit:citymodeltiles", "wit:citymodelmodel"}


@pytest.mark.parametrize("algorithm", list(CASES))
def test_real_layers_through_processing(algorithm, scene, tmp_path, run_algorithm):
    build, check = CASES[algorithm]
    before = {p: p.read_bytes() for p in (scene["folder"] / "수치지도").iterdir()}
    check(run_algorithm(algorithm, build(scene, tmp_path)), scene, tmp_path)
    assert {p: p.read_bytes() for p in (scene["folder"] / "수치지도").iterdir()} == before  # read only


def qgis_process(parameters: dict, algorithm: str, profile: Path) -> dict:
    env = dict(os.environ, WIT_QGIS_PROFILE=str(profile))
    args = [str(ROOT / "scripts" / "qgis-process"), "--json", "run", algorithm]
    for name, value in parameters.items():
        for item in value if isinstance(value, list) else [value]:
            args.append(f"--{name}={item}")
    result = subprocess.run(args, capture_output=True, text=True, env=env, timeout=900, check=False)
    assert result.returncode == 0, f"exit {result.returncode}: " + result.stdout[-3000:] + result.stderr[-3000:]
    return json.loads(result.stdout[result.stdout.index("{"):])


@pytest.fixture(scope="module")
def profile(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("qgis-profile")


@pytest.mark.parametrize("algorithm", list(CASES))
def test_real_layers_through_qgis_process(algorithm, scene, tmp_path, profile):
    build, check = CASES[algorithm]
    report = qgis_process(build(scene, tmp_path), algorithm, profile)
    check(report["results"], scene, tmp_path)


def _ngii_tiled(scene: dict, out: Path) -> dict:
    """NGII buildings and road polygons as shipped (EUC-KR .cpg, Korean field names,
    EPSG:5187), the DEM in EPSG:5186, the model in EPSG:5187, tiled on 1:5,000 sheets."""
    return {"ORTHO_INPUT": [scene["ortho"]], "DEM": scene["dem_5186"], "BUILDINGS": scene["buildings"],
            "ROADS": scene["roads"], "TARGET_CRS": TARGET, "ALL_BUILDINGS": True, "TILE_SCALE": 0,
            "WORKERS": 1, "MAX_EDGE": 20.0, "TILES3D": False, "OUTPUT": str(out)}


def _check_ngii_tiled(results: dict, log: str, scene: dict, out: Path) -> None:
    """No failed tile, roads in every tile, every building's height = 층수 × storey height."""
    assert (results["TILES_DONE"], results["TILES_FAILED"], results["TILES_EMPTY"]) == (2, 0, 0)
    assert results["BUILDINGS_WRITTEN"] == 12
    heights = {}
    for sheet in ("35901058", "35901059"):
        gml = out / "tiles" / sheet / "model.gml"
        assert _roads_of(gml) >= 1, sheet
        heights.update(_buildings_of(gml))
    assert heights == _ids_and_floors(scene["footprints"])
    assert "road polygon(s) of N3A_A0010000.shp are road surfaces as they are" in log


@pytest.mark.qgis_facing
def test_ngii_as_shipped_tiled_on_map_sheets_headless(scene, tmp_path, profile):
    """NGII layers as shipped, through qgis_process: no crash (a crash is an exit code here)."""
    out = tmp_path / "tiles"
    report = qgis_process(_ngii_tiled(scene, out), "wit:citymodeltiles", profile)
    _check_ngii_tiled(report["results"], json.dumps(report.get("log", ""), ensure_ascii=False), scene, out)


@pytest.mark.qgis_facing
def test_ngii_as_shipped_tiled_in_the_qgis_window(scene, tmp_path, xvfb_display):
    """The same case from the real QGIS window (under Xvfb), as a user runs it from the toolbox: the
    desktop's own GDAL settings (SHAPE_ENCODING=''), results loaded into the project; QGIS exits
    normally (a crash would close it: its exit status)."""
    out = tmp_path / "tiles"
    parameters = tmp_path / "parameters.json"
    parameters.write_text(json.dumps(_ngii_tiled(scene, out), ensure_ascii=False), encoding="utf-8")
    report = tmp_path / "gui.json"
    env = dict(os.environ, DISPLAY=xvfb_display, QT_QPA_PLATFORM="xcb",
               QGIS_CUSTOM_CONFIG_PATH=str(qgis_gui_profile(tmp_path / "profile")), WIT_GUI_ALG="wit:citymodeltiles",
               WIT_GUI_PARAMS=str(parameters), WIT_GUI_JSON=str(report))
    command = (f'source "{ROOT}/scripts/env.sh" && '
               f'exec qgis --nologo --noversioncheck --code "{ROOT}/scripts/gui_run.py"')
    run = subprocess.run(["bash", "-c", command], env=env, capture_output=True, text=True, timeout=900, check=False)
    assert report.exists(), f"QGIS exit {run.returncode}: {run.stdout[-2000:]}{run.stderr[-2000:]}"
    shown = json.loads(report.read_text(encoding="utf-8"))
    assert "error" not in shown, shown["error"]
    assert run.returncode == 0, run.stderr[-2000:]
    _check_ngii_tiled(shown["results"], "\n".join(shown["log"]), scene, out)
    index = [layer for layer in shown["layers"] if layer["provider"] == "ogr"]
    assert [(layer["valid"], layer["features"]) for layer in index] == [(True, 2)], shown["layers"]


def test_a_layer_of_the_project_filtered_or_in_memory(scene, tmp_path, run_algorithm):
    """A project layer: its filter is honoured (Processing copies what the core cannot open as it is)."""
    from qgis.core import QgsFeatureRequest, QgsProject, QgsVectorLayer

    ensure_wit_provider()
    filtered = QgsVectorLayer(scene["buildings"], "건물", "ogr")
    filtered.setSubsetString('"층수" > 3')
    memory = filtered.materialize(QgsFeatureRequest())
    QgsProject.instance().addMapLayers([filtered, memory])
    try:
        for layer in (filtered, memory):
            result = run_algorithm("wit:extrudebuildings", {"BUILDINGS": layer.id(), "DEM": scene["dem"],
                                                            "OUTPUT": str(tmp_path / f"{layer.id()}.gpkg")})
            assert (result["SOLIDS"], result["DEFAULT_HEIGHTS"]) == (sum(f > 3 for f in ngii.FLOORS), 0)
    finally:
        QgsProject.instance().removeMapLayers([filtered.id(), memory.id()])


def test_a_layer_without_the_fields_a_step_makes_names_that_step(scene, tmp_path, run_algorithm):
    from qgis.core import QgsProcessingException

    with pytest.raises(QgsProcessingException, match=r"Layer 'N3A_A0010000' in .*N3A_A0010000.shp lacks the field\(s\) "
                                                     r"wit_id of the prepared roads \(wit:preparevectors\)"):
        run_algorithm("wit:writecitygml", {"LOD1": scene["lod1"], "TIN": scene["tin"], "ROADS": scene["roads"],
                                           "OUTPUT": str(tmp_path / "model.gml")})
    assert not (tmp_path / "model.gml").exists()
