"""wit:mergetiles core: gdal_merge-exact grid and pixels, feather + gain seams, NoData, cancel."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal, osr
from osgeo_utils import gdal_merge

from wit_plugin import mosaic
from wit_plugin.errors import CanceledError, InputError
from wit_plugin.feedback import Feedback

EPSG = 5186
ORIGIN = (200000.0, 500000.0)


class Recorder(Feedback):
    """Keeps warnings; cancels after ``cancel_after`` progress reports (None: never)."""

    def __init__(self, cancel_after: int | None = None):
        self.warnings: list[str] = []
        self.reports = 0
        self.cancel_after = cancel_after

    def progress(self, percent: float) -> None:
        self.reports += 1

    def is_canceled(self) -> bool:
        return self.cancel_after is not None and self.reports >= self.cancel_after

    def warning(self, message: str) -> None:
        self.warnings.append(message)


def write_tif(path: Path, data: np.ndarray, origin: tuple[float, float], pixel: float | tuple[float, float] = 2.0,
              nodata: float | None = None, epsg: int | None = EPSG) -> str:
    """A GeoTIFF from (bands, rows, cols) or (rows, cols) ``data``; RGB if 3 bands of uint8."""
    data = data if data.ndim == 3 else data[None]
    px, py = (pixel, pixel) if isinstance(pixel, (int, float)) else pixel
    gtype = {np.dtype(np.uint8): gdal.GDT_Byte, np.dtype(np.float32): gdal.GDT_Float32}[data.dtype]
    options = ["PHOTOMETRIC=RGB"] if data.shape[0] == 3 and data.dtype == np.uint8 else []
    ds = gdal.GetDriverByName("GTiff").Create(str(path), data.shape[2], data.shape[1], data.shape[0], gtype, options)
    ds.SetGeoTransform((origin[0], px, 0.0, origin[1], 0.0, -py))
    if epsg:
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(epsg)
        ds.SetProjection(srs.ExportToWkt())
    for b in range(data.shape[0]):
        if nodata is not None:
            ds.GetRasterBand(b + 1).SetNoDataValue(nodata)
        ds.GetRasterBand(b + 1).WriteArray(data[b])
    ds = None
    return str(path)


def read(path: str) -> tuple[np.ndarray, gdal.Dataset]:
    ds = gdal.Open(str(path))
    return ds.ReadAsArray().reshape(ds.RasterCount, ds.RasterYSize, ds.RasterXSize), ds


def run_gdal_merge(inputs: list[str], output: Path) -> str:
    gdal_merge.main(["gdal_merge.py", "-q", "-o", str(output), *inputs])
    return str(output)


def coverage(report: mosaic.MergeReport) -> np.ndarray:
    """How many input rectangles cover each output pixel."""
    count = np.zeros((report.height, report.width), int)
    for x, y, w, h in report.tile_windows:
        count[y:y + h, x:x + w] += 1
    return count


def textured(rng: np.random.Generator, bands: int, rows: int, cols: int, dtype=np.uint8) -> np.ndarray:
    return rng.integers(1, 255, (bands, rows, cols)).astype(dtype)


def test_grid_and_pixels_match_gdal_merge_for_non_aligned_origins(tmp_path):
    """Origins off the first tile's grid by 0.3, 0.6 and 0.95 px: gdal_merge's placement, bit for bit."""
    rng = np.random.default_rng(1)
    px = 2.0
    inputs = [
        write_tif(tmp_path / "a.tif", textured(rng, 3, 40, 50), ORIGIN, px),
        write_tif(tmp_path / "b.tif", textured(rng, 3, 37, 45), (ORIGIN[0] + 41.3 * px, ORIGIN[1] - 12.6 * px), px),
        write_tif(tmp_path / "c.tif", textured(rng, 3, 30, 33), (ORIGIN[0] - 20.95 * px, ORIGIN[1] - 30.3 * px), px),
    ]
    expected, gm = read(run_gdal_merge(inputs, tmp_path / "gdal_merge.tif"))
    feedback = Recorder()
    report = mosaic.merge_tiles(inputs, str(tmp_path / "over.tif"), mode="overwrite", feedback=feedback)
    over, ds = read(report.output)
    assert ds.GetGeoTransform() == gm.GetGeoTransform()
    assert (ds.RasterXSize, ds.RasterYSize) == (gm.RasterXSize, gm.RasterYSize) == (report.width, report.height)
    np.testing.assert_array_equal(over, expected)  # overwrite is gdal_merge everywhere
    assert len([w for w in feedback.warnings if "off the output grid" in w]) == 3  # grid origin: c.x, a.y

    report = mosaic.merge_tiles(inputs, str(tmp_path / "feather.tif"), mode="feather", gain=False)
    feather, ds = read(report.output)
    assert ds.GetGeoTransform() == gm.GetGeoTransform()
    single = coverage(report) <= 1
    assert single.sum() > 0.8 * single.size
    np.testing.assert_array_equal(feather[:, single], expected[:, single])
    assert not np.array_equal(feather, expected)  # the overlaps were blended
    assert report.blended_pixels == int((coverage(report) >= 2).sum())


def seam_tiles(tmp_path: Path) -> tuple[list[str], np.ndarray]:
    """A smooth RGB scene that varies only north–south, cut into two tiles overlapping by 60 columns;
    the second tile is 20 % brighter. Returns the tile paths and the scene."""
    rows, cols, first_w, second_x = 80, 340, 200, 140
    y = np.arange(rows, dtype=np.float64)[:, None]
    scene = np.stack([np.repeat(90 + 30 * np.sin(y / 13.0) + 12 * b, cols, axis=1) for b in range(3)])
    tile1 = np.rint(scene[:, :, :first_w]).astype(np.uint8)
    tile2 = np.rint(scene[:, :, second_x:] * 1.2).astype(np.uint8)
    return [write_tif(tmp_path / "t1.tif", tile1, ORIGIN),
            write_tif(tmp_path / "t2.tif", tile2, (ORIGIN[0] + second_x * 2.0, ORIGIN[1]))], scene


def seam_step(image: np.ndarray) -> float:
    """Largest mean absolute colour step between neighbouring columns (the scene itself has none)."""
    return float(np.abs(np.diff(image.astype(float), axis=2)).mean(axis=(0, 1)).max())


def tone_difference(image: np.ndarray, scene: np.ndarray) -> float:
    """|brightness ratio to the scene over tile 2 alone − the same over tile 1 alone| (0: one tone)."""
    ratio1 = image[:, :, :140].mean() / scene[:, :, :140].mean()
    ratio2 = image[:, :, 200:].mean() / scene[:, :, 200:].mean()
    return abs(ratio2 - ratio1)


def test_feather_and_gain_remove_the_seam(tmp_path):
    inputs, scene = seam_tiles(tmp_path)
    over, _ = read(mosaic.merge_tiles(inputs, str(tmp_path / "over.tif"), mode="overwrite").output)
    report = mosaic.merge_tiles(inputs, str(tmp_path / "wit.tif"), mode="feather")
    wit, _ = read(report.output)
    assert report.gain
    assert seam_step(over) > 15
    assert seam_step(wit) * 5 <= seam_step(over)
    assert tone_difference(over, scene) == pytest.approx(0.2, abs=0.01)
    assert tone_difference(wit, scene) * 5 <= tone_difference(over, scene)
    g1, g2 = np.array(report.gains)
    np.testing.assert_allclose(g1 / g2, 1.2, rtol=0.01)  # the brighter tile is toned down relative
    np.testing.assert_allclose(g1 * g2, 1.0, rtol=1e-9)  # geometric mean 1


def test_gains_chain_tiles_and_leave_an_isolated_tile_alone(tmp_path):
    """Three tiles in a row, each 10 % brighter than the last, and one far away: the chain's gains
    undo the steps with geometric mean 1; the lone tile keeps gain 1."""
    grey = np.full((20, 30), 100.0, np.float32)
    inputs = [write_tif(tmp_path / f"t{k}.tif", grey * 1.1 ** k, (ORIGIN[0] + k * 40.0, ORIGIN[1])) for k in range(3)]
    inputs.append(write_tif(tmp_path / "far.tif", grey * 3, (ORIGIN[0] + 400.0, ORIGIN[1])))
    report = mosaic.merge_tiles(inputs, str(tmp_path / "m.tif"))
    gains = np.array(report.gains)[:, 0]
    np.testing.assert_allclose(gains[:3] * 1.1 ** np.arange(3), 1.1, rtol=1e-6)  # 1.1: their geometric mean
    assert np.prod(gains[:3]) == pytest.approx(1.0, rel=1e-9)
    assert gains[3] == 1.0
    out, _ = read(report.output)
    np.testing.assert_allclose(out[0, :, :70], 110.0, rtol=1e-5)  # one tone along the chain (70 px)


def test_feather_without_gain_keeps_single_coverage_pixels_and_weights_by_edge_distance(tmp_path):
    inputs, _ = seam_tiles(tmp_path)
    t1, _ = read(inputs[0])
    t2, _ = read(inputs[1])
    out, _ = read(mosaic.merge_tiles(inputs, str(tmp_path / "f.tif"), gain=False).output)
    np.testing.assert_array_equal(out[:, :, :140], t1[:, :, :140])
    np.testing.assert_array_equal(out[:, :, 200:], t2[:, :, 60:])
    row, col = 40, 150  # 10 columns into the overlap: centre 50.5 px from t1's right edge, 10.5 from t2's left
    w1 = min(200 - (col + 0.5), row + 0.5, 80 - (row + 0.5))
    w2 = min(col + 0.5 - 140, row + 0.5, 80 - (row + 0.5))
    v = (w1 * t1[:, row, col].astype(float) + w2 * t2[:, row, col - 140]) / (w1 + w2)
    np.testing.assert_array_equal(out[:, row, col], np.rint(v))


@pytest.mark.parametrize("mode", ["feather", "overwrite"])
def test_nodata_holes_are_filled_from_the_other_tile(tmp_path, mode):
    """Float DEM, NoData −9999: a hole in the later tile, inside the overlap, takes the earlier tile's
    heights unblended; pixels no tile covers are NoData and the output declares it."""
    dem1 = np.full((30, 40), 10.0, np.float32)
    dem2 = np.full((30, 40), 20.0, np.float32)
    dem2[5:12, 2:8] = -9999.0  # output rows 15:22, cols 32:38: inside tile 1 too
    inputs = [write_tif(tmp_path / "d1.tif", dem1, ORIGIN, nodata=-9999.0),
              write_tif(tmp_path / "d2.tif", dem2, (ORIGIN[0] + 60.0, ORIGIN[1] - 20.0), nodata=-9999.0)]
    report = mosaic.merge_tiles(inputs, str(tmp_path / "m.tif"), mode=mode, gain=False)
    out, ds = read(report.output)
    assert (report.width, report.height) == (70, 40)
    assert ds.GetRasterBand(1).GetNoDataValue() == -9999.0 and report.nodata == -9999.0
    assert ds.GetRasterBand(1).DataType == gdal.GDT_Float32
    np.testing.assert_array_equal(out[0, 15:22, 32:38], 10.0)
    np.testing.assert_array_equal(out[0, 30:40, 0:30], -9999.0)  # south-west corner: no tile
    np.testing.assert_array_equal(out[0, 0:10, 40:70], -9999.0)  # north-east corner: no tile
    overlap = out[0, 10:30, 30:40]
    assert overlap.min() >= 10.0 and overlap.max() <= 20.0  # never pulled towards −9999 or 0
    assert report.covered_pixels == 70 * 40 - 2 * 300


def test_nodata_parameter_overrides_and_rgb_holes(tmp_path):
    """RGB tiles declaring nothing; ``nodata=0`` makes black pixels holes: filled, not blended."""
    rgb1 = np.full((3, 20, 30), 100, np.uint8)
    rgb2 = np.full((3, 20, 30), 200, np.uint8)
    rgb2[:, 5:10, 0:5] = 0
    inputs = [write_tif(tmp_path / "r1.tif", rgb1, ORIGIN),
              write_tif(tmp_path / "r2.tif", rgb2, (ORIGIN[0] + 20.0, ORIGIN[1]))]
    report = mosaic.merge_tiles(inputs, str(tmp_path / "m.tif"), nodata=0, gain=False)
    out, ds = read(report.output)
    np.testing.assert_array_equal(out[:, 5:10, 10:15], 100)
    assert ds.GetRasterBand(1).GetNoDataValue() == 0
    blended = out[:, 12, 10:30]
    assert blended.min() > 100 and blended.max() < 200


def test_identical_dem_overlaps_reproduce_the_dem_exactly(tmp_path):
    """Two float32 tiles cut from one DEM: feather + gain returns the DEM bit for bit."""
    rng = np.random.default_rng(3)
    dem = (100 + rng.normal(0, 5, (50, 70)).cumsum(axis=1)).astype(np.float32)
    inputs = [write_tif(tmp_path / "a.tif", dem[:, :45], ORIGIN),
              write_tif(tmp_path / "b.tif", dem[:, 25:], (ORIGIN[0] + 50.0, ORIGIN[1]))]
    report = mosaic.merge_tiles(inputs, str(tmp_path / "dem.tif"), mode="feather", gain=True)
    out, _ = read(report.output)
    assert report.gains == [[1.0], [1.0]]
    assert report.blended_pixels == 50 * 20
    np.testing.assert_array_equal(out[0], dem)


def test_cancel_leaves_no_file(tmp_path):
    rng = np.random.default_rng(4)
    folder = tmp_path / "in"
    folder.mkdir()
    inputs = [write_tif(folder / "a.tif", textured(rng, 3, 64, 64), ORIGIN),
              write_tif(folder / "b.tif", textured(rng, 3, 64, 64), (ORIGIN[0] + 100.0, ORIGIN[1]))]
    out_dir = tmp_path / "out"
    with pytest.raises(CanceledError):
        mosaic.merge_tiles(inputs, str(out_dir / "m.tif"), feedback=Recorder(cancel_after=2), block_size=16)
    assert list(out_dir.iterdir()) == []
    assert sorted(os.listdir(folder)) == ["a.tif", "b.tif"]


def test_different_pixel_size_is_resampled_with_a_warning(tmp_path):
    fine = np.full((3, 20, 20), 50, np.uint8)
    coarse = np.full((3, 10, 10), 150, np.uint8)
    inputs = [write_tif(tmp_path / "fine.tif", fine, ORIGIN, 2.0),
              write_tif(tmp_path / "coarse.tif", coarse, (ORIGIN[0] + 40.0, ORIGIN[1]), 4.0)]
    feedback = Recorder()
    report = mosaic.merge_tiles(inputs, str(tmp_path / "m.tif"), mode="overwrite", feedback=feedback)
    out, ds = read(report.output)
    assert ds.GetGeoTransform()[1] == 2.0 and (report.width, report.height) == (40, 20)
    assert report.resampled == [inputs[1]]
    assert any("pixel size" in w and "resampled" in w for w in feedback.warnings)
    np.testing.assert_array_equal(out[:, :, :20], 50)
    np.testing.assert_array_equal(out[:, :, 20:], 150)


def test_different_crs_is_reprojected_with_a_warning(tmp_path):
    first = write_tif(tmp_path / "a.tif", np.full((20, 20), 5.0, np.float32), ORIGIN)
    other_src = write_tif(tmp_path / "b_src.tif", np.full((20, 20), 7.0, np.float32), (ORIGIN[0] + 40.0, ORIGIN[1]))
    other = str(tmp_path / "b.tif")
    gdal.Warp(other, other_src, dstSRS="EPSG:5179")
    feedback = Recorder()
    report = mosaic.merge_tiles([first, other], str(tmp_path / "m.tif"), feedback=feedback)
    out, _ = read(report.output)
    assert any("CRS" in w for w in feedback.warnings)
    assert report.width >= 40
    np.testing.assert_array_equal(out[0, :, :20], 5.0)
    np.testing.assert_allclose(out[0, 2:18, 22:38], 7.0 * report.gains[1][0], rtol=1e-5)


def test_refuses_mixed_band_counts_and_missing_crs(tmp_path):
    rgb = write_tif(tmp_path / "rgb.tif", np.ones((3, 10, 10), np.uint8), ORIGIN)
    grey = write_tif(tmp_path / "grey.tif", np.ones((10, 10), np.uint8), ORIGIN)
    with pytest.raises(InputError, match="band"):
        mosaic.merge_tiles([rgb, grey], str(tmp_path / "m.tif"))
    bare = write_tif(tmp_path / "bare.tif", np.ones((3, 10, 10), np.uint8), ORIGIN, epsg=None)
    with pytest.raises(InputError, match="no coordinate reference system"):
        mosaic.merge_tiles([rgb, bare], str(tmp_path / "m.tif"))
    with pytest.raises(InputError, match="mode"):
        mosaic.merge_tiles([rgb], str(tmp_path / "m.tif"), mode="blend")
    assert not (tmp_path / "m.tif").exists()


def test_landsat_tiles_overwrite_equal_gdal_merge(tmp_path, shared_dir):
    folder = shared_dir / "data" / "rgb_landsat_rasterio_cc0"
    inputs = [str(folder / f"rgb{i}.tif") for i in range(1, 5)]
    expected, gm = read(run_gdal_merge(inputs, tmp_path / "gdal_merge.tif"))
    report = mosaic.merge_tiles(inputs, str(tmp_path / "m.tif"), mode="overwrite", block_size=256)
    out, ds = read(report.output)
    assert ds.GetGeoTransform() == gm.GetGeoTransform()
    assert (ds.RasterXSize, ds.RasterYSize) == (791, 718)
    np.testing.assert_array_equal(out, expected)
    band = ds.GetRasterBand(1)
    assert band.GetNoDataValue() == 0
    assert band.GetBlockSize() == [512, 512]
    assert band.GetOverviewCount() == 1  # 791 → 396 px: under 512
    assert ds.GetMetadata("IMAGE_STRUCTURE")["COMPRESSION"] == "DEFLATE"
    assert report.covered_pixels == int((expected != 0).any(axis=0).sum())
