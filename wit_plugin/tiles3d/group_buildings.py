"""The buildings of a group of tiles (``groups``): the largest of its tiles' buildings, as simplified LoD1 prisms.

From afar a building is a few pixels, and a group stands for thousands of them. Each group shows the
``GROUP_BUILDINGS`` largest buildings below it (size: the larger of footprint diagonal and height, as
the quadtree's upper tiles choose theirs), each a prism on its footprint simplified to a sixteenth
of the group's grid cell, from its ground height to its roof. Roofs are draped with the group's own
image (the orthoimage at the group's resolution, from which the roof atlases are cut: a low level of
the same pixels), walls are lit in the leaves' plain colour; each building keeps its attributes
(``metadata``), so a click from afar names it.

Measured for the group's geometric error: the size of the largest building left out (anywhere below
the group) and the largest distance between a simplified footprint and its original (Hausdorff).

Candidates flow bottom-up: a tile's are its own largest buildings, read once from its ``lod1.gpkg``;
a group's the largest of its children's. No level reads more than its children hold, and memory
holds at most ``GROUP_BUILDINGS`` per child.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from ..infra import step_layers
from ..infra.io.vector_io import open_step_layer
from ..infra.meshes import triangulate
from .geo import Georeference
from .glb import GlbBuilder, unit_normals
from .metadata import BUILDING_CLASS, building_schema, property_columns
from .store import PER_FACE_FIELDS

GROUP_BUILDINGS = 4000
"""Most buildings in one group's content (bounds its size whatever the group's area)."""
SIMPLIFY_SHARE = 1 / 16
"""Footprint simplification tolerance, as a share of the group's grid cell."""


@dataclass
class Candidates:
    """Buildings that a group may show: footprints (2D), ground and roof heights, size and attributes."""

    fields: list[tuple[str, int]]
    ids: list[str] = field(default_factory=list)
    footprints: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    base: np.ndarray = field(default_factory=lambda: np.empty(0))
    top: np.ndarray = field(default_factory=lambda: np.empty(0))
    size: np.ndarray = field(default_factory=lambda: np.empty(0))
    attributes: list[list] = field(default_factory=list)
    dropped: float = 0.0
    """Size of the largest building left out below."""

    def largest(self, limit: int) -> Candidates:
        """The ``limit`` largest (ties by id), the others counted in ``dropped``."""
        if len(self.ids) <= limit:
            return self
        order = sorted(range(len(self.ids)), key=lambda i: (-self.size[i], self.ids[i]))
        keep, rest = np.array(order[:limit]), np.array(order[limit:])
        return Candidates(self.fields, [self.ids[i] for i in keep], self.footprints[keep], self.base[keep],
                          self.top[keep], self.size[keep], [self.attributes[i] for i in keep],
                          max(self.dropped, float(self.size[rest].max())))

    @classmethod
    def join(cls, parts: list[Candidates]) -> Candidates:
        """All the buildings of ``parts``; attributes mapped by field name (a field a part lacks is NULL)."""
        names: dict[str, int] = {}
        for part in parts:
            for name, kind in part.fields:
                names.setdefault(name, kind)
        fields = list(names.items())
        attributes = []
        for part in parts:
            where = [next((k for k, (n, _) in enumerate(part.fields) if n == name), None) for name, _ in fields]
            attributes += [[None if k is None else row[k] for k in where] for row in part.attributes]
        return cls(fields, [i for p in parts for i in p.ids],
                   np.concatenate([p.footprints for p in parts]) if parts else np.empty(0, dtype=object),
                   np.concatenate([p.base for p in parts]) if parts else np.empty(0),
                   np.concatenate([p.top for p in parts]) if parts else np.empty(0),
                   np.concatenate([p.size for p in parts]) if parts else np.empty(0),
                   attributes, max((p.dropped for p in parts), default=0.0))


def read_tile_buildings(lod1: str, limit: int = GROUP_BUILDINGS) -> Candidates:
    """The ``limit`` largest buildings of a tile's LoD1 layer (its ground faces)."""
    ds, layer, _ = open_step_layer(lod1, step_layers.LOD1_LAYER, "LoD1 faces (wit:extrudebuildings)",
                                   (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.BASE_Z, step_layers.HEIGHT))
    defn = layer.GetLayerDefn()
    kept = [i for i in range(defn.GetFieldCount()) if defn.GetFieldDefn(i).GetName() not in PER_FACE_FIELDS]
    fields = [(defn.GetFieldDefn(i).GetName(), defn.GetFieldDefn(i).GetType()) for i in kept]
    wit_id, base_z, height = (defn.GetFieldIndex(n)
                              for n in (step_layers.WIT_ID, step_layers.BASE_Z, step_layers.HEIGHT))
    layer.SetAttributeFilter(f"{step_layers.FACE_TYPE} = 'ground'")
    ids, wkb, base, top, size, attributes = [], [], [], [], [], []
    for feature in layer:
        geometry = feature.GetGeometryRef()
        if geometry is None or geometry.IsEmpty() or feature.IsFieldNull(base_z) or feature.IsFieldNull(height):
            continue
        xmin, xmax, ymin, ymax = geometry.GetEnvelope()
        ids.append(feature.GetField(wit_id))
        wkb.append(bytes(geometry.ExportToWkb()))
        base.append(feature.GetField(base_z))
        top.append(feature.GetField(base_z) + feature.GetField(height))
        size.append(max(math.hypot(xmax - xmin, ymax - ymin), feature.GetField(height)))
        attributes.append([None if feature.IsFieldNull(i) else feature.GetField(i) for i in kept])
    del layer, ds
    footprints = shapely.force_2d(shapely.from_wkb(np.array(wkb, dtype=object), on_invalid="ignore")) \
        if wkb else np.empty(0, dtype=object)
    return Candidates(fields, ids, footprints, np.array(base, dtype=float), np.array(top, dtype=float),
                      np.array(size, dtype=float), attributes).largest(limit)


