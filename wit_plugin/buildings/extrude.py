"""LoD1 building solids: each footprint extruded from one constant base height (wit:extrudebuildings).

Base: the minimum of the bilinear DEM surface over the footprint (exact: vertices, edges and the
DEM cell centres inside), so no building floats above the terrain; "median" is offered for
footprints on steep ground where the minimum buries one side deeply.

Height: the first source of the rule that gives a finite height > 0 (``wit_plugin.buildings.heights``:
``GRO_FLO_CO`` × storey height, the chosen field / expression, or the height and floor fields of
the common layers recognised by name), else the default; recorded per building as the kind
(``step_layers.HEIGHT_SOURCE``: floors, field, expression, default) and the exact rule
(``step_layers.HEIGHT_RULE``, e.g. ``GRO_FLO_CO × 3 m``). Buildings that got the default are a warning
with their count.

Each solid is a closed, outward-oriented shell of PolygonZ faces: the ground (clockwise seen from
above, normal down), the roof (counter-clockwise, normal up) and one quad per ring edge, courtyard
walls facing into the courtyard. Footprints are cleaned like the terrain's constraints (valid,
1 mm grid), so ground faces meet the TIN's holes. A footprint that is, or repairs into, several
polygons gives one solid per part, with ids ``<wit_id>_part1``, ``_part2``… by decreasing area:
a CityGML Solid has a single connected shell.
"""
from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely
from osgeo import ogr
from shapely.geometry import polygon as shapely_polygon
from shapely.geometry.base import BaseGeometry

from ..infra.dem import Dem
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.gpkg_bulk import write_layer
from ..infra.io.vector_io import FieldDef, keep_source_fields, read_prepared
from ..infra.step_layers import (
    BASE_Z,
    FACE_NUMBER,
    FACE_TYPE,
    HEIGHT,
    HEIGHT_RULE,
    HEIGHT_SOURCE,
    LOD1_LAYER,
    PREPARED_BUILDINGS,
    STOREYS_ABOVE,
    STOREYS_BELOW,
    WIT_ID,
)
from ..terrain.constraints import clean_polygons
from .heights import DEFAULT, HeightOptions, HeightRule, building_height

BASE_MODES = ("min", "median")

Ring = np.ndarray  # (n, 3) closed: first point repeated last


@dataclass
class Solid:
    """One closed LoD1 shell and what it was built from."""

    wit_id: str
    base_z: float
    height: float
    height_source: str
    height_rule: str
    storeys_above: int | None
    storeys_below: int | None
    faces: list[tuple[str, list[Ring]]]  # (face type, [exterior ring, interior rings…])
    attributes: dict = field(default_factory=dict)


@dataclass
class ExtrudeStats:
    buildings: int
    solids: int
    faces: int
    skipped: int
    height_sources: dict[str, int]
    nodata_filled: int

    def as_dict(self) -> dict:
        return asdict(self)


def _storeys(value: Any, minimum: int) -> int | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return round(number) if math.isfinite(number) and number >= minimum else None


def base_heights(dem: Dem, polygons: Sequence[BaseGeometry] | np.ndarray, mode: str = "min") -> np.ndarray:
    """One base height per polygon from the DEM: exact minimum of the surface, or median of samples.

    Samples are the ring vertices and the DEM cell centres inside; the minimum also covers the
    dips of the bilinear surface between vertices along the edges (``Dem.deviation_range``).
    """
    if mode not in BASE_MODES:
        raise InputError(f"Unknown base height mode '{mode}'; use one of {', '.join(BASE_MODES)}.")
    polygons = np.asarray(polygons, dtype=object)
    rings, ring_owner = shapely.get_rings(polygons, return_index=True)
    coords, ring_of = shapely.get_coordinates(rings, return_index=True)
    owner = ring_owner[ring_of]
    last = np.r_[ring_of[1:] != ring_of[:-1], True]  # closing point repeats the first
    z = dem.sample(coords[:, 0], coords[:, 1])
    bounds = shapely.bounds(polygons)
    node_owner, nx, ny, nz = dem.nodes_in_boxes(*bounds.T)
    inside = shapely.contains_xy(polygons[node_owner], nx, ny)
    owners = np.concatenate([owner[~last], node_owner[inside]])
    values = np.concatenate([z[~last], nz[inside]])
    if mode == "median":
        order = np.lexsort((values, owners))
        groups = np.split(values[order], np.flatnonzero(np.diff(owners[order])) + 1)
        return np.array([np.median(g) for g in groups])
    result = np.full(len(polygons), np.inf)
    np.minimum.at(result, owners, values)
    edge = ~last[:-1] & (ring_of[1:] == ring_of[:-1])
    a, b = coords[:-1][edge], coords[1:][edge]
    zeros = np.zeros(len(a))
    lo, _ = dem.deviation_range(a[:, 0], a[:, 1], zeros, b[:, 0], b[:, 1], zeros)
    np.minimum.at(result, owner[:-1][edge], lo)
    return result


