"""The whole chain in one call, in the core: raw national data → validated, textured CityGML 3.0.

``wit:citymodel`` is a thin adapter over :func:`run_city_model`, and the tiled run
(``wit_plugin.sheetrun``) calls it once per tile on Dask workers, without QGIS, passing the tile's own
step 1 (``ChainOptions.part_layers``): the chain knows nothing of tiles. Order of the steps:

1. prepare the vectors (fast) — the study area, grown to hold the buildings that cross its edge,
   is then known exactly;
2. coverage: the DEM and the orthoimage sheets (from their sheet numbers) must cover that area —
   checked in seconds, before anything heavy, naming what is missing;
3. georeference (as VRTs pointing at the untouched pixels) and merge only the sheets the area needs;
4. terrain TIN, 5. LoD1 solids, 6. textures, 7. CityGML (and, asked for, CityJSON beside it: ``model.city.json``,
or a tile's ``model.city.jsonl`` of its run's CityJSONSeq), 8. the 3D Tiles tileset, 9. validation,
10. quality metrics (started with step 6: all but the texture images are measured beside it). The output folder
also keeps the LoD1 and TIN GeoPackages (QGIS's 3D view).

Three steps run in a second Python process, so that a second core works (threads would share the GIL): the
merge beside the terrain and the solids (which do not read the orthoimage); the metrics from the solids on,
measuring all but the texture images beside the texture step and those once it has written them; and the 3D Tiles
export, which reads the step layers rather than the CityGML, beside the CityGML and its validation. Their programs
start before step 1, whose single process leaves the second core idle: they import meanwhile and wait for their run
(``programs``).

Everything is written into a staging folder inside the output folder and moved into place at the
end, so a failed or cancelled run leaves nothing behind (and never a half-updated output folder).
"""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from shapely.geometry.base import BaseGeometry

from ..buildings import extrude
from ..buildings.extrude import ExtrudeStats
from ..buildings.heights import HeightOptions
from ..citygml import schemas
from ..citygml.validate import FileReport, validate_files, write_report_html
from ..citygml.writer import CityGMLInputs, WriteReport, write_citygml
from ..cityjson.sequence import PART_FILE
from ..cityjson.validate import validate_cityjson_files
from ..cityjson.writer import SequencePart, texture_folder_of, write_cityjson
from ..infra import step_layers
from ..infra.errors import InputError, WitError
from ..infra.feedback import SILENT, Feedback, SaidOnce
from ..infra.interpreter import core_python
from ..infra.io import jsontext
from ..infra.io.fileio import ensure_writable_dir, publish, staging_folder
from ..infra.io.layersource import LayerSource
from ..infra.io.vector_io import read_prepared
from ..infra.step_process import pass_on
from ..mosaic.georef import OK, georeference_sheets, list_tifs, write_footprint_index
from ..prepare.area import StudyArea
from ..prepare.vectors import PrepareConfig, prepare_vectors
from ..terrain import triangulators
from ..terrain.build import TerrainConfig, TileContext, covering_area, triangulate_terrain
from ..terrain.constraints import Seam
from ..terrain.mesh import TinStats
from ..texture import BEYOND_ORTHO, TextureConfig, texture_model
from ..tiles3d import TILESET_FILE
from ..tiles3d.web import require_web_profile
from .coverage import OrthoCoverage, ortho_coverage, require_dem, require_ortho, require_sheet_names
from .programs import StepPrograms, start_command

OUTSIDE_ORTHO_CHOICES = ("fail", "untextured")
DEFAULT_SCHEMA_CACHE = Path.home() / ".cache" / "wit_citymodel"
TILESET_DIR = "3dtiles"
STEP_PROCESS_MODULES = ("numpy", "shapely", "pyproj", "osgeo")  # what the steps run in another process import
MOSAIC_MARGIN = 10.0  # m of orthoimage kept around the area's box
STEPS_FILE = "steps.json"

