"""Generated facades: every LoD1 wall textured from its building's storeys and use (``wit:wittexture``).

An orthoimage sees roofs and ground, never walls: walls get textures drawn by the plugin itself and say so.
Each building gets a style from its use (``uses``), a variant seeded by its id, and its storey count (the
layer's, else its height at the style's typical storey height); each (style, variant) is one tileable PNG
(``modules``) shared by every building that uses it, never an image per building, as tall as the most
storeys any of them has. The walls' texture coordinates (``walls``) put one image row on each storey.

The LoD1 layer is read twice, in order and in bulk: its ground faces (one per building) for the facades and
the images' heights, then its walls sorted by building and face for the texture coordinates, a building's
facade computed again from the same attributes (no table of all buildings held in memory).
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...buildings.heights import HeightOptions
from ...infra import step_layers
from ...infra.errors import InputError
from ...infra.io import bulk_read
from ...infra.io.layersource import LayerSource
from ...infra.io.sql import sql_name
from ...infra.io.vector_io import open_step_layer
from .modules import facade_image
from .uses import Facade, UseRule
from .walls import QUAD_POINTS, wall_texcoords

FACADE_PREFIX = step_layers.FACADE_IMAGE_PREFIX
FACADE_EXT = "png"  # drawn flat colours: lossless, and a stack of equal storeys compresses to almost one storey
_BATCH = 20_000


def image_name(facade: Facade) -> str:
    return f"{FACADE_PREFIX}{facade.image}.{FACADE_EXT}"


@dataclass
class FacadeReport:
    """What the facade pass made."""

    buildings: int = 0
    walls: int = 0
    untextured_walls: int = 0  # not quads (not as wit:extrudebuildings writes them)
    storeys_from_height: int = 0  # buildings whose layer gave no storey count
    styles: Counter = field(default_factory=Counter)
    rows: dict[str, int] = field(default_factory=dict)  # image → storeys it holds (its tallest building's)


class FacadeSource:
    """The LoD1 layer as the facade pass reads it: the use fields found, the buildings, the walls."""

    def __init__(self, lod1: str):
        self.path = lod1
        self._ds, layer, _ = open_step_layer(lod1, step_layers.LOD1_LAYER, step_layers.LOD1_ROLE,
                                             (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER,
                                              step_layers.HEIGHT))
        self.table, self.geometry = layer.GetName(), layer.GetGeometryColumn() or "geom"
        names = [layer.GetLayerDefn().GetFieldDefn(i).GetName() for i in range(layer.GetLayerDefn().GetFieldCount())]
        self.rule = UseRule.for_fields(names)
        self.floors_field = HeightOptions().rule_for(names).floors_field or step_layers.STOREYS_ABOVE
        self.storeys = step_layers.STOREYS_ABOVE if step_layers.STOREYS_ABOVE in names else None
        storeys = [self.storeys] if self.storeys else []
        self._columns = [step_layers.WIT_ID, step_layers.HEIGHT] + storeys + self.rule.fields

    def close(self) -> None:
        self._ds = None

    def facade(self, row: dict[str, Any]) -> Facade:
        height = row[step_layers.HEIGHT]
        return self.rule.facade(row[step_layers.WIT_ID], row, float(height) if height is not None else float("nan"),
                                row.get(self.storeys) if self.storeys else None, self.floors_field)

    def buildings(self) -> Iterator[list[tuple[str, Facade]]]:
        """Batches of (wit_id, facade), one per building (its ground face), in the layer's order."""
        for batch in self._select("ground", geometry=False, order=False):
            rows = _rows(batch, self._columns)
            yield [(row[step_layers.WIT_ID], self.facade(row)) for row in rows]

    def walls(self) -> Iterator[_Walls]:
        """Batches of whole buildings' walls, sorted by building and face number."""
        pending: _Walls | None = None
        for batch in self._select("wall", geometry=True, order=True):
            points, counts, _ = bulk_read.exterior_rings(batch["geometry"])
            part = _Walls(_rows(batch, self._columns), np.asarray(np.ma.filled(batch[step_layers.FACE_NUMBER], -1),
                                                                  dtype=np.int64), points, counts)
            part = pending.then(part) if pending is not None else part
            complete, pending = part.split_last_building()  # the last building may go on in the next batch
            if complete.rows:
                yield complete
        if pending is not None and pending.rows:
            yield pending

    def _select(self, kind: str, geometry: bool, order: bool) -> Iterator[dict[str, np.ndarray]]:
        names = self._columns + [step_layers.FACE_NUMBER, self.geometry] * geometry
        columns = ", ".join(map(sql_name, names))
        sql = (f"SELECT {columns} FROM {sql_name(self.table)} "  # nosec B608  # quoted names; kind: wall or ground
               f"WHERE {sql_name(step_layers.FACE_TYPE)} = '{kind}'")
        if order:
            sql += f' ORDER BY "{step_layers.WIT_ID}", "{step_layers.FACE_NUMBER}"'
        result = self._ds.ExecuteSQL(sql)
        if result is None:
            raise InputError(f"Cannot read the {kind} faces of {LayerSource.parse(self.path).path}.")
        try:
            yield from bulk_read.batches(result, _BATCH)
        finally:
            self._ds.ReleaseResultSet(result)


