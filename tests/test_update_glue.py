"""Updating a city as users do it: ``wit:citymodeltiles`` run again into its output headless through qgis_process
(the case of issue 28: MAX_EDGE 15, then 25 into the same folder — every tile built again, saying why; then
REBUILD), and ``wit:citymodel`` through Processing (built, then nothing to do, then built again when asked)."""
from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
import test_sheetrun
from test_sheetrun import ROOT, _parameters

from wit_plugin.sheetrun.index import read_index

pytestmark = pytest.mark.qgis_facing
sample = test_sheetrun.sample  # the tiled runs' sample (a fixture: this module's own copy)


def _qgis_process(parameters: dict, tmp_path: Path) -> tuple[dict, str]:
    """The results and the log of ``wit:citymodeltiles`` run by ``scripts/qgis-process --json``."""
    args = [str(ROOT / "scripts" / "qgis-process"), "--json", "run", "wit:citymodeltiles"]
    for name, value in parameters.items():
        args += [f"--{name}={item}" for item in (value if isinstance(value, list) else [value])]
    result = subprocess.run(args, capture_output=True, text=True, timeout=900,
                            env=dict(os.environ, WIT_QGIS_PROFILE=str(tmp_path / "profile")))
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads(result.stdout[result.stdout.index("{"):])
    return report["results"], json.dumps(report.get("log", "")) + result.stdout + result.stderr


def test_max_edge_changed_into_the_same_folder_rebuilds_every_tile_and_says_why(sample, tmp_path):
    """Issue 28: the second run used to say "1 already done, 0 to build" and keep the 15 m model."""
    out = tmp_path / "out"
    first, _ = _qgis_process(_parameters(sample, out), tmp_path)
    tiles = first["TILES_DONE"] + first["TILES_EMPTY"]
    assert (first["TILES_ADDED"], first["TILES_KEPT"], first["TILES_REBUILT"]) == (tiles, 0, 0) and tiles == 4
    models = {p: p.read_bytes() for p in out.glob("tiles/*/model.gml")}
    second, log = _qgis_process(dict(_parameters(sample, out), MAX_EDGE=25.0), tmp_path)
    assert (second["TILES_REBUILT"], second["TILES_KEPT"], second["TILES_ADDED"], second["TILES_REMOVED"]) == (
        tiles, 0, 0, 0)
    assert json.loads(second["REBUILD_REASONS"]) == {"max_edge": tiles}
    assert f"{tiles} to build again (max_edge: {tiles})" in log
    assert {r["reason"] for r in read_index(out).values()} == {"max_edge"}
    assert all(p.read_bytes() != model for p, model in models.items())  # the 25 m model, not the 15 m one
    forced, _ = _qgis_process(dict(_parameters(sample, out), MAX_EDGE=25.0, REBUILD=True), tmp_path)
    assert (forced["TILES_REBUILT"], forced["TILES_KEPT"]) == (tiles, 0)
    assert json.loads(forced["REBUILD_REASONS"]) == {"forced": tiles}


def _stamps(out: Path) -> dict[Path, int]:
    """The files' times, but the GeoPackages' (QGIS opens them when it loads the result layers, and may write)."""
    return {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.suffix != ".gpkg"}


def test_citymodel_run_again_into_its_folder_does_nothing_unless_asked(run_algorithm, sample, tmp_path):
    parameters = {"ORTHO_INPUT": [str(sample.ortho_tiles[0].parent)], "DEM": str(sample.dem),
                  "BUILDINGS": str(sample.buildings), "ROADS": str(sample.roads), "DISTRICTS": str(sample.districts),
                  "RADIUS": 200.0, "MAX_EDGE": 15.0, "TILES3D": False,  # over both sheets (for the seam metric)
                  "OUTPUT": str(tmp_path / "out")}
    first = run_algorithm("wit:citymodel", parameters)
    assert (first["REBUILT"], first["REBUILD_REASON"]) == (True, "no finished build recorded")
    stamps = _stamps(tmp_path / "out")
    again = run_algorithm("wit:citymodel", parameters)
    assert (again["REBUILT"], again["REBUILD_REASON"]) == (False, "")
    assert {k: again[k] for k in ("BUILDINGS_WRITTEN", "VALID", "GML")} == {
        k: first[k] for k in ("BUILDINGS_WRITTEN", "VALID", "GML")}
    assert _stamps(tmp_path / "out") == stamps
    forced = run_algorithm("wit:citymodel", dict(parameters, REBUILD=True))
    assert (forced["REBUILT"], forced["REBUILD_REASON"]) == (True, "forced")
