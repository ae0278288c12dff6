"""wit:qualitymetrics: the three measures run together and their report.

Outputs (each written atomically): a metrics table (metric, value, unit, paper figure) and one
row per building, as CSV, as a GeoPackage (``quality_metrics`` table, ``quality_buildings``
polygons) and as a small HTML page.
"""
from __future__ import annotations

import contextlib
import csv
import html
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import atomic_file
from ..infra.io.raster_io import open_raster
from ..infra.io.vector_io import FieldDef, OutputLayer, write_gpkg
from ..infra.raster_crs import crs_name, foreign_crs, transform_geometry
from .geometry import MATCHED, MODEL_ONLY, BuildingMetrics, GeometryMetrics, geometry_metrics
from .seam import SeamMetrics, seam_metrics
from .texture import TextureMetrics, texture_metrics

METRICS_TABLE = "quality_metrics"
BUILDINGS_LAYER = "quality_buildings"

#: the paper's figures: Table 17 (geometry) and Table 19 (texture: Bing Maps, V-World, WIT)
PAPER_TABLE17 = {"coordinate_mean_error": 30.0, "coordinate_max_error": 80.0, "placement_mean_error": 80.0,
                 "ssi_mean": 0.92}
PAPER_TABLE19 = {"laplacian_variance": {"Bing Maps": 898.63, "V-World": 1471.99, "WIT": 3008.24},
                 "contrast": {"Bing Maps": 71.32, "V-World": 75.35, "WIT": 78.87}}


@dataclass
class MetricRow:
    """One line of the metrics table; ``paper`` is the paper's figure for the same measure, if any."""

    group: str
    metric: str
    value: float
    unit: str
    paper: float | None = None
    note: str = ""


@dataclass
class QualityReport:
    """What ``quality_report`` measured and wrote."""

    rows: list[MetricRow]
    geometry: GeometryMetrics | None = None
    texture: TextureMetrics | None = None
    seam: SeamMetrics | None = None
    outputs: dict[str, str] = field(default_factory=dict)

    def value(self, metric: str) -> float:
        """The value of one metric by name (KeyError if it was not measured)."""
        return next(r.value for r in self.rows if r.metric == metric)


