"""``export_tileset``: the chain's LoD1 buildings, TIN and textures as a 3D Tiles 1.1 tileset.

Tiles form a quadtree over the model's extent (model CRS), with square leaves of ``leaf_size``:

* **Leaves** (geometric error 0) hold the full detail: every building whose footprint centre lies in
  the leaf (roofs with the texture step's atlases, walls lit, with their generated facades where the texture
  step made them, else plain) and every TIN triangle whose
  centroid lies in it (terrain and roads with the ground images). Images are the texture folder's,
  copied once into ``textures/`` and referenced by every tile that uses them.
* **Upper tiles** (``refine: REPLACE``) hold a coarse version of their square: the terrain as a
  regular grid of ``grid_cells``² cells with one image of ``image_size``² texels (see ``coarse``),
  and the buildings at least as large as a grid cell (footprint diagonal or height), the largest
  first up to ``building_budget``, their roofs on the atlases' mip level *k* for a tile *k* levels
  above the leaves. The geometric error of such a tile is what it leaves out, measured: the
  largest of its grid spacing, its terrain's vertical error and the size of the largest building
  it drops — and never less than a child's.

Each tile has its own east-north-up frame (``geo``); its ``transform`` is relative to its parent's.
Bounding volumes are regions computed from the vertices, so each holds its content and children.
Building metadata: ``EXT_mesh_features`` + ``EXT_structural_metadata`` (class ``building``: every
LoD1 field but the per-face ones; see ``metadata``).

Memory: the inputs are staged into an indexed SQLite file (``store``), then tiles are written
depth-first, one at a time; only the patches of the pending parents stay in memory. The tileset is
written into a temporary folder and moved onto ``output`` at the end: a failed or cancelled run
leaves nothing.
"""
from __future__ import annotations

import bisect
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from osgeo import osr

from ..infra import step_layers
from ..infra.arrays import unique_rows_unordered
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io import jsontext
from ..infra.io.fileio import atomic_files, refuse_overlap
from ..infra.io.vector_io import open_step_layer
from .building_parts import BuildingParts, Parts, face_up, roof_triangles
from .coarse import Patch, grid_triangles, leaf_patch, parent_patch
from .geo import Georeference, column_major, union_region
from .glb import GlbBuilder, unit_normals
from .metadata import BUILDING_CLASS, building_schema, property_columns
from .store import Grid, Store, TriangleRows
from .textures import TextureSet, encode_image
from .web import compress_tiles, require_web_profile

TILESET_FILE = "tileset.json"
TILE_DIR = "tiles"
WALL_RGB = (222, 213, 196)
ROOF_RGB = (176, 120, 100)
GROUND_RGB = (150, 150, 140)
_MAX_MIP = 4


@dataclass(frozen=True)
class TilesetConfig:
    leaf_size: float = 256.0
    """Side of a leaf tile (m)."""
    grid_cells: int = 64
    """Cells a side of an upper tile's terrain grid (even)."""
    image_size: int = 512
    """Texels a side of an upper tile's terrain image (even)."""
    building_budget: int = 3000
    """Most buildings in an upper tile."""
    jpeg_quality: int = 85
    web: bool = False
    """Web profile (``web``): quantized, meshopt-compressed geometry for browsers; QGIS cannot read it."""


@dataclass
class TilesetReport:
    output: str
    tileset: str
    tiles: int = 0
    leaves: int = 0
    levels: int = 0
    buildings: int = 0
    tin_triangles: int = 0
    triangles_written: int = 0
    """Triangles in all tiles (full detail and coarse)."""
    images: int = 0
    """Image files in textures/ (levels 0 and mips)."""
    bytes_written: int = 0
    geometric_error: float = 0.0
    """The root tile's."""
    orphan_faces: int = 0
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass
class _Tile:
    json: dict | None  # None: no tile (nothing of its own below), its patch only
    frame: np.ndarray
    region: list[float]
    error: float
    patch: Patch | None


