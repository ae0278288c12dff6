"""Tiled runs (wit_plugin.sheetrun): the tile plan alone, then real runs on Dask — an embedded scheduler,
and a `dask scheduler` with two `dask worker` processes started here — checked against the
single-area chain: same buildings, none twice, tiles valid, borders shared vertex for vertex;
resume, a failing tile, a killed worker and Cancel."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pygltflib
import pyproj
import pytest
import shapely
from conftest import view_in_chromium
from lxml import etree

from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
from wit_plugin.chain.fingerprint import Fingerprint
from wit_plugin.cityjson.validate import validate_cityjson_files
from wit_plugin.infra.errors import CanceledError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.mapsheet import sheet_at
from wit_plugin.prepare.area import StudyArea
from wit_plugin.sample import SampleConfig, generate_sample
from wit_plugin.sheetrun import plan
from wit_plugin.sheetrun.index import read_index
from wit_plugin.sheetrun.runner import run_tiles, stop_workers, worker_python
from wit_plugin.terrain import triangulators

ROOT = Path(__file__).resolve().parents[1]
NS = {"bldg": "http://www.opengis.net/citygml/building/3.0", "gml": "http://www.opengis.net/gml/3.2",
      "dem": "http://www.opengis.net/citygml/relief/3.0", "tran": "http://www.opengis.net/citygml/transportation/3.0"}
SUSEO = (127.1020, 37.4876)
AREA = StudyArea.circle(*SUSEO, 280.0)
GID = "{http://www.opengis.net/gml/3.2}id"


# -- the plan, alone ----------------------------------------------------------------------------

def test_tiles_partition_the_area_and_meet_corner_to_corner():
    area = shapely.Point(209020.9, 543132.8).buffer(1200)
    tiles = plan.plan_tiles(area, "EPSG:5186", 1000)
    assert len(tiles) >= 9 and [t.sheet for t in tiles] == sorted(t.sheet for t in tiles)
    pieces = [t.polygon.intersection(area) for t in tiles]
    assert sum(p.area for p in pieces) == pytest.approx(area.area, rel=1e-9)
    assert shapely.union_all(pieces).area == pytest.approx(area.area, rel=1e-9)  # no overlap, no gap
    corners = {tuple(c) for t in tiles for c in shapely.get_coordinates(t.polygon)}
    for t in tiles:  # a neighbour's corner is this tile's corner, bit for bit, or off its border
        for c in corners:
            d = t.polygon.exterior.distance(shapely.Point(c))
            assert d == 0.0 or d > 1.0 or c in {tuple(x) for x in shapely.get_coordinates(t.polygon)}


def test_ownership_is_one_sheet_per_point_and_follows_the_grid():
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(207000, 211000, 5000), rng.uniform(541000, 545000, 5000)])
    owners = plan.owners(points, "EPSG:5186", 1000)
    tiles = {t.sheet: t.polygon for t in plan.plan_tiles(shapely.box(206900, 540900, 211100, 545100),
                                                         "EPSG:5186", 1000)}
    inside = [tiles[o].distance(shapely.Point(p)) < 0.01 for o, p in zip(owners, points)]  # straight vs curved edges
    assert all(inside)
    lon, lat = pyproj.Transformer.from_crs("EPSG:5186", "EPSG:4737", always_xy=True).transform(*points[:10].T)
    assert owners[:10] == [sheet_at(x, y, 1000).number for x, y in zip(lon, lat)]
    owner = plan.TileOwner(owners[0], 1000, "EPSG:5186")
    assert owner(points).sum() == owners.count(owners[0])


def test_tile_scale_must_be_a_sheet_grid():
    from wit_plugin.infra.errors import InputError

    with pytest.raises(InputError, match="1:2500 is not offered"):
        plan.plan_tiles(shapely.box(0, 0, 1, 1), "EPSG:5186", 2500)


# -- real runs ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    """The generated sample without the buildings of one tile (a park): that tile owns none."""
    import shutil

    from osgeo import ogr

    base = generate_sample(tmp_path_factory.mktemp("tiles-sample"), SampleConfig(radius_m=320.0, seed=8,
                                                                                   ortho_pixel_size=1.0))
    holed = base.buildings.with_name("buildings_with_a_park.shp")
    for part in base.buildings.parent.glob(base.buildings.stem + ".*"):  # byte copies: the CP949 text stays
        shutil.copy(part, holed.with_suffix(part.suffix))
    ds = ogr.Open(str(holed), 1)
    layer = ds.GetLayer(0)
    area = AREA.geometry(pyproj.CRS("EPSG:5186"))
    park = min(plan.plan_tiles(area, "EPSG:5186", 1000), key=lambda t: t.polygon.intersection(area).area)
    to_layer = pyproj.Transformer.from_crs("EPSG:5186", layer.GetSpatialRef().ExportToWkt(), always_xy=True)
    polygon = shapely.transform(shapely.segmentize(park.polygon, 5.0),
                                lambda xy: np.column_stack(to_layer.transform(xy[:, 0], xy[:, 1])))
    near = polygon.buffer(2.0)
    boxes = [(f.GetFID(), f.GetGeometryRef().GetEnvelope()) for f in layer if f.GetGeometryRef() is not None]
    for fid, (xmin, xmax, ymin, ymax) in boxes:  # every building near the tile, defective ones too
        if near.intersects(shapely.box(xmin, ymin, xmax, ymax)):
            layer.DeleteFeature(fid)
    ds.ExecuteSQL(f"REPACK {layer.GetName()}")
    ds = None
    base.buildings = holed
    base.park = park.sheet
    return base


def _inputs(sample, **kw) -> ChainInputs:
    base = dict(ortho=[str(sample.ortho_tiles[0].parent)], dem=str(sample.dem), buildings=str(sample.buildings),
                roads=str(sample.roads), districts=str(sample.districts))
    base.update(kw)
    return ChainInputs(**base)


def _options() -> ChainOptions:
    return ChainOptions(area=None, max_edge=15.0, metrics=False, tiles3d=False, cityjson=True)


@pytest.fixture(scope="module")
def local_run(sample, tmp_path_factory):
    out = tmp_path_factory.mktemp("tiled")
    report = run_tiles(_inputs(sample), _options(), out, AREA, scale=1000, workers=2)
    return out, report


@pytest.fixture(scope="module")
def cdt_run(sample, tmp_path_factory):
    """The same tiled run on the permissively licensed backend (CDT)."""
    out = tmp_path_factory.mktemp("tiled-cdt")
    options = _options()
    options.triangulator = triangulators.CDT
    return out, run_tiles(_inputs(sample), options, out, AREA, scale=1000, workers=2)


BOTH_RUNS = pytest.mark.parametrize("run", ["local_run", "cdt_run"])


@pytest.fixture(scope="module")
def single(sample, tmp_path_factory):
    out = tmp_path_factory.mktemp("single")
    return run_city_model(_inputs(sample), ChainOptions(area=AREA, max_edge=15.0, metrics=False, tiles3d=False), out)


@pytest.mark.parametrize("run", [run_city_model, lambda i, o, out: run_tiles(i, o, out, None)],
                         ids=["chain", "map-sheet runner"])
def test_the_chain_and_the_map_sheet_runner_check_their_inputs_alike_before_reading_any(run, tmp_path):
    """One check (``chain.check_inputs``): a wrong choice fails the run at once, not each tile on its worker."""
    from wit_plugin.infra.errors import InputError

    inputs = ChainInputs(ortho=[], dem=str(tmp_path / "none.tif"), buildings=str(tmp_path / "none.shp"))
    with pytest.raises(InputError, match="Surfaces outside the orthoimage: choose one of fail, untextured"):
        run(inputs, ChainOptions(area=AREA, outside_ortho="grey"), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def _building_ids(gml: Path) -> list[str]:
    return [b.get(GID) for b in etree.parse(str(gml)).iterfind(".//bldg:Building", NS)]


def _ground_triangles(gml: Path) -> np.ndarray:
    """(n, 3, 3) terrain (gml:Triangle) and road (TrafficArea polygons "tri_…") triangles of a model."""
    tree = etree.parse(str(gml))
    lists = list(tree.iterfind(".//gml:Triangle//gml:posList", NS)) + [
        p for p in tree.iterfind(".//tran:TrafficArea//gml:Polygon//gml:posList", NS)]
    triangles = [np.array(p.text.split(), dtype=float).reshape(-1, 3)[:3] for p in lists]
    return np.array(triangles).reshape(-1, 3, 3)


def _modelled(report) -> list[dict]:
    return [row for row in report.rows if row["status"] in ("done", "empty")]


def test_every_building_in_exactly_one_tile_same_as_the_single_area(local_run, single):
    out, report = local_run
    assert report.count("done") >= 3 and report.count("failed") == 0
    ids = [i for row in _modelled(report) for i in _building_ids(out / row["gml"])]
    assert len(ids) == len(set(ids)) == report.buildings
    assert set(ids) == set(_building_ids(Path(single.gml)))
    index = read_index(out)
    assert {r["status"] for r in index.values()} <= {"done", "empty"}
    assert all(index[r["sheet"]]["buildings"] == r["buildings"] for r in report.rows)
    assert all(r["peak_mb"] > 50 and r["seconds"] > 0 for r in _modelled(report))


def test_a_tile_without_buildings_still_has_its_ground(local_run, sample):
    """The park's tile owns no building: status empty, a valid model of terrain and roads, no hole."""
    out, report = local_run
    park = next(r for r in report.rows if r["sheet"] == sample.park)
    assert park["status"] == "empty" and park["buildings"] == 0 and park["triangles"] > 20
    assert _building_ids(out / park["gml"]) == [] and len(_ground_triangles(out / park["gml"])) > 20
    triangles = np.concatenate([_ground_triangles(out / r["gml"]) for r in _modelled(report)])
    tree = shapely.STRtree(shapely.polygons(triangles[:, :, :2]))
    area = AREA.geometry(pyproj.CRS("EPSG:5186"))
    roofs = [np.array(p.text.split(), dtype=float).reshape(-1, 3)[:, :2] for r in _modelled(report)
             for p in etree.parse(str(out / r["gml"])).iterfind(".//bldg:Building//gml:posList", NS)]
    footprints = shapely.union_all(shapely.make_valid(np.array([shapely.Polygon(r) for r in roofs], dtype=object)))
    xmin, ymin, xmax, ymax = area.bounds
    grid = shapely.points(np.stack(np.meshgrid(np.linspace(xmin, xmax, 80), np.linspace(ymin, ymax, 80)), -1)
                          .reshape(-1, 2))
    ground = grid[shapely.contains(area, grid) & ~shapely.dwithin(footprints, grid, 1.0)]
    covered = np.unique(tree.query(ground, predicate="intersects")[0])
    assert len(ground) > 3000 and len(covered) == len(ground)  # every ground point lies on a triangle


