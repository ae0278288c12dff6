"""Orthoimage tiles (and a DEM) drawn from given building and road layers, so that real vectors get a
matching image.

Layers of any schema and CRS (road-name-address TL_SPBD_BULD / TL_SPRD_MANAGE, NGII, OpenStreetMap…)
are read near the area (``vector_io.read_layer`` detects their encoding and CRS) and reprojected to
EPSG:5186. They are drawn as follows:

* Footprints are repaired as wit:preparevectors repairs them. Each one is a roof whose colour comes
  from its size and position (``rasters.roof_styles``); pitched roofs are shaded along their ridge.
  Shadows use the height the layer gives (``heights`` recognises the common fields), else the
  default.
* Road centre lines are buffered as wit:preparevectors buffers them: width from
  ``vectors.road_widths`` (the layer's width field, lanes or class, else 6 m: ``roads``), round caps and joins.
  Road polygons are drawn as they are.
* Yards around buildings and sidewalks along roads are paved; the rest is lawn, forest or bare soil.

The area is the study area clipped to the layers' extent, or that whole extent. The tiles are the
NGII 1:5,000 sheets that meet the area, after it has been grown by the buildings that cross its edge
(as the chain's terrain is grown). They are named and cut like the synthetic mode's tiles. The inputs
are only read: nothing is written beside or into them.
"""
from __future__ import annotations

import datetime
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import pyproj
import shapely

from ..buildings.heights import HeightOptions, building_height
from ..infra import mapsheet
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io import jsontext
from ..infra.io.fileio import atomic_files, refuse_overlap, source_file
from ..infra.io.vector_io import VectorLayer, layer_extent, non_finite, read_layer
from ..infra.polygons import polygonal, repair_polygons, transform
from ..prepare.area import StudyArea
from ..prepare.vectors import ROAD_QUAD_SEGS, PrepareConfig, road_widths
from ..terrain.build import covering_area
from .config import MANIFEST, SampleConfig, check_rasters
from .gangnam import GROUND_LANE
from .ortho import DEM_NAME, ORTHO_DIR, RASTER_CRS, render_tiles, sheet_envelopes, write_sample_dem
from .rasters import NATURAL, SIDEWALK, Terrain, assemble_scene, grouped, roof_styles, street_trees

YARD_WIDTH = 6.0  # m of paving drawn around every footprint
SIDEWALK_WIDTH = 2.5  # m of paving drawn along both sides of every road


@dataclass(frozen=True)
class GivenLayers:
    """The layers to draw from (file paths or ``file.gpkg|layername=x``) and where to draw.

    ``area`` None means the whole extent of the building and road layers; a district area needs
    ``districts``. ``source_crs`` is the CRS of layers that declare none, ``encoding`` that of
    shapefiles whose declaration is wrong.
    """

    buildings: str | None = None
    roads: str | None = None
    districts: str | None = None
    area: StudyArea | None = None
    source_crs: str | None = None
    encoding: str | None = None


@dataclass
class DrawnSample:
    """What ``draw_from_layers`` wrote; ``area`` (EPSG:5186) is where the tiles were asked for."""

    folder: Path
    dem: Path | None
    ortho_tiles: list[Path]
    sheets: list[str]
    area: shapely.Geometry
    counts: dict[str, int]
    manifest: Path
    tile_gains: dict[str, list[float]] = field(default_factory=dict)