def export_tileset(lod1: str | None, tin: str | None, textures: str | None, output: str, crs: str = "EPSG:5186",
                   feedback: Feedback = SILENT, config: TilesetConfig = TilesetConfig()) -> TilesetReport:
    """Write the 3D Tiles 1.1 tileset of the chain's outputs into the folder ``output``.

    ``lod1`` (wit:extrudebuildings), ``tin`` (wit:triangulateterrain) and ``textures`` (wit:wittexture's
    folder) may each be None, but not both layers. Returns what was written; raises ``InputError``
    for unusable inputs and ``CanceledError`` on cancel (then nothing is written).
    """
    if not (lod1 or tin):
        raise InputError("Give the LoD1 buildings, the TIN, or both.")
    if config.grid_cells < 2 or config.grid_cells % 2 or config.image_size < 2 or config.image_size % 2 \
            or config.leaf_size <= 0 or config.building_budget < 1:
        raise InputError(f"Tileset settings out of range: {config}.")
    out = _check_output(Path(output), [p for p in (lod1, tin, textures) if p])
    if config.web:
        require_web_profile()
    georef = Georeference(crs)
    for path, layer, role in ((lod1, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE),
                              (tin, step_layers.TIN_LAYER, step_layers.TIN_ROLE)):
        if path:
            _check_crs(path, layer, role, georef)
    report = TilesetReport(output=str(out), tileset=str(out / TILESET_FILE))
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=".wit-stage-", dir=out.parent) as stage_dir, \
            atomic_files([out]) as tmp_dir:
        store = Store(Path(stage_dir) / "stage.sqlite")
        try:
            grid = Grid.covering(_extent(lod1, tin), config.leaf_size)
            if textures:
                store.add_textures(textures, feedback)
            feedback.progress(5.0)
            if lod1:
                report.buildings = store.add_buildings(lod1, grid, feedback)
            feedback.progress(15.0)
            if tin:
                report.tin_triangles = store.add_triangles(tin, grid, feedback)
            store.db.commit()
            report.orphan_faces = store.orphan_faces
            if report.orphan_faces:
                feedback.warning(f"{report.orphan_faces} roof/wall face(s) belong to no building with a ground "
                                 "face: left out of the tileset.")
            report.seconds["stage"] = round(time.perf_counter() - start, 3)
            feedback.progress(30.0)
            folder = tmp_dir / out.name
            folder.mkdir()
            writer = _Writer(store, grid, georef, folder, config, report, feedback,
                             TextureSet(Path(textures) if textures else None, store.images, folder,
                                        config.jpeg_quality))
            root = writer.tile(0, 0, 0)
            if root is None or root.json is None:
                raise InputError(f"Nothing to export: {lod1 or ''} {tin or ''} hold no faces or triangles.")
            root.json["transform"] = column_major(root.frame)
            if config.web:
                web_start = time.perf_counter()
                compress_tiles(folder, feedback)
                report.seconds["web"] = round(time.perf_counter() - web_start, 3)
            report.geometric_error = root.error
            side = grid.size * (1 << grid.depth)
            document = {"asset": {"version": "1.1", "generator": "WIT City Model (wit:export3dtiles)"},
                        "geometricError": max(2.0 * root.error, side / 4),
                        "root": root.json}
            (folder / TILESET_FILE).write_text(jsontext.dumps(document, ensure_ascii=False), encoding="utf-8")
            report.levels = grid.depth + 1
            report.images = len(writer.textures.written)
            report.bytes_written = folder_size(folder)
        finally:
            store.close()
    report.seconds["total"] = round(time.perf_counter() - start, 3)
    feedback.progress(100.0)
    feedback.info(f"3D Tiles: {report.tiles} tiles ({report.leaves} leaves, {report.levels} levels), "
                  f"{report.buildings} buildings, {report.tin_triangles} TIN triangles, {report.images} images, "
                  f"{report.bytes_written / 1e6:.1f} MB in {out}")
    return report


def _check_output(out: Path, inputs: list[str]) -> Path:
    """Refuse an output folder that holds an input, or that is not empty and not a tileset."""
    out = out.resolve()
    refuse_overlap([(out, True)], inputs)
    if out.is_dir() and any(out.iterdir()) and not (out / TILESET_FILE).is_file():
        raise InputError(f"The output folder {out} is not empty and holds no {TILESET_FILE}: "
                         "choose an empty or new folder (a tileset folder is replaced whole).")
    if out.exists() and not out.is_dir():
        raise InputError(f"The output {out} is a file: give a folder.")
    return out


