"""wit:qualitymetrics core: texture measures with hand-derived answers, geometry against the sources, seam step."""
from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import gdal, ogr, osr

from wit_plugin import metrics
from wit_plugin.buildings import extrude
from wit_plugin.citygml import reader
from wit_plugin.citygml import writer as citygml
from wit_plugin.infra import step_layers
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.interpreter import core_env
from wit_plugin.infra.step_process import RECORD
from wit_plugin.mosaic import georef, merge_rasters
from wit_plugin.prepare.area import StudyArea
from wit_plugin.prepare.vectors import prepare_vectors
from wit_plugin.sample import SampleConfig, generate_sample
from wit_plugin.texture import TextureConfig, texture_model

A = 255.0
X0, Y0 = 209000.0, 543000.0  # near Suseo station, EPSG:5186


def _srs() -> osr.SpatialReference:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    return srs


# --- Laplacian variance and contrast ---------------------------------------------------------------

def _brute_laplacian_var(img: np.ndarray, border: str) -> float:
    """Literal definition: loop over pixels, 4-neighbour kernel, reflect-101 index or 'valid' interior."""
    rows, cols = img.shape

    def at(r: int, c: int) -> float:
        r = -r if r < 0 else 2 * (rows - 1) - r if r >= rows else r
        c = -c if c < 0 else 2 * (cols - 1) - c if c >= cols else c
        return float(img[r, c])

    lo = 0 if border == "reflect101" else 1
    values = [at(r - 1, c) + at(r + 1, c) + at(r, c - 1) + at(r, c + 1) - 4 * at(r, c)
              for r in range(lo, rows - lo) for c in range(lo, cols - lo)]
    mean = sum(values) / len(values)
    return sum((v - mean) ** 2 for v in values) / len(values)


def _step_edge(n: int, m: int, k: int) -> np.ndarray:
    img = np.zeros((n, m))
    img[:, k:] = A
    return img


def test_step_edge_laplacian_variance_by_hand():
    # Rows are equal, so L = I[c-1] + I[c+1] - 2 I[c]: +A at column k-1, -A at column k, 0 elsewhere
    # (reflect-101 keeps the border columns flat when 2 <= k <= m-2). Mean 0, so
    # var = 2 n A² / (n m) = 2A²/m over all pixels, 2A²/(m-2) over the 'valid' interior.
    n, m, k = 6, 10, 5
    img = _step_edge(n, m, k)
    assert metrics.laplacian_variance(img) == pytest.approx(2 * A ** 2 / m, rel=1e-12)  # 13005
    assert metrics.laplacian_variance(img, border="valid") == pytest.approx(2 * A ** 2 / (m - 2), rel=1e-12)
    for border in metrics.BORDERS:
        assert metrics.laplacian_variance(img, border=border) == pytest.approx(_brute_laplacian_var(img, border))
    assert metrics.contrast(img) == pytest.approx(A / 2)


def test_laplacian_matches_brute_force_on_random_image():
    img = np.random.default_rng(3).integers(0, 256, (9, 13)).astype(float)
    for border in metrics.BORDERS:
        assert metrics.laplacian_variance(img, border=border) == pytest.approx(_brute_laplacian_var(img, border),
                                                                              rel=1e-12)


def test_flat_and_checkerboard():
    flat = np.full((7, 5), 93.0)
    assert metrics.laplacian_variance(flat) == 0.0 and metrics.contrast(flat) == 0.0
    # 1-pixel checkerboard: every neighbour differs, L = ±4A at every pixel (reflect-101 keeps the
    # parity at the border), equal counts → var = 16 A², std = A/2.
    board = A * (np.add.outer(np.arange(8), np.arange(8)) % 2)
    assert metrics.laplacian_variance(board) == pytest.approx(16 * A ** 2)  # 1,040,400
    assert metrics.laplacian_variance(board, border="valid") == pytest.approx(16 * A ** 2)
    assert metrics.contrast(board) == pytest.approx(A / 2)


