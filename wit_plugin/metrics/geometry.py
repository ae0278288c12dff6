"""Geometry against the 2D sources, the paper's Table 17: placement, vertex error, Hausdorff distance, SSI.

**Geometry against the 2D sources (Table 17).** The model's buildings are read from the written
CityGML 3.0 file (``bldg:Building`` → ``core:lod1Solid`` polygons, streamed by ``citygml.reader``,
so the metric checks the deliverable itself) or from the LoD1 faces GeoPackage. In the CityGML
file a face's kind is not stored: horizontal faces (Z spread ≤ 1 mm) at the solid's lowest Z are
its ground, at its highest Z its roof. Everything is compared in 2D (X, Y) with the prepared
source footprints (``step_layers.PREPARED_BUILDINGS``), matched by ``wit_id`` = ``gml:id``; the solids
``<wit_id>_part1``, ``_part2``… that wit:extrudebuildings makes from a multi-part footprint are
merged back into their building. Per building:

* *position (placement) error*: distance between the centroids of the source footprint and of the
  model's ground face(s); the mean over buildings is the paper's MPE;
* *vertex (coordinate) error*: for each vertex of the model's roof face(s), the distance to the
  nearest vertex of the source footprint; mean and maximum over all vertices are the paper's
  ME and MaxE ("coordinate consistency");
* *Hausdorff distance* of the two outlines (boundaries, GEOS discrete Hausdorff);
* *shape similarity index* SSI = IoU = area(A ∩ B) / area(A ∪ B) of the source footprint A and the
  model's ground face B: 1 for identical shapes, 0 for disjoint ones. (The paper gives no formula
  for its SSI of 0.92; IoU is the standard, scale-free choice.)

Buildings present in only one of the two are counted and listed (``model_only`` /
``source_only``) and left out of the statistics.
"""
from __future__ import annotations

import math
import os
import re
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from lxml import etree
from osgeo import osr

from ..citygml.namespaces import BLDG, CORE, GML, GML_ID
from ..citygml.reader import Stream, SyntaxProblem, envelope_srs
from ..citygml.validation.crs import frame_of
from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.layersource import LayerSource
from ..infra.io.vector_io import open_step_layer

MATCHED, MODEL_ONLY, SOURCE_ONLY = "matched", "model_only", "source_only"
_PART = re.compile(r"^(.*)_part\d+$")
_FLAT = 1e-3  # m: Z spread of a horizontal face
_PAIRS = 2_000_000  # vertex pairs per distance chunk


@dataclass
class BuildingMetrics:
    """One building: how far the model is from its source footprint (NaN where not matched)."""

    wit_id: str
    status: str  # MATCHED, MODEL_ONLY or SOURCE_ONLY
    solids: int = 0  # model solids merged into this building (parts of a multi-part footprint)
    position_error: float = math.nan
    vertex_mean_error: float = math.nan
    vertex_max_error: float = math.nan
    hausdorff: float = math.nan
    ssi: float = math.nan
    source_area: float = math.nan
    model_area: float = math.nan
    geometry: shapely.Geometry | None = None  # source footprint (model ground if model-only), 2D


@dataclass
class GeometryMetrics:
    """Table 17: coordinate consistency, placement accuracy and shape similarity over matched buildings."""

    buildings: list[BuildingMetrics]
    source_count: int
    model_count: int
    matched: int
    model_only: list[str]
    source_only: list[str]
    vertices: int
    coordinate_mean_error: float
    coordinate_max_error: float
    placement_mean_error: float
    placement_std: float
    placement_max_error: float
    hausdorff_mean: float
    hausdorff_max: float
    ssi_mean: float
    ssi_std: float
    ssi_min: float
    crs_wkt: str | None = None


@dataclass
class _ModelBuilding:
    grounds: list[shapely.Polygon] = field(default_factory=list)
    roof_vertices: list[np.ndarray] = field(default_factory=list)
    solids: int = 0