def _check_crs(path: str, layer_name: str, role: str, georef: Georeference) -> None:
    ds, layer, _ = open_step_layer(path, layer_name, role)
    srs = layer.GetSpatialRef()
    if srs is not None:
        wanted = osr.SpatialReference()
        wanted.ImportFromWkt(georef.crs.to_wkt())
        if not srs.IsSame(wanted, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES", "CRITERION=EQUIVALENT"]):
            raise InputError(f"{path} is in {srs.GetAuthorityName(None) or '?'}:{srs.GetAuthorityCode(None) or '?'}, "
                             f"not in the model CRS {georef.crs.to_string()}: give the CRS the chain used.")
    del layer, ds


def _extent(lod1: str | None, tin: str | None) -> tuple[float, float, float, float]:
    boxes = []
    for path, name, role in ((lod1, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE),
                             (tin, step_layers.TIN_LAYER, step_layers.TIN_ROLE)):
        if path:
            ds, layer, _ = open_step_layer(path, name, role)
            if layer.GetFeatureCount() > 0:
                xmin, xmax, ymin, ymax = layer.GetExtent()
                boxes.append((xmin, ymin, xmax, ymax))
            del layer, ds
    if not boxes:
        raise InputError(f"Nothing to export: {lod1 or ''} {tin or ''} hold no faces or triangles.")
    a = np.array(boxes)
    return float(a[:, 0].min()), float(a[:, 1].min()), float(a[:, 2].max()), float(a[:, 3].max())


class _Writer:
    """Writes tiles depth-first (children before their parent)."""

    def __init__(self, store: Store, grid: Grid, georef: Georeference, folder: Path, config: TilesetConfig,
                 report: TilesetReport, feedback: Feedback, textures: TextureSet):
        self.store, self.grid, self.georef, self.folder = store, grid, georef, folder
        self.config, self.report, self.feedback, self.textures = config, report, feedback, textures
        self.owned = store.leaves()
        self.occupied = sorted(self.owned | store.reached())
        self.schema = building_schema(store.fields)
        self.parts = BuildingParts(georef)
        self.done = 0

    def tile(self, level: int, col: int, row: int) -> _Tile | None:
        first, end = self.grid.code_range(level, col, row)
        if bisect.bisect_left(self.occupied, first) == bisect.bisect_left(self.occupied, end):
            return None
        self.feedback.check_canceled()
        if level == self.grid.depth:
            if first in self.owned:
                tile = self._leaf(level, col, row, first)
                self.report.leaves += 1
            else:  # only neighbours' triangles or roofs reach in: no tile, its coarse terrain for the levels above
                tile = _Tile(None, np.eye(4), [], 0.0, self._patch(self.grid.rect(level, col, row),
                                                                    self.store.triangles(first)))
            self.done += 1
            self.feedback.progress(30.0 + 70.0 * self.done / len(self.occupied))
        else:
            children = {(dx, dy): self.tile(level + 1, 2 * col + dx, 2 * row + dy) for dy in (1, 0) for dx in (0, 1)}
            tile = self._upper(level, col, row, {k: c for k, c in children.items() if c is not None})
        if tile.json is not None:
            self.report.tiles += 1
        return tile

    # --- contents ----------------------------------------------------------------------------

    def _leaf(self, level: int, col: int, row: int, code: int) -> _Tile:
        rect = self.grid.rect(level, col, row)
        triangles = self.store.triangles(code)
        buildings = self.store.buildings(code, code + 1)
        glb, corners = GlbBuilder(), []
        heights = np.concatenate([triangles.xyz[triangles.leaf == code].reshape(-1, 3)[:, 2],
                                  shapely.get_coordinates(buildings.polygons, include_z=True)[:, 2]])
        frame = self._frame(rect, heights)
        corners += self._buildings(glb, frame, buildings, mip=0)
        own = np.flatnonzero(triangles.leaf == code)
        xyz, uv, image = triangles.xyz[own].copy(), triangles.uv[own].astype(np.float64), triangles.image[own]
        face_up(xyz, uv)
        uv[:, :, 1] = 1.0 - uv[:, :, 1]  # texture table: v up; glTF: v down
        points, inverse = unique_rows_unordered(xyz.reshape(-1, 3))  # a TIN vertex: corner of ~6 triangles
        local = self.georef.local(frame, points)[inverse].reshape(-1, 3, 3)
        for number in np.unique(image).tolist():
            mine = image == number
            if number >= 0:
                material = glb.photo_material(uri="../../" + self.textures.uri(number), name=self.store.images[number])
                glb.triangles(local[mine], material, uv[mine])
            else:
                glb.triangles(local[mine], glb.plain_material(GROUND_RGB, lit=False, name="ground"))
        corners.append(points)
        return self._finish(level, col, row, glb, frame, corners, [], 0.0, self._patch(rect, triangles))

    def _patch(self, rect: tuple[float, float, float, float], triangles: TriangleRows) -> Patch:
        """A leaf square's coarse terrain: of the TIN ``triangles`` meeting it and the roofs over it."""
        return leaf_patch(triangles, self._roofs_over(rect), rect, self.config.grid_cells, self.config.image_size // 2,
                          self.textures if self.textures.folder else None)

    def _roofs_over(self, rect: tuple[float, float, float, float]) -> TriangleRows:
        """The roofs over ``rect`` as triangles at their building's ground height, for its coarse terrain."""
        roofs = self.store.roofs(rect)
        if not len(roofs.polygons):
            return TriangleRows(np.empty((0, 3, 3)), np.empty(0, dtype=np.int8), np.empty(0, dtype=np.int64),
                                np.empty((0, 3, 2), dtype=np.float32), np.empty(0, dtype=np.int64))
        xyz, uv, image, face = roof_triangles(roofs.polygons, roofs.uv, roofs.image)
        xyz[:, :, 2] = roofs.base[face][:, None]
        return TriangleRows(xyz, np.zeros(len(xyz), dtype=np.int8), image, uv.astype(np.float32),
                            np.zeros(len(xyz), dtype=np.int64))

    def _upper(self, level: int, col: int, row: int, children: dict[tuple[int, int], _Tile]) -> _Tile:
        rect = self.grid.rect(level, col, row)
        first, end = self.grid.code_range(level, col, row)
        patches = {key: child.patch for key, child in children.items() if child.patch is not None}
        patch = parent_patch(patches, self.config.grid_cells, self.config.image_size)
        for child in children.values():
            child.patch = None  # the parent's patch holds what is needed from now on
        children = {key: child for key, child in children.items() if child.json is not None}
        if not children:  # nothing of its own below: its coarse terrain goes on up, no tile
            return _Tile(None, np.eye(4), [], patch.error, patch)
        cell = (rect[2] - rect[0]) / self.config.grid_cells
        budget = self.config.building_budget
        buildings = self.store.buildings(first, end, min_size=cell, limit=budget)
        dropped = (self.store.largest_building(first, end, skip=budget) if len(buildings.ids) == budget
                   else self.store.largest_building(first, end, below=cell))
        glb, corners = GlbBuilder(), []
        xyz, uv = grid_triangles(patch, rect)
        frame = self._frame(rect, xyz[..., 2])
        if len(xyz):
            material = glb.photo_material(data=encode_image(patch.image, quality=self.config.jpeg_quality),
                                          name="terrain")
            points, inverse = unique_rows_unordered(xyz.reshape(-1, 3))  # a grid vertex: corner of up to 6
            glb.triangles(self.georef.local(frame, points)[inverse].reshape(-1, 3, 3), material, uv)
            corners.append(points)
        corners += self._buildings(glb, frame, buildings, mip=min(self.grid.depth - level, _MAX_MIP))
        error = max(cell, patch.error, dropped, *(c.error for c in children.values()))
        return self._finish(level, col, row, glb, frame, corners, list(children.values()), error, patch)

    def _buildings(self, glb: GlbBuilder, frame: np.ndarray, rows, mip: int) -> list[np.ndarray]:
        """Roofs (textured where the texture row fits) and walls of ``rows`` with their feature ids."""
        if not rows.ids:
            return []
        parts = self.parts.of(rows)
        corners = []
        if len(parts.roof_xyz):
            for number in np.unique(parts.roof_image).tolist():
                mine = parts.roof_image == number
                local = self.georef.local_of_ecef(frame, parts.roof_ecef[mine].reshape(-1, 3)).reshape(-1, 3, 3)
                if number >= 0:
                    material = glb.photo_material(uri="../../" + self.textures.uri(number, mip),
                                                  name=self.store.images[number])
                    glb.triangles(local, material, parts.roof_uv[mine], feature=parts.roof_feature[mine])
                else:
                    glb.triangles(local, glb.plain_material(ROOF_RGB, lit=False, name="roof"),
                                  feature=parts.roof_feature[mine])
            corners.append(parts.roof_xyz.reshape(-1, 3))
        if len(parts.ring_xyz):
            self._walls(glb, frame, parts, mip)
            corners.append(parts.ring_xyz)
        glb.property_table(self.schema, BUILDING_CLASS, property_columns(self.schema, rows.ids, rows.attributes))
        return corners

    def _walls(self, glb: GlbBuilder, frame: np.ndarray, parts: Parts, mip: int) -> None:
        """Walls with their generated facade (where the texture row fits the ring), else plain."""
        local = self.georef.local_of_ecef(frame, parts.ring_ecef)[parts.fan]  # (a ring point: corner of ~3 triangles)
        owner = parts.fan_wall
        first = np.concatenate([[True], owner[1:] != owner[:-1]])  # each face's first fan triangle
        normals = unit_normals(local[first])[np.cumsum(first) - 1]  # one per face: its corners are shared
        for number in np.unique(parts.fan_image).tolist():
            mine = parts.fan_image == number
            if number >= 0:
                material = glb.facade_material(uri="../../" + self.textures.uri(number, mip),
                                               name=self.store.images[number])
                corner_uv = parts.ring_uv[parts.fan[mine]].copy()
                corner_uv[:, :, 1] = 1.0 - corner_uv[:, :, 1]  # texture table: v up; glTF: v down
                glb.triangles(local[mine], material, corner_uv, feature=parts.fan_feature[mine],
                              normals=normals[mine], facade=True)
            else:
                glb.triangles(local[mine], glb.plain_material(WALL_RGB, lit=True, name="wall"),
                              feature=parts.fan_feature[mine], normals=normals[mine])

    # --- tile bookkeeping --------------------------------------------------------------------

    def _frame(self, rect: tuple[float, float, float, float], z: np.ndarray) -> np.ndarray:
        """East-north-up frame at the centre of ``rect``, halfway between the lowest and highest ``z``."""
        height = float((np.nanmin(z) + np.nanmax(z)) / 2) if z.size and np.isfinite(z).any() else 0.0
        return self.georef.frame((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2, height)

    def _finish(self, level: int, col: int, row: int, glb: GlbBuilder, frame: np.ndarray,
                corners: list[np.ndarray], children: list[_Tile], error: float, patch: Patch | None) -> _Tile:
        tile: dict = {"boundingVolume": {}, "geometricError": error, "refine": "REPLACE"}
        regions = [child.region for child in children]
        if glb.primitives:
            uri = f"{TILE_DIR}/{level}/{col}_{row}.glb"
            path = self.folder / uri
            path.parent.mkdir(parents=True, exist_ok=True)
            data = glb.to_bytes()
            path.write_bytes(data)
            tile["content"] = {"uri": uri}
            points = np.concatenate(corners)
            regions.append(self.georef.region(points[np.isfinite(points).all(axis=1)]))
            self.report.triangles_written += sum(self._count(glb, p) for p in glb.primitives)
        if children:
            inverse = np.linalg.inv(frame)
            tile["children"] = []
            for child in children:
                if child.json is not None:  # (always: _upper passes the children that have a tile)
                    child.json["transform"] = column_major(inverse @ child.frame)
                    tile["children"].append(child.json)
        tile["boundingVolume"]["region"] = union_region(regions)
        return _Tile(tile, frame, tile["boundingVolume"]["region"], error, patch)

    @staticmethod
    def _count(glb: GlbBuilder, primitive) -> int:
        return glb.gltf.accessors[primitive.indices].count // 3


def folder_size(path: str | os.PathLike) -> int:
    """Bytes in the files under ``path``."""
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())
