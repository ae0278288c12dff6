"""Rasters in another CRS than the model's: the DEM and the orthoimage reprojected on
the fly, window by window — heights checked against gdal.Warp and against bilinear sampling of the
source DEM at the transformed point, NoData, vertical values, the coverage check in the DEM's own CRS,
sheets georeferenced in another CRS, and the chain run with the model in EPSG:5187."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from conftest import RecordingFeedback
from osgeo import gdal, ogr

from wit_plugin.chain.coverage import ortho_coverage, require_dem
from wit_plugin.infra import step_layers
from wit_plugin.infra.dem import Dem
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.mapsheet import parse_sheet_number, projected_envelope
from wit_plugin.mosaic.georef import OK, georeference_sheets, list_tifs

SUSEO_5186 = (209020.9, 543132.8)
TO_5187 = pyproj.Transformer.from_crs("EPSG:5186", "EPSG:5187", always_xy=True)
SUSEO_5187 = TO_5187.transform(*SUSEO_5186)


def _terrain(rows: int, cols: int, seed: int = 5) -> np.ndarray:
    """Hills and valleys with a rough surface: slopes that change from cell to cell, as real DEMs'."""
    rng = np.random.default_rng(seed)
    i, j = np.mgrid[0:rows, 0:cols].astype(float)
    heights = 40 + 25 * np.sin(i / 23.0) * np.cos(j / 31.0) + 0.05 * (i + 2 * j)
    for _ in range(30):  # bumps of 2 to 10 cells, up to a metre high
        wave, angle, phase = rng.uniform(2, 10), rng.uniform(0, np.pi), rng.uniform(0, 2 * np.pi)
        heights += rng.uniform(0.2, 1.0) * np.sin((i * np.cos(angle) + j * np.sin(angle)) / wave + phase)
    return heights.astype(np.float32)


def _write_dem(path: Path, values: np.ndarray, gt: tuple, crs: str | None, nodata: float | None = None) -> str:
    ds = gdal.GetDriverByName("GTiff").Create(str(path), values.shape[1], values.shape[0], 1, gdal.GDT_Float32)
    ds.SetGeoTransform(gt)
    if crs:
        ds.SetProjection(pyproj.CRS(crs).to_wkt())
    if nodata is not None:
        ds.GetRasterBand(1).SetNoDataValue(nodata)
    ds.GetRasterBand(1).WriteArray(values)
    ds = None
    return str(path)


@pytest.fixture(scope="module")
def dem_5186(tmp_path_factory) -> tuple[str, np.ndarray, tuple]:
    """A 5 m DEM of 2.4 km around Suseo in EPSG:5186."""
    folder = tmp_path_factory.mktemp("dem5186")
    values = _terrain(480, 480)
    gt = (SUSEO_5186[0] - 1200.0, 5.0, 0.0, SUSEO_5186[1] + 1200.0, 0.0, -5.0)
    return _write_dem(folder / "dem_5186.tif", values, gt, "EPSG:5186"), values.astype(np.float64), gt


@pytest.fixture(scope="module")
def dem_4326(tmp_path_factory) -> tuple[str, np.ndarray, tuple]:
    """A one-arc-second DEM (about 25 × 31 m cells) in geographic EPSG:4326."""
    folder = tmp_path_factory.mktemp("dem4326")
    values = _terrain(150, 150, seed=9)
    step = 1 / 3600
    gt = (127.08, step, 0.0, 37.51, 0.0, -step)
    return _write_dem(folder / "dem_4326.tif", values, gt, "EPSG:4326"), values.astype(np.float64), gt


def _refusal(function, *args) -> str:
    """The message of the InputError ``function(*args)`` raises (not kept with its traceback: that would
    keep the GDAL datasets of the failed call alive past QGIS's exit)."""
    try:
        function(*args)
    except InputError as exc:
        return str(exc)
    raise AssertionError(f"{function.__name__} did not refuse")


