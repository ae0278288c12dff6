"""One tile's content as a glTF 2.0 binary (.glb), through pygltflib.

Primitives are indexed triangle lists (vertices shared within a primitive, float32 positions in the
tile's local frame). Photo-textured surfaces (roofs, terrain, roads) use ``KHR_materials_unlit`` so
they show the orthoimage's colours; walls are lit (flat normals), in a plain colour or with their generated
facade, whose image repeats along the wall (sampler REPEAT across, CLAMP up) and whose vertices carry
``_FACADE`` = 1 (an application attribute: a viewer can tell generated facades apart, e.g. to switch them
off, as the offline viewer does). Images are either
external files of the tileset, referenced by a relative URI and so shared by every tile that uses
them, or embedded (the coarse terrain's own image).

Building metadata follows the 3D Tiles 1.1 glTF extensions: each building primitive has a
``_FEATURE_ID_0`` vertex attribute (``EXT_mesh_features``) indexing the rows of one property table
(``EXT_structural_metadata``, class ``building``); a NULL is the property's ``noData`` value. Every
numeric property of the class is in every table (the official 3D Tiles validator rejects a table
without one); a text property that is empty in every row is left out (its values would be a buffer
view of 0 bytes, which glTF forbids) and reads as the class's ``default``, the empty string.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable
from typing import Any

import numpy as np
import pygltflib as gl

from ..infra.arrays import repeated_in_order
from ..infra.io import jsontext

UNLIT = "KHR_materials_unlit"
MESH_FEATURES = "EXT_mesh_features"
METADATA = "EXT_structural_metadata"
ALIGN = 8  # EXT_structural_metadata wants 8-byte aligned buffer views
LINEAR, LINEAR_MIPMAP_LINEAR, CLAMP, REPEAT = 9729, 9987, 33071, 10497
FACADE_ATTRIBUTE = "_FACADE"
_COMPONENT = {np.dtype(np.float32): gl.FLOAT, np.dtype(np.uint32): gl.UNSIGNED_INT,
              np.dtype(np.uint16): gl.UNSIGNED_SHORT}  # the last two for indices only
_TYPE = {1: gl.SCALAR, 2: gl.VEC2, 3: gl.VEC3}
_PROPERTY_DTYPE = {"INT32": np.int32, "INT64": np.int64, "FLOAT64": np.float64}


def unit_normals(corners: np.ndarray) -> np.ndarray:
    """Unit normals (t, 3) of triangles (t, 3, 3), counter-clockwise front; up (0, 1, 0) for a degenerate one."""
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(length > 0, n / np.where(length > 0, length, 1), [0.0, 1.0, 0.0])


def distinct_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What ``np.unique`` gives for the rows' bytes (``return_index``, ``return_inverse``): the first of each
    distinct row, ordered as their bytes compare, and each row's number among them (rows of two or more 4-byte
    numbers, as the vertex columns are).

    Sorted by their first 8 bytes as one integer (the bytes compared in the same order), which tells apart
    most vertices (x, y); only the rows sharing those bytes are sorted by all of theirs (a sort of 20-byte
    rows took a tenth of the export)."""
    n = len(rows)
    if not n:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    rows = np.ascontiguousarray(rows)
    raw = rows.view(np.uint8).reshape(n, -1)
    key = raw[:, :8].copy().view(">u8").ravel().astype(np.uint64)
    order = np.argsort(key, kind="stable")  # stable: the first of equal rows stays first
    words = rows.view(np.uint32).reshape(n, -1)
    repeated = repeated_in_order(words, order)
    clash = ~repeated & (key[order][1:] == key[order][:-1])  # different rows, same first bytes
    if np.count_nonzero(clash) > n // 16:  # (walls: a corner's x, y at its foot and at its top)
        return np.unique(raw.view(np.dtype((np.void, raw.shape[1]))).ravel(), return_index=True,
                         return_inverse=True)[1:]
    if clash.any():  # sort the runs of such rows by all their bytes (their first bytes keep their order)
        run = np.cumsum(np.append(True, ~(repeated | clash)))
        tied = np.flatnonzero(np.isin(run, run[1:][clash]))
        rows_tied = np.ascontiguousarray(raw[order[tied]]).view(np.dtype((np.void, raw.shape[1]))).ravel()
        order[tied] = order[tied][np.argsort(rows_tied, kind="stable")]
        repeated = repeated_in_order(words, order)
    first = np.append(True, ~repeated)
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = np.cumsum(first) - 1
    return order[first], inverse


