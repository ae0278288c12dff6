"""Bilinear DEM sampling (as the paper, Kang et al. 2025, §3.1): exactness, NoData handling, windowed
reads, the real Seoul DEM."""
from __future__ import annotations

import numpy as np
import pytest
from osgeo import gdal

from wit_plugin.infra.dem import Dem
from wit_plugin.infra.errors import InputError

SUSEO = (209020.9, 543132.8)  # EPSG:5186, data README


def _centres(shape, gt):
    rows, cols = shape
    x = gt[0] + (np.arange(cols) + 0.5) * gt[1]
    y = gt[3] + (np.arange(rows) + 0.5) * gt[5]
    return np.meshgrid(x, y)


def _write_tif(path, values, gt, nodata=None):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), values.shape[1], values.shape[0], 1, gdal.GDT_Float32)
    ds.SetGeoTransform(gt)
    band = ds.GetRasterBand(1)
    if nodata is not None:
        band.SetNoDataValue(nodata)
    band.WriteArray(values)
    ds = None


def test_plane_is_reproduced_exactly():
    gt = (1000.0, 2.5, 0.0, 5000.0, 0.0, -4.0)
    xs, ys = _centres((30, 40), gt)
    dem = Dem(0.37 * xs - 1.21 * ys + 9000.0, gt)
    rng = np.random.default_rng(1)
    # inside the outermost cell centres the bilinear surface of a plane is the plane
    x = rng.uniform(xs.min(), xs.max(), 5000)
    y = rng.uniform(ys.min(), ys.max(), 5000)
    np.testing.assert_allclose(dem.sample(x, y), 0.37 * x - 1.21 * y + 9000.0, rtol=0, atol=1e-9)


def test_exact_at_cell_centres_and_hand_computed_value():
    values = np.array([[1.0, 2.0], [3.0, 5.0]])
    dem = Dem(values, (0.0, 10.0, 0.0, 20.0, 0.0, -10.0))
    xs, ys = _centres(values.shape, dem.geotransform)
    np.testing.assert_array_equal(dem.sample(xs, ys), values)
    # (7.5, 12.5): alpha = beta = 0.25 from centre (5, 15) towards (15, 5)
    # 1·.75·.75 + 2·.25·.75 + 3·.75·.25 + 5·.25·.25 = 1.8125
    assert dem.sample(np.array([7.5]), np.array([12.5]))[0] == pytest.approx(1.8125, abs=1e-12)
    # at a raster edge the outermost centre's value holds across the last half cell
    assert dem.sample(np.array([0.0]), np.array([20.0]))[0] == pytest.approx(1.0)


def test_points_outside_the_dem_are_an_input_error():
    dem = Dem(np.zeros((3, 3)), (0.0, 1.0, 0.0, 3.0, 0.0, -1.0))
    with pytest.raises(InputError, match="outside the DEM"):
        dem.sample(np.array([1.0, 3.5]), np.array([1.0, 1.0]))
    with pytest.raises(InputError, match="outside the DEM"):
        dem.sample(np.array([np.nan]), np.array([1.0]))


def test_undeclared_nodata_is_filled_from_neighbours():
    gt = (0.0, 1.0, 0.0, 10.0, 0.0, -1.0)
    xs, ys = _centres((10, 10), gt)
    values = 100.0 + xs + ys
    values[4:6, 4:6] = -9999.0
    values[0, :] = -9999.0
    dem = Dem(values, gt)
    assert dem.nodata_cells == 14
    assert dem.values.min() > 100.0
    # filled by neighbours: close to the plane the valid cells describe
    assert abs(dem.values[4, 4] - (100.0 + xs[4, 4] + ys[4, 4])) < 1.5


def test_fills_write_no_work_files_into_the_current_folder(tmp_path, monkeypatch):
    """GDAL's fill wrote three GeoTIFFs into the current folder (QGIS's may be read-only; a killed process left
    them there): with GDAL's temporary folder unusable, the DEM's and the coarse terrain's fills still work."""
    from wit_plugin.tiles3d.coarse import fill_colours

    monkeypatch.chdir(tmp_path)
    gdal.SetConfigOption("CPL_TMPDIR", str(tmp_path / "no such folder"))
    try:
        gt = (0.0, 1.0, 0.0, 10.0, 0.0, -1.0)
        xs, ys = _centres((10, 10), gt)
        values = 100.0 + xs + ys
        values[4:6, 4:6] = -9999.0
        dem = Dem(values, gt)
        rgb = np.zeros((8, 8, 3), dtype=np.uint8)
        rgb[:, :4] = (10, 20, 30)
        hit = np.zeros((8, 8), dtype=bool)
        hit[:, :4] = True
        filled = fill_colours(rgb, hit)
    finally:
        gdal.SetConfigOption("CPL_TMPDIR", None)
    assert dem.nodata_cells == 4 and abs(dem.values[4, 4] - (100.0 + xs[4, 4] + ys[4, 4])) < 1.5
    assert filled[:, 4:].reshape(-1, 3).tolist() == [[10, 20, 30]] * 32
    assert list(tmp_path.iterdir()) == []


