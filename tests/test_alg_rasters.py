"""The raster steps through Processing, as a toolbox user runs them: georeference, merge, and that no
raster-reading algorithm writes beside its inputs."""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal, osr
from qgis.core import QgsProcessingException, QgsProcessingFeedback, QgsVectorLayer

pytestmark = pytest.mark.qgis_facing


def _unreferenced_tif(path, width=200, height=250, value=100):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), width, height, 3, gdal.GDT_Byte)
    for band in range(3):
        ds.GetRasterBand(band + 1).WriteArray(np.full((height, width), value + band, np.uint8))
    ds = None


def test_georeference_then_merge_through_processing(tmp_path, run_algorithm):
    import processing

    sources = tmp_path / "ngii"
    sources.mkdir()
    _unreferenced_tif(sources / "(B060)정사영상_2022_37709005.tif", value=100)
    _unreferenced_tif(sources / "(B060)정사영상_2022_37709004.tif", value=140)
    (sources / "notes_2022.tif").write_bytes(b"no sheet number here")
    (sources / "(B060)정사영상_2022_37709006.tif").write_bytes(b"")  # a failed copy: partial success
    feedback = _Warnings()
    result = processing.run("wit:georeferencemapsheets", {
        "INPUT": [str(sources)], "OUTPUT": str(tmp_path / "geo"),
        "OUTPUT_INDEX": str(tmp_path / "index.gpkg")}, feedback=feedback)
    assert (result["GEOREFERENCED"], result["SKIPPED"], result["FAILED"]) == (2, 1, 1)
    assert any(w.startswith("Failed ") and "37709006.tif is empty (0 bytes)" in w for w in feedback.warnings)
    ds = gdal.Open(str(tmp_path / "geo" / "37709005.tif"))
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    # sheet 37709005 (127.100–127.125°E, 37.475–37.500°N on EPSG:4737) projected to EPSG:5186:
    # x 208842.55–211056.87, y 541734.15–544511.46, plus the 50 m margin NGII's orthoimages have
    assert x0 == pytest.approx(208842.55 - 50, abs=0.01)
    assert y0 == pytest.approx(544511.46 + 50, abs=0.01)
    assert x0 + 200 * dx == pytest.approx(211056.87 + 50, abs=0.01)
    assert y0 + 250 * dy == pytest.approx(541734.15 - 50, abs=0.01)
    assert osr.SpatialReference(ds.GetProjection()).GetAuthorityCode(None) == "5186"
    index = QgsVectorLayer(result["OUTPUT_INDEX"], "index", "ogr")
    rows = {f["sheet"] or f["source"].rsplit("/", 1)[-1]: (f["status"], f["reason"]) for f in index.getFeatures()}
    assert rows["37709005"][0] == "ok" and rows["37709004"][0] == "ok"
    assert rows["notes_2022.tif"][0] == "skipped" and "sheet number" in rows["notes_2022.tif"][1]
    assert rows["37709006"][0] == "failed" and "is empty (0 bytes)" in rows["37709006"][1]

    merged = run_algorithm("wit:mergerasters", {
        "INPUT": result["OUTPUT_LAYERS"], "OVERLAP": 1, "GAIN": False,
        "OUTPUT": str(tmp_path / "mosaic.tif")})
    mosaic = gdal.Open(merged["OUTPUT"])
    assert mosaic.RasterCount == 3
    west_sheet_x0 = gdal.Open(str(tmp_path / "geo" / "37709004.tif")).GetGeoTransform()[0]
    assert mosaic.GetGeoTransform()[0] == pytest.approx(x0 - (x0 - west_sheet_x0))
    assert merged["BLENDED_PIXELS"] > 0

    box = (x0 + 1000.0, y0 - 2000.0, x0 + 1600.0, y0 - 1000.0)  # in 37709005's part of the mosaic
    clipped = run_algorithm("wit:mergerasters", {
        "INPUT": result["OUTPUT_LAYERS"], "OVERLAP": 1, "GAIN": False,
        "EXTENT": f"{box[0]},{box[2]},{box[1]},{box[3]} [EPSG:5186]", "OUTPUT": str(tmp_path / "clipped.tif")})
    part = gdal.Open(clipped["OUTPUT"])
    cx0, cdx, _, cy0, _, cdy = part.GetGeoTransform()
    assert cx0 <= box[0] < cx0 + cdx and cy0 + cdy < box[3] <= cy0  # the extent, on the mosaic's grid
    mx0, _, _, my0, _, _ = mosaic.GetGeoTransform()
    assert (part.RasterXSize, part.RasterYSize) == (
        math.ceil((box[2] - mx0) / cdx) - math.floor((box[0] - mx0) / cdx),
        math.ceil((box[1] - my0) / cdy) - math.floor((box[3] - my0) / cdy))
    col, row = round((cx0 - mosaic.GetGeoTransform()[0]) / cdx), round((cy0 - mosaic.GetGeoTransform()[3]) / cdy)
    np.testing.assert_array_equal(part.ReadAsArray(), mosaic.ReadAsArray(col, row, part.RasterXSize,
                                                                          part.RasterYSize))