def test_two_level_contrast_and_grayscale():
    img = np.full((4, 4), 40.0)
    img[0, :] = 200.0  # a quarter of the pixels: std = |a - b| √(p (1 - p))
    assert metrics.contrast(img) == pytest.approx(160 * math.sqrt(0.25 * 0.75))
    rgb = np.stack([np.full((2, 2), 100), np.full((2, 2), 50), np.full((2, 2), 200)]).astype(np.uint8)
    assert metrics.grayscale(rgb) == pytest.approx(np.full((2, 2), 0.299 * 100 + 0.587 * 50 + 0.114 * 200))
    assert math.isnan(metrics.laplacian_variance(np.zeros((1, 5))))
    assert math.isnan(metrics.contrast(img, np.zeros((4, 4), bool)))
    with pytest.raises(InputError, match="border"):
        metrics.laplacian_variance(img, border="zero")


# --- texture folders and the orthoimage ------------------------------------------------------------

def _write_raster(path, data: np.ndarray, driver: str = "GTiff", gt=None, nodata=None) -> str:
    bands = data.shape[0]
    mem = gdal.GetDriverByName("MEM").Create("", data.shape[2], data.shape[1], bands, gdal.GDT_Byte)
    if gt:
        mem.SetGeoTransform(gt)
        mem.SetProjection(_srs().ExportToWkt())
    for i in range(bands):
        mem.GetRasterBand(i + 1).WriteArray(data[i])
        if nodata is not None:
            mem.GetRasterBand(i + 1).SetNoDataValue(nodata)
    gdal.GetDriverByName(driver).CreateCopy(str(path), mem)
    return str(path)


def _write_texcoords(folder, rows: list[tuple[str, str]]) -> None:
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(folder / step_layers.TEXCOORD_FILE))
    layer = ds.CreateLayer(step_layers.TEXCOORD_TABLE, None, ogr.wkbNone)
    for name in (step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_IMAGE, step_layers.TEX_COORDS):
        layer.CreateField(ogr.FieldDefn(name, ogr.OFTString))
    for image, uv in rows:
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField(step_layers.TEX_TARGET, "roof")
        feature.SetField(step_layers.TEX_FEATURE, "BLD_1")
        feature.SetField(step_layers.TEX_IMAGE, image)
        feature.SetField(step_layers.TEX_COORDS, uv)
        layer.CreateFeature(feature)
    ds = None


def test_texture_folder_masks_islands_with_texcoords(tmp_path):
    # a 64 × 64 atlas, grey background, one checkerboard island at columns 8–39, rows 16–47
    atlas = np.full((3, 64, 64), 128, np.uint8)
    atlas[:, 16:48, 8:40] = (A * (np.add.outer(np.arange(32), np.arange(32)) % 2)).astype(np.uint8)
    folder = tmp_path / "tex"
    folder.mkdir()
    _write_raster(folder / "roof_atlas_0000.png", atlas, "PNG")
    _write_raster(folder / "roof_atlas_0000_mip1.png", atlas[:, ::2, ::2], "PNG")  # mip levels are ignored
    x0, x1, top, bottom = 8 / 64, 40 / 64, 1 - 16 / 64, 1 - 48 / 64  # V counts from the bottom
    ring = [(x0, bottom), (x1, bottom), (x1, top), (x0, top), (x0, bottom)]
    _write_texcoords(folder, [("roof_atlas_0000.png", " ".join(f"{u} {v}" for u, v in ring))])
    result = metrics.texture_metrics(str(folder))
    assert result.masked and [i.image for i in result.images] == ["roof_atlas_0000.png"]
    assert result.pixels == 32 * 32
    assert result.contrast == pytest.approx(A / 2)
    assert result.laplacian_variance == pytest.approx(16 * A ** 2)  # eroded island: all ±4A, none vs the grey
    whole = metrics.texture_metrics([str(folder / "roof_atlas_0000.png")])
    gray = metrics.grayscale(atlas)
    assert not whole.masked and whole.pixels == 64 * 64
    assert whole.laplacian_variance == pytest.approx(metrics.laplacian_variance(gray))
    assert whole.contrast == pytest.approx(metrics.contrast(gray))


