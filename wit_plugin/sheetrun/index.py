"""``index.gpkg``: the map of a tiled run, one row per tile, updated as tiles finish (so a run resumes).

Layer ``tiles``: the tile polygon and ``sheet``, ``status`` (pending, done, failed, or empty: the tile owns
no building and its model holds the ground alone, terrain and roads, so the tiles' terrain has no hole),
``buildings``, ``triangles``, ``seconds``, ``peak_mb``, ``gml`` (relative to the output folder)
and ``error``. Written by OGR, read with SQLite.
"""
from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pyproj
from osgeo import ogr

from ..io.fileio import atomic_file
from ..io.vector_io import FieldDef, OutputLayer, write_gpkg
from .plan import Tile

INDEX_FILE = "index.gpkg"
INDEX_LAYER = "tiles"
PENDING, DONE, FAILED, EMPTY = "pending", "done", "failed", "empty"
FIELDS = (("sheet", ogr.OFTString), ("status", ogr.OFTString), ("buildings", ogr.OFTInteger64),
          ("triangles", ogr.OFTInteger64), ("seconds", ogr.OFTReal), ("peak_mb", ogr.OFTReal),
          ("gml", ogr.OFTString), ("error", ogr.OFTString))
RESULT_FIELDS = tuple(name for name, _ in FIELDS if name != "sheet")


def read_index(output: Path) -> dict[str, dict]:
    """sheet → row of an existing index (empty when there is none)."""
    path = output / INDEX_FILE
    if not path.is_file():
        return {}
    with sqlite3.connect(path) as db:
        db.row_factory = sqlite3.Row
        try:
            rows = db.execute(f"SELECT * FROM {INDEX_LAYER}")  # nosec B608  # a constant table name
            return {row["sheet"]: dict(row) for row in rows}
        except sqlite3.DatabaseError:
            return {}


def write_index(output: Path, tiles: list[Tile], crs: str, previous: dict[str, dict]) -> None:
    """A new index of ``tiles``, keeping the rows of ``previous`` (a resumed run) for the same sheets."""
    columns: dict[str, list] = {name: [] for name, _ in FIELDS}
    for tile in tiles:
        row = previous.get(tile.sheet, {})
        for name, _ in FIELDS:
            default = PENDING if name == "status" else None
            columns[name].append(tile.sheet if name == "sheet" else row.get(name, default))
    layer = OutputLayer(INDEX_LAYER, [FieldDef(name, kind) for name, kind in FIELDS], columns,
                        np.array([t.polygon for t in tiles], dtype=object))
    with atomic_file(output / INDEX_FILE) as tmp:
        write_gpkg(tmp, [layer], pyproj.CRS.from_user_input(crs))


def update_row(output: Path, sheet: str, result: dict) -> None:
    """Record one finished tile (through OGR: the GeoPackage's R-tree triggers need its SQL functions)."""
    ds = ogr.Open(str(output / INDEX_FILE), 1)
    layer = ds.GetLayerByName(INDEX_LAYER)
    layer.SetAttributeFilter(f"sheet = '{sheet}'")
    for feature in layer:
        for name in RESULT_FIELDS:
            value = result.get(name)
            if value is None:
                feature.SetFieldNull(name)
            else:
                feature.SetField(name, value)
        layer.SetFeature(feature)
    ds = None