def test_every_tile_is_a_valid_citygml_file(local_run):
    out, report = local_run
    for row in _modelled(report):
        result = subprocess.run(["xmllint", "--nonet", "--noout", "--schema",
                                 str(ROOT / "wit_plugin/citygml/xsd/citygml3-all.xsd"), str(out / row["gml"])],
                                capture_output=True, text=True)
        assert result.returncode == 0, result.stderr[-2000:]


@BOTH_RUNS
def test_neighbouring_tiles_share_their_border_vertex_for_vertex(run, request):
    """On every shared border: the same vertices (x, y and z, to the millimetre) on both sides."""
    out, report = request.getfixturevalue(run)
    done = [r["sheet"] for r in _modelled(report)]
    polygons = {s: plan.tile_of(s, "EPSG:5186").polygon for s in done}
    checked = 0
    for k, a in enumerate(done):
        for b in done[k + 1:]:
            border = polygons[a].intersection(polygons[b])
            if border.length < 1.0:
                continue
            sides = []
            for sheet in (a, b):
                v = _ground_triangles(out / "tiles" / sheet / "model.gml").reshape(-1, 3)
                on = shapely.dwithin(shapely.points(v[:, :2]), border, 2e-3)
                sides.append({tuple(p) for p in np.round(v[on], 3)})
            assert sides[0] == sides[1], (a, b, sorted(sides[0] ^ sides[1])[:6])
            assert len(sides[0]) > 10
            checked += 1
    assert checked >= 2


def _t_junctions(triangles: np.ndarray) -> int:
    """Vertices lying inside (not at the ends of) an edge that only one triangle uses: cracks."""
    xy = np.round(triangles[:, :, :2], 6)
    vertices, index = np.unique(xy.reshape(-1, 2), axis=0, return_inverse=True)
    tris = index.reshape(-1, 3)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    open_edges = unique[count == 1]
    lines = shapely.linestrings(np.stack([vertices[open_edges[:, 0]], vertices[open_edges[:, 1]]], axis=1))
    tree = shapely.STRtree(shapely.points(vertices))
    line_index, vertex_index = tree.query(lines, predicate="dwithin", distance=1e-4)
    inner = (vertex_index != open_edges[line_index, 0]) & (vertex_index != open_edges[line_index, 1])
    return int(inner.sum())


