"""What a Dask worker runs for one tile: the ordinary chain on the tile (no QGIS in the process).

The task takes a plain dict (paths, numbers, WKT: JSON values) and returns one, whatever happens in
the tile: the runner submits it by its import path (``TASK``), so the Dask scheduler, which may be a
stock one without the core, unpickles nothing but strings, numbers and Dask's own functions; only
workers import the core. An error is never raised to Dask (which would run the tile again, or need
our exception class on the scheduler): a tile whose data cannot be made is ``failed`` with the
reason, an unexpected error is ``failed`` with its innermost frames. The tile is built into a folder of
its own under ``<output>/.wit-staging/`` with its record (``build.json``: its fingerprint and its index row);
the runner moves it into ``<output>/tiles/<sheet>/`` whole (``update.commit_tile``), so a killed worker
never leaves a half-written tile, and an update never a tile half old and half new.
"""
from __future__ import annotations

import logging
import os
import resource
import shutil
import sys
import time
import traceback
from pathlib import Path

from ..buildings.heights import HeightOptions
from ..chain import ChainInputs, ChainOptions, run_city_model
from ..chain.fingerprint import BUILD_FILE, write_record
from ..cityjson.sequence import tile_part
from ..infra.errors import WitError
from ..infra.feedback import LoggingFeedback
from ..prepare.area import StudyArea
from .index import DONE, EMPTY, FAILED
from .job import TileJob
from .plan import TileOwner

TILES_DIR = "tiles"
MODEL_FILE = "model.gml"
STAGING_DIR = ".wit-staging"  # tiles being built, and tiles being replaced (see ``update``)
STAGED = "staged"  # the row's key for the folder a tile was built in (relative to the output), not an index field
TASK = "wit_plugin.sheetrun.worker.run_tile"  # what a worker imports: the core's name on any machine


def tile_folder(output: str | Path, sheet: str) -> Path:
    return Path(output) / TILES_DIR / sheet


def peak_mb() -> float:
    """Peak resident memory of this process so far (MB)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


def tile_options(spec: dict) -> ChainOptions:
    """The chain's options of the tile ``spec["sheet"]``: the run's, with the tile's own area and layers."""
    sheet, target_crs = spec["sheet"], spec["options"]["target_crs"]
    owner = TileOwner(sheet, spec["scale"], target_crs, spec["options"]["sheet_crs"], spec["area_wkt"])
    job = TileJob(owner, spec["context"], tuple(spec["context_layers"]))
    return ChainOptions(**spec["options"], area=StudyArea.polygon(job.area(target_crs), target_crs),
                        heights=HeightOptions(**spec["heights"]), metrics=False, part_layers=job.tile_layers,
                        cityjson_part=tile_part(sheet, spec["cityjson_translate"], f"{TILES_DIR}/{sheet}"))


def run_tile(spec: dict) -> dict:
    """Build the tile ``spec["sheet"]``; the index row (status, counts, seconds, peak_mb, gml, error,
    fingerprint, reason) and, unless it failed, the folder it was built in (``STAGED``)."""
    start = time.perf_counter()
    sheet = spec["sheet"]
    folder = Path(spec["output"]) / STAGING_DIR / f"new-{sheet}-{time.time_ns()}-{os.getpid()}"
    options = tile_options(spec)
    row = {"sheet": sheet, "buildings": 0, "triangles": 0, "gml": None, "error": None,
           "fingerprint": spec["fingerprint"]["fingerprint"], "reason": spec["reason"]}
    files = []
    try:
        report = run_city_model(ChainInputs(**spec["inputs"]), options, folder,
                                LoggingFeedback(logging.getLogger(f"wit_plugin.sheetrun.{sheet}")))
        status = (DONE if report.buildings else EMPTY) if report.valid else FAILED
        files = report.files
        row.update(status=status, buildings=int(report.buildings), triangles=int(report.triangles),
                   gml=f"{TILES_DIR}/{sheet}/{MODEL_FILE}",
                   error=None if report.valid else f"{report.errors} validation error(s): see validation.html")
    except WitError as exc:  # the tile's data: recorded, the run goes on
        row.update(status=FAILED, error=str(exc))
    except Exception as exc:  # noqa: BLE001 — a bug: recorded with where it happened, never retried
        row.update(status=FAILED, error=f"{type(exc).__name__}: {exc} ({traceback.format_exc(limit=-4).strip()})")
    row.update(seconds=round(time.perf_counter() - start, 3), peak_mb=round(peak_mb(), 1))
    if row["status"] == FAILED:  # nothing of it stays
        shutil.rmtree(folder, ignore_errors=True)
        return row
    write_record(folder, {**spec["fingerprint"], "reason": spec["reason"], "row": row, "files": files + [BUILD_FILE]})
    return {**row, STAGED: folder.relative_to(spec["output"]).as_posix()}
