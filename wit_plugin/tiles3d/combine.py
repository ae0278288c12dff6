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

import functools
import json
import math
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io import jsontext
from ..infra.io.digests import digest
from ..infra.io.fileio import aside_of, publish, restore_folder, staging_folder
from ..mosaic.georef import OK, georeference_sheets
from .geo import Georeference, column_major, union_region
from .group_buildings import GROUP_BUILDINGS, Candidates, read_tile_buildings
from .group_summary import load_meta, load_parts, save_summary, summary_path
from .groups import (
    GROUP_DIR,
    Group,
    GroupPlan,
    Terrain,
    join_terrain,
    plan_groups,
    raster_extent,
    sample_terrain,
    write_group,
)
from .tileset import TILESET_FILE
from .web import compress_glb

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
                      margin: float = 50.0, feedback: Feedback = SILENT, web: bool = False,
                      fingerprints: dict[str, str] | None = None,
                      inputs_digest: Callable[[BaseGeometry], str] | None = None, force: bool = False) -> RunTileset:
    """Write ``<output>/tileset.json`` and ``<output>/3dtiles-groups/`` over the tiles ``tiles`` (sheet →
    tile folder relative to ``output``), whose areas (target CRS, clipped to the run) are ``areas``.
    The groups' terrain comes from ``dem`` and the ``ortho`` sheets (none without them); ``web``: the
    groups' contents in the web profile, as the tiles'. Tiles without a tileset are left out; none at all
    is an error.

    An update: with the tiles' ``fingerprints`` and ``inputs_digest`` (the digest of the DEM and orthoimage
    a lowest group reads over an area), a group whose fingerprint (its children's and those inputs') is the
    one recorded in its summary keeps its files as they are; the others are built again, their parents
    taking the unchanged children's parts from their summaries. Nothing changed: nothing is written.
    ``force``: every group built again."""
    out = Path(output)
    restore_folder(out / GROUP_DIR, aside_of(out / GROUP_DIR))  # a refresh killed between its two renames
    roots = _tile_roots(out, tiles)
    run = _plan_run(out, roots, areas, fingerprints, inputs_digest, force)
    if run.unchanged(out):
        feedback.info("3D Tiles: no group changed; the groups and the run's tileset are kept as they are.")
        return _report(out, len(roots), run.plans, run.metas, [_from_meta(n, _summary(run.metas, n)) for n in run.top])
    with staging_folder(out, ".wit-groups-") as staging, staging_folder(out, ".wit-ortho-") as scratch:
        georef = Georeference(target_crs)
        ground = _GroundSampler(dem, ortho, scratch, target_crs, georef.crs, sheet_crs, margin)
        builder = _GroupBuilder(out, tiles, roots, run, staging / GROUP_DIR, ground, georef, web, feedback)
        nodes = builder.write()
        feedback.info(f"3D Tiles: {len(builder.built)} group(s) built, {len(run.current)} kept as they were.")
        document = _run_document(nodes)
        if _json_bytes(document) != _read_bytes(out / TILESET_FILE):
            _write_json(staging / TILESET_FILE, document)
        publish(staging, out)  # the groups, then the run's tileset.json
    return _report(out, len(roots), run.plans, builder.metas, nodes)


def _tile_roots(out: Path, tiles: dict[str, str]) -> dict[str, _Node]:
    """The root of each tile's tileset (sheet → its node), for the tiles that have one; none is an error."""
    roots = {}
    for sheet, folder in tiles.items():
        path = out / folder / TILE_TILESET
        if path.is_file():
            root = json.loads(path.read_text(encoding="utf-8"))["root"]
            roots[sheet] = _Node(f"{folder}/{TILE_TILESET}", root["boundingVolume"]["region"],
                                 float(root["geometricError"]), 0)
    if not roots:
        raise InputError(f"No tile of {out} has a 3D Tiles tileset to combine.")
    return roots