def metric_rows(geometry: GeometryMetrics | None, texture: TextureMetrics | None,
                seam: SeamMetrics | None) -> list[MetricRow]:
    """The metrics table, with the paper's Table 17 / Table 19 figures beside ours."""
    rows: list[MetricRow] = []
    if geometry:
        g, t17 = geometry, "Table 17"
        rows += [
            MetricRow("geometry", "buildings_source", g.source_count, "count"),
            MetricRow("geometry", "buildings_model", g.model_count, "count", note="model solids merged per wit_id"),
            MetricRow("geometry", "buildings_matched", g.matched, "count"),
            MetricRow("geometry", "buildings_model_only", len(g.model_only), "count"),
            MetricRow("geometry", "buildings_source_only", len(g.source_only), "count"),
            MetricRow("geometry", "coordinate_mean_error", g.coordinate_mean_error, "m",
                      PAPER_TABLE17["coordinate_mean_error"],
                      f"{t17} ME (30–80 m); roof vertex → nearest source vertex"),
            MetricRow("geometry", "coordinate_max_error", g.coordinate_max_error, "m",
                      PAPER_TABLE17["coordinate_max_error"], f"{t17} MaxE"),
            MetricRow("geometry", "placement_mean_error", g.placement_mean_error, "m",
                      PAPER_TABLE17["placement_mean_error"], f"{t17} MPE (standard < 100 m); centroid distance"),
            MetricRow("geometry", "placement_std", g.placement_std, "m"),
            MetricRow("geometry", "placement_max_error", g.placement_max_error, "m"),
            MetricRow("geometry", "hausdorff_mean", g.hausdorff_mean, "m", note="outline Hausdorff distance"),
            MetricRow("geometry", "hausdorff_max", g.hausdorff_max, "m"),
            MetricRow("geometry", "ssi_mean", g.ssi_mean, "ratio", PAPER_TABLE17["ssi_mean"],
                      f"{t17} SSI (standard > 0.9); IoU of footprint and ground face"),
            MetricRow("geometry", "ssi_std", g.ssi_std, "ratio"),
            MetricRow("geometry", "ssi_min", g.ssi_min, "ratio"),
        ]
    if texture:
        lap, con = PAPER_TABLE19["laplacian_variance"], PAPER_TABLE19["contrast"]
        others = "Table 19: Bing Maps {Bing Maps}, V-World {V-World}, WIT {WIT}"
        if texture.images:
            scope = "textured rings only" if texture.masked else "whole images"
            rows += [
                MetricRow("texture", "texture_images", len(texture.images), "count"),
                MetricRow("texture", "texture_pixels", texture.pixels, "count", note=scope),
                MetricRow("texture", "model_laplacian_variance", texture.laplacian_variance, "DN²", lap["WIT"],
                          others.format(**lap)),
                MetricRow("texture", "model_contrast", texture.contrast, "DN", con["WIT"], others.format(**con)),
            ]
        if texture.ortho:
            rows += [
                MetricRow("texture", "ortho_laplacian_variance", texture.ortho.laplacian_variance, "DN²",
                          note="source orthoimage over the model's area"),
                MetricRow("texture", "ortho_contrast", texture.ortho.contrast, "DN"),
                MetricRow("texture", "ortho_pixels", texture.ortho.pixels, "count"),
            ]
        if texture.ortho_inside:
            rows += [
                MetricRow("texture", "ortho_footprints_laplacian_variance", texture.ortho_inside.laplacian_variance,
                          "DN²", note="source orthoimage inside the building footprints (what roofs show)"),
                MetricRow("texture", "ortho_footprints_contrast", texture.ortho_inside.contrast, "DN"),
                MetricRow("texture", "ortho_footprints_pixels", texture.ortho_inside.pixels, "count"),
            ]
    if seam:
        rows += [
            MetricRow("seam", "seam_step", seam.step, "DN", note="mean |colour step| across tile borders"),
            MetricRow("seam", "seam_baseline", seam.baseline, "DN", note="same, one pixel beside the border"),
            MetricRow("seam", "seam_excess", seam.excess, "DN", note="step − baseline"),
            MetricRow("seam", "seam_border_pixels", seam.pairs, "count"),
        ]
    return rows


_ROW_FIELDS = ["group", "metric", "value", "unit", "paper", "note"]
_BUILDING_FIELDS = [step_layers.WIT_ID, "status", "solids", "position_error", "vertex_mean_error", "vertex_max_error",
                    "hausdorff", "ssi", "source_area", "model_area"]


def _cell(value: object) -> object:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _building_values(b: BuildingMetrics) -> list[object]:
    return [b.wit_id, b.status, b.solids, b.position_error, b.vertex_mean_error, b.vertex_max_error,
            b.hausdorff, b.ssi, b.source_area, b.model_area]


def _write_csv(path: Path, header: list[str], rows: Iterator[list[object]]) -> None:
    with open(path, "w", newline="", encoding="utf-8-sig") as fh:  # BOM: Excel reads UTF-8
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow(["" if _cell(v) is None else (f"{v:.6g}" if isinstance(v, float) else v) for v in row])


def _write_gpkg(path: Path, rows: list[MetricRow], geometry: GeometryMetrics | None) -> None:
    text, real, integer = ogr.OFTString, ogr.OFTReal, ogr.OFTInteger
    layers = [OutputLayer(METRICS_TABLE, [FieldDef(n, t) for n, t in zip(
        _ROW_FIELDS, (text, text, real, text, real, text))],
        {n: [_cell(getattr(r, n)) for r in rows] for n in _ROW_FIELDS})]
    crs = pyproj.CRS.from_wkt(geometry.crs_wkt) if geometry and geometry.crs_wkt else pyproj.CRS("EPSG:5186")
    if geometry:
        kept = [b for b in geometry.buildings if b.geometry is not None]
        columns: list[Sequence[object]] = (list(zip(*[_building_values(b) for b in kept]))
                                           or [[]] * len(_BUILDING_FIELDS))
        types = (text, text, integer) + (real,) * 7
        layers.append(OutputLayer(BUILDINGS_LAYER, [FieldDef(n, t) for n, t in zip(_BUILDING_FIELDS, types)],
                                  {n: [_cell(v) for v in col] for n, col in zip(_BUILDING_FIELDS, columns)},
                                  np.array([shapely.force_2d(b.geometry) for b in kept], dtype=object)))
    write_gpkg(path, layers, crs)