def draw_from_layers(output_dir: str | Path, layers: GivenLayers, config: SampleConfig | None = None,
                     feedback: Feedback = SILENT) -> DrawnSample:
    """Render the ortho tiles (and the DEM) for ``layers`` into ``output_dir``, with a manifest
    (``config`` None: the default ``SampleConfig``).

    Nothing appears in ``output_dir`` unless every file is complete; the given layers are read only.
    """
    config = config or SampleConfig()
    check_rasters(config)
    if not (layers.buildings or layers.roads):
        raise InputError("Give a building or a road layer to draw the orthoimage from.")
    if not (config.with_ortho or config.with_dem):
        raise InputError("Nothing to generate: both the orthoimage and the DEM are switched off.")
    area = layers.area
    if area is not None and area.kind == "district" and not layers.districts:
        raise InputError("A district needs the district (legal-dong, TL_SCCO_EMD) layer as input.")
    folder = Path(output_dir)
    inputs = [layers.buildings, layers.roads, layers.districts, area.path if area else None]
    refuse_overlap([(folder, True)], [str(source_file(i)) for i in inputs if i])
    target = pyproj.CRS.from_user_input(RASTER_CRS)

    feedback.info("Finding the area of the given layers")
    region, districts = _region(layers, target, feedback.scaled(0, 3))
    sheets, drawn = _sheets_and_layers(layers, region, target, feedback.scaled(3, 12))
    if layers.districts and districts is None:
        feedback.info("The district layer is used only to find a district by code or name: not read.")
    feedback.info(f"Area: {region.area / 1e6:.3f} km², bounds {_rounded(region.bounds)} in "
                  f"{RASTER_CRS}; {len(sheets)} NGII 1:5,000 sheet(s): {', '.join(s.number for s in sheets)}")
    manifest: dict = {
        "generator": "wit_plugin.sample", "mode": "drawn from given layers", "raster_crs": RASTER_CRS,
        "config": {k: v for k, v in asdict(config).items() if k not in ("center_lon", "center_lat", "radius_m",
                                                                        "n_buildings")},
        "area": {"study_area": asdict(area) if area else "the layers' whole extent",
                 "bounds_5186": [round(v, 3) for v in region.bounds], "area_m2": round(region.area, 1)},
        "drawn_from": {kind: _describe(layer, count) for kind, (layer, count) in drawn.sources.items()}}
    if districts is not None:
        manifest["area"]["district_layer"] = _describe(districts, None)
    targets = [folder / MANIFEST] + ([folder / DEM_NAME] if config.with_dem else []) \
        + ([folder / ORTHO_DIR] if config.with_ortho else [])
    with atomic_files(targets) as tmp:
        if config.with_dem:
            feedback.info("Writing the DEM")
            manifest["dem_holes"] = write_sample_dem(tmp / DEM_NAME, drawn.cover.bounds, config.dem_cell_size,
                                                     Terrain(config.seed), config.seed, feedback.scaled(12, 20))
        if config.with_ortho:
            feedback.info(f"Rendering {len(sheets)} orthoimage tile(s) from {drawn.counts['buildings']} "
                          f"building(s) and {drawn.counts['roads']} road(s)")
            scene = assemble_scene(*drawn.scene_parts(config.seed))
            manifest["tiles"] = render_tiles(tmp, sheets, scene, config.ortho_pixel_size, config.seed,
                                             feedback.scaled(20, 100))
        tiles = [row["file"] for row in manifest.get("tiles", [])]
        counts = {**drawn.counts, "tiles": len(tiles)}
        manifest.update(files={"dem": DEM_NAME if config.with_dem else None, "ortho": tiles}, counts=counts)
        (tmp / MANIFEST).write_text(jsontext.dumps(manifest, ensure_ascii=False, indent=1, sort_keys=True),
                                    encoding="utf-8")
    feedback.progress(100.0)
    return DrawnSample(folder, folder / DEM_NAME if config.with_dem else None, [folder / t for t in tiles],
                       [s.number for s in sheets], region, counts, folder / MANIFEST,
                       {row["file"]: row["gain"] for row in manifest.get("tiles", [])})


def _region(layers: GivenLayers, target: pyproj.CRS,
            feedback: Feedback) -> tuple[shapely.Geometry, VectorLayer | None]:
    """The study area (EPSG:5186) clipped to the building and road layers' extent, or that extent;
    and the district layer when the area is a district."""
    boxes = [b for b in (layer_extent(p, target, crs=layers.source_crs) for p in (layers.buildings, layers.roads)
                         if p) if b is not None]
    if not boxes:
        raise InputError("The given building and road layers have no features.")
    extent = shapely.box(min(b[0] for b in boxes), min(b[1] for b in boxes),
                         max(b[2] for b in boxes), max(b[3] for b in boxes))
    if layers.area is None:
        return extent, None
    districts = None
    if layers.area.kind == "district" and layers.districts:  # (given: checked up front)
        districts = _read(layers.districts, layers, None, target, feedback)
        districts = replace(districts, geoms=repair_polygons(districts.geoms).geoms)
    area = layers.area.geometry(target, districts, feedback)
    region = polygonal(np.array([shapely.intersection(area, extent)], dtype=object))[0]
    if region is None or region.area <= 0:
        raise InputError(f"The study area (bounds {_rounded(area.bounds)} in {RASTER_CRS}) does not meet the "
                         f"given layers (extent {_rounded(extent.bounds)}): choose an area where they are, or "
                         "draw over their whole extent.")
    return region, districts


