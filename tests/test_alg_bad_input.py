"""Every algorithm turns bad input into a QgsProcessingException with a message, and writes nothing."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import write_polygons
from osgeo import gdal, osr
from qgis.core import QgsProcessingException

pytestmark = pytest.mark.qgis_facing


def _raster(path, bands, x0=209000.0, y0=543000.0, size=20, pixel=1.0):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), size, size, bands, gdal.GDT_Byte)
    ds.SetGeoTransform((x0, pixel, 0, y0 + size * pixel, 0, -pixel))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds.SetProjection(srs.ExportToWkt())
    for band in range(bands):
        ds.GetRasterBand(band + 1).WriteArray(np.full((size, size), 50 * (band + 1), np.uint8))
    ds = None
    return str(path)


@pytest.fixture
def inputs(tmp_path):
    return {
        "rgb": _raster(tmp_path / "rgb.tif", 3),
        "gray": _raster(tmp_path / "gray.tif", 1),
        "far_dem": _raster(tmp_path / "far.tif", 1, x0=150000.0, y0=450000.0),
        "footprints": write_polygons(tmp_path / "plain.gpkg", "buildings", ("wit_id",)),
        "zero": _empty(tmp_path / "(B060)정사영상_2022_37709005.tif"),
        "zero2": _empty(tmp_path / "(B060)정사영상_2022_37709004.tif"),
    }


def _empty(path):
    path.write_bytes(b"")
    return str(path)


CASES = {
    "mergerasters: different band counts": ("wit:mergerasters", lambda i, o: {
        "INPUT": [i["rgb"], i["gray"]], "OUTPUT": str(o / "out.tif")}, r"has 1 band\(s\) but"),
    "triangulateterrain: DEM elsewhere": ("wit:triangulateterrain", lambda i, o: {
        "DEM": i["far_dem"], "AREA": i["footprints"], "OUTPUT": str(o / "out.gpkg")}, "does not cover the area"),
    "extrudebuildings: DEM elsewhere": ("wit:extrudebuildings", lambda i, o: {
        "BUILDINGS": i["footprints"], "DEM": i["far_dem"], "OUTPUT": str(o / "out.gpkg")}, "does not cover the area"),
    "wittexture: not an LoD1 layer": ("wit:wittexture", lambda i, o: {
        "ORTHO": i["rgb"], "LOD1": i["footprints"], "OUTPUT": str(o / "out")},
        r"Layer 'buildings' in .*plain.gpkg lacks the field\(s\) .* of the LoD1 faces \(wit:extrudebuildings\)"),
    "writecitygml: not an LoD1 layer": ("wit:writecitygml", lambda i, o: {
        "LOD1": i["footprints"], "OUTPUT": str(o / "out.gml")},
        r"Layer 'buildings' in .*plain.gpkg lacks the field\(s\) .* of the LoD1 faces \(wit:extrudebuildings\)"),
    "exportcityjson: not an LoD1 layer": ("wit:exportcityjson", lambda i, o: {
        "LOD1": i["footprints"], "OUTPUT": str(o / "out.city.json")},
        r"Layer 'buildings' in .*plain.gpkg lacks the field\(s\) .* of the LoD1 faces \(wit:extrudebuildings\)"),
    "buildcolorstore: not RGB": ("wit:buildcolorstore", lambda i, o: {
        "INPUT": i["gray"], "OUTPUT": str(o / "out.gpkg")}, "is not an RGB orthoimage"),
    "qualitymetrics: nothing to measure": ("wit:qualitymetrics", lambda i, o: {
        "OUTPUT": str(o / "out.csv")}, "Nothing to measure"),
    "mergerasters: zero-byte tile": ("wit:mergerasters", lambda i, o: {
        "INPUT": [i["rgb"], i["zero"]], "OUTPUT": str(o / "out.tif")},
        r"^Unable to execute algorithm\nInput rasters: The raster .*37709005.tif is empty \(0 bytes\)"),
    "buildcolorstore: zero-byte orthoimage": ("wit:buildcolorstore", lambda i, o: {
        "INPUT": i["zero"], "OUTPUT": str(o / "out.gpkg")},
        r"^Unable to execute algorithm\nRGB orthoimage: The raster .*37709005.tif is empty \(0 bytes\)"),
    "georeferencemapsheets: every tile unreadable": ("wit:georeferencemapsheets", lambda i, o: {
        "INPUT": [i["zero"], i["zero2"]], "OUTPUT": str(o / "geo")},
        (r"No orthoimage TIF could be georeferenced \(0 skipped, 2 failed\):\n  \(B060\)정사영상_2022_37709005.tif: "
         r"failed, The orthoimage .* is empty \(0 bytes\).*\n  \(B060\)정사영상_2022_37709004.tif: failed")),
    "citymodel: no sheet-named TIF": ("wit:citymodel", lambda i, o: {
        "ORTHO_INPUT": [i["rgb"]], "DEM": i["far_dem"], "BUILDINGS": i["footprints"],
        "OUTPUT": str(o / "out")},
        r"No orthoimage TIF has a valid map-sheet number in its name .*rgb.tif: no 5–9 digit"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_is_a_message_and_no_output(case, inputs, tmp_path, run_algorithm):
    algorithm, parameters, message = CASES[case]
    out = tmp_path / "out_dir"
    out.mkdir()
    with pytest.raises(QgsProcessingException, match=message) as error:
        run_algorithm(algorithm, parameters(inputs, out))
    assert "Traceback" not in str(error.value)
    leftovers = [p for p in out.rglob("*") if p.is_file()]
    assert leftovers == [], leftovers


# --- damaged rasters ---------------------------------------------------------------------------------

def _truncated(source, target) -> str:
    """The first half of ``source``'s bytes: the header opens, the pixels of the second half are gone."""
    data = Path(source).read_bytes()
    Path(target).write_bytes(data[:len(data) // 2])
    return str(target)


def _corrupted(source, target) -> str:
    """``source`` as a tiled DEFLATE GeoTIFF whose every tile is garbage after its zlib header: the file
    is whole and opens, but no pixel decodes (only a read can tell)."""
    gdal.Translate(str(target), str(source), creationOptions=["COMPRESS=DEFLATE", "TILED=YES"])
    ds = gdal.Open(str(target))
    blocks = []
    for band in (ds.GetRasterBand(b + 1) for b in range(ds.RasterCount)):
        bx, by = band.GetBlockSize()
        for y in range(-(-ds.RasterYSize // by)):
            for x in range(-(-ds.RasterXSize // bx)):
                blocks.append(tuple(int(band.GetMetadataItem(f"BLOCK_{k}_{x}_{y}", "TIFF"))
                                    for k in ("OFFSET", "SIZE")))
    ds = None
    data = bytearray(Path(target).read_bytes())
    for offset, size in blocks:
        data[offset + 2:offset + size] = b"\x55" * (size - 2)
    Path(target).write_bytes(data)
    return str(target)


def _digest(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def damaged(tmp_path_factory, real_rasters):
    """The real orthophoto and DEM cut in half and with undecodable tiles, in a folder of their own."""
    folder = tmp_path_factory.mktemp("damaged")
    return {"folder": folder, "footprints": real_rasters["footprints"], "lod1": real_rasters["lod1"],
            "truncated": {"ortho": _truncated(real_rasters["ortho"], folder / "ortho_half.tif"),
                          "dem": _truncated(real_rasters["dem"], folder / "dem_half.tif")},
            "corrupted": {"ortho": _corrupted(real_rasters["ortho"], folder / "ortho_garbled.tif"),
                          "dem": _corrupted(real_rasters["dem"], folder / "dem_garbled.tif")}}


DAMAGED = {
    "mergerasters": ("wit:mergerasters", "ortho", lambda d, o: {"INPUT": [d["ortho"]], "OUTPUT": str(o / "m.tif")}),
    "buildcolorstore": ("wit:buildcolorstore", "ortho", lambda d, o: {"INPUT": d["ortho"],
                                                                      "OUTPUT": str(o / "c.gpkg")}),
    "wittexture": ("wit:wittexture", "ortho", lambda d, o: {"ORTHO": d["ortho"], "LOD1": d["lod1"],
                                                            "OUTPUT": str(o / "tex")}),
    "triangulateterrain": ("wit:triangulateterrain", "dem", lambda d, o: {"DEM": d["dem"], "AREA": d["footprints"],
                                                                          "OUTPUT": str(o / "tin.gpkg")}),
    "extrudebuildings": ("wit:extrudebuildings", "dem", lambda d, o: {"BUILDINGS": d["footprints"], "DEM": d["dem"],
                                                                      "OUTPUT": str(o / "lod1.gpkg")}),
}


@pytest.mark.parametrize("damage", ["truncated", "corrupted"])
@pytest.mark.parametrize("case", sorted(DAMAGED))
def test_damaged_raster_is_one_message_naming_the_file(case, damage, damaged, tmp_path, run_algorithm,
                                                        gdal_exceptions):
    """A GeoTIFF cut in half is refused up front (its blocks run past the end of the file); one whose
    tiles do not decode is refused at the first read, naming band and window. Either way: one message
    naming the file, nothing written, inputs byte for byte as they were, GDAL exceptions on or off."""
    algorithm, raster, parameters = DAMAGED[case]
    rasters = damaged[damage]
    out = tmp_path / "out"
    out.mkdir()
    before = _digest(damaged["folder"])
    with pytest.raises(QgsProcessingException, match="truncated or damaged") as error:
        run_algorithm(algorithm, parameters({**damaged, **rasters}, out))
    message = str(error.value)
    kind = "DEM" if raster == "dem" else "tile" if case == "mergerasters" else "orthoimage"
    if damage == "truncated":
        assert f"The raster {rasters[raster]} is truncated: its pixel data runs to byte" in message  # up front
    else:
        assert f"Cannot read the {kind} {rasters[raster]}, band" in message and "IReadBlock failed" in message
    assert "Traceback" not in message
    assert list(out.rglob("*")) == []
    assert _digest(damaged["folder"]) == before
