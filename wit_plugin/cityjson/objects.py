"""The model's city objects, read from the step layers as ``citygml.writer`` reads them: the same objects in the
same order (buildings, roads, the relief, one group per legal dong), the same ids, attributes and texture
coordinates. Geometry stays in numpy arrays (``Surfaces``) until it is encoded.

Memory: buildings are read one at a time, with their texture rows and district beside them (all three in
wit_id order); a road holds its own triangles; the TIN's texture coordinates are held as arrays indexed by
triangle (56 bytes a triangle) and the relief, one city object, as its corners' arrays — so memory grows
with the TIN, never with the number of buildings.
"""
from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from itertools import chain, groupby
from operator import itemgetter

import numpy as np
from osgeo import ogr

from ..citygml.inputs import (
    BULK,
    FacadeRows,
    InputLayer,
    Membership,
    checked_wit_id,
    clean_text,
    columns_of,
    fields_of,
    tri_ids,
    typed_attributes,
    uv_values,
)
from ..citygml.writer import (
    APPEARANCE_THEME,
    DISTRICT_NAME_FIELD,
    FACADE_THEME,
    RELIEF_LOD,
    ROAD_TRIANGLES,
    SKIP_BUILDING_FIELDS,
    TIN_RELIEF_ID,
    join_sorted,
)
from ..infra import step_layers
from ..infra.arrays import components, triangle_edge_keys
from ..infra.errors import InputError
from ..infra.io import bulk_read

SOLID, MULTI_SURFACE, COMPOSITE_SURFACE = "Solid", "MultiSurface", "CompositeSurface"
THEMES = (APPEARANCE_THEME, FACADE_THEME)  # theme index 0: the orthoimage's; 1: the walls' generated facades
FACE_SEMANTICS = ("GroundSurface", "RoofSurface", "WallSurface")  # in step_layers.FACE_TYPES order
ROAD_SEMANTICS = ("TrafficArea",)
BUILDING_LOD, ROAD_LOD = "1", "2"  # as the CityGML: lod1Solid, lod2MultiSurface


@dataclass
class Surfaces:
    """One geometry as arrays: every ring's corners one after another (no closing corner), rings per surface."""

    kind: str  # SOLID (one shell), MULTI_SURFACE or COMPOSITE_SURFACE
    lod: str
    points: np.ndarray  # (N, 3) coordinates in the model CRS
    ring_len: np.ndarray  # (R,) corners of each ring
    rings: np.ndarray  # (S,) rings of each surface, its exterior first
    semantics: tuple[str, ...] = ()  # the semantic surface types ``semantic`` refers to
    semantic: np.ndarray | None = None  # (S,) index into ``semantics``
    image: np.ndarray | None = None  # (S,) texture image (index into the model's images), -1: none
    theme: np.ndarray | None = None  # (S,) index into THEMES of its texture
    uv: np.ndarray | None = None  # (N, 2) texture coordinates of each corner, NaN where none

    @property
    def triangles(self) -> bool:
        """Every surface a triangle without holes (the TIN): encoded on a faster path."""
        return bool(len(self.ring_len)) and len(self.rings) == len(self.ring_len) and bool((self.ring_len == 3).all())


@dataclass
class CityObject:
    """A first-level city object, as a CityJSON object holds it."""

    id: str
    type: str
    attributes: dict = field(default_factory=dict)
    geometries: list[Surfaces] = field(default_factory=list)
    parents: list[str] | None = None
    children: list[str] | None = None


def attributes_of(feature: ogr.Feature, fields: list[tuple[int, str, int]], skip: set[str]) -> dict:
    """The generic attributes the CityGML writes, as JSON values (numbers stay numbers)."""
    return {name: value for name, _, value in typed_attributes(feature, fields, skip)}