#: (label, share of the progress bar) of each step, in the order they start; those run in another process
#: (share 0: the bar follows the steps beside them) are merge and extrude, beside terrain, metrics, beside
#: texture and the rest, and 3dtiles, beside citygml, cityjson and validate (extrude runs in the chain's process
#: when a QGIS height expression needs it, before the terrain)
STEPS = (("prepare", 3), ("coverage", 1), ("georeference", 2), ("merge", 0), ("extrude", 0), ("terrain", 22),
         ("metrics", 0), ("texture", 14), ("3dtiles", 0), ("citygml", 20), ("cityjson", 4), ("validate", 34))
CITYJSON_FILE = "model.city.json"


@dataclass
class PreparedLayers:
    """The prepared sources the later steps read (``str(LayerSource)``, as the steps take them), and the study
    area itself."""

    buildings: str | None  # None: a part of a larger run that owns no building
    study: BaseGeometry
    roads: str | None = None
    districts: str | None = None
    foreign: str | None = None  # buildings of neighbouring parts that cross into this one (holes in its terrain)
    seam: Seam | None = None  # a part's border, met alike by its neighbours

    @classmethod
    def read(cls, prepared: str, names: list[str], context: str, context_names: list[str],
             seam: Seam | None = None) -> PreparedLayers:
        """The layers ``names`` of ``prepared`` (buildings, study area, foreign buildings) and
        ``context_names`` of ``context`` (roads, dongs)."""
        def source(file: str, present: list[str], name: str) -> str | None:
            return str(LayerSource(file, name)) if name in present else None

        study = read_prepared(LayerSource(prepared, step_layers.STUDY_AREA), step_layers.STUDY_AREA).geoms[0]
        return cls(source(prepared, names, step_layers.PREPARED_BUILDINGS), study,
                   source(context, context_names, step_layers.PREPARED_ROADS),
                   source(context, context_names, step_layers.PREPARED_DISTRICTS),
                   source(prepared, names, step_layers.FOREIGN_BUILDINGS), seam)


@dataclass
class ChainInputs:
    """The raw inputs: orthoimage TIFs named by sheet number (files or folders), DEM, layers."""

    ortho: list[str]
    dem: str
    buildings: str
    roads: str | None = None
    districts: str | None = None


#: step 1 of a part of a larger run: (inputs, options, work folder, feedback) → its prepared layers
PartLayers = Callable[[ChainInputs, "ChainOptions", Path, Feedback], PreparedLayers]


@dataclass
class ChainOptions:
    """Everything else a run needs (defaults: the paper's settings and the NGII data's conventions)."""

    area: StudyArea
    target_crs: str = "EPSG:5186"
    sheet_crs: str = "EPSG:4737"  # datum of the sheet numbers' degrees
    margin: float = 50.0  # the NGII orthoimages' margin around their sheet
    max_edge: float = triangulators.MAX_EDGE
    tolerance: float = triangulators.VERTICAL_TOLERANCE
    triangulator: int | None = None  # triangulators.BACKENDS key; None: Triangle where installed, else CDT
    texture_scale: float = 1.0
    facades: str = TextureConfig.facades  # walls: generated facades, or "none"
    heights: HeightOptions = field(default_factory=HeightOptions)
    outside_ortho: str = "fail"  # or "untextured"
    schema_dir: str | None = None  # override of the shipped schemas
    schema_cache: str | None = None  # None: DEFAULT_SCHEMA_CACHE (see ``schema_cache_folder``)
    keep_work: bool = False  # keep the intermediate files as <output>/work
    metrics: bool = True
    tiles3d: bool = True  # write the 3D Tiles 1.1 tileset (<output>/3dtiles) for viewers
    tiles3d_web: bool = False  # its web profile: compressed geometry for browsers (QGIS cannot read it)
    encoding: str | None = None  # of shapefile inputs, when their declaration is wrong
    cityjson: bool = False  # write the model as CityJSON 2.0 too (model.city.json)
    cityjson_part: SequencePart | None = None  # a tile of a run: its CityJSONSeq (model.city.jsonl) instead
    #: step 1 of one part of a larger run (a tile of wit_plugin.sheetrun); None: the study area's layers
    part_layers: PartLayers | None = None


