"""wit:mergerasters core: gdal_merge-exact grid and pixels, feather + gain seams, NoData, cancel."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal, osr
from osgeo_utils import gdal_merge

from wit_plugin import metrics, mosaic
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.interpreter import core_env
from wit_plugin.infra.step_process import RECORD
from wit_plugin.mosaic import georef, tone
from wit_plugin.sample import SampleConfig, generate_sample

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
    report = mosaic.merge_rasters(inputs, str(tmp_path / "over.tif"), mode="overwrite", feedback=feedback)
    over, ds = read(report.output)
    assert ds.GetGeoTransform() == gm.GetGeoTransform()
    assert (ds.RasterXSize, ds.RasterYSize) == (gm.RasterXSize, gm.RasterYSize) == (report.width, report.height)
    np.testing.assert_array_equal(over, expected)  # overwrite is gdal_merge everywhere
    assert len([w for w in feedback.warnings if "off the output grid" in w]) == 3  # grid origin: c.x, a.y

    report = mosaic.merge_rasters(inputs, str(tmp_path / "feather.tif"), mode="feather", gain=False)
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
    over, _ = read(mosaic.merge_rasters(inputs, str(tmp_path / "over.tif"), mode="overwrite").output)
    report = mosaic.merge_rasters(inputs, str(tmp_path / "wit.tif"), mode="feather")
    wit, _ = read(report.output)
    assert report.gain
    assert seam_step(over) > 15
    assert seam_step(wit) * 5 <= seam_step(over)
    assert tone_difference(over, scene) == pytest.approx(0.2, abs=0.01)
    assert tone_difference(wit, scene) * 5 <= tone_difference(over, scene)
    g1, g2 = np.array(report.gains)
    np.testing.assert_allclose(g1 / g2, 1.2, rtol=0.01)  # the brighter tile is toned down relative
    np.testing.assert_allclose(g1 * g2, 1.0, rtol=1e-9)  # geometric mean 1
    np.testing.assert_allclose(report.offsets, 0.0, atol=1.5)  # a pure gain: (almost) no offset


@pytest.mark.parametrize("block_size", [1024, 32])
def test_an_extent_writes_the_same_pixels_as_the_whole_mosaic_there(tmp_path, block_size):
    """Tone, feathering and values of the clipped mosaic are the whole mosaic's, pixel for pixel, on its grid."""
    inputs, _ = seam_tiles(tmp_path)
    whole = mosaic.merge_rasters(inputs, str(tmp_path / "whole.tif"), block_size=block_size)
    extent = (ORIGIN[0] + 101.0, ORIGIN[1] - 151.0, ORIGIN[0] + 433.0, ORIGIN[1] - 21.0)  # inside the overlap band
    clipped = mosaic.merge_rasters(inputs, str(tmp_path / "clip.tif"), block_size=block_size, extent=extent)
    a, _ = read(whole.output)
    b, ds = read(clipped.output)
    assert clipped.window == (50, 10, 167, 66) and (clipped.width, clipped.height) == (167, 66)
    assert ds.GetGeoTransform() == pytest.approx((ORIGIN[0] + 100.0, 2.0, 0.0, ORIGIN[1] - 20.0, 0.0, -2.0))
    np.testing.assert_array_equal(b, a[:, 10:76, 50:217])
    assert clipped.gains == whole.gains and clipped.offsets == whole.offsets
    assert clipped.blended_pixels == 60 * 66 and clipped.tile_windows[0] == (-50, -10, 200, 80)
    with pytest.raises(InputError, match="do not meet the extent"):
        mosaic.merge_rasters(inputs, str(tmp_path / "none.tif"), extent=(0.0, 0.0, 10.0, 10.0))
    assert not (tmp_path / "none.tif").exists()


