"""One 3D Tiles 1.1 tileset over the tiles of a tiled run (``wit:citymodeltiles``), bounded at any scale.

Each tile's worker writes its own tileset (``tiles/<sheet>/3dtiles/tileset.json``, see ``tileset``).
Above them stand the groups of ``groups`` (1:5,000 sheets, 1:50,000 sheets, 1° blocks: as many levels
as the run needs), each with a coarse content of its terrain and largest buildings. Every group is a
tileset file of its own, ``3dtiles-groups/<name>.json``: its content, then its children as external
tilesets (3D Tiles 1.1 §"External tilesets") — the child groups' files or the tiles' tilesets —, each
with its region and its root's geometric error. The run's ``tileset.json`` holds a root without
content over the top groups. So no file grows with the run: a group's file lists at most 100
children, the run's file the 1° blocks; a viewer reads the files of the groups it comes close to.

Regions are in EPSG:4979 and are not changed by transforms. A group's root carries its content's
frame (ECEF ← local); each child below it carries the inverse, so that a child's own root places it
in ECEF as before. Everything is written beside the output first and moved into place at the end:
a failed run leaves the previous tileset.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..georef import OK, georeference_sheets
from ..io.fileio import atomic_file
from .geo import Georeference, column_major, union_region
from .group_buildings import GROUP_BUILDINGS, Candidates, read_tile_buildings
from .groups import GROUP_DIR, Terrain, join_terrain, plan_groups, raster_extent, sample_terrain, write_group
from .tileset import TILESET_FILE
from .web import compress_tiles

#: where each tile's tileset lies in its tile folder (the chain's ``3dtiles`` output)
TILE_TILESET = f"3dtiles/{TILESET_FILE}"
TILE_LOD1 = "lod1.gpkg"
EARTH_RADIUS = 6_371_000.0  # m
GENERATOR = "WIT City Model (wit:citymodeltiles)"


def region_diagonal(region: list[float]) -> float:
    """The ground diagonal of a 3D Tiles region (radians) in metres, on a sphere of the Earth's mean radius."""
    west, south, east, north = region[:4]
    width = (east - west) * EARTH_RADIUS * math.cos((south + north) / 2)
    return math.hypot(width, (north - south) * EARTH_RADIUS)


@dataclass
class RunTileset:
    """What ``write_run_tileset`` wrote."""

    path: str
    tiles: int = 0
    groups: int = 0
    levels: int = 0
    """Group levels between the root and the tiles (the longest path)."""
    without_terrain: int = 0
    """Groups whose content has no terrain (the DEM or the orthoimage does not cover them)."""
    buildings: int = 0
    """Buildings in all the groups' contents."""
    root_bytes: int = 0
    largest_file_bytes: int = 0
    """The largest tileset file (the run's or a group's)."""
    group_bytes: int = 0
    """Bytes of the groups' contents and files."""
    errors: dict[str, float] = field(default_factory=dict)
    """Each group's geometric error (m)."""


@dataclass
class _Node:
    """A written child, as its parent refers to it."""

    uri: str  # relative to the output folder
    region: list[float]
    error: float
    depth: int
    terrain: Terrain | None = None
    buildings: Candidates | None = None


