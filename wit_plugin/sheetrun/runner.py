"""Map the tiles of a run to Dask workers: an embedded ``LocalCluster``, or a running scheduler.

Workers are plain Python processes (``dask worker``) that import the core as ``wit_plugin``; they are started with
an explicit interpreter (``worker_python``), never with ``sys.executable`` blindly, because inside
QGIS on Windows and macOS that is QGIS itself. Progress advances per finished tile
(``as_completed``); Cancel stops submitting and cancels the running tiles; a tile that fails is
recorded in the index with its message and the others go on; a worker killed mid-run costs only
its tile's time (Dask runs the tile again elsewhere). A run into an existing output is an update
(``update``): the tiles whose fingerprint (``fingerprint``) is unchanged are kept as they are, the
others built again, tiles that left the area removed, and the levels above refreshed where a child
changed. The scheduler needs only dask and distributed (``submit_tile``): a stock ``dask scheduler``
serves a run, as on managed clusters.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import shapely
from shapely.geometry.base import BaseGeometry

from ..chain import ChainInputs, ChainOptions, check_coverage, check_inputs, schema_cache_folder
from ..chain.coverage import OrthoCoverage
from ..chain.fingerprint import Fingerprint
from ..chain.rerun import study_polygon
from ..cityjson.sequence import PART_FILE, remove_run_index, run_translate, write_run_index
from ..infra.deps import require
from ..infra.errors import CanceledError, InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.interpreter import core_env, core_python
from ..infra.io.fileio import ensure_writable_dir, publish, staging_folder
from ..prepare.area import StudyArea
from ..terrain import triangulators
from ..tiles3d.combine import remove_run_tileset, tile_areas, write_run_tileset
from .fingerprint import RunInputs
from .index import DONE, EMPTY, FAILED, INDEX_FILE, PENDING, read_index, write_index
from .layers import area_of_layer, prepare_context
from .plan import Tile, plan_tiles
from .update import UpdatePlan, commit_tile, plan_update, remove_tiles
from .worker import STAGING_DIR, TASK, TILES_DIR

CONTEXT_FILE = "context.gpkg"
POLL_SECONDS = 0.2


@dataclass
class TilesReport:
    """What a tiled run did: one index row per tile, and what it did with the tiles an earlier run left."""

    output: str
    index: str
    rows: list[dict] = field(default_factory=list)
    update: UpdatePlan = field(default_factory=UpdatePlan)  # kept, built again (why), added, removed
    seconds: float = 0.0
    tileset: str | None = None  # one 3D Tiles tileset over the tiles' tilesets
    cityjson: str | None = None  # the run's CityJSONSeq header (index.city.jsonl)

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.rows)

    @property
    def resumed(self) -> int:
        """Tiles an earlier run finished that this one kept (unchanged)."""
        return len(self.update.kept)

    def reasons(self) -> dict[str, int]:
        """How many tiles were built again for each reason (a tile may have several)."""
        counts: dict[str, int] = {}
        for reason in self.update.rebuilt.values():
            for part in reason.split(", "):
                counts[part] = counts.get(part, 0) + 1
        return counts

    @property
    def buildings(self) -> int:
        return sum(r.get("buildings") or 0 for r in self.rows)


WORKER_MODULES = ("distributed", "numpy", "shapely", "pyproj", "lxml", "osgeo")


def worker_python(configured: str | None = None, triangulator: str = "pythoncdt") -> str:
    """The interpreter for Dask worker processes (``wit_plugin.infra.interpreter.core_python`` with Dask and the
    triangulation library ``triangulator``)."""
    return core_python(configured, (*WORKER_MODULES, triangulator), "wit_plugin.sheetrun.worker")


def area_polygon(area: StudyArea | None, inputs: ChainInputs, target_crs: str,
                 encoding: str | None = None) -> BaseGeometry:
    """The run's area in ``target_crs``; None: everything the buildings layer covers."""
    if area is None:
        return area_of_layer(inputs.buildings, target_crs)
    return study_polygon(area, inputs.districts, target_crs, encoding)