def test_declared_nodata_and_nan():
    values = np.array([[5.0, 7.0, 0.0], [5.0, np.nan, 7.0]])
    dem = Dem(values, (0.0, 1.0, 0.0, 2.0, 0.0, -1.0), nodata=0.0)
    assert dem.nodata_cells == 2
    assert np.isfinite(dem.values).all() and dem.values.min() >= 5.0
    with pytest.raises(InputError, match="only NoData"):
        Dem(np.full((2, 2), -9999.0), (0.0, 1.0, 0.0, 2.0, 0.0, -1.0))


def test_window_read_matches_full_read(tmp_path):
    gt = (200000.0, 5.0, 0.0, 550000.0, 0.0, -5.0)
    rng = np.random.default_rng(2)
    values = rng.uniform(10, 60, (300, 400)).astype(np.float32)
    _write_tif(tmp_path / "d.tif", values, gt)
    full = Dem.open(tmp_path / "d.tif")
    bounds = (200700.0, 548900.0, 201100.0, 549600.0)
    window = Dem.open(tmp_path / "d.tif", bounds)
    assert window.values.size < full.values.size / 5
    x = rng.uniform(bounds[0], bounds[2], 2000)
    y = rng.uniform(bounds[1], bounds[3], 2000)
    np.testing.assert_allclose(window.sample(x, y), full.sample(x, y), rtol=0, atol=1e-9)
    with pytest.raises(InputError, match="outside the DEM"):  # beyond the window's last centres
        window.sample(np.array([bounds[0] - 100.0]), np.array([bounds[1]]))
    with pytest.raises(InputError, match="does not cover"):
        Dem.open(tmp_path / "d.tif", (199000.0, 548900.0, 201100.0, 549600.0))
    with pytest.raises(InputError, match="does not exist"):
        Dem.open(tmp_path / "missing.tif")


def test_nodes_in_boxes_matches_brute_force():
    gt = (10.0, 2.0, 0.0, 50.0, 0.0, -3.0)
    rng = np.random.default_rng(3)
    dem = Dem(rng.uniform(0, 9, (12, 15)), gt)
    xs, ys = _centres(dem.values.shape, gt)
    boxes = rng.uniform([8, 10, 8, 10], [42, 52, 42, 52], (50, 4))
    xmin, xmax = np.minimum(boxes[:, 0], boxes[:, 2]), np.maximum(boxes[:, 0], boxes[:, 2])
    ymin, ymax = np.minimum(boxes[:, 1], boxes[:, 3]), np.maximum(boxes[:, 1], boxes[:, 3])
    owner, x, y, z = dem.nodes_in_boxes(xmin, ymin, xmax, ymax)
    for b in range(len(boxes)):
        inside = (xs >= xmin[b]) & (xs <= xmax[b]) & (ys >= ymin[b]) & (ys <= ymax[b])
        got = sorted(zip(x[owner == b], y[owner == b], z[owner == b]))
        assert got == sorted(zip(xs[inside], ys[inside], dem.values[inside]))


def test_deviation_range_is_exact_along_segments():
    gt = (0.0, 1.0, 0.0, 20.0, 0.0, -1.0)
    rng = np.random.default_rng(4)
    dem = Dem(rng.uniform(0, 10, (20, 20)), gt)
    n = 300
    p0 = rng.uniform(0, 20, (n, 2))
    p1 = np.clip(p0 + rng.normal(0, 3, (n, 2)), 0, 20)
    z0, z1 = rng.uniform(0, 10, n), rng.uniform(0, 10, n)
    lo, hi = dem.deviation_range(p0[:, 0], p0[:, 1], z0, p1[:, 0], p1[:, 1], z1)
    t = np.linspace(0, 1, 4001)
    for k in range(n):
        x = p0[k, 0] + t * (p1[k, 0] - p0[k, 0])
        y = p0[k, 1] + t * (p1[k, 1] - p0[k, 1])
        dense = dem.sample(x, y) - (z0[k] + t * (z1[k] - z0[k]))
        # the exact extremes bound every dense sample, and they are reached: the function moves
        # by at most one sampling step's change between a true extreme and its nearest sample
        step = np.abs(np.diff(dense)).max()
        assert lo[k] <= dense.min() + 1e-9 and hi[k] >= dense.max() - 1e-9
        assert lo[k] >= dense.min() - step and hi[k] <= dense.max() + step


