"""``wit:citymodel`` run again into its own output (``chain.rerun.update_city_model``): nothing changed, nothing is
done and the recorded result is reported; a setting or an input changed, the model is built again, says why,
and the folder holds the new build alone (files of the old build it did not write are gone) — equal to a fresh
run; an interrupted build is never taken as current."""
from __future__ import annotations

import shutil
from pathlib import Path

import pyproj
import pytest
import shapely
import test_sheetrun
from test_sheetrun import _inputs
from test_update_tiles import _edited_buildings

from wit_plugin.chain import ChainOptions, rerun, run_city_model
from wit_plugin.chain.fingerprint import BUILD_FILE, read_record
from wit_plugin.chain.rerun import FORCED, NO_RECORD, update_city_model
from wit_plugin.prepare.area import StudyArea

sample = test_sheetrun.sample  # the tiled runs' sample (a fixture: this module's own copy)

AREA = StudyArea.circle(127.1020, 37.4876, 90.0)


def _options(**settings) -> ChainOptions:
    return ChainOptions(area=AREA, max_edge=settings.pop("max_edge", 15.0), metrics=False, **settings)


def _stamps(out: Path) -> dict[str, int]:
    return {p.relative_to(out).as_posix(): p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def built(sample, tmp_path_factory):
    out = tmp_path_factory.mktemp("citymodel") / "out"
    return out, update_city_model(_inputs(sample), _options(), out)


def test_a_first_run_builds_and_records_what_it_was_built_from(built):
    out, first = built
    record = read_record(out)
    assert first.rebuilt and first.reason == NO_RECORD and first.report.buildings > 10 and first.report.valid
    assert record["reason"] == NO_RECORD and len(record["fingerprint"]) == 32
    assert set(record["inputs"]) == {"area", "buildings", "roads", "districts", "dem", "ortho"}
    assert record["settings"]["max_edge"] == 15.0 and record["settings"]["plugin"]
    assert sorted(record["files"]) == sorted(p.name for p in out.iterdir() if p.name != BUILD_FILE)


def test_nothing_changed_does_nothing_and_reports_the_recorded_result(sample, built, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(built[0], out)
    before = _stamps(out)
    again = update_city_model(_inputs(sample), _options(), out)
    assert (again.rebuilt, again.reason) == (False, "")
    assert _stamps(out) == before
    expected = built[1].report.as_dict()
    expected.update({key: value.replace(str(built[0]), str(out)) for key, value in expected.items()
                     if isinstance(value, str) and value.startswith(str(built[0]))})
    assert again.report.as_dict() == expected


def test_a_setting_changed_builds_again_says_why_and_leaves_no_file_of_the_old_build(sample, built, tmp_path):
    """MAX_EDGE 15 → 25 and no 3D Tiles: built again for both reasons; the 3dtiles folder of the old build is
    gone, and the folder holds what a fresh run writes (the model byte for byte)."""
    out = tmp_path / "out"
    shutil.copytree(built[0], out)
    assert (out / "3dtiles").is_dir()
    changed = update_city_model(_inputs(sample), _options(max_edge=25.0, tiles3d=False), out)
    assert changed.rebuilt and changed.reason == "max_edge, tiles3d"
    assert not (out / "3dtiles").exists() and read_record(out)["reason"] == "max_edge, tiles3d"
    fresh = run_city_model(_inputs(sample), _options(max_edge=25.0, tiles3d=False), tmp_path / "fresh")
    assert sorted(p.name for p in out.iterdir()) == sorted([p.name for p in (tmp_path / "fresh").iterdir()]
                                                          + [BUILD_FILE])
    assert Path(changed.report.gml).read_bytes() == Path(fresh.gml).read_bytes()
    assert update_city_model(_inputs(sample), _options(max_edge=25.0, tiles3d=False), out).rebuilt is False


def test_rebuild_builds_again_what_has_not_changed(sample, built, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(built[0], out)
    forced = update_city_model(_inputs(sample), _options(), out, rebuild=True)
    assert (forced.rebuilt, forced.reason) == (True, FORCED)
    assert Path(forced.report.gml).read_bytes() == (built[0] / "model.gml").read_bytes()


def test_an_interrupted_build_is_never_taken_as_current(sample, built, tmp_path, monkeypatch):
    """The record goes before the build starts: a build stopped midway (after the old files were replaced in part,
    or before) leaves a folder without a record, which the next run builds again, saying so."""
    out = tmp_path / "out"
    shutil.copytree(built[0], out)

    def stopped(inputs, options, output, feedback):
        (Path(output) / "model.gml").write_text("half written")
        raise KeyboardInterrupt("killed")

    monkeypatch.setattr(rerun, "run_city_model", stopped)
    with pytest.raises(KeyboardInterrupt):
        update_city_model(_inputs(sample), _options(max_edge=25.0), out)
    monkeypatch.undo()
    assert not (out / BUILD_FILE).exists()
    again = update_city_model(_inputs(sample), _options(), out)  # even with the settings of the last good build
    assert (again.rebuilt, again.reason) == (True, NO_RECORD)
    assert (out / "model.gml").read_bytes() == (built[0] / "model.gml").read_bytes()


def test_an_edited_building_outside_the_area_changes_nothing_one_inside_builds_again(sample, built, tmp_path):
    """Only the features the run reads count."""
    out = tmp_path / "out"
    shutil.copytree(built[0], out)
    box = shapely.box(*AREA.geometry(pyproj.CRS("EPSG:5186")).bounds)
    far, _ = _edited_buildings(sample, tmp_path / "far", lambda footprint: box.distance(footprint) > 100)
    assert update_city_model(_inputs(sample, buildings=str(far)), _options(), out).rebuilt is False
    near, _ = _edited_buildings(sample, tmp_path / "near", box.contains)
    changed = update_city_model(_inputs(sample, buildings=str(near)), _options(), out)
    assert (changed.rebuilt, changed.reason) == (True, "buildings")