#: ChainOptions a tile sets itself (its area, its prepared layers, no metrics, no work kept) or sends apart
TILE_OWN_OPTIONS = frozenset({"area", "heights", "part_layers", "metrics", "keep_work", "cityjson_part"})


def _spec(inputs: ChainInputs, options: ChainOptions, output: Path, sheet: str, scale: int, area: BaseGeometry,
          context: tuple[str | None, list[str]], fingerprint: Fingerprint, reason: str) -> dict:
    """Everything one tile needs, as plain values (with the fingerprint it records and why it is built)."""
    heights = options.heights
    if heights.expression is not None:
        raise InputError("A height expression cannot travel to Dask workers: evaluate it into a column of a copy "
                         "of the buildings first and give HeightOptions.expression_column (wit:citymodeltiles does).")
    plain = {f.name: getattr(options, f.name) for f in dataclasses.fields(options) if f.name not in TILE_OWN_OPTIONS}
    plain.update(triangulator=triangulators.backend(options.triangulator).key,  # one for all tiles: the seams match
                 schema_cache=schema_cache_folder(options))
    return {
        "sheet": sheet, "scale": scale, "output": str(output), "area_wkt": shapely.to_wkt(area), "options": plain,
        "heights": dataclasses.asdict(heights),  # plain values: the expression is None (above)
        "cityjson_translate": list(run_translate(area)) if options.cityjson else None,  # the run's one transform
        "context": context[0], "context_layers": context[1],
        "inputs": {"ortho": inputs.ortho, "dem": inputs.dem, "buildings": inputs.buildings, "roads": None,
                   "districts": None},
        "fingerprint": fingerprint.as_dict(), "reason": reason,
    }


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int, python: str) -> Iterator:
    """A client of the scheduler at ``scheduler``; else of an embedded one (a LocalCluster without workers
    of its own) served by ``workers`` ``dask worker`` processes of ``python``, stopped on exit."""
    require(["distributed"])
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout=30)
        except OSError as exc:
            raise InputError(f"Cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
        try:
            yield client
        finally:
            client.close()
        return
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        logs = [Path(tempfile.mkdtemp(prefix="wit-dask-")) / "worker.log" for _ in range(workers)]
        processes = [start_worker(python, cluster.scheduler_address, log) for log in logs]
        try:
            _wait_for(client, processes, logs)
            yield client
        finally:
            stop_workers(processes)
            for log in logs:
                shutil.rmtree(log.parent, ignore_errors=True)


def start_worker(python: str, address: str, log: Path) -> subprocess.Popen:
    """One ``dask worker`` (with its nanny, which restarts it if it dies) of ``python``, importing the core
    from this checkout, logging to ``log``; in its own process group so that stopping it stops its children."""
    command = [python, "-m", "distributed.cli.dask_worker", address, "--nworkers", "1", "--nthreads", "1",
               "--memory-limit", "0", "--no-dashboard", "--name", f"wit-{os.getpid()}-{time.time_ns()}"]
    try:
        with open(log, "ab") as sink:
            return subprocess.Popen(command, env=core_env(), stdout=sink,  # nosec B603  # a Dask worker, no shell
                                    stderr=subprocess.STDOUT, start_new_session=True)
    except OSError as exc:
        raise InputError(f"Cannot start a Dask worker with {python}: {exc}") from exc


def _wait_for(client, processes: list[subprocess.Popen], logs: list[Path], timeout: float = 120.0) -> None:
    """Until every worker has joined; a worker that exits first is an error with the end of its log."""
    deadline = time.monotonic() + timeout
    while len(client.scheduler_info(n_workers=-1)["workers"]) < len(processes):
        for process, log in zip(processes, logs):
            if process.poll() is not None:
                tail = log.read_text(errors="replace").strip().splitlines()[-5:]
                raise InputError(f"A Dask worker stopped at start (exit {process.returncode}): " + " | ".join(tail))
        if time.monotonic() > deadline:
            raise InputError(f"The Dask workers did not start within {timeout:.0f} s; see {logs[0].parent}.")
        time.sleep(POLL_SECONDS)


def stop_workers(processes: list[subprocess.Popen], grace: float = 10.0) -> None:
    """Stop worker processes and their children: SIGTERM to the group, then SIGKILL after ``grace`` s."""
    for process in processes:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGTERM)
    deadline = time.monotonic() + grace
    for process in processes:
        try:
            process.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def run_tiles(inputs: ChainInputs, options: ChainOptions, output_dir: str | os.PathLike, area: StudyArea | None,
              scale: int = 5000, scheduler: str | None = None, workers: int | None = None,
              python: str | None = None, feedback: Feedback = SILENT, rebuild: bool = False) -> TilesReport:
    """Build every tile of ``area`` (None: all the buildings) into ``output_dir``, or update the tiles an earlier
    run left there (``rebuild``: build them all again); see the module docstring."""
    start = time.perf_counter()
    tifs = check_inputs(inputs, options)
    output = ensure_writable_dir(output_dir)
    polygon = area_polygon(area, inputs, options.target_crs, options.encoding)
    coverage = check_coverage(inputs, tifs, polygon, options, feedback)  # in seconds, before any worker starts
    tiles = plan_tiles(polygon, options.target_crs, scale, options.sheet_crs)
    feedback.info(f"{len(tiles)} tile(s) of 1:{scale:,} over {polygon.area / 1e6:.2f} km².")
    run, fingerprints, plan, context = _compare(inputs, options, output, tiles, scale, polygon, coverage, rebuild,
                                                feedback)
    write_index(output, tiles, options.target_crs, plan.rows)
    report = TilesReport(str(output), str(output / INDEX_FILE), update=plan)
    _log_plan(report, feedback)
    rows = dict(plan.rows)
    if plan.build:
        specs = {sheet: _spec(inputs, options, output, sheet, scale, polygon,
                              (str(output / CONTEXT_FILE) if context else None, context), fingerprints[sheet],
                              reason) for sheet, reason in plan.build.items()}
        backend = triangulators.backend(options.triangulator)
        triangulators.announce(backend, feedback)
        python = worker_python(python, backend.module)
        workers = workers or os.cpu_count() or 1
        feedback.info(f"Dask: {'scheduler ' + scheduler if scheduler else f'LocalCluster of {workers} worker(s)'}"
                      f"{'' if scheduler else ', Python ' + python}.")
        completed = False
        try:
            with dask_client(scheduler, workers, python) as client:
                rows.update(_map(client, specs, output, feedback))
            completed = True
        finally:  # once no tile of this run can be running (every tile finished, or our own workers
            if completed or not scheduler:  # stopped): what a killed or cancelled attempt began is removed
                _remove_unfinished(output)
    else:
        _remove_unfinished(output)  # (of an earlier run: none of its tiles is waited for)
    report.rows = [rows.get(t.sheet, {"sheet": t.sheet, "status": PENDING}) for t in tiles]
    failed = [r for r in report.rows if r["status"] == FAILED]
    for row in failed:
        feedback.warning(f"Tile {row['sheet']} failed: {row['error']}")
    if tiles and report.count(DONE) == 0:
        reasons = "; ".join(f"{r['sheet']}: {r.get('error')}" for r in report.rows[:5])
        raise InputError(f"No tile could be built ({len(failed)} failed, {report.count(EMPTY)} empty): {reasons}")
    if options.cityjson:
        report.cityjson = write_run_index(output, [(r["sheet"], f"{TILES_DIR}/{r['sheet']}/{PART_FILE}")
                                                   for r in report.rows if r["status"] in (DONE, EMPTY)],
                                          options.target_crs, run_translate(polygon))
        feedback.info(f"CityJSONSeq: {report.cityjson} (the run's header line; the tiles' features follow it)")
    else:
        remove_run_index(output)
    if options.tiles3d:
        modelled = [r for r in report.rows if r["status"] in (DONE, EMPTY)]
        feedback.info("3D Tiles: the groups above the tiles (coarse terrain and largest buildings).")
        written = write_run_tileset(output, {r["sheet"]: Path(r["gml"]).parent.as_posix() for r in modelled},
                                    tile_areas({t.sheet: t.polygon for t in tiles}, polygon), inputs.dem, tifs,
                                    options.target_crs, options.sheet_crs, options.margin, feedback,
                                    web=options.tiles3d_web, fingerprints={r["sheet"]: r["fingerprint"]
                                                                           for r in modelled},
                                    inputs_digest=run.group, force=rebuild)
        report.tileset = written.path
        feedback.info(f"3D Tiles: {written.groups} group(s) on {written.levels} level(s) over {written.tiles} tiles, "
                      f"{written.buildings} buildings in the groups; the run's tileset.json {written.root_bytes:,} "
                      f"bytes, the largest tileset file {written.largest_file_bytes:,} bytes.")
        if written.tiles < len(modelled):
            feedback.warning(f"{len(modelled) - written.tiles} tile(s) have no 3D Tiles "
                             f"and are not in {report.tileset}.")
        if written.without_terrain:
            feedback.warning(f"{written.without_terrain} group(s) of tiles have no coarse terrain (the DEM or the "
                             "orthoimage does not cover them): from afar they show their buildings only.")
    else:
        remove_run_tileset(output)  # an earlier run's: it would refer to tilesets the tiles no longer have
    remove_tiles(output, plan.removed)  # last: the run's tileset no longer refers to them
    with contextlib.suppress(OSError):  # (unless an external cluster's cancelled tiles still write there)
        (output / STAGING_DIR).rmdir()
    report.seconds = round(time.perf_counter() - start, 3)
    feedback.info(f"Tiles: {report.count(DONE)} done, {len(failed)} failed, {report.count(EMPTY)} empty, "
                  f"{report.buildings} buildings, {report.seconds:.1f} s."
                  + (f" 3D Tiles: {report.tileset}" if report.tileset else ""))
    return report


