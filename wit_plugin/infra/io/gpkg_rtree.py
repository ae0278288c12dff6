"""A GeoPackage layer's R-tree spatial index, bulk-loaded: its node pages written at once, not row by row.

GDAL 3.6 (Debian 12, the QGIS 3.22 and 3.40 floor) builds the index of ``CreateSpatialIndex`` by inserting the
rows one by one into SQLite's R-tree, about 9 µs each whatever their order: 5.1 of the 8.4 s of
``wit:triangulateterrain`` on the 1 km sample's 595,000 triangles (0.8 s here). Here the rows' envelopes are packed
Sort-Tile-Recursive (sorted by x into vertical slices, each by y into full nodes, then the same one level up)
and the R-tree's three shadow tables (``%_node``, ``%_rowid``, ``%_parent``) are written in SQLite's own format
(``ext/rtree/rtree.c``): a node is a blob of the root's size, its depth (the root only) and cell count as 16-bit
big-endian integers, then cells of a 64-bit id and four 32-bit floats, big-endian; the root is node 1. Each
envelope is rounded outwards to 32-bit floats as SQLite rounds it (``rtreeValueDown``/``Up``), so the index holds
what SQLite would have inserted, and SQLite's ``rtreecheck`` finds it consistent (tested). Nodes are packed full
(SQLite's own splits leave them emptier): a later edit splits a full node as SQLite splits any.
"""
from __future__ import annotations

import sqlite3

import numpy as np

from .sql import sql_name

_CELL = np.dtype([("id", ">i8"), ("box", ">f4", 4)])  # id (row or child node), minx, maxx, miny, maxy
_TOWARDS, _AWAY = 1.0 - 1.0 / 8388608.0, 1.0 + 1.0 / 8388608.0  # SQLite's RNDTOWARDS, RNDAWAY


def outward_float32(bounds: np.ndarray) -> np.ndarray:
    """(n, 4) minx, maxx, miny, maxy (float64) as SQLite's R-tree stores them: minima rounded down, maxima up."""
    bounds = np.asarray(bounds, dtype=np.float64)
    out = bounds.astype(np.float32)
    low = np.zeros(bounds.shape, dtype=bool)
    low[:, [0, 2]] = True
    down = low & (out > bounds)  # a minimum the cast rounded up
    up = ~low & (out < bounds)  # a maximum it rounded down
    negative = bounds < 0
    out[down] = (bounds[down] * np.where(negative[down], _AWAY, _TOWARDS)).astype(np.float32)
    out[up] = (bounds[up] * np.where(negative[up], _TOWARDS, _AWAY)).astype(np.float32)
    return out


def bulk_load(db: sqlite3.Connection, rtree: str, ids: np.ndarray, bounds: np.ndarray) -> None:
    """Fill the empty 2-D R-tree virtual table ``rtree`` (created, not yet used on this connection) with ``ids``
    and their envelopes ``bounds`` (n, 4: minx, maxx, miny, maxy), through its shadow tables."""
    if not len(ids):
        return
    node, rowid, parent = (sql_name(f"{rtree}_{shadow}") for shadow in ("node", "rowid", "parent"))
    size_query = f"SELECT length(data) FROM {node} WHERE nodeno = 1"  # nosec B608  # the table's name quoted
    (node_size,) = db.execute(size_query).fetchone()
    fanout = (node_size - 4) // _CELL.itemsize
    cells = np.zeros(len(ids), dtype=_CELL)
    cells["id"], cells["box"] = ids, outward_float32(bounds)
    nodes: list[tuple[int, bytes]] = []
    pairs = []  # (row or child node, its node) of each level
    depth, next_number = 0, 2  # node 1 is the root
    while True:
        order, starts = _tiles(cells["box"], fanout)
        cells, root = cells[order], len(starts) == 1
        numbers = np.array([1]) if root else np.arange(next_number, next_number + len(starts))
        next_number += 0 if root else len(starts)
        ends = np.append(starts[1:], len(cells))
        nodes += [(number, _node_blob(cells[a:b], node_size, depth if root else 0))
                  for number, a, b in zip(numbers.tolist(), starts.tolist(), ends.tolist())]
        pairs.append(np.column_stack([cells["id"], np.repeat(numbers, ends - starts)]))
        if root:
            break
        box = cells["box"]
        above = np.zeros(len(starts), dtype=_CELL)
        above["id"] = numbers
        above["box"] = np.column_stack([np.minimum.reduceat(box[:, 0], starts), np.maximum.reduceat(box[:, 1], starts),
                                        np.minimum.reduceat(box[:, 2], starts), np.maximum.reduceat(box[:, 3], starts)])
        cells, depth = above, depth + 1
    insert = "INSERT INTO {} VALUES (?, ?)"  # (the tables' names quoted, values bound)
    db.execute(f"DELETE FROM {node}")  # nosec B608  # the table's name quoted
    db.executemany(insert.format(node), nodes)
    rows = pairs[0][np.argsort(pairs[0][:, 0], kind="stable")]  # in key order: appended to the table's B-tree
    db.executemany(insert.format(rowid), zip(rows[:, 0].tolist(), rows[:, 1].tolist()))
    if len(pairs) > 1:
        db.executemany(insert.format(parent), np.concatenate(pairs[1:]).tolist())


def _tiles(boxes: np.ndarray, fanout: int) -> tuple[np.ndarray, np.ndarray]:
    """Sort-Tile-Recursive grouping of ``boxes`` into nodes of at most ``fanout``: the boxes' order and where
    each node's run of them starts."""
    count = len(boxes)
    if count <= fanout:
        return np.arange(count), np.zeros(1, dtype=np.int64)
    slices = int(np.ceil(np.sqrt(-(-count // fanout))))
    per_slice = slices * fanout
    centre_x = boxes[:, 0].astype(np.float64) + boxes[:, 1]
    centre_y = boxes[:, 2].astype(np.float64) + boxes[:, 3]
    order = np.argsort(centre_x, kind="stable")
    starts = []
    for first in range(0, count, per_slice):
        part = order[first:first + per_slice]
        order[first:first + per_slice] = part[np.argsort(centre_y[part], kind="stable")]
        starts.append(np.arange(first, first + len(part), fanout))
    return order, np.concatenate(starts)


def _node_blob(cells: np.ndarray, node_size: int, depth: int) -> bytes:
    header = np.array([depth, len(cells)], dtype=">u2").tobytes()
    body = cells.tobytes()
    return header + body + bytes(node_size - len(header) - len(body))