@BOTH_RUNS
def test_no_t_junction_inside_a_tile_nor_across_its_borders(run, request):
    out, report = request.getfixturevalue(run)
    every = []
    for row in _modelled(report):
        triangles = _ground_triangles(out / row["gml"])
        assert _t_junctions(triangles) == 0, row["sheet"]
        every.append(triangles)
    assert _t_junctions(np.concatenate(every)) == 0  # the tiles together: no crack along the borders


def _walls(gmls: list[Path]) -> list:
    """The outline of every surface of every building (the footprints among them)."""
    return [shapely.LinearRing(np.array(p.text.split(), dtype=float).reshape(-1, 3)[:, :2]) for g in gmls
            for p in etree.parse(str(g)).iterfind(".//bldg:Building//gml:posList", NS)]


def _lone_ground_edges(gmls: list[Path], rim, walls: list) -> np.ndarray:
    """Midpoints of the ground edges (terrain and road triangles, vertices as written: x, y, z to the
    millimetre) that no other triangle shares, farther than 1 cm from the boundary of ``rim`` and from
    the ``walls`` (the footprints the ground stops at)."""
    triangles = np.concatenate([_ground_triangles(g) for g in gmls])
    digits = np.rint(triangles.reshape(-1, 3) * 1000).astype(np.int64)
    vertices, index = np.unique(digits, axis=0, return_inverse=True)
    tris = index.reshape(-1, 3)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    lone = unique[count == 1]
    middle = (vertices[lone[:, 0], :2] + vertices[lone[:, 1], :2]) / 2000.0
    stops = shapely.union_all([rim.boundary, *walls])
    return middle[~shapely.dwithin(stops, shapely.points(middle), 0.01)]


@BOTH_RUNS
def test_the_ground_is_watertight_to_the_millimetre(run, request, single):
    """Every ground edge away from the area's rim and the buildings is shared by two triangles as written
    (a road triangle and a relief one meet at the same digits), in each tile, across the tiles' borders,
    and in a single run: no vertex written twice a millimetre apart (once seen on real road layers)."""
    out, report = request.getfixturevalue(run)
    rim = AREA.geometry(pyproj.CRS("EPSG:5186"))
    gmls = [out / r["gml"] for r in _modelled(report)]
    walls = _walls(gmls)  # a tile's ground also stops at its neighbours' buildings that cross into it
    for row in _modelled(report):
        tile = plan.tile_of(row["sheet"], "EPSG:5186").polygon
        assert len(_lone_ground_edges([out / row["gml"]], tile.intersection(rim), walls)) == 0, row["sheet"]
    assert len(_lone_ground_edges(gmls, rim, walls)) == 0
    assert len(_lone_ground_edges([Path(single.gml)], rim, _walls([Path(single.gml)]))) == 0


def test_a_second_run_resumes(local_run, sample):
    out, first = local_run
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("tiles/*/model.gml")}
    report = run_tiles(_inputs(sample), _options(), out, AREA, scale=1000, workers=1)
    assert report.resumed == len(first.rows) and report.buildings == first.buildings
    assert {p: p.stat().st_mtime_ns for p in out.glob("tiles/*/model.gml")} == stamps


@pytest.mark.slow  # two tiled runs: 88 s on a loaded 2-core machine
def test_tiles_an_earlier_run_made_without_3d_tiles_are_built_again_when_they_are_asked_for(local_run, sample,
                                                                                           tmp_path):
    import shutil

    out = tmp_path / "out"
    shutil.copytree(local_run[0], out)
    options = _options()
    options.tiles3d = True
    report = run_tiles(_inputs(sample), options, out, AREA, scale=1000, workers=2)
    assert report.resumed == 0 and report.buildings == local_run[1].buildings
    children = _tile_refs(out)
    assert len(children) == len(_modelled(report)) and all((out / c).is_file() for c in children)
    _check_run_tileset(Path(report.tileset), report)
    _check_from_afar(out, tmp_path)
    again = run_tiles(_inputs(sample), options, out, AREA, scale=1000, workers=1)  # now they are all there
    assert again.resumed == len(report.rows) and again.tileset == report.tileset


def test_a_tile_whose_buildings_are_all_its_neighbours_or_too_small_is_empty_with_its_ground(sample, tmp_path):
    """The park's tile with one building of its own, too small to keep (0.36 m²), beside its neighbours'
    buildings: nothing is kept, and the tile is empty — its terrain and roads — not failed."""
    import shutil

    from osgeo import ogr

    from wit_plugin.sheetrun import worker

    buildings = tmp_path / "buildings_with_a_shed.shp"
    for part in sample.buildings.parent.glob(sample.buildings.stem + ".*"):
        shutil.copy(part, buildings.with_suffix(part.suffix))
    ds = ogr.Open(str(buildings), 1)
    layer = ds.GetLayer(0)
    polygon = AREA.geometry(pyproj.CRS("EPSG:5186"))
    inside = plan.tile_of(sample.park, "EPSG:5186").polygon.intersection(polygon).point_on_surface()
    x, y = pyproj.Transformer.from_crs("EPSG:5186", layer.GetSpatialRef().ExportToWkt(), always_xy=True).transform(
        inside.x - 0.3, inside.y - 0.3)
    shed = ogr.Feature(layer.GetLayerDefn())
    shed.SetGeometry(ogr.CreateGeometryFromWkt(shapely.box(x, y, x + 0.6, y + 0.6).wkt))
    layer.CreateFeature(shed)
    ds = None
    row = worker.run_tile(_one_tile_spec(sample, tmp_path, sample.park, buildings=str(buildings)))
    assert (row["status"], row["buildings"], row["error"]) == ("empty", 0, None), row
    gml = tmp_path / "out" / row[worker.STAGED] / "model.gml"  # built, not yet in its place (the runner moves it)
    assert _building_ids(gml) == [] and len(_ground_triangles(gml)) == row["triangles"] > 20