def _compare(inputs: ChainInputs, options: ChainOptions, output: Path, tiles: list[Tile], scale: int,
             polygon: BaseGeometry, coverage: OrthoCoverage, rebuild: bool, feedback: Feedback
             ) -> tuple[RunInputs, dict[str, Fingerprint], UpdatePlan, list[str]]:
    """Prepare the run's roads and dongs, take every tile's fingerprint and compare it with the tile's record:
    (the run's inputs, the fingerprints, the plan, the context layers). The prepared context replaces the
    output's only when a tile is to be built (the kept ones do not read it)."""
    staging = output / STAGING_DIR
    staging.mkdir(exist_ok=True)
    with staging_folder(staging, "context-") as scratch:
        context = prepare_context(inputs.roads, inputs.districts, polygon, options.target_crs,
                                  str(scratch / CONTEXT_FILE), options.encoding, feedback.scaled(0, 2))
        started = time.perf_counter()
        run = RunInputs(inputs, options, scale, polygon, coverage, str(scratch / CONTEXT_FILE) if context else None,
                        context)
        fingerprints = {tile.sheet: run.tile(tile) for tile in tiles}
        feedback.info(f"Fingerprints of the {len(tiles)} tile(s): {time.perf_counter() - started:.1f} s.")
        plan = plan_update(output, tiles, fingerprints, read_index(output), rebuild)
        if plan.build:
            publish(scratch, output)
    return run, fingerprints, plan, context


