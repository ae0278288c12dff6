"""Bulk GeoPackage writer: what OGR reads back is exactly what was written, index and all."""
from __future__ import annotations

import sqlite3

import numpy as np
import pyproj
import pytest
import shapely
from osgeo import ogr

from wit_plugin.infra.errors import CanceledError
from wit_plugin.infra.io import gpkg_bulk, sql
from wit_plugin.infra.io.vector_io import FieldDef

CRS = pyproj.CRS.from_epsg(5186)
FIELDS = [FieldDef("n", ogr.OFTInteger), FieldDef("h", ogr.OFTReal), FieldDef("name", ogr.OFTString)]
COURTYARD = shapely.Polygon([(0, 0, 1), (30, 0, 1), (30, 20, 1.5), (0, 20, 1.5)],
                            [[(10, 5, 1.25), (10, 15, 1.25), (20, 15, 1.25), (20, 5, 1.25)]])


def _geoms(n: int) -> np.ndarray:
    xy = np.random.default_rng(1).uniform(200000, 201000, (n, 2)).round(3)
    tris = [shapely.Polygon([(x, y, 10.123), (x + 4, y, 11.456), (x, y + 3, 12.789)]) for x, y in xy]
    return np.array([shapely.affinity.translate(COURTYARD, 200000, 540000)] + tris, dtype=object)


def _read(path):
    ds = ogr.Open(str(path))
    lyr = ds.GetLayer("faces")
    rows = [(f.GetFID(), bytes(f.GetGeometryRef().ExportToIsoWkb()), f.GetField("n"), f.GetField("h"),
             f.GetField("name")) for f in lyr]
    return ds, lyr, rows


@pytest.mark.parametrize("index", [True, False])
def test_written_layer_reads_back_exactly(tmp_path, index):
    geoms = _geoms(50)
    names = ["수서동 건물"] + [None if k % 7 == 0 else f"b{k}" for k in range(1, len(geoms))]
    columns = [np.arange(len(geoms)), [None] + [1.5 * k for k in range(1, len(geoms))], names]
    path = tmp_path / "faces.gpkg"
    assert gpkg_bulk.write_layer(path, "faces", CRS, FIELDS, geoms, columns, spatial_index=index) == len(geoms)
    ds, lyr, rows = _read(path)
    assert lyr.GetGeomType() == ogr.wkbPolygon25D
    assert lyr.GetSpatialRef().GetAuthorityCode(None) == "5186"
    assert [r[0] for r in rows] == list(range(1, len(geoms) + 1))
    for (_, wkb, n, h, name), geom, k in zip(rows, geoms, range(len(geoms))):
        assert shapely.equals_exact(shapely.from_wkb(wkb), geom, tolerance=0)
        assert shapely.get_coordinates(shapely.from_wkb(wkb), include_z=True).tolist() == \
            shapely.get_coordinates(geom, include_z=True).tolist()
        assert (n, h, name) == (k, columns[1][k], names[k])
    x0, y0, x1, y1 = shapely.total_bounds(geoms)
    assert lyr.GetExtent() == pytest.approx((x0, x1, y0, y1), abs=1e-6)
    lyr.SetSpatialFilterRect(200000, 540000, 200031, 540021)  # only the courtyard building
    assert [f.GetFID() for f in lyr] == [1]
    del lyr, ds  # close before reading the file with sqlite3
    db = sqlite3.connect(path)
    tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    assert ("rtree_faces_geom" in tables) == index
    assert db.execute("SELECT feature_count FROM gpkg_ogr_contents WHERE table_name = 'faces'").fetchone() == \
        (len(geoms),)  # the count GDAL keeps and trusts
    # OGR's feature-count triggers, dropped while the rows went in, are back as OGR made them
    triggers = "SELECT name FROM sqlite_master WHERE type = 'trigger' AND name LIKE 'trigger_%'"
    assert {r[0] for r in db.execute(triggers)} == {"trigger_insert_feature_count_faces",
                                                    "trigger_delete_feature_count_faces"}
    if not index:  # (the R-tree's triggers need OGR's SQL functions)
        db.execute("INSERT INTO faces (n) VALUES (99)")
        assert db.execute("SELECT feature_count FROM gpkg_ogr_contents WHERE table_name = 'faces'").fetchone() == \
            (len(geoms) + 1,)
        db.rollback()
    if index:
        assert db.execute("SELECT rtreecheck('rtree_faces_geom')").fetchone() == ("ok",)
        assert db.execute("SELECT count(*) FROM rtree_faces_geom").fetchone() == (len(geoms),)


