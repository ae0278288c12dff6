"""Updating a tiled run (wit_plugin.sheetrun.update): a rerun into an existing output rebuilds exactly the tiles
whose inputs or settings changed — and says why —, keeps the others untouched (their files not rewritten),
refreshes the groups above only where a child changed, and ends equal to a fresh run on the new inputs: every
tile's CityGML, textures and 3D Tiles byte for byte, the groups and the run's tileset, the index.

The run is the 1:1,000 tiles of ``test_sheetrun``'s sample over AREA: 377090320 (the big one), 377090229 to its
west, 377090310 (the park: no building) north and the sliver 377090321 east; orthoimage sheets 37709004 (west
of x ≈ 208,845) and 37709005 (east of it)."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
import test_sheetrun
from osgeo import gdal, ogr
from test_sheetrun import AREA, _inputs

from wit_plugin.chain import ChainOptions
from wit_plugin.infra.io.vector_io import read_layer
from wit_plugin.prepare.area import StudyArea
from wit_plugin.prepare.vectors import building_reach
from wit_plugin.sheetrun import plan
from wit_plugin.sheetrun.index import read_index
from wit_plugin.sheetrun.layers import CONTEXT_MARGIN
from wit_plugin.sheetrun.runner import run_tiles

sample = test_sheetrun.sample  # the tiled runs' sample (a fixture: this module's own copy)

BIG, WEST, PARK, SLIVER = "377090320", "377090229", "377090310", "377090321"
ALL = {BIG, WEST, PARK, SLIVER}
#: files that say when or how fast, not what: the tile's record and steps, validation's timings, GeoPackages'
#: time stamps (their features are compared), the groups' summaries (zip time stamps; their groups are compared)
VARYING = (".gpkg", "steps.json", "validation.html", "build.json", ".summary.npz", ".csv")
ROW_FIELDS = ("sheet", "status", "buildings", "triangles", "gml", "error", "fingerprint")


def _options(**settings) -> ChainOptions:
    return ChainOptions(area=None, max_edge=settings.pop("max_edge", 15.0), metrics=False, tiles3d=True, **settings)


def _run(inputs, out: Path, area: StudyArea = AREA, **settings):
    return run_tiles(inputs, _options(**settings), out, area, scale=1000, workers=2)


@pytest.fixture(scope="module")
def base(sample, tmp_path_factory):
    """A fresh run over AREA with its 3D Tiles: what each case updates (a copy of it)."""
    out = tmp_path_factory.mktemp("base") / "out"
    return out, _run(_inputs(sample), out)


def _copy(base, tmp_path: Path) -> tuple[Path, dict]:
    """A copy of the base run (times kept) to update, and its files' (time, size) before the update."""
    out = tmp_path / "updated"
    shutil.copytree(base[0], out)
    return out, _stamps(out)


def _stamps(out: Path) -> dict[str, tuple[int, int]]:
    return {p.relative_to(out).as_posix(): (p.stat().st_mtime_ns, p.stat().st_size) for p in out.rglob("*")
            if p.is_file()}


def _content(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*")
            if p.is_file() and not p.name.endswith(VARYING)}


def _features(gpkg: Path) -> list:
    layer = read_layer(gpkg)
    return [(shapely.to_wkb(g), tuple(layer.columns[f.name][i] for f in layer.fields))
            for i, g in enumerate(layer.geoms)]


def _assert_equal_to_fresh(updated: Path, fresh: Path) -> None:
    """Every tile's CityGML, textures and 3D Tiles, the groups and the run's tileset byte for byte; the LoD1 and
    TIN layers feature for feature; the index row for row (what was built from what)."""
    ours, theirs = _content(updated), _content(fresh)
    assert sorted(ours) == sorted(theirs)
    assert [name for name in ours if ours[name] != theirs[name]] == []
    for gpkg in sorted(fresh.glob("tiles/*/*.gpkg")):
        assert _features(updated / gpkg.relative_to(fresh)) == _features(gpkg), gpkg
    rows = [{k: r[k] for k in ROW_FIELDS} for r in read_index(updated).values()]
    assert rows == [{k: r[k] for k in ROW_FIELDS} for r in read_index(fresh).values()]
    assert not (updated / ".wit-staging").exists()


def _assert_untouched(out: Path, before: dict, sheets: set[str], groups: set[str] = frozenset()) -> None:
    """The kept tiles' and groups' files are the same files as before (not written again)."""
    kept = {name: stamp for name, stamp in before.items() if name.split("/")[:2] in ([["tiles", s] for s in sheets])
            or name.startswith(tuple(f"3dtiles-groups/{g}." for g in groups))}
    assert kept and {name: _stamps(out).get(name) for name in kept} == kept