def test_heights_are_offset_along_a_chain_never_scaled_and_an_isolated_tile_is_left_alone(tmp_path):
    """Three flat float32 DEM tiles in a row at 100, 110 and 121 m, and one far away: one least-squares
    solve over both overlaps levels the chain at its mean (110.33 m) with gains exactly 1; the lone
    tile keeps its heights."""
    flat = np.ones((100, 120), np.float32)
    inputs = [write_tif(tmp_path / f"t{k}.tif", flat * 100 * 1.1 ** k, (ORIGIN[0] + k * 120.0, ORIGIN[1]))
              for k in range(3)]
    inputs.append(write_tif(tmp_path / "far.tif", flat * 300, (ORIGIN[0] + 1000.0, ORIGIN[1])))
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"))
    assert report.gains == [[1.0]] * 4
    heights = np.array([100.0, 110.0, 121.0])
    offsets = np.array(report.offsets)[:, 0]
    np.testing.assert_allclose(heights + offsets[:3], heights.mean(), atol=1e-4)
    assert offsets[:3].sum() == pytest.approx(0.0, abs=1e-9)
    assert offsets[3] == 0.0
    out, _ = read(report.output)
    np.testing.assert_allclose(out[0, :, :240], heights.mean(), atol=1e-4)  # one surface along the chain
    np.testing.assert_array_equal(out[0, :, -120:], 300.0)


def test_feather_without_gain_keeps_single_coverage_pixels_and_weights_by_edge_distance(tmp_path):
    inputs, _ = seam_tiles(tmp_path)
    t1, _ = read(inputs[0])
    t2, _ = read(inputs[1])
    out, _ = read(mosaic.merge_rasters(inputs, str(tmp_path / "f.tif"), gain=False).output)
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
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"), mode=mode, gain=False)
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
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"), nodata=0, gain=False)
    out, ds = read(report.output)
    np.testing.assert_array_equal(out[:, 5:10, 10:15], 100)
    assert ds.GetRasterBand(1).GetNoDataValue() == 0
    blended = out[:, 12, 10:30]
    assert blended.min() > 100 and blended.max() < 200


def test_identical_dem_overlaps_reproduce_the_dem_exactly(tmp_path):
    """Two float32 tiles cut from one DEM: the overlap is measured (no warning) and the correction is
    the identity, so feather + tone returns the DEM bit for bit."""
    rng = np.random.default_rng(3)
    dem = (100 + rng.normal(0, 5, (120, 160)).cumsum(axis=1)).astype(np.float32)
    inputs = [write_tif(tmp_path / "a.tif", dem[:, :100], ORIGIN),
              write_tif(tmp_path / "b.tif", dem[:, 60:], (ORIGIN[0] + 120.0, ORIGIN[1]))]
    feedback = Recorder()
    report = mosaic.merge_rasters(inputs, str(tmp_path / "dem.tif"), mode="feather", gain=True, feedback=feedback)
    out, _ = read(report.output)
    assert feedback.warnings == []
    assert report.gains == [[1.0], [1.0]] and report.offsets == [[0.0], [0.0]]
    assert report.blended_pixels == 120 * 40
    np.testing.assert_array_equal(out[0], dem)


def test_dem_tiles_with_a_vertical_bias_get_an_offset_not_a_gain(tmp_path):
    """The second DEM tile reads 5 m high (another survey's datum): each tile moves 2.5 m towards the
    other, no height is scaled, and the mosaic is one surface, 2.5 m above the first tile."""
    rng = np.random.default_rng(5)
    dem = (300 + rng.normal(0, 4, (120, 160)).cumsum(axis=1)).astype(np.float32)
    inputs = [write_tif(tmp_path / "a.tif", dem[:, :100], ORIGIN, nodata=-9999.0),
              write_tif(tmp_path / "b.tif", dem[:, 60:] + 5, (ORIGIN[0] + 120.0, ORIGIN[1]), nodata=-9999.0)]
    report = mosaic.merge_rasters(inputs, str(tmp_path / "dem.tif"))
    assert report.gains == [[1.0], [1.0]]
    np.testing.assert_allclose(report.offsets, [[2.5], [-2.5]], atol=1e-4)
    out, _ = read(report.output)
    np.testing.assert_allclose(out[0], dem + 2.5, atol=1e-3)


