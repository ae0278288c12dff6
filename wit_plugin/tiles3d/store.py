"""Staging store: the chain's layers copied once, in batches, into a temporary SQLite file indexed by tile.

The export then reads one tile at a time, so memory holds one tile's features whatever the size of
the model (the inputs need no spatial index of their own, and are never written to):

* ``building``: one row per building, from its ``ground`` face: the leaf tile holding the centre of
  its footprint (a Morton code, so a subtree of the quadtree is one range of codes), its size (the
  larger of footprint diagonal and height, to keep the largest ones in coarse tiles) and its
  attributes (JSON, every field of the LoD1 layer but the per-face ones).
* ``face``: roof and wall faces (WKB), joined to their building; ``tex_roof`` their texture rows.
* ``tri``: TIN triangles (9 float64), with the leaf of their centroid; ``spill`` lists the other
  leaves a triangle's extent reaches (a leaf's coarse terrain is sampled from its own triangles and
  those), a few per cent of them; ``tex_tri`` their texture rows (image number, 3 uv pairs).

Batches are read as columns (GDAL's Arrow interface where it exists) and written with one
``executemany`` each; no spatial index is built (an R-tree insert per triangle cost more than all the rest).
"""
from __future__ import annotations

import json
import math
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
from osgeo import ogr

from .. import bulk_read, model
from ..errors import InputError
from ..feedback import Feedback
from ..meshes import parse_texcoords, triangle_vertices
from ..vector_io import open_step_layer

FACE_KINDS = {"roof": 0, "wall": 1}  # ground faces are never seen and are not exported
SURFACES = {name: number for number, name in enumerate(model.TIN_SURFACES)}
PER_FACE_FIELDS = (model.FACE_TYPE, model.FACE_NUMBER)
BATCH = 20_000


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
    for bit in range(20):
        code |= ((col >> bit) & 1) << (2 * bit) | ((row >> bit) & 1) << (2 * bit + 1)
    return code