def _rounded(bounds) -> tuple:
    return tuple(round(v, 1) for v in bounds)


def _read(path: str, layers: GivenLayers, bbox, target: pyproj.CRS, feedback: Feedback) -> VectorLayer:
    """The features of ``path`` whose envelope meets ``bbox`` (all when None), in ``target``."""
    layer = read_layer(path, encoding=layers.encoding, crs=layers.source_crs, bbox=bbox, bbox_crs=target,
                       feedback=feedback)
    layer.geoms = transform(layer.geoms, layer.crs, target)
    return layer


def sheets_meeting(area: shapely.Geometry) -> list[mapsheet.MapSheet]:
    """The NGII 1:5,000 sheets that overlap ``area`` (EPSG:5186), as the chain's tiles are planned."""
    try:
        return [sheet for sheet, _ in mapsheet.sheets_overlapping(area, RASTER_CRS)]
    except InputError as exc:
        raise InputError(f"The area (bounds {_rounded(area.bounds)} in {RASTER_CRS}) has no NGII map sheets: "
                         f"{exc}") from None


@dataclass
class _Drawn:
    """The given features in EPSG:5186, ready to become a scene; ``cover``: the area grown by the
    buildings that cross its edge (what the chain's terrain covers); ``sources``: kind → (layer, drawn)."""

    view: shapely.Geometry
    cover: shapely.Geometry
    roofs: np.ndarray
    heights: np.ndarray
    road_surfaces: np.ndarray
    road_lines: np.ndarray
    line_widths: np.ndarray
    sources: dict[str, tuple[VectorLayer, int]]

    @property
    def counts(self) -> dict[str, int]:
        return {kind: self.sources[kind][1] if kind in self.sources else 0 for kind in ("buildings", "roads")}

    def scene_parts(self, seed: int) -> tuple:
        """The arguments of ``assemble_scene``: natural ground, paved yards and sidewalks under roads and roofs."""
        yards = grouped(shapely.buffer(self.roofs, YARD_WIDTH, quad_segs=2))
        sidewalks = grouped(shapely.buffer(self.road_surfaces, SIDEWALK_WIDTH, quad_segs=2))
        ground = np.concatenate([np.array([self.view], dtype=object), yards, sidewalks])
        classes = np.concatenate([[NATURAL], np.full(len(yards), GROUND_LANE), np.full(len(sidewalks), SIDEWALK)])
        trees = street_trees(self.road_lines, self.line_widths, np.random.default_rng([seed, 50]))
        roof_rgb, pitched = roof_styles(self.roofs, seed)
        return ((ground, classes), self.road_surfaces, self.road_lines, self.line_widths, trees, self.roofs,
                self.heights, roof_rgb, pitched)


def _sheets_and_layers(layers: GivenLayers, region: shapely.Geometry, target: pyproj.CRS,
                       feedback: Feedback) -> tuple[list[mapsheet.MapSheet], _Drawn]:
    """The sheets for the region grown by the buildings crossing its edge, and the features on them."""
    sheets = sheets_meeting(region)
    shapely.prepare(region)
    while True:  # at most twice: every building that decides the growth is read the first time
        view = _view(sheets)
        buildings = _read(layers.buildings, layers, view.bounds, target, feedback) if layers.buildings else None
        roofs, keep, reasons = _footprints(buildings) if buildings is not None else (np.array([], dtype=object),) * 3
        inside = roofs[shapely.contains(region, shapely.point_on_surface(roofs))] if len(roofs) else roofs
        cover = covering_area(region, list(inside))
        grown = sheets_meeting(cover)
        if {s.number for s in grown} <= {s.number for s in sheets}:
            break
        sheets = sorted({s.number: s for s in sheets + grown}.values(), key=lambda s: s.number)
    sources, heights = {}, np.zeros(0)
    if buildings is not None:
        sources["buildings"] = (buildings, len(roofs))
        heights = _heights(buildings, keep)
        _warn_dropped("buildings", len(buildings), reasons, feedback)
    surfaces, lines, widths = np.array([], dtype=object), np.array([], dtype=object), np.zeros(0)
    if layers.roads:
        roads = _read(layers.roads, layers, view.bounds, target, feedback)
        surfaces, lines, widths, drawn = _roads(roads, feedback)
        sources["roads"] = (roads, drawn)
    feedback.progress(100.0)
    return sheets, _Drawn(view, cover, roofs, heights, surfaces, lines, widths, sources)