@pytest.mark.parametrize("bands, dtype, heights", [
    (1, np.float32, True), (1, np.float64, True), (1, np.int16, True), (1, np.uint8, False),
    (1, np.uint16, False), (3, np.uint8, False), (3, np.float32, False)])
def test_what_counts_as_heights(bands, dtype, heights):
    assert tone.is_elevation(bands, np.dtype(dtype)) is heights


def test_cancel_leaves_no_file(tmp_path):
    rng = np.random.default_rng(4)
    folder = tmp_path / "in"
    folder.mkdir()
    inputs = [write_tif(folder / "a.tif", textured(rng, 3, 64, 64), ORIGIN),
              write_tif(folder / "b.tif", textured(rng, 3, 64, 64), (ORIGIN[0] + 100.0, ORIGIN[1]))]
    out_dir = tmp_path / "out"
    with pytest.raises(CanceledError):
        mosaic.merge_rasters(inputs, str(out_dir / "m.tif"), feedback=Recorder(cancel_after=2), block_size=16)
    assert list(out_dir.iterdir()) == []
    assert sorted(os.listdir(folder)) == ["a.tif", "b.tif"]


def test_different_pixel_size_is_resampled_with_a_warning(tmp_path):
    fine = np.full((3, 20, 20), 50, np.uint8)
    coarse = np.full((3, 10, 10), 150, np.uint8)
    inputs = [write_tif(tmp_path / "fine.tif", fine, ORIGIN, 2.0),
              write_tif(tmp_path / "coarse.tif", coarse, (ORIGIN[0] + 40.0, ORIGIN[1]), 4.0)]
    feedback = Recorder()
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"), mode="overwrite", feedback=feedback)
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
    report = mosaic.merge_rasters([first, other], str(tmp_path / "m.tif"), feedback=feedback)
    out, _ = read(report.output)
    assert any("CRS" in w for w in feedback.warnings)
    assert report.width >= 40
    np.testing.assert_array_equal(out[0, :, :20], 5.0)
    np.testing.assert_allclose(out[0, 2:18, 22:38], 7.0 * report.gains[1][0] + report.offsets[1][0], rtol=1e-5)


def test_refuses_mixed_band_counts_and_missing_crs(tmp_path):
    rgb = write_tif(tmp_path / "rgb.tif", np.ones((3, 10, 10), np.uint8), ORIGIN)
    grey = write_tif(tmp_path / "grey.tif", np.ones((10, 10), np.uint8), ORIGIN)
    with pytest.raises(InputError, match="band"):
        mosaic.merge_rasters([rgb, grey], str(tmp_path / "m.tif"))
    bare = write_tif(tmp_path / "bare.tif", np.ones((3, 10, 10), np.uint8), ORIGIN, epsg=None)
    with pytest.raises(InputError, match="no coordinate reference system"):
        mosaic.merge_rasters([rgb, bare], str(tmp_path / "m.tif"))
    with pytest.raises(InputError, match="mode"):
        mosaic.merge_rasters([rgb], str(tmp_path / "m.tif"), mode="blend")
    assert not (tmp_path / "m.tif").exists()


def test_landsat_tiles_overwrite_equal_gdal_merge(tmp_path, shared_dir):
    folder = shared_dir / "data" / "rgb_landsat_rasterio_cc0"
    inputs = [str(folder / f"rgb{i}.tif") for i in range(1, 5)]
    expected, gm = read(run_gdal_merge(inputs, tmp_path / "gdal_merge.tif"))
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"), mode="overwrite", block_size=256)
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


# --- tone correction on real imagery ---------------------------------------------------------------

@pytest.fixture(scope="module")
def landsat_scene(tmp_path_factory, shared_dir) -> str:
    """The real Landsat scene put back together from its 2×2 tiles (NoData 0 around the footprint)."""
    folder = shared_dir / "data" / "rgb_landsat_rasterio_cc0"
    return run_gdal_merge([str(folder / f"rgb{i}.tif") for i in range(1, 5)],
                          tmp_path_factory.mktemp("landsat") / "scene.tif")