@pytest.mark.parametrize("uv", ["0 0 1 0 1 1 0", "0 0 1 x 1 1 0 1"])
def test_texture_coordinates_that_are_not_pairs_of_numbers_are_refused_naming_the_file(tmp_path, uv):
    atlas = np.full((3, 8, 8), 128, np.uint8)
    folder = tmp_path / "tex"
    folder.mkdir()
    _write_raster(folder / "roof_atlas_0000.png", atlas, "PNG")
    _write_texcoords(folder, [("roof_atlas_0000.png", "0 0 1 0 1 1 0 0"), ("roof_atlas_0000.png", uv)])
    with pytest.raises(InputError, match=r"texcoords\.gpkg: texture coordinates that are not pairs of numbers u v: "
                                         r"re-run wit:wittexture"):
        metrics.texture_metrics(str(folder))


def test_ortho_is_streamed_like_in_memory(tmp_path, monkeypatch):
    monkeypatch.setattr(metrics.texture, "_BLOCK_PIXELS", 300 * 97)  # blocks of 97 rows: block joins are exercised
    rng = np.random.default_rng(7)
    data = rng.integers(0, 256, (3, 1100, 300)).astype(np.uint8)
    data[:, 600:650, 100:180] = 0  # NoData hole
    gt = (X0, 0.5, 0.0, Y0, 0.0, -0.5)
    ortho = _write_raster(tmp_path / "ortho.tif", data, gt=gt, nodata=0)
    gray, valid = metrics.grayscale(data), data[0] != 0
    result = metrics.texture_metrics(None, ortho)
    assert result.ortho.pixels == valid.sum()
    assert result.ortho.laplacian_variance == pytest.approx(metrics.laplacian_variance(gray, valid), rel=1e-10)
    assert result.ortho.contrast == pytest.approx(metrics.contrast(gray, valid), rel=1e-10)
    # a box: rows 100–899, columns 20–219 (in metres from the corner)
    box = (X0 + 10.0, Y0 - 450.0, X0 + 110.0, Y0 - 50.0)
    sub = metrics.texture_metrics(None, ortho, box)
    window = (slice(100, 900), slice(20, 220))
    assert sub.ortho_area == pytest.approx(box)
    assert sub.ortho.laplacian_variance == pytest.approx(
        metrics.laplacian_variance(gray[window], valid[window]), rel=1e-10)
    with pytest.raises(InputError, match="does not cover"):
        metrics.texture_metrics(None, ortho, (X0 - 500, Y0 - 10, X0 - 400, Y0))


def test_masks_follow_wittexture_uv_convention(tmp_path):
    """Islands cut by wit:wittexture (PNG, S = 1) are the ortho's pixels under the roof: same stats."""
    rng = np.random.default_rng(11)
    data = rng.integers(0, 256, (3, 200, 200)).astype(np.uint8)
    gt = (X0, 0.5, 0.0, Y0, 0.0, -0.5)
    ortho = _write_raster(tmp_path / "ortho.tif", data, gt=gt)
    roof = shapely.Polygon([(X0 + 20.13, Y0 - 70.21), (X0 + 61.37, Y0 - 70.21), (X0 + 61.37, Y0 - 40.08),
                            (X0 + 40.11, Y0 - 22.42), (X0 + 20.13, Y0 - 40.08)])
    lod1 = tmp_path / "lod1.gpkg"
    extrude.write_solids(lod1, [extrude.Solid("BLD_1", 10.0, 9.0, "default", "default 3 m", None, None,
                                              extrude.solid_faces(roof, 10.0, 9.0), {})], _pyproj_5186())
    tex = tmp_path / "tex"
    texture_model(ortho, str(lod1), None, str(tex), TextureConfig(image_format="PNG"))
    result = metrics.texture_metrics(str(tex))
    cols, rows = np.meshgrid(np.arange(200) + 0.5, np.arange(200) + 0.5)
    inside = shapely.contains_xy(roof, X0 + cols * 0.5, Y0 - rows * 0.5)
    gray = metrics.grayscale(data)
    assert result.masked and result.pixels == inside.sum()
    assert result.contrast == pytest.approx(metrics.contrast(gray, inside), rel=1e-9)
    assert result.laplacian_variance == pytest.approx(metrics.laplacian_variance(gray, inside), rel=1e-9)
    source = metrics.texture_metrics(None, ortho, ortho_mask=roof).ortho_inside  # the same pixels in the ortho
    assert source.pixels == result.pixels
    assert source.contrast == pytest.approx(result.contrast, rel=1e-9)
    assert source.laplacian_variance == pytest.approx(result.laplacian_variance, rel=1e-9)


