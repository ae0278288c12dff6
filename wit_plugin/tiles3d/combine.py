"""One 3D Tiles 1.1 tileset over the tiles of a tiled run (``wit:citymodeltiles``).

Each tile's worker writes its own tileset (``tiles/<sheet>/3dtiles/tileset.json``, see ``tileset``);
the run's ``tileset.json`` at the top of the output folder refers to them as external tilesets
(3D Tiles 1.1 §"External tilesets"), each with its tileset's region and geometric error, below their
group (``groups``: the sheet one scale up, with a coarse terrain of its own) and a root without
content. A viewer then streams the whole run as one model: far away the groups' coarse terrain, then
a tile's tileset only when it comes into view. Regions are in EPSG:4979 and are not changed by
transforms, so they are taken from the tiles' roots as written; a tile below a group carries the
inverse of the group's transform, so that its own root places it in ECEF as before.
"""
from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..fileio import atomic_file
from .geo import column_major, union_region
from .groups import Group
from .tileset import TILESET_FILE

#: where each tile's tileset lies in its tile folder (the chain's ``3dtiles`` output)
TILE_TILESET = f"3dtiles/{TILESET_FILE}"
EARTH_RADIUS = 6_371_000.0  # m


def region_diagonal(region: list[float]) -> float:
    """The ground diagonal of a 3D Tiles region (radians) in metres, on a sphere of the Earth's mean radius."""
    west, south, east, north = region[:4]
    width = (east - west) * EARTH_RADIUS * math.cos((south + north) / 2)
    return math.hypot(width, (north - south) * EARTH_RADIUS)


def write_run_tileset(output: str | Path, tile_folders: Iterable[str], groups: dict[str, list[str]] | None = None,
                      contents: dict[str, Group | None] | None = None) -> tuple[str, int]:
    """Write ``<output>/tileset.json`` over the tilesets of ``tile_folders`` (relative to ``output``);
    (its path, the number of tiles in it). With ``groups`` (name → its tile folders) the tiles hang below
    their group, which shows ``contents[name]`` (``groups``) until a viewer comes close. Tiles without a
    tileset are left out; none at all is an error."""
    out = Path(output)
    tiles = {}
    for folder in tile_folders:
        path = out / folder / TILE_TILESET
        if not path.is_file():
            continue
        document = json.loads(path.read_text(encoding="utf-8"))
        tiles[folder] = {"boundingVolume": {"region": document["root"]["boundingVolume"]["region"]},
                         "geometricError": document["geometricError"],
                         "content": {"uri": f"{folder}/{TILE_TILESET}"}}
    if not tiles:
        raise InputError(f"No tile of {out} has a 3D Tiles tileset to combine.")
    children = list(tiles.values()) if groups is None else [
        _group_node([tiles[f] for f in folders if f in tiles], (contents or {}).get(name))
        for name, folders in sorted(groups.items()) if any(f in tiles for f in folders)]
    root = _container(children)
    document = {"asset": {"version": "1.1", "generator": "WIT City Model (wit:citymodeltiles)"},
                "geometricError": 2.0 * root["geometricError"], "root": root}
    target = out / TILESET_FILE
    with atomic_file(target) as tmp:
        Path(tmp).write_text(json.dumps(document, ensure_ascii=False), encoding="utf-8")
    return str(target), len(tiles)


def _container(children: list[dict]) -> dict:
    """A tile without content over ``children``: its error is its diagonal, so that a viewer opens it from
    any distance it is seen from (with a smaller one the whole run would vanish when seen from afar)."""
    region = union_region([c["boundingVolume"]["region"] for c in children])
    error = max(max(c["geometricError"] for c in children), region_diagonal(region))
    return {"boundingVolume": {"region": region}, "geometricError": error, "refine": "ADD", "children": children}


def _group_node(children: list[dict], content: Group | None) -> dict:
    """A group of tiles showing its coarse ``content`` until refined into them (or a plain container)."""
    if content is None:
        return _container(children)
    inverse = column_major(np.linalg.inv(content.frame))  # the tiles' own roots place them in ECEF
    region = union_region([content.region] + [c["boundingVolume"]["region"] for c in children])
    error = max(content.error, 2.0 * max(c["geometricError"] for c in children))
    return {"boundingVolume": {"region": region}, "geometricError": error, "refine": "REPLACE",
            "transform": column_major(content.frame), "content": {"uri": content.uri},
            "children": [dict(c, transform=inverse) for c in children]}