def _updated(sample, base, tmp_path: Path, rebuilt: dict[str, str], groups_kept: set[str] = frozenset(),
             settings: dict | None = None, **inputs):
    """The base run updated with ``inputs`` (and ``settings``): exactly the tiles ``rebuilt`` built again (sheet →
    why), the others' files untouched (and the groups ``groups_kept``'), the output equal to a fresh run's."""
    out, before = _copy(base, tmp_path)
    report = _run(_inputs(sample, **inputs), out, **(settings or {}))
    assert report.update.rebuilt == rebuilt
    if set(rebuilt) != ALL:
        _assert_untouched(out, before, ALL - set(rebuilt), groups_kept)
    fresh = tmp_path / "fresh"
    _run(_inputs(sample, **inputs), fresh, **(settings or {}))
    _assert_equal_to_fresh(out, fresh)
    return out, report


def _tile_reach(sheet: str) -> tuple:
    polygon = AREA.geometry(pyproj.CRS("EPSG:5186"))
    return building_reach(plan.tile_of(sheet, "EPSG:5186").polygon.intersection(polygon), CONTEXT_MARGIN).bounds


def _edited_buildings(sample, folder: Path, choose, footprint: bool = True) -> tuple[Path, shapely.Polygon]:
    """A copy of the buildings in ``folder`` with one building, the first ``choose(box in EPSG:5186)`` accepts,
    given three more storeys and (``footprint``) shrunk by half a metre; and that building (EPSG:5186)."""
    copy = folder / sample.buildings.name
    folder.mkdir()
    for part in sample.buildings.parent.glob(sample.buildings.stem + ".*"):  # byte copies: the CP949 text stays
        shutil.copy(part, copy.with_suffix(part.suffix))
    ds = gdal.OpenEx(str(copy), gdal.OF_VECTOR | gdal.OF_UPDATE, open_options=["ENCODING="])
    layer = ds.GetLayer(0)
    to_5186 = pyproj.Transformer.from_crs(layer.GetSpatialRef().ExportToWkt(), "EPSG:5186", always_xy=True)
    for feature in layer:
        geometry = shapely.from_wkb(bytes(feature.GetGeometryRef().ExportToWkb()))
        here = shapely.transform(geometry, lambda xy: np.column_stack(to_5186.transform(xy[:, 0], xy[:, 1])))
        if geometry.area > 100 and choose(shapely.box(*here.bounds)):
            if footprint:
                shrunk = geometry.buffer(-0.5, join_style="mitre")
                feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(shrunk)))
            feature.SetField("GRO_FLO_CO", feature.GetField("GRO_FLO_CO") + 3)
            layer.SetFeature(feature)
            return copy, here
    raise AssertionError("no building to edit")


def _clear_of(box: shapely.Polygon, sheets: set[str]) -> bool:
    return not any(box.intersects(shapely.box(*_tile_reach(s))) for s in sheets)


def test_nothing_changed_keeps_every_file_and_writes_nothing(sample, base, tmp_path):
    out, before = _copy(base, tmp_path)
    report = _run(_inputs(sample), out)
    assert (sorted(report.update.kept), report.update.build, report.update.removed) == (sorted(ALL), {}, [])
    assert _stamps(out) == before and report.buildings == base[1].buildings
    assert [r["status"] for r in report.rows] == [r["status"] for r in base[1].rows]


def test_one_building_edited_inside_its_tile_rebuilds_that_tile_only(sample, base, tmp_path):
    """A building of the big tile, farther than the neighbours' margin from every other tile: its tile is built
    again (because of the buildings), nothing else; its group and the block above it are refreshed, the other
    group is not."""
    inside = shapely.box(*_tile_reach(BIG)).buffer(-150)
    edited, _ = _edited_buildings(sample, tmp_path / "edited",
                                  lambda box: inside.contains(box) and _clear_of(box, ALL - {BIG}))
    out, report = _updated(sample, base, tmp_path, {BIG: "buildings"}, {"37709004"}, buildings=str(edited))
    assert sorted(report.update.kept) == sorted(ALL - {BIG}) and read_index(out)[BIG]["reason"] == "buildings"


@pytest.mark.slow  # two tiled runs
def test_a_building_edited_across_a_border_rebuilds_both_tiles(sample, base, tmp_path):
    """A building crossing the border of the big tile and its western neighbour: a hole in the neighbour's
    terrain, simplified with its walls — both tiles are built again, the two others kept."""
    border = shapely.LineString([(208844.0, 542800.0), (208844.0, 543450.0)])
    edited, _ = _edited_buildings(sample, tmp_path / "edited",
                                  lambda box: box.intersects(border) and _clear_of(box, {PARK, SLIVER}))
    _updated(sample, base, tmp_path, {BIG: "buildings", WEST: "buildings"}, buildings=str(edited))


