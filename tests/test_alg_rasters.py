"""wit:georeferencemapsheets and wit:mergetiles through Processing, as a toolbox user runs them."""
from __future__ import annotations

import numpy as np
import pytest
from osgeo import gdal, osr
from qgis.core import QgsProcessingException, QgsProcessingFeedback, QgsVectorLayer


def _unreferenced_tif(path, width=200, height=250, value=100):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), width, height, 3, gdal.GDT_Byte)
    for band in range(3):
        ds.GetRasterBand(band + 1).WriteArray(np.full((height, width), value + band, np.uint8))
    ds = None


def test_georeference_then_merge_through_processing(tmp_path, run_algorithm):
    sources = tmp_path / "ngii"
    sources.mkdir()
    _unreferenced_tif(sources / "(B060)정사영상_2022_37709005.tif", value=100)
    _unreferenced_tif(sources / "(B060)정사영상_2022_37709004.tif", value=140)
    (sources / "notes_2022.tif").write_bytes(b"no sheet number here")
    result = run_algorithm("wit:georeferencemapsheets", {
        "INPUT": [str(sources)], "OUTPUT": str(tmp_path / "geo"),
        "OUTPUT_INDEX": str(tmp_path / "index.gpkg")})
    assert (result["GEOREFERENCED"], result["SKIPPED"], result["FAILED"]) == (2, 1, 0)
    ds = gdal.Open(str(tmp_path / "geo" / "37709005.tif"))
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    # SPEC §3 worked example: x 208842.55–211056.87, y 541734.15–544511.46, plus the 50 m margin
    assert x0 == pytest.approx(208842.55 - 50, abs=0.01)
    assert y0 == pytest.approx(544511.46 + 50, abs=0.01)
    assert x0 + 200 * dx == pytest.approx(211056.87 + 50, abs=0.01)
    assert y0 + 250 * dy == pytest.approx(541734.15 - 50, abs=0.01)
    assert osr.SpatialReference(ds.GetProjection()).GetAuthorityCode(None) == "5186"
    index = QgsVectorLayer(result["OUTPUT_INDEX"], "index", "ogr")
    rows = {f["sheet"] or f["source"].rsplit("/", 1)[-1]: (f["status"], f["reason"]) for f in index.getFeatures()}
    assert rows["37709005"][0] == "ok" and rows["37709004"][0] == "ok"
    assert rows["notes_2022.tif"][0] == "skipped" and "sheet number" in rows["notes_2022.tif"][1]

    merged = run_algorithm("wit:mergetiles", {
        "INPUT": result["OUTPUT_LAYERS"], "OVERLAP": 1, "GAIN": False,
        "OUTPUT": str(tmp_path / "mosaic.tif")})
    mosaic = gdal.Open(merged["OUTPUT"])
    assert mosaic.RasterCount == 3
    assert mosaic.GetGeoTransform()[0] == pytest.approx(x0 - (x0 - gdal.Open(str(tmp_path / "geo" / "37709004.tif")).GetGeoTransform()[0]))
    assert merged["BLENDED_PIXELS"] > 0


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
        processing.run("wit:mergetiles", {"INPUT": tiles, "OUTPUT": str(out / "m.tif")})
    assert "Traceback" not in str(error.value)
    assert list(out.iterdir()) == []
    feedback = _Warnings()
    result = processing.run("wit:mergetiles", {"INPUT": tiles, "MAX_EMPTY": 95, "OUTPUT": str(out / "m.tif")},
                            feedback=feedback)
    ds = gdal.Open(result["OUTPUT"])
    assert (ds.RasterXSize, ds.RasterYSize) == (520, 20)
    assert any("about 92% of it is empty" in w for w in feedback.warnings), feedback.warnings
