"""Bulk reading (bulk_read) and ring text (numtext): the same values OGR and Python formatting give."""
from __future__ import annotations

import numpy as np
import pytest
from osgeo import ogr

from wit_plugin.infra.io import bulk_read
from wit_plugin.infra.numtext import ring_texts

TRIANGLE = "POLYGON Z ((200000.125 540000 10.5, 200004 540000 11, 200000 540003.3 12.25, 200000.125 540000 10.5))"
SHAPES = [TRIANGLE, None, "POLYGON Z ((0 0 1, 9 0 1, 9 9 1, 0 9 1, 0 0 1), (1 1 1, 2 1 1, 2 2 1, 1 1 1))",
          "MULTIPOLYGON Z (((0 0 1, 1 0 1, 1 1 1, 0 0 1)))", "POINT Z (1 2 3)", "POLYGON Z EMPTY",
          "MULTIPOLYGON Z (((0 0 1, 1 0 1, 1 1 1, 0 0 1)), ((5 5 1, 6 5 1, 6 6 1, 5 5 1)))"]


def _layer(tmp_path, driver: str, shapes: list[str | None]) -> tuple[ogr.DataSource, ogr.Layer]:
    path = str(tmp_path / ("t.gpkg" if driver == "GPKG" else "t")) if driver != "Memory" else "m"
    ds = ogr.GetDriverByName(driver).CreateDataSource(path)
    layer = ds.CreateLayer("t", None, ogr.wkbUnknown if driver == "GPKG" else ogr.wkbPolygon25D)
    layer.CreateField(ogr.FieldDefn("tri_id", ogr.OFTInteger))
    layer.CreateField(ogr.FieldDefn("name", ogr.OFTString))
    for i, wkt in enumerate(shapes):
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField("tri_id", i)
        if i % 2 == 0:
            feature.SetField("name", f"수서 {i}")
        if wkt:
            feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
        layer.CreateFeature(feature)
    return ds, layer


def _ogr_rings(layer: ogr.Layer) -> list[list[tuple[float, ...]] | None]:
    rings = []
    layer.ResetReading()
    for feature in layer:
        geom = feature.GetGeometryRef()
        if geom is not None and geom.GetGeometryName() == "MULTIPOLYGON" and geom.GetGeometryCount() == 1:
            geom = geom.GetGeometryRef(0)
        ok = geom is not None and geom.GetGeometryName() == "POLYGON" and not geom.IsEmpty()
        rings.append(geom.GetGeometryRef(0).GetPoints() if ok else None)
    return rings


@pytest.mark.parametrize("driver", ["GPKG", "Memory"])
def test_batches_give_what_ogr_reads_feature_by_feature(tmp_path, driver):
    ds, layer = _layer(tmp_path, driver, SHAPES)
    expected = _ogr_rings(layer)
    batches = list(bulk_read.batches(layer, size=3, fid=True))
    assert [len(b["geometry"]) for b in batches] == [3, 3, 1]
    points, counts, rings = (np.concatenate(parts) for parts in zip(
        *(bulk_read.exterior_rings(b["geometry"]) for b in batches)))
    assert rings.tolist() == [1, 0, 2, 1, 0, 0, 0]
    assert counts.tolist() == [len(r) if r else 0 for r in expected]
    assert [tuple(p) for p in points.tolist()] == [p for r in expected if r for p in r]
    assert [t for b in batches for t in bulk_read.texts(b["name"])] == [
        f"수서 {i}" if i % 2 == 0 else "" for i in range(len(SHAPES))]
    assert [t for b in batches for t in bulk_read.texts(b["tri_id"])] == [str(i) for i in range(len(SHAPES))]
    assert np.concatenate([bulk_read.valid(b["name"]) for b in batches]).tolist() == [i % 2 == 0 for i in range(7)]
    assert bulk_read.geometry_name(batches[1]["geometry"][1]) == "a POINT"
    assert bulk_read.geometry_name(batches[0]["geometry"][1]) == "no geometry"
    assert bulk_read.geometry_name(batches[1]["geometry"][2]) == "an empty POLYGON"


def test_triangles_are_unpacked_without_shapely_and_agree_with_it(tmp_path):
    shapes = [TRIANGLE.replace("200000.125", f"{200000 + k / 7:.6f}") for k in range(20)]
    ds, layer = _layer(tmp_path, "GPKG", shapes)
    (batch,) = bulk_read.batches(layer)
    corners = bulk_read.triangles(batch["geometry"])
    assert corners.shape == (20, 4, 3)
    wkb = np.array(batch["geometry"].tolist(), dtype=object)  # the same WKB, not as one fixed-size block
    assert bulk_read.triangles(wkb) is None
    points, counts, rings = bulk_read.exterior_rings(wkb)
    assert (corners.reshape(-1, 3) == points).all() and (counts == 4).all() and (rings == 1).all()
    assert [tuple(p) for p in corners.reshape(-1, 3).tolist()] == [p for r in _ogr_rings(layer) for p in r]


@pytest.mark.parametrize("point_format", ["%.3f %.3f %.3f", "%.7g %.7g %.7g"])
def test_ring_texts_equal_point_by_point_formatting(point_format):
    rng = np.random.default_rng(3)
    corners = rng.choice(np.concatenate([rng.uniform(-1e6, 1e6, 40), [0.0, -0.0, 1e-9, 0.0005, 2.5e-4, np.nan]]),
                         size=(300, 3))
    counts = rng.integers(1, 7, 60)
    counts[-1] += 300 - counts.sum()
    expected, start = [], 0
    for n in counts.tolist():
        expected.append(" ".join(point_format % tuple(p) for p in corners[start:start + n].tolist()))
        start += n
    assert ring_texts(corners, counts, point_format) == expected
    assert ring_texts(corners, np.full(100, 3), point_format) == [
        " ".join(point_format % tuple(p) for p in corners[k:k + 3].tolist()) for k in range(0, 300, 3)]
    assert ring_texts(np.empty((0, 3)), np.zeros(0, dtype=int), point_format) == []


def test_unique_rows_unordered_group_equal_bytes_even_when_hashes_collide(monkeypatch):
    """(ring_texts and the 3D Tiles export's transforms: each distinct point once, -0.0 apart from 0.0.)"""
    from wit_plugin.infra import arrays

    points = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [-0.0, 0.0, 0.0], [1.0, 2.0, 3.5],
                       [0.0, 0.0, 0.0]])
    for factor in (arrays._HASH_FACTOR, np.uint64(0)):  # 0: every row hashes alike, so rows are sorted instead
        monkeypatch.setattr(arrays, "_HASH_FACTOR", factor)
        distinct, index = arrays.unique_rows_unordered(points)
        assert len(distinct) == 4  # -0.0 is another point than 0.0 by its bytes, as a transform may tell
        assert distinct[index].tobytes() == points.tobytes()
        assert index[0] == index[2] and index[1] == index[5] and len(set(index[[0, 1, 3, 4]].tolist())) == 4
        uv = points[:, :2].copy()  # rows of two numbers (texture coordinates)
        distinct, index = arrays.unique_rows_unordered(uv)
        assert len(distinct) == 3 and distinct[index].tobytes() == uv.tobytes()


def test_the_collector_is_paused_inside_and_restored_after():
    import gc

    from wit_plugin.infra.gc_pause import collector_paused

    assert gc.isenabled()
    with pytest.raises(KeyError), collector_paused():
        assert not gc.isenabled()
        raise KeyError
    assert gc.isenabled()
    gc.disable()
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()  # left as it was found
    finally:
        gc.enable()