def test_the_first_id_of_merge_rasters_still_runs_and_is_marked_deprecated(tmp_path, run_algorithm, wit_provider):
    """wit:mergetiles was merge rasters' id until 0.2: saved models and scripts that call it get the same
    mosaic, and QGIS hides it from the toolbox and the modeler (the Deprecated flag)."""
    from qgis.core import QgsApplication
    from wit_citymodel.processing_provider.qgis_compat import AlgorithmFlag

    tiles = [_tile(tmp_path / "a.tif", 0, 0), _tile(tmp_path / "b.tif", 150, 0)]
    old = run_algorithm("wit:mergetiles", {"INPUT": tiles, "OUTPUT": str(tmp_path / "old.tif")})
    new = run_algorithm("wit:mergerasters", {"INPUT": tiles, "OUTPUT": str(tmp_path / "new.tif")})
    np.testing.assert_array_equal(gdal.Open(old["OUTPUT"]).ReadAsArray(), gdal.Open(new["OUTPUT"]).ReadAsArray())
    assert old["BLENDED_PIXELS"] == new["BLENDED_PIXELS"] > 0
    registry = QgsApplication.processingRegistry()
    first, renamed = registry.algorithmById("wit:mergetiles"), registry.algorithmById("wit:mergerasters")
    assert first.flags() & AlgorithmFlag.Deprecated and not renamed.flags() & AlgorithmFlag.Deprecated
    assert renamed.displayName() == "Merge rasters (WIT seam feathering)"


def test_georeference_rejects_unwritable_output_with_a_message(tmp_path, run_algorithm):
    sources = tmp_path / "ngii"
    sources.mkdir()
    _unreferenced_tif(sources / "37709005.tif")
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(QgsProcessingException, match="not writable"):
        run_algorithm("wit:georeferencemapsheets", {
            "INPUT": [str(sources)], "OUTPUT": str(blocker / "out"),
            "OUTPUT_INDEX": str(tmp_path / "index.gpkg")})


def _tile(path, x0, y0, size=20, pixel=10.0):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), size, size, 3, gdal.GDT_Byte)
    ds.SetGeoTransform((x0, pixel, 0, y0, 0, -pixel))
    ds.SetProjection(_epsg5186())
    for band in range(3):
        ds.GetRasterBand(band + 1).WriteArray(np.full((size, size), 60 + 40 * band, np.uint8))
    ds = None
    return str(path)


def _epsg5186():
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    return srs.ExportToWkt()


class _Warnings(QgsProcessingFeedback):
    def __init__(self):
        super().__init__()
        self.warnings = []

    def pushWarning(self, warning):  # noqa: N802
        self.warnings.append(warning)
        super().pushWarning(warning)


def test_sparse_mosaic_is_refused_before_writing_unless_the_limit_is_raised(tmp_path, wit_provider):
    """Two 200 m tiles 5 km apart: a 520 × 20 px mosaic 92 % empty is refused (nothing written) under
    the default 90 % limit; raising the advanced limit writes it, with a warning."""
    import processing

    tiles = [_tile(tmp_path / "west.tif", 200000.0, 550000.0), _tile(tmp_path / "east.tif", 205000.0, 550000.0)]
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(QgsProcessingException, match=r"520 × 20 px.*about 92% of it would be empty.*raise the "
                                                     r"maximum empty share \(now 90%\)") as error:
        processing.run("wit:mergerasters", {"INPUT": tiles, "OUTPUT": str(out / "m.tif")})
    assert "Traceback" not in str(error.value)
    assert list(out.iterdir()) == []
    feedback = _Warnings()
    result = processing.run("wit:mergerasters", {"INPUT": tiles, "MAX_EMPTY": 95, "OUTPUT": str(out / "m.tif")},
                            feedback=feedback)
    ds = gdal.Open(result["OUTPUT"])
    assert (ds.RasterXSize, ds.RasterYSize) == (520, 20)
    assert any("about 92% of it is empty" in w for w in feedback.warnings), feedback.warnings


