"""What a Dask worker runs for one tile: the ordinary chain on the tile (no QGIS in the process).

The task takes and returns plain dicts (paths, numbers, WKT), so it travels between processes and
machines with nothing to unpickle but this module, importable as ``wit_plugin.tiles.worker``.
The tile's files appear in ``<output>/tiles/<sheet>/`` only once written and validated (the chain
stages them), so a killed worker never leaves a half-written tile.
"""
from __future__ import annotations

import logging
import resource
import shutil
import sys
import time
import traceback
from pathlib import Path

from ..chain import ChainInputs, ChainOptions, run_city_model
from ..errors import CanceledError, WitError
from ..feedback import LoggingFeedback
from ..heights import HeightOptions
from ..vectors import StudyArea
from .index import DONE, EMPTY, FAILED
from .job import TileJob
from .plan import TileOwner

TILES_DIR = "tiles"
MODEL_FILE = "model.gml"


def tile_folder(output: str | Path, sheet: str) -> Path:
    return Path(output) / TILES_DIR / sheet


def peak_mb() -> float:
    """Peak resident memory of this process so far (MB)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


def run_tile(spec: dict) -> dict:
    """Build the tile ``spec["sheet"]``; the index row: status, counts, seconds, peak_mb, gml, error."""
    start = time.perf_counter()
    sheet = spec["sheet"]
    folder = tile_folder(spec["output"], sheet)
    owner = TileOwner(sheet, spec["scale"], spec["target_crs"], spec["sheet_crs"], spec["area_wkt"])
    job = TileJob(owner, spec["context"], tuple(spec["context_layers"]))
    options = ChainOptions(
        area=StudyArea.polygon(job.area(spec["target_crs"]), spec["target_crs"]),
        target_crs=spec["target_crs"], sheet_crs=spec["sheet_crs"], margin=spec["margin"],
        max_edge=spec["max_edge"], tolerance=spec["tolerance"], texture_scale=spec["texture_scale"],
        triangulator=spec["triangulator"],
        heights=HeightOptions(**spec["heights"]), outside_ortho=spec["outside_ortho"],
        schema_dir=spec["schema_dir"], schema_cache=spec["schema_cache"], metrics=False,
        tiles3d=spec["tiles3d"], tiles3d_web=spec["tiles3d_web"], encoding=spec["encoding"], tile=job)
    row = {"sheet": sheet, "buildings": 0, "triangles": 0, "gml": None, "error": None}
    try:
        report = run_city_model(ChainInputs(**spec["inputs"]), options, folder,
                                LoggingFeedback(logging.getLogger(f"wit_plugin.tiles.{sheet}")))
        status = (DONE if report.buildings else EMPTY) if report.valid else FAILED
        row.update(status=status, buildings=report.buildings, triangles=report.triangles,
                   gml=f"{TILES_DIR}/{sheet}/{MODEL_FILE}",
                   error=None if report.valid else f"{report.errors} validation error(s): see validation.html")
    except CanceledError:
        raise
    except WitError as exc:  # the tile's data: recorded, the run goes on
        row.update(status=FAILED, error=str(exc))
    except Exception as exc:  # an unexpected error: raised, so Dask runs the tile once more (the runner's
        _remove_unfinished_tile(folder)  # retries=1) and records it as failed if it happens again
        raise UnexpectedTileError(f"{type(exc).__name__}: {exc} ({traceback.format_exc(limit=-4)})") from None
    if row["status"] == FAILED:
        _remove_unfinished_tile(folder)
    row.update(seconds=round(time.perf_counter() - start, 3), peak_mb=round(peak_mb(), 1))
    return row


class UnexpectedTileError(RuntimeError):
    """A tile ended in an error that is not about its data (a bug, or a transient fault of its worker)."""


def _remove_unfinished_tile(folder: Path) -> None:
    """Nothing of a failed tile stays (a model a previous run finished is kept)."""
    if folder.is_dir() and not any(folder.glob(MODEL_FILE)):
        shutil.rmtree(folder, ignore_errors=True)
