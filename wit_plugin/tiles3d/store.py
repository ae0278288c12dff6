"""Staging store: the chain's layers copied once, in batches, into a temporary SQLite file indexed by tile.

The export then reads one tile at a time, so memory holds one tile's features whatever the size of
the model, and at most ``PARSED_BUILDINGS`` buildings as parsed for the tiles drawn last (a coarse tile
draws again the largest buildings of its leaves: they are not read again); the inputs need no spatial
index of their own, and are never written to:

* ``building``: one row per building, from its ``ground`` face: the leaf tile holding the centre of
  its footprint (a Morton code, so a subtree of the quadtree is one range of codes), its size (the
  larger of footprint diagonal and height, to keep the largest ones in coarse tiles), its ground height
  and its attributes (JSON, every field of the LoD1 layer but the per-face ones).
* ``roof_box``: an R-tree of the roofs' extents, for the roofs over a tile's square (its coarse terrain
  shows them where the TIN has a building's footprint left out).
* ``face``: roof and wall faces (WKB), joined to their building; ``tex_face`` their texture rows (roofs from the
  orthoimage, walls' generated facades); ``facade`` the buildings' facade attributes (how the walls' texture
  was made), which join their attributes.
* ``tri_block``: TIN triangles in blocks, one row per leaf of their centroids and batch read (ids,
  surfaces, corners as 9 float64, image numbers, 3 uv pairs: columns of numbers in one blob each);
  ``spill_block`` the same for the triangles whose extent reaches another leaf (a leaf's coarse
  terrain is sampled from its own triangles and those), a few per cent of them, by that leaf;
  ``tex_block`` the texture table's triangle rows, blocks of a batch read each in one bucket of ids
  (``TEX_BUCKET``), sorted by id.

Batches are read as columns (GDAL's Arrow interface where it exists); triangles are written and read
in blocks (a row per triangle cost more, in and out, than all the rest of their staging), the
buildings' rows with one ``executemany`` per batch; no spatial index is built.
"""
from __future__ import annotations

import json
import math
import sqlite3
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import Feedback
from ..infra.io import bulk_read, jsontext
from ..infra.io.vector_io import open_step_layer
from ..infra.meshes import triangle_vertices
from ..infra.texcoords import decimal_integers, parse_texcoord_column, unique_texts

FACE_KINDS = {"roof": 0, "wall": 1}  # ground faces are never seen and are not exported
SURFACES = {name: number for number, name in enumerate(step_layers.TIN_SURFACES)}
PER_FACE_FIELDS = (step_layers.FACE_TYPE, step_layers.FACE_NUMBER)
BATCH = 20_000
PARSED_BUILDINGS = 20_000  # buildings kept parsed between tiles (the coarse tiles draw again the largest)
TEX_BUCKET = 20_000
"""TIN triangle ids per texture block: a batch of the texture table (in image order) holds ids from all over the TIN,
so it is stored as blocks of ids in one bucket each; a batch of TIN triangles (in id order) then meets a few blocks
of each batch, not all of them whole (the lookup in the 1 km sample's export profile: 0.38 -> 0.18 s)."""
_PLAIN_FIELDS = (ogr.OFTInteger, ogr.OFTInteger64, ogr.OFTReal, ogr.OFTString)