def _fmt(value: float | None) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    if isinstance(value, int) or float(value).is_integer() and abs(value) >= 1:
        return f"{value:,.0f}"
    return f"{value:.4g}" if abs(value) >= 1 else f"{value:.4f}"


def _write_html(path: Path, report: QualityReport) -> None:
    esc = html.escape
    table = "".join(f"<tr><td>{esc(r.group)}</td><td>{esc(r.metric)}</td><td class=n>{_fmt(r.value)}</td>"
                    f"<td>{esc(r.unit)}</td><td class=n>{_fmt(r.paper)}</td><td>{esc(r.note)}</td></tr>"
                    for r in report.rows)
    parts = [("<h2>Metrics</h2><table><tr><th>Group</th><th>Metric</th><th>Ours</th><th>Unit</th><th>Paper</th>"
              f"<th>Note</th></tr>{table}</table>")]
    g = report.geometry
    if g:
        worst = sorted((b for b in g.buildings if b.status == MATCHED), key=lambda b: -b.position_error)[:20]
        parts.append("<h2>Buildings with the largest placement error</h2><table><tr><th>wit_id</th><th>placement m"
                     "</th><th>vertex mean m</th><th>vertex max m</th><th>Hausdorff m</th><th>SSI</th></tr>" + "".join(
                         f"<tr><td>{esc(b.wit_id)}</td><td class=n>{b.position_error:.4f}</td>"
                         f"<td class=n>{b.vertex_mean_error:.4f}</td><td class=n>{b.vertex_max_error:.4f}</td>"
                         f"<td class=n>{b.hausdorff:.4f}</td><td class=n>{b.ssi:.5f}</td></tr>" for b in worst)
                     + "</table>")
        for title, ids in (("Model buildings without a source footprint", g.model_only),
                           ("Source footprints without a model building", g.source_only)):
            if ids:
                parts.append(f"<h2>{title} ({len(ids)})</h2><p>{esc(', '.join(ids[:200]))}"
                             f"{' …' if len(ids) > 200 else ''}</p>")
    t = report.texture
    if t and (t.images or t.ortho):
        images = t.images + [i for i in (t.ortho, t.ortho_inside) if i]
        parts.append("<h2>Texture images</h2><table><tr><th>Image</th><th>Pixels</th><th>Laplacian variance</th>"
                     "<th>Contrast</th></tr>" + "".join(
                         f"<tr><td>{esc(i.image)}</td><td class=n>{i.pixels:,}</td>"
                         f"<td class=n>{_fmt(i.laplacian_variance)}</td><td class=n>{_fmt(i.contrast)}</td></tr>"
                         for i in images) + "</table>")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>WIT City Model quality metrics</title>