class ModelObjects:
    """Reads the model's city objects; ``suffix`` is added to the ids of the objects a tile of a run shares with
    its neighbours (roads, the relief, districts), so that the tiles' sequences join without a repeated id."""

    def __init__(self, lod1: InputLayer | None, tin: InputLayer | None, roads: InputLayer | None,
                 members: Membership | None, texcoords: InputLayer | None, facades: FacadeRows | None,
                 images: dict[str, int], suffix: str = ""):
        self.lod1, self.tin, self.roads, self.members = lod1, tin, roads, members
        self.texcoords, self.facades, self.images, self.suffix = texcoords, facades, images, suffix
        self.tin_textures = _TinTextures(texcoords, images, tin) if texcoords and tin else None

    def all(self) -> Iterator[CityObject]:
        """Every city object, in the CityGML writer's order."""
        if self.lod1:
            yield from self.buildings()
        if self.roads or self.tin:
            yield from self.road_objects()
        if self.tin:
            relief = self.relief()
            if relief is not None:
                yield relief
        if self.members:
            yield from self.groups()

    # buildings ---------------------------------------------------------------------------------
    def buildings(self) -> Iterator[CityObject]:
        """One building a time, with its texture rows and its district read beside it (all in wit_id order)."""
        lod1 = self.lod1
        if lod1 is None:  # (``all`` asks only with the layer)
            return
        if self.members:  # the districts first: a building names its group (``parents``)
            with lod1.select(where=f"\"{step_layers.FACE_TYPE}\" = 'ground'", order=(step_layers.WIT_ID,)) as result:
                key = columns_of(result)[step_layers.WIT_ID]
                for face in result:
                    geometry = face.GetGeometryRef()
                    if geometry is not None and not geometry.IsEmpty():
                        self.members.add(face.GetFieldAsString(key), bytes(geometry.ExportToIsoWkb()))
        with contextlib.ExitStack() as stack:
            parents = _Lookup(self.members.parents() if self.members else iter(()))
            textures = _Lookup(self._face_textures(stack))
            result = stack.enter_context(lod1.select(order=(step_layers.WIT_ID, step_layers.FACE_NUMBER)))
            fields, col = fields_of(result), columns_of(result)
            key = col[step_layers.WIT_ID]
            for wit_id, faces in groupby(result, key=lambda f: f.GetFieldAsString(key)):
                wit_id = checked_wit_id(wit_id, f"A face in {lod1.path}")
                parent = parents.of(wit_id)
                yield self._building(wit_id, list(faces), fields, col, textures.of(wit_id) or {},
                                     [parent + self.suffix] if parent else None)

    def _face_textures(self, stack: contextlib.ExitStack) -> Iterator[tuple[str, dict]]:
        """(building wit_id, {face number: (image, theme, uv pairs)}) in wit_id order."""
        if not self.texcoords:
            return
        targets = ", ".join(f"'{t}'" for t in ("roof", step_layers.TEX_WALL))
        order = (step_layers.TEX_FEATURE, step_layers.TEX_FACE)
        result = stack.enter_context(self.texcoords.select(f"\"{step_layers.TEX_TARGET}\" IN ({targets})", order))
        names = (step_layers.TEX_FEATURE, step_layers.TEX_FACE, step_layers.TEX_TARGET, step_layers.TEX_IMAGE,
                 step_layers.TEX_COORDS)
        path = self.texcoords.path
        rows = chain.from_iterable(self._texture_rows(batch, names, path) for batch in bulk_read.batches(result, BULK))
        for wit_id, group in groupby(rows, key=itemgetter(0)):
            yield wit_id, {int(face): (self.images[image], int(target == step_layers.TEX_WALL), uv)
                           for _, face, target, image, uv in group}

    def _texture_rows(self, batch: dict[str, np.ndarray], names: tuple[str, ...], path: str) -> Iterator[tuple]:
        """(feature, face, target, image, (u, v) pairs) of each row of a batch (of the texture table ``path``), its
        coordinates parsed in one go."""
        features, faces, targets, images, texts = (bulk_read.texts(batch[name]) for name in names)
        uv, counts = uv_values(texts, lambda i: f"{targets[i]} {features[i]}_f{faces[i]} in {path}", False)
        ends = np.cumsum(counts).tolist()
        return zip(features, faces, targets, images, (uv[end - n:end] for end, n in zip(ends, counts.tolist())))

    def _building(self, wit_id: str, faces: list[ogr.Feature], fields: list[tuple[int, str, int]],
                  col: dict[str, int], textures: dict, parents: list[str] | None) -> CityObject:
        first = faces[0]
        attributes = attributes_of(first, fields, SKIP_BUILDING_FIELDS)
        facade = self.facades.of(wit_id) if self.facades else None
        if facade is not None and self.facades is not None:  # how the wall texture was made
            attributes.update(attributes_of(facade, self.facades.fields, {step_layers.WIT_ID,
                                                                          step_layers.FACADE_IMAGE}))
        attributes.update(_height(first, col))
        for name, key in ((step_layers.STOREYS_ABOVE, "storeysAboveGround"),
                          (step_layers.STOREYS_BELOW, "storeysBelowGround")):
            if name in col and first.IsFieldSetAndNotNull(col[name]):
                attributes[key] = first.GetFieldAsInteger64(col[name])
        number_col, type_col, last = col[step_layers.FACE_NUMBER], col[step_layers.FACE_TYPE], -1
        points, ring_len, rings, semantic, image, theme, uv = [], [], [], [], [], [], []
        for face in faces:
            number, geometry = face.GetFieldAsInteger(number_col), face.GetGeometryRef()
            if not face.IsFieldSetAndNotNull(number_col) or number <= last:
                raise InputError(f"Building {wit_id} has a face without a unique {step_layers.FACE_NUMBER}: "
                                 "re-run wit:extrudebuildings.")
            if geometry is None or geometry.IsEmpty():
                raise InputError(f"Face {number} of building {wit_id} has no geometry: re-run wit:extrudebuildings.")
            last = number
            face_type = face.GetFieldAsString(type_col)
            semantic.append(step_layers.FACE_TYPES.index(face_type) if face_type in step_layers.FACE_TYPES else -1)
            texture = textures.get(number)
            image.append(texture[0] if texture else -1)
            theme.append(texture[1] if texture else -1)
            rings.append(geometry.GetGeometryCount())
            for i in range(geometry.GetGeometryCount()):
                ring = np.array(geometry.GetGeometryRef(i).GetPoints(), dtype=np.float64)[:-1]
                points.append(ring)
                ring_len.append(len(ring))
                ring_uv = np.full((len(ring), 2), np.nan)
                if texture and i == 0:  # the exterior ring's, as the CityGML (interior rings: none)
                    if len(texture[2]) != len(ring) + 1:
                        raise InputError(f"Texture coordinates of face {wit_id}_f{number} have {len(texture[2])} "
                                         f"pairs for a ring of {len(ring) + 1} points: re-run wit:wittexture.")
                    ring_uv = texture[2][:-1]
                uv.append(ring_uv)
        if any(s < 0 for s in semantic):
            raise InputError(f"Building {wit_id} has a face whose {step_layers.FACE_TYPE} is not one of "
                             f"{', '.join(step_layers.FACE_TYPES)}: re-run wit:extrudebuildings.")
        geometry = Surfaces(SOLID, BUILDING_LOD, np.concatenate(points)[:, :3], np.array(ring_len), np.array(rings),
                            FACE_SEMANTICS, np.array(semantic), np.array(image), np.array(theme), np.concatenate(uv))
        return CityObject(wit_id, "Building", attributes, [geometry], parents)

    # roads, relief, groups ---------------------------------------------------------------------
    def road_objects(self) -> Iterator[CityObject]:
        """One ``Road`` per road wit_id in the road layer or among the road triangles (a MultiSurface of them)."""
        with contextlib.ExitStack() as stack:
            road_rows: Iterator = iter(())
            fields: list[tuple[int, str, int]] = []
            if self.roads:
                result = stack.enter_context(self.roads.select(order=(step_layers.WIT_ID,)))
                fields, key = fields_of(result), columns_of(result)[step_layers.WIT_ID]
                road_rows = ((k, next(g)) for k, g in groupby(result, key=lambda f: f.GetFieldAsString(key)))
            triangle_rows = self._road_triangles(stack) if self.tin else iter(())
            for wit_id, road, triangles in join_sorted(road_rows, triangle_rows):
                wit_id = checked_wit_id(wit_id, "A road")
                attributes = attributes_of(road, fields, {step_layers.WIT_ID}) if road is not None else {}
                geometries = [self._triangles(triangles, MULTI_SURFACE, ROAD_LOD, ROAD_SEMANTICS)] \
                    if triangles is not None else []
                yield CityObject(wit_id + self.suffix, "Road", attributes, geometries)

    def _road_triangles(self, stack: contextlib.ExitStack) -> Iterator[tuple[str, tuple[np.ndarray, np.ndarray]]]:
        """(road wit_id, (tri ids, corners)) per road, in wit_id order."""
        if self.tin is None:  # (asked only with the TIN)
            return
        result = stack.enter_context(self.tin.select(ROAD_TRIANGLES, (step_layers.TIN_FEATURE_ID,
                                                                         step_layers.TIN_TRIANGLE_ID)))
        rows = chain.from_iterable(zip(bulk_read.texts(batch[step_layers.TIN_FEATURE_ID]), *_tin_batch(batch))
                                   for batch in bulk_read.batches(result, BULK))
        for wit_id, group in groupby(rows, key=itemgetter(0)):
            road = list(group)
            yield wit_id, (np.array([row[1] for row in road]), np.array([row[2] for row in road]))

    def relief(self) -> CityObject | None:
        """Every TIN triangle not written as a road surface, as one ``TINRelief``: a ``CompositeSurface`` per part
        that hangs together (by edges), as a composite surface must; the roads cut the ground into such parts."""
        if self.tin is None:  # (``all`` asks only with the TIN)
            return None
        ids, corners = [], []
        with self.tin.select(f"NOT ({ROAD_TRIANGLES})", (step_layers.TIN_TRIANGLE_ID,)) as result:
            for batch in bulk_read.batches(result, BULK):
                batch_ids, batch_corners = _tin_batch(batch)
                ids.append(batch_ids)
                corners.append(batch_corners)
        if not ids or not sum(map(len, ids)):
            return None
        ids, corners = np.concatenate(ids), np.concatenate(corners)
        part = surface_parts(corners)
        order = np.argsort(part, kind="stable")  # parts in the order of their first triangle
        bounds = np.flatnonzero(np.r_[True, part[order][1:] != part[order][:-1], True])
        pieces = [order[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
        pieces.sort(key=lambda piece: piece[0])
        return CityObject(TIN_RELIEF_ID + self.suffix, "TINRelief", {}, [
            self._triangles((ids[piece], corners[piece]), COMPOSITE_SURFACE, RELIEF_LOD, ()) for piece in pieces])

    def _triangles(self, triangles: tuple[np.ndarray, np.ndarray], kind: str, lod: str,
                   semantics: tuple[str, ...]) -> Surfaces:
        ids, corners = triangles
        count = len(ids)
        geometry = Surfaces(kind, lod, corners.reshape(-1, 3), np.full(count, 3), np.ones(count, dtype=np.int64),
                            semantics, np.zeros(count, dtype=np.int64) if semantics else None)
        if self.tin_textures:
            geometry.image, geometry.uv = self.tin_textures.of(ids)
            geometry.theme = np.zeros(count, dtype=np.int64)
        return geometry

    def groups(self) -> Iterator[CityObject]:
        """One ``CityObjectGroup`` per legal dong with buildings: its fields, its name, its buildings."""
        members = self.members
        if members is None:  # (``all`` asks only with the districts)
            return
        for wit_id, district, buildings in members.groups():
            attributes = attributes_of(district, members.fields, {step_layers.WIT_ID})
            index = district.GetFieldIndex(DISTRICT_NAME_FIELD)
            if index >= 0 and district.IsFieldSetAndNotNull(index):
                attributes = {"name": clean_text(district.GetFieldAsString(index)), **attributes}
            yield CityObject(wit_id + self.suffix, "CityObjectGroup", attributes, children=list(buildings))


def _height(feature: ogr.Feature, col: dict[str, int]) -> dict:
    """The CityGML's ``con:height`` as flat attributes (QGIS's CityJSON Loader stores no nested value): its value
    (m), measured when it came from a height field, else estimated, and its references."""
    if step_layers.HEIGHT not in col or not feature.IsFieldSetAndNotNull(col[step_layers.HEIGHT]):
        return {}
    value = feature.GetFieldAsDouble(col[step_layers.HEIGHT])
    if not np.isfinite(value):
        return {}
    source = feature.GetFieldAsString(col[step_layers.HEIGHT_SOURCE]) if step_layers.HEIGHT_SOURCE in col else None
    return {"height": round(value, 3), "heightStatus": "measured" if source == "field" else "estimated",
            "heightLowReference": "lowestGroundPoint", "heightHighReference": "highestRoofEdge"}


def surface_parts(corners: np.ndarray, max_passes: int = 8) -> np.ndarray:
    """For triangles given as (n, 3, 3) corners: a part label per triangle such that each part is a composite
    surface as validators want it: connected through edges, and manifold at every vertex (the triangles of a
    part around a vertex form one fan). Corners equal to the millimetre are one vertex.

    Parts are first the edge-connected sets; where a part meets itself at a vertex only (two fans, e.g. where
    roads nearly enclose a piece of ground), each fan but the first becomes a part of its own, and the parts
    that lost one are split again where that disconnected them. Only those vertices and parts are looked at
    again: the work is a few sorts of the triangles' edges.
    """
    keys = np.rint(corners.reshape(-1, 3)[:, :2] / 1e-3).astype(np.int64)
    keys -= keys.min(axis=0)
    _, vertex = np.unique(keys[:, 0] * (keys[:, 1].max() + 1) + keys[:, 1], return_inverse=True)
    vertex = vertex.reshape(-1, 3)
    flat = triangle_edge_keys(vertex).ravel()  # edge k of a triangle joins its corners k and k + 1
    order = np.argsort(flat, kind="stable")
    same = np.flatnonzero(flat[order][1:] == flat[order][:-1])
    first, second = order[same], order[same + 1]  # the two uses (triangle * 3 + edge) of each inner edge
    t1, t2 = first // 3, second // 3
    # the corners an inner edge links: the same vertex in both triangles, at both ends of the edge
    ends = []
    for end in (0, 1):
        k1 = (first % 3 + end) % 3
        v = vertex[t1, k1]
        ends.append(np.column_stack([3 * t1 + k1, 3 * t2 + np.argmax(vertex[t2] == v[:, None], axis=1)]))
    links = np.vstack(ends)
    part = components(np.column_stack([t1, t2]), len(vertex))
    for _ in range(max_passes):
        pinched = _pinched(part, vertex, links)
        if not len(pinched):
            break
        size = int(vertex.max()) + 1  # (part, vertex) as one number, as _pinched numbers them
        at = np.isin(part.repeat(3) * size + vertex.ravel(), pinched)  # the corners there
        local = np.full(3 * len(vertex), -1)
        local[at] = np.arange(at.sum())
        mine = at[links[:, 0]] & at[links[:, 1]] & (part[links[:, 0] // 3] == part[links[:, 1] // 3])
        fan = components(local[links[mine]], int(at.sum()))  # the fans around those vertices
        corner = np.flatnonzero(at)
        group = part[corner // 3] * size + vertex.ravel()[corner]
        pairs = np.unique(np.column_stack([group, fan]), axis=0)
        extra = pairs[np.r_[False, pairs[1:, 0] == pairs[:-1, 0]], 1]  # a second (third…) fan at a vertex
        leaving = np.isin(fan, extra)
        moved = corner[leaving]
        changed = np.isin(part, part[moved // 3])  # the parts that lose a fan: split again below
        part[moved // 3] = -1 - fan[leaving]  # a fan's triangles together, apart from the rest of their part
        keep = changed[t1] & changed[t2] & ((part[t1] == part[t2]) | ((part[t1] >= 0) & (part[t2] >= 0)))
        sub = np.flatnonzero(changed)
        index = np.full(len(vertex), -1)
        index[sub] = np.arange(len(sub))
        part[sub] = sub[components(index[np.column_stack([t1[keep], t2[keep]])], len(sub))]
    return part


def _pinched(part: np.ndarray, vertex: np.ndarray, links: np.ndarray) -> np.ndarray:
    """The (part, vertex) keys where a part meets itself at a vertex. At a vertex, each open fan of triangles has
    one corner more than the links between them (a closed one as many; a TIN has no other): two or more open
    fans there are two parts touching, or one part pinched — only those vertices are counted per part."""
    count = int(vertex.max()) + 1
    joined = part[links[:, 0] // 3] == part[links[:, 1] // 3]
    fans = np.bincount(vertex.ravel(), minlength=count) - np.bincount(vertex.ravel()[links[joined, 0]],
                                                                        minlength=count)
    candidates = fans >= 2
    if not candidates.any():
        return np.zeros(0, dtype=np.int64)
    corner = np.flatnonzero(candidates[vertex.ravel()])
    key = part[corner // 3] * count + vertex.ravel()[corner]
    keys, corners = np.unique(key, return_counts=True)
    link = links[joined][candidates[vertex.ravel()[links[joined, 0]]], 0]
    link_keys, linked = np.unique(part[link // 3] * count + vertex.ravel()[link], return_counts=True)
    inner = np.zeros(len(keys), dtype=np.int64)
    inner[np.searchsorted(keys, link_keys)] = linked
    return keys[corners - inner >= 2]


def _tin_batch(batch: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(tri ids, (n, 3, 3) corners) of a batch of TIN features; refuses what is not a closed triangle."""
    ids = np.array([int(text[4:]) for text in tri_ids(batch[step_layers.TIN_TRIANGLE_ID])], dtype=np.int64)
    points, counts, rings = bulk_read.exterior_rings(batch["geometry"])
    bad = np.flatnonzero((rings != 1) | (counts != 4))
    if len(bad):
        raise InputError(f"TIN feature tri_id={ids[bad[0]]} is not a closed triangle: re-run wit:triangulateterrain.")
    return ids, points.reshape(-1, 4, 3)[:, :3]


class _TinTextures:
    """The TIN's texture coordinates held by triangle id: image (-1 none) and three (u, v) corners."""

    def __init__(self, texcoords: InputLayer, images: dict[str, int], tin: InputLayer):
        last = f'SELECT MAX("{step_layers.TIN_TRIANGLE_ID}") FROM {tin.table}'  # nosec B608  # quoted layer name
        size = int(tin.scalar(last) or 0) + 1
        self.image = np.full(size, -1, dtype=np.int32)
        self.uv = np.full((size, 3, 2), np.nan)
        targets = ", ".join(f"'{t}'" for t in ("tin", "road"))
        names = (step_layers.TEX_FEATURE, step_layers.TEX_IMAGE, step_layers.TEX_COORDS)
        with texcoords.select(f"\"{step_layers.TEX_TARGET}\" IN ({targets})", columns=", ".join(
                f'"{name}"' for name in names)) as result:
            for batch in bulk_read.batches(result, BULK):
                features, image_names, texts = (bulk_read.texts(batch[name]) for name in names)
                try:
                    ids = np.array(features, dtype=np.int64)
                except ValueError:
                    raise InputError(f"Texture table {texcoords.path} has a TIN row whose feature is not a triangle "
                                     "id: re-run wit:wittexture.") from None
                def triangle_of(i: int, f: list[str] = features) -> str:
                    return f"TIN triangle {f[i]} in {texcoords.path}"

                uv, _ = uv_values(texts, triangle_of, True)
                inside = (ids >= 0) & (ids < size)
                self.image[ids[inside]] = [images[name] for name, ok in zip(image_names, inside) if ok]
                self.uv[ids[inside]] = uv.reshape(-1, 4, 2)[inside, :3]

    def of(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Images (per triangle) and (u, v) (per corner) of the triangles ``ids``."""
        return self.image[ids].astype(np.int64), self.uv[ids].reshape(-1, 2)


class _Lookup:
    """Values of a key-sorted stream of (key, value), looked up with keys that only grow."""

    def __init__(self, rows: Iterator[tuple[str, object]]):
        self.rows, self.row = rows, next(rows, None)

    def of(self, key: str):
        while self.row is not None and self.row[0] < key:
            self.row = next(self.rows, None)
        return self.row[1] if self.row is not None and self.row[0] == key else None