def _log_plan(report: TilesReport, feedback: Feedback) -> None:
    """What the run does with the tiles, and why it builds some again."""
    plan = report.update
    reasons = ", ".join(f"{name}: {count}" for name, count in sorted(report.reasons().items()))
    feedback.info(f"Update: {len(plan.kept)} tile(s) kept as they were, {len(plan.rebuilt)} to build again"
                  + (f" ({reasons})" if reasons else "") + f", {len(plan.added)} new, {len(plan.removed)} removed "
                  "(left the area).")
    for sheet, reason in plan.rebuilt.items():
        feedback.info(f"Tile {sheet} is built again: {reason}.")


def _remove_unfinished(output: Path) -> None:
    """The folders of tiles that did not finish (built by a killed or cancelled attempt, never moved into place)."""
    for staging in (output / STAGING_DIR).glob("new-*"):
        shutil.rmtree(staging, ignore_errors=True)


def submit_tile(client, sheet: str, spec: dict):
    """Submit one tile so that the scheduler needs nothing of the core: the task graph holds Dask's own
    functions (``import_term``, ``apply``), the import path ``TASK`` and the plain ``spec``; only the
    worker that runs it imports the core. No ``retries``: Dask runs a tile again only when its worker
    is lost (up to the scheduler's ``allowed-failures``), never after an error in the tile itself."""
    from dask.utils import apply
    from distributed.utils import import_term

    stamp = time.time_ns()
    task = client.submit(import_term, TASK, key=f"wit-task-{sheet}-{stamp}", pure=False)
    return client.submit(apply, task, (spec,), key=f"wit-tile-{sheet}-{stamp}", pure=False)