def _pyproj_5186():
    import pyproj
    return pyproj.CRS("EPSG:5186")


# --- geometry ---------------------------------------------------------------------------------------

def test_shape_similarity_iou():
    square = shapely.box(0, 0, 10, 10)
    assert metrics.shape_similarity(square, square) == pytest.approx(1.0)
    assert metrics.shape_similarity(square, shapely.box(0.5, 0, 10.5, 10)) == pytest.approx(9.5 / 10.5)
    assert metrics.shape_similarity(square, shapely.box(20, 0, 30, 10)) == 0.0


def _write_sources(path, buildings: dict[str, shapely.Geometry]) -> str:
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(step_layers.PREPARED_BUILDINGS, _srs(), ogr.wkbMultiPolygon)
    layer.CreateField(ogr.FieldDefn(step_layers.WIT_ID, ogr.OFTString))
    for wit_id, geom in buildings.items():
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField(step_layers.WIT_ID, wit_id)
        feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(shapely.MultiPolygon(
            list(shapely.get_parts(geom))))))
        layer.CreateFeature(feature)
    ds = None
    return str(path)


def _write_lod1(path, footprints: dict[str, shapely.Polygon], base: float = 30.0, height: float = 9.0) -> str:
    """A minimal LoD1 faces layer: ground (clockwise), roof (counter-clockwise), one wall per edge."""
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(step_layers.LOD1_LAYER, _srs(), ogr.wkbPolygon25D)
    for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                       (step_layers.FACE_NUMBER, ogr.OFTInteger)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    for wit_id, poly in footprints.items():
        poly = shapely.geometry.polygon.orient(poly, 1.0)
        ring = np.asarray(poly.exterior.coords)
        faces = [("ground", np.column_stack([ring[::-1], np.full(len(ring), base)])),
                 ("roof", np.column_stack([ring, np.full(len(ring), base + height)]))]
        faces += [("wall", np.array([[*p, base], [*q, base], [*q, base + height], [*p, base + height], [*p, base]]))
                  for p, q in pairwise(ring)]
        for number, (kind, pts) in enumerate(faces):
            feature = ogr.Feature(layer.GetLayerDefn())
            feature.SetField(step_layers.WIT_ID, wit_id)
            feature.SetField(step_layers.FACE_TYPE, kind)
            feature.SetField(step_layers.FACE_NUMBER, number)
            feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(shapely.Polygon(pts), output_dimension=3)))
            layer.CreateFeature(feature)
    ds = None
    return str(path)


@pytest.fixture(scope="module")
def shifted(tmp_path_factory):
    """Sources, and a model with every building moved by (0.3, 0.4) m: a 0.5 m shift."""
    folder = tmp_path_factory.mktemp("shifted")
    square = shapely.box(X0, Y0, X0 + 10, Y0 + 10)
    ell = shapely.Polygon([(X0 + 20, Y0), (X0 + 35, Y0), (X0 + 35, Y0 + 6), (X0 + 26, Y0 + 6), (X0 + 26, Y0 + 14),
                           (X0 + 20, Y0 + 14)])
    twin = shapely.MultiPolygon([shapely.box(X0 + 40, Y0, X0 + 48, Y0 + 8), shapely.box(X0 + 52, Y0, X0 + 60, Y0 + 5)])
    lonely = shapely.box(X0 + 70, Y0, X0 + 75, Y0 + 5)
    sources = _write_sources(folder / "prepared.gpkg", {"BLD_sq": square, "BLD_ell": ell, "BLD_twin": twin,
                                                        "BLD_lonely": lonely})

    def move(g: shapely.Geometry) -> shapely.Geometry:
        return shapely.transform(g, lambda xy: xy + [0.3, 0.4])

    parts = list(twin.geoms)
    lod1 = _write_lod1(folder / "lod1.gpkg", {"BLD_sq": move(square), "BLD_ell": move(ell),
                                              "BLD_twin_part1": move(parts[0]), "BLD_twin_part2": move(parts[1]),
                                              "BLD_extra": shapely.box(X0 + 90, Y0, X0 + 94, Y0 + 4)})
    gml = folder / "city.gml"
    citygml.write_citygml(citygml.CityGMLInputs(lod1=lod1), str(gml))
    return sources, lod1, str(gml), {"square": square, "ell": ell}