@dataclass
class ChainReport:
    """What the run wrote and measured."""

    output: str
    gml: str
    validation_report: str
    metrics: str | None
    valid: bool
    errors: int
    buildings: int
    default_heights: int
    untextured_outside: int
    triangles: int
    seconds: dict[str, float]
    wall_seconds: float = 0.0
    work: str | None = None
    lod1: str | None = None
    tin: str | None = None
    tileset: str | None = None
    cityjson: str | None = None
    files: list[str] = field(default_factory=list)  # what the run put in the output folder (names in it)

    def as_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class Beside:
    """A step running in another process: ``wait`` for its end (its result; raises its failure), ``tell`` it that
    what it waits for is written."""

    wait: Callable[[], Any]
    tell: Callable[[], None]


NOT_RUN = Beside(lambda: None, lambda: None)
"""A step beside that was not asked for."""


class _Clock:
    """Runs the steps in order with their share of the progress bar, cancel checks and timing."""

    seconds: dict[str, float]  # by step label

    def __init__(self, feedback: Feedback, programs: StepPrograms | None = None):
        self.feedback, self.seconds = SaidOnce(feedback), {}  # (a SaidOnce: steps beside label theirs)
        self.programs = programs  # the steps' programs started ahead, if any
        total = sum(share for _, share in STEPS)
        starts = [sum(share for _, share in STEPS[:k]) for k in range(len(STEPS))]
        self.spans = {label: (100.0 * a / total, 100.0 * (a + share) / total)
                      for (label, share), a in zip(STEPS, starts)}

    @contextmanager
    def step(self, label: str) -> Iterator[Feedback]:
        self.feedback.check_canceled()
        number = [name for name, _ in STEPS].index(label) + 1
        self.feedback.info(f"Step {number}/{len(STEPS)}: {label}")
        start = time.perf_counter()
        yield self.feedback.scaled(*self.spans[label])
        self.seconds[label] = round(time.perf_counter() - start, 3)

    @contextmanager
    def beside(self, label: str, command: list[str]) -> Iterator[Beside]:
        """Run ``command`` (a core module in its own Python process, so that the second core works: threads
        would share the GIL) while the block runs the next steps; the block gets its ``Beside``: wait for it,
        or tell it (a line on its standard input) that what it waits for is written. Cancel stops it; a failure
        is an ``InputError`` with the end of its messages."""
        self.feedback.check_canceled()
        number = [name for name, _ in STEPS].index(label) + 1
        self.feedback.info(f"Step {number}/{len(STEPS)}: {label} (in a second process, beside the next steps)")
        start = time.perf_counter()
        process, tell_end = self.programs.start(command) if self.programs else start_command(command)
        ended: dict[str, Any] = {}

        def read() -> None:  # drains its pipes as it writes (a full pipe would stall it) and notes when it ended
            ended["stdout"], ended["stderr"] = process.communicate()
            ended["at"] = time.perf_counter()

        reader = threading.Thread(target=read, name=f"wit-{label}", daemon=True)
        reader.start()

        def wait() -> Any:
            while reader.is_alive():
                reader.join(0.1)
                if reader.is_alive() and self.feedback.is_canceled():
                    process.kill()
                    reader.join()
                    self.feedback.check_canceled()
            self.seconds[label] = round(ended["at"] - start, 3)  # its own time, not the time we waited
            said = self.feedback.labelled(label)
            refusals: list[WitError] = []
            others: list[str] = []
            for line in ended["stderr"].splitlines():  # its records (``step_process``); Python's or a library's
                if not pass_on(line, said, refusals, progress=False) and line.strip():  # lines: warnings
                    said.warning(line)
                    others.append(line)
            if process.returncode != 0:
                why = str(refusals[-1]) if refusals else " | ".join(others[-5:] or [f"status {process.returncode}"])
                raise (type(refusals[-1]) if refusals else InputError)(f"The {label} step failed: {why}")
            return json.loads(ended["stdout"]) if ended["stdout"].strip() else None

        def tell() -> None:
            with contextlib.suppress(OSError):  # (it ended already: waiting says how)
                os.write(tell_end, b"go\n")
            os.close(tell_end)

        try:
            yield Beside(wait, tell)
        finally:
            if process.poll() is None:
                process.kill()
            reader.join()
            with contextlib.suppress(OSError):  # (told already: closed then)
                os.close(tell_end)