def cut_tile(scene: str, path: Path, window: tuple[int, int, int, int], tone_change=lambda v: v) -> str:
    """A tile cut from ``scene`` (xoff, yoff, width, height) with its tone changed, clipped to 1–255
    (NoData 0 stays 0 and is declared)."""
    ds = gdal.Translate(str(path), scene, srcWin=list(window))
    data = ds.ReadAsArray().astype(np.float64)
    covered = (data != 0).any(axis=0)
    ds.WriteArray(np.where(covered, np.clip(np.rint(tone_change(data)), 1, 255), 0).astype(np.uint8))
    for band in range(ds.RasterCount):
        ds.GetRasterBand(band + 1).SetNoDataValue(0)
    ds = None
    return str(path)


def overlap_tone_difference(report: mosaic.MergeReport, i: int, j: int, corrected: bool = True) -> float:
    """Mean absolute colour difference between tiles i and j over their overlap, after each tile's
    correction (or before): pixels NoData or saturated (255) in either tile are left out, as no
    linear correction can bring back a clipped value."""
    wi, wj = report.tile_windows[i], report.tile_windows[j]
    x0, y0 = max(wi[0], wj[0]), max(wi[1], wj[1])
    x1, y1 = min(wi[0] + wi[2], wj[0] + wj[2]), min(wi[1] + wi[3], wj[1] + wj[3])
    values = []
    for k, w in ((i, wi), (j, wj)):
        data = gdal.Open(report.inputs[k]).ReadAsArray(x0 - w[0], y0 - w[1], x1 - x0, y1 - y0).astype(np.float64)
        gain, offset = (np.array(report.gains[k]), np.array(report.offsets[k])) if corrected else (1.0, 0.0)
        values.append((data, data * np.reshape(gain, (-1, 1, 1)) + np.reshape(offset, (-1, 1, 1))))
    (raw_i, tone_i), (raw_j, tone_j) = values
    usable = ((raw_i > 0) & (raw_i < 255) & (raw_j > 0) & (raw_j < 255)).all(axis=0)
    return float(np.abs(tone_i - tone_j)[:, usable].mean())


TONE_CHANGES = {"+40": lambda v: v + 40, "x1.2": lambda v: v * 1.2, "x1.2+40": lambda v: v * 1.2 + 40}


@pytest.mark.parametrize("change", sorted(TONE_CHANGES))
def test_tone_correction_removes_gain_and_offset_between_real_tiles(tmp_path, landsat_scene, change):
    """Two real tiles overlapping by 100 columns, the second with its tone changed: the tone
    difference in the overlap drops at least 5× (measured: 40.0 → 0.0, 9.7 → 0.2, 49.4 → 0.2; a gain
    alone left 19.7, 3.1, 18.9) and the seam across the tile border goes (excess step 12.5 → 0.5 with
    +40); single-coverage NoData stays NoData."""
    inputs = [cut_tile(landsat_scene, tmp_path / "left.tif", (0, 0, 450, 718)),
              cut_tile(landsat_scene, tmp_path / "right.tif", (350, 0, 441, 718), TONE_CHANGES[change])]
    over = mosaic.merge_rasters(inputs, str(tmp_path / "over.tif"), mode="overwrite")
    wit = mosaic.merge_rasters(inputs, str(tmp_path / "wit.tif"), mode="feather")
    before, after = overlap_tone_difference(over, 0, 1), overlap_tone_difference(wit, 0, 1)
    assert before > 9
    assert after * 5 <= before and after < 0.5
    seam_before, seam_after = (metrics.seam_metrics(r.output, inputs).excess for r in (over, wit))
    assert seam_before > 2.5 and abs(seam_after) * 4 <= seam_before
    gains, offsets = np.array(wit.gains), np.array(wit.offsets)
    expected_ratio = 1.2 if "x1.2" in change else 1.0
    np.testing.assert_allclose(gains[0] / gains[1], expected_ratio, rtol=0.01)
    np.testing.assert_allclose(np.log(gains).sum(axis=0), 0.0, atol=1e-9)  # anchored: geometric mean 1
    np.testing.assert_allclose(offsets.sum(axis=0), 0.0, atol=1e-9)  # and mean offset 0
    out, _ = read(wit.output)
    scene, _ = read(landsat_scene)
    np.testing.assert_array_equal(out[:, scene.any(axis=0) == 0], 0)  # NoData never corrected