def _one_tile_spec(sample, tmp_path: Path, sheet: str, **inputs) -> dict:
    """What the runner gives a worker for ``sheet`` of the run over AREA (its roads and dongs prepared)."""
    from wit_plugin.sheetrun import runner
    from wit_plugin.sheetrun.layers import prepare_context

    polygon = AREA.geometry(pyproj.CRS("EPSG:5186"))
    context = prepare_context(str(sample.roads), str(sample.districts), polygon, "EPSG:5186",
                              str(tmp_path / "context.gpkg"))
    return runner._spec(_inputs(sample, **inputs), _options(), tmp_path / "out", sheet, 1000, polygon,
                        (str(tmp_path / "context.gpkg"), context), STAND_IN, "new tile")


STAND_IN = Fingerprint({"max_edge": 15.0}, {"buildings": "0" * 32})  # what a tile built alone records


def test_a_tile_is_built_when_gdal_objects_outlive_their_use(sample, local_run, tmp_path, monkeypatch):
    """Dask's worker profiler keeps the frames it samples (every 10 ms) for a moment, and with them what they
    held: a GDAL Arrow stream (GDAL allows one per layer at a time, so the next read of the layer failed,
    "GetArrowStream() failed": the stress test's failed tiles, benchmarks/stress_tiles.py), a dataset whose new
    layer OGR creates only when it is destroyed (the TIN writer then failed, "'NoneType' object is not
    subscriptable", once in a tiled run's terrain step). Here every such object is kept alive: the tile is
    built as in the run."""
    from osgeo import ogr

    from wit_plugin.sheetrun import worker

    kept = []
    read, create = ogr.Layer.GetArrowStreamAsNumPy, ogr.DataSource.CreateLayer

    def outliving_stream(layer, options=[]):  # noqa: B006 — GDAL's own signature
        stream = read(layer, options)
        kept.append(stream.stream)  # the GDAL stream, as the sampled frame of this call would hold it
        return stream

    def outliving_dataset(ds, *args, **kwargs):
        kept.append(ds)
        return create(ds, *args, **kwargs)

    monkeypatch.setattr(ogr.Layer, "GetArrowStreamAsNumPy", outliving_stream)
    monkeypatch.setattr(ogr.DataSource, "CreateLayer", outliving_dataset)
    sheet = max(local_run[1].rows, key=lambda r: r["buildings"])
    row = worker.run_tile(_one_tile_spec(sample, tmp_path, sheet["sheet"]))
    assert (row["status"], row["buildings"], row["triangles"], row["error"]) == (
        "done", sheet["buildings"], sheet["triangles"], None), row
    assert len(kept) > 10


def test_a_tiled_run_in_the_3d_tiles_web_profile_compresses_every_tile_and_group(sample, tmp_path):
    import pygltflib

    options = _options()
    options.tiles3d, options.tiles3d_web = True, True
    report = run_tiles(_inputs(sample), options, tmp_path / "out", AREA, scale=1000, workers=2)
    files = sorted((tmp_path / "out").rglob("*.glb"))
    groups = [f for f in files if "3dtiles-groups" in f.parts]
    assert report.tileset and groups and len(files) > len(groups)
    for path in files:
        gltf = pygltflib.GLTF2().load_binary(str(path))
        assert {"EXT_meshopt_compression", "KHR_mesh_quantization"} <= set(gltf.extensionsRequired), path


def _holed_dem(sample, tmp_path: Path) -> Path:
    """The sample's DEM with a hole (-9999) under the eastern sliver tile 377090321 (1:1,000) of AREA."""
    from osgeo import gdal

    holed = tmp_path / "dem_holed.tif"
    gdal.Translate(str(holed), str(sample.dem))
    ds = gdal.Open(str(holed), gdal.GA_Update)
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    c0, c1 = int((209280 - x0) / dx), int((209320 - x0) / dx)
    r0, r1 = int((543240 - y0) / dy), int((543030 - y0) / dy)
    band = ds.GetRasterBand(1)
    band.WriteArray(np.full((r1 - r0, c1 - c0), -9999.0, dtype=np.float32), c0, r0)
    ds = band = None
    return holed


def test_a_failing_tile_is_recorded_and_the_others_go_on(sample, tmp_path):
    """A DEM with a hole (-9999) under the eastern sliver tile: 1 % of the run's area, which the check
    before the cluster lets through with a warning (a DEM or orthoimage that misses the area is refused
    there: test_reproject), but all of that tile's: it fails with the reason, the others are built."""
    holed = _holed_dem(sample, tmp_path)
    report = run_tiles(_inputs(sample, dem=str(holed)), _options(), tmp_path / "out", AREA, scale=1000, workers=2)
    failed = [r for r in report.rows if r["status"] == "failed"]
    assert [r["sheet"] for r in failed] == ["377090321"] and report.count("done") >= 1
    assert "dem_holed.tif has NoData under 100% of the area" in failed[0]["error"]
    assert not any((tmp_path / "out" / "tiles" / r["sheet"]).exists() for r in failed)
    assert {s: r["status"] for s, r in read_index(tmp_path / "out").items()} == {
        r["sheet"]: r["status"] for r in report.rows}


def test_an_unexpected_error_fails_its_tile_once_with_where_it_happened(sample, tmp_path, monkeypatch):
    """Not a data problem (a bug): the tile is failed with its innermost frames, run once — Dask retries
    nothing but a lost worker — and nothing of it stays."""
    from distributed import Client, LocalCluster

    from wit_plugin.infra.feedback import SILENT
    from wit_plugin.sheetrun import runner, worker
    from wit_plugin.sheetrun.index import write_index

    polygon = AREA.geometry(pyproj.CRS("EPSG:5186"))
    tile = plan.plan_tiles(polygon, "EPSG:5186", 1000)[0]
    spec = runner._spec(_inputs(sample), _options(), tmp_path, tile.sheet, 1000, polygon, (None, []), STAND_IN,
                        "new tile")
    folder = worker.tile_folder(tmp_path, tile.sheet)
    write_index(tmp_path, [tile], "EPSG:5186", {})
    calls = []

    def fails_midway(*args, **kwargs):
        calls.append(args)
        (Path(args[2]) / ".wit-run-x").mkdir(parents=True)  # the folder the tile is built in, half written
        raise TypeError("'NoneType' object is not subscriptable")

    monkeypatch.setattr(worker, "run_city_model", fails_midway)  # the in-process worker imports this module
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        rows = runner._map(client, {tile.sheet: spec}, tmp_path, SILENT)
    row = rows[tile.sheet]
    assert len(calls) == 1 and row["status"] == "failed"
    assert row["error"].startswith("TypeError: 'NoneType' object is not subscriptable (Traceback")
    assert "fails_midway" in row["error"] and not folder.exists() and not list(tmp_path.glob(".wit-staging/*"))
    assert read_index(tmp_path)[tile.sheet]["status"] == "failed"