def _bilinear(values: np.ndarray, gt: tuple, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The paper's bilinear formula (Kang et al. 2025, §3.1) straight on the source grid (this test's own,
    independent of the core)."""
    u = (x - gt[0]) / gt[1] - 0.5
    v = (y - gt[3]) / gt[5] - 0.5
    j, i = np.floor(u).astype(int), np.floor(v).astype(int)
    a, b = u - j, v - i
    return (values[i, j] * (1 - a) * (1 - b) + values[i, j + 1] * a * (1 - b)
            + values[i + 1, j] * (1 - a) * b + values[i + 1, j + 1] * a * b)


def _bound(values: np.ndarray, gt: tuple, x: np.ndarray, y: np.ndarray, cell: float,
           metres: tuple[float, float]) -> np.ndarray:
    """How far the bilinear surface of the reprojected grid may depart from the source's, per point.

    Bilinear interpolation reproduces linear functions, so at p its error is a weighted mean of
    F(cᵢ) − F(p) − G·(cᵢ − p) over the four cell centres cᵢ around p, for any vector G: at most
    |cᵢ − p| ≤ √2·cell times the spread of the source surface's gradient near p. A bilinear cell's
    slopes lie between its edges' slopes, so that spread is at most the range of the edge slopes of
    the source cells within two cells of p (converted to metres per metre).
    """
    u = (x - gt[0]) / gt[1] - 0.5
    v = (y - gt[3]) / gt[5] - 0.5
    sx = np.diff(values, axis=1) / metres[0]
    sy = np.diff(values, axis=0) / metres[1]
    out = np.empty(len(x))
    for k, (j, i) in enumerate(zip(np.floor(u).astype(int), np.floor(v).astype(int))):
        bx, by = sx[i - 2:i + 4, j - 2:j + 3], sy[i - 2:i + 3, j - 2:j + 4]
        out[k] = math.sqrt(2) * cell * math.hypot(bx.max() - bx.min(), by.max() - by.min())
    return 1.01 * out + 1e-6


def _gdal_warp(path: str, dem: Dem, crs: str) -> np.ndarray:
    """gdal.Warp of the whole file onto the grid of ``dem`` (bilinear, exact transforms, four cells)."""
    x0, size, _, y1, _, dy = dem.geotransform
    rows, cols = dem.values.shape
    out = gdal.Warp("", path, format="MEM", dstSRS=crs, outputBounds=(x0, y1 + rows * dy, x0 + cols * size, y1),
                    width=cols, height=rows, resampleAlg="bilinear", errorThreshold=0, outputType=gdal.GDT_Float64,
                    warpOptions=["XSCALE=1", "YSCALE=1"], dstNodata=math.nan)
    return out.ReadAsArray()


def _centres(dem: Dem) -> tuple[np.ndarray, np.ndarray]:
    x0, size, _, y1, _, dy = dem.geotransform
    rows, cols = dem.values.shape
    return np.meshgrid(x0 + (np.arange(cols) + 0.5) * size, y1 + (np.arange(rows) + 0.5) * dy)


def test_a_dem_in_5186_read_in_5187_equals_gdal_warp_and_stays_close_to_the_source(dem_5186):
    path, values, gt = dem_5186
    bounds = (SUSEO_5187[0] - 500, SUSEO_5187[1] - 400, SUSEO_5187[0] + 450, SUSEO_5187[1] + 500)
    log = RecordingFeedback()
    dem = Dem.open(path, bounds, crs="EPSG:5187", feedback=log)
    x0, size, _, y1, _, dy = dem.geotransform
    assert size == -dy == 5.0  # the source's 5 m (5.0017 m in the East Belt's units), square
    assert x0 / size == pytest.approx(round(x0 / size), abs=1e-9) and y1 / size == pytest.approx(round(y1 / size),
                                                                                               abs=1e-9)
    xmin, ymin, xmax, ymax = dem.extent
    assert xmin < bounds[0] and ymin < bounds[1] and xmax > bounds[2] and ymax > bounds[3]
    # 1. the grid is gdal.Warp's of the whole file (the core warps a window of it)
    np.testing.assert_allclose(dem.values, _gdal_warp(path, dem, "EPSG:5187"), rtol=0, atol=1e-6)
    # 2. every cell centre holds the source's bilinear height at that point, to the micrometre
    cx, cy = _centres(dem)
    sx, sy = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(cx, cy)
    np.testing.assert_allclose(dem.values, _bilinear(values, gt, sx, sy), rtol=0, atol=1e-6)
    # 3. between the centres, the grid's bilinear surface stays within the bound of the resampling
    rng = np.random.default_rng(2)
    x, y = rng.uniform(bounds[0], bounds[2], 4000), rng.uniform(bounds[1], bounds[3], 4000)
    px, py = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(x, y)
    error = np.abs(dem.sample(x, y) - _bilinear(values, gt, px, py))
    bound = _bound(values, gt, px, py, size, (5.0, 5.0))
    assert (error <= bound).all(), (error.max(), bound[np.argmax(error - bound)])
    assert error.max() < 0.5 and 0 < error.mean() < 0.05  # a resampling, not a copy; cm on average here
    assert not log.warnings and not any("NoData" in m for m in log.infos)


def test_a_geographic_dem_in_4326_read_in_5187(dem_4326):
    path, values, gt = dem_4326
    centre = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:5187", always_xy=True).transform(127.1, 37.49)
    bounds = (centre[0] - 600, centre[1] - 600, centre[0] + 600, centre[1] + 600)
    dem = Dem.open(path, bounds, crs="EPSG:5187")
    geod = pyproj.Geod(ellps="WGS84")
    per_lon = geod.inv(127.1, 37.49, 127.1 + gt[1], 37.49)[2]  # metres of one cell along the parallel
    per_lat = geod.inv(127.1, 37.49, 127.1, 37.49 + gt[1])[2]
    size = dem.geotransform[1]
    assert size == pytest.approx(min(per_lon, per_lat), rel=0.01) and per_lon < per_lat  # about 24.6 m
    np.testing.assert_allclose(dem.values, _gdal_warp(path, dem, "EPSG:5187"), rtol=0, atol=1e-6)
    to_source = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:4326", always_xy=True)
    cx, cy = _centres(dem)
    np.testing.assert_allclose(dem.values, _bilinear(values, gt, *to_source.transform(cx, cy)), rtol=0, atol=1e-6)
    rng = np.random.default_rng(4)
    x, y = rng.uniform(bounds[0], bounds[2], 3000), rng.uniform(bounds[1], bounds[3], 3000)
    lon, lat = to_source.transform(x, y)
    error = np.abs(dem.sample(x, y) - _bilinear(values, gt, lon, lat))
    assert (error <= _bound(values, gt, lon, lat, size, (per_lon, per_lat))).all()


def test_neighbouring_windows_share_the_reprojected_grid(dem_5186):
    """Tiles read their own windows: where they meet, the same cells and the same heights."""
    path = dem_5186[0]
    x, y = SUSEO_5187
    west = Dem.open(path, (x - 400, y - 300, x, y + 300), crs="EPSG:5187")
    east = Dem.open(path, (x, y - 300, x + 400, y + 300), crs="EPSG:5187")
    assert west.geotransform[1] == east.geotransform[1]
    line = np.linspace(y - 300, y + 300, 301)
    np.testing.assert_allclose(west.sample(np.full(301, x), line), east.sample(np.full(301, x), line),
                               rtol=0, atol=1e-9)


def test_nodata_is_filled_in_the_source_and_never_leaks_into_a_height(tmp_path):
    values = _terrain(200, 200)
    values[90:96, 100:104] = -9999.0  # real Korean DEMs: -9999 without a NoData flag
    values[20, 30] = -32768.0
    gt = (SUSEO_5186[0] - 500.0, 5.0, 0.0, SUSEO_5186[1] + 500.0, 0.0, -5.0)
    path = _write_dem(tmp_path / "holes.tif", values, gt, "EPSG:5186")
    log = RecordingFeedback()
    x, y = SUSEO_5187
    dem = Dem.open(path, (x - 300, y - 300, x + 300, y + 300), crs="EPSG:5187", feedback=log)
    valid = values[values > -1000]
    assert dem.values.min() >= valid.min() - 1e-6 and dem.values.max() <= valid.max() + 1e-6
    assert "DEM: 24 NoData cell(s) filled from their neighbours." in log.infos  # the source's cells, counted


def test_heights_keep_their_vertical_datum(tmp_path):
    """A DEM in a compound CRS (EPSG:5186 + Incheon height): its heights are reprojected horizontally
    only, never shifted to another vertical datum."""
    i, j = np.mgrid[0:100, 0:100]
    plane = (30.0 + 0.2 * i - 0.1 * j).astype(np.float32)
    gt = (SUSEO_5186[0] - 250.0, 5.0, 0.0, SUSEO_5186[1] + 250.0, 0.0, -5.0)
    path = _write_dem(tmp_path / "compound.tif", plane, gt, "EPSG:5186+5193")
    x, y = SUSEO_5187
    dem = Dem.open(path, (x - 150, y - 150, x + 150, y + 150), crs="EPSG:5187")
    rng = np.random.default_rng(1)
    px, py = rng.uniform(x - 150, x + 150, 500), rng.uniform(y - 150, y + 150, 500)
    sx, sy = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(px, py)
    np.testing.assert_allclose(dem.sample(px, py), _bilinear(plane.astype(float), gt, sx, sy), rtol=0, atol=1e-4)


def test_a_dem_in_the_layers_crs_is_read_as_before(dem_5186):
    """Same place, other definition (the real Seoul DEM's custom TM): no reprojection, the file's own grid."""
    path, values, gt = dem_5186
    custom = Path(path).with_name("custom_tm.tif")
    wkt = pyproj.CRS.from_proj4("+proj=tmerc +lat_0=38 +lon_0=127 +k=1 +x_0=200000 +y_0=600000 +ellps=GRS80 "
                                "+units=m +no_defs").to_wkt()
    gdal.Translate(str(custom), path, outputSRS=wkt)
    dem = Dem.open(str(custom), (SUSEO_5186[0] - 100, SUSEO_5186[1] - 100, SUSEO_5186[0] + 100, SUSEO_5186[1] + 100),
                   crs="EPSG:5186")
    c0, r0 = round((dem.geotransform[0] - gt[0]) / 5.0), round((gt[3] - dem.geotransform[3]) / 5.0)
    rows, cols = dem.values.shape
    assert dem.geotransform[1] == 5.0 and dem.geotransform[0] == gt[0] + 5.0 * c0
    np.testing.assert_array_equal(dem.values, values[r0:r0 + rows, c0:c0 + cols])  # the file's own cells


def test_the_coverage_check_judges_a_dem_in_its_own_crs(dem_4326, tmp_path):
    path = dem_4326[0]
    folder = Path(path).parent
    before = sorted(p.name for p in folder.iterdir())
    inside = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:5187", always_xy=True).transform(127.1, 37.49)
    log = RecordingFeedback()
    require_dem(path, shapely.Point(inside).buffer(300), "EPSG:5187", log)
    assert any("is in WGS 84 (EPSG:4326): it is reprojected on the fly to Korea 2000 / East Belt 2010 (EPSG:5187) "
               "(bilinear, cells of 24." in m for m in log.infos), log.infos
    east = shapely.Point(inside[0] + 2500, inside[1]).buffer(300)  # beyond 127.1217°E, where the DEM stops
    message = _refusal(require_dem, path, east, "EPSG:5187")
    assert message.startswith("The DEM dem_4326.tif (x 127.080000–127.121667, y 37.468333–37.510000 in its CRS, "
                              "EPSG:4326) does not cover the area (x 127.")
    assert re.search(r"\(the area's box in EPSG:5187, reprojected\)\): it stops short by 0\.0\d{5}° "
                     r"to the east\. ", message)
    assert sorted(p.name for p in folder.iterdir()) == before  # nothing written beside the DEM (no .aux.xml)


def test_a_dem_without_crs_is_assumed_in_the_layers_crs(tmp_path):
    values = _terrain(40, 40)
    gt = (SUSEO_5186[0] - 100.0, 5.0, 0.0, SUSEO_5186[1] + 100.0, 0.0, -5.0)
    path = _write_dem(tmp_path / "nocrs.tif", values, gt, None)
    log = RecordingFeedback()
    dem = Dem.open(path, (SUSEO_5186[0] - 50, SUSEO_5186[1] - 50, SUSEO_5186[0] + 50, SUSEO_5186[1] + 50),
                   crs="EPSG:5187", feedback=log)
    assert dem.geotransform[1] == 5.0
    assert log.warnings == [("The DEM nocrs.tif has no coordinate reference system: it is assumed to be in the layers' "
                             "CRS, Korea 2000 / East Belt 2010 (EPSG:5187). If it is not, assign its CRS first "
                             "(Raster ▸ Projections ▸ Assign Projection).")]


# -- orthoimage sheets georeferenced in another CRS ---------------------------------------------

def _sheet_tif(folder: Path, number: str, crs: str = "EPSG:5186", pixel: float = 2.0) -> str:
    """A georeferenced RGB sheet (its envelope + 50 m in ``crs``) of 20 m squares, each its own colour."""
    sheet = parse_sheet_number(number)
    xmin, ymin, xmax, ymax = projected_envelope(sheet, crs, "EPSG:4737", 50.0)
    cols, rows = round((xmax - xmin) / pixel), round((ymax - ymin) / pixel)
    i, j = np.mgrid[0:rows, 0:cols]
    block = (i * pixel // 20) * 7 + (j * pixel // 20) * 13
    path = folder / f"(B060)정사영상_2022_{number}.tif"
    ds = gdal.GetDriverByName("GTiff").Create(str(path), cols, rows, 3, gdal.GDT_Byte)
    ds.SetGeoTransform((xmin, pixel, 0.0, ymax, 0.0, -pixel))
    ds.SetProjection(pyproj.CRS(crs).to_wkt())
    for b in range(3):
        ds.GetRasterBand(b + 1).WriteArray(((block * (b + 3)) % 200 + 30).astype(np.uint8))
    ds = None
    return str(path)


def test_sheets_georeferenced_in_5186_are_reprojected_to_5187_from_their_own_georeference(tmp_path):
    inputs = tmp_path / "sheets"
    inputs.mkdir()
    paths = [_sheet_tif(inputs, n) for n in ("37709004", "37709005")]  # list_tifs's order
    before = sorted(p.name for p in inputs.iterdir())
    log = RecordingFeedback()
    results = georeference_sheets(list_tifs(str(inputs)), tmp_path / "geo", "EPSG:5187", fmt="VRT", feedback=log)
    assert [r.status for r in results] == [OK, OK]
    assert sorted(p.name for p in inputs.iterdir()) == before  # nothing beside the inputs
    assert sorted(p.name for p in (tmp_path / "geo").iterdir()) == [
        "37709004.vrt", "37709004.warped.vrt", "37709005.vrt", "37709005.warped.vrt"]
    assert any("carries its own georeference in EPSG:5186: reprojected to EPSG:5187 (bilinear, 2 m pixels) "
               "→ 37709005.vrt" in m for m in log.infos)
    to_5186 = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True)
    for result, path in zip(results, paths):
        vrt, source = gdal.Open(result.output), gdal.Open(path)
        assert vrt.RasterCount == 3 and vrt.GetRasterBand(1).GetMaskFlags() == gdal.GMF_PER_DATASET
        assert pyproj.CRS(vrt.GetProjection()).to_epsg() == 5187
        gt, sgt = vrt.GetGeoTransform(), source.GetGeoTransform()
        rgb = vrt.ReadAsArray()
        mask = vrt.GetRasterBand(1).GetMaskBand().ReadAsArray()
        src = source.ReadAsArray()
        rng = np.random.default_rng(0)
        rows, cols = rng.integers(0, vrt.RasterYSize, 3000), rng.integers(0, vrt.RasterXSize, 3000)
        x, y = gt[0] + (cols + 0.5) * gt[1], gt[3] + (rows + 0.5) * gt[5]
        sx, sy = to_5186.transform(x, y)
        u, v = (sx - sgt[0]) / sgt[1], (sy - sgt[3]) / sgt[5]
        inside = (u > 1) & (v > 1) & (u < source.RasterXSize - 1) & (v < source.RasterYSize - 1)
        assert (mask[rows, cols][inside] == 255).all() and (mask[rows, cols][~inside & (
            (u < -1) | (v < -1) | (u > source.RasterXSize + 1) | (v > source.RasterYSize + 1))] == 0).all()
        # inside a 20 m square (not within a pixel of its edge) the warped pixel is the square's colour
        fu, fv = (u * 2.0) % 20, (v * 2.0) % 20
        plain = inside & (fu > 2.5) & (fu < 17.5) & (fv > 2.5) & (fv < 17.5)
        assert plain.sum() > 1500
        np.testing.assert_array_equal(rgb[:, rows[plain], cols[plain]],
                                      src[:, v[plain].astype(int), u[plain].astype(int)])
    tifs = georeference_sheets(paths[1:], tmp_path / "geo_tif", "EPSG:5187", fmt="GTiff")  # a GeoTIFF, masked
    assert [p.name for p in (tmp_path / "geo_tif").iterdir()] == ["37709005.tif"]
    tif, vrt = gdal.Open(tifs[0].output), gdal.Open(results[1].output)
    assert tif.GetGeoTransform() == vrt.GetGeoTransform()
    assert tif.GetRasterBand(1).GetMaskFlags() == gdal.GMF_PER_DATASET
    np.testing.assert_array_equal(tif.ReadAsArray(), vrt.ReadAsArray())
    np.testing.assert_array_equal(tif.GetRasterBand(1).GetMaskBand().ReadAsArray(),
                                  vrt.GetRasterBand(1).GetMaskBand().ReadAsArray())
    del tif, vrt
    coverage = ortho_coverage(paths, shapely.Point(SUSEO_5187).buffer(300), "EPSG:5187")
    ds = gdal.Open(paths[1])
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    footprint = shapely.box(x0, y0 + dy * ds.RasterYSize, x0 + dx * ds.RasterXSize, y0)
    moved = shapely.transform(shapely.segmentize(footprint, 50.0),
                              lambda xy: np.column_stack(TO_5187.transform(xy[:, 0], xy[:, 1])))
    used = next(s for s in coverage.used if s.sheet.number == "37709005")
    assert used.footprint.symmetric_difference(moved).area < 1.0  # its real footprint, not its 5187 envelope


# -- the chain with the model in EPSG:5187, the DEM and the orthoimage sheets in EPSG:5186 --------

@pytest.fixture(scope="module")
def east_belt_run(tmp_path_factory):
    """The sample (DEM and sheets in EPSG:5186, the sheets georeferenced as GeoTIFFs) modelled in EPSG:5187."""
    from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import SampleConfig, generate_sample

    folder = tmp_path_factory.mktemp("east-belt")
    sample = generate_sample(folder / "sample", SampleConfig(radius_m=180.0, seed=4, ortho_pixel_size=1.0))
    sheets = georeference_sheets([str(p) for p in sample.ortho_tiles], folder / "sheets_5186", "EPSG:5186")
    inputs = sorted(p.name for p in folder.rglob("*") if p.is_file() and "out" not in p.parts)
    log = RecordingFeedback()
    report = run_city_model(
        ChainInputs(ortho=[r.output for r in sheets], dem=str(sample.dem), buildings=str(sample.buildings),
                    roads=str(sample.roads), districts=str(sample.districts)),
        ChainOptions(area=StudyArea.circle(127.1020, 37.4876, 150.0), target_crs="EPSG:5187", max_edge=10.0,
                     tiles3d=False, keep_work=True), folder / "out", log)
    return {"sample": sample, "sheets": [r.output for r in sheets], "report": report, "log": log,
            "folder": folder, "inputs": inputs}


def _tin_vertices(path: str) -> np.ndarray:
    ds = ogr.Open(path)
    points = [g.GetPoints() for f in ds.GetLayer(step_layers.TIN_LAYER) for g in [f.GetGeometryRef().GetGeometryRef(0)]]
    return np.unique(np.round(np.array([p for ring in points for p in ring[:3]]), 6), axis=0)


def test_the_chain_models_a_5186_dem_and_sheets_in_5187(east_belt_run):
    report, log, sample = east_belt_run["report"], east_belt_run["log"], east_belt_run["sample"]
    assert report.valid and report.errors == 0 and report.buildings > 30
    assert any("dem_5186.tif is in Korea 2000 / Central Belt 2010 (EPSG:5186): it is reprojected on the fly to "
               "Korea 2000 / East Belt 2010 (EPSG:5187) (bilinear, cells of 5 m)" in m for m in log.infos)
    assert not any("CRS" in w for w in log.warnings), log.warnings
    # every TIN vertex lies on the reprojected DEM (to the mm), itself within the resampling's bound of the source
    xyz = _tin_vertices(report.tin)
    box = (*xyz[:, :2].min(axis=0), *xyz[:, :2].max(axis=0))
    dem = Dem.open(str(sample.dem), box, crs="EPSG:5187")
    np.testing.assert_allclose(xyz[:, 2], dem.sample(xyz[:, 0], xyz[:, 1]), rtol=0, atol=1e-3)
    ds = gdal.Open(str(sample.dem))
    gt, values = ds.GetGeoTransform(), ds.ReadAsArray().astype(float)
    filled = Dem(values, gt).values  # the sample's few -9999 cells filled as the core does
    sx, sy = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(xyz[:, 0], xyz[:, 1])
    error = np.abs(xyz[:, 2] - _bilinear(filled, gt, sx, sy))
    assert (error <= _bound(filled, gt, sx, sy, dem.geotransform[1], (gt[1], -gt[5])) + 1e-3).all()
    # the merged orthoimage in 5187 shows at each roof what the 5186 sheet shows there
    mosaic = gdal.Open(str(Path(report.work) / "ortho.tif"))
    lod1 = ogr.Open(report.lod1)  # kept while its layer is read
    roofs = [shapely.from_wkb(bytes(f.GetGeometryRef().ExportToWkb())) for f in lod1.GetLayer(step_layers.LOD1_LAYER)
             if f.GetField(step_layers.FACE_TYPE) == "roof"]
    inner = [r.buffer(-2.0) for r in shapely.force_2d(np.array(roofs, dtype=object))]
    points = np.array([shapely.get_coordinates(p.representative_point())[0] for p in inner if not p.is_empty])
    assert len(points) > 20
    mgt = mosaic.GetGeoTransform()
    seen = mosaic.ReadAsArray()[:, ((points[:, 1] - mgt[3]) / mgt[5]).astype(int),
                                ((points[:, 0] - mgt[0]) / mgt[1]).astype(int)].astype(int)
    px, py = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(*points.T)

    def sheets_at(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        colours = np.zeros_like(seen)
        for path in east_belt_run["sheets"]:
            sheet = gdal.Open(path)
            sg = sheet.GetGeoTransform()
            c, r = ((x - sg[0]) / sg[1]).astype(int), ((y - sg[3]) / sg[5]).astype(int)
            on = (c >= 0) & (r >= 0) & (c < sheet.RasterXSize) & (r < sheet.RasterYSize)
            colours[:, on] = sheet.ReadAsArray()[:, r[on], c[on]]
        return colours

    def misfit(colours: np.ndarray) -> float:
        """Median residual of the mosaic's colours against a per-band gain and offset of ``colours`` (the
        mosaic's tone correction)."""
        residuals = [seen[b] - np.polyval(np.polyfit(colours[b], seen[b], 1), colours[b]) for b in range(3)]
        return float(np.median(np.abs(residuals)))

    assert misfit(sheets_at(px, py)) <= 3  # the same roof, its tone corrected
    assert misfit(sheets_at(px + 25.0, py)) > 10  # 25 m off: another roof, or the ground


def test_the_inputs_of_a_reprojecting_run_are_untouched(east_belt_run):
    folder = east_belt_run["folder"]
    assert sorted(p.name for p in folder.rglob("*") if p.is_file() and "out" not in p.parts) == east_belt_run["inputs"]


def test_a_mosaic_in_another_crs_is_reprojected_by_the_texture_step(east_belt_run, tmp_path):
    """wit:wittexture with the layers in 5187 and the merged orthoimage in 5186: its pixels over the layers
    are warped as they are read; the roof atlas matches the one cut from the chain's 5187 mosaic."""
    from wit_plugin.mosaic import merge_rasters
    from wit_plugin.texture import texture_model

    report = east_belt_run["report"]
    mosaic = tmp_path / "mosaic_5186.tif"
    merge_rasters(east_belt_run["sheets"], str(mosaic), mode="feather", gain=True)
    log = RecordingFeedback()
    texture_model(str(mosaic), report.lod1, report.tin, str(tmp_path / "textures"), feedback=log)
    assert any("mosaic_5186.tif is in Korea 2000 / Central Belt 2010 (EPSG:5186): its pixels over the layers are "
               "reprojected as they are read to Korea 2000 / East Belt 2010 (EPSG:5187) (bilinear, 1 m pixels)" in m
               for m in log.infos), log.infos
    ours = gdal.Open(str(tmp_path / "textures" / "roof_atlas_0000.jpg")).ReadAsArray().astype(int)
    chain = gdal.Open(str(Path(report.work) / "textures" / "roof_atlas_0000.jpg")).ReadAsArray().astype(int)
    assert ours.shape == chain.shape
    assert np.median(np.abs(ours - chain)) <= 4


def test_a_tiled_run_checks_the_dem_in_its_own_crs_before_any_worker_starts(east_belt_run, dem_4326, tmp_path,
                                                                              monkeypatch):
    from wit_plugin.chain import ChainInputs, ChainOptions
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sheetrun import runner

    def no_cluster(*args, **kwargs):
        raise AssertionError("a Dask cluster was started")

    monkeypatch.setattr(runner, "dask_client", no_cluster)
    sample = east_belt_run["sample"]
    inputs = ChainInputs(ortho=east_belt_run["sheets"], dem=dem_4326[0], buildings=str(sample.buildings),
                         roads=str(sample.roads), districts=str(sample.districts))
    area = StudyArea.circle(127.118, 37.4876, 500.0)  # reaches 127.1237°E: the DEM stops at 127.1217°E
    message = _refusal(runner.run_tiles, inputs, ChainOptions(area=None, target_crs="EPSG:5187", tiles3d=False),
                       tmp_path / "out", area, 1000)
    assert message.startswith("The DEM dem_4326.tif (x 127.080000–127.121667, y 37.468333–37.510000 in its CRS, "
                              "EPSG:4326) does not cover the area"), message
    assert "° to the east. Use a DEM that covers the area, or a smaller area." in message
    assert not (tmp_path / "out" / "index.gpkg").exists()


def test_a_tiled_run_checks_the_orthoimage_sheets_before_any_worker_starts(east_belt_run, tmp_path, monkeypatch):
    """The sheet under the area missing (surfaces outside the orthoimage: fail): refused in seconds, naming it."""
    from wit_plugin.chain import ChainInputs, ChainOptions
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sheetrun import runner

    def no_cluster(*args, **kwargs):
        raise AssertionError("a Dask cluster was started")

    monkeypatch.setattr(runner, "dask_client", no_cluster)
    sample = east_belt_run["sample"]
    sheets = [s for s in east_belt_run["sheets"] if "37709005" not in s]
    inputs = ChainInputs(ortho=sheets, dem=str(sample.dem), buildings=str(sample.buildings), roads=str(sample.roads),
                         districts=str(sample.districts))
    message = _refusal(runner.run_tiles, inputs, ChainOptions(area=None, target_crs="EPSG:5187", tiles3d=False),
                       tmp_path / "out", StudyArea.circle(127.1020, 37.4876, 150.0), 1000)
    assert message.startswith("The orthoimage sheets leave 0.0") and "of the area uncovered" in message
    assert "the sheets that would cover it: 37709005. Add those TIFs" in message, message
    assert not (tmp_path / "out" / "index.gpkg").exists()