<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse;margin-bottom:2em}}
td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left;vertical-align:top}}th{{background:#eee}}
td.n{{text-align:right;font-variant-numeric:tabular-nums}}</style></head>
<body><h1>Quality metrics (paper Tables 17 and 19)</h1>
<p>Placement error: centroid distance; coordinate error: each roof vertex to the nearest source vertex;
SSI: area(A∩B)/area(A∪B) of source footprint and model ground face. Sharpness: variance of the
Laplacian [[0,1,0],[1,−4,1],[0,1,0]] of I = 0.299R+0.587G+0.114B (reflect-101 borders); contrast:
standard deviation of I. Seam step: mean |colour step| across tile borders inside the mosaic.</p>
{''.join(parts)}
</body></html>
"""
    path.write_text(page, encoding="utf-8")


def _in_ortho_crs(footprints: shapely.Geometry, crs_wkt: str | None, ortho: str | None,
                  feedback: Feedback) -> shapely.Geometry:
    """The footprints in the ortho's CRS when it has another one: its own pixels are measured, never
    resampled (a warp would smooth them and lower their sharpness)."""
    if not ortho or not crs_wkt:
        return footprints
    source = foreign_crs(open_raster(ortho, "orthoimage"), crs_wkt)
    if source is None:
        return footprints
    feedback.info(f"The orthoimage {Path(ortho).name} is in {crs_name(source)}: the footprints are reprojected to it.")
    return transform_geometry(footprints, pyproj.CRS.from_wkt(crs_wkt), source, 1.0)


def quality_report(output_csv: str, model_source: str | None = None, source_buildings: str | None = None,
                   textures: Sequence[str] | str | None = None, ortho: str | None = None,
                   mosaic: str | None = None, footprints: str | Sequence[str] | None = None,
                   output_html: str | None = None, output_gpkg: str | None = None,
                   output_buildings_csv: str | None = None, feedback: Feedback = SILENT,
                   images_ready: Callable[[], None] | None = None) -> QualityReport:
    """wit:qualitymetrics: measure what is given and write the tables (all files appear together or none).

    Geometry needs ``model_source`` and ``source_buildings``; texture needs ``textures`` and/or
    ``ortho``; the seam needs ``mosaic`` and ``footprints``. Per-building rows go to
    ``output_buildings_csv`` (default ``<output_csv stem>_buildings.csv``) when geometry is measured.
    The texture images are measured last, after ``images_ready`` returns (the chain starts the metrics while the
    texture step still writes them: all else is measured meanwhile).
    """
    if bool(model_source) != bool(source_buildings):
        raise InputError("The geometry comparison needs both the model (CityGML or LoD1 faces) and the prepared "
                         "source buildings.")
    if bool(mosaic) != bool(footprints):
        raise InputError("The seam step needs both the merged mosaic and the tile footprints.")
    if not (model_source or textures or ortho or mosaic):
        raise InputError("Nothing to measure: give the model and source buildings, the textures/orthoimage, "
                         "or the mosaic and tile footprints.")
    steps = [s for s in ("geometry" if model_source else None, "texture" if textures or ortho else None,
                         "seam" if mosaic else None) if s]
    span = 95.0 / len(steps)
    done = 0.0

    def next_feedback() -> Feedback:
        nonlocal done
        done += span
        return feedback.scaled(done - span, done)

    geometry = (geometry_metrics(model_source, source_buildings, next_feedback())
                if model_source and source_buildings else None)  # (both or neither: checked above)
    area = footprints_2d = None
    if geometry is not None:
        sources = [b.geometry for b in geometry.buildings if b.status != MODEL_ONLY and b.geometry is not None]
        if sources:
            footprints_2d = _in_ortho_crs(shapely.multipolygons(shapely.get_parts(np.array(sources, dtype=object))),
                                          geometry.crs_wkt, ortho, feedback)
            area = tuple(footprints_2d.bounds)
    seam = seam_metrics(mosaic, footprints, next_feedback()) if mosaic and footprints else None  # (both or neither)
    texture = (texture_metrics(textures, ortho, area, footprints_2d, next_feedback(), images_ready)
               if textures or ortho else None)
    report = QualityReport(metric_rows(geometry, texture, seam), geometry, texture, seam)
    if not any(math.isfinite(r.value) for r in report.rows if r.value is not None and r.unit != "count"):
        reason = (f": no building of the model ({geometry.model_count}) matches one of the {geometry.source_count} "
                  "source footprints by wit_id; give the prepared buildings the model was made from"
                  if geometry is not None and not geometry.matched else "")
        raise InputError(f"Nothing could be measured{reason}. Nothing was written.")
    targets = {"csv": output_csv}
    if geometry is not None:
        targets["buildings_csv"] = output_buildings_csv or str(Path(output_csv).with_name(
            f"{Path(output_csv).stem}_buildings.csv"))
    if output_gpkg:
        targets["gpkg"] = output_gpkg
    if output_html:
        targets["html"] = output_html
    feedback.check_canceled()
    with contextlib.ExitStack() as stack:  # every file renamed into place only once all are written
        tmp = {key: stack.enter_context(atomic_file(path)) for key, path in targets.items()}
        _write_csv(tmp["csv"], _ROW_FIELDS, ([getattr(r, n) for n in _ROW_FIELDS] for r in report.rows))
        if geometry is not None:
            _write_csv(tmp["buildings_csv"], _BUILDING_FIELDS, (_building_values(b) for b in geometry.buildings))
        if "gpkg" in tmp:
            _write_gpkg(tmp["gpkg"], report.rows, geometry)
        if "html" in tmp:
            _write_html(tmp["html"], report)
    report.outputs = {key: str(path) for key, path in targets.items()}
    feedback.progress(100.0)
    return report
