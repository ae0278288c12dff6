"""Every algorithm turns bad input into a QgsProcessingException with a message, and writes nothing."""
from __future__ import annotations

import numpy as np
import pytest
from osgeo import gdal, ogr, osr
from qgis.core import QgsProcessingException


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


def _polygons(path, name, fields=()):
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer(name, srs, ogr.wkbPolygon)
    for field in fields:
        layer.CreateField(ogr.FieldDefn(field, ogr.OFTString))
    feature = ogr.Feature(layer.GetLayerDefn())
    feature.SetGeometry(ogr.CreateGeometryFromWkt(
        "POLYGON((209002 543002,209010 543002,209010 543010,209002 543010,209002 543002))"))
    layer.CreateFeature(feature)
    del layer, ds
    return f"{path}|layername={name}"


@pytest.fixture
def inputs(tmp_path):
    return {
        "rgb": _raster(tmp_path / "rgb.tif", 3),
        "gray": _raster(tmp_path / "gray.tif", 1),
        "far_dem": _raster(tmp_path / "far.tif", 1, x0=150000.0, y0=450000.0),
        "footprints": _polygons(tmp_path / "plain.gpkg", "buildings", ("wit_id",)),
    }


CASES = {
    "mergetiles: different band counts": ("wit:mergetiles", lambda i, o: {
        "INPUT": [i["rgb"], i["gray"]], "OUTPUT": str(o / "out.tif")}, r"has 1 band\(s\) but"),
    "triangulateterrain: DEM elsewhere": ("wit:triangulateterrain", lambda i, o: {
        "DEM": i["far_dem"], "AREA": i["footprints"], "OUTPUT": str(o / "out.gpkg")}, "does not cover the area"),
    "extrudebuildings: DEM elsewhere": ("wit:extrudebuildings", lambda i, o: {
        "BUILDINGS": i["footprints"], "DEM": i["far_dem"], "OUTPUT": str(o / "out.gpkg")}, "does not cover the area"),
    "wittexture: not an LoD1 layer": ("wit:wittexture", lambda i, o: {
        "ORTHO": i["rgb"], "LOD1": i["footprints"], "OUTPUT": str(o / "out")}, "has no layer 'lod1_faces'"),
    "writecitygml: not an LoD1 layer": ("wit:writecitygml", lambda i, o: {
        "LOD1": i["footprints"], "OUTPUT": str(o / "out.gml")}, "has no layer 'lod1_faces'"),
    "buildcolorstore: not RGB": ("wit:buildcolorstore", lambda i, o: {
        "INPUT": i["gray"], "OUTPUT": str(o / "out.gpkg")}, "is not an RGB orthoimage"),
    "qualitymetrics: nothing to measure": ("wit:qualitymetrics", lambda i, o: {
        "OUTPUT": str(o / "out.csv")}, "Nothing to measure"),
    "citymodel: no sheet-named TIF": ("wit:citymodel", lambda i, o: {
        "ORTHO_INPUT": [i["rgb"]], "DEM": i["far_dem"], "BUILDINGS": i["footprints"],
        "OUTPUT": str(o / "out")}, "No orthoimage TIF has a valid map-sheet number"),
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