def _polygon_3d(rings: list[np.ndarray]) -> tuple[shapely.Polygon, np.ndarray]:
    """2D polygon and the 3D points (closing points dropped) of rings given as (n, 3) arrays."""
    poly = shapely.Polygon(rings[0][:, :2], [r[:, :2] for r in rings[1:]])
    return poly, np.concatenate([r[:-1] for r in rings])


def _add_solid(target: _ModelBuilding, faces: list[tuple[shapely.Polygon, np.ndarray, str | None]]) -> None:
    """Add one solid's faces; faces without a kind are classified by height (lowest/highest horizontal)."""
    if not faces:
        return
    z = np.concatenate([pts[:, 2] for _, pts, _ in faces])
    low, high = float(z.min()), float(z.max())
    for poly, pts, kind in faces:
        if kind is None and np.ptp(pts[:, 2]) <= _FLAT:
            kind = "ground" if abs(pts[0, 2] - low) <= _FLAT else "roof" if abs(pts[0, 2] - high) <= _FLAT else None
        if kind == "ground":
            target.grounds.append(poly)
        elif kind == "roof":
            target.roof_vertices.append(pts[:, :2])
    target.solids += 1


def _poslist(ring: etree._Element, gml_id: str) -> np.ndarray:
    pos = ring.find(GML + "posList")
    if pos is not None:
        dim = int(pos.get("srsDimension") or 3)
        values = np.array((pos.text or "").split(), dtype=np.float64)
    else:
        points = [np.array((p.text or "").split(), dtype=np.float64) for p in ring.iter(GML + "pos")]
        dim, values = (len(points[0]) if points else 3), np.concatenate(points) if points else np.zeros(0)
    if dim != 3 or values.size % 3 or values.size < 12:
        raise InputError(f"Building {gml_id}: a lod1Solid ring is not a closed 3D ring (srsDimension 3, ≥ 4 points); "
                         "re-run wit:writecitygml.")
    return values.reshape(-1, 3)


def _building_of(node: etree._Element) -> etree._Element | None:
    """The nearest ``bldg:Building`` that holds ``node``."""
    node = node.getparent()
    while node is not None and node.tag != BLDG + "Building":
        node = node.getparent()
    return node


def _read_gml(path: str, feedback: Feedback) -> tuple[dict[str, _ModelBuilding], str | None]:
    """Buildings of a CityGML 3.0 file: per gml:id the solids' ground polygons and roof vertices.

    Read part by part by the CityGML reader the validator uses (``citygml.reader``: constant memory,
    entities never expanded). Positions are turned easting (longitude) first when the envelope's
    srsName says they are written northing (latitude) first: its URN or URL form for a CRS whose
    EPSG order is so (``validation.crs``).
    """
    buildings: dict[str, _ModelBuilding] = {}
    size = max(os.path.getsize(path), 1)

    def on_chunk(done: int) -> None:
        feedback.check_canceled()
        feedback.progress(100.0 * done / size)

    stream = Stream(Path(path), CORE + "CityModel", on_chunk)
    srs: str | None = None
    order: list[int] | None = None  # axis order, fixed at the first building by the envelope read before it
    try:
        for parent, n in stream.parts():
            children = parent[:n]
            if parent is stream.root:
                if order is None and srs is None:
                    srs = envelope_srs(children)
                children = [c for c in children if c.tag == CORE + "cityObjectMember"]
            faces: dict[str, list] = {}  # per building, in document order: the faces of its solids in this part
            for child in children:
                _name_buildings(child, buildings)
                order = _collect_solid_faces(child, buildings, srs, order, faces)
            for gml_id, solid_faces in faces.items():
                _add_solid(buildings.setdefault(gml_id, _ModelBuilding()), solid_faces)
    except SyntaxProblem as exc:
        where = f" at line {exc.line}" if exc.line else ""
        raise InputError(f"{path} is not well-formed XML ({exc.message}{where}); re-run wit:writecitygml.") from exc
    if not buildings:
        raise InputError(f"{path} has no CityGML 3.0 bldg:Building: give the .gml written by wit:writecitygml "
                         "(or the LoD1 faces GeoPackage).")
    return buildings, srs