def test_tone_is_solved_over_all_overlaps_of_four_real_tiles(tmp_path, landsat_scene):
    """2×2 real tiles overlapping each other (six overlaps, a loop) with four different tones: one
    least-squares solve makes every overlap agree (before 10–40 grey levels, after ≤ 0.3)."""
    changes = [lambda v: v, lambda v: v + 40, lambda v: v * 1.2, lambda v: v * 0.9 + 15]
    windows = [(0, 0, 450, 410), (341, 0, 450, 410), (0, 308, 450, 410), (341, 308, 450, 410)]
    inputs = [cut_tile(landsat_scene, tmp_path / f"q{k}.tif", w, c) for k, (w, c) in enumerate(zip(windows, changes))]
    report = mosaic.merge_rasters(inputs, str(tmp_path / "m.tif"))
    for i in range(4):
        for j in range(i + 1, 4):
            before = overlap_tone_difference(report, i, j, corrected=False)
            after = overlap_tone_difference(report, i, j)
            assert before > 10 and after * 5 <= before and after < 0.5, (i, j, before, after)
    gains = np.array(report.gains)
    np.testing.assert_allclose(gains[0] / gains[1], 1.0, rtol=0.01)
    np.testing.assert_allclose(gains[0] / gains[2], 1.2, rtol=0.01)
    np.testing.assert_allclose(gains[0] / gains[3], 0.9, rtol=0.01)


def test_tone_correction_on_the_generated_sample_recovers_its_tile_exposures(tmp_path):
    """The sample's two NGII-named tiles carry known exposures (0.88–0.91 and 1.07–1.08 per band) and
    their own sensor noise; after georeferencing (the second tile is resampled), the solved gains
    match the true ratio within 2 % and the mean colour difference in the overlap drops ≥ 5×."""
    sample = generate_sample(tmp_path / "sample", SampleConfig(radius_m=250.0, seed=11, ortho_pixel_size=2.0,
                                                                with_dem=False))
    results = georef.georeference_sheets([str(p) for p in sample.ortho_tiles], tmp_path / "geo")
    tiles = [r.output for r in results]
    report = mosaic.merge_rasters(tiles, str(tmp_path / "m.tif"))
    exposure = [np.array(sample.tile_gains[str(Path(r.source).relative_to(sample.folder))]) for r in results]
    true_ratio = exposure[1] / exposure[0]
    gains = np.array(report.gains)
    np.testing.assert_allclose(gains[0] / gains[1], true_ratio, rtol=0.02)

    def mean_difference(corrected: bool) -> float:
        wa, wb = report.tile_windows
        x0, x1 = wb[0], wa[0] + wa[2]
        means = []
        for k, w in enumerate(report.tile_windows):
            data = gdal.Open(tiles[k]).ReadAsArray(x0 - w[0], 0, x1 - x0, 1400).astype(np.float64)
            if corrected:
                data = data * np.reshape(report.gains[k], (-1, 1, 1)) + np.reshape(report.offsets[k], (-1, 1, 1))
            means.append(data.mean(axis=(1, 2)))
        return float(np.abs(means[0] - means[1]).mean())

    assert mean_difference(corrected=False) > 15
    assert mean_difference(corrected=True) * 5 <= mean_difference(corrected=False)


