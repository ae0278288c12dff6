"""Test set-up: the core importable as ``wit_plugin``; the plugin importable as ``wit_citymodel``.

The checkout folder may have any name (CI clones into an arbitrary one), so the plugin package
is registered under its installed name from the repository root.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
os.environ.setdefault("PROJ_DATA", "/usr/share/proj")

from osgeo import gdal  # noqa: E402  (after PROJ_DATA: GDAL reads it when it loads)

_SESSION_GDAL_EXCEPTIONS = bool(gdal.GetUseExceptions())

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

if "wit_citymodel" not in sys.modules:
    _spec = importlib.util.spec_from_file_location(
        "wit_citymodel", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    _module = importlib.util.module_from_spec(_spec)
    sys.modules["wit_citymodel"] = _module
    _spec.loader.exec_module(_module)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The shared fixture data beside the checkout (present in CI)."""
    if not SHARED.is_dir():
        pytest.fail(f"{SHARED} is missing: the tests need ../shared beside the checkout")
    return SHARED


_KEEP_ALIVE: list = []


def ensure_wit_provider():
    """The ``wit`` provider registered in the test QGIS, as the plugin does it.

    Looked up on every use: a plugin test's unload() removes (and deletes) the provider.
    """
    from qgis.core import QgsApplication
    from wit_citymodel.processing_provider.provider import WitProvider

    registry = QgsApplication.processingRegistry()
    if registry.providerById("wit") is None:
        _KEEP_ALIVE.append(WitProvider())  # the Python side must outlive its registration
        registry.addProvider(_KEEP_ALIVE[-1])
    return registry.providerById("wit")


@pytest.fixture
def wit_provider(qgis_processing):
    return ensure_wit_provider()


@pytest.fixture
def run_algorithm(wit_provider):
    """Run a Processing algorithm like a user (processing.run) and return its results."""
    import processing

    def run(algorithm_id: str, parameters: dict) -> dict:
        return processing.run(algorithm_id, parameters)

    return run


@pytest.fixture
def cancel_after_checks():
    """A core Feedback factory: ``cancel_after_checks(n)`` answers "cancel" from its (n+1)-th check on."""
    from wit_plugin.feedback import Feedback

    class CancelAfter(Feedback):
        def __init__(self, checks: int):
            self.checks = checks

        def is_canceled(self) -> bool:
            self.checks -= 1
            return self.checks < 0

    return CancelAfter


def _exception_modules() -> list:
    """The GDAL modules whose exception state is one switch, in the order their handlers stack.

    GDAL ≥ 3.7: ``gdal.UseExceptions()`` switches every module at once. Before, each module pushes its
    own error handler (``UseExceptions``) and pops it (``DontUseExceptions``), only from the top of one
    shared stack: switching gdal alone fails once something (QGIS 3.40's own Python, a plugin) has
    turned ogr's or osr's on ("Cannot call gdal.DontUseExceptions() at that point since the stack of
    error handlers is: osr ogr gdal"). So gdal, ogr and osr are switched together, on in this order,
    off in the reverse.
    """
    from osgeo import gdal, ogr, osr

    return [gdal] if int(gdal.VersionInfo()) >= 3070000 else [gdal, ogr, osr]


def set_gdal_exceptions(on: bool) -> list:
    """Turn GDAL exceptions on or off in every module; the modules switched, for ``restore``."""
    modules = _exception_modules()
    changed = [m for m in (modules if on else modules[::-1]) if bool(m.GetUseExceptions()) != on]
    for module in changed:
        module.UseExceptions() if on else module.DontUseExceptions()
    return changed


def restore_gdal_exceptions(changed: list, on: bool) -> None:
    """Undo ``set_gdal_exceptions(on)`` that switched ``changed``, in the reverse order."""
    for module in changed[::-1]:
        module.DontUseExceptions() if on else module.UseExceptions()


@pytest.fixture(params=[False, True], ids=["gdal-exceptions-off", "gdal-exceptions-on"])
def gdal_exceptions(request):
    """Run with GDAL exceptions off (QGIS's default) and on (as some plugins and scripts set them)."""
    changed = set_gdal_exceptions(request.param)
    yield request.param
    restore_gdal_exceptions(changed, request.param)


@pytest.fixture(autouse=True)
def gdal_exceptions_as_found():
    """Each test starts with GDAL's exception state as the session started: QGIS's own Python code may
    switch it on for the whole process while a test runs (QGIS ≥ 3.40 does), which must not change
    what the next tests see (seen: gdal_merge then wrote nothing)."""
    yield
    set_gdal_exceptions(_SESSION_GDAL_EXCEPTIONS)


FOOTPRINT_WKT = "POLYGON((209002 543002,209010 543002,209010 543010,209002 543010,209002 543002))"


def write_polygons(path, name, fields=(), wkt=FOOTPRINT_WKT) -> str:
    """A one-polygon GeoPackage layer in EPSG:5186 (the test footprint by default); its layer source."""
    from osgeo import ogr, osr

    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(name, srs, ogr.wkbPolygon)
    for field in fields:
        layer.CreateField(ogr.FieldDefn(field, ogr.OFTString))
    feature = ogr.Feature(layer.GetLayerDefn())
    feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
    layer.CreateFeature(feature)
    del layer, ds
    return f"{path}|layername={name}"