def _name_buildings(element: etree._Element, buildings: dict[str, _ModelBuilding]) -> None:
    """Every bldg:Building under ``element`` in ``buildings``, one without a gml:id named once (so that a later
    part finds the same name)."""
    for building in element.iter(BLDG + "Building"):
        if not building.get(GML_ID):
            building.set(GML_ID, f"Building_{len(buildings) + 1}")
        buildings.setdefault(building.get(GML_ID), _ModelBuilding())


def _collect_solid_faces(element: etree._Element, buildings: dict[str, _ModelBuilding], srs: str | None,
                         order: list[int] | None, faces: dict[str, list]) -> list[int] | None:
    """The faces of the LoD1 solids under ``element`` added to ``faces`` (per building's gml:id); returns the axis
    order, fixed at the first solid by the srsName read before it."""
    for solid in element.iter(CORE + "lod1Solid"):
        building = _building_of(solid)
        if building is None:
            continue
        if order is None:
            order = [1, 0, 2] if srs and frame_of(srs).lat_axis == 0 else [0, 1, 2]
        gml_id = building.get(GML_ID) or f"Building_{len(buildings) + 1}"
        building.set(GML_ID, gml_id)
        solid_faces = faces.setdefault(gml_id, [])
        for polygon in solid.iter(GML + "Polygon"):
            rings = [_poslist(r, gml_id)[:, order] for r in polygon.iter(GML + "LinearRing")]
            if rings:
                solid_faces.append((*_polygon_3d(rings), None))
    return order


def _read_lod1(path: str, feedback: Feedback) -> tuple[dict[str, _ModelBuilding], osr.SpatialReference | None]:
    """Ground polygons and roof vertices per wit_id from the LoD1 faces layer (FACE_TYPE given)."""
    ds, layer, _ = open_step_layer(path, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE,
                                   (step_layers.WIT_ID, step_layers.FACE_TYPE))
    faces: dict[str, list] = defaultdict(list)
    total = max(layer.GetFeatureCount(), 1)
    for k, feature in enumerate(layer):
        if k % 5000 == 0:
            feedback.check_canceled()
            feedback.progress(100.0 * k / total)
        kind = feature.GetFieldAsString(step_layers.FACE_TYPE)
        geometry = feature.GetGeometryRef()
        if kind not in ("ground", "roof") or geometry is None or geometry.IsEmpty():
            continue
        poly = shapely.from_wkb(bytes(geometry.ExportToIsoWkb()))
        rings = [np.asarray(poly.exterior.coords)] + [np.asarray(r.coords) for r in poly.interiors]
        if rings[0].shape[1] != 3:
            rings = [np.column_stack([r, np.zeros(len(r))]) for r in rings]
        faces[feature.GetFieldAsString(step_layers.WIT_ID)].append((*_polygon_3d(rings), kind))
    buildings: dict[str, _ModelBuilding] = {}
    for wit_id, solid in faces.items():
        _add_solid(buildings.setdefault(wit_id, _ModelBuilding()), solid)
    srs = layer.GetSpatialRef()
    return buildings, srs.Clone() if srs else None


def _read_sources(source: str) -> tuple[list[str], np.ndarray, osr.SpatialReference | None]:
    ds, layer, _ = open_step_layer(source, step_layers.PREPARED_BUILDINGS, step_layers.PREPARED_BUILDINGS_ROLE,
                                   (step_layers.WIT_ID,))
    ids, wkbs = [], []
    for feature in layer:
        geometry = feature.GetGeometryRef()
        if geometry is None or geometry.IsEmpty():
            continue
        ids.append(feature.GetFieldAsString(step_layers.WIT_ID))
        wkbs.append(bytes(geometry.ExportToIsoWkb()))
    geoms = shapely.force_2d(shapely.from_wkb(np.array(wkbs, dtype=object))) if wkbs else np.empty(0, dtype=object)
    srs = layer.GetSpatialRef()
    return ids, geoms, srs.Clone() if srs else None


def _epsg(srs: osr.SpatialReference | str | None) -> str | None:
    if srs is None:
        return None
    try:
        crs = pyproj.CRS.from_user_input(srs.ExportToWkt() if isinstance(srs, osr.SpatialReference) else srs)
    except pyproj.exceptions.CRSError:
        return None
    code = crs.to_epsg(min_confidence=70)
    return str(code) if code else None