@pytest.fixture(scope="module")
def seoul(shared_dir):
    return shared_dir / "data/dem_seoul_90m_5186/seoul_dem.tif"


def test_seoul_dem_nodata_and_suseo_height(seoul):
    dem = Dem.open(seoul)
    assert dem.values.shape == (316, 385)
    assert dem.nodata_cells == 770  # the −9999 cells, without a NoData flag in the file
    raw = gdal.Open(str(seoul)).ReadAsArray()
    valid = raw[raw > -1000]
    assert dem.values.min() >= valid.min() and dem.values.max() <= valid.max()

    # README: 18.6 m at Suseo station is the value of the cell that contains it. Bilinear
    # interpolation mixes the four surrounding centres (18.44, 18.63, 20.19, 18.99 m), so it
    # lies within their range, and for α = 0.7767, β = 0.2800 it is 18.773 m.
    gt = dem.geotransform
    row, col = int((SUSEO[1] - gt[3]) / gt[5]), int((SUSEO[0] - gt[0]) / gt[1])
    assert round(float(dem.values[row, col]), 1) == 18.6
    z = dem.sample(np.array([SUSEO[0]]), np.array([SUSEO[1]]))[0]
    assert z == pytest.approx(18.7734, abs=1e-4)
    assert abs(z - 18.6) < 0.2

    windowed = Dem.open(seoul, (SUSEO[0] - 1000, SUSEO[1] - 1000, SUSEO[0] + 1000, SUSEO[1] + 1000))
    assert windowed.values.size < 1000
    assert windowed.sample(np.array([SUSEO[0]]), np.array([SUSEO[1]]))[0] == pytest.approx(z, abs=1e-9)


def test_seoul_dem_never_samples_nodata(seoul):
    dem = Dem.open(seoul)
    xmin, ymin, xmax, ymax = dem.extent
    rng = np.random.default_rng(5)
    z = dem.sample(rng.uniform(xmin, xmax, 200000), rng.uniform(ymin, ymax, 200000))
    assert z.min() >= 1.05 - 1e-6  # the lowest valid height in the file; −9999 never leaks in
    edge = dem.sample(np.array([xmin, xmax, xmin, xmax]), np.array([ymin, ymin, ymax, ymax]))
    assert edge.min() > -1000


@pytest.mark.parametrize("cell", [1.0, 7.0])
def test_plane_deviation_bound_never_underestimates(cell):
    """The cheap bound ≥ the exact error on random triangles, small and large against the cells,
    and infinite for slivers and for triangles reaching the flat rim beyond the outermost centres."""
    from wit_plugin.terrain.mesh import exact_vertical_error

    rng = np.random.default_rng(5)
    rows = cols = 30
    dem = Dem(rng.uniform(0, 10, (rows, cols)), (0.0, cell, 0.0, rows * cell, 0.0, -cell))
    m = 400
    a = rng.uniform(0, cols * cell, (m, 2))
    tri_xy = np.stack([a, a + rng.normal(0, 2 * cell, (m, 2)), a + rng.normal(0, 2 * cell, (m, 2))], axis=1)
    tri_xy = np.clip(tri_xy, 0, cols * cell)
    xyz = np.column_stack([tri_xy.reshape(-1, 2), dem.sample(*tri_xy.reshape(-1, 2).T)])
    tris = np.arange(3 * m).reshape(m, 3)
    bound = dem.plane_deviation_bound(xyz[tris[:, 0]], xyz[tris[:, 1]], xyz[tris[:, 2]])
    exact = exact_vertical_error(dem, xyz, tris)
    assert (bound >= exact - 1e-9).all()
    rim = (tri_xy.min(axis=1) < 0.5 * cell).any(axis=1) | (tri_xy.max(axis=1) > (cols - 0.5) * cell).any(axis=1)
    assert np.isinf(bound[rim]).all() and np.isfinite(bound[~rim]).any()
    inner = np.isfinite(bound)
    assert np.median(bound[inner] / np.maximum(exact[inner], 1e-9)) < 20  # a bound, not a shrug
    flat = np.array([[10.0, 10.0, 1.0], [12.0, 12.0, 1.0], [14.0, 14.0, 1.0]])  # collinear
    assert np.isinf(dem.plane_deviation_bound(flat[:1], flat[1:2], flat[2:]))[0]
