"""What a group above the tiles hands to its parent, kept beside its files (``<name>.summary.npz``).

A group's parent joins its children's coarse terrains and largest buildings (``groups``, ``group_buildings``).
When a run is updated, only the groups over a changed tile are built again; their parents take the unchanged
children's parts from here, exactly as they were (floats, ids and attributes as written), so a group built
again equals the one a fresh run writes. ``meta`` also holds the group's fingerprint, the names of its files,
and what its parent's tileset refers to (region, geometric error, depth).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import shapely

from ..infra.io import jsontext
from .group_buildings import Candidates
from .groups import Terrain

SUFFIX = ".summary.npz"


def summary_path(folder: Path, name: str) -> Path:
    return folder / f"{name}{SUFFIX}"


def save_summary(path: Path, meta: dict, terrain: Terrain | None, buildings: Candidates) -> None:
    """Write ``meta`` (plain values), the terrain (or none) and the buildings into ``path``."""
    wkb = [shapely.to_wkb(g) for g in buildings.footprints]
    parts = {"meta": np.array(jsontext.dumps(meta)), "fields": np.array(jsontext.dumps(buildings.fields)),
             "ids": np.array(jsontext.dumps(buildings.ids, ensure_ascii=False)),
             "attributes": np.array(jsontext.dumps(buildings.attributes, ensure_ascii=False, default=_tagged)),
             "footprints": np.frombuffer(b"".join(wkb), dtype=np.uint8),
             "offsets": np.cumsum([0] + [len(w) for w in wkb]), "base": buildings.base, "top": buildings.top,
             "size": buildings.size, "dropped": np.array(buildings.dropped)}
    if terrain is not None:
        parts.update(rect=np.array(terrain.rect), heights=terrain.heights, image=terrain.image,
                     terrain_error=np.array(terrain.error))
    with open(path, "wb") as handle:
        np.savez(handle, **parts)


def load_meta(path: Path) -> dict | None:
    """The ``meta`` of a summary; None when there is none or it cannot be read."""
    try:
        with np.load(path) as data:
            return json.loads(str(data["meta"]))
    except (OSError, ValueError, KeyError):
        return None


def load_parts(path: Path) -> tuple[Terrain | None, Candidates]:
    """The terrain (None if the group has none) and the buildings, as ``save_summary`` was given them."""
    with np.load(path) as data:
        offsets = data["offsets"]
        blob = data["footprints"].tobytes()
        footprints = np.array([shapely.from_wkb(blob[a:b]) for a, b in zip(offsets[:-1], offsets[1:])],
                              dtype=object)
        buildings = Candidates([tuple(f) for f in json.loads(str(data["fields"]))], json.loads(str(data["ids"])),
                               footprints, data["base"], data["top"], data["size"],
                               json.loads(str(data["attributes"]), object_hook=_untagged), float(data["dropped"]))
        terrain = None
        if "rect" in data:
            x0, y0, x1, y1 = (float(v) for v in data["rect"])
            terrain = Terrain((x0, y0, x1, y1), data["heights"], data["image"], float(data["terrain_error"]))
    return terrain, buildings


def _tagged(value: object) -> dict:
    """Attribute values JSON has no type for, kept exactly."""
    if isinstance(value, (bytes, bytearray)):
        return {"$bytes": bytes(value).hex()}
    raise TypeError(f"An attribute value of type {type(value).__name__} cannot be kept in a group summary.")


def _untagged(value: dict) -> object:
    return bytes.fromhex(value["$bytes"]) if set(value) == {"$bytes"} else value