def schema_cache_folder(options: ChainOptions) -> str:
    """The folder a run caches downloaded CityGML schemas in (tiles of a run all get their runner's)."""
    return str(options.schema_cache or DEFAULT_SCHEMA_CACHE)


def check_inputs(inputs: ChainInputs, options: ChainOptions) -> list[str]:
    """What a run checks before it reads any data — the options' choices, the library of the 3D Tiles web
    profile, the orthoimage files' sheet numbers —; those files. The map-sheet runner checks the same before
    any tile starts."""
    if options.outside_ortho not in OUTSIDE_ORTHO_CHOICES:
        raise InputError(f"Surfaces outside the orthoimage: choose one of {', '.join(OUTSIDE_ORTHO_CHOICES)}.")
    if options.tiles3d and options.tiles3d_web:
        require_web_profile()
    tifs = list_tifs(inputs.ortho)
    require_sheet_names(tifs)
    return tifs


def check_coverage(inputs: ChainInputs, tifs: list[str], area: BaseGeometry, options: ChainOptions,
                   feedback: Feedback = SILENT) -> OrthoCoverage:
    """Whether the DEM and the orthoimage files ``tifs`` cover ``area`` (answered in seconds, before anything
    heavy): which sheets it needs; an ``InputError`` naming what is missing (see ``coverage``)."""
    require_dem(inputs.dem, area, options.target_crs, feedback)
    coverage = ortho_coverage(tifs, area, options.target_crs, options.sheet_crs, options.margin)
    require_ortho(coverage, options.outside_ortho == "untextured", feedback)
    return coverage


def run_city_model(inputs: ChainInputs, options: ChainOptions, output_dir: str | os.PathLike,
                   feedback: Feedback = SILENT) -> ChainReport:
    """Run the whole chain into ``output_dir`` (model.gml + textures, validation.html, metrics, steps.json)."""
    check_inputs(inputs, options)
    started = time.perf_counter()
    output = ensure_writable_dir(output_dir)
    with staging_folder(output, ".wit-run-") as staging, \
            StepPrograms(_ahead_modules(options), lambda: _step_python(options)) as programs:
        clock = _Clock(feedback, programs)
        report = _run(inputs, options, output, staging, clock, programs)
        report.files = publish(staging, output) + [STEPS_FILE]
    report.seconds = {label: clock.seconds[label] for label, _ in STEPS if label in clock.seconds}
    report.wall_seconds = round(time.perf_counter() - started, 3)
    (output / STEPS_FILE).write_text(jsontext.dumps({"seconds": report.seconds, "wall": report.wall_seconds}, indent=1),
                                       encoding="utf-8")
    feedback.info("Seconds per step: " + ", ".join(f"{k} {v:.1f}" for k, v in report.seconds.items())
                  + f"; {report.wall_seconds:.1f} s in all (merge, 3D Tiles and metrics beside the next steps)")
    feedback.progress(100.0)
    return report


