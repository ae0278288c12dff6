"""Test set-up: the core importable as ``wit_plugin``; the plugin importable as ``wit_citymodel``.

The checkout folder may have any name (CI clones into an arbitrary one), so the plugin package
is registered under its installed name from the repository root.

Markers given here: ``qgis`` on every test that needs QGIS (see ``needs_qgis``); the others are core
tests, which ``scripts/test.sh --core`` (``make test-fast``) runs with qgis unimportable.
"""
from __future__ import annotations

import ast
import functools
import importlib.util
import inspect
import os
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
os.environ.setdefault("PROJ_DATA", "/usr/share/proj")

from osgeo import gdal  # noqa: E402 (after PROJ_DATA is set, which GDAL reads when loaded)

from wit_plugin.infra.feedback import Feedback  # noqa: E402

_SESSION_GDAL_EXCEPTIONS = bool(gdal.GetUseExceptions())

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

if "wit_citymodel" not in sys.modules:
    _spec = importlib.util.spec_from_file_location(
        "wit_citymodel", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    _module = importlib.util.module_from_spec(_spec)
    sys.modules["wit_citymodel"] = _module
    _spec.loader.exec_module(_module)


# -- which tests need QGIS: the marker qgis ---------------------------------------------------------------

#: modules that exist only with QGIS: QGIS's own, and the plugin's glue (which imports them)
QGIS_MODULES = ("qgis", "processing", "wit_citymodel.processing_provider", "wit_citymodel.plugin")
#: the commands (a string constant in a test's code) that run QGIS in another process
QGIS_COMMANDS = ("qgis-process", "qgis_process", "qgis_process.bin")


class RecordingFeedback(Feedback):
    """A core feedback that keeps what it is told (``infos``, ``warnings``), for the assertions."""

    def __init__(self) -> None:
        self.infos: list[str] = []
        self.warnings: list[str] = []

    def info(self, message: str) -> None:
        self.infos.append(message)

    def warning(self, message: str) -> None:
        self.warnings.append(message)

try:
    import qgis  # noqa: F401
    QGIS_IMPORTABLE = True
except ImportError:  # scripts/test.sh --core, or a machine without QGIS
    QGIS_IMPORTABLE = False


def _imports_qgis(node: ast.AST) -> bool:
    for child in ast.walk(node):
        if isinstance(child, ast.Import):
            names = [alias.name for alias in child.names]
        elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
            names = [child.module] + [f"{child.module}.{alias.name}" for alias in child.names]
        else:
            continue
        if any(name == m or name.startswith(m + ".") for name in names for m in QGIS_MODULES):
            return True
    return False


def _runs_qgis(node: ast.AST) -> bool:
    return any(isinstance(n, ast.Constant) and n.value in QGIS_COMMANDS for n in ast.walk(node))


@functools.cache
def module_needs_qgis(path: Path) -> bool:
    """A test module whose own top-level statements import QGIS (it cannot even be imported without)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top_level = [n for n in tree.body if not isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))]
    return any(_imports_qgis(n) for n in top_level)


def _function_needs_qgis(function, seen: set | None = None) -> bool:
    """The function's code imports QGIS or runs qgis_process, itself or in a function of its module it calls."""
    seen = set() if seen is None else seen
    if function is None or function in seen:
        return False
    seen.add(function)
    try:
        tree = ast.parse(inspect.getsource(function).lstrip())  # (a method's source is indented)
    except (OSError, TypeError, SyntaxError):
        return False
    if _imports_qgis(tree) or _runs_qgis(tree):
        return True
    module = getattr(function, "__module__", None)
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
    helpers = (getattr(function, "__globals__", {}).get(name) for name in called)
    return any(inspect.isfunction(h) and h.__module__ == module and _function_needs_qgis(h, seen) for h in helpers)


def _requests_qgis_fixture(item) -> bool:
    """The test asks, itself or through its fixtures, for a pytest-qgis fixture (``qgis_*``). pytest-qgis's
    autouse fixtures, which every test gets, do not count: they do nothing for a test that asks nothing."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return False
    todo, seen = list(info.argnames), set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        if name.startswith("qgis_"):
            return True
        for definition in info.name2fixturedefs.get(name, ()):
            todo.extend(definition.argnames)
            if _function_needs_qgis(definition.func):
                return True
    return False


def needs_qgis(item) -> bool:
    """A test needs QGIS when its module imports QGIS at the top, its own code imports QGIS or runs
    qgis_process, or it asks for a QGIS fixture; the QGIS-facing tests are QGIS tests by definition, and a
    test can say so itself (``pytest.mark.qgis``)."""
    return (module_needs_qgis(Path(str(item.fspath))) or item.get_closest_marker("qgis_facing") is not None
            or item.get_closest_marker("qgis") is not None
            or _function_needs_qgis(getattr(item, "function", None)) or _requests_qgis_fixture(item))


def pytest_ignore_collect(collection_path, config):
    """Without QGIS, a module that imports it at the top is not even imported (all its tests need QGIS)."""
    if not QGIS_IMPORTABLE and collection_path.suffix == ".py" and collection_path.name.startswith("test_"):
        return module_needs_qgis(collection_path) or None
    return None


@pytest.hookimpl(tryfirst=True)  # before -m chooses by marker
def pytest_collection_modifyitems(config, items):
    """Mark the QGIS tests ``qgis``; without QGIS, leave them out (deselected, so counted)."""
    deselected = []
    for item in items:
        if needs_qgis(item):
            item.add_marker(pytest.mark.qgis)
            if not QGIS_IMPORTABLE:
                deselected.append(item)
    if deselected:
        config.hook.pytest_deselected(items=deselected)
        items[:] = [item for item in items if item not in deselected]


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
    from wit_plugin.infra.feedback import Feedback

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

    from wit_plugin.infra.io.vector_io import read_layer
    from wit_plugin.infra.polygons import transform
    from wit_plugin.prepare.vectors import road_widths
    from wit_plugin.sample import SampleConfig, generate_sample

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


def view_in_chromium(tileset_folder: Path, tmp_path: Path, click: bool = False, query: str = "",
                     options: tuple[str, ...] = ()):
    """Build the offline viewer of ``tileset_folder``, serve it and load it in headless Chromium
    (viewer/browse.mjs, with its ``options``, e.g. ``--no-facades``), the page's ``query`` appended (e.g.
    ``?range=3``: from afar); (the browser's report, the screenshot's (n, 3) RGB pixels)."""
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
                                + (["--click"] if click else []) + list(options), capture_output=True, text=True,
                                timeout=400)
    finally:
        server.terminate()
        server.wait(timeout=10)
    report = json.loads(result.stdout)
    assert report["loaded"], report
    assert not (report["consoleErrors"] or report["pageErrors"] or report["httpErrors"]
                or report["failedRequests"]), report
    assert report["externalRequests"] == []  # offline: nothing but the local server
    return report, np.moveaxis(gdal.Open(str(shot)).ReadAsArray()[:3], 0, -1).reshape(-1, 3).astype(int)


@pytest.fixture(scope="module")
def xvfb_display():
    """An X display (Xvfb) for the real QGIS window."""
    import subprocess

    assert shutil.which("Xvfb"), "Xvfb is not installed: scripts/setup.sh installs it"
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1600x1000x24",
                               "-nolisten", "tcp"], pass_fds=(write,),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    try:
        assert number, "Xvfb did not report a display"
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(timeout=10)


def qgis_gui_profile(folder: Path, locale: str | None = None) -> Path:
    """A throwaway QGIS profile folder with this checkout as the enabled plugin (and ``locale`` forced)."""
    plugins = folder / "profiles" / "default" / "python" / "plugins"
    plugins.mkdir(parents=True)
    (folder / "profiles" / "default" / "QGIS").mkdir()
    (plugins / "wit_citymodel").symlink_to(ROOT)
    settings = "[PythonPlugins]\nwit_citymodel=true\nprocessing=true\n\n[qgis]\ncheckVersion=false\n"
    if locale:
        settings += f"\n[locale]\noverrideFlag=true\nuserLocale={locale}\nglobalLocale={locale}\n"
    (folder / "profiles" / "default" / "QGIS" / "QGIS3.ini").write_text(settings, encoding="utf-8")
    return folder