@pytest.mark.parametrize("which", ["gml", "lod1"])
def test_half_metre_shift_is_measured_exactly(shifted, which):
    sources, lod1, gml, shapes = shifted
    result = metrics.geometry_metrics(gml if which == "gml" else lod1, sources)
    assert result.matched == 3 and result.source_count == 4 and result.model_count == 4
    assert result.model_only == ["BLD_extra"] and result.source_only == ["BLD_lonely"]
    assert result.placement_mean_error == pytest.approx(0.5, abs=1e-9)
    assert result.placement_max_error == pytest.approx(0.5, abs=1e-9)
    assert result.coordinate_mean_error == pytest.approx(0.5, abs=1e-9)  # every roof vertex is 0.5 m off
    assert result.coordinate_max_error == pytest.approx(0.5, abs=1e-9)
    assert result.hausdorff_max == pytest.approx(0.5, abs=1e-9)
    assert result.vertices == 4 + 6 + 8
    rows = {b.wit_id: b for b in result.buildings}
    assert rows["BLD_twin"].solids == 2 and rows["BLD_twin"].status == metrics.MATCHED
    assert rows["BLD_sq"].ssi == pytest.approx((9.7 * 9.6) / (200 - 9.7 * 9.6))
    moved = shapely.transform(shapes["ell"], lambda xy: xy + [0.3, 0.4])
    assert rows["BLD_ell"].ssi == pytest.approx(metrics.shape_similarity(shapes["ell"], moved))
    assert rows["BLD_lonely"].status == metrics.SOURCE_ONLY and math.isnan(rows["BLD_lonely"].ssi)
    assert rows["BLD_extra"].status == metrics.MODEL_ONLY and rows["BLD_extra"].model_area == pytest.approx(16)


def test_gml_read_in_small_parts_gives_the_same_buildings(shifted, monkeypatch, tmp_path):
    """The CityGML reader hands a building's finished children out in parts (its solid too) while the parser is
    still inside the building (here in the storeys after the solid)."""
    sources, _, written, _ = shifted
    gml = tmp_path / "storeys.gml"
    gml.write_text(Path(written).read_text(encoding="utf-8").replace(
        "</core:lod1Solid>", "</core:lod1Solid><bldg:storeysAboveGround>2</bldg:storeysAboveGround>"), encoding="utf-8")
    gml = str(gml)
    whole = metrics.geometry_metrics(gml, sources)
    monkeypatch.setattr(reader, "CHUNK_BYTES", 97)
    monkeypatch.setattr(reader, "MIN_PART", 1)
    parted = metrics.geometry_metrics(gml, sources)
    assert [(b.wit_id, b.status, b.solids, b.position_error, b.vertex_max_error, b.ssi) for b in parted.buildings] == [
        (b.wit_id, b.status, b.solids, b.position_error, b.vertex_max_error, b.ssi) for b in whole.buildings]
    assert (parted.model_count, parted.matched, parted.vertices) == (4, 3, 4 + 6 + 8)


def test_geometry_input_errors(shifted, tmp_path):
    sources = shifted[0]
    with pytest.raises(InputError, match="does not exist"):
        metrics.geometry_metrics(str(tmp_path / "none.gml"), sources)
    with pytest.raises(InputError, match=r"Layer 'buildings' .* lacks the field\(s\) wit_face of the LoD1 faces "
                                         r"\(wit:extrudebuildings\)"):
        metrics.geometry_metrics(sources, sources)
    bad = tmp_path / "bad.gml"
    bad.write_text("<core:CityModel xmlns:core='http://www.opengis.net/citygml/3.0'><oops></core:CityModel>")
    with pytest.raises(InputError, match="not well-formed"):
        metrics.geometry_metrics(str(bad), sources)
    empty = tmp_path / "empty.gml"
    empty.write_text("<core:CityModel xmlns:core='http://www.opengis.net/citygml/3.0'/>")
    with pytest.raises(InputError, match="no CityGML 3.0 bldg:Building"):
        metrics.geometry_metrics(str(empty), sources)