def test_a_tile_spec_and_its_row_are_plain_values(sample, local_run):
    """What travels through the scheduler: JSON values only (nothing of the core to unpickle there)."""
    from wit_plugin.sheetrun import runner

    polygon = AREA.geometry(pyproj.CRS("EPSG:5186"))
    spec = runner._spec(_inputs(sample), _options(), Path("/out"), "376081", 1000, polygon, ("/out/c.gpkg", ["x"]),
                        STAND_IN, "new tile")
    assert json.loads(json.dumps(spec)) == spec
    rows = local_run[1].rows
    assert json.loads(json.dumps(rows)) == rows


class _CancelAfterFirstTile(Feedback):
    def __init__(self):
        self.finished = 0

    def info(self, message: str) -> None:
        self.finished += message.startswith("Tile ")

    def is_canceled(self) -> bool:
        return self.finished >= 1


def test_cancel_stops_the_run_and_leaves_no_half_tile(sample, tmp_path):
    with pytest.raises(CanceledError):
        run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, workers=1,
                  feedback=_CancelAfterFirstTile())
    index = read_index(tmp_path / "out")
    assert "pending" in {r["status"] for r in index.values()}
    for folder in (tmp_path / "out" / "tiles").glob("*"):
        assert (folder / "model.gml").is_file() and (folder / "build.json").is_file()
    assert not list((tmp_path / "out").glob(".wit-staging/new-*"))  # nothing half-built is left


# -- a real distributed cluster: dask scheduler + dask worker processes --------------------------

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stock_scheduler(tmp_path: Path, **config: str) -> tuple[str, subprocess.Popen]:
    """A `dask scheduler` that cannot import the core (tests/stock_scheduler.py, isolated mode, started outside
    the checkout), as managed clusters run it; ``config``: Dask settings (``DASK_…`` variables)."""
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(config)
    scheduler = subprocess.Popen([worker_python(), "-I", str(ROOT / "tests" / "stock_scheduler.py"), "--host",
                                  "127.0.0.1", "--port", str(port), "--no-dashboard"], env=env, cwd=tmp_path,
                                 start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return f"tcp://127.0.0.1:{port}", scheduler


def _workers(address: str, count: int = 2) -> list[subprocess.Popen]:
    """`dask worker` processes (each with its nanny) importing the core from this checkout."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return [subprocess.Popen([worker_python(), "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                              "--no-dashboard", "--memory-limit", "0"], env=env, start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for _ in range(count)]


@pytest.fixture()
def cluster(tmp_path_factory):
    """A stock scheduler (no core) and two `dask worker` processes with the core, on 127.0.0.1."""
    address, scheduler = _stock_scheduler(tmp_path_factory.mktemp("scheduler"))
    workers = _workers(address)
    from distributed import Client

    with Client(address, timeout=60) as client:
        client.wait_for_workers(2, timeout=120)
    yield address, workers
    stop_workers(workers + [scheduler])


def _border_vertices(gml: Path, sheet: str) -> set[tuple]:
    """The ground vertices (x, y, z to the mm) on a tile's border."""
    v = _ground_triangles(gml).reshape(-1, 3)
    on = shapely.dwithin(shapely.points(v[:, :2]), plan.tile_of(sheet, "EPSG:5186").polygon.exterior, 2e-3)
    return {tuple(p) for p in np.round(v[on], 3)}


def test_a_stock_scheduler_without_the_core_gives_the_local_result(cluster, sample, local_run, tmp_path):
    """The scheduler refuses to import the core (proved by asking it), yet serves the run: same tiles,
    statuses, buildings, ids and borders as the embedded run."""
    import importlib

    from distributed import Client

    address, _ = cluster
    with Client(address, timeout=30) as client, pytest.raises(ModuleNotFoundError, match="wit_plugin"):
        client.run_on_scheduler(importlib.import_module, "wit_plugin")
    report = run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, scheduler=address)
    out, local = local_run
    assert [(r["sheet"], r["status"], r["buildings"], r["triangles"]) for r in report.rows] == [
        (r["sheet"], r["status"], r["buildings"], r["triangles"]) for r in local.rows]
    assert report.buildings == local.buildings and local.count("done") >= 3
    for row in _modelled(report):
        assert _building_ids(tmp_path / "out" / row["gml"]) == _building_ids(out / row["gml"])
        borders = _border_vertices(tmp_path / "out" / row["gml"], row["sheet"])
        assert len(borders) > 10 and borders == _border_vertices(out / row["gml"], row["sheet"])


class _WorkerKiller(threading.Thread):
    """Kills (SIGKILL, by pid) the first worker seen running a tile; ``killed``: the tiles it was given."""

    def __init__(self, address: str):
        super().__init__()
        self.address, self.killed = address, []

    def run(self) -> None:
        from distributed import Client

        with Client(self.address, timeout=30) as client:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                busy = {w: [k for k in keys if str(k).startswith("wit-tile-")]
                        for w, keys in client.processing().items()}
                busy = {w: keys for w, keys in busy.items() if keys}
                if busy:
                    worker, keys = next(iter(busy.items()))
                    pids = client.run(os.getpid, workers=[worker])
                    os.kill(next(iter(pids.values())), signal.SIGKILL)
                    self.killed = [str(k).split("-")[2] for k in keys]
                    return
                time.sleep(0.05)


def test_a_killed_worker_costs_only_its_tile(cluster, sample, local_run, tmp_path):
    """Kill the process running a tile (by pid): Dask runs the tile again; the run ends complete and the
    killed attempt's staging folder is removed."""
    address, _ = cluster
    killer = _WorkerKiller(address)
    killer.start()
    report = run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, scheduler=address)
    killer.join()
    failed = [r for r in report.rows if r["status"] == "failed"]
    assert killer.killed and not failed and report.buildings == local_run[1].buildings, (killer.killed, failed)
    assert not (tmp_path / "out" / ".wit-staging").exists()  # nothing of the killed attempt is left