def test_an_extent_the_tiles_do_not_meet_is_refused_before_writing(tmp_path, wit_provider):
    """EXTENT 10 km away from the tiles: one clear message naming both, no output, inputs untouched."""
    import processing

    tiles = [_tile(tmp_path / "a.tif", 200000.0, 550000.0), _tile(tmp_path / "b.tif", 200150.0, 550000.0)]
    before = {t: Path(t).read_bytes() for t in tiles}
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(QgsProcessingException, match=r"do not meet the extent x 210000\.0–210500\.0") as error:
        processing.run("wit:mergerasters", {"INPUT": tiles, "EXTENT": "210000,210500,560000,560500 [EPSG:5186]",
                                          "OUTPUT": str(out / "m.tif")})
    assert "Traceback" not in str(error.value)
    assert list(out.iterdir()) == [] and {t: Path(t).read_bytes() for t in tiles} == before


def _listing(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


READERS = {
    "mergerasters": ("wit:mergerasters", lambda r, o: {"INPUT": [r["ortho"]], "OUTPUT": str(o / "m.tif")}),
    "buildcolorstore": ("wit:buildcolorstore", lambda r, o: {"INPUT": r["ortho"], "OUTPUT": str(o / "c.gpkg")}),
    "wittexture": ("wit:wittexture", lambda r, o: {"ORTHO": r["ortho"], "LOD1": r["lod1"], "OUTPUT": str(o / "tex")}),
    "triangulateterrain": ("wit:triangulateterrain", lambda r, o: {
        "DEM": r["dem"], "AREA": r["footprints"], "OUTPUT": str(o / "tin.gpkg")}),
    "extrudebuildings": ("wit:extrudebuildings", lambda r, o: {
        "BUILDINGS": r["footprints"], "DEM": r["dem"], "OUTPUT": str(o / "lod1.gpkg")}),
    "qualitymetrics": ("wit:qualitymetrics", lambda r, o: {"ORTHO": r["ortho"], "OUTPUT": str(o / "q.csv")}),
}


@pytest.mark.parametrize("case", sorted(READERS))
def test_reading_rasters_writes_nothing_beside_them(case, real_rasters, tmp_path, run_algorithm):
    """QGIS computes statistics when it loads a raster parameter, and GDAL saved them as .aux.xml
    beside the inputs: every raster-reading algorithm now leaves the input folder as it was."""
    algorithm, parameters = READERS[case]
    folder = tmp_path / "inputs"
    shutil.copytree(real_rasters["folder"], folder)
    inputs = {**real_rasters, "ortho": str(folder / "ortho.tif"), "dem": str(folder / "dem.tif")}
    before = _listing(folder)
    assert sorted(before) == ["dem.tif", "ortho.tif"]
    run_algorithm(algorithm, parameters(inputs, tmp_path))
    assert _listing(folder) == before


def test_georeferencing_writes_nothing_beside_the_sources(real_rasters, tmp_path, run_algorithm):
    sources = tmp_path / "ngii"
    sources.mkdir()
    (sources / "(B060)정사영상_2022_37709005.tif").write_bytes(Path(real_rasters["ortho"]).read_bytes())
    before = _listing(sources)
    result = run_algorithm("wit:georeferencemapsheets", {"INPUT": [str(sources)], "OUTPUT": str(tmp_path / "geo")})
    assert result["GEOREFERENCED"] == 1
    run_algorithm("wit:mergerasters", {"INPUT": result["OUTPUT_LAYERS"], "OUTPUT": str(tmp_path / "m.tif")})
    assert _listing(sources) == before
    assert sorted(p.name for p in (tmp_path / "geo").iterdir()) == ["37709005.tif"]