def test_the_metrics_process_measures_the_images_once_told(tmp_path):
    """The chain starts ``python -m wit_plugin.metrics --images-when-told`` beside the texture step: the orthoimage
    is measured while the texture folder does not exist yet, the images once a line on standard input says they are
    written; the same figures as measured at once. Its input's end without that line: the run stopped, one line
    and exit status 2, nothing written."""
    rng = np.random.default_rng(5)
    data = rng.integers(0, 256, (3, 200, 200)).astype(np.uint8)
    ortho = _write_raster(tmp_path / "ortho.tif", data, gt=(X0, 0.5, 0.0, Y0, 0.0, -0.5))
    roof = shapely.box(X0 + 20.13, Y0 - 70.21, X0 + 61.37, Y0 - 22.42)
    lod1 = tmp_path / "lod1.gpkg"
    extrude.write_solids(lod1, [extrude.Solid("BLD_1", 10.0, 9.0, "default", "default 3 m", None, None,
                                              extrude.solid_faces(roof, 10.0, 9.0), {})], _pyproj_5186())
    written, later = tmp_path / "tex", tmp_path / "later"
    texture_model(ortho, str(lod1), None, str(written), TextureConfig(image_format="PNG"))
    at_once = metrics.quality_report(str(tmp_path / "at_once" / "m.csv"), textures=str(written), ortho=ortho)
    command = [sys.executable, "-m", "wit_plugin.metrics", str(tmp_path / "told" / "m.csv"), "--textures", str(later),
               "--ortho", ortho, "--images-when-told"]
    process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=core_env())
    time.sleep(1.0)  # (the texture step still writes)
    shutil.copytree(written, later)
    out, err = process.communicate("go\n", timeout=120)
    assert process.returncode == 0, err
    assert json.loads(out)["csv"] == str(tmp_path / "told" / "m.csv")
    assert (tmp_path / "told" / "m.csv").read_bytes() == (tmp_path / "at_once" / "m.csv").read_bytes()
    assert at_once.value("texture_pixels") > 0 and at_once.texture.masked
    stopped = subprocess.run([*command[:3], str(tmp_path / "stopped" / "m.csv"), *command[4:]],
                             stdin=subprocess.DEVNULL, capture_output=True, text=True, env=core_env())
    assert stopped.returncode == 2 and stopped.stderr.splitlines()[-1] == RECORD + json.dumps({
        "refused": "The texture images were never written (the run stopped): nothing was measured.",
        "error": "InputError"})  # (the records before it: its progress)
    assert not (tmp_path / "stopped").exists()

def test_sample_pipeline_matches_sources(tmp_path):
    """generate_sample → preparevectors → extrudebuildings → writecitygml: the .gml sits on its sources."""
    sample = generate_sample(tmp_path / "sample", SampleConfig(radius_m=200, with_ortho=False))
    prepared = tmp_path / "prepared.gpkg"
    prepare_vectors(sample.buildings, None, None, StudyArea.circle(127.1020, 37.4876, 200, "EPSG:4737"), prepared)
    lod1 = tmp_path / "lod1.gpkg"
    extrude.extrude_buildings(prepared, sample.dem, lod1)
    gml = tmp_path / "city.gml"
    citygml.write_citygml(citygml.CityGMLInputs(lod1=str(lod1)), str(gml))
    result = metrics.geometry_metrics(str(gml), str(prepared))
    assert result.matched >= 100 and not result.model_only and not result.source_only
    assert result.placement_mean_error <= 0.01 and result.placement_max_error <= 0.01
    assert result.coordinate_mean_error <= 0.01 and result.coordinate_max_error <= 0.01
    assert result.ssi_mean >= 0.999 and result.ssi_min >= 0.999
    assert any(b.solids > 1 for b in result.buildings)  # multi-part footprints folded back

    out = tmp_path / "report"
    report = metrics.quality_report(str(out / "metrics.csv"), str(gml), str(prepared),
                                    output_html=str(out / "metrics.html"), output_gpkg=str(out / "metrics.gpkg"))
    assert sorted(p.name for p in out.iterdir()) == ["metrics.csv", "metrics.gpkg", "metrics.html",
                                                      "metrics_buildings.csv"]
    with open(out / "metrics.csv", encoding="utf-8-sig") as fh:
        rows = {r["metric"]: r for r in csv.DictReader(fh)}
    assert float(rows["ssi_mean"]["value"]) >= 0.999 and rows["ssi_mean"]["paper"] == "0.92"
    assert float(rows["placement_mean_error"]["paper"]) == 80
    assert report.value("buildings_matched") == result.matched
    ds = ogr.Open(str(out / "metrics.gpkg"))
    assert ds.GetLayerByName(metrics.BUILDINGS_LAYER).GetFeatureCount() == result.matched
    assert ds.GetLayerByName(metrics.METRICS_TABLE).GetFeatureCount() == len(report.rows)
    assert "Table 17" in (out / "metrics.html").read_text(encoding="utf-8")