def solid_faces(footprint: BaseGeometry, base_z: float, height: float) -> list[tuple[str, list[Ring]]]:
    """Ground, roof and wall faces of the prism over a valid polygon, all normals pointing out."""
    poly = shapely_polygon.orient(footprint, 1.0)  # exterior counter-clockwise, holes clockwise
    top = base_z + height
    rings = [np.asarray(r.coords)[:, :2] for r in (poly.exterior, *poly.interiors)]

    def lift(ring: np.ndarray, z: float) -> Ring:
        return np.column_stack([ring, np.full(len(ring), z)])

    faces: list[tuple[str, list[Ring]]] = [
        ("ground", [lift(r[::-1], base_z) for r in rings]),  # seen from below: normal down
        ("roof", [lift(r, top) for r in rings]),
    ]
    for ring in rings:
        # walking a counter-clockwise exterior (or a clockwise hole), the solid is on the left:
        # the quad (p, q at the base, q, p at the top) then faces right, away from the solid
        for p, q in pairwise(ring):
            faces.append(("wall", [np.array([[*p, base_z], [*q, base_z], [*q, top], [*p, top], [*p, base_z]])]))
    return faces


def extrude(buildings: Sequence[tuple[str | None, BaseGeometry | None, dict]], dem: Dem,
            rule: HeightRule | None = None, base: str = "min",
            feedback: Feedback = SILENT) -> tuple[list[Solid], ExtrudeStats]:
    """Build one closed LoD1 solid per footprint (per part of a multi-part footprint)."""
    rule = rule or HeightRule()  # the road-name-address layer's floors
    if not rule.storey_height > 0 or not rule.default_height > 0:
        raise InputError("Storey height and default height must be positive.")
    cleaned = clean_polygons([g for _, g, _ in buildings])
    parts: list[tuple[int, str, BaseGeometry]] = []
    skipped = 0
    for k, ((wit_id, _, _), geom) in enumerate(zip(buildings, cleaned)):
        name = str(wit_id) if wit_id is not None else f"BLD_{k + 1}"
        if geom is None:
            skipped += 1
            feedback.warning(f"Building {name}: empty or degenerate footprint, skipped.")
            continue
        pieces = sorted(shapely.get_parts(geom), key=lambda p: -p.area)
        if len(pieces) == 1:
            parts.append((k, name, pieces[0]))
        else:
            feedback.warning(f"Building {name}: footprint has {len(pieces)} parts, one solid each.")
            parts += [(k, f"{name}_part{n}", p) for n, p in enumerate(pieces, start=1)]
    feedback.progress(20)
    bases = base_heights(dem, [p for _, _, p in parts], base) if parts else np.empty(0)
    feedback.progress(60)

    solids = []
    for (k, name, poly), base_z in zip(parts, bases):
        feedback.check_canceled()
        attrs = buildings[k][2]
        height, source = building_height(attrs, rule)
        above, below = [_storeys(attrs.get(column), least) if column else None
                        for column, least in ((rule.floors_field, 1), (rule.basement_field, 0))]
        solids.append(Solid(name, float(base_z), height, source.kind if source else DEFAULT, rule.label(source),
                            above, below, solid_faces(poly, float(base_z), height), attrs))
    sources = Counter(s.height_source for s in solids)
    feedback.info("Heights: " + ", ".join(f"{count} from {label}" for label, count in
                                         Counter(s.height_rule for s in solids).most_common()))
    if sources.get(DEFAULT):
        feedback.warning(f"{sources[DEFAULT]} of {len(solids)} building(s) had no usable height and got the default "
                         f"{rule.default_height:g} m ({HEIGHT_SOURCE} = 'default'). Rule tried: {rule.describe()}.")
    stats = ExtrudeStats(len(buildings), len(solids), sum(len(s.faces) for s in solids), skipped,
                         dict(sources), dem.nodata_cells)
    feedback.progress(100)
    return solids, stats


