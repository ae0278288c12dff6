"""Prepare the building, road and district layers for the 3D chain (wit:preparevectors).

Pipeline per layer: read (encoding and CRS detected, see ``vector_io``) → reproject to the target
CRS → repair (``polygons.repair_polygons``) → select / clip to the study area (``area``) →
Douglas–Peucker simplification that keeps shared walls shared (``simplify``) → GeoPackage.

Decisions:

* **Repairs and slivers** are counted per kind (see ``polygons``); every dropped feature is listed.
* **Clipping**: buildings are kept whole when their representative point lies in the study area
  (cutting a building in half would create a fake wall); roads and districts are cut to it.
* **Simplification** keeps shared boundaries shared (``simplify.simplify_shared``); districts
  are simplified before they are cut, so the study area's edge stays exact.
* **Stats**: ``features_in`` counts the features read, i.e. those whose envelope meets the study
  area's bounding box (GDAL filters the rest out unread); ``outside_area`` those read but not in
  the area; ``dropped`` the defects (reasons ``DROP_REASONS``; ``non_finite``: a coordinate is
  ±inf or NaN, in the file or after reprojection; ``covered``: a road entirely inside wider ones;
  ``duplicate``: see below). Every drop is also a warning with its count.
* **Duplicates**: a building (or district) with the same source id and the same footprint as an
  earlier one (stacked copies) is dropped as ``duplicate``, one copy kept. The same id on
  different footprints is two buildings: both are kept, the later ones with ``_2``, ``_3``… on
  their ``wit_id`` (ids stay unique, as CityGML's gml:id must), and a warning counts them.
* **Roads**: road polygons (the NGII road boundary ``N3A_A0010000``, any polygon layer) are the road
  surfaces as they are: repaired and cut to the study area like districts, not simplified. Centre
  lines are simplified (DP keeps every section's end points, so the network stays connected), then
  buffered by width / 2 with round caps and joins (a gap-free surface at junctions and bends, which
  the TIN needs). The width comes from the layer's rule (``roads``: its width field, else its lane
  count × lane width, else its class default, else ``default_road_width``), logged with its counts.
  Features with the same id are merged. At junctions the buffers overlap; each point goes to the
  widest road covering it (ties: smaller id), so road polygons tile the road area without
  overlaps. A layer may hold both kinds. ``road_area`` gives the dissolved area.
"""
from __future__ import annotations

import csv
import os
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np
import pyproj
import shapely
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import atomic_file, refuse_overlap
from ..infra.io.vector_io import (
    BUILDING_FIELDS,
    DISTRICT_FIELDS,
    ROAD_FIELDS,
    FieldDef,
    OutputLayer,
    VectorLayer,
    keep_source_fields,
    non_finite,
    read_layer,
    write_gpkg,
)
from ..infra.polygons import (
    REPAIR_KINDS,
    REPEATED_POINT_TOLERANCE,
    exact_duplicates,
    orient,
    polygonal,
    repair_polygons,
    transform,
    vertex_count,
)
from .area import StudyArea
from .roads import WidthRule, field_text
from .roads import widths as road_widths_of
from .simplify import GRID_SIZE, simplify_shared

DROP_REASONS = ("no_geometry", "non_finite", "wrong_type", "collapsed", "too_small", "thin", "covered", "duplicate")
ROAD_QUAD_SEGS = 4
STATS_TABLE = "stats"
DROPPED_TABLE = "dropped"