def write_run_tileset(output: str | Path, tiles: dict[str, str], areas: dict[str, BaseGeometry],
                      dem: str | None, ortho: list[str], target_crs: str, sheet_crs: str = "EPSG:4737",
                      margin: float = 50.0, feedback: Feedback = SILENT, web: bool = False) -> RunTileset:
    """Write ``<output>/tileset.json`` and ``<output>/3dtiles-groups/`` over the tiles ``tiles`` (sheet →
    tile folder relative to ``output``), whose areas (target CRS, clipped to the run) are ``areas``.
    The groups' terrain comes from ``dem`` and the ``ortho`` sheets (none without them); ``web``: the
    groups' contents in the web profile, as the tiles'. Tiles without a tileset are left out; none at all
    is an error."""
    out = Path(output)
    roots = {}
    for sheet, folder in tiles.items():
        path = out / folder / TILE_TILESET
        if path.is_file():
            root = json.loads(path.read_text(encoding="utf-8"))["root"]
            roots[sheet] = _Node(f"{folder}/{TILE_TILESET}", root["boundingVolume"]["region"],
                                 float(root["geometricError"]), 0)
    if not roots:
        raise InputError(f"No tile of {out} has a 3D Tiles tileset to combine.")
    plans, top = plan_groups(list(roots))
    georef = Georeference(target_crs)
    result = RunTileset(str(out / TILESET_FILE), tiles=len(roots), groups=len(plans))
    staging = Path(tempfile.mkdtemp(prefix=".wit-groups-", dir=out))
    try:
        vrts = []
        if dem and ortho:
            sheets = georeference_sheets(ortho, staging / "ortho", target_crs, sheet_crs, margin, fmt="VRT")
            vrts = [r.output for r in sheets if r.status == OK]
        extents = shapely.box(*np.array([raster_extent(v) for v in vrts]).T) if vrts else np.empty(0, dtype=object)
        folder = staging / GROUP_DIR
        folder.mkdir()

        def build(name: str) -> _Node:
            if name in roots:
                node = roots[name]
                lod1 = out / tiles[name] / TILE_LOD1
                node.buildings = read_tile_buildings(str(lod1)) if lod1.is_file() else Candidates([])
                return node
            plan = plans[name]
            children = [build(child) for child in plan.children]
            feedback.check_canceled()
            area = shapely.union_all([areas[t] for t in plan.tiles])
            if plan.over_tiles:
                near = [vrts[k] for k in np.flatnonzero(shapely.intersects(extents, area))] if vrts else []
                terrain = sample_terrain(area, georef.crs, dem, near) if near else None
            else:
                terrain = join_terrain([c.terrain for c in children if c.terrain is not None], area)
            buildings = Candidates.join([c.buildings for c in children]).largest(GROUP_BUILDINGS)
            content = write_group(name, area, terrain, buildings, georef, folder)
            error = max([c.error for c in children] + ([content.error] if content else []))
            region = union_region([c.region for c in children] + ([content.region] if content else []))
            file = folder / f"{name}.json"
            inverse = column_major(np.linalg.inv(content.frame)) if content else None
            refs = [_reference(c, Path(os.path.relpath(out / c.uri, out / GROUP_DIR)).as_posix(), inverse)
                    for c in children]
            root = {"boundingVolume": {"region": region}, "geometricError": error, "refine": "REPLACE"}
            if content:
                root.update(transform=column_major(content.frame), content={"uri": content.uri})
                result.group_bytes += content.bytes
                result.buildings += content.buildings
            root["children"] = refs
            _write_json(file, {"asset": {"version": "1.1", "generator": GENERATOR}, "geometricError": error,
                               "root": root})
            size = file.stat().st_size
            result.group_bytes += size
            result.largest_file_bytes = max(result.largest_file_bytes, size)
            result.without_terrain += terrain is None
            result.errors[name] = round(error, 3)
            for child in children:  # what the parent needs of them is in `terrain` and `buildings`
                child.terrain = child.buildings = None
            return _Node(f"{GROUP_DIR}/{name}.json", region, error, 1 + max(c.depth for c in children), terrain,
                         buildings)

        nodes = [build(name) for name in top]
        result.levels = max(n.depth for n in nodes)
        if web:
            compress_tiles(folder, feedback)
            result.group_bytes = sum(file.stat().st_size for file in folder.iterdir())
        document = _root_document([_reference(n, n.uri, None) for n in nodes])
        target = out / GROUP_DIR
        if target.exists():
            shutil.rmtree(target)
        os.replace(folder, target)
        with atomic_file(out / TILESET_FILE) as tmp:
            _write_json(Path(tmp), document)
        result.root_bytes = (out / TILESET_FILE).stat().st_size
        result.largest_file_bytes = max(result.largest_file_bytes, result.root_bytes)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return result


def _reference(node: _Node, uri: str, transform: list[float] | None) -> dict:
    """A child referring to ``node``'s tileset: its region, its root's error, the parent's inverse frame."""
    ref = {"boundingVolume": {"region": node.region}, "geometricError": node.error, "content": {"uri": uri}}
    if transform is not None:
        ref["transform"] = transform
    return ref


def _root_document(children: list[dict]) -> dict:
    """The run's tileset: a root without content over ``children``, whose error is its diagonal, so that
    a viewer opens it from any distance it is seen from (with a smaller one the whole run would vanish
    when seen from afar)."""
    region = union_region([c["boundingVolume"]["region"] for c in children])
    error = max(max(c["geometricError"] for c in children), region_diagonal(region))
    root = {"boundingVolume": {"region": region}, "geometricError": error, "refine": "ADD", "children": children}
    return {"asset": {"version": "1.1", "generator": GENERATOR}, "geometricError": 2.0 * error, "root": root}


def _write_json(path: Path, document: dict) -> None:
    path.write_text(json.dumps(document, ensure_ascii=False, separators=(",", ":")), encoding="utf-8")


def tile_areas(polygons: dict[str, BaseGeometry], run_area: BaseGeometry) -> dict[str, BaseGeometry]:
    """Each tile's polygon clipped to the run's area."""
    return {sheet: shapely.intersection(run_area, polygon) for sheet, polygon in polygons.items()}