@dataclass
class Drawn:
    """What ``add_buildings`` put into a glb: model corners (for the region), the simplification's
    largest displacement, and the buildings' sizes it could not draw (their footprint vanished)."""

    corners: np.ndarray
    simplification: float
    vanished: float


WALL_RGB = (222, 213, 196)  # the leaves' (tileset.WALL_RGB)
ROOF_RGB = (176, 120, 100)


def add_buildings(glb: GlbBuilder, georef: Georeference, frame: np.ndarray, buildings: Candidates,
                  rect: tuple[float, float, float, float], cell: float, roof_image: bytes | None, name: str) -> Drawn:
    """The prisms of ``buildings`` into ``glb`` (positions local to ``frame``); roofs draped with
    ``roof_image`` (JPEG over the square ``rect``) or plain; their property table."""
    if not buildings.ids:
        return Drawn(np.empty((0, 3)), 0.0, 0.0)
    valid = shapely.make_valid(buildings.footprints)
    simple = shapely.simplify(valid, cell * SIMPLIFY_SHARE, preserve_topology=True)
    parts, part_owner = shapely.get_parts(simple, return_index=True)
    parts, inner = shapely.get_parts(parts, return_index=True)  # (make_valid may give a collection of polygons)
    part_owner = part_owner[inner]
    polygonal = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)  # not the lines make_valid may add
    parts, part_owner = parts[polygonal], part_owner[polygonal]
    drawn = np.zeros(len(buildings.ids), dtype=bool)
    drawn[part_owner] = True
    with np.errstate(invalid="ignore"):  # (NaN for a footprint GEOS cannot measure: left out of the maximum)
        moved = shapely.hausdorff_distance(simple[drawn], valid[drawn])
    moved = moved[np.isfinite(moved)]
    simplification = float(moved.max()) if len(moved) else 0.0
    vanished = float(buildings.size[~drawn].max()) if (~drawn).any() else 0.0
    corners = []
    # roofs: flat at the roof height, facing up, uv over the group's image
    triangles, owner = shapely.get_parts(triangulate(parts), return_index=True)
    owner = part_owner[owner]
    if len(triangles):
        xy = shapely.get_coordinates(triangles).reshape(-1, 4, 2)[:, :3]
        clockwise = _signed_area(xy) < 0
        xy[clockwise, 1], xy[clockwise, 2] = xy[clockwise, 2].copy(), xy[clockwise, 1].copy()
        xyz = np.concatenate([xy, np.repeat(buildings.top[owner], 3).reshape(-1, 3, 1)], axis=2)
        local = georef.local(frame, xyz.reshape(-1, 3)).reshape(-1, 3, 3)
        if roof_image is not None:
            xmin, _, xmax, ymax = rect
            side = xmax - xmin
            uv = np.stack([(xy[..., 0] - xmin) / side, (ymax - xy[..., 1]) / side], axis=-1)
            glb.triangles(local, glb.photo_material(data=roof_image, name=name), uv, feature=owner)
        else:
            glb.triangles(local, glb.plain_material(ROOF_RGB, lit=False, name="roof"), feature=owner)
        corners.append(xyz.reshape(-1, 3))
    # walls: a quad per ring edge, from the ground height to the roof
    rings, ring_owner = shapely.get_rings(parts, return_index=True)
    ring_owner = part_owner[ring_owner]
    points, ring = shapely.get_coordinates(rings, return_index=True)
    edge = np.flatnonzero(ring[:-1] == ring[1:])
    if len(edge):
        a, b, own = points[edge], points[edge + 1], ring_owner[ring[edge]]
        low, high = buildings.base[own][:, None], buildings.top[own][:, None]
        a0, b0 = np.hstack([a, low]), np.hstack([b, low])
        a1, b1 = np.hstack([a, high]), np.hstack([b, high])
        quads = np.concatenate([np.stack([a0, b0, b1], axis=1), np.stack([a0, b1, a1], axis=1)])
        local = georef.local(frame, quads.reshape(-1, 3)).reshape(-1, 3, 3)
        normals = unit_normals(local[:len(edge)])  # one per quad: its two triangles share their corners
        glb.triangles(local, glb.plain_material(WALL_RGB, lit=True, name="wall"), feature=np.concatenate([own, own]),
                      normals=np.concatenate([normals, normals]))
        corners.append(quads.reshape(-1, 3))
    schema = building_schema(buildings.fields)
    glb.property_table(schema, BUILDING_CLASS, property_columns(schema, buildings.ids, buildings.attributes))
    return Drawn(np.concatenate(corners) if corners else np.empty((0, 3)), simplification, vanished)


def _signed_area(xy: np.ndarray) -> np.ndarray:
    d1, d2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    return d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