@dataclass
class _RunPlan:
    """The groups over a run's tiles, and which of them an earlier run left as they should be."""

    plans: dict[str, GroupPlan]
    top: list[str]
    areas: dict[str, BaseGeometry]
    prints: dict[str, str | None]
    metas: dict[str, dict | None]  # each group's summary in the output (None: it has none)
    current: set[str]  # the groups kept as they are

    def unchanged(self, out: Path) -> bool:
        """Whether every group is current, no other is in the output, and the run's tileset is the one written."""
        previous = out / GROUP_DIR
        if self.current != set(self.plans) or \
                sorted(previous.glob("*.json")) != sorted(previous / f"{n}.json" for n in self.plans):
            return False
        document = _run_document([_from_meta(n, _summary(self.metas, n)) for n in self.top])
        return _json_bytes(document) == _read_bytes(out / TILESET_FILE)


def _plan_run(out: Path, roots: dict[str, _Node], areas: dict[str, BaseGeometry], fingerprints: dict[str, str] | None,
              inputs_digest: Callable[[BaseGeometry], str] | None, force: bool) -> _RunPlan:
    """Plan the groups over the tiles ``roots`` and compare each one's fingerprint with its summary's."""
    plans, top = plan_groups(list(roots))
    group_areas = {name: shapely.union_all([areas[t] for t in plan.tiles]) for name, plan in plans.items()}
    prints = _fingerprints(plans, group_areas, fingerprints, inputs_digest)
    previous = out / GROUP_DIR
    metas = {name: load_meta(summary_path(previous, name)) for name in plans}
    current = {name for name, meta in metas.items() if not force and meta and prints[name] is not None
               and meta["fingerprint"] == prints[name] and all((previous / f).is_file() for f in meta["files"])}
    return _RunPlan(plans, top, group_areas, prints, metas, current)


class _GroundSampler:
    """A lowest group's coarse terrain from the DEM and the orthoimage sheets near it; the sheets are
    georeferenced (as VRTs in ``scratch``) the first time a group needs them."""

    def __init__(self, dem: str | None, ortho: list[str], scratch: Path, target_crs: str, crs: pyproj.CRS,
                 sheet_crs: str, margin: float):
        self.dem, self.ortho, self.scratch = dem, ortho, scratch
        self.target_crs, self.crs, self.sheet_crs, self.margin = target_crs, crs, sheet_crs, margin

    @functools.cached_property
    def _sheets(self) -> tuple[list[str], np.ndarray]:
        """The georeferenced sheets and their extents."""
        sheets = georeference_sheets(self.ortho, self.scratch, self.target_crs, self.sheet_crs, self.margin, fmt="VRT")
        vrts = [r.output for r in sheets if r.status == OK and r.output is not None]
        extents = shapely.box(*np.array([raster_extent(v) for v in vrts]).T) if vrts else np.empty(0, dtype=object)
        return vrts, extents

    def terrain(self, area: BaseGeometry) -> Terrain | None:
        """The terrain over ``area``; None without a DEM, or where no orthoimage sheet lies."""
        if not (self.dem and self.ortho):
            return None
        vrts, extents = self._sheets
        near = [vrts[k] for k in np.flatnonzero(shapely.intersects(extents, area))] if vrts else []
        return sample_terrain(area, self.crs, self.dem, near) if near else None