@pytest.fixture(scope="module")
def real_rasters(tmp_path_factory, shared_dir, qgis_processing) -> dict:
    """Writable real rasters in one folder around the test footprint (209002–209010, 543002–543010):
    the USGS 15 cm orthophoto placed there in EPSG:5186 (383 × 232 px, stripped; the footprint lies
    in rows 99–152) and the Seoul 90 m DEM; beside them (other folder) the footprint and its LoD1."""
    import processing
    from osgeo import gdal

    ensure_wit_provider()
    rasters = tmp_path_factory.mktemp("rasters")
    ortho = str(rasters / "ortho.tif")
    source = shared_dir / "data" / "ortho_usgs_hro_15cm" / "201404_13SED190110_201404_0x1500m_CL_1.tif"
    gdal.Translate(ortho, str(source), outputSRS="EPSG:5186",
                   outputBounds=[208990.0, 542990.0 + 232 * 0.15, 208990.0 + 383 * 0.15, 542990.0])
    dem = rasters / "dem.tif"
    dem.write_bytes((shared_dir / "data" / "dem_seoul_90m_5186" / "seoul_dem.tif").read_bytes())
    vectors = tmp_path_factory.mktemp("vectors")
    footprints = write_polygons(vectors / "plain.gpkg", "buildings", ("wit_id",))
    lod1 = processing.run("wit:extrudebuildings", {"BUILDINGS": footprints, "DEM": str(dem),
                                                   "OUTPUT": str(vectors / "lod1.gpkg")})["OUTPUT"]
    return {"folder": rasters, "ortho": ortho, "dem": str(dem), "footprints": footprints, "lod1": lod1}


def juso_roads(shared: Path) -> Path:
    """The real Gangnam road centre lines (TL_SPRD_MANAGE 2019: CP949 without .cpg, EPSG:5179)."""
    return shared / "data" / "juso_gangnam_11680_2019" / "TL_SPRD_MANAGE.shp"


@pytest.fixture(scope="session")
def suseo_buildings(tmp_path_factory, shared_dir) -> Path:
    """Real-looking footprints around Suseo station that keep off the real roads, as an OpenStreetMap
    export (EPSG:4326; ``osm_id``, ``building``, ``building:levels``): the sample generator's buildings
    within 350 m, less those within 3 m of a real road surface (ROAD_BT / 2)."""
    import numpy as np
    import pyproj
    import shapely
    from osgeo import ogr, osr

    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.vector_io import read_layer
    from wit_plugin.vectors import road_widths, transform

    folder = tmp_path_factory.mktemp("suseo")
    synthetic = generate_sample(folder / "synthetic", SampleConfig(radius_m=350.0, with_ortho=False, with_dem=False))
    buildings = read_layer(synthetic.buildings)
    footprints = shapely.make_valid(buildings.geoms)
    roads = read_layer(juso_roads(shared_dir), bbox=shapely.total_bounds(footprints), bbox_crs=buildings.crs)
    widths, _ = road_widths(roads, 6.0)
    surface = shapely.union_all(shapely.buffer(roads.geoms, widths / 2 + 3.0))
    keep = np.flatnonzero(~shapely.intersects(footprints, surface) & (shapely.get_type_id(footprints) == 3))
    lonlat = transform(footprints[keep], buildings.crs, pyproj.CRS("EPSG:4326"))
    path = folder / "osm_buildings.gpkg"
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(4326)
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("buildings", srs, ogr.wkbPolygon)
    for name in ("osm_id", "building", "building:levels"):
        layer.CreateField(ogr.FieldDefn(name, ogr.OFTString))
    for k, (i, geom) in enumerate(zip(keep, lonlat)):
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField("osm_id", f"way/{100000 + k}")
        feature.SetField("building", "yes")
        if buildings.columns["GRO_FLO_CO"][i]:
            feature.SetField("building:levels", str(buildings.columns["GRO_FLO_CO"][i]))
        # the GeoPackage stores lon/lat (x = longitude) whatever the CRS's axis order
        feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(geom)))
        layer.CreateFeature(feature)
    del layer, ds
    shutil.rmtree(folder / "synthetic")
    return path


def view_in_chromium(tileset_folder: Path, tmp_path: Path, click: bool = False, query: str = ""):
    """Build the offline viewer of ``tileset_folder``, serve it and load it in headless Chromium
    (viewer/browse.mjs), the page's ``query`` appended (e.g. ``?range=3``: from afar); (the browser's
    report, the screenshot's (n, 3) RGB pixels)."""
    import json
    import subprocess

    import numpy as np
    from osgeo import gdal

    viewer = tmp_path / "viewer"
    script = str(ROOT / "scripts" / "viewer.py")
    subprocess.run([sys.executable, script, "build", str(tileset_folder), str(viewer)], check=True,
                   capture_output=True, timeout=120)
    server = subprocess.Popen([sys.executable, script, "serve", str(viewer), "--port", "0"], stdout=subprocess.PIPE,
                              text=True)
    try:
        url = server.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:")
        url += query
        shot = tmp_path / "view.png"
        result = subprocess.run(["node", str(ROOT / "viewer" / "browse.mjs"), url, str(shot), "--timeout", "240"]
                                + (["--click"] if click else []), capture_output=True, text=True, timeout=400)
    finally:
        server.terminate()
        server.wait(timeout=10)
    report = json.loads(result.stdout)
    assert report["loaded"], report
    assert not (report["consoleErrors"] or report["pageErrors"] or report["httpErrors"]
                or report["failedRequests"]), report
    assert report["externalRequests"] == []  # offline: nothing but the local server
    return report, np.moveaxis(gdal.Open(str(shot)).ReadAsArray()[:3], 0, -1).reshape(-1, 3).astype(int)
