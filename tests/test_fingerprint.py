"""The pieces of a fingerprint (``chain.fingerprint``, ``io.digests``), alone: what changes a digest, what not."""
from __future__ import annotations

import numpy as np
import pyproj
import shapely
from osgeo import gdal, ogr, osr

from wit_plugin.chain.fingerprint import Fingerprint, LayerDigests
from wit_plugin.infra.io.digests import digest, file_digest, raster_window_digest
from wit_plugin.infra.io.vector_io import read_layer


def _layer(path, features: list[tuple[str, int, str]]) -> str:
    """A GeoPackage of (id, storeys, WKT) buildings in EPSG:5186."""
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    layer = ds.CreateLayer("buildings", srs, ogr.wkbPolygon)
    layer.CreateField(ogr.FieldDefn("UFID", ogr.OFTString))
    layer.CreateField(ogr.FieldDefn("GRO_FLO_CO", ogr.OFTInteger))
    for ufid, storeys, wkt in features:
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField("UFID", ufid)
        feature.SetField("GRO_FLO_CO", storeys)
        feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
        layer.CreateFeature(feature)
    ds = None
    return str(path)


A, B = "POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))", "POLYGON ((100 0, 110 0, 110 10, 100 10, 100 0))"


def _digests(path) -> LayerDigests:
    return LayerDigests(read_layer(path), "BLD", [("UFID",)])


def test_a_buildings_attributes_change_its_full_digest_its_footprint_both(tmp_path):
    base = _digests(_layer(tmp_path / "a.gpkg", [("1", 3, A), ("2", 5, B)]))
    taller = _digests(_layer(tmp_path / "b.gpkg", [("1", 4, A), ("2", 5, B)]))
    moved = _digests(_layer(tmp_path / "c.gpkg", [("1", 3, A.replace("10 10", "10 11")), ("2", 5, B)]))
    assert (base.full[0] != taller.full[0]).any() and (base.shape[0] == taller.shape[0]).all()
    assert (base.full[0] != moved.full[0]).any() and (base.shape[0] != moved.shape[0]).any()
    assert (base.full[1] == taller.full[1]).all()  # the other building's are its own
    both = np.array([0, 1])
    assert base.digest(both, np.array([False, True])) == taller.digest(both, np.array([False, True]))
    assert base.digest(both) != taller.digest(both)


def test_the_order_of_the_features_counts(tmp_path):
    """Ids repeated are numbered in the order read (``vectors.unique_ids``): the same features in another order
    may give other ids."""
    one = _digests(_layer(tmp_path / "a.gpkg", [("1", 3, A), ("2", 5, B)]))
    other = _digests(_layer(tmp_path / "b.gpkg", [("2", 5, B), ("1", 3, A)]))
    assert one.digest(np.array([0, 1])) != other.digest(np.array([0, 1]))


def test_a_box_selects_the_features_whose_box_meets_it_and_those_no_box_holds(tmp_path):
    path = _layer(tmp_path / "a.gpkg", [("1", 3, A), ("2", 5, B), ("3", 1, "POLYGON ((0 0, 1 0, 1 1, 0 0))")])
    layer = read_layer(path)
    layer.geoms[2] = shapely.Polygon([(0, 0), (np.inf, 0), (1, 1)])  # a non-finite coordinate: read by every read
    digests = LayerDigests(layer)
    assert digests.select((-5, -5, 5, 5), "EPSG:5186").tolist() == [0, 2]
    assert digests.select((50, -5, 99.5, 5), "EPSG:5186").tolist() == [1, 2]  # within SLACK (1 m) of B
    assert digests.select((50, -5, 98, 5), "EPSG:5186").tolist() == [2]
    to_5179 = pyproj.Transformer.from_crs("EPSG:5186", "EPSG:5179", always_xy=True)  # a box in the run's CRS
    box = to_5179.transform_bounds(-5, -5, 5, 5)
    assert LayerDigests(read_layer(path)).select(box, "EPSG:5179").tolist() == [0, 2]  # not B, 90 m away


def test_a_raster_window_digest_sees_its_cells_only(tmp_path):
    def dem(name: str, bump: tuple[int, int] | None) -> str:
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(5186)
        ds = gdal.GetDriverByName("GTiff").Create(str(tmp_path / name), 100, 100, 1, gdal.GDT_Float32)
        ds.SetGeoTransform((0.0, 5.0, 0.0, 500.0, 0.0, -5.0))
        ds.SetProjection(srs.ExportToWkt())
        values = np.full((100, 100), 30.0, dtype=np.float32)
        if bump:
            values[bump] += 2.0
        ds.GetRasterBand(1).WriteArray(values)
        ds = None
        return str(tmp_path / name)

    plain, bumped = dem("a.tif", None), dem("b.tif", (10, 90))  # the cell of x 450–455, y 445–450
    west, east = (0.0, 0.0, 200.0, 200.0), (300.0, 300.0, 480.0, 480.0)
    assert raster_window_digest(plain, west, 2) == raster_window_digest(bumped, west, 2)
    assert raster_window_digest(plain, east, 2) != raster_window_digest(bumped, east, 2)
    assert file_digest(plain) != file_digest(bumped)


def test_a_fingerprint_names_what_changed_settings_first():
    old = Fingerprint({"max_edge": 15.0, "plugin": "0.1.0"}, {"buildings": "a", "dem": "b"})
    new = Fingerprint({"max_edge": 25.0, "plugin": "0.1.0"}, {"buildings": "a", "dem": "c"})
    assert new.changes(old.as_dict()) == ["max_edge", "dem"] and new.digest != old.digest
    assert Fingerprint(*[{"max_edge": 15.0, "plugin": "0.1.0"}, {"buildings": "a", "dem": "b"}]).digest == old.digest
    assert old.changes(old.as_dict()) == [] and old.changes(None) == ["max_edge", "plugin", "buildings", "dem"]
    assert digest("ab", "c") != digest("a", "bc")