class Owner(Protocol):
    """Which tile keeps a building, from its point on surface ((n, 2) target-CRS points → n booleans)."""

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Owned by this tile."""

    def in_run(self, points: np.ndarray) -> np.ndarray:
        """Owned by some tile of the run (in its area): a building owned by none is not in the model at all."""


@dataclass
class PrepareConfig:
    """Parameters of wit:preparevectors (lengths and areas in target-CRS metres)."""

    target_crs: str = "EPSG:5186"
    building_tolerance: float = 0.5
    road_tolerance: float = 5.0
    district_tolerance: float = 5.0
    min_area: float = 1.0
    sliver_thinness: float = 0.05
    sliver_width: float = 1.0
    default_road_width: float = 6.0
    encoding: str | None = None  # force the text encoding of shapefile inputs
    source_crs: str | None = None  # CRS of inputs that declare none (no .prj); declared ones win
    stats_csv: str | None = None  # default: <output stem>_stats.csv beside the GeoPackage
    # Tiles (wit_plugin.sheetrun): keep the buildings whose point on surface ``owner`` accepts (an (n, 2)
    # array → n booleans; it replaces the area test), read and simplify them together with their neighbours
    # within ``context_margin`` (so walls shared across the tile's edge are simplified alike on both sides),
    # and write the neighbours that cross into the area and another tile of the run owns
    # (``owner.in_run``) as ``step_layers.FOREIGN_BUILDINGS`` (holes in the tile's terrain).
    owner: Owner | None = None
    context_margin: float = 0.0


@dataclass
class LayerStats:
    """One row of the stats table: what happened to one layer."""

    layer: str
    features_in: int  # read: features whose envelope meets the study area's bounding box
    features_out: int
    outside_area: int
    repaired: dict[str, int] = field(default_factory=dict)
    dropped: dict[str, int] = field(default_factory=dict)
    vertices_in: int = 0
    vertices_out: int = 0
    arcs_kept: int = 0  # arcs left unsimplified to keep polygons valid and walls shared

    def row(self) -> dict[str, object]:
        """Flat columns for the table and CSV: repaired_<kind>, dropped_<reason>."""
        flat = {k: v for k, v in asdict(self).items() if k not in ("repaired", "dropped")}
        flat.update({f"repaired_{k}": self.repaired.get(k, 0) for k in REPAIR_KINDS})
        flat.update({f"dropped_{k}": self.dropped.get(k, 0) for k in DROP_REASONS})
        return flat


@dataclass
class DroppedFeature:
    """A feature removed as a defect, so the user can find it in the source."""

    layer: str
    source_fid: int
    wit_id: str
    reason: str


@dataclass
class PrepareReport:
    """What prepare_vectors wrote."""

    output: str
    stats_csv: str
    layers: list[str]
    stats: list[LayerStats]
    dropped: list[DroppedFeature]
    area: shapely.Geometry


# -- ids ----------------------------------------------------------------------------------------

def _id_part(value: object) -> str:
    """The value as a part of an id ("" when not filled)."""
    text = field_text(value)
    return re.sub(r"[^\w.\-]", "_", text) if text else ""  # an id part stays part of an XML name (gml:id)


def source_ids(layer: VectorLayer, prefix: str, keys: Sequence[Sequence[str]]) -> list[str]:
    """``<prefix>_<key fields joined by _>`` from the first key whose fields are all filled (model rules),
    else ``<prefix>_F<source fid>``; not yet unique (see ``unique_ids``)."""
    fmap = layer.field_map([name for key in keys for name in key])
    usable = [key for key in keys if all(name in fmap for name in key)]
    ids = []
    for i, fid in enumerate(layer.fids):
        wid = None
        for key in usable:
            parts = [_id_part(layer.columns[fmap[name]][i]) for name in key]
            if all(parts):
                wid = f"{prefix}_{'_'.join(parts)}"
                break
        ids.append(wid or f"{prefix}_F{fid}")
    return ids


def unique_ids(ids: Sequence[str], skip: np.ndarray | None = None) -> list[str]:
    """A repeated id gets ``_2``, ``_3``… in source order, so ids stay unique and the same for the same
    input; features in ``skip`` (duplicates about to be dropped) keep the id they repeat."""
    out: list[str] = []
    seen: dict[str, int] = {}
    for i, wid in enumerate(ids):
        if skip is not None and skip[i]:
            out.append(wid)
            continue
        seen[wid] = seen.get(wid, 0) + 1
        out.append(wid if seen[wid] == 1 else f"{wid}_{seen[wid]}")
    return out



# -- roads --------------------------------------------------------------------------------------

def road_widths(layer: VectorLayer, default_width: float, feedback: Feedback = SILENT) -> tuple[np.ndarray, list[str]]:
    """Width per centre line and its source, by the layer's rule (``roads.WidthRule``: its width field,
    else lanes × lane width, else its class default, else ``default_width``); the rule is logged, and
    defaults are a warning with the count."""
    rule = WidthRule.of([f.name for f in layer.fields], default_width)
    widths, sources = road_widths_of(layer.columns, len(layer), rule)
    counts: dict[str, int] = {}
    for source in sources:
        counts[source] = counts.get(source, 0) + 1
    feedback.info(f"Road width rule: {rule.describe()}; " + ", ".join(f"{n} from {k}" for k, n in counts.items()))
    if counts.get("default"):
        feedback.warning(f"roads: {counts['default']} of {len(sources)} centre line(s) have no width, lane count or "
                         f"known class: buffered with the default width {default_width:g} m.")
    return widths, sources


def separate_roads(polys: np.ndarray, widths: np.ndarray, ids: Sequence[str]) -> np.ndarray:
    """Remove junction overlaps: each road loses what wider roads (ties: smaller id) cover.

    Every road subtracts the union of its higher-priority neighbours' original polygons, so the
    result tiles the union exactly and each road is computed independently (no sequential chain).
    """
    rank = np.empty(len(polys), dtype=int)
    rank[np.lexsort((np.array(ids, dtype=object), -widths))] = np.arange(len(polys))
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    higher = rank[b] < rank[a]
    a, b = a[higher], b[higher]
    out = polys.copy()
    for i in np.unique(a):
        out[i] = shapely.difference(polys[i], shapely.union_all(polys[b[a == i]]))
    return polygonal(out)


def road_area(roads: np.ndarray) -> shapely.Geometry:
    """The dissolved road surface (the TIN's constraint), from road polygons."""
    return shapely.union_all(roads[~shapely.is_missing(roads)], grid_size=GRID_SIZE)


def _dissolve_by_id(layer: VectorLayer, ids: list[str]) -> tuple[VectorLayer, list[str]]:
    """One feature per road id: later features with the same id are merged into the first."""
    first: dict[str, int] = {}
    groups: dict[int, list[int]] = {}
    for i, wid in enumerate(ids):
        groups.setdefault(first.setdefault(wid, i), []).append(i)
    keep = sorted(groups)
    merged = layer.take(keep)
    for j, i in enumerate(keep):
        if len(groups[i]) > 1:
            merged.geoms[j] = shapely.line_merge(shapely.union_all(layer.geoms[groups[i]]))
    return merged, [ids[i] for i in keep]


# -- the algorithm ------------------------------------------------------------------------------

@dataclass
class _Prepared:
    """One output layer before writing."""

    name: str
    layer: VectorLayer
    ids: list[str]
    extra_fields: list[FieldDef] = field(default_factory=list)
    extra_columns: dict[str, list] = field(default_factory=dict)
    foreign: _Prepared | None = None  # tiles: the neighbours' buildings that cross into the area


def _check_config(config: PrepareConfig) -> pyproj.CRS:
    """The target CRS; parameters that cannot work are input errors before any reading."""
    try:
        target = pyproj.CRS.from_user_input(config.target_crs)
    except pyproj.exceptions.CRSError as exc:
        raise InputError(f"Unknown target CRS {config.target_crs!r}: {exc}") from exc
    if not target.is_projected or target.axis_info[0].unit_name not in ("metre", "meter"):
        raise InputError(f"The target CRS {config.target_crs} must be projected in metres (e.g. EPSG:5186), "
                         "because tolerances, areas and widths are in metres.")
    for name in ("building_tolerance", "road_tolerance", "district_tolerance", "min_area", "sliver_width"):
        if not getattr(config, name) >= 0:
            raise InputError(f"{name} must be zero or positive, not {getattr(config, name)}.")
    if not config.default_road_width > 0:
        raise InputError(f"default_road_width must be positive, not {config.default_road_width}.")
    return target


def _read(path: str, kind: str, expected: Sequence[str], target: pyproj.CRS, config: PrepareConfig,
          area: shapely.Geometry | None, feedback: Feedback) -> VectorLayer:
    """Read the features near ``area`` (all when None), report missing fields, reproject."""
    layer = read_layer(path, encoding=config.encoding, crs=config.source_crs,
                       bbox=area.bounds if area is not None else None, bbox_crs=target, feedback=feedback)
    if layer.field_map(expected):  # a road-name-address layer: name what it lacks (other schemas lack them all)
        layer.field_map(expected, feedback)
    feedback.info(f"{kind}: {len(layer)} features read from {path} (CRS {layer.crs.name}, "
                  f"encoding {layer.encoding or 'as declared'})")
    layer.geoms = transform(layer.geoms, layer.crs, target)
    return layer


def _drop(layer: VectorLayer, ids: list[str], reasons: np.ndarray, stats: LayerStats,
          dropped: list[DroppedFeature]) -> np.ndarray:
    """Record features with a reason; return the indices of the others."""
    for i in np.flatnonzero(reasons != None):  # noqa: E711
        stats.dropped[reasons[i]] = stats.dropped.get(reasons[i], 0) + 1
        dropped.append(DroppedFeature(stats.layer, int(layer.fids[i]), ids[i], str(reasons[i])))
    return np.flatnonzero(reasons == None)  # noqa: E711


def _polygon_layer(layer: VectorLayer, name: str, prefix: str, keys: Sequence[Sequence[str]],
                   area: shapely.Geometry, tolerance: float, clip: bool, config: PrepareConfig,
                   dropped: list[DroppedFeature], feedback: Feedback) -> tuple[_Prepared, LayerStats]:
    """Drop exact duplicates, repair, select (whole features by representative point, or cut), simplify."""
    stats = LayerStats(name, len(layer), 0, 0, vertices_in=vertex_count(layer.geoms))
    raw = source_ids(layer, prefix, keys)
    duplicate = exact_duplicates(layer.geoms, raw)
    ids = unique_ids(raw, skip=duplicate)
    shared = sum(1 for i, wid in enumerate(ids) if wid != raw[i])
    if shared:
        feedback.warning(f"{name}: {shared} feature(s) share their source id with another of a different "
                         "shape; all are kept, with _2, _3… added to their wit_id.")
    rep = repair_polygons(layer.geoms, layer.unclosed_rings, config.min_area, config.sliver_thinness,
                          config.sliver_width)
    rep.reasons[(rep.reasons == None) & duplicate] = "duplicate"  # noqa: E711 (numpy)
    stats.repaired = rep.counts
    keep = _drop(layer, ids, rep.reasons, stats, dropped)
    geoms = rep.geoms[keep]
    context = None
    if clip:
        # A neighbour that only touches the area, or reaches into it by less than the simplification
        # tolerance (a district bordering the chosen dong), is outside: clipping it would leave slivers.
        inner = area.buffer(-max(tolerance, 10 * GRID_SIZE))
        inside = shapely.intersects(inner if not inner.is_empty else area, geoms)
    else:
        points = shapely.point_on_surface(geoms)
        if config.owner is not None:  # a tile: its owner rule decides, also a few mm outside the area
            inside = np.asarray(config.owner(shapely.get_coordinates(points)), dtype=bool)
        else:
            inside = shapely.contains(area, points)
        if config.context_margin > 0:  # neighbours simplified with the kept ones, so shared walls match
            context = inside | shapely.intersects(area.buffer(config.context_margin), geoms)
    stats.outside_area = int(np.count_nonzero(~inside))
    feedback.check_canceled()
    if context is not None:
        simplified, stats.arcs_kept = simplify_shared(geoms[context], tolerance, feedback=feedback)
        ours = inside[context]
        crossing = ~ours & shapely.intersects(area, simplified)
        if config.owner is not None:  # a neighbour no tile of the run owns is not in the model: ground here
            crossing[crossing] = config.owner.in_run(shapely.get_coordinates(points[context][crossing]))
        foreign = layer.take(keep[context][crossing])
        foreign.geoms = simplified[crossing]
        others = _Prepared(step_layers.FOREIGN_BUILDINGS, foreign, [ids[i] for i in keep[context][crossing]])
        keep, geoms = keep[context][ours], simplified[ours]
        out = layer.take(keep)
        out.geoms = geoms
        stats.features_out, stats.vertices_out = len(out), vertex_count(geoms)
        return _Prepared(name, out, [ids[i] for i in keep], foreign=others), stats
    keep, geoms = keep[inside], geoms[inside]
    geoms, stats.arcs_kept = simplify_shared(geoms, tolerance, feedback=feedback)
    if clip:
        geoms = polygonal(shapely.intersection(geoms, area, grid_size=GRID_SIZE))
        emptied = shapely.is_missing(geoms)
        stats.outside_area += int(np.count_nonzero(emptied))
        keep, geoms = keep[~emptied], orient(geoms[~emptied])[0]
    out = layer.take(keep)
    out.geoms = geoms
    stats.features_out, stats.vertices_out = len(out), vertex_count(geoms)
    return _Prepared(name, out, [ids[i] for i in keep]), stats


#: building ids: the road-name-address building number, else its parts, NGII's feature id UFID, OpenStreetMap's osm_id
BUILDING_KEYS = [("BD_MGT_SN",), ("SIG_CD", "BUL_MAN_NO"), ("UFID",), ("osm_id",)]
BUILDING_PREFIX = "BLD"


def building_reach(area: shapely.Geometry, context_margin: float) -> shapely.Geometry:
    """Where the buildings of ``area`` are read from: the area, grown by the neighbours' ``context_margin``
    (a tile's; see ``PrepareConfig.owner``)."""
    return area.buffer(context_margin) if context_margin > 0 else area


#: road ids: juso road sections share one (merged), NGII's feature id UFID, OpenStreetMap's osm_id
ROAD_KEYS = [("SIG_CD", "RDS_MAN_NO"), ("UFID",), ("osm_id",)]


def _road_layer(layer: VectorLayer, area: shapely.Geometry, config: PrepareConfig,
                dropped: list[DroppedFeature], feedback: Feedback) -> tuple[_Prepared, LayerStats]:
    """Road polygons as the road surfaces they are (``_polygon_layer``, not simplified, cut to the area),
    centre lines (and anything else, dropped as ``wrong_type``) through ``_road_lines``; one layer."""
    surface = np.isin(shapely.get_type_id(layer.geoms), (3, 6))
    parts = []
    if surface.any():
        polygons = layer.take(np.flatnonzero(surface))
        feedback.info(f"roads: {len(polygons)} road polygon(s) of {Path(layer.path).name} are road surfaces as "
                      "they are (repaired, cut to the study area, not simplified).")
        prep, stats = _polygon_layer(polygons, step_layers.PREPARED_ROADS, "RD", ROAD_KEYS, area, 0.0, True, config,
                                     dropped, feedback)
        prep.extra_fields = _ROAD_EXTRA
        prep.extra_columns = {step_layers.ROAD_WIDTH: [None] * len(prep.ids),
                              step_layers.ROAD_WIDTH_SOURCE: ["surface"] * len(prep.ids)}
        parts.append((prep, stats))
    if not surface.all() or not parts:  # an empty layer too: its stats say so
        parts.append(_road_lines(layer.take(np.flatnonzero(~surface)), area, config, dropped, feedback))
    if len(parts) == 1:
        return parts[0]
    (a, sa), (b, sb) = parts
    merged = VectorLayer(a.layer.path, a.layer.name, np.concatenate([a.layer.geoms, b.layer.geoms]),
                         np.concatenate([a.layer.fids, b.layer.fids]), a.layer.fields,
                         {k: a.layer.columns[k] + b.layer.columns[k] for k in a.layer.columns}, a.layer.crs,
                         a.layer.encoding, np.concatenate([a.layer.unclosed_rings, b.layer.unclosed_rings]))
    stats = LayerStats(sa.layer, sa.features_in + sb.features_in, sa.features_out + sb.features_out,
                       sa.outside_area + sb.outside_area,
                       {k: sa.repaired.get(k, 0) + sb.repaired.get(k, 0) for k in REPAIR_KINDS},
                       {k: sa.dropped.get(k, 0) + sb.dropped.get(k, 0) for k in DROP_REASONS if k in sa.dropped
                        or k in sb.dropped}, sa.vertices_in + sb.vertices_in, sa.vertices_out + sb.vertices_out,
                       sa.arcs_kept + sb.arcs_kept)
    columns = {k: a.extra_columns[k] + b.extra_columns[k] for k in a.extra_columns}
    return _Prepared(a.name, merged, unique_ids(a.ids + b.ids), _ROAD_EXTRA, columns), stats


_ROAD_EXTRA = [FieldDef(step_layers.ROAD_WIDTH, ogr.OFTReal), FieldDef(step_layers.ROAD_WIDTH_SOURCE, ogr.OFTString)]


def _road_lines(layer: VectorLayer, area: shapely.Geometry, config: PrepareConfig,
                dropped: list[DroppedFeature], feedback: Feedback) -> tuple[_Prepared, LayerStats]:
    """Centre lines → simplified → buffered by width/2 (``roads.WidthRule``) → clipped → junction overlaps removed."""
    name = step_layers.PREPARED_ROADS
    ids = source_ids(layer, "RD", ROAD_KEYS)  # sections of one road share it: merged below
    stats = LayerStats(name, len(layer), 0, 0, vertices_in=vertex_count(layer.geoms))
    g = layer.geoms
    reasons = np.full(len(g), None, dtype=object)
    reasons[shapely.is_missing(g) | shapely.is_empty(g)] = "no_geometry"
    reasons[(reasons == None) & non_finite(g)] = "non_finite"  # noqa: E711 (numpy)
    reasons[(reasons == None) & ~np.isin(shapely.get_type_id(g), (1, 5))] = "wrong_type"  # noqa: E711 (numpy)
    live = reasons == None  # noqa: E711 (numpy)
    layer.geoms = g.copy()
    layer.geoms[live] = shapely.remove_repeated_points(g[live], REPEATED_POINT_TOLERANCE)
    stats.repaired = dict.fromkeys(REPAIR_KINDS, 0)
    stats.repaired["repeated_vertex"] = int(np.count_nonzero(
        shapely.get_num_coordinates(layer.geoms[live]) < shapely.get_num_coordinates(g[live])))
    reasons[live & (shapely.length(layer.geoms) <= REPEATED_POINT_TOLERANCE)] = "collapsed"
    keep = _drop(layer, ids, reasons, stats, dropped)
    inside = shapely.intersects(area, layer.geoms[keep])
    stats.outside_area = int(np.count_nonzero(~inside))
    keep = keep[inside]
    roads, ids = _dissolve_by_id(layer.take(keep), [ids[i] for i in keep])
    roads.geoms = shapely.simplify(roads.geoms, config.road_tolerance, preserve_topology=False)
    widths, sources = road_widths(roads, config.default_road_width, feedback)
    feedback.check_canceled()
    polys = shapely.buffer(roads.geoms, widths / 2, quad_segs=ROAD_QUAD_SEGS, cap_style="round", join_style="round")
    polys = polygonal(shapely.intersection(polys, area))
    cut = np.flatnonzero(~shapely.is_missing(polys))
    polys[cut] = separate_roads(polys[cut], widths[cut], [ids[i] for i in cut])
    covered = shapely.is_missing(polys)
    for i in np.flatnonzero(covered):
        stats.dropped["covered"] = stats.dropped.get("covered", 0) + 1
        dropped.append(DroppedFeature(name, int(roads.fids[i]), ids[i], "covered"))
    ok = np.flatnonzero(~covered)
    out = roads.take(ok)
    out.geoms = orient(polys[ok])[0]
    stats.features_out, stats.vertices_out = len(out), vertex_count(out.geoms)
    columns = {step_layers.ROAD_WIDTH: [float(widths[i]) for i in ok],
               step_layers.ROAD_WIDTH_SOURCE: [sources[i] for i in ok]}
    return _Prepared(name, out, [ids[i] for i in ok], _ROAD_EXTRA, columns), stats


def _reasons(stats: LayerStats) -> str:
    """``12 feature(s): 10 non_finite, 2 duplicate`` (nothing when none was dropped)."""
    counts = ", ".join(f"{n} {reason}" for reason, n in stats.dropped.items() if n)
    return f"{sum(stats.dropped.values())} feature(s): {counts}" if counts else "0 features"


def _output_layer(prep: _Prepared, feedback: Feedback) -> OutputLayer:
    """Source fields (renamed where they clash with ours, see ``keep_source_fields``) + ours."""
    ours = [FieldDef(step_layers.WIT_ID, ogr.OFTString)] + prep.extra_fields
    kept = keep_source_fields(prep.layer.fields, [f.name for f in ours], prep.name, feedback)
    fields = [out for out, _ in kept] + ours
    columns = {out.name: prep.layer.columns[source] for out, source in kept}
    columns[step_layers.WIT_ID] = prep.ids
    columns.update(prep.extra_columns)
    return OutputLayer(prep.name, fields, columns, prep.layer.geoms)


def _table(name: str, rows: list[dict[str, object]], fields: list[FieldDef]) -> OutputLayer:
    """A non-spatial GeoPackage table from dict rows."""
    return OutputLayer(name, fields, {f.name: [r[f.name] for r in rows] for f in fields})


def prepare_vectors(buildings: str | os.PathLike | None, roads: str | os.PathLike | None,
                    districts: str | os.PathLike | None, area: StudyArea, output_gpkg: str | os.PathLike,
                    config: PrepareConfig | None = None, feedback: Feedback = SILENT) -> PrepareReport:
    """Run wit:preparevectors: clean layers in ``output_gpkg`` plus the stats table (and its CSV).

    Any of the three inputs may be None; a district code needs ``districts``. Raises InputError
    for unusable inputs or a study area that misses every layer; a cancelled run writes nothing.
    """
    config = config or PrepareConfig()
    target = _check_config(config)
    if not (buildings or roads or districts):
        raise InputError("Give at least one input layer (buildings, roads or districts).")
    output_gpkg = Path(output_gpkg)
    csv_path = Path(config.stats_csv) if config.stats_csv else output_gpkg.with_name(f"{output_gpkg.stem}_stats.csv")
    refuse_overlap([(output_gpkg, False), (csv_path, False)], [buildings, roads, districts, area.path])
    if area.kind == "district" and not districts:
        raise InputError("A district code needs the district (legal-dong, TL_SCCO_EMD) layer as input.")
    feedback.progress(0)
    # a district code is looked up in the whole district layer; other areas filter every read
    polygon = None if area.kind == "district" else area.geometry(target, feedback=feedback.scaled(0, 5))
    district_layer = None
    if districts:
        district_layer = _read(str(districts), "districts", DISTRICT_FIELDS, target, config, polygon,
                               feedback.scaled(5, 10))
    if polygon is None:
        if district_layer is None:  # (a district area without the layer is refused above)
            raise InputError("A district code needs the district (legal-dong, TL_SCCO_EMD) layer as input.")
        polygon = area.geometry(target, replace(district_layer, geoms=repair_polygons(district_layer.geoms).geoms))
    feedback.info(f"Study area: {polygon.area / 1e6:.3f} km², bounds {tuple(round(v, 1) for v in polygon.bounds)}")
    shapely.prepare(polygon)
    dropped: list[DroppedFeature] = []
    results: list[tuple[_Prepared, LayerStats]] = []
    if buildings:
        layer = _read(str(buildings), "buildings", BUILDING_FIELDS, target, config,
                      building_reach(polygon, config.context_margin), feedback.scaled(10, 30))
        results.append(_polygon_layer(layer, step_layers.PREPARED_BUILDINGS, BUILDING_PREFIX, BUILDING_KEYS, polygon,
                                      config.building_tolerance, False, config, dropped, feedback.scaled(30, 70)))
    if roads:
        feedback.check_canceled()
        layer = _read(str(roads), "roads", ROAD_FIELDS, target, config, polygon, feedback.scaled(70, 75))
        results.append(_road_layer(layer, polygon, config, dropped, feedback.scaled(75, 82)))
    if district_layer is not None:
        feedback.check_canceled()
        results.append(_polygon_layer(district_layer, step_layers.PREPARED_DISTRICTS, "EMD", [("EMD_CD",)], polygon,
                                      config.district_tolerance, True, config, dropped, feedback.scaled(82, 88)))
    stats = [s for _, s in results]
    for s in stats:
        feedback.info(f"{s.layer}: {s.features_in} in, {s.features_out} out, "
                      f"vertices {s.vertices_in} → {s.vertices_out}")
        if s.dropped:
            feedback.warning(f"{s.layer}: dropped {_reasons(s)} (each listed in the '{DROPPED_TABLE}' table).")
    # a tile may keep nothing (its buildings all its neighbours' or too small): its model is then its ground
    if not any(s.features_out for s in stats) and any(s.dropped for s in stats) and config.owner is None:
        raise InputError("No feature could be kept: " + "; ".join(
            f"{s.layer}: {s.features_in} read, {s.outside_area} outside the study area, dropped {_reasons(s)}"
            for s in stats) + ". Nothing was written.")
    if not any(s.features_out for s in stats) and config.owner is None:  # a tile may own nothing: its ground
        raise InputError(f"The study area (bounds {tuple(round(v, 1) for v in polygon.bounds)} in "
                         f"{config.target_crs}) does not overlap any feature of the input layers.")
    for s in stats:
        if s.features_out == 0 and config.owner is None:
            feedback.warning(f"{s.layer}: no feature lies in the study area.")
    rows = [s.row() for s in stats]
    stat_fields = [FieldDef(c, ogr.OFTString if c == "layer" else ogr.OFTInteger64) for c in rows[0]]
    drop_fields = [FieldDef("layer", ogr.OFTString), FieldDef("source_fid", ogr.OFTInteger64),
                   FieldDef(step_layers.WIT_ID, ogr.OFTString), FieldDef("reason", ogr.OFTString)]
    layers = [_output_layer(p, feedback) for p, _ in results]
    layers += [_output_layer(p.foreign, feedback) for p, _ in results if p.foreign is not None]
    layers.append(OutputLayer(step_layers.STUDY_AREA, [FieldDef("area_m2", ogr.OFTReal)], {"area_m2": [polygon.area]},
                              np.array([polygon], dtype=object)))
    layers += [_table(STATS_TABLE, rows, stat_fields), _table(DROPPED_TABLE, [asdict(d) for d in dropped], drop_fields)]
    feedback.check_canceled()
    with atomic_file(output_gpkg) as tmp:
        write_gpkg(tmp, layers, target, feedback.scaled(88, 99))
        with atomic_file(csv_path) as tmp_csv:
            with open(tmp_csv, "w", newline="", encoding="utf-8") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
                writer.writeheader()
                writer.writerows(rows)
            feedback.check_canceled()
    feedback.progress(100)
    names = [p.name for p, _ in results] + [p.foreign.name for p, _ in results if p.foreign is not None]
    return PrepareReport(str(output_gpkg), str(csv_path), names, stats, dropped, polygon)
