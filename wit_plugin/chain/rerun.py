"""The chain run again into its own output: rebuilt when what made it changed, else kept as it is (``wit:citymodel``).

The output folder records its fingerprint (``build.json``, see ``fingerprint``) with the report of the build
and the names of the files it wrote. A rerun with the same fingerprint and those files in place does no work
and reports the recorded result; otherwise the record goes first, the chain runs (its results replace the old
ones), files of the old build that the new one did not write are removed, and the new record comes last: a
folder without a record is never taken as current, so an interrupted update is rebuilt, not trusted.
"""
from __future__ import annotations

import os
import shutil
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.digests import digest
from ..infra.io.fileio import ensure_writable_dir
from ..infra.io.vector_io import read_layer
from ..infra.polygons import repair_polygons, transform
from ..mosaic.georef import list_tifs
from ..prepare.area import StudyArea
from .apart import ChainProgram, runs_apart
from .citymodel import ChainInputs, ChainOptions, ChainReport, run_city_model
from .coverage import ortho_coverage
from .fingerprint import (
    BUILD_FILE,
    SLACK,
    DemDigests,
    Fingerprint,
    LayerDigests,
    OrthoDigests,
    chain_settings,
    grown,
    read_record,
    union_bounds,
    write_record,
)

FORCED = "forced"
NO_RECORD = "no finished build recorded"
FILES_MISSING = "files missing"
#: the report's fields that are paths in the output folder (recorded relative to it)
REPORT_PATHS = ("output", "gml", "validation_report", "metrics", "work", "lod1", "tin", "tileset")


@dataclass
class UpdateReport:
    """What a rerun did: the report of the build now in the folder, whether this run made it, and why."""

    report: ChainReport
    rebuilt: bool
    reason: str  # why it was built ("" when it was kept)


def study_polygon(area: StudyArea, districts: str | None, target_crs: str, encoding: str | None = None
                  ) -> BaseGeometry:
    """The study area in ``target_crs`` (a legal dong is looked up in the ``districts`` layer)."""
    target = pyproj.CRS.from_user_input(target_crs)
    if area.kind != "district":
        return area.geometry(target)
    if not districts:
        raise InputError("A district code needs the district (legal-dong, TL_SCCO_EMD) layer as input.")
    layer = read_layer(districts, encoding=encoding)
    layer.geoms = repair_polygons(transform(layer.geoms, layer.crs, target)).geoms
    return area.geometry(target, layer)


def rebuild_reason(fingerprint: Fingerprint, record: dict | None, folder: Path, force: bool = False) -> str:
    """Why ``folder`` (holding ``record``) must be built again for ``fingerprint``; "" when it need not."""
    if force:
        return FORCED
    if record is None:
        return NO_RECORD
    changed = fingerprint.changes(record)
    if changed:
        return ", ".join(changed)
    return FILES_MISSING if any(not (folder / name).exists() for name in record.get("files", [])) else ""


def city_model_fingerprint(inputs: ChainInputs, options: ChainOptions) -> Fingerprint:
    """The settings and the inputs as ``run_city_model`` reads them: the features in the study area's box
    (all the legal dongs when the area is one of them), the DEM cells under it and under the buildings that
    cross its edge, the orthoimage sheets there."""
    target = options.target_crs
    polygon = study_polygon(options.area, inputs.districts, target, options.encoding)
    box = polygon.bounds
    buildings = LayerDigests.read(inputs.buildings, options.encoding, box, target)
    read = buildings.select(box, target)
    window = union_bounds(grown(box, SLACK), buildings.target_bounds(read, target))
    parts = {"area": digest(options.area.kind, shapely.to_wkb(shapely.normalize(polygon))),
             "buildings": buildings.digest(read)}
    for name, path, whole in (("roads", inputs.roads, False),
                              ("districts", inputs.districts, options.area.kind == "district")):
        if path:
            layer = LayerDigests.read(path, options.encoding, None if whole else box, target)
            parts[name] = layer.digest(layer.select(None if whole else box, target))
    parts["dem"] = DemDigests(inputs.dem, target).digest(window)
    coverage = ortho_coverage(list_tifs(inputs.ortho), shapely.box(*window), target, options.sheet_crs,
                              options.margin)
    parts["ortho"] = OrthoDigests(coverage).digest(window)
    return Fingerprint(chain_settings(options), parts)


def update_city_model(inputs: ChainInputs, options: ChainOptions, output_dir: str | os.PathLike,
                      rebuild: bool = False, feedback: Feedback = SILENT, apart: bool = False) -> UpdateReport:
    """``run_city_model`` into ``output_dir`` unless the build recorded there has the same fingerprint and its
    files are in place (``rebuild``: build anyway); see the module docstring. ``apart``: run it in a Python
    program of its own where it can (``chain.apart``: QGIS's embedded Python is slower)."""
    output = ensure_writable_dir(output_dir)
    with ChainProgram() if apart and runs_apart(options) else nullcontext() as program:  # (its start-up meanwhile)
        fingerprint = city_model_fingerprint(inputs, options)
        record = read_record(output)
        reason = rebuild_reason(fingerprint, record, output, rebuild)
        if not reason and record is not None:  # (no reason: a finished build is recorded)
            feedback.info(f"Nothing changed since the last build (fingerprint {fingerprint.digest}): {output} is "
                          "kept as it is.")
            feedback.progress(100.0)
            return UpdateReport(_report_from(record["report"], output), False, "")
        feedback.info(f"Building (fingerprint {fingerprint.digest}): {reason}.")
        (output / BUILD_FILE).unlink(missing_ok=True)  # from here until the new record, the folder is not current
        report = (program.run if program else run_city_model)(inputs, options, output, feedback)
    for name in set((record or {}).get("files", [])) - set(report.files) - {BUILD_FILE}:  # the old build's only
        stale = output / name
        if stale.is_dir() and not stale.is_symlink():
            shutil.rmtree(stale)
        else:
            stale.unlink(missing_ok=True)
    write_record(output, {**fingerprint.as_dict(), "reason": reason, "files": report.files,
                          "report": _portable(report, output)})
    return UpdateReport(report, True, reason)


def _portable(report: ChainReport, output: Path) -> dict:
    """The report with its paths relative to the output folder (which may be moved)."""
    values = report.as_dict()
    for key in REPORT_PATHS:
        if values.get(key) is not None:
            values[key] = os.path.relpath(values[key], output)
    return values


def _report_from(values: dict, output: Path) -> ChainReport:
    values = dict(values)
    for key in REPORT_PATHS:
        if values.get(key) is not None:
            values[key] = str(output / values[key]) if key != "output" else str(output)
    return ChainReport(**values)