def test_rows_keep_their_order_across_insert_statements(tmp_path, monkeypatch):
    """Many rows per INSERT: 3 a statement here (12 values, 4 columns), so 17 statements, the last one partial."""
    monkeypatch.setattr(gpkg_bulk, "MAX_VALUES", 12)
    geoms = _geoms(50)
    names = [f"b{k}" for k in range(len(geoms))]
    path = tmp_path / "faces.gpkg"
    gpkg_bulk.write_layer(path, "faces", CRS, FIELDS, geoms, [np.arange(len(geoms)), [0.5] * len(geoms), names])
    ds, lyr, rows = _read(path)
    assert [(fid, n, name) for fid, _, n, _, name in rows] == [(k + 1, k, f"b{k}") for k in range(len(geoms))]
    assert [shapely.from_wkb(r[1]).wkt for r in rows] == [g.wkt for g in geoms]


def test_an_empty_layer_is_a_valid_geopackage(tmp_path):
    path = tmp_path / "faces.gpkg"
    assert gpkg_bulk.write_layer(path, "faces", CRS, FIELDS, np.array([], dtype=object), [[], [], []]) == 0
    ds, lyr, rows = _read(path)
    assert rows == [] and lyr.GetGeomType() == ogr.wkbPolygon25D


def test_cancel_between_batches_leaves_no_file(tmp_path, monkeypatch, cancel_after_checks):
    monkeypatch.setattr(gpkg_bulk, "BATCH", 10)
    path = tmp_path / "faces.gpkg"
    geoms = _geoms(50)
    with pytest.raises(CanceledError):
        gpkg_bulk.write_layer(path, "faces", CRS, FIELDS, geoms, [range(51), [1.0] * 51, ["x"] * 51],
                              feedback=cancel_after_checks(2))
    assert list(tmp_path.iterdir()) == []


def test_columns_must_match_fields_and_rows(tmp_path):
    with pytest.raises(ValueError):
        gpkg_bulk.write_layer(tmp_path / "x.gpkg", "faces", CRS, FIELDS, _geoms(2), [[1, 2, 3]])


def test_triangle_corners_give_the_same_blobs_as_shapely(tmp_path):
    corners = np.random.default_rng(2).uniform(0, 1000, (40, 3, 3)) + [200000, 540000, 0]
    polygons = shapely.polygons(corners[:, [0, 1, 2, 0]])
    assert gpkg_bulk.envelopes(corners).tolist() == shapely.bounds(polygons).tolist()
    assert gpkg_bulk.geometry_blobs(corners, 7, gpkg_bulk.envelopes(corners)) == \
        gpkg_bulk.geometry_blobs(polygons, 7, shapely.bounds(polygons))
    path = tmp_path / "faces.gpkg"
    gpkg_bulk.write_layer(path, "faces", CRS, FIELDS, corners, [range(40), [0.5] * 40, ["t"] * 40])
    ds, lyr, rows = _read(path)
    assert [shapely.get_coordinates(shapely.from_wkb(r[1]), include_z=True).tolist() for r in rows] == \
        corners[:, [0, 1, 2, 0]].tolist()
    x0, y0, x1, y1 = shapely.total_bounds(polygons)
    assert lyr.GetExtent() == pytest.approx((x0, x1, y0, y1), abs=1e-6)


