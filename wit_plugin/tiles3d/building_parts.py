"""A building's roofs and walls as the tiles draw them, made once for every level that draws the building.

A coarse tile draws again the largest buildings of its leaves (the 1 km sample's 3,850 buildings are drawn 12,077
times). What does not depend on the tile is made once per building and kept: the roofs cut into triangles
(facing up, their texture rows' v turned down as glTF wants it), the walls' ring points, fans and texture rows,
and every one of those points in ECEF; a tile then only moves the ECEF points into its own frame. At most
``store.PARSED_BUILDINGS`` are kept (as the store keeps their faces), the least recently drawn dropped.
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import shapely

from ..infra.meshes import fan_corners, planar_triangles
from . import store
from .geo import Georeference
from .store import FACE_KINDS, BuildingRows


@dataclass
class Parts:
    """Roofs and walls of buildings, arrays one after the other (a tile's: ``feature`` says whose)."""

    roof_xyz: np.ndarray  # (t, 3, 3) model coordinates, facing up
    roof_ecef: np.ndarray  # (t, 3, 3)
    roof_uv: np.ndarray  # (t, 3, 2) glTF uv (v down)
    roof_image: np.ndarray  # (t,) image number, -1: the face's row does not fit its ring
    roof_feature: np.ndarray  # (t,) the building (row of the tile's property table; a building's own parts: none)
    ring_xyz: np.ndarray  # (p, 3) the walls' exterior-ring points, closing points included
    ring_ecef: np.ndarray  # (p, 3)
    ring_uv: np.ndarray  # (p, 2) texture-table uv (v up), 0 where the wall's row does not fit its ring
    fan: np.ndarray  # (f, 3) the walls' fan triangles as indices into the ring points
    fan_wall: np.ndarray  # (f,) the wall of each fan triangle (ordinal among the walls)
    fan_image: np.ndarray  # (f,) image number, -1: plain
    fan_feature: np.ndarray  # (f,) the building (a building's own parts: none)


_OWN = np.zeros(0, dtype=np.int64)  # the feature of a building's own parts: its row is the tile's to say


class BuildingParts:
    """The parts of the buildings drawn, kept by building id."""

    def __init__(self, georef: Georeference):
        self.georef = georef
        self._kept: OrderedDict[str, Parts] = OrderedDict()

    def of(self, rows: BuildingRows) -> Parts:
        """The parts of the buildings ``rows`` (made for those not kept), in their order."""
        missing = [k for k, wit_id in enumerate(rows.ids) if wit_id not in self._kept]
        if missing:
            for k, parts in zip(missing, self._made(rows, missing)):
                self._kept[rows.ids[k]] = parts
        drawn = [self._kept[wit_id] for wit_id in rows.ids]
        for wit_id in rows.ids:
            self._kept.move_to_end(wit_id)
        while len(self._kept) > max(store.PARSED_BUILDINGS, len(rows.ids)):
            self._kept.popitem(last=False)
        return _joined(drawn)

    def _made(self, rows: BuildingRows, buildings: list[int]) -> list[Parts]:
        """The parts of the buildings ``buildings`` (indices into ``rows``), made for all of them at once."""
        mine = np.isin(rows.face_building, buildings)
        roofs = np.flatnonzero(mine & (rows.face_kind == FACE_KINDS["roof"]))
        walls = np.flatnonzero(mine & (rows.face_kind == FACE_KINDS["wall"]))
        roof_xyz, roof_uv, roof_image, roof_face = roof_triangles(
            rows.polygons[roofs], [rows.face_uv[i] for i in roofs.tolist()], rows.face_image[roofs])
        face_up(roof_xyz, roof_uv)
        roof_uv[:, :, 1] = 1.0 - roof_uv[:, :, 1]  # texture table: v up; glTF: v down
        polygons = rows.polygons[walls]
        rings = shapely.get_exterior_ring(polygons)
        ring_xyz = shapely.get_coordinates(rings, include_z=True)
        ring_counts = shapely.get_num_coordinates(rings)
        textured, ring_uv = ring_texcoords([rows.face_uv[i] for i in walls.tolist()], ring_counts)
        fan, fan_wall = fan_corners(polygons)
        fan_image = np.where(textured, rows.face_image[walls], -1)[fan_wall]
        ecef = self.georef.ecef(np.concatenate([roof_xyz.reshape(-1, 3), ring_xyz]))
        roof_ecef, ring_ecef = ecef[:3 * len(roof_xyz)].reshape(-1, 3, 3), ecef[3 * len(roof_xyz):]
        # each building's share: its triangles, ring points, walls and fans come one after the other
        ks = np.asarray(buildings)
        roof = _bounds(rows.face_building[roofs][roof_face], ks)
        wall_owner = rows.face_building[walls]
        points = _bounds(np.repeat(wall_owner, ring_counts), ks)
        fans = _bounds(wall_owner[fan_wall], ks)
        first_wall = np.searchsorted(wall_owner, ks)  # (a building without walls: no fan to move)
        first_point = np.concatenate([[0], np.cumsum(ring_counts)])[first_wall]
        return [Parts(roof_xyz[r0:r1].copy(), roof_ecef[r0:r1].copy(), roof_uv[r0:r1].copy(), roof_image[r0:r1].copy(),
                      _OWN, ring_xyz[p0:p1].copy(), ring_ecef[p0:p1].copy(), ring_uv[p0:p1].copy(), fan[f0:f1] - point,
                      fan_wall[f0:f1] - wall, fan_image[f0:f1].copy(), _OWN)  # (copies: a kept building holds its own)
                for (r0, r1), (p0, p1), (f0, f1), point, wall in zip(roof, points, fans, first_point.tolist(),
                                                                   first_wall.tolist())]


def _bounds(owner: np.ndarray, buildings: np.ndarray) -> list[tuple[int, int]]:
    """Where each of ``buildings`` has its rows in ``owner`` (sorted: a building's rows come one after the other)."""
    return list(zip(np.searchsorted(owner, buildings, side="left").tolist(),
                    np.searchsorted(owner, buildings, side="right").tolist()))


def _joined(drawn: list[Parts]) -> Parts:
    """The buildings' parts one after the other, their indices moved past those before, ``feature`` = the order."""
    points = np.cumsum([0] + [len(p.ring_xyz) for p in drawn])[:-1]
    walls = np.cumsum([0] + [int(p.fan_wall.max()) + 1 if len(p.fan_wall) else 0 for p in drawn])[:-1]

    def joined(name: str, empty_shape: tuple[int, ...], dtype=np.float64) -> np.ndarray:
        arrays = [getattr(p, name) for p in drawn]
        return np.concatenate(arrays) if arrays else np.empty(empty_shape, dtype=dtype)

    return Parts(
        joined("roof_xyz", (0, 3, 3)), joined("roof_ecef", (0, 3, 3)), joined("roof_uv", (0, 3, 2)),
        joined("roof_image", (0,), np.int64),
        np.repeat(np.arange(len(drawn)), [len(p.roof_xyz) for p in drawn]).astype(np.int64),
        joined("ring_xyz", (0, 3)), joined("ring_ecef", (0, 3)), joined("ring_uv", (0, 2)),
        np.concatenate([p.fan + offset for p, offset in zip(drawn, points)]) if drawn else np.empty((0, 3), np.int64),
        np.concatenate([p.fan_wall + offset for p, offset in zip(drawn, walls)]) if drawn else np.empty(0, np.int64),
        joined("fan_image", (0,), np.int64),
        np.repeat(np.arange(len(drawn)), [len(p.fan) for p in drawn]).astype(np.int64))


def ring_texcoords(uvs: list[np.ndarray | None], ring_counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which faces have a texture row (``uvs``) with one (u, v) per point of their ring (of ``ring_counts``
    points), and the (u, v) of every ring point, rings after one another: their rows', else 0."""
    textured = np.array([uv is not None and len(uv) == n for uv, n in zip(uvs, np.asarray(ring_counts).tolist())],
                        dtype=bool)
    uv = np.zeros((int(np.sum(ring_counts)), 2))
    if textured.any():
        uv[np.repeat(textured, ring_counts)] = np.concatenate([uvs[k] for k in np.flatnonzero(textured).tolist()])
    return textured, uv


def roof_triangles(polygons: np.ndarray, uvs: list[np.ndarray | None], images: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Roof faces cut into triangles: corners (t, 3, 3), texture-table uv (t, 3, 2), image number (-1 where the
    face's row does not fit its ring) and face (t,) of each."""
    ring_xyz, ring_face = shapely.get_coordinates(shapely.get_exterior_ring(polygons), include_z=True,
                                                  return_index=True)
    textured, uv = ring_texcoords(uvs, np.bincount(ring_face, minlength=len(polygons)))
    xy, fitted, face = planar_triangles(polygons, np.column_stack([ring_xyz[:, 2], uv]))
    xyz = np.concatenate([xy, fitted[:, :, :1]], axis=2)
    return xyz, fitted[:, :, 1:].copy(), np.where(textured[face], images[face], -1), face


def face_up(xyz: np.ndarray, *others: np.ndarray) -> None:
    """Swap two corners of the triangles wound clockwise seen from above (in place), so they face up."""
    d1, d2 = xyz[:, 1, :2] - xyz[:, 0, :2], xyz[:, 2, :2] - xyz[:, 0, :2]
    down = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] < 0
    for array in (xyz, *others):
        array[down, 1], array[down, 2] = array[down, 2].copy(), array[down, 1].copy()
