"""Nothing lost: no algorithm writes over one of its inputs, and bad inputs are refused
up front with one message that names the problem; every input file stays byte-identical and no
output (nor a partial one) is left behind."""
from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pyproj
import pytest
from osgeo import gdal, ogr, osr
from qgis.core import QgsProcessingException

from wit_plugin.infra import step_layers

pytestmark = pytest.mark.qgis_facing

ORIGIN = (209000.0, 543000.0)
SQUARE = "POLYGON((209002 543002,209010 543002,209010 543010,209002 543010,209002 543002))"


def _srs(epsg: int = 5186) -> osr.SpatialReference:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    return srs


def raster(path: Path, bands: int = 1, epsg: int | None = 5186, size: int = 40) -> str:
    ds = gdal.GetDriverByName("GTiff").Create(str(path), size, size, bands, gdal.GDT_Byte)
    ds.SetGeoTransform((ORIGIN[0] - 10, 1.0, 0, ORIGIN[1] + size - 10, 0, -1.0))
    if epsg:
        ds.SetProjection(_srs(epsg).ExportToWkt())
    for band in range(bands):
        ds.GetRasterBand(band + 1).WriteArray(np.full((size, size), 50 * (band + 1), np.uint8))
    ds = None
    return str(path)


def vector(path: Path, name: str, wkts: list[str], geometry=ogr.wkbPolygon, fields: dict | None = None,
           driver: str = "GPKG", rows: list[dict] | None = None) -> str:
    """A layer (appended to ``path`` when it exists, GeoPackage) with one feature per WKT."""
    drv = ogr.GetDriverByName(driver)
    ds = drv.Open(str(path), 1) if path.exists() and driver == "GPKG" else drv.CreateDataSource(str(path))
    layer = ds.CreateLayer(name, _srs(), geometry)
    for field, kind in (fields or {}).items():
        layer.CreateField(ogr.FieldDefn(field, kind))
    for k, wkt in enumerate(wkts):
        feature = ogr.Feature(layer.GetLayerDefn())
        for field, value in ((rows or [{}] * len(wkts))[k]).items():
            feature.SetField(field, value)
        feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
        layer.CreateFeature(feature)
    del layer, ds
    return str(path) if driver != "GPKG" else f"{path}|layername={name}"


@pytest.fixture
def data(tmp_path):
    """One input of every kind the algorithms read, in its own folder."""
    folder = tmp_path / "inputs"
    (folder / "ortho").mkdir(parents=True)
    (folder / "textures").mkdir()
    (folder / "textures" / "roof.jpg").write_bytes(b"\xff\xd8 not really a jpeg")
    gpkg = folder / "model.gpkg"
    lines = "LINESTRING(209000 543005,209030 543005)"
    return {
        "folder": folder,
        "rgb": raster(folder / "rgb.tif", 3),
        "dem": raster(folder / "dem.tif", 1),
        "sheet": raster(folder / "ortho" / "37709005.tif", 3),
        "buildings_shp": vector(folder / "buildings.shp", "buildings", [SQUARE], driver="ESRI Shapefile",
                                fields={"BD_MGT_SN": ogr.OFTString}, rows=[{"BD_MGT_SN": "1"}]),
        "roads_shp": vector(folder / "roads.shp", "roads", [lines], ogr.wkbLineString, driver="ESRI Shapefile"),
        "buildings": vector(gpkg, "buildings", [SQUARE], fields={"wit_id": ogr.OFTString}),
        "area": vector(gpkg, "study_area", [("POLYGON((209000 543000,209030 543000,209030 543030,"
                                             "209000 543030,209000 543000))")]),
        "lod1": vector(gpkg, "lod1_faces", [SQUARE], ogr.wkbPolygon25D, fields={"wit_id": ogr.OFTString}),
        "tin": vector(gpkg, "tin", [SQUARE], ogr.wkbPolygon25D),
        "points": vector(folder / "points.gpkg", "points", ["POINT(209005 543005)"], ogr.wkbPoint),
        "gml": str(_write(folder / "model.gml", b"<CityModel/>")),
        "store": str(_write(folder / "store.gpkg", Path(gpkg.parent / "model.gpkg").read_bytes())),
        "textures": str(folder / "textures"),
    }