def test_a_tile_whose_worker_dies_too_often_is_failed_and_the_others_go_on(sample, local_run, tmp_path):
    """A scheduler that allows no worker death per task (allowed-failures 0): the killed tile ends
    KilledWorker, recorded as failed with the reason; every other tile is built."""
    address, scheduler = _stock_scheduler(tmp_path, DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES="0")
    workers = _workers(address)
    try:
        killer = _WorkerKiller(address)
        killer.start()
        report = run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, scheduler=address)
        killer.join()
    finally:
        stop_workers(workers + [scheduler])
    failed = {r["sheet"]: r["error"] for r in report.rows if r["status"] == "failed"}
    assert killer.killed and failed, (killer.killed, failed)
    assert all(e.startswith("its worker process died each time it ran the tile") for e in failed.values())
    assert report.count("done") + report.count("empty") == len(report.rows) - len(failed)
    assert not any((tmp_path / "out" / "tiles" / sheet / "model.gml").exists() for sheet in failed)


def test_a_tile_recorded_is_not_built_again_when_its_worker_dies_later(sample, tmp_path):
    """The worker that built the first tile dies once the tile is recorded: Dask computes again every result a
    lost worker held that is still wanted (the tile was written into after the run had ended; the stress test
    found its staging folder). The runner lets each row go once recorded: every tile is built once."""
    from distributed import Client

    address, scheduler = _stock_scheduler(tmp_path)
    workers = _workers(address)
    killed = []

    class KillTheFirstBuilder(Feedback):
        def __init__(self, client):
            self.client = client

        def info(self, message: str) -> None:
            if killed or not message.startswith("Tile "):
                return
            prefix = f"wit-tile-{message.split()[1].rstrip(':')}-"
            key, builder = next((t["key"], t["worker"]) for t in self.client.get_task_stream()
                                if str(t["key"]).startswith(prefix))
            deadline = time.monotonic() + 30  # until the scheduler has let the row go (at once when released)
            while any(key in keys for keys in self.client.has_what().values()) and time.monotonic() < deadline:
                time.sleep(0.05)
            os.kill(self.client.run(os.getpid, workers=[builder])[builder], signal.SIGKILL)
            killed.append(key)

    try:
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            client.get_task_stream()  # the scheduler records the tasks run from now on
            report = run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, scheduler=address,
                               feedback=KillTheFirstBuilder(client))
            built = [str(t["key"]) for t in client.get_task_stream()
                     if str(t["key"]).startswith("wit-tile-") and t["status"] == "OK"]
    finally:
        stop_workers(workers + [scheduler])
    assert killed and report.count("failed") == 0
    assert sorted(built) == sorted(set(built)) and len(built) == len(report.rows), (killed, built)


