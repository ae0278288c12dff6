"""``index.gpkg``: the map of a tiled run, one row per tile, updated as tiles finish (so a run resumes).

Layer ``tiles``: the tile polygon and ``sheet``, ``status`` (pending: not built for the current inputs and
settings yet; done; failed; or empty: the tile owns no building and its model holds the ground alone,
terrain and roads, so the tiles' terrain has no hole), ``buildings``, ``triangles``, ``seconds``,
``peak_mb``, ``gml`` (relative to the output folder), ``error``, ``fingerprint`` (of what the tile's files
were built from, see ``fingerprint``) and ``reason`` (why it was last built, or is to be). Written by OGR,
read with SQLite; rewritten only when its rows change.
"""
from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pyproj
from osgeo import ogr

from ..infra.io.fileio import atomic_file
from ..infra.io.vector_io import FieldDef, OutputLayer, write_gpkg
from .plan import Tile

INDEX_FILE = "index.gpkg"
INDEX_LAYER = "tiles"
PENDING, DONE, FAILED, EMPTY = "pending", "done", "failed", "empty"
FIELDS = (("sheet", ogr.OFTString), ("status", ogr.OFTString), ("buildings", ogr.OFTInteger64),
          ("triangles", ogr.OFTInteger64), ("seconds", ogr.OFTReal), ("peak_mb", ogr.OFTReal),
          ("gml", ogr.OFTString), ("error", ogr.OFTString), ("fingerprint", ogr.OFTString), ("reason", ogr.OFTString))
RESULT_FIELDS = tuple(name for name, _ in FIELDS if name != "sheet")


def read_index(output: Path) -> dict[str, dict]:
    """sheet → row (its fields of ``FIELDS``) of an existing index (empty when there is none)."""
    path = output / INDEX_FILE
    if not path.is_file():
        return {}
    names = {name for name, _ in FIELDS}
    with sqlite3.connect(path) as db:
        db.row_factory = sqlite3.Row
        try:
            rows = db.execute(f"SELECT * FROM {INDEX_LAYER}")  # nosec B608  # a constant table name
            return {row["sheet"]: {k: row[k] for k in row.keys() if k in names} for row in rows}
        except sqlite3.DatabaseError:
            return {}


def index_rows(tiles: list[Tile], rows: dict[str, dict]) -> list[dict]:
    """The index's rows for ``tiles``: their values in ``rows`` (by sheet), else pending."""
    return [{name: tile.sheet if name == "sheet" else rows.get(tile.sheet, {}).get(name, PENDING if name == "status"
                                                                                 else None) for name, _ in FIELDS}
            for tile in tiles]


def write_index(output: Path, tiles: list[Tile], crs: str, rows: dict[str, dict]) -> bool:
    """The index of ``tiles`` with ``rows`` (see ``index_rows``), unless it holds them already; written or not."""
    wanted = index_rows(tiles, rows)
    present = read_index(output)
    if list(present) == [t.sheet for t in tiles] and all(
            {name: present[row["sheet"]].get(name) for name, _ in FIELDS} == row for row in wanted):
        return False
    columns: dict[str, list] = {name: [] for name, _ in FIELDS}
    for row in wanted:
        for name, _ in FIELDS:
            columns[name].append(row[name])
    layer = OutputLayer(INDEX_LAYER, [FieldDef(name, kind) for name, kind in FIELDS], columns,
                        np.array([t.polygon for t in tiles], dtype=object))
    with atomic_file(output / INDEX_FILE) as tmp:
        write_gpkg(tmp, [layer], pyproj.CRS.from_user_input(crs))
    return True


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