class GlbBuilder:
    """Accumulates primitives, materials, images and a property table; ``to_bytes`` gives the .glb."""

    def __init__(self) -> None:
        self.gltf = gl.GLTF2(asset=gl.Asset(version="2.0", generator="WIT City Model"))
        self.blob = bytearray()
        self.primitives: list[gl.Primitive] = []
        self._textures: dict[str, int] = {}
        self._samplers: dict[tuple[int, int], int] = {}
        self._extensions: set[str] = set()

    # --- buffers -----------------------------------------------------------------------------

    def _view(self, data: bytes, target: int | None = None) -> int:
        self.blob.extend(b"\0" * (-len(self.blob) % ALIGN))
        self.gltf.bufferViews.append(gl.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data),
                                                   target=target))
        self.blob.extend(data)
        return len(self.gltf.bufferViews) - 1

    def _accessor(self, array: np.ndarray, target: int, bounds: bool = False) -> int:
        array = np.ascontiguousarray(array)
        width = 1 if array.ndim == 1 else array.shape[1]
        accessor = gl.Accessor(bufferView=self._view(array.tobytes(), target), componentType=_COMPONENT[array.dtype],
                               count=len(array), type=_TYPE[width])
        if bounds:
            flat = array.reshape(len(array), width)
            accessor.min, accessor.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        self.gltf.accessors.append(accessor)
        return len(self.gltf.accessors) - 1

    # --- materials ---------------------------------------------------------------------------

    def _texture(self, key: str, uri: str | None = None, data: bytes | None = None, mime: str = "image/jpeg",
                 wrap_s: int = CLAMP) -> int:
        if key not in self._textures:
            if (wrap_s, CLAMP) not in self._samplers:
                self._samplers[wrap_s, CLAMP] = len(self.gltf.samplers)
                self.gltf.samplers.append(gl.Sampler(magFilter=LINEAR, minFilter=LINEAR_MIPMAP_LINEAR,
                                                     wrapS=wrap_s, wrapT=CLAMP))
            if uri:
                image = gl.Image(uri=uri)
            elif data is not None:
                image = gl.Image(bufferView=self._view(data), mimeType=mime)
            else:
                raise ValueError(f"The texture {key} has neither a URI nor its bytes.")
            self.gltf.images.append(image)
            self.gltf.textures.append(gl.Texture(sampler=self._samplers[wrap_s, CLAMP],
                                                 source=len(self.gltf.images) - 1))
            self._textures[key] = len(self.gltf.textures) - 1
        return self._textures[key]

    def photo_material(self, uri: str | None = None, data: bytes | None = None, name: str = "") -> int:
        """Unlit material showing an image (an external ``uri`` or embedded JPEG ``data``)."""
        texture = self._texture(uri or f"embedded:{name}", uri, data)
        pbr = gl.PbrMetallicRoughness(baseColorTexture=gl.TextureInfo(index=texture), metallicFactor=0.0,
                                      roughnessFactor=1.0)
        return self._material(gl.Material(name=name, pbrMetallicRoughness=pbr, extensions={UNLIT: {}}))

    def facade_material(self, uri: str, name: str = "") -> int:
        """Lit, double-sided material showing a generated facade image that repeats along the wall."""
        texture = self._texture(uri, uri, wrap_s=REPEAT)
        pbr = gl.PbrMetallicRoughness(baseColorTexture=gl.TextureInfo(index=texture), metallicFactor=0.0,
                                      roughnessFactor=1.0)
        return self._material(gl.Material(name=name, pbrMetallicRoughness=pbr, doubleSided=True))

    def plain_material(self, rgb: tuple[int, int, int], lit: bool, name: str = "") -> int:
        pbr = gl.PbrMetallicRoughness(baseColorFactor=[c / 255 for c in rgb] + [1.0], metallicFactor=0.0,
                                      roughnessFactor=1.0)
        return self._material(gl.Material(name=name, pbrMetallicRoughness=pbr, doubleSided=lit,
                                          extensions={} if lit else {UNLIT: {}}))

    def _material(self, material: gl.Material) -> int:
        self._extensions.update(material.extensions)
        self.gltf.materials.append(material)
        return len(self.gltf.materials) - 1

    # --- geometry ----------------------------------------------------------------------------

    def triangles(self, corners: np.ndarray, material: int, uv: np.ndarray | None = None,
                  feature: np.ndarray | None = None, normals: bool | np.ndarray = False, facade: bool = False) -> None:
        """Add triangles (t, 3, 3 local glTF coordinates, float64) as one indexed primitive.

        ``uv`` (t, 3, 2) in glTF's convention (v down from the image's top), ``feature`` (t,) the
        property-table row of each triangle, ``normals`` flat normals: True to compute them per triangle, or
        given (t, 3) (the same for the triangles of a planar face, so that the face's corners are shared),
        ``facade`` marks the vertices of a generated facade (``FACADE_ATTRIBUTE``).
        """
        if len(corners) == 0:
            return
        t = len(corners)
        columns = [corners.reshape(-1, 3).astype(np.float32)]
        lit = normals is not False
        if lit:
            n = unit_normals(corners) if normals is True else np.asarray(normals)
            columns.append(np.repeat(n, 3, axis=0).astype(np.float32))
        if uv is not None:
            columns.append(uv.reshape(-1, 2).astype(np.float32))
        if feature is not None:
            columns.append(np.repeat(feature, 3).astype(np.float32)[:, None])
        if facade:
            columns.append(np.ones((3 * t, 1), dtype=np.float32))
        rows = np.concatenate(columns, axis=1)
        unique, index = distinct_rows(rows)
        vertices = rows[unique]
        attributes = gl.Attributes(POSITION=self._accessor(vertices[:, :3], gl.ARRAY_BUFFER, bounds=True))
        column = 3
        if lit:
            attributes.NORMAL = self._accessor(vertices[:, 3:6], gl.ARRAY_BUFFER)
            column = 6
        if uv is not None:
            attributes.TEXCOORD_0 = self._accessor(vertices[:, column:column + 2], gl.ARRAY_BUFFER)
            column += 2
        primitive = gl.Primitive(attributes=attributes, material=material, mode=gl.TRIANGLES,
                                 indices=self._accessor(index.astype(np.uint16 if len(vertices) < 65536 else np.uint32)
                                                        .reshape(t * 3), gl.ELEMENT_ARRAY_BUFFER))
        if feature is not None:
            # float: a 1- or 2-byte vertex attribute would need padding to 4 bytes per vertex anyway
            attributes._FEATURE_ID_0 = self._accessor(vertices[:, column], gl.ARRAY_BUFFER)
            column += 1
            primitive.extensions = {MESH_FEATURES: {"featureIds": [
                {"featureCount": int(feature.max()) + 1, "attribute": 0, "propertyTable": 0}]}}
            self._extensions.add(MESH_FEATURES)
        if facade:
            setattr(attributes, FACADE_ATTRIBUTE, self._accessor(vertices[:, column], gl.ARRAY_BUFFER))
        self.primitives.append(primitive)

    # --- metadata ----------------------------------------------------------------------------

    def property_table(self, schema: dict, class_name: str, columns: dict[str, list]) -> None:
        """The property table of ``class_name`` (rows = feature ids) with the ``columns`` given."""
        properties = schema["classes"][class_name]["properties"]
        count = len(next(iter(columns.values()))) if columns else 0
        table: dict = {"class": class_name, "count": count, "properties": {}}
        for name, values in columns.items():
            spec = properties[name]
            if spec["type"] == "STRING" and all(v is None or v == "" for v in values):
                continue  # no empty buffer view: the class gives the text's ``default`` (``metadata``)
            if spec["type"] == "STRING":
                encoded = [(v if v is not None else "").encode("utf-8") for v in values]
                offsets = np.concatenate([[0], np.cumsum([len(e) for e in encoded])]).astype(np.uint32)
                table["properties"][name] = {"values": self._view(b"".join(encoded)),
                                             "stringOffsets": self._view(offsets.tobytes()),
                                             "stringOffsetType": "UINT32"}
            else:
                fill = spec["noData"]
                array = np.array([fill if v is None else v for v in values],
                                 dtype=_PROPERTY_DTYPE[spec["componentType"]])
                table["properties"][name] = {"values": self._view(array.tobytes())}
        self.gltf.extensions[METADATA] = {"schema": schema, "propertyTables": [table]}
        self._extensions.add(METADATA)

    def to_bytes(self) -> bytes:
        self.gltf.meshes = [gl.Mesh(primitives=self.primitives)]
        self.gltf.nodes = [gl.Node(mesh=0)]
        self.gltf.scenes = [gl.Scene(nodes=[0])]
        self.gltf.scene = 0
        self.gltf.extensionsUsed = sorted(self._extensions)
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        self.gltf.buffers = [gl.Buffer(byteLength=len(self.blob))]
        return glb_bytes(self.gltf, bytes(self.blob))