def _run(inputs: ChainInputs, options: ChainOptions, output: Path, staging: Path, clock: _Clock,
         programs: StepPrograms) -> ChainReport:
    work = staging / "work"
    work.mkdir()
    tifs = list_tifs(inputs.ortho)  # (their names checked by check_inputs)

    with clock.step("prepare") as fb:
        layers = _prepare(inputs, options, work, fb)
        area = covering_area(layers.study, read_prepared(layers.buildings, step_layers.PREPARED_BUILDINGS).geoms) \
            if layers.buildings else layers.study

    with clock.step("coverage") as fb:
        coverage = check_coverage(inputs, tifs, area, options, fb)

    with clock.step("georeference") as fb:
        sheets = georeference_sheets([s.path for s in coverage.used], work / "georeferenced", options.target_crs,
                                     options.sheet_crs, options.margin, fmt="VRT", feedback=fb)
        write_footprint_index(sheets, work / "sheets.gpkg", options.target_crs)
        rasters = [r.output for r in sheets if r.status == OK and r.output is not None]  # (OK: it has one)
        if not rasters:
            raise InputError("No orthoimage sheet could be read: " + "; ".join(
                f"{Path(r.source).name}: {r.reason}" for r in sheets))

    mosaic = str(work / "ortho.tif")
    xmin, ymin, xmax, ymax = area.bounds  # the sheets' pixels the area needs (tone and seams: all of them)
    extent = (xmin - MOSAIC_MARGIN, ymin - MOSAIC_MARGIN, xmax + MOSAIC_MARGIN, ymax + MOSAIC_MARGIN)
    python = programs.interpreter()
    merge = [python, "-m", "wit_plugin.mosaic", mosaic, *rasters, "--mode", "feather", "--gain",
             "--extent", *map(repr, extent), "--compression", "fast"]  # (read by the next steps only)
    with clock.beside("merge", merge) as merging:  # beside the terrain and the solids: they do not read it
        tin, tin_stats, lod1, lod1_stats = _terrain_and_solids(inputs, options, layers, work, python, clock)
        merging.wait()

    textures = str(work / "textures")
    metrics_csv = staging / "metrics.csv" if options.metrics and lod1 else None
    with _metrics_beside(python, metrics_csv, clock, lod1, layers, textures, mosaic, work) as measuring:
        with clock.step("texture") as fb:
            untextured = options.outside_ortho == "untextured" and coverage.uncovered is not None
            texture_report = texture_model(mosaic, lod1, tin, textures,
                                           TextureConfig(scale=options.texture_scale, facades=options.facades), fb,
                                           coverage=coverage.footprint if untextured else None)
        measuring.tell()  # the texture folder is written: the metrics measure its images now
        gml, written, cityjson, validation = _model_files(python, options, clock, layers, lod1, tin, textures,
                                                          output, staging)
        measuring.wait()
    tileset = str(staging / TILESET_DIR / TILESET_FILE) if options.tiles3d else None

    for layer in filter(None, (lod1, tin)):  # the model's GIS layers, for QGIS's 3D view
        os.replace(layer, staging / Path(layer).name)
    if not options.keep_work:
        shutil.rmtree(work)

    errors = sum(i.severity == "error" for r in validation for i in r.issues)
    return ChainReport(
        output=str(output), gml=str(output / "model.gml"), validation_report=str(output / "validation.html"),
        metrics=str(output / "metrics.csv") if metrics_csv else None, valid=all(r.valid for r in validation),
        errors=errors, buildings=written.buildings,
        default_heights=lod1_stats.height_sources.get("default", 0) if lod1_stats else 0,
        untextured_outside=texture_report.untextured.get(BEYOND_ORTHO, 0), triangles=tin_stats.triangles,
        seconds={}, work=str(output / "work") if options.keep_work else None,
        lod1=str(output / Path(lod1).name) if lod1 else None, tin=str(output / Path(tin).name),
        tileset=str(output / TILESET_DIR / Path(tileset).name) if tileset else None,
        cityjson=str(output / cityjson.name) if cityjson else None)


def _model_files(python: str, options: ChainOptions, clock: _Clock, layers: PreparedLayers, lod1: str | None,
                 tin: str, textures: str, output: Path, staging: Path
                 ) -> tuple[Path, WriteReport, Path | None, list[FileReport]]:
    """Steps 7 to 9: the CityGML (and CityJSON), the 3D Tiles export beside them, and their validation."""
    with _tiles3d_beside(python, options, clock, lod1, tin, textures, staging) as exporting:
        with clock.step("citygml") as fb:
            gml = staging / "model.gml"
            written_inputs = CityGMLInputs(lod1=lod1, tin=tin, textures=textures,
                                           roads=layers.roads and LayerSource.parse(layers.roads).path,
                                           districts=layers.districts and LayerSource.parse(layers.districts).path)
            written = write_citygml(written_inputs, str(gml), srs_name=options.target_crs, feedback=fb)
        cityjson = _write_cityjson(written_inputs, gml, options, clock) if options.cityjson else None
        validation = _validate(gml, cityjson, options, output, staging, clock)
        exporting.wait()
    return gml, written, cityjson, validation