def lost_row(sheet: str, exc: BaseException) -> dict:
    """The index row of a tile that returned no row: its worker died too often (``KilledWorker``), or it
    could not start (a worker without the core)."""
    from distributed import KilledWorker

    if isinstance(exc, KilledWorker):
        error = (f"its worker process died each time it ran the tile ({exc}): killed, out of memory or a crash in "
                 "native code; see the Dask worker logs")
    elif isinstance(exc, ImportError):
        error = (f"a Dask worker cannot import the core ({exc}): install it on every worker (python -m pip install "
                 ". in a checkout of the plugin, or PYTHONPATH to it)")
    else:
        error = f"{type(exc).__name__}: {exc}"
    return {"sheet": sheet, "status": FAILED, "buildings": 0, "triangles": 0, "gml": None, "error": error}


def _map(client, specs: dict[str, dict], output: Path, feedback: Feedback) -> dict[str, dict]:
    """Submit every tile, record each as it finishes; cancel everything on Cancel."""
    from distributed import as_completed

    futures = {submit_tile(client, sheet, spec): sheet for sheet, spec in specs.items()}
    total, done = len(futures), {}
    finished = as_completed(list(futures), loop=client.loop)  # not the default client's, which may be another
    try:
        while not finished.is_empty():
            if feedback.is_canceled():
                raise CanceledError("Cancelled by the user.")
            batch = finished.next_batch(block=False)
            if not batch:
                time.sleep(POLL_SECONDS)
                continue
            for future in batch:
                sheet = futures.pop(future)
                try:
                    row = future.result()
                except Exception as exc:  # noqa: BLE001 — the task never raises: its worker was lost
                    row = {**lost_row(sheet, exc), "fingerprint": specs[sheet]["fingerprint"]["fingerprint"],
                           "reason": specs[sheet]["reason"]}
                future.release()  # recorded: were it still wanted, Dask would build the tile again (writing into
                # it after the run) if the worker holding this row died later
                row = commit_tile(output, sheet, row)
                done[sheet] = row
                feedback.info(f"Tile {sheet}: {row['status']}, {row.get('buildings') or 0} buildings, "
                              f"{row.get('seconds') or 0:.1f} s, peak {row.get('peak_mb') or 0:.0f} MB"
                              + (f" — {row['error']}" if row.get("error") else ""))
                feedback.progress(2 + 98 * len(done) / total)
    except BaseException:
        client.cancel(list(futures), force=True)
        raise
    return done