def _view(sheets: list[mapsheet.MapSheet]) -> shapely.Geometry:
    """The box the tiles of ``sheets`` cover (EPSG:5186)."""
    envelopes = np.array(sheet_envelopes(sheets))
    return shapely.box(*envelopes[:, :2].min(axis=0), *envelopes[:, 2:].max(axis=0))


def _footprints(buildings: VectorLayer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The repaired footprints, the indices of the features they come from and every feature's drop
    reason (None when kept), as wit:preparevectors repairs them."""
    repaired = repair_polygons(buildings.geoms, buildings.unclosed_rings)
    keep = np.flatnonzero(repaired.reasons == None)  # noqa: E711 (numpy)
    return repaired.geoms[keep], keep, repaired.reasons


def _warn_dropped(kind: str, total: int, reasons: np.ndarray, feedback: Feedback) -> None:
    """One warning with the count of features not drawn and why."""
    dropped = [r for r in reasons if r is not None]
    if dropped:
        counts = ", ".join(f"{dropped.count(r)} {r}" for r in sorted(set(dropped)))
        feedback.warning(f"{kind}: {len(dropped)} of {total} feature(s) not drawn ({counts}).")


def _heights(buildings: VectorLayer, keep: np.ndarray) -> np.ndarray:
    """Height per kept building for its shadow: the layer's height or floor fields, else the default."""
    rule = HeightOptions().rule_for([f.name for f in buildings.fields], buildings.name)
    names = [s.name for s in rule.sources]
    return np.array([building_height({n: buildings.columns[n][i] for n in names}, rule)[0] for i in keep])


def _roads(roads: VectorLayer, feedback: Feedback) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Road surfaces (buffered centre lines, then polygons as given), centre-line parts and their widths."""
    geoms = roads.geoms
    usable = ~shapely.is_missing(geoms) & ~shapely.is_empty(geoms) & ~non_finite(geoms)
    types = shapely.get_type_id(geoms)
    line = np.flatnonzero(usable & np.isin(types, (1, 5)))
    polygon = np.flatnonzero(usable & np.isin(types, (3, 6)))
    skipped = len(roads) - len(line) - len(polygon)
    if skipped:
        feedback.warning(f"roads: {skipped} of {len(roads)} feature(s) not drawn (no usable line or polygon).")
    widths, _ = road_widths(roads.take(line), PrepareConfig.default_road_width, feedback)
    buffered = shapely.buffer(geoms[line], widths / 2, quad_segs=ROAD_QUAD_SEGS, cap_style="round",
                              join_style="round")
    areas = repair_polygons(geoms[polygon], roads.unclosed_rings[polygon], min_area=0.0).geoms
    areas = areas[~shapely.is_missing(areas)]
    parts, part_of = shapely.get_parts(geoms[line], return_index=True)
    drawn = len(line) + len(areas)
    return np.concatenate([buffered, areas]), parts, widths[part_of], drawn


def _describe(layer: VectorLayer, drawn: int | None) -> dict:
    """A given layer as the manifest records it: where it is, what it is, how many features were drawn
    (None: only read, e.g. the district layer that gives the study area)."""
    stat = source_file(layer.path).stat()
    row = {"source": layer.path, "layer": layer.name, "crs": layer.crs.to_string(), "encoding": layer.encoding,
           "features_read": len(layer), "bytes": stat.st_size,
           "modified": datetime.datetime.fromtimestamp(stat.st_mtime, datetime.timezone.utc).isoformat()}
    if drawn is not None:
        row["features_drawn"] = drawn
    return row