def _terrain_and_solids(inputs: ChainInputs, options: ChainOptions, layers: PreparedLayers, work: Path,
                        python: str, clock: _Clock) -> tuple[str, TinStats, str | None, ExtrudeStats | None]:
    """Steps 4 and 5: the LoD1 solids (in a second process, beside the terrain, which they do not read; here,
    first, when a QGIS height expression needs this process) and the TIN (a tile that owns no building: terrain
    and roads only)."""
    buildings = layers.buildings
    lod1 = str(work / "lod1.gpkg") if buildings else None
    lod1_stats = None
    beside = buildings is not None and options.heights.expression is None
    if buildings and lod1 and not beside:
        with clock.step("extrude") as fb:
            lod1_stats = extrude.extrude_buildings(buildings, inputs.dem, lod1, options.heights,
                                                   spatial_index=options.keep_work, feedback=fb)
    with _extrude_beside(python, options, clock, buildings, inputs.dem, lod1) if beside \
            else nullcontext(NOT_RUN) as extruding:
        with clock.step("terrain") as fb:
            tin = str(work / "tin.gpkg")
            config = TerrainConfig(options.max_edge, options.tolerance, spatial_index=options.keep_work,
                                   triangulator=options.triangulator)
            tile_context = TileContext(layers.foreign, layers.seam) if layers.seam is not None else None
            tin_stats = triangulate_terrain(inputs.dem, layers.buildings, layers.roads, tin, layers.study, config,
                                            fb, tile_context)
        solids = extruding.wait()
    return tin, tin_stats, lod1, ExtrudeStats(**solids) if solids is not None else lod1_stats


def _extrude_beside(python: str, options: ChainOptions, clock: _Clock, buildings: str | None, dem: str,
                    lod1: str | None) -> AbstractContextManager[Beside]:
    heights = options.heights
    command = [python, "-m", "wit_plugin.buildings", buildings or "", dem, lod1 or "",
               "--storey-height", repr(heights.storey_height), "--default-height", repr(heights.default_height)]
    for flag, value in (("--height-field", heights.height_field), ("--expression-column", heights.expression_column),
                        ("--expression-text", heights.expression_text)):
        if value:
            command += [flag, value]
    return clock.beside("extrude", command + (["--spatial-index"] if options.keep_work else []))


def _ahead_modules(options: ChainOptions) -> dict[str, tuple[str, ...]]:
    """The steps beside whose programs start ahead (``programs``), each with the other modules its step needs."""
    modules: dict[str, tuple[str, ...]] = {"wit_plugin.mosaic": ()}
    if options.heights.expression is None:
        modules["wit_plugin.buildings"] = ()
    if options.metrics:
        modules["wit_plugin.metrics"] = ()
    if options.tiles3d:
        modules["wit_plugin.tiles3d"] = ("meshoptimizer",) if options.tiles3d_web else ()
    return modules


def _step_python(options: ChainOptions) -> str:
    """The Python that runs the steps the chain starts in another process when their programs started ahead cannot:
    one that imports all of them, found (and checked) once."""
    modules: tuple[str, ...] = STEP_PROCESS_MODULES + ("wit_plugin.mosaic", "wit_plugin.buildings")
    modules += ("pygltflib", "wit_plugin.tiles3d") if options.tiles3d else ()
    modules += ("meshoptimizer",) if options.tiles3d and options.tiles3d_web else ()
    return core_python(None, modules, "wit_plugin.metrics" if options.metrics else "wit_plugin.mosaic")