def test_mostly_empty_mosaic_is_a_warning_then_refused_before_anything_is_written(tmp_path):
    """Two 20 × 20 px tiles: 60 px apart the mosaic is 60 % empty (a warning); 380 px apart 90.5 %
    (refused under the default 90 %, before the output folder is even made; written when raised)."""
    grey = np.full((3, 20, 20), 90, np.uint8)
    a = write_tif(tmp_path / "a.tif", grey, ORIGIN)
    near = write_tif(tmp_path / "near.tif", grey, (ORIGIN[0] + 160.0, ORIGIN[1]))
    far = write_tif(tmp_path / "far.tif", grey, (ORIGIN[0] + 800.0, ORIGIN[1]))
    feedback = Recorder()
    mosaic.merge_rasters([a, near], str(tmp_path / "near_m.tif"), feedback=feedback)
    assert feedback.warnings == [("The mosaic is 100 × 20 px, 0.0 GB uncompressed, and about 60% of it is empty "
                                  "(no tile covers it): the tiles lie far apart.")]
    out = tmp_path / "out"
    with pytest.raises(InputError, match=r"^The mosaic would be 420 × 20 px, 0.0 GB uncompressed, and about 90% of it "
                                         r"would be empty .* raise the maximum empty share \(now 90%\)"):
        mosaic.merge_rasters([a, far], str(out / "m.tif"))
    assert not out.exists()
    report = mosaic.merge_rasters([a, far], str(out / "m.tif"), max_empty=0.95)
    assert (report.width, report.height) == (420, 20)
    with pytest.raises(InputError, match="0–1"):
        mosaic.merge_rasters([a], str(out / "x.tif"), max_empty=1.5)


def test_the_merge_in_its_own_process_writes_the_same_mosaic(tmp_path):
    """The chain runs ``python -m wit_plugin.mosaic`` beside the terrain: the same pixels, grid and report as in
    this process, for the chain's options (feather, tone, an extent, the fast compression of a mosaic only the
    next steps read: ZSTD, 1.5 CPU-s less than DEFLATE on the 1 km sample); a refusal is a record and exit
    status 2."""
    inputs, _ = seam_tiles(tmp_path)
    extent = (ORIGIN[0] + 101.0, ORIGIN[1] - 150.0, ORIGIN[0] + 501.0, ORIGIN[1] - 3.0)
    here = mosaic.merge_rasters(inputs, str(tmp_path / "here.tif"), mode="feather", gain=True, extent=extent)
    done = subprocess.run([sys.executable, "-m", "wit_plugin.mosaic", str(tmp_path / "there.tif"), *inputs,
                           "--mode", "feather", "--gain", "--extent", *map(repr, extent), "--compression", "fast"],
                          capture_output=True, text=True, env=core_env(), check=True)
    there = json.loads(done.stdout)
    assert (there["width"], there["height"], there["gain"]) == (here.width, here.height, True)
    assert there["geotransform"] == list(here.geotransform)
    a, ds_a = read(here.output)
    b, ds_b = read(there["output"])
    np.testing.assert_array_equal(a, b)
    assert ds_a.GetGeoTransform() == ds_b.GetGeoTransform()
    assert ds_a.GetMetadata("IMAGE_STRUCTURE")["COMPRESSION"] == "DEFLATE"  # (the product's, as wit:mergerasters')
    assert ds_b.GetMetadata("IMAGE_STRUCTURE")["COMPRESSION"] == "ZSTD"  # (GDAL here has it)
    with pytest.raises(InputError, match="Unknown compression 'lzma'"):
        mosaic.merge_rasters(inputs, str(tmp_path / "none.tif"), compression="lzma")
    refused = subprocess.run([sys.executable, "-m", "wit_plugin.mosaic", str(tmp_path / "none.tif"),
                              str(tmp_path / "missing.tif")], capture_output=True, text=True, env=core_env())
    last = json.loads(refused.stderr.splitlines()[-1].removeprefix(RECORD))  # (a record: ``infra.step_process``)
    assert refused.returncode == 2 and last["error"] == "InputError" and "missing.tif" in last["refused"]
    assert not (tmp_path / "none.tif").exists()