_FULL_DISK_CHILD = r"""
import json, os, resource, signal, sys, tempfile
sys.path.insert(0, sys.argv[1])
import numpy as np, pyproj
from osgeo import ogr
from wit_plugin.infra.io.gpkg_bulk import write_layer
from wit_plugin.infra.io.vector_io import FieldDef

signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as on a full disk
corners = np.random.default_rng(3).uniform(0, 1000, (3000, 3, 3)) + [200000, 540000, 0]
outcomes = []
for limit in json.loads(sys.argv[2]):
    folder = tempfile.mkdtemp(dir=sys.argv[3])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))
    try:
        write_layer(os.path.join(folder, "tin.gpkg"), "tin", pyproj.CRS.from_epsg(5186),
                    [FieldDef("n", ogr.OFTInteger)], corners, [np.arange(len(corners))],
                    spatial_index=sys.argv[4] == "index")
        outcome = "ok"
    except Exception as exc:
        outcome = f"{type(exc).__name__}: {exc}"
    resource.setrlimit(resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
    outcomes.append([limit, outcome, sorted(os.listdir(folder))])
print(json.dumps(outcomes))
"""


@pytest.mark.parametrize("index", ["index", "no-index"])
def test_a_full_disk_is_an_input_error_naming_the_file_and_leaves_nothing(tmp_path, index):
    """Every point where a write can fail (the file, the layer's table that OGR creates late, the rows, the
    feature count, the R-tree): a clear InputError, never SQLite's or a TypeError (OGR's late creation of the
    table failed unreported when the dataset was destroyed, and the row lookup hit None — the
    "'NoneType' object is not subscriptable" once seen in a tiled run's terrain step)."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    limits = [4096, 16384, 32768, 49152, 65536, 81920, 98304, 131072, 196608, 262144, 393216, 524288, 10 ** 8]
    child = subprocess.run([sys.executable, "-c", _FULL_DISK_CHILD, str(Path(__file__).resolve().parents[1]),
                            json.dumps(limits), str(tmp_path), index], check=False, capture_output=True, text=True,
                           timeout=600)
    assert child.returncode == 0, child.stderr[-2000:]
    outcomes = json.loads(child.stdout)
    failures = [(limit, outcome) for limit, outcome, _ in outcomes if outcome != "ok"]
    assert outcomes[-1][1] == "ok" and len(failures) >= 5, outcomes
    for limit, outcome in failures:
        assert outcome.startswith("InputError: Cannot write the layer 'tin' into ") and outcome.endswith(
            ". Is the disk full?"), (limit, outcome)
    assert all(files == [] for _, outcome, files in outcomes if outcome != "ok")  # nothing half-written
    assert all(files == ["tin.gpkg"] for _, outcome, files in outcomes if outcome == "ok")



_OUTLIVING_DATASET_CHILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np, pyproj
from osgeo import ogr
from wit_plugin.infra.io.gpkg_bulk import write_layer
from wit_plugin.infra.io.vector_io import FieldDef

kept = []
create_layer = ogr.DataSource.CreateLayer


def outliving(ds, *args, **kwargs):
    kept.append(ds)  # as the sampled frame of this call would hold it
    return create_layer(ds, *args, **kwargs)


ogr.DataSource.CreateLayer = outliving
corners = np.random.default_rng(4).uniform(0, 100, (500, 3, 3)) + [200000, 540000, 0]
try:
    print(write_layer(sys.argv[2], "tin", pyproj.CRS.from_epsg(5186), [FieldDef("n", ogr.OFTInteger)], corners,
                      [np.arange(500)], spatial_index=sys.argv[3] == "index"), len(kept))
except Exception as exc:
    print(f"{type(exc).__name__}: {exc}")
kept.clear()  # the profiler lets go: the dataset is destroyed now, after the file was moved into place
"""