# --- seam step ------------------------------------------------------------------------------------

def _tile(path, x0: float, width: int, gain: float) -> str:
    """A smooth RGB scene (the same ground everywhere), seen with a tile-specific exposure."""
    cols = np.arange(width) + x0
    rows = np.arange(200)[:, None]
    scene = 90 + 0.15 * cols[None, :] + 0.1 * rows
    data = np.stack([scene, 0.9 * scene, 0.8 * scene + 10]) * gain
    return _write_raster(path, np.clip(np.round(data), 0, 255).astype(np.uint8),
                         gt=(X0 + x0, 1.0, 0.0, Y0, 0.0, -1.0))


def test_seam_step_overwrite_vs_feather(tmp_path):
    tiles = [_tile(tmp_path / "a.tif", 0, 300, 0.85), _tile(tmp_path / "b.tif", 200, 300, 1.15)]
    overwrite, feather = str(tmp_path / "overwrite.tif"), str(tmp_path / "feather.tif")
    merge_rasters(tiles, overwrite, mode="overwrite")
    merge_rasters(tiles, feather, mode="feather", gain=True)
    index = tmp_path / "footprints.gpkg"
    georef.write_footprint_index(
        [georef.SheetResult(t, "0", 5000, georef.OK, "", t, metrics.seam._raster_bounds(t)[0]) for t in tiles]
        + [georef.SheetResult("skipped.tif")], index)
    hard = metrics.seam_metrics(overwrite, str(index))
    soft = metrics.seam_metrics(feather, tiles)
    assert {(e.tile, e.side) for e in hard.edges} == {(0, "east"), (1, "west")}  # the two edges in the overlap
    assert hard.pairs == soft.pairs == 2 * 198
    assert hard.step > 5 * soft.step
    assert hard.excess > 10 and abs(soft.excess) < 1
    assert metrics.seam_step(overwrite, tiles) == pytest.approx(hard.step)
    # overwrite: tile b covers a's east edge (no step there), its west edge shows the exposure jump
    west = next(e for e in hard.edges if e.side == "west")
    assert west.step == pytest.approx(0.3 * np.mean([1, 0.9, 0.8]) * (90 + 0.15 * 200 + 0.1 * 99.5) + 10 * 0.3 / 3,
                                      rel=0.05)
    with pytest.raises(InputError, match="two"):
        metrics.seam_metrics(overwrite, tiles[:1])


def test_quality_report_texture_and_seam_only(tmp_path):
    tiles = [_tile(tmp_path / "a.tif", 0, 300, 0.9), _tile(tmp_path / "b.tif", 200, 300, 1.1)]
    mosaic = str(tmp_path / "m.tif")
    merge_rasters(tiles, mosaic, mode="overwrite")
    out = tmp_path / "out"
    report = metrics.quality_report(str(out / "q.csv"), ortho=mosaic, mosaic=mosaic, footprints=tiles,
                                    output_html=str(out / "q.html"))
    assert sorted(p.name for p in out.iterdir()) == ["q.csv", "q.html"]
    assert report.value("seam_step") == pytest.approx(report.seam.step)
    assert report.value("ortho_pixels") == 500 * 200
    with pytest.raises(InputError, match="both"):
        metrics.quality_report(str(out / "x.csv"), mosaic=mosaic)
    with pytest.raises(InputError, match="Nothing to measure"):
        metrics.quality_report(str(out / "x.csv"))
