"""wit:georeferencemapsheets core: unreferenced NGII-named TIFs → georeferenced GeoTIFF/VRT + index."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal, ogr, osr

from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.mosaic import georef

W, H = 200, 250
# sheet 37713074's envelope + 50 m: the extent of NGII's real orthoimage of that sheet (../shared/data)
ULLR_37713074 = (206619.31, 497391.01, 208945.34, 494514.49)


def make_tif(path: Path, seed: int = 0, bands: int = 3) -> np.ndarray:
    """A plain TIFF without geotransform or CRS, like NGII delivers; returns its pixels."""
    pixels = np.random.default_rng(seed).integers(0, 256, (bands, H, W), dtype=np.uint8)
    ds = gdal.GetDriverByName("GTiff").Create(str(path), W, H, bands, gdal.GDT_Byte,
                                              ["PHOTOMETRIC=RGB"] if bands == 3 else [])
    ds.WriteRaster(0, 0, W, H, pixels.tobytes())
    ds = None
    check = gdal.Open(str(path))
    assert check.GetGeoTransform(can_return_null=True) is None and not check.GetProjection()
    return pixels


def read(path: str) -> np.ndarray:
    ds = gdal.Open(path)
    return ds.ReadAsArray()


@pytest.fixture
def inputs(tmp_path) -> Path:
    folder = tmp_path / "입력 영상"
    folder.mkdir()
    make_tif(folder / "(B060)정사영상_2022_37713074.tif", seed=1)
    make_tif(folder / "37612093.tif", seed=2)
    make_tif(folder / "정사영상_2022.tif", seed=3)  # no sheet number
    make_tif(folder / "ortho_37709101.tif", seed=4)  # cell 101 at 1:5,000
    make_tif(folder / "copy_of_37612093.tiff", seed=5)  # duplicate sheet
    (folder / "37709005.tif").write_bytes(os.urandom(4096))  # not a TIFF at all
    (folder / "readme.txt").write_text("not an image")
    return folder


def by_name(results):
    return {Path(r.source).name: r for r in results}


def test_list_tifs(inputs, tmp_path):
    names = [Path(p).name for p in georef.list_tifs(inputs)]
    assert names == sorted(names) and len(names) == 6 and "readme.txt" not in names
    one = str(inputs / "37612093.tif")
    assert georef.list_tifs([one, inputs]) == [one] + [p for p in georef.list_tifs(inputs) if p != one]
    with pytest.raises(InputError, match="does not exist"):
        georef.list_tifs(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="No .tif"):
        georef.list_tifs(tmp_path / "empty")


def test_geotiff_mode(inputs, tmp_path):
    out = tmp_path / "out"
    messages = []

    class Recorder(Feedback):
        def warning(self, message):
            messages.append(message)

    results = georef.georeference_sheets(georef.list_tifs(inputs), out, feedback=Recorder())
    r = by_name(results)
    assert [x.status for x in results].count("ok") == 2

    ok = r["(B060)정사영상_2022_37713074.tif"]
    assert (ok.status, ok.sheet, ok.scale, ok.reason) == ("ok", "37713074", 5000, "")
    assert ok.output == str(out / "37713074.tif")
    ds = gdal.Open(ok.output)
    ulx, xres, rx, uly, ry, yres = ds.GetGeoTransform()
    assert (rx, ry) == (0, 0)
    assert (ulx, uly, ulx + W * xres, uly + H * yres) == pytest.approx(ULLR_37713074, abs=0.01)
    assert osr.SpatialReference(ds.GetProjection()).GetAuthorityCode(None) == "5186"
    assert ds.GetRasterBand(1).GetBlockSize() == [512, 512]
    assert ds.GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE") == "DEFLATE"
    assert np.array_equal(ds.ReadAsArray(), read(ok.source))
    assert ok.bounds == pytest.approx((206619.31, 494514.49, 208945.34, 497391.01), abs=0.01)

    other = r["37612093.tif"]
    gt = gdal.Open(other.output).GetGeoTransform()
    # 126.800–126.825°E, 37.250–37.275°N in EPSG:5186: x 182256.11–184479.23, y 516772.30–519551.27, + 50 m
    assert (gt[0], gt[3], gt[1] * W, -gt[5] * H) == pytest.approx(
        (182206.11, 519601.27, 184479.23 - 182256.11 + 100, 519551.27 - 516772.30 + 100), abs=0.01)

    assert r["정사영상_2022.tif"].status == "skipped"
    assert "no 5–9 digit sheet number" in r["정사영상_2022.tif"].reason
    assert r["ortho_37709101.tif"].status == "skipped"
    assert "cell 101 out of range 001–100 at 1:5,000" in r["ortho_37709101.tif"].reason
    dup = r["copy_of_37612093.tiff"]
    assert (dup.status, dup.sheet, dup.output) == ("skipped", "37612093", None)
    assert "already comes from" in dup.reason and "37612093.tif" in dup.reason
    bad = r["37709005.tif"]
    assert (bad.status, bad.sheet, bad.output) == ("failed", "37709005", None)
    assert "Cannot open the orthoimage" in bad.reason and "not recognized" in bad.reason
    assert len(messages) == 4
    assert sorted(os.listdir(out)) == ["37612093.tif", "37713074.tif"]


def test_vrt_mode_points_at_source_pixels(inputs, tmp_path):
    out = tmp_path / "vrt out"
    source = str(inputs / "(B060)정사영상_2022_37713074.tif")
    (result,) = georef.georeference_sheets([source], out, fmt="VRT")
    assert result.status == "ok" and result.output == str(out / "37713074.vrt")
    text = Path(result.output).read_text(encoding="utf-8")
    assert '<SourceFilename relativeToVRT="1">../입력 영상/(B060)정사영상_2022_37713074.tif</SourceFilename>' in text
    ds = gdal.Open(result.output)
    assert Path(source).resolve() in [Path(f).resolve() for f in ds.GetFileList()]
    ulx, xres, _, uly, _, yres = ds.GetGeoTransform()
    assert (ulx, uly, ulx + W * xres, uly + H * yres) == pytest.approx(ULLR_37713074, abs=0.01)
    assert osr.SpatialReference(ds.GetProjection()).GetAuthorityCode(None) == "5186"
    assert np.array_equal(ds.ReadAsArray(), read(source))
    assert sorted(os.listdir(out)) == ["37713074.vrt"]


def test_other_crs_and_margin(inputs, tmp_path):
    source = str(inputs / "37612093.tif")
    (result,) = georef.georeference_sheets([source], tmp_path / "o", target_crs="EPSG:5179", margin=0)
    ds = gdal.Open(result.output)
    assert osr.SpatialReference(ds.GetProjection()).GetAuthorityCode(None) == "5179"
    gt = ds.GetGeoTransform()
    assert gt[0] == pytest.approx(result.bounds[0], abs=1e-6) and gt[3] == pytest.approx(result.bounds[3], abs=1e-6)
    assert 900_000 < gt[0] < 1_000_000 and 1_900_000 < gt[3] < 2_000_000  # UTM-K, west of 127.5°E


def test_unwritable_output_folder(inputs, tmp_path):
    blocker = tmp_path / "a file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="not writable"):
        georef.georeference_sheets(georef.list_tifs(inputs), blocker / "out")
    if os.geteuid() != 0:  # root ignores permission bits
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        with pytest.raises(InputError, match="not writable"):
            georef.georeference_sheets(georef.list_tifs(inputs), locked)


def test_bad_parameters(inputs, tmp_path):
    tifs = georef.list_tifs(inputs)
    with pytest.raises(InputError, match="Unknown output format"):
        georef.georeference_sheets(tifs, tmp_path / "o", fmt="PNG")
    with pytest.raises(InputError, match="margin"):
        georef.georeference_sheets(tifs, tmp_path / "o", margin=-1)
    with pytest.raises(InputError, match="Unknown coordinate reference system"):
        georef.georeference_sheets(tifs, tmp_path / "o", target_crs="EPSG:nonsense")


def test_source_in_output_folder_is_not_overwritten(tmp_path):
    pixels = make_tif(tmp_path / "37713074.tif")
    with pytest.raises(InputError, match=r"\(1 skipped, 0 failed\):\n  37713074.tif: skipped, the output .* would "
                                         "replace the source"):
        georef.georeference_sheets([str(tmp_path / "37713074.tif")], tmp_path)
    assert np.array_equal(read(str(tmp_path / "37713074.tif")), pixels)


class CancelAfterFirst(Feedback):
    """Cancels once the first file has been written (reported through ``info``)."""

    def __init__(self):
        self.done = False
        self.values = []

    def progress(self, percent):
        self.values.append(percent)

    def info(self, message):
        self.done = True

    def is_canceled(self):
        return self.done


@pytest.mark.parametrize("fmt", ["GTiff", "VRT"])
def test_cancel_leaves_no_partial_output(tmp_path, fmt):
    folder = tmp_path / "in"
    folder.mkdir()
    make_tif(folder / "37713074.tif")
    make_tif(folder / "37612093.tif")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("earlier work")
    feedback = CancelAfterFirst()
    with pytest.raises(CanceledError):
        georef.georeference_sheets(georef.list_tifs(folder), out, fmt=fmt, feedback=feedback)
    assert os.listdir(out) == ["keep.txt"]
    assert 50 <= max(feedback.values) < 100


def test_cancel_inside_translate(tmp_path):
    make_tif(tmp_path / "37713074.tif")

    class CancelDuringCopy(Feedback):
        def __init__(self):
            self.calls = 0

        def is_canceled(self):
            self.calls += 1
            return self.calls > 1  # the check before the file passes, GDAL's callback stops the copy

    with pytest.raises(CanceledError):
        georef.georeference_sheets([str(tmp_path / "37713074.tif")], tmp_path / "out", feedback=CancelDuringCopy())
    assert os.listdir(tmp_path / "out") == []


def test_footprint_index(inputs, tmp_path):
    results = georef.georeference_sheets(georef.list_tifs(inputs), tmp_path / "out")
    index = tmp_path / "index" / "footprints.gpkg"
    georef.write_footprint_index(results, index, "EPSG:5186")
    assert sorted(os.listdir(index.parent)) == ["footprints.gpkg"]
    ds = ogr.Open(str(index))
    layer = ds.GetLayer(0)
    assert layer.GetName() == "footprints" and layer.GetFeatureCount() == 6
    assert layer.GetSpatialRef().GetAuthorityCode(None) == "5186"
    rows = {Path(f["source"]).name: f for f in layer}
    ok = rows["(B060)정사영상_2022_37713074.tif"]
    assert (ok["sheet"], ok["scale"], ok["status"], ok["reason"]) == ("37713074", 5000, "ok", "")
    assert ok["output"] == str(tmp_path / "out" / "37713074.tif")
    xmin, xmax, ymin, ymax = ok.GetGeometryRef().GetEnvelope()
    assert (xmin, ymax, xmax, ymin) == pytest.approx(ULLR_37713074, abs=0.01)
    assert ok.GetGeometryRef().GetArea() == pytest.approx((xmax - xmin) * (ymax - ymin))
    skipped = rows["정사영상_2022.tif"]
    assert skipped["status"] == "skipped" and skipped["sheet"] is None and skipped.GetGeometryRef() is None
    assert "no 5–9 digit sheet number" in skipped["reason"]
    failed = rows["37709005.tif"]
    assert failed["status"] == "failed" and failed["output"] is None and failed.GetGeometryRef() is not None
    assert {f["status"] for f in rows.values()} == {"ok", "skipped", "failed"}
