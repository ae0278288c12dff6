"""The vector-based colour store (wit_plugin.colorstore): quadtree, GeoPackage and PostGIS backends.

The synthetic ortho (700 × 500 px, 0.5 m, EPSG:5186; not a multiple of the 256 px root block, so
edge blocks are clipped) has three regions: x < 250 px smooth (linear ramps and a slow sine),
250–500 px sharp edges (a 40 px checkerboard and a disc), x ≥ 500 px one flat colour.

PostGIS tests run against the real local server that scripts/setup.sh starts (scripts/postgis.sh);
they fail, never skip, when it is not there. WIT_TEST_POSTGIS_DSN overrides the DSN.
"""
from __future__ import annotations

import os
import sqlite3
import subprocess
import uuid
from pathlib import Path

import numpy as np
import pytest
import shapely
from osgeo import gdal, osr

from wit_plugin import colorstore
from wit_plugin.infra.errors import CanceledError, InputError

ROOT = Path(__file__).resolve().parents[1]
W, H, PX = 700, 500, 0.5
X0, Y0 = 200000.0, 500000.0
TOL = 12.0
FLAT = (80, 120, 160)
DEFAULT_DSN = "postgresql://wit:wit@127.0.0.1:5432/wit_test"


def _pixels() -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    img = np.empty((3, H, W))
    img[0] = 40 + 150 * xx / W + 30 * yy / H
    img[1] = 100 + 60 * np.sin(xx / 40) * np.cos(yy / 55)
    img[2] = 30 + 180 * yy / H
    edges = (xx >= 250) & (xx < 500)
    checker = ((xx // 40 + yy // 40) % 2 == 0) | ((xx - 380) ** 2 + (yy - 250) ** 2 < 70 ** 2)
    for band, (on, off) in enumerate([(230, 20), (40, 210), (200, 10)]):
        img[band][edges] = np.where(checker, on, off)[edges]
        img[band][:, 500:] = FLAT[band]
    return np.rint(img).astype(np.uint8)


def _write_tif(path: Path, data: np.ndarray, dtype: int = gdal.GDT_Byte) -> Path:
    ds = gdal.GetDriverByName("GTiff").Create(str(path), data.shape[2], data.shape[1], data.shape[0], dtype,
                                               ["TILED=YES"])
    ds.SetGeoTransform((X0, PX, 0, Y0, 0, -PX))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    ds.SetProjection(srs.ExportToWkt())
    ds.WriteArray(data)
    ds = None
    return path


@pytest.fixture(scope="module")
def pixels() -> np.ndarray:
    return _pixels()


@pytest.fixture(scope="module")
def ortho(tmp_path_factory, pixels) -> Path:
    return _write_tif(tmp_path_factory.mktemp("ortho") / "ortho.tif", pixels)


@pytest.fixture(scope="module")
def built(tmp_path_factory, ortho) -> tuple[Path, colorstore.BuildReport]:
    """A GeoPackage store with the hard bound (metric max)."""
    path = tmp_path_factory.mktemp("store") / "store.gpkg"
    return path, colorstore.build_color_store(ortho, path, tolerance=TOL, metric="max")


@pytest.fixture
def store(built):
    with colorstore.ColorStore.open(built[0]) as s:
        yield s


def _ground(c: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground coordinates of lattice points (pixel centres at integer c, r)."""
    return X0 + (c + 0.5) * PX, Y0 - (r + 0.5) * PX


def _source_bilinear(pixels: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The source's own bilinear interpolation between pixel centres, (n, 3) float."""
    c, r = np.clip(c, 0, W - 1), np.clip(r, 0, H - 1)
    i, j = np.minimum(np.floor(c).astype(int), W - 2), np.minimum(np.floor(r).astype(int), H - 2)
    fu, fv = c - i, r - j
    p = pixels.astype(np.float64)
    top = p[:, j, i] * (1 - fu) + p[:, j, i + 1] * fu
    bottom = p[:, j + 1, i] * (1 - fu) + p[:, j + 1, i + 1] * fu
    return (top * (1 - fv) + bottom * fv).T


def _cells(path: Path) -> np.ndarray:
    with sqlite3.connect(path) as db:
        return np.array(db.execute(f"SELECT {', '.join(colorstore.CELL_COLUMNS)} FROM color_cells").fetchall())


# --- the quadtree -------------------------------------------------------------------------------

def test_report_and_measured_error(built, pixels):
    path, report = built
    assert (report.width, report.height, report.pixel_size) == (W, H, (PX, PX))
    assert report.metric == "max" and report.max_depth == 8 and report.cells_over_tolerance == 0
    assert report.cells == len(_cells(path)) == sum(report.levels.values())
    assert 0 < report.max_error <= TOL and 0 < report.mean_error < 2.0
    assert report.image_bytes == W * H * 3 and report.store_bytes == path.stat().st_size


def test_reconstruction_within_tolerance_everywhere(store, pixels):
    """|store − source bilinear| ≤ tolerance at any point (module docstring), + ½ for rounding."""
    rng = np.random.default_rng(7)
    c, r = rng.uniform(-0.5, W - 0.5, 400), rng.uniform(-0.5, H - 0.5, 400)
    c[:100], r[:100] = np.round(c[:100]), np.round(r[:100])  # pixel centres: vs the pixels themselves
    x, y = _ground(c, r)
    got = np.array([store.query_point(a, b) for a, b in zip(x, y)], float)
    err = np.abs(got - _source_bilinear(pixels, c, r))
    assert err.max() <= TOL + 0.5
    assert err[:100].max() <= TOL  # integers both: |Δ| ≤ 12.5 means ≤ 12


def test_flat_areas_get_big_cells_and_edges_deep_ones(built):
    cells = _cells(built[0])
    level, c0, c1 = cells[:, 0], cells[:, 1], cells[:, 3]
    # The root blocks from column 512 on are flat: one level-0 cell each (2 rows of blocks).
    assert level[c0 >= 512].tolist() == [0, 0]
    smooth = level[c1 <= 240]  # clear of the steps at column 250
    edges = level[(c0 >= 250) & (c1 <= 500)]
    assert smooth.min() >= 2 and smooth.max() <= 4  # 16–64 px cells follow ramps and the slow sine
    assert len(edges) > 100 * len(smooth)
    assert edges.max() == 8 and np.count_nonzero(edges == 8) > len(edges) / 2  # 1-px cells on the steps


def test_query_point_exact_at_cell_corners(store, built, pixels):
    cells = _cells(built[0])
    rng = np.random.default_rng(3)
    for row in cells[rng.choice(len(cells), 150, replace=False)]:
        c0, r0, c1, r1 = row[1:5]
        colors = row[5:].reshape(4, 3)
        for (c, r), stored in zip([(c0, r1), (c1, r1), (c1, r0), (c0, r0)], colors):  # LB RB RT LT
            x, y = _ground(np.array(c), np.array(r))
            assert store.query_point(float(x), float(y)) == tuple(stored) == tuple(pixels[:, r, c])


def test_query_patch_matches_windowed_read(store, ortho, pixels):
    """A pixel-aligned patch at the ortho's resolution is the windowed read, within tolerance."""
    col, row, n = 200, 180, 160  # straddles the smooth and edge regions and two root blocks
    xmin, ymax = X0 + col * PX, Y0 - row * PX
    patch = store.query_patch((xmin, ymax - n * PX, xmin + n * PX, ymax), PX)
    window = gdal.Open(str(ortho)).ReadAsArray(col, row, n, n).transpose(1, 2, 0)
    assert patch.shape == (n, n, 3) and patch.dtype == np.uint8
    assert np.abs(patch.astype(int) - window).max() <= TOL
    assert np.count_nonzero(patch != window) > 0  # lossy elsewhere than at corners


def test_query_patch_any_resolution_is_consistent_with_points(store, pixels):
    box = shapely.box(X0 + 30.3, Y0 - 180.2, X0 + 62.3, Y0 - 160.2)  # 32 × 20 m, not pixel-aligned
    patch = store.query_patch(box, 0.2)
    assert patch.shape == (100, 160, 3)
    j, i = np.mgrid[0:100:7, 0:160:9]
    x, y = X0 + 30.3 + (i + 0.5) * 0.2, Y0 - 160.2 - (j + 0.5) * 0.2
    points = np.array([store.query_point(a, b) for a, b in zip(x.ravel(), y.ravel())])
    assert (patch[j.ravel(), i.ravel()] == points).all()
    c, r = (x.ravel() - X0) / PX - 0.5, (Y0 - y.ravel()) / PX - 0.5
    assert np.abs(points - _source_bilinear(pixels, c, r)).max() <= TOL + 0.5


def test_rms_metric_and_depth_limit(tmp_path, ortho):
    rms = colorstore.build_color_store(ortho, tmp_path / "rms.gpkg", tolerance=TOL)
    assert rms.metric == "rms" and rms.cells_over_tolerance == 0
    shallow = colorstore.build_color_store(ortho, tmp_path / "d2.gpkg", tolerance=TOL, max_depth=2, metric="max")
    assert max(shallow.levels) == 2 and shallow.cells_over_tolerance > 0 and shallow.max_error > TOL
    lossless = colorstore.build_color_store(ortho, tmp_path / "exact.gpkg", tolerance=0, metric="max")
    assert lossless.max_error == 0 and rms.cells < lossless.cells
    with colorstore.ColorStore.open(tmp_path / "exact.gpkg") as s:
        patch = s.query_patch((X0, Y0 - 40, X0 + 60, Y0), PX)
    assert (patch == _pixels()[:, :80, :120].transpose(1, 2, 0)).all()


def test_outer_half_pixel_border_and_outside(store, pixels):
    assert store.extent == (X0, Y0 - H * PX, X0 + W * PX, Y0)
    assert store.query_point(X0, Y0) == tuple(pixels[:, 0, 0])  # image corner: nearest domain point
    assert store.query_point(X0 + W * PX, Y0 - H * PX) == tuple(pixels[:, -1, -1])
    with pytest.raises(InputError, match="outside the colour store's extent"):
        store.query_point(X0 - 1, Y0 - 10)
    with pytest.raises(InputError, match="outside"):
        store.query_patch((X0 + 300, Y0 - 10, X0 + 400, Y0), 1.0)


# --- GeoPackage ---------------------------------------------------------------------------------

def test_geopackage_has_rtree_and_metadata(built):
    path, report = built
    with sqlite3.connect(path) as db:
        ext = db.execute("SELECT table_name, column_name FROM gpkg_extensions "
                         "WHERE extension_name = 'gpkg_rtree_index'").fetchall()
        assert ext == [("color_cells", "geom")]
        assert db.execute("SELECT count(*) FROM rtree_color_cells_geom").fetchone()[0] == report.cells
        assert db.execute("SELECT geometry_type_name, srs_id FROM gpkg_geometry_columns").fetchall() == [
            ("POLYGON", 5186)]
        meta = dict(db.execute("SELECT key, value FROM color_cells_meta").fetchall())
    assert meta["tolerance"] == "12.0" and meta["metric"] == '"max"' and meta["width"] == str(W)
    assert gdal.OpenEx(str(path), gdal.OF_VECTOR).GetLayerByName("color_cells").GetFeatureCount() == report.cells


def test_module_functions_accept_a_path(built, store):
    path = built[0]
    assert colorstore.query_point(path, X0 + 10, Y0 - 10) == store.query_point(X0 + 10, Y0 - 10)
    box = (X0 + 10, Y0 - 20, X0 + 20, Y0 - 10)
    assert (colorstore.query_patch(str(path), box, 1.0) == store.query_patch(box, 1.0)).all()


# --- PostGIS ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def pg_dsn() -> str:
    """The test server's DSN; starts it (scripts/postgis.sh) if needed and fails loudly without it."""
    import psycopg2

    dsn = os.environ.get("WIT_TEST_POSTGIS_DSN", DEFAULT_DSN)
    try:
        psycopg2.connect(dsn, connect_timeout=5).close()
        return dsn
    except psycopg2.Error as first:
        if "WIT_TEST_POSTGIS_DSN" in os.environ:
            pytest.fail(f"PostGIS server {dsn} is not reachable: {first}")
    run = subprocess.run(["bash", str(ROOT / "scripts" / "postgis.sh")], capture_output=True, text=True, check=False)
    if run.returncode != 0:
        pytest.fail(f"PostGIS server could not be started (CI={os.environ.get('CI')}): "
                    f"scripts/postgis.sh said:\n{run.stderr}")
    return run.stdout.strip()


@pytest.fixture
def pg_schema(pg_dsn):
    """A fresh schema for one test, dropped afterwards."""
    import psycopg2

    schema = f"wit_test_{uuid.uuid4().hex[:10]}"
    conn = psycopg2.connect(pg_dsn)
    conn.autocommit = True
    conn.cursor().execute(f"CREATE SCHEMA {schema}")
    try:
        yield schema, conn
    finally:
        conn.cursor().execute(f"DROP SCHEMA {schema} CASCADE")
        conn.close()


def test_postgis_round_trip_identical_to_geopackage(pg_dsn, pg_schema, ortho, built, store):
    schema, conn = pg_schema
    table = f"{schema}.cells"
    report = colorstore.build_color_store(ortho, None, tolerance=TOL, metric="max", postgis_dsn=pg_dsn,
                                          table=table)
    gpkg_report = built[1]
    assert report.backend == "postgis" and "wit:wit@" not in report.output and ":***@" in report.output
    assert (report.cells, report.levels, report.max_error) == (gpkg_report.cells, gpkg_report.levels,
                                                               gpkg_report.max_error)
    cur = conn.cursor()
    cur.execute("SELECT indexdef FROM pg_indexes WHERE schemaname = %s AND tablename = 'cells'", (schema,))
    assert any("USING gist (geom)" in d for (d,) in cur.fetchall())
    cur.execute(f"SELECT Find_SRID('{schema}', 'cells', 'geom'), GeometryType(geom), count(*) "
                f"FROM {table} GROUP BY 2")
    assert cur.fetchall() == [(5186, "POLYGON", report.cells)]
    assert report.store_bytes > 0
    rng = np.random.default_rng(11)
    x, y = X0 + rng.uniform(0, W * PX, 300), Y0 - rng.uniform(0, H * PX, 300)
    x[:50], y[:50] = _ground(rng.integers(0, W, 50), rng.integers(0, H, 50))  # on lattice lines
    with colorstore.ColorStore.open(pg_dsn, table) as pg:
        assert pg.extent == store.extent
        assert [pg.query_point(a, b) for a, b in zip(x, y)] == [store.query_point(a, b) for a, b in zip(x, y)]
        for box, res in [((X0 + 100, Y0 - 200, X0 + 164, Y0 - 136), 0.5), ((X0 + 3.1, Y0 - 50, X0 + 40, Y0 - 7), 0.3)]:
            assert (pg.query_patch(box, res) == store.query_patch(box, res)).all()
    # Building again replaces the store.
    again = colorstore.build_color_store(ortho, None, tolerance=40, metric="max", postgis_dsn=pg_dsn, table=table)
    cur.execute(f"SELECT count(*) FROM {table}")
    assert cur.fetchone()[0] == again.cells < report.cells


def test_cancel_leaves_no_postgis_table(pg_dsn, pg_schema, ortho, cancel_after_checks):
    schema, conn = pg_schema
    with pytest.raises(CanceledError):
        colorstore.build_color_store(ortho, None, postgis_dsn=pg_dsn, table=f"{schema}.cells",
                                     feedback=cancel_after_checks(2))
    cur = conn.cursor()
    cur.execute("SELECT count(*) FROM pg_tables WHERE schemaname = %s", (schema,))
    assert cur.fetchone()[0] == 0


@pytest.mark.parametrize("dsn, message", [
    ("postgresql://wit:wrong-secret@127.0.0.1:5432/wit_test", "password"),
    ("postgresql://wit:wit@127.0.0.1:1/wit_test", "Cannot connect to PostgreSQL"),
    ("host=127.0.0.1 port=5432 user=wit password=wit dbname=no_such_db", "no_such_db"),
])
def test_bad_dsn(pg_dsn, ortho, dsn, message):
    with pytest.raises(InputError, match=message) as err:
        colorstore.build_color_store(ortho, None, postgis_dsn=dsn)
    assert "wrong-secret" not in str(err.value) and "password=wit " not in str(err.value)
    with pytest.raises(InputError, match="Cannot connect"):
        colorstore.ColorStore.open(dsn)


def test_postgis_store_missing(pg_dsn, pg_schema):
    with pytest.raises(InputError, match="has no WIT colour store"):
        colorstore.ColorStore.open(pg_dsn, f"{pg_schema[0]}.nothing")


# --- bad inputs and cancel ----------------------------------------------------------------------

def test_bad_inputs(tmp_path, ortho):
    grey = _write_tif(tmp_path / "grey.tif", np.zeros((1, 20, 20), np.uint8))
    floats = _write_tif(tmp_path / "float.tif", np.zeros((3, 20, 20), np.float32), gdal.GDT_Float32)
    out = tmp_path / "s.gpkg"
    cases = [
        ({"ortho": tmp_path / "missing.tif", "output": out}, "does not exist"),
        ({"ortho": grey, "output": out}, "not an RGB orthoimage.*1 band"),
        ({"ortho": floats, "output": out}, "not an RGB orthoimage.*Float32"),
        ({"ortho": ortho, "output": tmp_path / "s.sqlite"}, "must be a GeoPackage"),
        ({"ortho": ortho, "output": out, "postgis_dsn": DEFAULT_DSN}, "either an output GeoPackage or a PostGIS"),
        ({"ortho": ortho, "output": out, "tolerance": -1}, "Tolerance"),
        ({"ortho": ortho, "output": out, "metric": "mean"}, "Unknown error metric"),
        ({"ortho": ortho, "output": out, "block_size": 100}, "power of two"),
        ({"ortho": ortho, "output": out, "table": "1; DROP TABLE x"}, "Table name"),
    ]
    for kwargs, message in cases:
        with pytest.raises(InputError, match=message):
            colorstore.build_color_store(**kwargs)
    assert not out.exists()
    with pytest.raises(InputError, match="does not exist"):
        colorstore.ColorStore.open(tmp_path / "none.gpkg")
    with pytest.raises(InputError, match="not a GeoPackage"):
        colorstore.ColorStore.open(grey)
    other = tmp_path / "other.gpkg"
    ds = gdal.GetDriverByName("GPKG").Create(str(other), 0, 0, 0, gdal.GDT_Unknown)
    ds.CreateLayer("color_cells")
    ds = None
    with pytest.raises(InputError, match="not a WIT colour store"):
        colorstore.ColorStore.open(other)


def test_cancel_leaves_no_geopackage(tmp_path, ortho, cancel_after_checks):
    with pytest.raises(CanceledError):
        colorstore.build_color_store(ortho, tmp_path / "s.gpkg", feedback=cancel_after_checks(3))
    assert list(tmp_path.iterdir()) == []


def test_postgis_script_prints_only_the_dsn_after_an_unclean_stop(tmp_path):
    """After the server died (a stale postmaster.pid, as on a machine booted from an image),
    pg_ctlcluster says "Removed stale pid file." on stdout: scripts/postgis.sh must still print the DSN
    alone, since test.sh and qgis-chroot.sh hand its stdout to the tests (CI failed so). The cluster
    tools are stand-ins here (the real server is shared with other test runs): a cluster that is down
    until pg_ctlcluster starts it, talking on stdout as the real one does."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    up = tmp_path / "up"
    tools = {
        "pg_lsclusters": f'[ -e {up} ] && s=online || s=down; echo "15 main 5432 $s postgres /x /x.log"',
        "pg_ctlcluster": f'echo "Removed stale pid file."; touch {up}',
        "pg_isready": "exit 0",
        "psql": f"cat >/dev/null 2>&1 <&0 || true; echo 'NOTICE: on stdout'; [ -e {up} ]",
        "runuser": 'shift 3; exec "$@"',
        "sudo": '[ "$1" = -u ] && shift 2; exec "$@"',
    }
    for name, body in tools.items():
        (bin_dir / name).write_text(f"#!/bin/bash\n{body}\n")
        (bin_dir / name).chmod(0o755)
    run = subprocess.run(["bash", str(ROOT / "scripts" / "postgis.sh")], capture_output=True, text=True, check=False,
                         timeout=60, stdin=subprocess.DEVNULL,
                         env=dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}"))
    assert run.returncode == 0, run.stderr
    assert run.stdout == f"{DEFAULT_DSN}\n"
    assert "Removed stale pid file." in run.stderr and up.exists()