@dataclass
class BuildingRows:
    """The buildings of one tile and their faces (roof uv where the texture row fits the ring)."""

    ids: list[str]
    attributes: list[list]
    face_building: np.ndarray  # (f,) index into ids
    face_kind: np.ndarray  # (f,) FACE_KINDS value
    polygons: np.ndarray  # (f,) shapely PolygonZ
    roof_image: np.ndarray  # (f,) image number, -1 = untextured
    roof_uv: list[np.ndarray | None]  # per face: (ring points, 2) or None


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
            CREATE TABLE building (wit_id TEXT PRIMARY KEY, leaf INTEGER, size REAL, attrs TEXT) WITHOUT ROWID;
            CREATE TABLE face (wit_id TEXT, face_no INTEGER, kind INTEGER, wkb BLOB);
            CREATE TABLE tex_roof (wit_id TEXT, face_no INTEGER, image INTEGER, uv BLOB,
                                   PRIMARY KEY (wit_id, face_no)) WITHOUT ROWID;
            CREATE TABLE tri (id INTEGER PRIMARY KEY, leaf INTEGER, surface INTEGER, xyz BLOB);
            CREATE TABLE spill (leaf INTEGER, tri INTEGER);
            CREATE TABLE tex_tri (tri_id INTEGER PRIMARY KEY, image INTEGER, uv BLOB);
        """)
        self.images: list[str] = []
        self.fields: list[tuple[str, int]] = []  # building attributes: (name, OGR field type)
        self.orphan_faces = 0

    def close(self) -> None:
        self.db.close()

    # --- filling -----------------------------------------------------------------------------

    def add_textures(self, folder: str, feedback: Feedback) -> None:
        path = Path(folder) / model.TEXCOORD_FILE
        fields = (model.TEX_TARGET, model.TEX_FEATURE, model.TEX_FACE, model.TEX_IMAGE, model.TEX_COORDS)
        ds, layer, _ = open_step_layer(str(path), model.TEXCOORD_TABLE, model.TEXCOORD_ROLE, fields)
        numbers: dict[str, int] = {}
        for batch in _column_batches(layer, fields):
            feedback.check_canceled()
            try:
                uv, counts = parse_texcoords(_texts(batch[model.TEX_COORDS]))
            except ValueError:
                raise InputError(f"The texture table {path} has malformed texture coordinates: "
                                 "re-run wit:wittexture.") from None
            uv = uv.astype(np.float32)
            starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            names, image = np.unique(_texts(batch[model.TEX_IMAGE]), return_inverse=True)
            image = np.array([numbers.setdefault(name, len(numbers)) for name in names.tolist()], dtype=np.int64)[image]
            target = np.array(_texts(batch[model.TEX_TARGET]), dtype=object)
            roof = np.flatnonzero(target == "roof")
            features = np.array(_texts(batch[model.TEX_FEATURE]), dtype=object)
            self.db.executemany("INSERT OR REPLACE INTO tex_roof VALUES (?, ?, ?, ?)", [
                (features[i], int(batch[model.TEX_FACE][i] or 0), int(image[i]), uv[starts[i]:starts[i + 1]].tobytes())
                for i in roof.tolist()])
            tri = np.flatnonzero((target != "roof") & (counts == 4))
            try:
                ids = features[tri].astype(np.int64)
            except ValueError:
                raise InputError(f"The texture table {path} names a TIN triangle by a non-numeric id: "
                                 "re-run wit:wittexture.") from None
            corners = uv[starts[tri][:, None] + np.arange(3)].reshape(len(tri), 6)
            self.db.executemany("INSERT OR REPLACE INTO tex_tri VALUES (?, ?, ?)",
                                zip(ids.tolist(), image[tri].tolist(), map(bytes, corners)))
        del layer, ds
        self.images = sorted(numbers, key=numbers.get)
        self.db.executemany("INSERT INTO image VALUES (?, ?)", [(n, name) for name, n in numbers.items()])

    def add_buildings(self, path: str, grid: Grid, feedback: Feedback) -> int:
        """Buildings from their ground faces, then their roof and wall faces; returns the building count."""
        ds, layer, _ = open_step_layer(path, model.LOD1_LAYER, model.LOD1_ROLE,
                                       (model.WIT_ID, model.FACE_TYPE, model.FACE_NUMBER, model.HEIGHT))
        defn = layer.GetLayerDefn()
        kept = [i for i in range(defn.GetFieldCount()) if defn.GetFieldDefn(i).GetName() not in PER_FACE_FIELDS]
        self.fields = [(defn.GetFieldDefn(i).GetName(), defn.GetFieldDefn(i).GetType()) for i in kept]
        wit_id, height = defn.GetFieldIndex(model.WIT_ID), defn.GetFieldIndex(model.HEIGHT)
        layer.SetAttributeFilter(f"{model.FACE_TYPE} = 'ground'")
        rows: list[tuple] = []
        for feature in layer:
            geometry = feature.GetGeometryRef()
            if geometry is None or geometry.IsEmpty():
                continue
            xmin, xmax, ymin, ymax = geometry.GetEnvelope()
            attrs = [None if feature.IsFieldNull(i) else feature.GetField(i) for i in kept]
            rows.append((feature.GetField(wit_id), (xmin + xmax) / 2, (ymin + ymax) / 2,
                         max(math.hypot(xmax - xmin, ymax - ymin), feature.GetField(height) or 0.0),
                         json.dumps(attrs, ensure_ascii=False)))
            if len(rows) == BATCH:
                self._insert_buildings(rows, grid)
                rows = []
                feedback.check_canceled()
        self._insert_buildings(rows, grid)
        layer.SetAttributeFilter(f"{model.FACE_TYPE} IN ('roof', 'wall')")
        for batch in _column_batches(layer, (model.WIT_ID, model.FACE_NUMBER, model.FACE_TYPE), geometry=True):
            feedback.check_canceled()
            kinds = [FACE_KINDS[k] for k in _texts(batch[model.FACE_TYPE])]
            self.db.executemany("INSERT INTO face VALUES (?, ?, ?, ?)", [
                row for row in zip(_texts(batch[model.WIT_ID]), batch[model.FACE_NUMBER].tolist(), kinds, batch[None])
                if row[3]])
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
        self.db.executemany("INSERT OR IGNORE INTO building VALUES (?, ?, ?, ?)",
                            [(r[0], int(leaf), r[3], r[4]) for r, leaf in zip(rows, leaves.tolist())])

    def add_triangles(self, path: str, grid: Grid, feedback: Feedback) -> int:
        ds, layer, _ = open_step_layer(path, model.TIN_LAYER, model.TIN_ROLE,
                                       (model.TIN_TRIANGLE_ID, model.TIN_SURFACE))
        total = 0
        for batch in _column_batches(layer, (model.TIN_TRIANGLE_ID, model.TIN_SURFACE), geometry=True):
            feedback.check_canceled()
            xyz = triangle_vertices(shapely.from_wkb(np.array(batch[None], dtype=object), on_invalid="ignore"))
            ok = np.isfinite(xyz).all(axis=(1, 2))
            ids = np.asarray(batch[model.TIN_TRIANGLE_ID], dtype=np.int64)[ok]
            names, surface = np.unique(_texts(batch[model.TIN_SURFACE]), return_inverse=True)
            surface = np.array([SURFACES.get(name, 0) for name in names.tolist()], dtype=np.int64)[surface][ok]
            xyz = xyz[ok]
            centre = xyz.mean(axis=1)
            own = grid.leaf_codes(centre[:, 0], centre[:, 1])
            try:
                self.db.executemany("INSERT INTO tri VALUES (?, ?, ?, ?)", zip(
                    ids.tolist(), own.tolist(), surface.tolist(), map(bytes, xyz.reshape(-1, 9))))
            except sqlite3.IntegrityError:
                raise InputError(f"The TIN {path} repeats triangle ids ({model.TIN_TRIANGLE_ID}): "
                                 "re-run wit:triangulateterrain.") from None
            lo, hi = xyz.min(axis=1), xyz.max(axis=1)
            spills = set()
            for x, y in ((lo[:, 0], lo[:, 1]), (hi[:, 0], lo[:, 1]), (lo[:, 0], hi[:, 1]), (hi[:, 0], hi[:, 1])):
                other = grid.leaf_codes(x, y)
                crossing = np.flatnonzero(other != own)
                spills.update(zip(other[crossing].tolist(), ids[crossing].tolist()))
            self.db.executemany("INSERT INTO spill VALUES (?, ?)", spills)
            total += len(ids)
        del layer, ds
        self.db.execute("CREATE INDEX tri_leaf ON tri (leaf)")
        self.db.execute("CREATE INDEX spill_leaf ON spill (leaf)")
        return total

    # --- reading -----------------------------------------------------------------------------

    def leaves(self) -> set[int]:
        """Codes of the leaves holding anything."""
        rows = self.db.execute("SELECT DISTINCT leaf FROM building UNION SELECT DISTINCT leaf FROM tri")
        return {leaf for (leaf,) in rows}

    def buildings(self, first: int, end: int, min_size: float = 0.0, limit: int = -1) -> BuildingRows:
        """Buildings whose leaf is in [first, end) and size ≥ ``min_size``, the largest first, at most ``limit``."""
        chosen = self.db.execute(
            "SELECT wit_id, attrs FROM building WHERE leaf >= ? AND leaf < ? AND size >= ? "
            "ORDER BY size DESC, wit_id LIMIT ?", (first, end, min_size, limit)).fetchall()
        ids = [wit_id for wit_id, _ in chosen]
        number = {wit_id: i for i, wit_id in enumerate(ids)}
        faces = []
        for part in range(0, len(ids), 500):
            marks = ",".join("?" * len(ids[part:part + 500]))
            faces += self.db.execute(
                f"SELECT f.wit_id, f.kind, f.wkb, x.image, x.uv FROM face f LEFT JOIN tex_roof x "
                f"ON x.wit_id = f.wit_id AND x.face_no = f.face_no WHERE f.wit_id IN ({marks})",
                ids[part:part + 500]).fetchall()
        return BuildingRows(
            ids, [json.loads(attrs) for _, attrs in chosen],
            np.array([number[f[0]] for f in faces], dtype=np.int64), np.array([f[1] for f in faces], dtype=np.int8),
            shapely.from_wkb(np.array([f[2] for f in faces], dtype=object), on_invalid="ignore"),
            np.array([-1 if f[3] is None else f[3] for f in faces], dtype=np.int64),
            [None if f[4] is None else np.frombuffer(f[4], dtype=np.float32).reshape(-1, 2) for f in faces])

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
        """The leaf's TIN triangles and those of its neighbours reaching into it (``leaf`` tells which)."""
        columns = "t.leaf, t.surface, t.xyz, x.image, x.uv"
        rows = self.db.execute(
            f"SELECT {columns} FROM tri t LEFT JOIN tex_tri x ON x.tri_id = t.id WHERE t.leaf = ? UNION ALL "
            f"SELECT {columns} FROM spill s JOIN tri t ON t.id = s.tri LEFT JOIN tex_tri x ON x.tri_id = t.id "
            "WHERE s.leaf = ?", (leaf, leaf)).fetchall()
        n = len(rows)
        xyz = np.frombuffer(b"".join(r[2] for r in rows), dtype=np.float64).reshape(n, 3, 3)
        uv = np.zeros((n, 3, 2), np.float32)
        textured = [i for i, r in enumerate(rows) if r[4] is not None]
        if textured:
            uv[textured] = np.frombuffer(b"".join(rows[i][4] for i in textured), dtype=np.float32).reshape(-1, 3, 2)
        return TriangleRows(xyz, np.array([r[1] for r in rows], dtype=np.int8),
                            np.array([-1 if r[3] is None else r[3] for r in rows], dtype=np.int64), uv,
                            np.array([r[0] for r in rows], dtype=np.int64))


def _column_batches(layer: ogr.Layer, fields: tuple[str, ...], geometry: bool = False) -> Iterator[dict]:
    """Batches of columns (numpy arrays; key None: the ISO WKB geometries), through GDAL's Arrow
    interface when it can take the layer (``bulk_read.arrow_ready``), else a feature loop. Text may
    come as bytes: see ``_texts``."""
    if bulk_read.arrow_ready(layer):
        geom_name = layer.GetGeometryColumn() or "geom"
        options = ["USE_MASKED_ARRAYS=NO", f"MAX_FEATURES_IN_BATCH={BATCH}", "INCLUDE_FID=NO"]
        for batch in layer.GetArrowStreamAsNumPy(options=options):
            columns = {f: batch[f] for f in fields}
            if geometry:
                columns[None] = [bytes(w) if w is not None else None for w in batch[geom_name]]
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
        columns[None] = [r[-1] for r in rows]
    return columns


def _texts(column: np.ndarray) -> list[str]:
    """A text column as str (Arrow gives UTF-8 bytes; NULL → "")."""
    return [v.decode("utf-8") if isinstance(v, bytes) else ("" if v is None else str(v)) for v in column.tolist()]