def plan_facades(source: FacadeSource, report: FacadeReport) -> Iterator[list[tuple]]:
    """Pass 1: each building's facade, counted in ``report`` (images' rows too); yields the facade table's rows."""
    for batch in source.buildings():
        rows = []
        for wit_id, facade in batch:
            name = image_name(facade)
            report.rows[name] = max(report.rows.get(name, 0), facade.storeys)
            report.styles[facade.style] += 1
            report.storeys_from_height += facade.storeys_source.startswith("height")
            rows.append((wit_id, step_layers.FACADES_GENERATED, facade.style, facade.rule, facade.storeys,
                         facade.storeys_source, name))
        report.buildings += len(rows)
        yield rows


def facade_images(report: FacadeReport) -> Iterator[tuple[str, np.ndarray]]:
    """The facade images the buildings use, each as tall as its tallest building (a power of two of storeys)."""
    for name, storeys in sorted(report.rows.items()):
        style, _, variant = name[len(FACADE_PREFIX):-len(FACADE_EXT) - 1].rpartition("_")
        yield name, facade_image(style, int(variant), 1 << max(0, storeys - 1).bit_length())


def wall_rows(source: FacadeSource, report: FacadeReport) -> Iterator[list[tuple[str, str, int, np.ndarray]]]:
    """Pass 2: the texture table's rows of the walls, (wit_id, image, face number, uv (5, 2)) per wall, in batches."""
    for walls in source.walls():
        rows, faces, points, counts = walls.rows, walls.faces, walls.points, walls.counts
        quads = counts == QUAD_POINTS
        report.untextured_walls += int((~quads).sum())
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        kept = np.flatnonzero(quads)
        if not len(kept):
            continue
        ids = [rows[k][step_layers.WIT_ID] for k in kept.tolist()]
        first = np.array([True] + [a != b for a, b in zip(ids[1:], ids[:-1])])
        facades: dict[str, Facade] = {}
        for k, wit_id in zip(kept.tolist(), ids):
            if wit_id not in facades:
                facades[wit_id] = source.facade(rows[k])
        chosen = [facades[wit_id] for wit_id in ids]
        names = [image_name(f) for f in chosen]
        phase = np.array([f.phase for f in chosen])
        top_v = np.array([f.storeys / (1 << max(0, report.rows[name] - 1).bit_length())
                          for f, name in zip(chosen, names)])
        base = points[starts[kept][:, None] + np.arange(2)][:, :, :2]
        uv = wall_texcoords(base, first, phase, top_v).reshape(len(kept), QUAD_POINTS, 2)
        report.walls += len(kept)
        yield list(zip(ids, names, faces[kept].tolist(), uv))


def _rows(batch: dict[str, np.ndarray], columns: list[str]) -> list[dict[str, Any]]:
    """A batch's ``columns`` as one dict per row (text decoded, NULL as None)."""
    values = {name: _python(batch[name]) for name in columns}
    count = len(next(iter(values.values()))) if values else 0
    return [{name: values[name][k] for name in columns} for k in range(count)]


def _python(column: np.ndarray) -> list[Any]:
    values = column.tolist()
    return [v.decode("utf-8", "replace") if isinstance(v, bytes) else v for v in values]


@dataclass
class _Walls:
    """Wall faces as read: attribute rows, face numbers, their rings' points one after another, points per ring."""

    rows: list[dict[str, Any]]
    faces: np.ndarray
    points: np.ndarray
    counts: np.ndarray

    def then(self, other: _Walls) -> _Walls:
        return _Walls(self.rows + other.rows, np.concatenate([self.faces, other.faces]),
                      np.concatenate([self.points, other.points]), np.concatenate([self.counts, other.counts]))

    def split_last_building(self) -> tuple[_Walls, _Walls]:
        """(the walls of every building but the last, the last building's walls)."""
        last = self.rows[-1][step_layers.WIT_ID] if self.rows else None
        cut = len(self.rows)
        while cut and self.rows[cut - 1][step_layers.WIT_ID] == last:
            cut -= 1
        point_cut = int(self.counts[:cut].sum())
        return (_Walls(self.rows[:cut], self.faces[:cut], self.points[:point_cut], self.counts[:cut]),
                _Walls(self.rows[cut:], self.faces[cut:], self.points[point_cut:], self.counts[cut:]))