def _merge_parts(models: dict[str, _ModelBuilding], source_ids: set[str]) -> dict[str, _ModelBuilding]:
    """Solids ``<id>_partN`` of a source building ``<id>`` folded into one model building."""
    merged: dict[str, _ModelBuilding] = {}
    for gml_id, b in models.items():
        match = _PART.match(gml_id)
        key = match.group(1) if match and gml_id not in source_ids and match.group(1) in source_ids else gml_id
        target = merged.setdefault(key, _ModelBuilding())
        target.grounds += b.grounds
        target.roof_vertices += b.roof_vertices
        target.solids += b.solids
    return merged


def _nearest_vertex_distances(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` (n, 2) to the nearest of ``targets`` (m, 2), chunked."""
    out = np.empty(len(points))
    step = max(1, _PAIRS // max(len(targets), 1))
    for k in range(0, len(points), step):
        d = points[k:k + step, None, :] - targets[None, :, :]
        out[k:k + step] = np.sqrt(np.min(np.einsum("ijk,ijk->ij", d, d), axis=1))
    return out


def _vertices(geometry: shapely.Geometry) -> np.ndarray:
    """2D vertices of every ring of a (multi)polygon, closing points dropped."""
    rings = shapely.get_rings(shapely.get_parts(geometry))
    return np.concatenate([shapely.get_coordinates(r)[:-1] for r in rings]) if len(rings) else np.zeros((0, 2))


def _valid(geoms: np.ndarray) -> np.ndarray:
    """Invalid polygons repaired (GEOS overlay needs valid input), keeping only their polygonal parts."""
    bad = np.flatnonzero(~shapely.is_valid(geoms))
    if bad.size:
        geoms = geoms.copy()
        for k in bad:
            parts = shapely.get_parts(shapely.make_valid(geoms[k]))
            geoms[k] = shapely.union_all(parts[np.isin(shapely.get_type_id(parts), (3, 6))])
    return geoms


def shape_similarity(a: shapely.Geometry | np.ndarray, b: shapely.Geometry | np.ndarray) -> float | np.ndarray:
    """SSI = IoU = area(A ∩ B) / area(A ∪ B) of valid polygons, element-wise for arrays (NaN if both empty)."""
    with np.errstate(invalid="ignore", divide="ignore"):  # GEOS raises FP flags on some empty overlays
        inter = shapely.area(shapely.intersection(a, b))
        return inter / (shapely.area(a) + shapely.area(b) - inter)


def geometry_metrics(model_source: str, source_buildings: str, feedback: Feedback = SILENT) -> GeometryMetrics:
    """Compare the model's buildings with the 2D source footprints (Table 17; see the module docstring).

    ``model_source``: the CityGML file (``.gml``/``.xml``) or the LoD1 faces GeoPackage;
    ``source_buildings``: footprints with the ``wit_id`` of wit:preparevectors: its GeoPackage (layer
    ``buildings``), one of its layers as ``file.gpkg|layername=…``, or a file of one such layer.
    """
    if not Path(model_source).is_file():
        raise InputError(f"The model {model_source} does not exist.")
    if not LayerSource.parse(source_buildings).file.is_file():
        raise InputError(f"The source buildings {source_buildings} do not exist.")
    ids, sources, source_srs = _read_sources(str(source_buildings))
    if not ids:
        raise InputError(f"{source_buildings} has no building footprints.")
    if len(set(ids)) != len(ids):
        raise InputError(f"{source_buildings}: '{step_layers.WIT_ID}' is not unique; "
                         "give the output of wit:preparevectors.")
    feedback.progress(5.0)
    if Path(model_source).suffix.lower() in (".gml", ".xml"):
        raw, model_srs = _read_gml(str(model_source), feedback.scaled(5.0, 60.0))
    else:
        raw, model_srs = _read_lod1(str(model_source), feedback.scaled(5.0, 60.0))
    model_code, source_code = _epsg(model_srs), _epsg(source_srs)
    if model_code and source_code and model_code != source_code:
        raise InputError(f"The model is in EPSG:{model_code} but the source buildings in EPSG:{source_code}: "
                         "compare layers in the same CRS (re-run wit:preparevectors with the model's CRS).")
    models = _merge_parts(raw, set(ids))
    index = {wit_id: k for k, wit_id in enumerate(ids)}
    matched_ids = [m for m in models if m in index and models[m].grounds]
    source_only = [i for i in ids if i not in models or not models[i].grounds]
    model_only = [m for m in models if m not in index]
    rows: list[BuildingMetrics] = []
    if matched_ids:
        a = _valid(sources[[index[m] for m in matched_ids]])
        b = _valid(np.array([shapely.union_all(models[m].grounds) if len(models[m].grounds) > 1
                             else models[m].grounds[0] for m in matched_ids], dtype=object))
        position = shapely.distance(shapely.centroid(a), shapely.centroid(b))
        area_a, area_b = shapely.area(a), shapely.area(b)
        ssi = np.asarray(shape_similarity(a, b))  # (arrays in, an array out)
        hausdorff = shapely.hausdorff_distance(shapely.boundary(a), shapely.boundary(b))
        feedback.progress(75.0)
        all_errors = []
        for k, wit_id in enumerate(matched_ids):
            if k % 1000 == 0:
                feedback.check_canceled()
                feedback.progress(75.0 + 20.0 * k / len(matched_ids))
            roof = models[wit_id].roof_vertices
            errors = (_nearest_vertex_distances(np.concatenate(roof), _vertices(a[k])) if roof else np.zeros(0))
            all_errors.append(errors)
            rows.append(BuildingMetrics(wit_id, MATCHED, models[wit_id].solids, float(position[k]),
                                        float(errors.mean()) if errors.size else math.nan,
                                        float(errors.max()) if errors.size else math.nan,
                                        float(hausdorff[k]), float(ssi[k]), float(area_a[k]), float(area_b[k]), a[k]))
        errors = np.concatenate(all_errors)
    else:
        position = ssi = hausdorff = errors = np.zeros(0)
    rows += [BuildingMetrics(i, SOURCE_ONLY, 0, source_area=float(sources[index[i]].area), geometry=sources[index[i]])
             for i in source_only]
    for m in model_only:
        ground = shapely.union_all(models[m].grounds) if models[m].grounds else None
        rows.append(BuildingMetrics(m, MODEL_ONLY, models[m].solids,
                                    model_area=float(ground.area) if ground is not None else math.nan,
                                    geometry=ground))
    if model_only:
        feedback.warning(f"{len(model_only)} model building(s) have no source footprint, e.g. {model_only[0]}.")
    if source_only:
        feedback.warning(f"{len(source_only)} source footprint(s) have no model building, e.g. {source_only[0]}.")

    def stat(values: np.ndarray, how) -> float:
        return float(how(values)) if values.size else math.nan

    result = GeometryMetrics(
        buildings=rows, source_count=len(ids), model_count=len(models), matched=len(matched_ids),
        model_only=model_only, source_only=source_only, vertices=int(errors.size),
        coordinate_mean_error=stat(errors, np.mean), coordinate_max_error=stat(errors, np.max),
        placement_mean_error=stat(position, np.mean), placement_std=stat(position, np.std),
        placement_max_error=stat(position, np.max), hausdorff_mean=stat(hausdorff, np.mean),
        hausdorff_max=stat(hausdorff, np.max), ssi_mean=stat(ssi, np.mean), ssi_std=stat(ssi, np.std),
        ssi_min=stat(ssi, np.min), crs_wkt=source_srs.ExportToWkt() if source_srs else None)
    feedback.info(f"Geometry: {result.matched} matched building(s); "
                  f"placement error {result.placement_mean_error:.4f} m "
                  f"(max {result.placement_max_error:.4f}), vertex error {result.coordinate_mean_error:.4f} m "
                  f"(max {result.coordinate_max_error:.4f}), SSI {result.ssi_mean:.4f} (min {result.ssi_min:.4f}).")
    feedback.progress(100.0)
    return result