@dataclass(frozen=True)
class Grid:
    """The leaf grid: square leaves of ``size`` from ``origin`` (south-west corner), 2^depth a side."""

    x0: float
    y0: float
    size: float
    depth: int

    @classmethod
    def covering(cls, extent: tuple[float, float, float, float], size: float) -> Grid:
        xmin, ymin, xmax, ymax = extent
        cells = max(1, math.ceil(max(xmax - xmin, ymax - ymin) / size - 1e-9))
        return cls(xmin, ymin, size, max(0, math.ceil(math.log2(cells))))

    def leaf_codes(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Morton codes of the leaves holding the points (clipped to the grid)."""
        last = (1 << self.depth) - 1
        col = np.clip(np.floor((x - self.x0) / self.size), 0, last).astype(np.int64)
        row = np.clip(np.floor((y - self.y0) / self.size), 0, last).astype(np.int64)
        return morton(col, row)

    def rect(self, level: int, col: int, row: int) -> tuple[float, float, float, float]:
        """Extent (xmin, ymin, xmax, ymax) of the node at ``level`` (0 = root)."""
        side = self.size * (1 << (self.depth - level))
        return (self.x0 + col * side, self.y0 + row * side, self.x0 + (col + 1) * side, self.y0 + (row + 1) * side)

    def code_range(self, level: int, col: int, row: int) -> tuple[int, int]:
        """Leaf codes [first, end) under the node."""
        shift = 2 * (self.depth - level)
        first = int(morton(np.array([col]), np.array([row]))[0]) << shift
        return first, first + (1 << shift)


def morton(col: np.ndarray, row: np.ndarray) -> np.ndarray:
    """Interleave the bits of column (even bits) and row (odd bits), 20 bits each."""
    code = np.zeros(np.shape(col), dtype=np.int64)
    col, row = np.asarray(col, dtype=np.int64), np.asarray(row, dtype=np.int64)
    bits = min(20, int(max(col.max(), row.max())).bit_length()) if code.size else 0  # the higher bits are 0
    for bit in range(bits):
        code |= ((col >> bit) & 1) << (2 * bit) | ((row >> bit) & 1) << (2 * bit + 1)
    return code


@dataclass
class BuildingRows:
    """The buildings of one tile and their faces (uv where the texture row fits the ring)."""

    ids: list[str]
    attributes: list[list]
    face_building: np.ndarray  # (f,) index into ids
    face_kind: np.ndarray  # (f,) FACE_KINDS value
    polygons: np.ndarray  # (f,) shapely PolygonZ
    face_image: np.ndarray  # (f,) image number, -1 = untextured
    face_uv: list[np.ndarray | None]  # per face: (ring points, 2) or None


@dataclass
class ParsedBuilding:
    """A building's attributes and faces (kind, shapely PolygonZ, image number, uv or None), as read once: a coarse
    tile draws again buildings its leaves drew."""

    attributes: list
    faces: list[tuple[int, Any, int, np.ndarray | None]]


@dataclass
class RoofRows:
    """Roof faces (shapely PolygonZ), their image numbers (-1 = untextured), uv (per ring point, or None) and
    their building's ground height."""

    polygons: np.ndarray
    image: np.ndarray
    uv: list[np.ndarray | None]
    base: np.ndarray


@dataclass
class TriangleRows:
    """TIN triangles: corners (n, 3, 3), surface, image number (-1 untextured), uv (n, 3, 2), leaf code."""

    xyz: np.ndarray
    surface: np.ndarray
    image: np.ndarray
    uv: np.ndarray
    leaf: np.ndarray


class Store:
    """The staging database; ``build`` fills it from the step outputs."""

    def __init__(self, path: Path):
        self.db = sqlite3.connect(str(path))
        self.db.executescript("""
            PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF; PRAGMA temp_store = FILE;
            CREATE TABLE image (id INTEGER PRIMARY KEY, name TEXT UNIQUE);
            CREATE TABLE building (wit_id TEXT PRIMARY KEY, leaf INTEGER, size REAL, base REAL, attrs TEXT)
                WITHOUT ROWID;
            CREATE TABLE face (id INTEGER PRIMARY KEY, wit_id TEXT, face_no INTEGER, kind INTEGER, wkb BLOB);
            CREATE VIRTUAL TABLE roof_box USING rtree(id, xmin, xmax, ymin, ymax);
            CREATE TABLE roof_leaf (leaf INTEGER PRIMARY KEY);
            CREATE TABLE tex_face (wit_id TEXT, face_no INTEGER, image INTEGER, uv BLOB,
                                   PRIMARY KEY (wit_id, face_no)) WITHOUT ROWID;
            CREATE TABLE facade (wit_id TEXT PRIMARY KEY, attrs TEXT) WITHOUT ROWID;
            CREATE TABLE tri_block (leaf INTEGER, ids BLOB, surface BLOB, xyz BLOB, image BLOB, uv BLOB);
            CREATE TABLE spill_block (leaf INTEGER, own BLOB, surface BLOB, xyz BLOB, image BLOB, uv BLOB);
            CREATE TABLE tex_block (first INTEGER, last INTEGER, ids BLOB, image BLOB, uv BLOB);
        """)
        self.images: list[str] = []
        self.fields: list[tuple[str, int]] = []  # building attributes: (name, OGR field type)
        self.facade_fields: list[tuple[str, int]] = []  # of the facade table, after the LoD1 layer's
        self.orphan_faces = 0
        self._parsed: OrderedDict[str, ParsedBuilding] = OrderedDict()  # by wit_id, least recently drawn first

    def close(self) -> None:
        self.db.close()

    # --- filling -----------------------------------------------------------------------------

    def add_textures(self, folder: str, feedback: Feedback) -> None:
        path = Path(folder) / step_layers.TEXCOORD_FILE
        fields = (step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE, step_layers.TEX_IMAGE,
                  step_layers.TEX_COORDS)
        ds, layer, _ = open_step_layer(str(path), step_layers.TEXCOORD_TABLE, step_layers.TEXCOORD_ROLE, fields)
        numbers: dict[str, int] = {}
        for batch in _column_batches(layer, fields):
            feedback.check_canceled()
            try:
                uv, counts = parse_texcoord_column(batch[step_layers.TEX_COORDS])
            except ValueError:
                raise InputError(f"The texture table {path} has malformed texture coordinates: "
                                 "re-run wit:wittexture.") from None
            uv = uv.astype(np.float32)
            starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            names, image = unique_texts(batch[step_layers.TEX_IMAGE])
            image = np.array([numbers.setdefault(name, len(numbers)) for name in names], dtype=np.int64)[image]
            kinds, target = unique_texts(batch[step_layers.TEX_TARGET])
            is_face = np.isin(target, [k for k, kind in enumerate(kinds) if kind in FACE_KINDS])
            face_rows = np.flatnonzero(is_face)
            features = np.asarray(batch[step_layers.TEX_FEATURE])
            faces = batch[step_layers.TEX_FACE][face_rows].tolist()
            pairs, ends = uv.tobytes(), (8 * starts).tolist()  # (slices of bytes: cheaper than of an array)
            self.db.executemany("INSERT OR REPLACE INTO tex_face VALUES (?, ?, ?, ?)", [
                (feature, int(face or 0), int(image[i]), pairs[ends[i]:ends[i + 1]])
                for feature, face, i in zip(bulk_read.texts(features[face_rows]), faces, face_rows.tolist())])
            tri = np.flatnonzero(~is_face & (counts == 4))
            try:
                ids = decimal_integers(features[tri])
            except ValueError:
                raise InputError(f"The texture table {path} names a TIN triangle by a non-numeric id: "
                                 "re-run wit:wittexture.") from None
            if len(ids):  # sorted by id; of a repeated id the last row counts (as the roofs' rows)
                order = np.argsort(ids, kind="stable")
                last = np.append(ids[order][1:] != ids[order][:-1], True)
                order = order[last]
                if len(tri) == len(counts):  # every row a triangle's (4 pairs): its first 3 taken as rows of 6
                    corners = np.take(uv.reshape(-1, 8), tri[order], axis=0)[:, :6].reshape(-1, 3, 2)
                else:
                    corners = uv[starts[tri[order]][:, None] + np.arange(3)]
                sorted_ids, sorted_image = ids[order], image[tri[order]]
                bucket = sorted_ids // TEX_BUCKET
                first = np.flatnonzero(np.append(True, bucket[1:] != bucket[:-1]))
                self.db.executemany("INSERT INTO tex_block VALUES (?, ?, ?, ?, ?)", [
                    (int(sorted_ids[a]), int(sorted_ids[b - 1]), sorted_ids[a:b].tobytes(),
                     sorted_image[a:b].tobytes(), corners[a:b].tobytes())
                    for a, b in zip(first.tolist(), [*first[1:].tolist(), len(order)])])
        del layer, ds
        self.images = sorted(numbers, key=numbers.__getitem__)
        self.db.executemany("INSERT INTO image VALUES (?, ?)", [(n, name) for name, n in numbers.items()])
        if (Path(folder) / step_layers.FACADE_FILE).is_file():
            self._add_facades(Path(folder) / step_layers.FACADE_FILE)

    def _add_facades(self, path: Path) -> None:
        """The facade table's attributes of each building (all but its id and image), read in bulk."""
        ds, layer, _ = open_step_layer(str(path), step_layers.FACADE_TABLE, step_layers.TEXCOORD_ROLE,
                                       step_layers.FACADE_FIELDS)
        defn = layer.GetLayerDefn()
        kept = [defn.GetFieldDefn(i) for i in range(defn.GetFieldCount())
                if defn.GetFieldDefn(i).GetName() not in (step_layers.WIT_ID, step_layers.FACADE_IMAGE)]
        self.facade_fields = [(f.GetName(), f.GetType()) for f in kept]
        for batch in bulk_read.batches(layer):
            columns = [[None if v is None else v.decode("utf-8") if isinstance(v, bytes) else v
                        for v in batch[f.GetName()].tolist()] for f in kept]
            self.db.executemany("INSERT OR REPLACE INTO facade VALUES (?, ?)", (
                (wit_id, jsontext.dumps(list(values), ensure_ascii=False))
                for wit_id, values in zip(bulk_read.texts(batch[step_layers.WIT_ID]), zip(*columns))))
        del layer, ds

    def add_buildings(self, path: str, grid: Grid, feedback: Feedback) -> int:
        """Buildings from their ground faces, then their roof and wall faces; returns the building count."""
        ds, layer, _ = open_step_layer(path, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE,
                                       (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER,
                                        step_layers.HEIGHT))
        defn = layer.GetLayerDefn()
        kept = [i for i in range(defn.GetFieldCount()) if defn.GetFieldDefn(i).GetName() not in PER_FACE_FIELDS]
        self.fields = [(defn.GetFieldDefn(i).GetName(), defn.GetFieldDefn(i).GetType()) for i in kept] \
            + self.facade_fields
        wit_id, height = (kept.index(defn.GetFieldIndex(name)) for name in (step_layers.WIT_ID, step_layers.HEIGHT))
        layer.SetAttributeFilter(f"{step_layers.FACE_TYPE} = 'ground'")
        rows: list[tuple] = []
        for (xmin, xmax, ymin, ymax, base), attrs in _ground_faces(layer, kept):
            rows.append((attrs[wit_id], (xmin + xmax) / 2, (ymin + ymax) / 2,
                         max(math.hypot(xmax - xmin, ymax - ymin), attrs[height] or 0.0), base,
                         jsontext.dumps(attrs, ensure_ascii=False)))
            if len(rows) == BATCH:
                self._insert_buildings(rows, grid)
                rows = []
                feedback.check_canceled()
        self._insert_buildings(rows, grid)
        layer.SetAttributeFilter(f"{step_layers.FACE_TYPE} IN ('roof', 'wall')")
        face_id = 0
        for batch in _column_batches(layer, (step_layers.WIT_ID, step_layers.FACE_NUMBER, step_layers.FACE_TYPE),
                                     geometry=True):
            feedback.check_canceled()
            kinds = np.array([FACE_KINDS[k] for k in bulk_read.texts(batch[step_layers.FACE_TYPE])], dtype=np.int64)
            wkbs = [_blob(w) for w in batch[None]]
            present = np.flatnonzero([w is not None for w in wkbs])
            ids = face_id + np.arange(len(present))
            face_id += len(present)
            names, numbers = bulk_read.texts(batch[step_layers.WIT_ID]), batch[step_layers.FACE_NUMBER].tolist()
            self.db.executemany("INSERT INTO face VALUES (?, ?, ?, ?, ?)", [
                (int(i), names[k], numbers[k], int(kinds[k]), wkbs[k]) for i, k in zip(ids.tolist(), present.tolist())])
            roofs = kinds[present] == FACE_KINDS["roof"]
            bounds = shapely.bounds(shapely.from_wkb(np.array([wkbs[k] for k in present[roofs]], dtype=object),
                                                     on_invalid="ignore"))
            finite = np.isfinite(bounds).all(axis=1)
            self.db.executemany("INSERT INTO roof_box VALUES (?, ?, ?, ?, ?)", [
                (int(i), b[0], b[2], b[1], b[3]) for i, b in zip(ids[roofs][finite].tolist(), bounds[finite].tolist())])
            reached = {int(code) for x, y in ((0, 1), (2, 1), (0, 3), (2, 3))
                       for code in grid.leaf_codes(bounds[finite, x], bounds[finite, y]).tolist()}
            self.db.executemany("INSERT OR IGNORE INTO roof_leaf VALUES (?)", [(code,) for code in reached])
        del layer, ds
        self.db.execute("CREATE INDEX face_building ON face (wit_id)")
        self.orphan_faces = self.db.execute(
            "SELECT count(*) FROM face WHERE wit_id NOT IN (SELECT wit_id FROM building)").fetchone()[0]
        self.db.execute("CREATE INDEX building_leaf ON building (leaf, size)")
        return self.db.execute("SELECT count(*) FROM building").fetchone()[0]

    def _insert_buildings(self, rows: list[tuple], grid: Grid) -> None:
        if not rows:
            return
        leaves = grid.leaf_codes(np.array([r[1] for r in rows]), np.array([r[2] for r in rows]))
        self.db.executemany("INSERT OR IGNORE INTO building VALUES (?, ?, ?, ?, ?)",
                            [(r[0], int(leaf), r[3], r[4], r[5]) for r, leaf in zip(rows, leaves.tolist())])

    def add_triangles(self, path: str, grid: Grid, feedback: Feedback) -> int:
        ds, layer, _ = open_step_layer(path, step_layers.TIN_LAYER, step_layers.TIN_ROLE,
                                       (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE))
        seen = []
        for batch in _column_batches(layer, (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE), geometry=True):
            feedback.check_canceled()
            xyz = _triangle_corners(batch[None])
            ok = np.isfinite(xyz).all(axis=(1, 2))
            ids = np.asarray(batch[step_layers.TIN_TRIANGLE_ID], dtype=np.int64)[ok]
            names, surface = unique_texts(batch[step_layers.TIN_SURFACE])
            surface = np.array([SURFACES.get(name, 0) for name in names], dtype=np.int8)[surface][ok]
            xyz = np.ascontiguousarray(xyz[ok])
            if not len(ids):
                continue
            seen.append(ids)
            image, uv = self._triangle_textures(ids)
            centre = (xyz[:, 0] + xyz[:, 1] + xyz[:, 2]) / 3  # (the mean; elementwise: faster over an axis of 3)
            own = grid.leaf_codes(centre[:, 0], centre[:, 1])
            columns = (surface, xyz, image, uv)
            order = np.argsort(own, kind="stable")
            leaves, first = np.unique(own[order], return_index=True)
            self.db.executemany("INSERT INTO tri_block VALUES (?, ?, ?, ?, ?, ?)", [
                (int(leaf), ids[part].tobytes(), *(c[part].tobytes() for c in columns))
                for leaf, part in zip(leaves.tolist(), np.split(order, first[1:]))])
            lo = np.minimum(np.minimum(xyz[:, 0], xyz[:, 1]), xyz[:, 2])
            hi = np.maximum(np.maximum(xyz[:, 0], xyz[:, 1]), xyz[:, 2])
            spills: set[tuple[int, int]] = set()  # (leaf code, triangle row)
            for x, y in ((lo[:, 0], lo[:, 1]), (hi[:, 0], lo[:, 1]), (lo[:, 0], hi[:, 1]), (hi[:, 0], hi[:, 1])):
                other = grid.leaf_codes(x, y)
                crossing = np.flatnonzero(other != own)
                spills.update(zip(other[crossing].tolist(), crossing.tolist()))
            if spills:
                pairs = np.array(list(spills), dtype=np.int64)
                order = np.argsort(pairs[:, 0], kind="stable")
                leaves, first = np.unique(pairs[order, 0], return_index=True)
                self.db.executemany("INSERT INTO spill_block VALUES (?, ?, ?, ?, ?, ?)", [
                    (int(leaf), own[pairs[part, 1]].tobytes(), *(c[pairs[part, 1]].tobytes() for c in columns))
                    for leaf, part in zip(leaves.tolist(), np.split(order, first[1:]))])
        del layer, ds
        everything = np.concatenate(seen) if seen else np.zeros(0, dtype=np.int64)
        if len(np.unique(everything)) < len(everything):
            raise InputError(f"The TIN {path} repeats triangle ids ({step_layers.TIN_TRIANGLE_ID}): "
                             "re-run wit:triangulateterrain.")
        self.db.execute("CREATE INDEX tri_block_leaf ON tri_block (leaf)")
        self.db.execute("CREATE INDEX spill_block_leaf ON spill_block (leaf)")
        return len(everything)

    def _triangle_textures(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image number (-1: none) and uv (3 pairs) of the triangles ``ids``, from the texture blocks whose id
        range meets theirs (a later block's row counts over an earlier one's): bucket by bucket (a block holds
        the ids of one), its blocks joined and sorted once, then one search (a search per block took a fifth of the
        TIN's staging); memory holds one bucket's blocks."""
        image, uv = np.full(len(ids), -1, dtype=np.int64), np.zeros((len(ids), 3, 2), dtype=np.float32)
        buckets: dict[int, list[int]] = {}
        for rowid, first in self.db.execute("SELECT rowid, first FROM tex_block WHERE first <= ? AND last >= ? "
                                            "ORDER BY rowid", (int(ids.max()), int(ids.min()))):
            buckets.setdefault(first // TEX_BUCKET, []).append(rowid)
        for bucket, rowids in buckets.items():
            rows = np.flatnonzero((ids >= bucket * TEX_BUCKET) & (ids < (bucket + 1) * TEX_BUCKET))
            if not len(rows):  # (a bucket between the batch's ids)
                continue
            marks = ",".join("?" * len(rowids))
            blocks = self.db.execute("SELECT ids, image, uv FROM tex_block "  # nosec B608  # '?' marks only go in
                                     f"WHERE rowid IN ({marks}) ORDER BY rowid", rowids).fetchall()
            known = np.frombuffer(b"".join(b[0] for b in blocks), dtype=np.int64)
            order = np.argsort(known, kind="stable")  # (stable: of a repeated id, the later block's row comes last)
            order = order[np.append(known[order][1:] != known[order][:-1], True)]
            where = np.minimum(np.searchsorted(known[order], ids[rows]), len(order) - 1)
            hit = known[order[where]] == ids[rows]
            rows, where = rows[hit], order[where[hit]]
            image[rows] = np.take(np.frombuffer(b"".join(b[1] for b in blocks), dtype=np.int64), where)
            uv[rows] = np.take(np.frombuffer(b"".join(b[2] for b in blocks), dtype=np.float32).reshape(-1, 6), where,
                               axis=0).reshape(-1, 3, 2)
        return image, uv

    # --- reading -----------------------------------------------------------------------------

    def leaves(self) -> set[int]:
        """Codes of the leaves holding anything."""
        rows = self.db.execute("SELECT DISTINCT leaf FROM building UNION SELECT DISTINCT leaf FROM tri_block")
        return {leaf for (leaf,) in rows}

    def reached(self) -> set[int]:
        """Codes of the leaves that a neighbour's triangle or roof reaches into (their coarse terrain shows it)."""
        rows = self.db.execute("SELECT DISTINCT leaf FROM spill_block UNION SELECT leaf FROM roof_leaf")
        return {leaf for (leaf,) in rows}

    def buildings(self, first: int, end: int, min_size: float = 0.0, limit: int = -1) -> BuildingRows:
        """Buildings whose leaf is in [first, end) and size ≥ ``min_size``, the largest first, at most ``limit``;
        each building's faces in their order in the LoD1 layer."""
        ids = [wit_id for (wit_id,) in self.db.execute(
            "SELECT wit_id FROM building WHERE leaf >= ? AND leaf < ? AND size >= ? ORDER BY size DESC, wit_id LIMIT ?",
            (first, end, min_size, limit))]
        self._parse([wit_id for wit_id in ids if wit_id not in self._parsed])
        parsed = [self._parsed[wit_id] for wit_id in ids]
        for wit_id in ids:
            self._parsed.move_to_end(wit_id)
        while len(self._parsed) > max(PARSED_BUILDINGS, len(ids)):
            self._parsed.popitem(last=False)
        faces = [face for building in parsed for face in building.faces]
        return BuildingRows(
            ids, [building.attributes for building in parsed],
            np.repeat(np.arange(len(ids)), [len(building.faces) for building in parsed]).astype(np.int64),
            np.array([f[0] for f in faces], dtype=np.int8), np.array([f[1] for f in faces], dtype=object),
            np.array([f[2] for f in faces], dtype=np.int64), [f[3] for f in faces])

    def _parse(self, ids: list[str]) -> None:
        """Read the attributes and faces of the buildings ``ids`` into the parsed buildings' cache."""
        no_facade = jsontext.dumps([None] * len(self.facade_fields))
        for part in range(0, len(ids), 500):
            chunk = ids[part:part + 500]
            marks = ",".join("?" * len(chunk))
            rows = self.db.execute("SELECT b.wit_id, b.attrs, f.attrs FROM building b "  # nosec B608  # '?' marks only
                                   f"LEFT JOIN facade f ON f.wit_id = b.wit_id WHERE b.wit_id IN ({marks})", chunk)
            attributes = {wit_id: json.loads(attrs) + json.loads(facade or no_facade) for wit_id, attrs, facade in rows}
            faces = self.db.execute(
                "SELECT f.wit_id, f.kind, f.wkb, x.image, x.uv FROM face f "  # nosec B608  # '?' marks only go in
                f"LEFT JOIN tex_face x ON x.wit_id = f.wit_id AND x.face_no = f.face_no WHERE f.wit_id IN ({marks}) "
                "ORDER BY f.id", chunk).fetchall()
            polygons = shapely.from_wkb(np.array([f[2] for f in faces], dtype=object), on_invalid="ignore")
            for wit_id in chunk:
                self._parsed[wit_id] = ParsedBuilding(attributes[wit_id], [])
            for (wit_id, kind, _, image, uv), polygon in zip(faces, polygons.tolist()):
                corners = None if uv is None else np.frombuffer(uv, dtype=np.float32).reshape(-1, 2)
                self._parsed[wit_id].faces.append((kind, polygon, -1 if image is None else image, corners))

    def roofs(self, rect: tuple[float, float, float, float]) -> RoofRows:
        """The roofs whose extent meets ``rect`` (xmin, ymin, xmax, ymax), with their texture rows and their
        building's ground height, by the R-tree of their extents."""
        found = self.db.execute(
            "SELECT f.wkb, x.image, x.uv, b.base FROM roof_box r JOIN face f ON f.id = r.id "
            "JOIN building b ON b.wit_id = f.wit_id "
            "LEFT JOIN tex_face x ON x.wit_id = f.wit_id AND x.face_no = f.face_no "
            "WHERE r.xmax >= ? AND r.xmin <= ? AND r.ymax >= ? AND r.ymin <= ? ORDER BY f.id",
            (rect[0], rect[2], rect[1], rect[3])).fetchall()
        return RoofRows(shapely.from_wkb(np.array([f[0] for f in found], dtype=object), on_invalid="ignore"),
                        np.array([-1 if f[1] is None else f[1] for f in found], dtype=np.int64),
                        [None if f[2] is None else np.frombuffer(f[2], dtype=np.float32).reshape(-1, 2) for f in found],
                        np.array([f[3] for f in found], dtype=np.float64))

    def largest_building(self, first: int, end: int, below: float | None = None, skip: int = 0) -> float:
        """Size of the largest building in [first, end) smaller than ``below`` (or the ``skip``-th largest)."""
        if below is not None:
            row = self.db.execute("SELECT max(size) FROM building WHERE leaf >= ? AND leaf < ? AND size < ?",
                                  (first, end, below)).fetchone()
        else:
            row = self.db.execute("SELECT size FROM building WHERE leaf >= ? AND leaf < ? "
                                  "ORDER BY size DESC, wit_id LIMIT 1 OFFSET ?", (first, end, skip)).fetchone()
        return float(row[0]) if row and row[0] is not None else 0.0

    def triangles(self, leaf: int) -> TriangleRows:
        """The leaf's TIN triangles (by id) and those of its neighbours reaching into it (``leaf`` tells which)."""
        own = self.db.execute("SELECT ids, surface, xyz, image, uv FROM tri_block WHERE leaf = ? ORDER BY rowid",
                              (leaf,)).fetchall()
        spill = self.db.execute("SELECT own, surface, xyz, image, uv FROM spill_block WHERE leaf = ? ORDER BY rowid",
                                (leaf,)).fetchall()
        ids = np.frombuffer(b"".join(r[0] for r in own), dtype=np.int64)
        order = np.concatenate([np.argsort(ids, kind="stable"), len(ids) + np.arange(
            sum(len(r[0]) for r in spill) // 8)]).astype(np.int64)
        rows = own + spill

        def column(k: int, dtype, shape: tuple[int, ...] = ()) -> np.ndarray:
            return np.frombuffer(b"".join(r[k] for r in rows), dtype=dtype).reshape((-1, *shape))[order]

        leaves = np.concatenate([np.full(len(ids), leaf, dtype=np.int64), np.frombuffer(
            b"".join(r[0] for r in spill), dtype=np.int64)])[order]
        return TriangleRows(column(2, np.float64, (3, 3)), column(1, np.int8), column(3, np.int64),
                            column(4, np.float32, (3, 2)), leaves)


def _ground_faces(layer: ogr.Layer, kept: list[int]) -> Iterator[tuple[tuple[float, ...], list]]:
    """Each face of ``layer`` with a geometry: its envelope (xmin, xmax, ymin, ymax, lowest z; as OGR's
    ``GetEnvelope3D``) and the values of the fields ``kept`` as ``GetField`` gives them (None for NULL).

    Read in column batches (``bulk_read``) when every kept field is a plain number or text, else feature by
    feature (a date, a boolean: their Python values are OGR's); the feature loop took most of the buildings'
    staging."""
    defn = layer.GetLayerDefn()
    fields = [defn.GetFieldDefn(i) for i in kept]
    if not all(f.GetType() in _PLAIN_FIELDS and f.GetSubType() == ogr.OFSTNone for f in fields):
        for feature in layer:
            geometry = feature.GetGeometryRef()
            if geometry is not None and not geometry.IsEmpty():
                yield geometry.GetEnvelope3D()[:5], [None if feature.IsFieldNull(i) else feature.GetField(i)
                                                     for i in kept]
        return
    for batch in bulk_read.batches(layer):
        geometries = shapely.from_wkb(np.array(batch["geometry"].tolist(), dtype=object))
        present = np.flatnonzero(~shapely.is_missing(geometries) & ~shapely.is_empty(geometries))
        if not len(present):
            continue
        xyz, owner = shapely.get_coordinates(geometries[present], include_z=True, return_index=True)
        xyz[~shapely.has_z(geometries[present])[owner], 2] = 0.0  # a 2D face: z 0, as OGR's envelope
        starts = np.searchsorted(owner, np.arange(len(present)))
        low, high = np.minimum.reduceat(xyz, starts), np.maximum.reduceat(xyz, starts)
        boxes = np.column_stack([low[:, 0], high[:, 0], low[:, 1], high[:, 1], low[:, 2]]).tolist()
        columns = [[v.decode("utf-8") if isinstance(v, bytes) else v for v in batch[f.GetName()][present].tolist()]
                   for f in fields]
        yield from zip(boxes, (list(values) for values in zip(*columns)))


def _column_batches(layer: ogr.Layer, fields: tuple[str, ...], geometry: bool = False) -> Iterator[dict]:
    """Batches of columns (numpy arrays; key None: the ISO WKB geometries), through GDAL's Arrow
    interface when it can take the layer (``bulk_read.arrow_ready``), else a feature loop. Text may
    come as bytes: see ``_texts``."""
    if bulk_read.arrow_ready(layer):
        geom_name = layer.GetGeometryColumn() or "geom"
        options = ["USE_MASKED_ARRAYS=NO", f"MAX_FEATURES_IN_BATCH={BATCH}", "INCLUDE_FID=NO"]
        for batch in layer.GetArrowStreamAsNumPy(options=options):
            columns: dict[str | None, Any] = {f: batch[f] for f in fields}
            if geometry:
                columns[None] = batch[geom_name]
            yield columns
        return
    rows: list[list] = []
    for feature in layer:
        geom = feature.GetGeometryRef() if geometry else None
        rows.append([feature.GetField(f) for f in fields] + [bytes(geom.ExportToIsoWkb()) if geom else None])
        if len(rows) == BATCH:
            yield _as_columns(rows, fields, geometry)
            rows = []
    if rows:
        yield _as_columns(rows, fields, geometry)


def _as_columns(rows: list[list], fields: tuple[str, ...], geometry: bool) -> dict:
    columns: dict = {f: np.array([r[k] for r in rows], dtype=object) for k, f in enumerate(fields)}
    if geometry:
        columns[None] = np.array([r[-1] for r in rows] + [None], dtype=object)[:-1]
    return columns


def _blob(wkb) -> bytes | None:
    return None if wkb is None else bytes(wkb)


#: a triangle as GDAL writes it in ISO WKB: little-endian Polygon Z, one ring of four points
_TRIANGLE_WKB = bytes([1, 0xEB, 3, 0, 0, 1, 0, 0, 0, 4, 0, 0, 0])


def _triangle_corners(wkbs: np.ndarray) -> np.ndarray:
    """(n, 3, 3) corners of triangle polygons (NaN for anything else). Read straight from the WKB
    bytes when every row is a plain triangle of the same layout (the TIN's), else through shapely."""
    if wkbs.dtype.kind == "V" and wkbs.dtype.itemsize == len(_TRIANGLE_WKB) + 96 and len(wkbs):
        raw = np.frombuffer(wkbs.tobytes(), dtype=np.uint8).reshape(len(wkbs), -1)
        if (raw[:, :len(_TRIANGLE_WKB)] == np.frombuffer(_TRIANGLE_WKB, dtype=np.uint8)).all():
            points = raw[:, len(_TRIANGLE_WKB):].copy().view("<f8").reshape(len(wkbs), 4, 3)
            return points[:, :3].astype(np.float64)
    geometries = shapely.from_wkb(np.array([_blob(w) for w in wkbs], dtype=object), on_invalid="ignore")
    return triangle_vertices(geometries)