def test_workers_without_the_core_fail_every_tile_saying_so(sample, tmp_path):
    """A cluster whose workers cannot import the core (not installed there): every tile failed with what to
    install, and the run ends with that reason."""
    from wit_plugin.infra.errors import InputError

    address, scheduler = _stock_scheduler(tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    worker = subprocess.Popen([worker_python(), "-I", "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                               "--no-dashboard", "--memory-limit", "0"], env=env, cwd=tmp_path, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with pytest.raises(InputError, match=r"^No tile could be built \((\d+) failed, 0 empty\): ") as error:
            run_tiles(_inputs(sample), _options(), tmp_path / "out", AREA, scale=1000, scheduler=address)
    finally:
        stop_workers([worker, scheduler])
    rows = read_index(tmp_path / "out")
    assert rows and {r["status"] for r in rows.values()} == {"failed"}
    assert all(r["error"].startswith("a Dask worker cannot import the core (No module named 'wit_plugin')")
               for r in rows.values()), rows
    assert "install it on every worker" in str(error.value)


def test_no_worker_is_started_with_qgis_as_interpreter(monkeypatch, tmp_path):
    """Inside QGIS on Windows/macOS sys.executable is QGIS: workers then use a Python found on the PATH."""
    fake = tmp_path / "qgis-bin"
    fake.write_text("#!/bin/sh\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    monkeypatch.delenv("WIT_WORKER_PYTHON", raising=False)
    chosen = worker_python()
    assert chosen != str(fake) and Path(chosen).name.startswith("python")
    assert worker_python(sys.base_prefix + "/bin/python3") == sys.base_prefix + "/bin/python3"



# -- as users run it: through Processing in the QGIS process, and headless through qgis_process ----

def _parameters(sample, output: Path) -> dict:
    return {"ORTHO_INPUT": [str(sample.ortho_tiles[0].parent)], "DEM": str(sample.dem),
            "BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads), "DISTRICTS": str(sample.districts),
            "RADIUS": 280.0, "MAX_EDGE": 15.0, "TILE_SCALE": 1, "WORKERS": 2, "OUTPUT": str(output)}


@pytest.mark.qgis_facing
def test_citymodeltiles_through_processing_never_relaunches_qgis(run_algorithm, sample, local_run, tmp_path,
                                                                 monkeypatch):
    """In the QGIS process, with sys.executable pointing at a program that is not Python (QGIS on
    Windows and macOS), the workers are plain Pythons and the run gives the core's result."""
    fake = tmp_path / "qgis"
    fake.write_text("#!/bin/sh\necho 'QGIS was started again' >&2\nexit 3\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    monkeypatch.delenv("WIT_WORKER_PYTHON", raising=False)
    result = run_algorithm("wit:citymodeltiles", _parameters(sample, tmp_path / "out"))
    assert result["TILES_DONE"] == local_run[1].count("done") and result["TILES_FAILED"] == 0
    assert result["BUILDINGS_WRITTEN"] == local_run[1].buildings
    assert Path(result["INDEX"]).is_file()


@pytest.mark.qgis_facing
def test_failed_tiles_fail_the_algorithm_and_the_tiles_done_stay_for_the_next_run(run_algorithm, sample, local_run,
                                                                                    tmp_path):
    """A DEM with a hole under one tile (the check before the cluster lets it through: 1 % of the area):
    qgis_process exits non-zero with the count and the first reasons, the tiles done stay; through
    Processing on the same folder the same error (the tiles done are not built again); with the whole DEM
    the run ends complete, building again the tile that had failed and the one whose DEM window held part
    of the hole (its edge), keeping the two others."""
    from qgis.core import QgsProcessingException

    out = tmp_path / "out"
    parameters = dict(_parameters(sample, out), DEM=str(_holed_dem(sample, tmp_path)))
    args = [str(ROOT / "scripts" / "qgis-process"), "run", "wit:citymodeltiles"]
    for name, value in parameters.items():
        args += [f"--{name}={item}" for item in (value if isinstance(value, list) else [value])]
    result = subprocess.run(args, check=False, capture_output=True, text=True, timeout=900,
                            env=dict(os.environ, WIT_QGIS_PROFILE=str(tmp_path / "profile")))
    index = read_index(out)
    failed = sorted(s for s, r in index.items() if r["status"] == "failed")
    done = {s: (out / r["gml"]).stat().st_mtime_ns for s, r in index.items() if r["status"] in ("done", "empty")}
    log = result.stdout + result.stderr
    assert result.returncode != 0 and failed and done, log[-3000:]
    assert f"{len(failed)} of {len(index)} tile(s) failed. First reasons: {failed[0]}: " in log, log[-3000:]
    assert failed == ["377090321"] and "has NoData under 100% of the area" in log and "Traceback" not in log
    assert not any((out / "tiles" / s).exists() for s in failed)
    with pytest.raises(QgsProcessingException, match=rf"^{len(failed)} of {len(index)} tile\(s\) failed\. "):
        run_algorithm("wit:citymodeltiles", parameters)
    assert {s: (out / index[s]["gml"]).stat().st_mtime_ns for s in done} == done  # resumed, not built again
    result = run_algorithm("wit:citymodeltiles", _parameters(sample, out))
    assert (result["TILES_KEPT"], result["TILES_REBUILT"], result["TILES_FAILED"]) == (len(done) - 1, 2, 0)
    assert json.loads(result["REBUILD_REASONS"]) == {"dem": 1, "failed before": 1}
    assert read_index(out)["377090320"]["reason"] == "dem" and read_index(out)["377090321"]["reason"] == \
        "failed before"
    assert result["BUILDINGS_WRITTEN"] == local_run[1].buildings
    assert {s: r["status"] for s, r in read_index(out).items()} == {r["sheet"]: r["status"] for r in local_run[1].rows}


@pytest.mark.qgis_facing
def test_citymodeltiles_headless_through_qgis_process(sample, local_run, tmp_path):
    env = dict(os.environ, WIT_QGIS_PROFILE=str(tmp_path / "profile"))
    args = [str(ROOT / "scripts" / "qgis-process"), "--json", "run", "wit:citymodeltiles"]
    for name, value in _parameters(sample, tmp_path / "out").items():
        for item in value if isinstance(value, list) else [value]:
            args.append(f"--{name}={item}")
    result = subprocess.run(args, capture_output=True, text=True, env=env, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads(result.stdout[result.stdout.index("{"):])
    assert report["results"]["TILES_DONE"] == local_run[1].count("done")
    assert report["results"]["BUILDINGS_WRITTEN"] == local_run[1].buildings
    log = json.dumps(report.get("log", "")) + result.stdout + result.stderr
    python = log.split(", Python ")[1].split(".")[0] if ", Python " in log else ""
    assert "python" in Path(python).name.lower(), log[-2000:]
    _check_run_tileset(Path(report["results"]["TILESET"]), local_run[1])
    _check_in_the_viewer(tmp_path / "out", tmp_path)


def _tile_refs(output: Path) -> list[str]:
    """The tiles' tilesets (paths relative to ``output``) that the run's group files refer to, once each."""
    refs = []
    for file in (output / "3dtiles-groups").glob("*.json"):
        for child in json.loads(file.read_text(encoding="utf-8"))["root"]["children"]:
            target = (file.parent / child["content"]["uri"]).resolve()
            if target.parent.name == "3dtiles":
                refs.append(target.relative_to(output.resolve()).as_posix())
    return refs


def _check_run_tileset(path: Path, local) -> None:
    """One tileset over the tiles: the groups above them (1:5,000 sheets and up), each a tileset file of its
    own with its coarse terrain and its largest buildings; every tile's tileset referred to once; our
    checker finds nothing (regions nested, errors falling, metadata complete); transforms cancel out."""
    from wit_plugin.tiles3d.check import check_tileset

    out = path.parent
    document = json.loads(path.read_text(encoding="utf-8"))
    assert document["asset"]["version"] == "1.1" and path == out / "tileset.json"
    root = document["root"]
    assert document["geometricError"] > root["geometricError"]
    w, s, e, n, low, high = root["boundingVolume"]["region"]
    diagonal = np.hypot((e - w) * 6_371_000 * np.cos((s + n) / 2), (n - s) * 6_371_000)
    assert root["geometricError"] >= diagonal * (1 - 1e-9) and diagonal > 500  # opened from any distance
    check = check_tileset(path)
    assert check.problems == [], check.problems[:5]
    assert sorted(_tile_refs(out)) == sorted(f"tiles/{r['sheet']}/3dtiles/tileset.json" for r in _modelled(local))
    groups = sorted((out / "3dtiles-groups").glob("*.json"))
    assert groups and {f"3dtiles-groups/{g.name}" for g in groups} <= set(check.tilesets)
    shown = set()
    for file in groups:
        group = json.loads(file.read_text(encoding="utf-8"))["root"]
        frame = np.array(group["transform"]).reshape(4, 4).T
        glb = pygltflib.GLTF2().load(str(file.parent / group["content"]["uri"]))
        assert glb.meshes and glb.images  # the coarse terrain, draped
        metadata = glb.extensions["EXT_structural_metadata"]
        assert metadata["propertyTables"][0]["count"] > 0  # its buildings, with their attributes
        shown |= set(_property_strings(glb, "wit_id"))
        for child in group["children"]:
            assert group["geometricError"] >= child["geometricError"]
            # translations in metres of ECEF (~6e6 m): float64 round-off there is ~1e-9 m (numpy 2.4 on QGIS 3.44)
            np.testing.assert_allclose(frame @ np.array(child["transform"]).reshape(4, 4).T, np.eye(4), atol=1e-6)
            target = json.loads((file.parent / child["content"]["uri"]).read_text(encoding="utf-8"))["root"]
            assert child["boundingVolume"]["region"] == target["boundingVolume"]["region"]
            assert child["geometricError"] == target["geometricError"]
    assert shown == {i for r in _modelled(local) for i in _building_ids(out / r["gml"])}  # < 4,000: all of them
    result = subprocess.run(["node", str(ROOT / "viewer" / "validate-gltf.mjs"), str(out / "3dtiles-groups")],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]  # e.g. the viewer packages missing (scripts/setup-viewer.sh)
    summary = json.loads(result.stdout)
    assert summary["files"] == len(groups) and summary["errors"] == 0 and summary["warnings"] == 0, summary


def _property_strings(gltf: pygltflib.GLTF2, name: str) -> list[str]:
    """A text column of a glb's property table."""
    blob = gltf.binary_blob()
    table = gltf.extensions["EXT_structural_metadata"]["propertyTables"][0]
    values, offsets = (gltf.bufferViews[table["properties"][name][k]] for k in ("values", "stringOffsets"))
    ends = np.frombuffer(blob, dtype=np.uint32, count=table["count"] + 1, offset=offsets.byteOffset)
    data = blob[values.byteOffset:values.byteOffset + values.byteLength]
    return [data[a:b].decode("utf-8") for a, b in zip(ends[:-1], ends[1:])]


def test_the_core_installs_with_one_pip_command_for_workers(tmp_path):
    """pyproject.toml: `pip install .` gives a worker the core as `wit_plugin`, schemas included."""
    import shutil

    source = tmp_path / "checkout"  # a copy, so that the build leaves nothing in this checkout
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "wit_plugin", source / "wit_plugin", ignore=shutil.ignore_patterns("__pycache__"))
    target = tmp_path / "site"
    build = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                            "--target", str(target), str(source)], capture_output=True, text=True, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    probe = subprocess.run([sys.executable, "-c",
                            "import wit_plugin.sheetrun.worker as w, wit_plugin.citygml.schemas as s; "
                            "print(w.__file__); print((s.EMBEDDED_DIR / 'citygml3-all.xsd').is_file())"],
                           capture_output=True, text=True, cwd=tmp_path,
                           env=dict(os.environ,
                                    PYTHONPATH=os.pathsep.join([str(target), os.environ.get("PYTHONPATH", "")])))
    assert probe.returncode == 0, probe.stderr[-2000:]
    assert probe.stdout.split() == [str(target / "wit_plugin" / "sheetrun" / "worker.py"), "True"]


def _check_from_afar(output: Path, tmp_path: Path) -> None:
    """Zoomed out (4 radii of the run's bounding sphere), the viewer loads the top group's content alone and
    shows buildings (a bug once: from afar the groups held terrain only): a click names one."""
    report, picture = view_in_chromium(output, tmp_path, click=True, query="?range=4")
    top = json.loads((output / "tileset.json").read_text(encoding="utf-8"))["root"]["children"]
    assert len(top) == 1 and report["loadedTiles"] == 2  # the top group's file and its content, no tile
    assert report["firstViewRequests"] == 3 and report["firstViewBytes"] < 2e6  # and tileset.json
    assert report["buildingPixels"] > 0 and report["info"]["rows"]["wit_id"].startswith("BLD_")
    assert (np.abs(picture - picture[0]).sum(axis=1) > 30).mean() > 0.02


def _check_in_the_viewer(output: Path, tmp_path: Path) -> None:
    """The run's tileset in the offline viewer, in headless Chromium: loaded, no error, the model drawn."""
    _, picture = view_in_chromium(output, tmp_path)
    assert not list((tmp_path / "viewer" / "3dtiles").rglob("*.gml"))  # the tilesets alone
    assert (np.abs(picture - picture[0]).sum(axis=1) > 30).mean() > 0.2  # the tiles fill the view


def test_the_tiles_cityjsonseqs_join_into_one_valid_sequence(local_run, tmp_path):
    """Each tile's model.city.jsonl (the run's one transform) and the run's header index.city.jsonl: joined as
    `cat` joins them, one sequence holding every building of the tiles' CityGML once, valid (schemas, geometry,
    the images found from the run's folder)."""
    out, report = local_run
    modelled = _modelled(report)
    head = json.loads((out / "index.city.jsonl").read_text(encoding="utf-8"))
    assert report.cityjson == str(out / "index.city.jsonl")
    assert [part["sheet"] for part in head["metadata"]["parts"]] == [row["sheet"] for row in modelled]
    lines = [(out / "index.city.jsonl").read_text(encoding="utf-8").rstrip("\n")]
    for part in head["metadata"]["parts"]:
        tile = (out / part["file"]).read_text(encoding="utf-8").splitlines()
        assert json.loads(tile[0])["transform"] == head["transform"] and len(tile) - 1 == part["features"]
        lines += tile[1:]
    joined = out / "joined.city.jsonl"
    joined.write_text("\n".join(lines) + "\n", encoding="utf-8")
    features = [json.loads(line) for line in lines[1:]]
    buildings = [f["id"] for f in features if f["CityObjects"][f["id"]]["type"] == "Building"]
    assert sorted(buildings) == sorted(i for row in modelled for i in _building_ids(out / row["gml"]))
    (valid,) = validate_cityjson_files([str(joined)])
    joined.unlink()
    assert valid.valid, valid.issues[:5]


def test_every_setting_of_the_run_reaches_its_tiles(sample, tmp_path):
    """The tile's chain options are the run's: each setting changed from its default arrives at the worker as
    given (the facades did not: a tiled run's walls were generated whatever FACADES said)."""
    import dataclasses

    from wit_plugin.buildings.heights import HeightOptions
    from wit_plugin.sheetrun import runner, worker

    changed = dict(target_crs="EPSG:5179", sheet_crs="EPSG:4326", margin=40.0, max_edge=7.0, tolerance=0.25,
                   triangulator=triangulators.backend(None).key, texture_scale=0.5, facades="none",
                   outside_ortho="untextured", schema_dir=str(tmp_path / "schemas"),
                   schema_cache=str(tmp_path / "cache"), tiles3d=False, tiles3d_web=True, encoding="cp949",
                   cityjson=True)
    defaults = ChainOptions(area=None)
    plain = [f.name for f in dataclasses.fields(ChainOptions) if f.name not in runner.TILE_OWN_OPTIONS]
    assert sorted(plain) == sorted(changed), "a new ChainOptions field: add it here with a value not its default"
    assert all(changed[name] != getattr(defaults, name) for name in plain)
    options = ChainOptions(area=None, heights=HeightOptions(storey_height=3.5), keep_work=True, **changed)
    polygon = AREA.geometry(pyproj.CRS("EPSG:5179"))
    sheet = plan.plan_tiles(polygon, "EPSG:5179", 1000)[0].sheet
    spec = json.loads(json.dumps(runner._spec(_inputs(sample), options, tmp_path, sheet, 1000, polygon, (None, []),
                                              STAND_IN, "new tile")))  # as Dask sends it: plain values
    received = worker.tile_options(spec)
    assert {name: getattr(received, name) for name in plain} == changed
    assert received.heights.storey_height == 3.5 and received.metrics is False and received.keep_work is False
    assert received.area.crs == "EPSG:5179" and received.part_layers is not None
    assert received.cityjson_part.suffix == f"_{sheet}" and received.cityjson_part.folder == f"tiles/{sheet}"