def _tiles3d_beside(python: str, options: ChainOptions, clock: _Clock, lod1: str | None, tin: str, textures: str,
                    staging: Path) -> AbstractContextManager[Beside]:
    """Step 8, asked for: the 3D Tiles export in a second process, from the step layers (not the CityGML),
    so it runs beside the CityGML, its validation and the metrics; the block gets the function that waits."""
    if not options.tiles3d:
        return nullcontext(NOT_RUN)
    return clock.beside("3dtiles", [python, "-m", "wit_plugin.tiles3d",
                                    lod1 or "", tin, textures, str(staging / TILESET_DIR), "--crs", options.target_crs]
                        + (["--web"] if options.tiles3d_web else []))


def _metrics_beside(python: str, metrics_csv: Path | None, clock: _Clock, lod1: str | None, layers: PreparedLayers,
                    textures: str, mosaic: str, work: Path) -> AbstractContextManager[Beside]:
    """Step 10, asked for: the quality metrics in a second process, from the step layers, the mosaic and the
    sheets' footprints (``metrics.csv`` and ``metrics.html``): all but the texture images beside the texture step,
    those once it is told the texture folder is written."""
    if metrics_csv is None:
        return nullcontext(NOT_RUN)
    return clock.beside("metrics", [
        python, "-m", "wit_plugin.metrics", str(metrics_csv),
        "--model", lod1 or "", "--buildings", layers.buildings or "", "--textures", textures, "--ortho", mosaic,
        "--mosaic", mosaic, "--footprints", str(work / "sheets.gpkg"), "--html", str(metrics_csv.with_suffix(".html")),
        "--images-when-told"])


def _validate(gml: Path, cityjson: Path | None, options: ChainOptions, output: Path, staging: Path,
              clock: _Clock) -> list[FileReport]:
    """Step 9: the model (and its CityJSON) validated offline, ``validation.html`` written; the reports."""
    with clock.step("validate") as fb:
        schema_dir, source = schemas.find_schema_dir(options.schema_dir,
                                                     schema_cache_folder(options),
                                                     allow_download=True, feedback=fb)
        fb.info(f"Schemas: {source} ({schema_dir})")
        validation = validate_files([str(gml)], schema_dir, feedback=fb)
        if cityjson:  # the same checks; a tile's image paths start from its run's folder
            part = options.cityjson_part
            validation += validate_cityjson_files([str(cityjson)], fb, image_folder=lambda _: staging,
                                                  strip_prefix=f"{part.folder}/" if part else "")
        for report in validation:  # name the file where it will be, not where it was validated
            report.file = str(output / Path(report.file).name)
        write_report_html(validation, str(staging / "validation.html"))
    return validation


def _write_cityjson(inputs: CityGMLInputs, gml: Path, options: ChainOptions, clock: _Clock) -> Path:
    """Step 7b: the same model as CityJSON beside the CityGML, referring to the CityGML's copy of the images."""
    with clock.step("cityjson") as fb:
        part = options.cityjson_part
        path = gml.parent / (PART_FILE if part else CITYJSON_FILE)
        images = texture_folder_of(gml)
        write_cityjson(inputs, str(path), options.target_crs, fb, images_in=str(images) if images.is_dir() else None,
                       part=part)
    return path


def _prepare(inputs: ChainInputs, options: ChainOptions, work: Path, feedback: Feedback) -> PreparedLayers:
    """Step 1: the study area's layers, or those of a part of a larger run (``options.part_layers``)."""
    if options.part_layers is not None:
        return options.part_layers(inputs, options, work, feedback)
    prepared = str(work / "prepared.gpkg")
    config = PrepareConfig(target_crs=options.target_crs, encoding=options.encoding,
                           stats_csv=str(work / "prepared_stats.csv"))
    names = prepare_vectors(inputs.buildings, inputs.roads, inputs.districts, options.area, prepared, config,
                            feedback).layers
    if step_layers.PREPARED_BUILDINGS not in names:
        raise InputError("No building of the building layer lies in the study area.")
    return PreparedLayers.read(prepared, names, prepared, names)