def _write(path: Path, content: bytes) -> Path:
    path.write_bytes(content)
    return path


#: per algorithm: parameters with every input given (outputs are added by the tests)
INPUTS = {
    "wit:georeferencemapsheets": lambda d: {"INPUT": [str(Path(d["sheet"]).parent)]},
    "wit:mergerasters": lambda d: {"INPUT": [d["rgb"], d["sheet"]]},
    "wit:mergetiles": lambda d: {"INPUT": [d["rgb"], d["sheet"]]},  # its first id, deprecated: the same guards
    "wit:preparevectors": lambda d: {"BUILDINGS": d["buildings_shp"], "ROADS": d["roads_shp"],
                                     "DISTRICTS": d["area"], "AREA_LAYER": d["area"]},
    "wit:triangulateterrain": lambda d: {"DEM": d["dem"], "AREA": d["area"], "BUILDINGS": d["buildings"]},
    "wit:extrudebuildings": lambda d: {"BUILDINGS": d["buildings"], "DEM": d["dem"]},
    "wit:wittexture": lambda d: {"ORTHO": d["rgb"], "LOD1": d["lod1"], "TIN": d["tin"]},
    "wit:writecitygml": lambda d: {"LOD1": d["lod1"], "TIN": d["tin"], "TEXTURES": d["textures"]},
    "wit:export3dtiles": lambda d: {"LOD1": d["lod1"], "TIN": d["tin"], "TEXTURES": d["textures"]},
    "wit:exportcityjson": lambda d: {"LOD1": d["lod1"], "TIN": d["tin"], "TEXTURES": d["textures"]},
    "wit:validatecitygml": lambda d: {"INPUT": [d["gml"]]},
    "wit:buildcolorstore": lambda d: {"INPUT": d["rgb"]},
    "wit:querycolorstore": lambda d: {"STORE": d["store"], "POINTS": d["points"],
                                      "EXTENT": "209000,209010,543000,543010 [EPSG:5186]"},
    "wit:qualitymetrics": lambda d: {"MODEL": d["gml"], "SOURCE_BUILDINGS": d["buildings"], "ORTHO": d["rgb"]},
    "wit:citymodel": lambda d: {"ORTHO_INPUT": [d["sheet"]], "DEM": d["dem"], "BUILDINGS": d["buildings_shp"],
                                "ROADS": d["roads_shp"]},
    "wit:citymodeltiles": lambda d: {"ORTHO_INPUT": [d["sheet"]], "DEM": d["dem"], "BUILDINGS": d["buildings_shp"],
                                     "ROADS": d["roads_shp"]},
    "wit:generatesample": lambda d: {"BUILDINGS": d["buildings_shp"], "ROADS": d["roads_shp"],
                                     "DISTRICTS": d["area"], "AREA_LAYER": d["area"]},
}

#: per algorithm: its destination parameters (name → "file" or "folder")
DESTINATIONS = {
    "wit:georeferencemapsheets": {"OUTPUT": "folder", "OUTPUT_INDEX": "file"},
    "wit:mergerasters": {"OUTPUT": "file"},
    "wit:mergetiles": {"OUTPUT": "file"},
    "wit:preparevectors": {"OUTPUT": "file"},
    "wit:triangulateterrain": {"OUTPUT": "file"},
    "wit:extrudebuildings": {"OUTPUT": "file"},
    "wit:wittexture": {"OUTPUT": "folder"},
    "wit:writecitygml": {"OUTPUT": "file"},
    "wit:export3dtiles": {"OUTPUT": "folder"},
    "wit:exportcityjson": {"OUTPUT": "file"},
    "wit:validatecitygml": {"OUTPUT": "file", "OUTPUT_CSV": "file", "OUTPUT_TABLE": "file"},
    "wit:buildcolorstore": {"OUTPUT": "file"},
    "wit:querycolorstore": {"OUTPUT": "file", "OUTPUT_PATCH": "file"},
    "wit:qualitymetrics": {"OUTPUT": "file", "OUTPUT_HTML": "file"},
    "wit:citymodel": {"OUTPUT": "folder"},
    "wit:citymodeltiles": {"OUTPUT": "folder"},
    "wit:generatesample": {"OUTPUT": "folder"},
}