@pytest.mark.parametrize("index", ["index", "no-index"])
def test_the_table_is_there_when_the_dataset_outlives_its_creation(tmp_path, index):
    """OGR creates a new layer's table when the dataset is flushed or destroyed, and Dask's worker profiler can
    keep the dataset alive for a moment (in the frames it samples). With the dataset kept alive the rows are
    still written (the writer once failed with "'NoneType' object is not subscriptable" there, in a tile's
    terrain step) and read back whole once it is let go. In a plain Python, as a Dask worker is."""
    import subprocess
    import sys
    from pathlib import Path

    path = tmp_path / "tin.gpkg"
    child = subprocess.run([sys.executable, "-c", _OUTLIVING_DATASET_CHILD, str(Path(__file__).resolve().parents[1]),
                            str(path), index], check=False, capture_output=True, text=True, timeout=300)
    assert child.returncode == 0 and child.stdout.split() == ["500", "1"], child.stdout + child.stderr[-2000:]
    ds = ogr.Open(str(path))
    lyr = ds.GetLayer("tin")
    assert lyr.GetFeatureCount() == 500 and sorted(f.GetField("n") for f in lyr) == list(range(500))


_OUTLIVING_WRITE_GPKG_CHILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np, pyproj, shapely
from osgeo import ogr
from wit_plugin.infra.io.vector_io import FieldDef, OutputLayer, write_gpkg

kept = []
create_layer = ogr.DataSource.CreateLayer
ogr.DataSource.CreateLayer = lambda ds, *args, **kwargs: kept.append(ds) or create_layer(ds, *args, **kwargs)
fields = [FieldDef("n", ogr.OFTInteger)]
write_gpkg(sys.argv[2], [OutputLayer("full", fields, {"n": [1]}, np.array([shapely.box(0, 0, 1, 1)], dtype=object)),
                         OutputLayer("empty", fields, {"n": []}, np.array([], dtype=object)),
                         OutputLayer("table", fields, {"n": []})], pyproj.CRS.from_epsg(5186))
ds = ogr.Open(sys.argv[2])
print(len(kept), *sorted(ds.GetLayer(i).GetName() for i in range(ds.GetLayerCount())))
"""


def test_write_gpkg_writes_every_layer_while_the_dataset_outlives_it(tmp_path):
    """vector_io.write_gpkg (prepared layers, the tile index): an empty layer OGR creates only when the dataset
    is flushed or destroyed is in the file even while the dataset is kept alive (Dask's worker profiler)."""
    import subprocess
    import sys
    from pathlib import Path

    child = subprocess.run([sys.executable, "-c", _OUTLIVING_WRITE_GPKG_CHILD, str(Path(__file__).resolve().parents[1]),
                            str(tmp_path / "x.gpkg")], check=False, capture_output=True, text=True, timeout=300)
    assert child.returncode == 0 and child.stdout.split() == ["3", "empty", "full", "table"], (
        child.stdout + child.stderr[-2000:])  # the dataset kept once per layer it made


def test_names_with_double_quotes_are_written_and_read_by_sql(tmp_path):
    """A user's field (or layer) name holding a quote once broke the INSERT, the index and the ordered reads."""
    from wit_plugin.citygml.inputs import InputLayer

    assert sql.sql_name('say "hi"') == '"say ""hi"""'
    path = tmp_path / "quoted.gpkg"
    fields = [FieldDef('the "n"', ogr.OFTInteger)]
    geoms = _geoms(3)
    assert gpkg_bulk.write_layer(path, 'Kim\'s roofs "A"', CRS, fields, geoms, [[3, 1, 2, 0]]) == 4
    ds = ogr.Open(str(path))
    layer = ds.GetLayer('Kim\'s roofs "A"')
    layer.SetSpatialFilterRect(200000, 540000, 200031, 540021)  # the R-tree index: only the courtyard building
    assert [f.GetField('the "n"') for f in layer] == [3]
    layer.SetSpatialFilter(None)
    assert [f.GetField('the "n"') for f in layer] == [3, 1, 2, 0]
    with InputLayer(ds, layer, str(path), 'Kim\'s roofs "A"').select(order=['the "n"']) as ordered:
        assert [f.GetField('the "n"') for f in ordered] == [0, 1, 2, 3]
    del layer, ds  # closed before sqlite3 reads the file
    tables = {r[0] for r in sqlite3.connect(path).execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    assert 'rtree_Kim\'s roofs "A"_geom' in tables