def write_solids(path: str | Path, solids: Sequence[Solid], crs: pyproj.CRS,
                 source_fields: Sequence[FieldDef] = (), spatial_index: bool = True,
                 feedback: Feedback = SILENT) -> int:
    """Write the faces as PolygonZ features (layer ``step_layers.LOD1_LAYER``) with the solid's fields.

    Source fields keep their names and types (one that clashes with ours is kept as ``<name>_src``).
    """
    own = [FieldDef(WIT_ID, ogr.OFTString), FieldDef(FACE_TYPE, ogr.OFTString), FieldDef(FACE_NUMBER, ogr.OFTInteger),
           FieldDef(BASE_Z, ogr.OFTReal), FieldDef(HEIGHT, ogr.OFTReal), FieldDef(HEIGHT_SOURCE, ogr.OFTString),
           FieldDef(HEIGHT_RULE, ogr.OFTString), FieldDef(STOREYS_ABOVE, ogr.OFTInteger),
           FieldDef(STOREYS_BELOW, ogr.OFTInteger)]
    kept = keep_source_fields(source_fields, [fd.name for fd in own], LOD1_LAYER, feedback)
    extra = [out for out, _ in kept]

    geoms, rows = [], []
    for s in solids:
        values = [s.wit_id, s.base_z, s.height, s.height_source, s.height_rule, s.storeys_above, s.storeys_below]
        values += [s.attributes.get(source) for _, source in kept]
        for number, (kind, rings) in enumerate(s.faces):
            geoms.append(shapely.Polygon(rings[0], rings[1:]))
            rows.append((values[0], kind, number, *values[1:]))
    columns: list[Sequence[Any]] = list(zip(*rows)) if rows else [[] for _ in own + extra]
    return write_layer(path, LOD1_LAYER, crs, own + extra, np.array(geoms, dtype=object), columns,
                       spatial_index=spatial_index, feedback=feedback)


def extrude_buildings(vectors: str | Path, dem_path: str | Path, output: str | Path,
                      heights: HeightOptions | None = None, base: str = "min", spatial_index: bool = True,
                      feedback: Feedback = SILENT) -> ExtrudeStats:
    """wit:extrudebuildings: read the prepared buildings and the DEM, write the LoD1 faces GeoPackage.

    ``vectors`` is the prepared buildings layer (``file.gpkg|layername=…``) or the prepared GeoPackage.
    The height rule is resolved against its fields (``HeightOptions.rule_for``) and logged.
    """
    layer = read_prepared(vectors, PREPARED_BUILDINGS, feedback)
    rule = (heights or HeightOptions()).rule_for([f.name for f in layer.fields], str(vectors))
    feedback.info(f"Height rule: {rule.describe()}")
    geoms = [g for g in layer.geoms if g is not None and not g.is_empty]
    if not geoms:
        raise InputError(f"{vectors} has no building footprints.")
    dem = Dem.open(dem_path, tuple(shapely.total_bounds(geoms)), feedback=feedback, crs=layer.crs)
    ids = layer.columns.get(WIT_ID) or [None] * len(layer)
    rows = [{name: column[k] for name, column in layer.columns.items()} for k in range(len(layer))]
    solids, stats = extrude(list(zip(ids, layer.geoms, rows)), dem, rule, base, feedback.scaled(0, 80))
    if not solids:  # a run that made nothing fails and writes nothing
        raise InputError(f"No LoD1 solid could be made: the {len(layer)} footprint(s) of {vectors} are all empty "
                         "or degenerate. Nothing was written.")
    source_fields = [f for f in layer.fields if f.name.lower() != WIT_ID]  # the id is the solid's own
    write_solids(output, solids, layer.crs, source_fields, spatial_index, feedback.scaled(80, 100))
    feedback.info("LoD1: " + ", ".join(f"{k} {v}" for k, v in stats.as_dict().items()))
    feedback.progress(100)
    return stats