@pytest.mark.slow  # two tiled runs
def test_a_building_across_a_border_given_more_storeys_rebuilds_its_own_tile_only(sample, base, tmp_path):
    """Its attributes are its own tile's alone: the neighbour takes its footprint and id, not its height."""
    border = shapely.LineString([(208844.0, 542800.0), (208844.0, 543450.0)])
    edited, building = _edited_buildings(sample, tmp_path / "edited",
                                         lambda box: box.intersects(border) and _clear_of(box, {PARK, SLIVER}),
                                         footprint=False)
    owner = plan.owners(shapely.get_coordinates(building.point_on_surface()), "EPSG:5186", 1000)[0]
    assert owner in {BIG, WEST}
    _updated(sample, base, tmp_path, {owner: "buildings"}, buildings=str(edited))


@pytest.mark.slow  # two tiled runs
def test_one_orthoimage_sheet_replaced_rebuilds_the_tiles_that_use_it(sample, base, tmp_path):
    """The western sheet brightened (same name, same size): the tiles whose area (and buildings) its footprint
    meets are built again; the park and the sliver, on the eastern sheet alone, are kept."""
    ortho = tmp_path / "ortho"
    ortho.mkdir()
    for tif in sample.ortho_tiles:
        shutil.copy(tif, ortho / tif.name)
    western = next(p for p in ortho.iterdir() if "37709004" in p.name)
    ds = gdal.Open(str(western), gdal.GA_Update)
    for number in range(1, ds.RasterCount + 1):
        band = ds.GetRasterBand(number)
        band.WriteArray(np.minimum(band.ReadAsArray().astype(np.int32) + 20, 255).astype(np.uint8))
    ds = None
    _updated(sample, base, tmp_path, {BIG: "ortho", WEST: "ortho"}, ortho=[str(ortho)])


@pytest.mark.slow  # two tiled runs
def test_the_dem_replaced_rebuilds_the_tiles_under_its_changed_cells(sample, base, tmp_path):
    """Another DEM file, 3 m higher over 20 m × 20 m inside the big tile: that tile is built again, its
    neighbours (whose windows do not reach there) are kept."""
    dem = tmp_path / "dem_new.tif"
    gdal.Translate(str(dem), str(sample.dem))
    ds = gdal.Open(str(dem), gdal.GA_Update)
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    c0, r0 = int((209040 - x0) / dx), int((543010 - y0) / dy)
    band = ds.GetRasterBand(1)
    cells = band.ReadAsArray(c0, r0, 4, 4)
    band.WriteArray(cells + 3.0, c0, r0)
    ds = band = None
    _updated(sample, base, tmp_path, {BIG: "dem"}, {"37709004"}, dem=str(dem))


@pytest.mark.slow  # two tiled runs
def test_a_parameter_changed_rebuilds_every_tile_and_says_which(sample, base, tmp_path):
    out, report = _updated(sample, base, tmp_path, dict.fromkeys(ALL, "max_edge"), settings={"max_edge": 25.0})
    assert report.update.kept == [] and {r["reason"] for r in read_index(out).values()} == {"max_edge"}


@pytest.mark.slow  # three tiled runs
def test_the_area_shrunk_then_grown_removes_then_adds_tiles(sample, base, tmp_path):
    """A radius of 250 m instead of 280 m leaves the park and the sliver outside: they are removed (files and
    rows), the two others built again (their area changed); grown back, the two come back as new tiles and
    the output equals the base run."""
    smaller = StudyArea.circle(AREA.x, AREA.y, 250.0)
    out, _ = _copy(base, tmp_path)
    report = _run(_inputs(sample), out, smaller)
    assert (sorted(report.update.removed), sorted(report.update.rebuilt), report.update.added) == (
        sorted({PARK, SLIVER}), sorted({BIG, WEST}), [])
    assert all("area" in reason.split(", ") for reason in report.update.rebuilt.values())
    assert sorted(read_index(out)) == sorted({BIG, WEST}) and sorted(p.name for p in (out / "tiles").iterdir()) == \
        sorted({BIG, WEST})
    fresh = tmp_path / "fresh"
    _run(_inputs(sample), fresh, smaller)
    _assert_equal_to_fresh(out, fresh)
    report = _run(_inputs(sample), out)
    assert (sorted(report.update.added), sorted(report.update.rebuilt), report.update.removed) == (
        sorted({PARK, SLIVER}), sorted({BIG, WEST}), [])
    _assert_equal_to_fresh(out, base[0])


