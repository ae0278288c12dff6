"""The bulk-loaded R-tree: what SQLite's own inserts (GDAL 3.6's CreateSpatialIndex) would hold, consistent by
SQLite's ``rtreecheck``, answering window queries alike, and editable afterwards."""
from __future__ import annotations

import sqlite3

import numpy as np
import pyproj
import pytest
import shapely
from osgeo import ogr

from wit_plugin.infra.io import gpkg_bulk
from wit_plugin.infra.io.gpkg_rtree import bulk_load, outward_float32
from wit_plugin.infra.io.vector_io import FieldDef

pytestmark = pytest.mark.qgis_facing  # on each QGIS's GDAL and SQLite: the index is written in SQLite's format

WINDOWS = [(200300.0, 200500.0, 540200.0, 540300.0), (-10.0, 10.0, -10.0, 10.0), (200000.0, 201000.0, 540000.0,
                                                                                    541000.0)]


def _rtree() -> sqlite3.Connection:
    db = sqlite3.connect(":memory:")
    db.execute("CREATE VIRTUAL TABLE r USING rtree(id, minx, maxx, miny, maxy)")
    return db


def _boxes(n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.where(rng.random(n) < 0.1, rng.uniform(-5, 5, n), 200000 + rng.random(n) * 1000)  # some round zero
    y = np.where(x < 100, rng.uniform(-5, 5, n), 540000 + rng.random(n) * 1000)
    return np.column_stack([x, x + rng.random(n) * 3, y, y + rng.random(n) * 3])


@pytest.mark.parametrize("count", [0, 1, 51, 52, 2601, 2602, 20000])  # a root leaf, full, two levels, three
def test_bulk_load_holds_what_sqlite_inserts_would(count):
    boxes, ids = _boxes(count), np.arange(1, count + 1) * 3
    bulk, inserted = _rtree(), _rtree()
    bulk_load(bulk, "r", ids, boxes)
    inserted.executemany("INSERT INTO r VALUES (?, ?, ?, ?, ?)", [(int(i), *b) for i, b in zip(ids, boxes.tolist())])
    assert bulk.execute("SELECT rtreecheck('r')").fetchone() == ("ok",)
    assert bulk.execute("SELECT * FROM r ORDER BY id").fetchall() == \
        inserted.execute("SELECT * FROM r ORDER BY id").fetchall()
    window = "SELECT id FROM r WHERE maxx >= ? AND minx <= ? AND maxy >= ? AND miny <= ? ORDER BY id"
    for xmin, xmax, ymin, ymax in WINDOWS:
        found = bulk.execute(window, (xmin, xmax, ymin, ymax)).fetchall()
        assert found == inserted.execute(window, (xmin, xmax, ymin, ymax)).fetchall()
    depth = bulk.execute("SELECT substr(data, 1, 2) FROM r_node WHERE nodeno = 1").fetchone()[0]
    assert int.from_bytes(depth, "big") == (0 if count <= 51 else 1 if count <= 51 * 51 else 2)


def test_outward_rounding_is_sqlites_for_both_signs():
    values = np.array([[200000.123456789, 200000.123456789, -550000.987654321, -550000.987654321],
                       [0.1, 0.1, -0.1, -0.1], [1.5, 1.5, -2.0, -2.0]])
    db = _rtree()
    db.executemany("INSERT INTO r VALUES (?, ?, ?, ?, ?)", [(k, *v) for k, v in enumerate(values.tolist())])
    stored = np.array(db.execute("SELECT minx, maxx, miny, maxy FROM r ORDER BY id").fetchall())
    assert outward_float32(values).astype(np.float64).tolist() == stored.tolist()
    assert (stored[:, [0, 2]] <= values[:, [0, 2]]).all() and (stored[:, [1, 3]] >= values[:, [1, 3]]).all()


def test_a_bulk_loaded_tree_takes_edits():
    """A user edits the layer later: SQLite inserts into full nodes (splits) and deletes (reinserts) as usual."""
    db = _rtree()
    boxes = _boxes(5000)
    bulk_load(db, "r", np.arange(1, 5001), boxes)
    db.executemany("INSERT INTO r VALUES (?, ?, ?, ?, ?)", [(5000 + k, *b) for k, b in
                                                            enumerate(_boxes(3000, seed=2).tolist(), start=1)])
    db.execute("DELETE FROM r WHERE id % 3 = 0")
    assert db.execute("SELECT rtreecheck('r')").fetchone() == ("ok",)
    assert db.execute("SELECT count(*) FROM r").fetchone() == (8000 - 8000 // 3,)


def test_write_layer_index_is_ogrs_own(tmp_path):
    """The TIN's writer: the same R-tree entries and triggers as GDAL's CreateSpatialIndex over the same rows,
    and OGR's spatial filter finds the triangles it should (a brute-force check of the envelopes)."""
    corners = np.random.default_rng(5).uniform(0, 1000, (6000, 3, 3)) + [200000, 540000, 0]
    fields = [FieldDef("n", ogr.OFTInteger)]
    crs = pyproj.CRS.from_epsg(5186)
    bulk, plain = tmp_path / "bulk.gpkg", tmp_path / "plain.gpkg"
    gpkg_bulk.write_layer(bulk, "tin", crs, fields, corners, [np.arange(6000)], spatial_index=True)
    gpkg_bulk.write_layer(plain, "tin", crs, fields, corners, [np.arange(6000)], spatial_index=False)
    ds = ogr.Open(str(plain), update=1)
    ds.ExecuteSQL("SELECT CreateSpatialIndex('tin', 'geom')")  # GDAL's own, a row at a time
    ds = None
    ours, gdals = sqlite3.connect(bulk), sqlite3.connect(plain)
    assert ours.execute("SELECT rtreecheck('rtree_tin_geom')").fetchone() == ("ok",)
    assert ours.execute("SELECT * FROM rtree_tin_geom ORDER BY id").fetchall() == \
        gdals.execute("SELECT * FROM rtree_tin_geom ORDER BY id").fetchall()
    schema = "SELECT type, name, sql FROM sqlite_master WHERE name NOT LIKE 'sqlite_%' ORDER BY name"
    assert ours.execute(schema).fetchall() == gdals.execute(schema).fetchall()  # the triggers are back as OGR made them
    assert ours.execute("SELECT * FROM gpkg_extensions").fetchall() == \
        gdals.execute("SELECT * FROM gpkg_extensions").fetchall()
    ours.close()
    gdals.close()
    layer_ds = ogr.Open(str(bulk))
    layer = layer_ds.GetLayer("tin")
    layer.SetSpatialFilterRect(200400, 540400, 200420, 540410)
    found = sorted(f.GetField("n") for f in layer)
    triangles = shapely.polygons(corners[:, [0, 1, 2, 0]])
    assert found == np.flatnonzero(shapely.intersects(triangles, shapely.box(200400, 540400, 200420, 540410))).tolist()
    assert found


def test_a_feature_added_by_ogr_is_indexed(tmp_path):
    """The R-tree's triggers work after the bulk load: a triangle added through OGR (as QGIS adds one) is found
    by the spatial filter, and the tree stays sound."""
    path = tmp_path / "tin.gpkg"
    corners = np.random.default_rng(6).uniform(0, 100, (300, 3, 3)) + [200000, 540000, 0]
    gpkg_bulk.write_layer(path, "tin", pyproj.CRS.from_epsg(5186), [FieldDef("n", ogr.OFTInteger)], corners,
                          [np.arange(300)])
    ds = ogr.Open(str(path), update=1)
    layer = ds.GetLayer("tin")
    feature = ogr.Feature(layer.GetLayerDefn())
    feature.SetField("n", 999)
    feature.SetGeometry(ogr.CreateGeometryFromWkt("POLYGON Z ((205000 545000 1,205001 545000 1,205000 545001 1,"
                                                  "205000 545000 1))"))
    assert layer.CreateFeature(feature) == ogr.OGRERR_NONE
    ds = None
    ds = ogr.Open(str(path))
    layer = ds.GetLayer("tin")
    layer.SetSpatialFilterRect(204999, 544999, 205002, 545002)
    assert [f.GetField("n") for f in layer] == [999]
    ds = None
    db = sqlite3.connect(path)
    assert db.execute("SELECT rtreecheck('rtree_tin_geom')").fetchone() == ("ok",)
    assert db.execute("SELECT count(*) FROM rtree_tin_geom").fetchone() == (301,)


def test_nodes_take_the_size_sqlite_gave_the_tree():
    """On small pages SQLite makes smaller nodes (1024-byte pages: 960 bytes, 39 cells): the loader packs as many."""
    bulk, inserted = sqlite3.connect(":memory:"), sqlite3.connect(":memory:")
    for db in (bulk, inserted):
        db.execute("PRAGMA page_size = 1024")
        db.execute("CREATE VIRTUAL TABLE r USING rtree(id, minx, maxx, miny, maxy)")
    boxes = _boxes(3000)
    bulk_load(bulk, "r", np.arange(1, 3001), boxes)
    inserted.executemany("INSERT INTO r VALUES (?, ?, ?, ?, ?)", [(k, *b) for k, b in enumerate(boxes.tolist(), 1)])
    assert bulk.execute("SELECT DISTINCT length(data) FROM r_node").fetchall() == [(960,)]
    assert bulk.execute("SELECT max(substr(data, 3, 2)) FROM r_node").fetchone()[0] == (39).to_bytes(2, "big")
    assert bulk.execute("SELECT rtreecheck('r')").fetchone() == ("ok",)
    assert bulk.execute("SELECT * FROM r ORDER BY id").fetchall() == \
        inserted.execute("SELECT * FROM r ORDER BY id").fetchall()
