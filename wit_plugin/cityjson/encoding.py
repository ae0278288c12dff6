"""A city object's geometry in CityJSON's arrays: integer vertices on the model's millimetre grid (``transform``),
rings of vertex indices, texture values of (u, v) indices, as JSON text built in bulk.

Each geometry's corners are quantised and made unique (the same millimetre, the same vertex), and its
(u, v) pairs alike; indices are local, from 0, and a writer shifts them by what it wrote before (one
CityJSON file, whose vertices are global) or leaves them local (a CityJSONFeature).
"""
from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..infra.arrays import unique_rows
from .objects import SOLID, THEMES, Surfaces

SCALE = 0.001  # the millimetre grid the CityGML's coordinates are written on (3 decimals)
TEXT_BATCH = 65_536  # surfaces formatted per piece of text
SMALL = 256  # rows made distinct in Python rather than by sorting


def json_text(value: object) -> str:
    """Compact JSON of attributes and metadata, UTF-8 as it is; floats as Python's shortest repr, whatever other
    code did to the ``json`` module (cjio, for one, replaces its float formatting with six decimals)."""
    if isinstance(value, str):
        return json.encoder.py_encode_basestring(value)
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{value} cannot be written in JSON")
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, dict):
        return "{" + ",".join(f"{json_text(str(k))}:{json_text(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(map(json_text, value)) + "]"
    raise TypeError(f"{type(value).__name__} is not a JSON value")


@dataclass(frozen=True)
class Transform:
    """CityJSON's ``transform``: coordinate = integer × scale + translate."""

    translate: tuple[float, float, float]
    scale: float = SCALE

    @classmethod
    def around(cls, lower_corner: tuple[float, ...]) -> Transform:
        """A translate on whole metres at or below ``lower_corner`` (x, y, z), so integers stay small."""
        x, y, z = (float(np.floor(v)) for v in lower_corner[:3])
        return cls((x, y, z))

    def as_json(self) -> dict:
        return {"scale": [self.scale] * 3, "translate": list(self.translate)}

    def integers(self, points: np.ndarray) -> np.ndarray:
        """Coordinates (n, 3) as CityJSON's integers."""
        return np.rint((points - np.asarray(self.translate)) / self.scale).astype(np.int64)


@dataclass
class Encoded:
    """A geometry's distinct vertices and (u, v) pairs, and each corner's index into them."""

    vertices: np.ndarray  # (V, 3) int64
    corner_vertex: np.ndarray  # (N,) index into vertices
    uv: np.ndarray  # (U, 2) float64
    corner_uv: np.ndarray  # (N,) index into uv, -1 where the corner has none


def encode(geometry: Surfaces, transform: Transform) -> Encoded:
    """The geometry's vertices and (u, v) pairs, each distinct one once."""
    vertices, corner_vertex = _distinct(transform.integers(geometry.points))
    corner_uv = np.full(len(geometry.points), -1, dtype=np.int64)
    uv = np.zeros((0, 2))
    if geometry.uv is not None:
        has = ~np.isnan(geometry.uv).any(axis=1)
        uv, corner_uv[has] = _distinct(np.ascontiguousarray(geometry.uv[has]))
    return Encoded(vertices, corner_vertex, uv, corner_uv)