class _GroupBuilder:
    """Writes a run's groups into ``folder``: the current ones linked from the output's, the others built
    again, each after its children (so that it is made of their terrain and buildings, let go once it is
    written). ``metas``: every group's summary, ``built``: the groups built again."""

    def __init__(self, out: Path, tiles: dict[str, str], roots: dict[str, _Node], run: _RunPlan, folder: Path,
                 ground: _GroundSampler, georef: Georeference, web: bool, feedback: Feedback):
        self.out, self.tiles, self.roots, self.run, self.folder = out, tiles, roots, run, folder
        self.ground, self.georef, self.web, self.feedback = ground, georef, web, feedback
        self.previous = out / GROUP_DIR
        self.metas = dict(run.metas)
        self.built: list[str] = []

    def write(self) -> list[_Node]:
        """Write every group; the top ones, as the run's tileset refers to them."""
        self.folder.mkdir()
        for name in self.run.current:
            for file in _summary(self.metas, name)["files"]:
                _link(self.previous / file, self.folder / file)
        return [self.node(name, False) for name in self.run.top]

    def node(self, name: str, parts: bool) -> _Node:
        """The child ``name`` as its parent refers to it; with its terrain and buildings when ``parts``."""
        if name in self.roots:
            node = self.roots[name]
            lod1 = self.out / self.tiles[name] / TILE_LOD1
            node.buildings = read_tile_buildings(str(lod1)) if lod1.is_file() else Candidates([])
            return node
        if name in self.run.current:
            child = _from_meta(name, _summary(self.metas, name))
            if parts:
                child.terrain, child.buildings = load_parts(summary_path(self.previous, name))
            return child
        return self.build(name)

    def build(self, name: str) -> _Node:
        """Write the group ``name`` (its content, its tileset file, its summary) after its children."""
        plan = self.run.plans[name]
        children = [self.node(child, True) for child in plan.children]
        self.feedback.check_canceled()
        area = self.run.areas[name]
        terrain = self.ground.terrain(area) if plan.over_tiles else \
            join_terrain([c.terrain for c in children if c.terrain is not None], area)
        buildings = Candidates.join([c.buildings for c in children if c.buildings is not None]).largest(
            GROUP_BUILDINGS)  # (every child has its buildings: node() gives them)
        content = write_group(name, area, terrain, buildings, self.georef, self.folder)
        if content and self.web:
            glb = self.folder / content.uri
            glb.write_bytes(compress_glb(glb.read_bytes()))
        error = max([c.error for c in children] + ([content.error] if content else []))
        region = union_region([c.region for c in children] + ([content.region] if content else []))
        file = self.folder / f"{name}.json"
        _write_json(file, _group_document(self.out, children, content, region, error))
        depth = 1 + max(c.depth for c in children)
        meta = {"fingerprint": self.run.prints[name], "region": region, "error": error, "depth": depth,
                "buildings": len(buildings.ids), "terrain": terrain is not None, "json_bytes": file.stat().st_size,
                "files": [file.name, summary_path(self.folder, name).name] + ([content.uri] if content else []),
                "bytes": file.stat().st_size + ((self.folder / content.uri).stat().st_size if content else 0)}
        save_summary(summary_path(self.folder, name), meta, terrain, buildings)
        self.metas[name] = meta
        self.built.append(name)
        for child in children:  # what the parent needs of them is in `terrain` and `buildings`
            child.terrain = child.buildings = None
        return _Node(f"{GROUP_DIR}/{name}.json", region, error, depth, terrain, buildings)


def _group_document(out: Path, children: list[_Node], content: Group | None, region: list[float],
                    error: float) -> dict:
    """A group's tileset file: its content in its own frame, then its children as external tilesets, each
    with the inverse frame (so that a child's own root places it in ECEF as before)."""
    inverse = column_major(np.linalg.inv(content.frame)) if content else None
    refs = [_reference(c, Path(os.path.relpath(out / c.uri, out / GROUP_DIR)).as_posix(), inverse) for c in children]
    root = {"boundingVolume": {"region": region}, "geometricError": error, "refine": "REPLACE"}
    if content:
        root.update(transform=column_major(content.frame), content={"uri": content.uri})
    root["children"] = refs
    return {"asset": {"version": "1.1", "generator": GENERATOR}, "geometricError": error, "root": root}


def _report(out: Path, tiles: int, plans: dict[str, GroupPlan], metas: dict[str, dict | None],
            top: list[_Node]) -> RunTileset:
    """What the run's tileset holds: the groups' summaries (``metas``), the top groups, the written files."""
    result = RunTileset(str(out / TILESET_FILE), tiles=tiles, groups=len(plans))
    for name in plans:
        _count(result, name, _summary(metas, name))
    result.levels = max(n.depth for n in top)
    result.root_bytes = (out / TILESET_FILE).stat().st_size
    result.largest_file_bytes = max(result.largest_file_bytes, result.root_bytes)
    return result