def glb_bytes(gltf: gl.GLTF2, blob: bytes) -> bytes:
    """The GLB container of ``gltf`` and its binary chunk ``blob``: the JSON compact and UTF-8, without empty
    properties nor the accessors' and buffer views' defaults (``byteOffset`` 0, ``normalized`` false), which a tile
    with a primitive per facade image would repeat a few hundred times. Built from the objects' fields directly:
    pygltflib's own ``to_json`` deep-copies every value, which took a tenth of the export."""
    text = jsontext.dumps(_plain(gltf), separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    return b"".join([struct.pack("<4sII", b"glTF", 2, 28 + len(text) + len(blob)),
                     struct.pack("<I4s", len(text), b"JSON"), text, struct.pack("<I4s", len(blob), b"BIN\0"), blob])


def _plain(value: object) -> object:
    """A pygltflib object as JSON values, None and empty values left out as pygltflib leaves them out (an
    ``extensions`` object is written as it is: ``KHR_materials_unlit: {}``, a metadata ``noData: ""``), the
    accessors' and buffer views' defaults dropped."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    items: Iterable[tuple[str, Any]]
    if isinstance(value, dict):
        items = value.items()
    elif hasattr(value, "__dict__"):
        items = vars(value).items()
        if isinstance(value, (gl.Accessor, gl.BufferView)):
            items = [(k, v) for k, v in items if not (k == "byteOffset" and v == 0) and not (k == "normalized"
                                                                                              and v is False)]
    else:
        return value
    out = {}
    for key, item in items:
        if item is None or (hasattr(item, "__len__") and len(item) == 0) \
                or (key.startswith("_") and not isinstance(value, gl.Attributes)):
            continue
        out[key] = item if key == "extensions" else _plain(item)
    return out