def _distinct(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``unique_rows``, in order of first appearance for the few rows of a building (a dict: no sort to set up)."""
    if len(rows) > SMALL:
        return unique_rows(rows)
    index: dict[tuple, int] = {}
    inverse = [index.setdefault(row, len(index)) for row in map(tuple, rows.tolist())]
    return np.array(list(index), dtype=rows.dtype).reshape(-1, rows.shape[1]), np.array(inverse, dtype=np.int64)


def vertices_text(vertices: np.ndarray) -> Iterator[str]:
    """``[x,y,z],[x,y,z],…`` in pieces (no brackets around the whole)."""
    for start in range(0, len(vertices), TEXT_BATCH):
        yield ",".join(map("[%d,%d,%d]".__mod__, map(tuple, vertices[start:start + TEXT_BATCH].tolist())))


def uv_text(uv: np.ndarray) -> Iterator[str]:
    """``[u,v],…`` in pieces, 7 significant digits as the CityGML's texture coordinates."""
    for start in range(0, len(uv), TEXT_BATCH):
        yield ",".join(map("[%.7g,%.7g]".__mod__, map(tuple, uv[start:start + TEXT_BATCH].tolist())))


def geometry_text(geometry: Surfaces, encoded: Encoded, vertex_offset: int, uv_offset: int,
                  images: np.ndarray | None = None) -> Iterator[str]:
    """The Geometry Object as JSON text, in pieces: boundaries, semantics, textures.

    Indices are shifted by ``vertex_offset`` and ``uv_offset``; ``images`` maps the model's image indices to
    the indices written (None: as they are).
    """
    solid = geometry.kind == SOLID
    yield f'{{"type":"{geometry.kind}","lod":"{geometry.lod}","boundaries":' + ("[[" if solid else "[")
    yield from _join(_rings(geometry, (encoded.corner_vertex + vertex_offset).tolist()))
    yield "]]" if solid else "]"
    if geometry.semantic is not None:
        semantic = geometry.semantic.tolist()
        used = sorted(set(semantic))  # the semantic surfaces used, each once (a few: a set, not numpy's unique)
        surfaces = ",".join(f'{{"type":"{geometry.semantics[k]}"}}' for k in used)
        values_text = ",".join(map(str, map(dict(zip(used, range(len(used)))).__getitem__, semantic)))
        yield f',"semantics":{{"surfaces":[{surfaces}],"values":' + (f"[[{values_text}]]}}" if solid
                                                                       else f"[{values_text}]}}")
    if geometry.image is not None:
        image = geometry.image if images is None else np.where(geometry.image >= 0, images[geometry.image], -1)
        corner_uv = np.where(encoded.corner_uv >= 0, encoded.corner_uv + uv_offset, -1).tolist()
        themes = [t for t in range(len(THEMES)) if ((geometry.theme == t) & (image >= 0)).any()]
        for n, theme in enumerate(themes):
            yield ("," if n else ',"texture":{') + f'"{THEMES[theme]}":{{"values":' + ("[[" if solid else "[")
            textured = np.where(geometry.theme == theme, image, -1)
            yield from _join(_texture_rings(geometry, textured, corner_uv))
            yield ("]]}" if solid else "]}") + ("}" if n == len(themes) - 1 else "")
    yield "}"


def _join(pieces: Iterator[list[str]]) -> Iterator[str]:
    """Lists of surface texts joined by commas, across pieces."""
    first = True
    for texts in pieces:
        if texts:
            yield ("" if first else ",") + ",".join(texts)
            first = False


def _rings(geometry: Surfaces, corners: list[int]) -> Iterator[list[str]]:
    """Each surface as ``[[i,j,k],[…]]`` (its rings of vertex indices), a batch of surfaces at a time."""
    if geometry.triangles:
        triples = list(zip(*[iter(corners)] * 3))
        for start in range(0, len(triples), TEXT_BATCH):
            yield list(map("[[%d,%d,%d]]".__mod__, triples[start:start + TEXT_BATCH]))
        return
    ring_texts = _ring_lists(corners, geometry.ring_len, lambda ring: "[" + ",".join(map(str, ring)) + "]")
    yield _surfaces(ring_texts, geometry.rings)


def _texture_rings(geometry: Surfaces, image: np.ndarray, corner_uv: list[int]) -> Iterator[list[str]]:
    """Each surface's texture values: ``[[image,uv…]]`` for its exterior ring, ``[null]`` for untextured rings."""
    images = image.tolist()
    if geometry.triangles:
        for start in range(0, len(images), TEXT_BATCH):
            stop = min(start + TEXT_BATCH, len(images))
            yield ["[[null]]" if t < 0 else "[[{},{},{},{}]]".format(t, *corner_uv[3 * s:3 * s + 3])
                   for s, t in zip(range(start, stop), images[start:stop])]
        return
    ring_surface = np.repeat(np.arange(len(geometry.rings)), geometry.rings).tolist()
    ring_image = [images[s] for s in ring_surface]
    rings = _ring_lists(corner_uv, geometry.ring_len, None)
    texts = ["[null]" if ring_image[r] < 0 or min(ring) < 0 else f"[{ring_image[r]}," + ",".join(map(str, ring)) + "]"
             for r, ring in enumerate(rings)]
    yield _surfaces(texts, geometry.rings)


def _ring_lists(corners: list[int], ring_len: np.ndarray, as_text) -> list:
    ends = np.cumsum(ring_len).tolist()
    rings = [corners[start:end] for start, end in zip([0] + ends[:-1], ends)]
    return [as_text(ring) for ring in rings] if as_text else rings


def _surfaces(ring_texts: list[str], rings: np.ndarray) -> list[str]:
    ends = np.cumsum(rings).tolist()
    return ["[" + ",".join(ring_texts[start:end]) + "]" for start, end in zip([0] + ends[:-1], ends)]