def remove_run_tileset(output: str | Path) -> None:
    """The run's tileset and groups an earlier run wrote, for a run without 3D Tiles (its tiles have none)."""
    out = Path(output)
    restore_folder(out / GROUP_DIR, aside_of(out / GROUP_DIR))
    shutil.rmtree(out / GROUP_DIR, ignore_errors=True)
    (out / TILESET_FILE).unlink(missing_ok=True)


def _fingerprints(plans: dict[str, GroupPlan], areas: dict[str, BaseGeometry], tiles: dict[str, str] | None,
                  inputs_digest: Callable[[BaseGeometry], str] | None) -> dict[str, str | None]:
    """Each group's fingerprint: its children's and, over tiles, the inputs it reads itself (None for all
    without the tiles' fingerprints: every group is then built)."""
    prints: dict[str, str | None] = {}

    def of(name: str) -> str | None:
        if name not in plans:  # a tile
            return (tiles or {}).get(name)
        if name not in prints:
            plan = plans[name]
            children = [of(c) for c in plan.children]
            own = inputs_digest(areas[name]) if plan.over_tiles and inputs_digest else ""
            known = [c for c in children if c is not None]
            prints[name] = digest(name, own, *known) if tiles is not None and len(known) == len(children) else None
        return prints[name]

    return {name: of(name) for name in plans}


def _summary(metas: dict[str, dict | None], name: str) -> dict:
    """The summary of group ``name``, which it has: a current group's (its files are kept), or a built one's."""
    meta = metas[name]
    if meta is None:
        raise InputError(f"The 3D Tiles group {name} has no summary in {GROUP_DIR}/.")
    return meta


def _from_meta(name: str, meta: dict) -> _Node:
    return _Node(f"{GROUP_DIR}/{name}.json", meta["region"], meta["error"], meta["depth"])


def _count(result: RunTileset, name: str, meta: dict) -> None:
    """Add a group (its summary's ``meta``) to what ``result`` says of the groups."""
    result.group_bytes += meta["bytes"]
    result.buildings += meta["buildings"]
    result.largest_file_bytes = max(result.largest_file_bytes, meta["json_bytes"])
    result.without_terrain += not meta["terrain"]
    result.errors[name] = round(meta["error"], 3)


def _link(source: Path, target: Path) -> None:
    """``source`` also at ``target``, as it is: a hard link, else a copy with its times."""
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def _read_bytes(path: Path) -> bytes | None:
    return path.read_bytes() if path.is_file() else None


def _reference(node: _Node, uri: str, transform: list[float] | None) -> dict:
    """A child referring to ``node``'s tileset: its region, its root's error, the parent's inverse frame."""
    ref = {"boundingVolume": {"region": node.region}, "geometricError": node.error, "content": {"uri": uri}}
    if transform is not None:
        ref["transform"] = transform
    return ref


def _run_document(top: list[_Node]) -> dict:
    """The run's tileset over its top groups."""
    return _root_document([_reference(n, n.uri, None) for n in top])


def _root_document(children: list[dict]) -> dict:
    """The run's tileset: a root without content over ``children``, whose error is its diagonal, so that
    a viewer opens it from any distance it is seen from (with a smaller one the whole run would vanish
    when seen from afar)."""
    region = union_region([c["boundingVolume"]["region"] for c in children])
    error = max(max(c["geometricError"] for c in children), region_diagonal(region))
    root = {"boundingVolume": {"region": region}, "geometricError": error, "refine": "ADD", "children": children}
    return {"asset": {"version": "1.1", "generator": GENERATOR}, "geometricError": 2.0 * error, "root": root}


def _json_bytes(document: dict) -> bytes:
    return jsontext.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")


def _write_json(path: Path, document: dict) -> None:
    path.write_bytes(_json_bytes(document))


def tile_areas(polygons: dict[str, BaseGeometry], run_area: BaseGeometry) -> dict[str, BaseGeometry]:
    """Each tile's polygon clipped to the run's area."""
    return {sheet: shapely.intersection(run_area, polygon) for sheet, polygon in polygons.items()}