def test_an_update_stopped_between_a_tiles_move_and_its_row_is_taken_up_by_the_next_run(sample, base, tmp_path,
                                                                                        monkeypatch):
    """Stopped (an exception standing for a kill) after the rebuilt tile's folder took its place, before its
    index row said so: the folder is the new build whole (its record says so), the row says pending — never
    done with the old fingerprint; the next run keeps the tile (nothing to build) and writes its row."""
    from wit_plugin.chain.fingerprint import read_record
    from wit_plugin.sheetrun import update

    inside = shapely.box(*_tile_reach(BIG)).buffer(-150)
    edited, _ = _edited_buildings(sample, tmp_path / "edited",
                                  lambda box: inside.contains(box) and _clear_of(box, ALL - {BIG}))
    out, _ = _copy(base, tmp_path)
    old = read_record(out / "tiles" / BIG)["fingerprint"]

    def killed(*args):
        raise KeyboardInterrupt("killed")

    monkeypatch.setattr(update, "update_row", killed)
    with pytest.raises(KeyboardInterrupt):
        _run(_inputs(sample, buildings=str(edited)), out)
    monkeypatch.undo()
    record = read_record(out / "tiles" / BIG)
    row = read_index(out)[BIG]
    assert record["fingerprint"] != old and record["reason"] == "buildings"
    assert (row["status"], row["fingerprint"], row["reason"]) == ("pending", old, "buildings")
    assert not list(out.glob(".wit-staging/*"))
    report = _run(_inputs(sample, buildings=str(edited)), out)
    assert report.update.build == {} and read_index(out)[BIG]["fingerprint"] == record["fingerprint"]
    fresh = tmp_path / "fresh"
    _run(_inputs(sample, buildings=str(edited)), fresh)
    _assert_equal_to_fresh(out, fresh)


def test_a_tile_left_aside_by_a_kill_between_two_renames_is_put_back(sample, base, tmp_path):
    """The state a kill leaves between a replacement's two renames (``test_swap``: a real SIGKILL there): the old
    folder aside, none in its place, the new build unfinished. The next run puts the old folder back and,
    nothing having changed, keeps every tile: the output is the base run's."""
    from wit_plugin.sheetrun.index import update_row

    out, _ = _copy(base, tmp_path)
    update_row(out, BIG, {**read_index(out)[BIG], "status": "pending"})
    (out / ".wit-staging").mkdir()
    shutil.copytree(out / "tiles" / BIG, out / ".wit-staging" / f"new-{BIG}-1-1")
    (out / "tiles" / BIG).rename(out / ".wit-staging" / f"old-{BIG}")
    report = _run(_inputs(sample), out)
    assert report.update.build == {} and sorted(report.update.kept) == sorted(ALL)
    _assert_equal_to_fresh(out, base[0])


@pytest.mark.slow  # two tiled runs
def test_3d_tiles_switched_off_rebuilds_every_tile_without_them_and_removes_the_runs_tileset(sample, base, tmp_path):
    """Not a mix: the groups and the run's tileset.json of the earlier run would refer to tilesets the tiles no
    longer have; they go, as a fresh run without 3D Tiles has none."""
    out, _ = _copy(base, tmp_path)
    report = run_tiles(_inputs(sample), ChainOptions(area=None, max_edge=15.0, metrics=False, tiles3d=False), out,
                       AREA, scale=1000, workers=2)
    assert report.update.rebuilt == dict.fromkeys(ALL, "tiles3d") and report.tileset is None
    assert not (out / "tileset.json").exists() and not (out / "3dtiles-groups").exists()
    assert not list(out.glob("tiles/*/3dtiles"))
    fresh = tmp_path / "fresh"
    run_tiles(_inputs(sample), ChainOptions(area=None, max_edge=15.0, metrics=False, tiles3d=False), fresh, AREA,
              scale=1000, workers=2)
    _assert_equal_to_fresh(out, fresh)


@pytest.mark.slow  # three tiled runs
def test_cityjson_switched_on_then_off_rebuilds_every_tile_and_keeps_the_runs_sequence_true(sample, base, tmp_path):
    """On: every tile built again with its CityJSONSeq and the run's index.city.jsonl over them, equal to a fresh
    run with CityJSON; off again: the tiles lose theirs and the run's header goes (it would list parts that are no
    longer there), equal to the base run."""
    out, report = _updated(sample, base, tmp_path, dict.fromkeys(ALL, "cityjson, cityjson_translate"),
                           settings={"cityjson": True})
    assert report.cityjson == str(out / "index.city.jsonl") and len(list(out.glob("tiles/*/model.city.jsonl"))) == 4
    report = _run(_inputs(sample), out)
    assert report.update.rebuilt == dict.fromkeys(ALL, "cityjson, cityjson_translate") and report.cityjson is None
    assert not (out / "index.city.jsonl").exists() and not list(out.glob("tiles/*/model.city.jsonl"))
    _assert_equal_to_fresh(out, base[0])
