"""io.raster_io and gdal_env: opening and reading input rasters is checked, named, and writes nothing beside them."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
from osgeo import gdal

from wit_plugin import mosaic
from wit_plugin.infra.errors import InputError
from wit_plugin.infra.gdal_env import no_sidecars
from wit_plugin.infra.io.raster_io import open_raster, raster_file_problem, read_window


@pytest.fixture
def landsat(tmp_path, shared_dir):
    """A writable copy of a real 400 × 400 px RGB GeoTIFF (Landsat, NoData 0, stripped, 481,148 bytes)."""
    path = tmp_path / "rgb1.tif"
    shutil.copyfile(shared_dir / "data" / "rgb_landsat_rasterio_cc0" / "rgb1.tif", path)
    return path


def test_missing_empty_and_unknown_files_are_named(tmp_path, gdal_exceptions):
    (tmp_path / "empty.tif").write_bytes(b"")
    (tmp_path / "notes.tif").write_text("not a raster")
    with pytest.raises(InputError, match=r"^The DEM .*missing.tif does not exist\.$"):
        open_raster(tmp_path / "missing.tif", "DEM")
    with pytest.raises(InputError, match=r"^The tile .*empty.tif is empty \(0 bytes\): the file may be truncated"):
        open_raster(tmp_path / "empty.tif", "tile")
    with pytest.raises(InputError, match=r"^Cannot open the raster .*notes.tif: .*not recognized as a supported"):
        open_raster(tmp_path / "notes.tif")
    assert "is empty (0 bytes)" in raster_file_problem(tmp_path / "empty.tif")


def test_truncated_geotiff_is_refused_when_opened(landsat, tmp_path, shared_dir, gdal_exceptions):
    """Half of a real GeoTIFF: GDAL opens it (the header is in the first half), the block table says
    where the pixels end; a half whose header is at the end (the USGS orthophoto) does not open."""
    half = tmp_path / "half.tif"
    half.write_bytes(landsat.read_bytes()[:240574])
    with pytest.raises(InputError, match=r"^The orthoimage .*half.tif is truncated: its pixel data runs to byte "
                                         r"481,148 but the file has 240,574 bytes; the file may be truncated"):
        open_raster(half, "orthoimage")
    usgs = (shared_dir / "data" / "ortho_usgs_hro_15cm" / "201404_13SED190110_201404_0x1500m_CL_1.tif").read_bytes()
    (tmp_path / "usgs_half.tif").write_bytes(usgs[:len(usgs) // 2])
    with pytest.raises(InputError, match=r"^Cannot open the raster .*usgs_half.tif: .*TIFF"):
        open_raster(tmp_path / "usgs_half.tif")
    assert open_raster(landsat).RasterXSize == 400


def test_undecodable_block_names_file_band_and_window(landsat, tmp_path, gdal_exceptions):
    """A DEFLATE tile overwritten with garbage: the file opens, the read says where it failed."""
    garbled = tmp_path / "garbled.tif"
    gdal.Translate(str(garbled), str(landsat), creationOptions=["COMPRESS=DEFLATE", "TILED=YES", "BLOCKXSIZE=256",
                                                                "BLOCKYSIZE=256", "INTERLEAVE=BAND"])
    ds = gdal.Open(str(garbled))
    offset, size = (int(ds.GetRasterBand(2).GetMetadataItem(f"BLOCK_{k}_1_1", "TIFF")) for k in ("OFFSET", "SIZE"))
    ds = None
    data = bytearray(garbled.read_bytes())
    data[offset + 2:offset + size] = b"\x55" * (size - 2)
    garbled.write_bytes(data)
    ds = open_raster(garbled, "orthoimage")
    np.testing.assert_array_equal(read_window(ds, 0, 0, 256, 256, "x"),
                                  gdal.Open(str(landsat)).ReadAsArray(0, 0, 256, 256))
    with pytest.raises(InputError, match=r"^Cannot read the orthoimage .*garbled.tif, band 2, pixels x 300–309, "
                                         r"y 260–269: .*IReadBlock failed.*; the file may be truncated or damaged"):
        read_window(ds.GetRasterBand(2), 300, 260, 10, 10, f"the orthoimage {garbled}")
    with pytest.raises(InputError, match=r"^Cannot read the tile .*, bands 1, 2, 3, pixels x 250–269, y 250–269: "):
        read_window(ds, 250, 250, 20, 20, f"the tile {garbled}")


def test_reading_writes_no_sidecar_and_an_existing_one_is_read_untouched(landsat, tmp_path):
    """Statistics computed while PAM is off stay in memory (else GDAL writes rgb1.tif.aux.xml); an
    .aux.xml that was already there is read (its NoData counts) and left byte for byte."""
    with no_sidecars():
        ds = open_raster(landsat)
        ds.GetRasterBand(1).ComputeStatistics(False)
        ds = None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rgb1.tif"]

    plain = tmp_path / "plain.tif"
    gdal.Translate(str(plain), str(landsat), noData="none")
    pam = tmp_path / "plain.tif.aux.xml"
    pam.write_text('<PAMDataset><PAMRasterBand band="1"><NoDataValue>0</NoDataValue></PAMRasterBand>'
                   '<PAMRasterBand band="2"><NoDataValue>0</NoDataValue></PAMRasterBand>'
                   '<PAMRasterBand band="3"><NoDataValue>0</NoDataValue></PAMRasterBand></PAMDataset>')
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert open_raster(plain).GetRasterBand(1).GetNoDataValue() == 0.0
    report = mosaic.merge_rasters([str(plain)], str(tmp_path / "out" / "m.tif"))
    assert report.nodata == 0.0
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before
