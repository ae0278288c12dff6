"""One 3D Tiles 1.1 tileset over the tiles of a tiled run (``wit:citymodeltiles``).

Each tile's worker writes its own tileset (``tiles/<sheet>/3dtiles/tileset.json``, see ``tileset``);
the run's ``tileset.json`` at the top of the output folder refers to them as external tilesets
(3D Tiles 1.1 §"External tilesets"): a root without content whose children are the tiles, each with
its tileset's region and geometric error. A viewer then streams the whole run as one model and
loads a tile's tileset only when it comes into view. Regions are in EPSG:4979 and are not changed
by the tiles' transforms, so they are taken from the tiles' roots as written.
"""
from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

from ..errors import InputError
from ..fileio import atomic_file
from .geo import union_region
from .tileset import TILESET_FILE

#: where each tile's tileset lies in its tile folder (the chain's ``3dtiles`` output)
TILE_TILESET = f"3dtiles/{TILESET_FILE}"
EARTH_RADIUS = 6_371_000.0  # m


def region_diagonal(region: list[float]) -> float:
    """The ground diagonal of a 3D Tiles region (radians) in metres, on a sphere of the Earth's mean radius."""
    west, south, east, north = region[:4]
    width = (east - west) * EARTH_RADIUS * math.cos((south + north) / 2)
    return math.hypot(width, (north - south) * EARTH_RADIUS)


def write_run_tileset(output: str | Path, tile_folders: Iterable[str]) -> tuple[str, int]:
    """Write ``<output>/tileset.json`` over the tilesets of ``tile_folders`` (relative to ``output``);
    (its path, the number of tiles in it). Tiles without a tileset are left out; none at all is an error."""
    out = Path(output)
    children = []
    for folder in tile_folders:
        path = out / folder / TILE_TILESET
        if not path.is_file():
            continue
        document = json.loads(path.read_text(encoding="utf-8"))
        children.append({"boundingVolume": {"region": document["root"]["boundingVolume"]["region"]},
                         "geometricError": document["geometricError"],
                         "content": {"uri": f"{folder}/{TILE_TILESET}"}})
    if not children:
        raise InputError(f"No tile of {out} has a 3D Tiles tileset to combine.")
    region = union_region([c["boundingVolume"]["region"] for c in children])
    # the root has no content of its own: its error must make a viewer open it at any distance the
    # run is seen from (its diagonal), or the whole run would vanish when seen from afar
    error = max(max(c["geometricError"] for c in children), region_diagonal(region))
    root = {"boundingVolume": {"region": region}, "geometricError": error, "refine": "ADD", "children": children}
    document = {"asset": {"version": "1.1", "generator": "WIT City Model (wit:citymodeltiles)"},
                "geometricError": 2.0 * error, "root": root}
    target = out / TILESET_FILE
    with atomic_file(target) as tmp:
        Path(tmp).write_text(json.dumps(document, ensure_ascii=False), encoding="utf-8")
    return str(target), len(children)