def _input_files(parameters: dict) -> list[str]:
    values = []
    for value in parameters.values():
        values += value if isinstance(value, list) else [value]
    files = []
    for value in values:
        path = Path(str(value).split("|")[0])
        if path.is_file():
            files.append(str(path))
        elif path.is_dir():
            files += [str(p) for p in sorted(path.iterdir()) if p.is_file()]
    return sorted(set(files))


def snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` with the hash of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_the_tables_cover_every_algorithm_and_destination(wit_provider):
    writers = {f"wit:{a.name()}": a for a in wit_provider.algorithms() if a.destinationParameterDefinitions()}
    assert set(DESTINATIONS) == set(INPUTS) == set(writers) - {"wit:citymodelmodel"}
    for key, algorithm in writers.items():
        if key in DESTINATIONS:
            assert {d.name() for d in algorithm.destinationParameterDefinitions()} == set(DESTINATIONS[key]), key


@pytest.mark.parametrize("algorithm,destination", [(a, d) for a, ds in DESTINATIONS.items() for d in ds])
def test_an_output_pointed_at_any_input_is_refused(algorithm, destination, data, tmp_path, run_algorithm):
    """Each destination pointed at each input file (a folder destination at the input's folder)."""
    files = _input_files(INPUTS[algorithm](data))
    assert files
    before = snapshot(data["folder"])
    for k, target in enumerate(map(Path, files)):
        parameters = INPUTS[algorithm](data)
        out = tmp_path / f"out{k}"
        out.mkdir()
        for name, kind in DESTINATIONS[algorithm].items():
            parameters[name] = str(out / name) if kind == "folder" else str(out / f"{name}.dat")
        parameters[destination] = str(target.parent if DESTINATIONS[algorithm][destination] == "folder" else target)
        folder = DESTINATIONS[algorithm][destination] == "folder"
        message = "holds the input" if folder else "would overwrite the input"
        with pytest.raises(QgsProcessingException, match=message) as error:
            run_algorithm(algorithm, parameters)
        assert "Traceback" not in str(error.value)
        assert snapshot(data["folder"]) == before, target
        assert [p for p in out.rglob("*") if p.is_file()] == []


@pytest.mark.parametrize("sidecar", [".dbf", ".shx", ".prj"])
def test_an_output_over_a_shapefile_sidecar_is_refused(sidecar, data, tmp_path, run_algorithm):
    """A GeoPackage named like the input's .dbf would replace the shapefile's attributes."""
    before = snapshot(data["folder"])
    output = str(Path(data["buildings_shp"]).with_suffix(sidecar))
    with pytest.raises(QgsProcessingException, match=r"would overwrite the input .*buildings\.shp"):
        run_algorithm("wit:preparevectors", {"BUILDINGS": data["buildings_shp"], "OUTPUT": output})
    assert snapshot(data["folder"]) == before


def test_links_to_an_input_are_refused(data, tmp_path, run_algorithm):
    """A symbolic link and a hard link to the input GeoPackage are the input."""
    gpkg = Path(data["buildings"].split("|")[0])
    (tmp_path / "link.gpkg").symlink_to(gpkg)
    (tmp_path / "hard").mkdir()
    (tmp_path / "hard" / "copy.gpkg").hardlink_to(gpkg)
    before = snapshot(data["folder"])
    for output in (tmp_path / "link.gpkg", tmp_path / "hard" / "copy.gpkg"):
        with pytest.raises(QgsProcessingException, match="would overwrite the input"):
            run_algorithm("wit:extrudebuildings", {"BUILDINGS": data["buildings"], "DEM": data["dem"],
                                                   "OUTPUT": str(output)})
    assert snapshot(data["folder"]) == before


def test_atomic_writes_refuse_to_replace_a_protected_input(tmp_path):
    """The core-level guard: whoever calls, a write inside ``protect`` never replaces an input."""
    from wit_plugin.infra.errors import InputError
    from wit_plugin.infra.io.fileio import atomic_file, atomic_files, protect, refuse_overlap

    source = tmp_path / "a.shp"
    source.write_bytes(b"shape")
    (tmp_path / "a.dbf").write_bytes(b"table")
    with protect([f"{source}|layername=a"]):
        for target in (source, tmp_path / "a.dbf", tmp_path / "a.shx"):
            with pytest.raises(InputError, match="would overwrite the input"), atomic_file(target) as tmp:
                tmp.write_bytes(b"new")
        with pytest.raises(InputError, match="would overwrite the input"), atomic_files([tmp_path / "a.dbf"]) as tmp:
            (tmp / "a.dbf").write_bytes(b"new")
        with atomic_file(tmp_path / "b.gpkg") as tmp:  # another name is fine
            tmp.write_bytes(b"new")
    with atomic_file(tmp_path / "a.dbf") as tmp:  # outside the run, the file is no input any more
        tmp.write_bytes(b"new")
    assert source.read_bytes() == b"shape"
    with pytest.raises(InputError, match=r"output folder .* holds the input .*a\.shp"):
        refuse_overlap([(tmp_path, True)], [str(source)])
    refuse_overlap([(tmp_path / "sub", True)], [str(source)])


# -- bad inputs refused up front -----------------------------------------------------------------

def _refused(run_algorithm, algorithm: str, parameters: dict, message: str, data: dict, out: Path) -> str:
    """Run, expect one message matching ``message``; inputs untouched and nothing in ``out``."""
    before = snapshot(data["folder"])
    out.mkdir(exist_ok=True)
    with pytest.raises(QgsProcessingException, match=message) as error:
        run_algorithm(algorithm, parameters)
    assert "Traceback" not in str(error.value)
    assert snapshot(data["folder"]) == before
    assert [p for p in out.rglob("*") if p.is_file()] == []
    return str(error.value)


@pytest.mark.parametrize("algorithm,parameter", [
    ("wit:preparevectors", "BUILDINGS"), ("wit:preparevectors", "ROADS"), ("wit:extrudebuildings", "BUILDINGS"),
    ("wit:triangulateterrain", "AREA"), ("wit:writecitygml", "LOD1"), ("wit:qualitymetrics", "SOURCE_BUILDINGS"),
    ("wit:citymodel", "BUILDINGS")])
def test_a_layer_of_the_wrong_geometry_type_is_refused(algorithm, parameter, data, tmp_path, run_algorithm):
    """Points given as buildings or roads (centre lines or road polygons): one message, naming both types."""
    parameters = INPUTS[algorithm](data)
    wrong = data["points"]
    parameters[parameter] = wrong
    for name, kind in DESTINATIONS[algorithm].items():
        parameters[name] = str(tmp_path / "out" / (name if kind == "folder" else f"{name}.dat"))
    message = _refused(run_algorithm, algorithm, parameters, "expected", data, tmp_path / "out")
    expected = "lines or polygons" if parameter == "ROADS" else "polygons"
    assert "has points" in message and f"expected {expected}." in message, message
    assert Path(wrong.split("|")[0]).name in message


@pytest.fixture
def floors(data):
    """Buildings with floor counts, as wit:preparevectors writes them."""
    second = "POLYGON((209015 543015,209025 543015,209025 543025,209015 543025,209015 543015))"
    return vector(data["folder"] / "floors.gpkg", "buildings", [SQUARE, second],
                  fields={"wit_id": ogr.OFTString, "GRO_FLO_CO": ogr.OFTInteger},
                  rows=[{"wit_id": "BLD_1", "GRO_FLO_CO": 0}, {"wit_id": "BLD_2", "GRO_FLO_CO": 0}])


@pytest.mark.parametrize("expression,message", [
    ('"GRO_FLO_CO" *', "has a syntax error"),
    ('"HEIGHT_M" * 2', r"uses the field\(s\) HEIGHT_M, which the layer"),
    ('"wit_id" + 1', "fails on the first feature"),
])
def test_a_bad_height_expression_is_refused(expression, message, data, floors, tmp_path, run_algorithm):
    """Not silently the default height for every building."""
    text = _refused(run_algorithm, "wit:extrudebuildings", {
        "BUILDINGS": floors, "DEM": data["dem"], "HEIGHT_EXPRESSION": expression,
        "OUTPUT": str(tmp_path / "out" / "lod1.gpkg")}, message, data, tmp_path / "out")
    assert expression in text and "Height expression" in text


def test_a_good_height_expression_is_used(data, floors, tmp_path, run_algorithm):
    result = run_algorithm("wit:extrudebuildings", {
        "BUILDINGS": floors, "DEM": data["dem"], "HEIGHT_EXPRESSION": "length(\"wit_id\") * 2",
        "OUTPUT": str(tmp_path / "lod1.gpkg")})
    ds = ogr.Open(result["OUTPUT"])
    heights = {f["wit_id"]: (f[step_layers.HEIGHT], f[step_layers.HEIGHT_SOURCE]) for f in ds.GetLayer("lod1_faces")}
    assert heights == {"BLD_1": (10.0, "expression"), "BLD_2": (10.0, "expression")}


def _shapefile(folder: Path) -> Path:
    """A copy of the buildings shapefile (all its files) in ``folder``."""
    folder.mkdir()
    for part in Path(folder.parent / "inputs").glob("buildings.*"):
        shutil.copy(part, folder / part.name)
    return folder / "buildings.shp"


@pytest.mark.parametrize("damage,message", [
    ("no_shx", r"buildings\.shp has no \.shx beside it"),
    ("no_dbf", r"buildings\.shp has no \.dbf beside it"),
    ("empty_shp", r"buildings\.shp is empty \(0 bytes\)"),
    ("empty_dbf", r"buildings\.dbf beside buildings\.shp is empty"),
    ("missing", r"buildings\.shp does not exist"),
    ("not_gpkg", r"not a GeoPackage \(no SQLite header\)"),
    ("no_layer", r"model\.gpkg has no layer 'houses'; it has: buildings, lod1_faces, study_area, tin\."),
])
def test_a_damaged_vector_file_is_named_with_its_problem(damage, message, data, tmp_path, run_algorithm):
    """Not QGIS's generic "Incorrect parameter value for BUILDINGS"."""
    shp = _shapefile(tmp_path / "damaged")
    source = str(shp)
    if damage == "no_shx":
        shp.with_suffix(".shx").unlink()
    elif damage == "no_dbf":
        shp.with_suffix(".dbf").unlink()
    elif damage == "empty_shp":
        shp.write_bytes(b"")
    elif damage == "empty_dbf":
        shp.with_suffix(".dbf").write_bytes(b"")
    elif damage == "missing":
        source = str(tmp_path / "elsewhere" / "buildings.shp")
    elif damage == "no_layer":
        source = data["buildings"].replace("layername=buildings", "layername=houses")
    else:
        source = str(_write(tmp_path / "damaged" / "buildings.gpkg", b"<html>not found</html>"))
    text = _refused(run_algorithm, "wit:preparevectors", {
        "BUILDINGS": source, "OUTPUT": str(tmp_path / "out" / "prepared.gpkg")}, message, data, tmp_path / "out")
    assert "Incorrect parameter value" not in text


def run_logged(algorithm: str, parameters: dict) -> tuple[dict, list[str]]:
    """Run through Processing; return the results and the warnings pushed to the feedback."""
    import processing
    from qgis.core import QgsProcessingFeedback

    class Warnings(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.warnings = []

        def pushWarning(self, warning):  # noqa: N802
            self.warnings.append(warning)
            super().pushWarning(warning)

    feedback = Warnings()
    return processing.run(algorithm, parameters, feedback=feedback), feedback.warnings


def _table(gpkg: str, name: str) -> list[dict]:
    ds = ogr.Open(gpkg)
    return [f.items() for f in ds.GetLayer(name)]


SQUARE_B = "POLYGON((209020 543002,209028 543002,209028 543010,209020 543010,209020 543002))"
SQUARE_C = "POLYGON((209040 543002,209048 543002,209048 543010,209040 543010,209040 543002))"
CENTRE = "209020,543010 [EPSG:5186]"


def test_exact_duplicate_buildings_are_dropped_and_counted(data, tmp_path, wit_provider):
    """Three stacked copies of building 1 (one starting its ring elsewhere) become one; building 2
    drawn twice with different footprints stays two buildings with unique ids."""
    shifted = "POLYGON((209010 543002,209010 543010,209002 543010,209002 543002,209010 543002))"
    buildings = vector(data["folder"] / "stacked.gpkg", "stacked", [SQUARE, SQUARE, shifted, SQUARE_B, SQUARE_C],
                       fields={"BD_MGT_SN": ogr.OFTString},
                       rows=[{"BD_MGT_SN": i} for i in ("1", "1", "1", "2", "2")])
    result, warnings = run_logged("wit:preparevectors", {"BUILDINGS": buildings, "CENTER": CENTRE, "RADIUS": 200,
                                                         "OUTPUT": str(tmp_path / "prepared.gpkg")})
    ids = sorted(row["wit_id"] for row in _table(result["OUTPUT"], "buildings"))
    assert ids == ["BLD_1", "BLD_2", "BLD_2_2"]
    stats = {row["layer"]: row for row in _table(result["OUTPUT"], "stats")}["buildings"]
    assert (stats["features_in"], stats["features_out"], stats["dropped_duplicate"]) == (5, 3, 2)
    dropped = _table(result["OUTPUT"], "dropped")
    assert sorted((row["source_fid"], row["wit_id"], row["reason"]) for row in dropped) == [
        (2, "BLD_1", "duplicate"), (3, "BLD_1", "duplicate")]
    assert any("dropped 2 feature(s): 2 duplicate" in w for w in warnings), warnings
    assert any("1 feature(s) share their source id" in w for w in warnings), warnings


INF, NAN = float("inf"), float("nan")


def _ring_layer(path: Path, rings: list[list[tuple[float, float]]]) -> str:
    """Polygons from coordinate lists (WKT cannot carry inf or NaN)."""
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("buildings", _srs(), ogr.wkbPolygon)
    layer.CreateField(ogr.FieldDefn("BD_MGT_SN", ogr.OFTString))
    for k, coords in enumerate(rings):
        ring = ogr.Geometry(ogr.wkbLinearRing)
        for x, y in coords:
            ring.AddPoint_2D(x, y)
        polygon = ogr.Geometry(ogr.wkbPolygon)
        polygon.AddGeometry(ring)
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField(0, str(k + 1))
        feature.SetGeometry(polygon)
        layer.CreateFeature(feature)
    gdal.PushErrorHandler("CPLQuietErrorHandler")  # GeoPackage cannot store an infinite extent
    del layer, ds
    gdal.PopErrorHandler()
    return f"{path}|layername=buildings"


def _broken(x0: float, bad: float) -> list[tuple[float, float]]:
    return [(x0, 543002), (bad, 543002), (x0 + 8, 543010), (x0, 543010), (x0, 543002)]


def test_features_with_non_finite_coordinates_are_dropped_and_counted(data, tmp_path, wit_provider):
    good = [(209002, 543002), (209010, 543002), (209010, 543010), (209002, 543010), (209002, 543002)]
    buildings = _ring_layer(data["folder"] / "inf.gpkg",
                            [good, _broken(209020, INF), _broken(209040, -INF), _broken(209060, NAN)])
    result, warnings = run_logged("wit:preparevectors", {"BUILDINGS": buildings, "CENTER": CENTRE, "RADIUS": 200,
                                                         "OUTPUT": str(tmp_path / "prepared.gpkg")})
    assert [row["wit_id"] for row in _table(result["OUTPUT"], "buildings")] == ["BLD_1"]
    stats = {row["layer"]: row for row in _table(result["OUTPUT"], "stats")}["buildings"]
    assert (stats["features_in"], stats["features_out"], stats["dropped_non_finite"]) == (4, 1, 3)
    assert sorted(row["wit_id"] for row in _table(result["OUTPUT"], "dropped")) == ["BLD_2", "BLD_3", "BLD_4"]
    assert any("dropped 3 feature(s): 3 non_finite" in w for w in warnings), warnings


def test_a_run_that_keeps_no_feature_fails_with_the_reasons(data, tmp_path, run_algorithm):
    buildings = _ring_layer(data["folder"] / "allbad.gpkg", [_broken(209020, INF), _broken(209040, NAN)])
    message = _refused(run_algorithm, "wit:preparevectors", {
        "BUILDINGS": buildings, "CENTER": CENTRE, "RADIUS": 200, "OUTPUT": str(tmp_path / "out" / "p.gpkg")},
        "No feature could be kept", data, tmp_path / "out")
    assert "buildings: 2 read, 0 outside the study area, dropped 2 feature(s): 2 non_finite" in message


def test_extrude_that_makes_no_solid_fails(data, tmp_path, run_algorithm):
    flat = vector(data["folder"] / "flat.gpkg", "buildings",
                  ["POLYGON((209002 543002,209010 543002,209006 543002,209002 543002))"],
                  fields={"wit_id": ogr.OFTString}, rows=[{"wit_id": "BLD_1"}])
    _refused(run_algorithm, "wit:extrudebuildings", {"BUILDINGS": flat, "DEM": data["dem"],
                                                    "OUTPUT": str(tmp_path / "out" / "lod1.gpkg")},
             r"No LoD1 solid could be made: the 1 footprint\(s\) of .*flat\.gpkg", data, tmp_path / "out")


def test_writecitygml_with_no_building_fails(data, tmp_path, run_algorithm):
    empty = vector(data["folder"] / "empty.gpkg", "lod1_faces", [], ogr.wkbPolygon25D,
                   fields={"wit_id": ogr.OFTString, step_layers.FACE_NUMBER: ogr.OFTInteger,
                           step_layers.FACE_TYPE: ogr.OFTString})
    _refused(run_algorithm, "wit:writecitygml", {"LOD1": empty, "OUTPUT": str(tmp_path / "out" / "model.gml")},
             "has no building faces", data, tmp_path / "out")


def test_qualitymetrics_with_nothing_matched_fails(data, floors, tmp_path, run_algorithm):
    lod1 = run_algorithm("wit:extrudebuildings", {"BUILDINGS": floors, "DEM": data["dem"],
                                                  "OUTPUT": str(data["folder"] / "lod1.gpkg")})["LOD1"]
    others = vector(data["folder"] / "others.gpkg", "buildings", [SQUARE], fields={"wit_id": ogr.OFTString},
                    rows=[{"wit_id": "BLD_9"}])
    _refused(run_algorithm, "wit:qualitymetrics", {"MODEL": lod1.split("|")[0], "SOURCE_BUILDINGS": others,
                                                   "OUTPUT": str(tmp_path / "out" / "m.csv")},
             r"Nothing could be measured: no building of the model \(2\) matches one of the 1 source", data,
             tmp_path / "out")


def _dem(path: Path, epsg: int | None) -> str:
    if epsg != 4326:
        return raster(path, 1, epsg)
    ds = gdal.GetDriverByName("GTiff").Create(str(path), 10, 10, 1, gdal.GDT_Float32)
    ds.SetGeoTransform((127.0, 0.01, 0, 37.6, 0, -0.01))
    ds.SetProjection(_srs(4326).ExportToWkt())
    ds = None
    return str(path)


@pytest.mark.parametrize("algorithm", ["wit:extrudebuildings", "wit:triangulateterrain"])
def test_a_dem_in_another_crs_is_judged_in_its_own_crs(algorithm, data, tmp_path, run_algorithm):
    """A DEM in EPSG:4326 is reprojected, never refused for its CRS: this one stops at 127.1°E,
    150 m west of the buildings, and the message says so in its own degrees."""
    dem = _dem(data["folder"] / "dem4326.tif", 4326)
    parameters = {"BUILDINGS": data["buildings"], "DEM": dem, "OUTPUT": str(tmp_path / "out" / "o.gpkg")}
    if algorithm == "wit:triangulateterrain":
        parameters["AREA"] = data["area"]
    message = _refused(run_algorithm, algorithm, parameters, "does not cover the area needed", data, tmp_path / "out")
    assert "The DEM dem4326.tif (extent x 127.000000–127.100000, y 37.500000–37.600000 in EPSG:4326)" in message
    assert "in EPSG:5186, x 127.10" in message and "° to the east" in message and "mismatch" not in message


@pytest.mark.parametrize("algorithm", ["wit:extrudebuildings", "wit:triangulateterrain"])
def test_a_dem_without_crs_is_assumed_in_the_layers_crs_with_a_warning(algorithm, data, tmp_path, wit_provider):
    dem = _dem(data["folder"] / "nocrs.tif", None)
    parameters = {"BUILDINGS": data["buildings"], "DEM": dem, "OUTPUT": str(tmp_path / "o.gpkg")}
    if algorithm == "wit:triangulateterrain":
        parameters["AREA"] = data["area"]
    result, warnings = run_logged(algorithm, parameters)
    assert Path(result["OUTPUT"]).is_file()
    # EPSG:5186's name as this PROJ's EPSG database spells it ("Korea 2000 / …", "KGD2002 / …" in newer ones)
    name = pyproj.CRS("EPSG:5186").name
    assert name.endswith(" / Central Belt 2010")
    assert any("nocrs.tif has no coordinate reference system: it is assumed to be in the layers' CRS, "
               f"{name} (EPSG:5186)" in w for w in warnings), warnings


@pytest.mark.parametrize("declaration", ["ldid", "cpg"])
def test_cp949_text_under_a_wrong_code_page_is_read_as_cp949(declaration, shared_dir, data, tmp_path, wit_provider):
    """The real Gangnam legal dongs, their .dbf declaring ISO-8859-1 (LDID 0x57) or with a .cpg saying so."""
    folder = tmp_path / "emd"
    folder.mkdir()
    for part in (shared_dir / "data" / "juso_gangnam_11680_2019").glob("TL_SCCO_EMD.*"):
        shutil.copyfile(part, folder / part.name)
    dbf = folder / "TL_SCCO_EMD.dbf"
    if declaration == "ldid":
        content = bytearray(dbf.read_bytes())
        content[29] = 0x57
        dbf.write_bytes(bytes(content))
    else:
        (folder / "TL_SCCO_EMD.cpg").write_text("ISO-8859-1")
    before = snapshot(folder)
    result, warnings = run_logged("wit:preparevectors", {
        "DISTRICTS": str(folder / "TL_SCCO_EMD.shp"), "DISTRICT_CODE": "11680101",
        "OUTPUT": str(tmp_path / "prepared.gpkg")})
    names = [row["EMD_KOR_NM"] for row in _table(result["OUTPUT"], "districts")]
    assert "역삼동" in names, names
    assert any("but its text is Korean (CP949): read as CP949" in w for w in warnings), warnings
    assert snapshot(folder) == before
    forced = run_algorithm_encoding(folder, tmp_path)
    assert "역삼동" not in forced and any("»" in n or "¿" in n for n in forced), forced


def run_algorithm_encoding(folder: Path, tmp_path: Path) -> list[str]:
    """The ENCODING parameter still wins: ISO-8859-1 as asked gives the mojibake."""
    import processing

    result = processing.run("wit:preparevectors", {
        "DISTRICTS": str(folder / "TL_SCCO_EMD.shp"), "DISTRICT_CODE": "11680101", "ENCODING": "ISO-8859-1",
        "OUTPUT": str(tmp_path / "forced.gpkg")})
    return [row["EMD_KOR_NM"] for row in _table(result["OUTPUT"], "districts")]


def test_writecitygml_refuses_to_copy_textures_onto_their_source(data, tmp_path, run_algorithm):
    """The images go to <name>_textures beside the .gml: that folder must not be the texture input."""
    textures = data["folder"] / "city_textures"
    shutil.copytree(data["textures"], textures)
    _refused(run_algorithm, "wit:writecitygml", {"LOD1": data["lod1"], "TEXTURES": str(textures),
                                                 "OUTPUT": str(data["folder"] / "city.gml")},
             r"Texture images beside the CityGML file.*holds the input 'Texture folder", data,
             tmp_path / "out")
    assert not (data["folder"] / "city.gml").exists()


def test_terrain_leaves_out_non_finite_constraints_with_a_warning(data, tmp_path, wit_provider):
    good = [(209002, 543002), (209010, 543002), (209010, 543010), (209002, 543010), (209002, 543002)]
    buildings = _ring_layer(data["folder"] / "inf.gpkg", [good, _broken(209012, INF), _broken(209020, NAN)])
    result, warnings = run_logged("wit:triangulateterrain", {
        "DEM": data["dem"], "AREA": data["area"], "BUILDINGS": buildings, "OUTPUT": str(tmp_path / "t.gpkg")})
    assert result["TRIANGLES"] > 0
    assert any("buildings: 2 feature(s) with infinite or NaN coordinates left out" in w for w in warnings), warnings
    assert any(w.startswith("2 building/road polygon(s) dropped") for w in warnings), warnings
